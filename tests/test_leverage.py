"""The leverage test (poseonly.robust.default.leverage_test, the core's leverage_veto): inliers whose own
residual the fit absorbs are judged by the fit of the others, and the translation's deviation carries
the distance between the two fits (a SLAM user's trial: short baselines, `ok` translations 5 deg off
with deviations of 0.04 deg)."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

from poseonly import _core
from poseonly.sim import make_scene

c = np.ascontiguousarray


def _reference_leverage(R, t, f1, f2, inl):
    """h_i = J_i (J^T J)^-1 J_i^T of the inliers' Sampson errors in the pose's five parameters (numpy)."""
    _, J = _core._refine_residuals(0, c(R), c(t / np.linalg.norm(t)), c(f1[inl]), c(f2[inl]), np.zeros(5), None)
    J = np.asarray(J).reshape(-1, 5)
    h = np.zeros(len(f1))
    h[inl] = np.einsum("ij,jk,ik->i", J, np.linalg.inv(J.T @ J), J)
    return h


def test_leverages_are_the_hat_matrix_diagonal():
    sc = make_scene(120, camera="pinhole", noise_px=0.5, outlier_fraction=0.2, seed=4)
    inl = np.asarray(sc.inliers, bool).copy()
    lev, veto, group, tested, Ro, to = _core.leverage_veto(c(sc.R), c(sc.t), c(sc.f1), c(sc.f2), inl, 1e-3, 0.5)
    assert np.allclose(lev, _reference_leverage(sc.R, sc.t, sc.f1, sc.f2, inl), rtol=1e-9, atol=1e-12)
    assert abs(lev.sum() - 5.0) < 1e-9  # the trace of a rank-5 projection
    assert not tested and not veto.any() and not group.any()  # no inlier above 1/2: nothing to test
    assert np.all(np.isnan(Ro)) and np.all(np.isnan(to))


def test_matches_of_leverage_one_are_peeled_and_vetoed_when_the_others_disagree():
    """Two matches of large parallax on the epipolar lines of a translation 8 deg off hold a short baseline's
    direction: both have leverage ~1, their own residuals are ~0, and the others' fit rejects them."""
    rng = np.random.default_rng(0)
    sc = make_scene(200, camera="pinhole", noise_px=0.3, outlier_fraction=0.0, seed=5)
    f1, f2, R, t = sc.f1, sc.f2, sc.R, sc.t
    axis = np.cross(t, [0.0, 0.0, 1.0])
    tw = t * np.cos(np.radians(8)) + np.cross(axis / np.linalg.norm(axis), t) * np.sin(np.radians(8))
    Y = np.column_stack([rng.uniform(-1, 1, 2), rng.uniform(-1, 1, 2), [2.0, 2.5]])
    Y2 = Y @ R.T + 6.0 * tw  # far along the wrong direction: large parallax, exactly on its epipolar lines
    g1 = np.vstack([f1, Y / np.linalg.norm(Y, axis=1)[:, None]])
    g2 = np.vstack([f2, Y2 / np.linalg.norm(Y2, axis=1)[:, None]])
    # the least-squares pose of all 202 matches, from the truth: pulled towards tw by the two
    Rl, tl, _ = _core.refine_sampson(c(R), c(t), c(g1), c(g2), None, loss="linear", max_iterations=100, tol=1e-14)
    inl = np.ones(len(g1), bool)
    lev, veto, group, tested, Ro, to = _core.leverage_veto(c(Rl), c(tl), c(g1), c(g2), inl, 3 * 0.3 / 800, 0.5)
    assert tested and lev[-2:].min() > 0.5 and np.flatnonzero(group).tolist() == [200, 201]
    assert np.flatnonzero(veto).tolist() == [200, 201]
    assert np.degrees(np.arccos(abs(to @ t))) < 0.5 * np.degrees(np.arccos(abs(tl @ t)))  # the others' fit is nearer the truth


def _short_baseline_scenes(n: int):
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
    from leverage_study import PARAMS, H, W, scene

    from poseonly.cameras import Camera

    cam = Camera("OPENCV", W, H, PARAMS)
    rng = np.random.default_rng(11)
    return cam, [scene(rng, cam, 0.05) for _ in range(n)]


