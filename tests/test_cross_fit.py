"""The ML stage's cross-fitted inliers (``PoseonlyOptions.ml_folds``, robust/default.py ``_cross_fit``)."""

from __future__ import annotations

import numpy as np
import pytest

from poseonly import estimate_relative_pose, sim_hard
from poseonly.geometry import InputError, rotation_error_deg

SEEDS = range(12)


def _errors(**opts) -> np.ndarray:
    out = []
    for s in SEEDS:
        c = sim_hard.low_parallax(parallax_deg=0.75, seed=s)
        r = estimate_relative_pose(c.u1, c.u2, c.K, c.K, seed=s, **opts)
        out.append(rotation_error_deg(c.R, r.R))
    return np.array(out)


def test_cross_fit_beats_self_decided_inliers_at_low_parallax():
    # the ML pose deciding its own inliers picks up outliers near its epipolar lines (seeded: the
    # geometric-mean error over these 12 scenes drops by ~30 % with the cross-fit)
    with_cf, without = _errors(), _errors(ml_folds=0)
    assert np.all(np.isfinite(with_cf))
    assert np.exp(np.mean(np.log(with_cf / without))) < 0.85


def test_one_fold_is_off_and_the_diagnostic_says_so():
    c = sim_hard.low_parallax(parallax_deg=0.75, seed=3)
    a = estimate_relative_pose(c.u1, c.u2, c.K, c.K, seed=3, ml_folds=0)
    b = estimate_relative_pose(c.u1, c.u2, c.K, c.K, seed=3, ml_folds=1)
    d = estimate_relative_pose(c.u1, c.u2, c.K, c.K, seed=3)
    np.testing.assert_array_equal(a.R, b.R)
    assert "cross_fit" not in a.diagnostics
    assert isinstance(d.diagnostics["cross_fit"], bool)


@pytest.mark.parametrize("bad", [-1, 17, 2.5, "3"])
def test_bad_fold_count_is_an_error(bad):
    c = sim_hard.low_parallax(parallax_deg=0.75, seed=0)
    with pytest.raises(InputError):
        estimate_relative_pose(c.u1, c.u2, c.K, c.K, ml_folds=bad)


def _ml_pose(seed: int):
    """A low-parallax hard case's bearings, the search's pose and its ML stage (pose and mixture)."""
    from poseonly.geometry import bearings_from_pixels
    from poseonly.options import PoseonlyOptions
    from poseonly.robust import default

    c = sim_hard.low_parallax(parallax_deg=0.75, seed=seed)
    f1, f2 = bearings_from_pixels(c.u1, c.K), bearings_from_pixels(c.u2, c.K)
    r = estimate_relative_pose(c.u1, c.u2, c.K, c.K, seed=seed, ml_folds=0)
    tau = float(r.diagnostics["tau_effective"])
    T = float(PoseonlyOptions().ml_range) * tau
    best = default._ml_stage(r.R, r.t, f1, f2, tau, T)
    assert best is not None
    return f1, f2, T, best


def test_the_veto_removes_only_the_ml_poses_own_inliers():
    from poseonly.robust import default

    f1, f2, T, (R, t, m) = _ml_pose(3)
    tails = (float(m["nu"]), float(m["alpha"]))
    # a decision no error reaches: every held-out pose keeps every match, nothing is vetoed and the
    # ML pose comes back untouched (no EM on a set that did not change)
    out = default._cross_fit(R, t, f1, f2, T, 1e3 * float(m["decision_gauss"]), True, None, 5, tails)
    assert out is not None
    np.testing.assert_array_equal(out[0], R)
    np.testing.assert_array_equal(out[1], t)
    assert out[2] == 0
    # the mixture's own decision: this seeded scene is one where the ML pose holds outliers the
    # held-out poses reject; they are removed, at most all of the ML pose's inliers, and the pose moves
    out = default._cross_fit(R, t, f1, f2, T, float(m["decision_gauss"]), True, None, 5, tails)
    assert out is not None
    own = int(np.count_nonzero(default.v_sampson(R, t, f1, f2) < float(m["decision_gauss"])))
    assert 1 <= out[2] < own
    assert rotation_error_deg(R, out[0]) > 1e-6


def test_the_vetoed_count_is_reported():
    c = sim_hard.low_parallax(parallax_deg=0.75, seed=3)
    d = estimate_relative_pose(c.u1, c.u2, c.K, c.K, seed=3).diagnostics
    assert d["cross_fit"] is True
    assert isinstance(d["cross_fit_vetoed"], int) and d["cross_fit_vetoed"] >= 1


# --- the folds' poses by Gauss-Newton from the ML fit (ml_fold_fit="newton", _core.ml_fold_poses) ---


def _fit(seed: int, noise_px: float = 0.5, outliers: float = 0.3, n: int = 300):
    from poseonly import _core, sim

    sc = sim.make_scene(n, camera="pinhole", noise_px=noise_px, outlier_fraction=outliers, seed=seed)
    T = 3.0 / sim.FOCAL
    m = _core.ml_refine(sc.R, sc.t, sc.f1, sc.f2, T, rounds=50, pose_tol=1e-9, student=True)
    return sc, T, m