@pytest.mark.parametrize("max_leverage, most_beyond", [(1.0, None), (0.5, 1)])
def test_short_baselines_translation_deviation_is_honest(max_leverage, most_beyond):
    """The trial's scenes (benchmarks/leverage_study.py, baseline 0.05): without the test many `ok`
    translations lie beyond three of their deviations; with it at most one of the first ten scenes'."""
    import poseonly

    cam, scenes = _short_baseline_scenes(10)
    beyond = 0
    for u1, u2, R, t in scenes:
        r = poseonly.estimate_relative_pose(u1, u2, camera1=cam, max_leverage=max_leverage)
        if r.status == "ok":
            et = np.degrees(np.arccos(np.clip(r.t @ t, -1.0, 1.0)))
            beyond += et > 3 * r.diagnostics["translation_std_deg"]
    if most_beyond is None:
        assert beyond >= 3, beyond  # the failure the test is for
    else:
        assert beyond <= most_beyond, beyond


def test_a_bound_on_the_translation_deviation_makes_a_loose_direction_uncertain():
    """``max_translation_std_deg`` (default inf: the status reads the rotation alone) lets a pipeline that
    needs the direction call a short baseline's pose `uncertain`."""
    import poseonly

    cam, scenes = _short_baseline_scenes(3)
    u1, u2, _, _ = scenes[0]
    r = poseonly.estimate_relative_pose(u1, u2, camera1=cam)
    sd = r.diagnostics["translation_std_deg"]
    assert r.status == "ok" and 0.1 < sd < np.inf
    loose = poseonly.estimate_relative_pose(u1, u2, camera1=cam, max_translation_std_deg=sd / 2)
    assert loose.status == "uncertain" and "translation direction only to" in loose.message
    assert np.array_equal(loose.R, r.R) and loose.diagnostics["translation_std_deg"] == sd
    assert poseonly.estimate_relative_pose(u1, u2, camera1=cam, max_translation_std_deg=2 * sd).status == "ok"


def test_no_valid_pose_is_not_tested():
    """A search that scored no hypothesis leaves a placeholder R (here diag(0, 0, 1)) for the status to call
    degenerate: the leverage test leaves it alone (the fuzz: 18 of 3000 cases raised the core's "R must be a
    rotation matrix")."""
    from poseonly.robust.default import leverage_test

    sc = make_scene(60, camera="pinhole", noise_px=0.5, seed=2)
    m = {"decision_gauss": 1e-3, "nu": 30.0, "alpha": 0.0}
    diag: dict = {}
    assert leverage_test(np.diag([0.0, 0.0, 1.0]), np.array([0.0, 0.0, -1.0]), sc.f1, sc.f2, m, 0.01, True, None, 0.5, diag) is None
    assert diag == {}


def test_the_vetoed_matches_leave_the_ml_pose():
    """Scene 1 of the trial's short-baseline scenes: two wrong matches of high leverage are vetoed and the
    ML pose refitted without them and without the matches the cross-fit removed (translation 4.67 -> 1.41
    deg, rotation 0.045 -> 0.025 deg off; 3.37 deg when the refit saw the cross-fit's removed matches
    again); the translation then lies within three of its deviations, where it lay beyond them."""
    import poseonly
    from poseonly.geometry import rotation_error_deg

    cam, scenes = _short_baseline_scenes(2)
    u1, u2, R, t = scenes[1]
    off = poseonly.estimate_relative_pose(u1, u2, camera1=cam, max_leverage=1.0)
    on = poseonly.estimate_relative_pose(u1, u2, camera1=cam)
    d = on.diagnostics
    assert d["leverage_vetoed"] == 2 and "leverage_vetoed" not in off.diagnostics

    def t_err(r):
        return np.degrees(np.arccos(np.clip(r.t @ t, -1.0, 1.0)))

    assert t_err(on) < t_err(off) - 1.0 and rotation_error_deg(R, on.R) < rotation_error_deg(R, off.R)
    assert t_err(on) < 2.0 and t_err(on) < 3 * d["translation_std_deg"]
    assert t_err(off) > 3 * off.diagnostics["translation_std_deg"]