@pytest.mark.parametrize("steps", [1, 2])
def test_fold_poses_match_the_numpy_reference(steps):
    from poseonly import _core
    from reference.fold_poses import fold_poses, ml_weights

    sc, _, m = _fit(1)
    Rc, tc = _core.ml_fold_poses(m["R"], m["t"], sc.f1, sc.f2, m["posterior"], m["sigma"], m["nu"], m["alpha"], None, 5, steps)
    Rr, tr = fold_poses(m["R"], m["t"], sc.f1, sc.f2, ml_weights(m, sc.f1, sc.f2), 5, steps)
    for j in range(5):
        assert rotation_error_deg(Rr[j], Rc[j]) < 1e-7
        np.testing.assert_allclose(tc[j], tr[j], atol=1e-9)
        # the folds move: the test compares steps, not the start
        assert rotation_error_deg(m["R"], Rc[j]) > 1e-4


def test_fold_poses_are_exact_on_noise_free_data():
    from poseonly import _core

    sc, _, m = _fit(2, noise_px=0.0, outliers=0.0)
    Rc, tc = _core.ml_fold_poses(sc.R, sc.t, sc.f1, sc.f2, np.ones(len(sc.f1)), 1e-4, np.inf, 0.0, None, 5, 1)
    for j in range(5):
        assert rotation_error_deg(sc.R, Rc[j]) < 1e-9
        np.testing.assert_allclose(tc[j], sc.t / np.linalg.norm(sc.t), atol=1e-12)


def test_fold_poses_approximate_the_folds_em():
    # two Gauss-Newton steps land far closer to each fold's EM than the fit on all matches does
    from poseonly import _core

    for seed in range(3):
        sc, T, m = _fit(seed)
        Rc, _ = _core.ml_fold_poses(m["R"], m["t"], sc.f1, sc.f2, m["posterior"], m["sigma"], m["nu"], m["alpha"], None, 5, 2)
        fold = np.arange(len(sc.f1)) % 5
        for j in range(5):
            tr = fold != j
            e = _core.ml_refine(
                m["R"],
                m["t"],
                np.ascontiguousarray(sc.f1[tr]),
                np.ascontiguousarray(sc.f2[tr]),
                T,
                rounds=50,
                pose_tol=1e-9,
                student=True,
                nu=m["nu"],
                alpha=m["alpha"],
                pose_only=True,
                sigma_init=m["sigma"],
                g_init=m["inlier_fraction"],
            )
            assert rotation_error_deg(e["R"], Rc[j]) < 0.5 * rotation_error_deg(e["R"], m["R"])


def test_fold_poses_bad_input_is_an_error():
    from poseonly import _core

    sc, _, m = _fit(0)
    args = (m["R"], m["t"], sc.f1, sc.f2, m["posterior"], m["sigma"], m["nu"], m["alpha"])
    with pytest.raises(ValueError, match="folds"):
        _core.ml_fold_poses(*args, None, 1, 1)
    with pytest.raises(ValueError, match="steps"):
        _core.ml_fold_poses(*args, None, 5, 0)
    with pytest.raises(ValueError, match="posterior"):
        _core.ml_fold_poses(m["R"], m["t"], sc.f1, sc.f2, m["posterior"][:-1], m["sigma"], m["nu"], m["alpha"])
    with pytest.raises(ValueError, match="sigma"):
        _core.ml_fold_poses(m["R"], m["t"], sc.f1, sc.f2, m["posterior"], 0.0, m["nu"], m["alpha"])


def test_fold_poses_singular_fold_is_nan():
    # every weight of four folds zero: the other folds' normal matrix of fold 0 is singular
    from poseonly import _core

    sc, _, m = _fit(0)
    w = np.zeros(len(sc.f1))
    w[np.arange(len(w)) % 5 == 0] = 1.0
    Rc, tc = _core.ml_fold_poses(sc.R, sc.t, sc.f1, sc.f2, w, 1e-3, np.inf, 0.0, None, 5, 1)
    assert np.all(np.isnan(Rc[0])) and np.all(np.isnan(tc[0]))
    assert np.all(np.isfinite(Rc[1]))


def test_newton_folds_run_in_the_default():
    c = sim_hard.low_parallax(parallax_deg=0.75, seed=3)
    a = estimate_relative_pose(c.u1, c.u2, c.K, c.K, seed=3, ml_fold_fit="newton")
    b = estimate_relative_pose(c.u1, c.u2, c.K, c.K, seed=3, ml_fold_fit="em")
    assert isinstance(a.diagnostics["cross_fit"], bool)
    assert rotation_error_deg(a.R, b.R) < 0.2
    with pytest.raises(InputError):
        estimate_relative_pose(c.u1, c.u2, c.K, c.K, ml_fold_fit="lm")
