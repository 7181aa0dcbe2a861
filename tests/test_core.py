"""The compiled core against the numpy references (tests/reference), and the generic robust loop."""

from __future__ import annotations

import threading

import numpy as np
import pytest

from poseonly import _core, sim
from poseonly.estimator import get_estimator
from poseonly.geometry import rotation_error_deg
from poseonly.residuals import RESIDUALS
from poseonly.robust.gnc import GNCOptions, gnc_irls_batch
from poseonly.solvers.lirp import lirp, lirp_batch
from reference import gnc as ref_gnc
from reference import lirp as ref_lirp
from reference import residuals as ref_res

REF = {
    "sampson": ref_res.v_sampson,
    "sampson-chiral": ref_res.v_sampson_chiral,
    "ligt": ref_res.v_LiGT,
    "coplanar": ref_res.v_E,
    "ppo": ref_res.v_PPO,
    "ba": ref_res.v_BA,
    "opengv": ref_res.v_OpenGV,
    "opengv-symmetric": lambda R, t, f1, f2: ref_res.v_OpenGV(R, t, f1, f2, symmetric=True),
}


def _rot(rng):
    from scipy.spatial.transform import Rotation

    return Rotation.from_rotvec(rng.normal(0, 0.4, 3)).as_matrix()


@pytest.mark.parametrize("name", sorted(REF))
def test_residuals_match_reference(name):
    rng = np.random.default_rng(1)
    s = sim.make_scene(200, noise_px=2.0, outlier_fraction=0.3, seed=4)
    R = np.stack([s.R] + [_rot(rng) for _ in range(4)])
    t = np.stack([s.t] + [rng.normal(size=3) for _ in range(4)])
    t = t / np.linalg.norm(t, axis=1, keepdims=True)
    core = RESIDUALS[name](R, t, s.f1, s.f2)
    ref = REF[name](R, t, s.f1, s.f2)
    assert core.shape == (5, 200)
    np.testing.assert_allclose(core, ref, rtol=1e-9, atol=1e-12)


@pytest.mark.parametrize("kind,camera", [("normal", "wide"), ("normal", "pinhole"), ("rotation", "wide"), ("planar", "pinhole")])
def test_lirp_exact_on_noise_free_data(kind, camera):
    for seed in range(20):
        s = sim.make_scene(30, kind=kind, camera=camera, seed=seed)
        o = lirp_batch(s.f1[None], s.f2[None])
        errs = rotation_error_deg(s.R, o["cand_R"][0])
        assert errs.min() < 1e-6  # one candidate is exact
        if kind != "planar":  # planar: the homography twin is exact too and PPO cannot break the tie
            assert errs[o["best"][0]] < 1e-6


def test_lirp_matches_reference_on_noisy_data():
    for seed in range(20):
        s = sim.make_scene(40, noise_px=1.0, seed=seed, camera="wide" if seed % 2 else "pinhole")
        w = np.random.default_rng(seed).uniform(0.2, 1.0, 40)
        c = lirp_batch(s.f1[None], s.f2[None], w[None])
        r = ref_lirp.lirp_batch(s.f1[None], s.f2[None], w[None])
        np.testing.assert_allclose(c["singular_values"], r["singular_values"], rtol=1e-9, atol=1e-13)
        assert rotation_error_deg(c["R"][0], r["R"][0]) < 1e-7
        np.testing.assert_allclose(c["t"][0], r["t"][0], atol=1e-9)
        # the same 18 candidates (eigenvalue order within an action matrix is the solver's choice)
        np.testing.assert_allclose(np.sort(c["cand_cost"][0]), np.sort(r["cand_cost"][0]), rtol=1e-9, atol=1e-12)
        assert c["cand_valid"][0].sum() == r["cand_valid"][0].sum()


def test_lirp_best_only_scoring_picks_the_same_candidate():
    """``all_costs=False`` stops a candidate once it cannot win (an exact bail-out): the same best
    candidate, pose and cost as scoring all 18, bit for bit; stopped candidates keep ``inf``."""
    stopped = 0
    for seed in range(40):
        n = 6 + 7 * (seed % 9)
        s = sim.make_scene(n, noise_px=[0.0, 0.5, 3.0][seed % 3], seed=seed, camera="wide" if seed % 2 else "pinhole", outlier_fraction=0.3 if seed % 4 == 0 else 0.0)
        w = None if seed % 5 else np.random.default_rng(seed).uniform(0.0, 1.0, (1, n))
        full = lirp_batch(s.f1[None], s.f2[None], w, all_costs=True)
        fast = lirp_batch(s.f1[None], s.f2[None], w, all_costs=False)
        b = int(full["best"][0])
        assert int(fast["best"][0]) == b
        assert np.array_equal(fast["R"], full["R"]) and np.array_equal(fast["t"], full["t"])
        assert fast["cand_cost"][0, b] == full["cand_cost"][0, b]
        assert np.array_equal(fast["cand_valid"], full["cand_valid"])
        scored = np.isfinite(fast["cand_cost"][0])
        # a scored candidate's cost is exact; a valid one that was stopped costs more than the best
        np.testing.assert_array_equal(fast["cand_cost"][0, scored], full["cand_cost"][0, scored])
        gone = full["cand_valid"][0] & ~scored
        assert np.all(full["cand_cost"][0, gone] > full["cand_cost"][0, b])
        stopped += int(gone.sum())
    assert stopped > 100  # the bail-out does fire


@pytest.mark.parametrize("weights", ["1e100", "mixed", "1e308", "5e-324"])
def test_lirp_extreme_weights(weights):
    """The numba SVD returned R = I (24 deg off) with status ok for 1e100 weights; the core rescales.
    Uniform 1e308 (the singular values overflowed) and 5e-324 (the reciprocal of the largest weight
    did) gave status degenerate with a pose 24-33 deg off until the public call divided the weights by
    their maximum."""
    s = sim.make_scene(30, seed=3)
    extreme = {"1e100": np.full(30, 1e100), "1e308": np.full(30, 1e308), "5e-324": np.full(30, 5e-324)}
    w = extreme[weights] if weights in extreme else np.where(np.arange(30) % 3, 1e150, 1e-150)
    r = lirp(s.f1, s.f2, w)
    assert r.ok
    assert rotation_error_deg(s.R, r.R) < 1e-6
    ref = ref_lirp.lirp(s.f1, s.f2, w / w.max())
    assert rotation_error_deg(ref.R, r.R) < 1e-6


@pytest.mark.parametrize(
    "residual,all_cand,scale", [("ligt", False, "median"), ("ligt", False, "mad"), ("sampson-chiral", True, None), ("ppo", False, "median"), ("ba", False, "median")]
)
def test_gnc_matches_reference_loop(residual, all_cand, scale):
    s = sim.make_scene(60, noise_px=1.0, outlier_fraction=0.3, seed=7)
    opts = GNCOptions(noise_bound=2.0 / 800 if scale is None else None, scale=scale or "median", max_iterations=40, mu0=1e3 if scale is None else None)
    est = get_estimator("lirp-all" if all_cand else "lirp", residual)
    g = gnc_irls_batch(s.f1[None], s.f2[None], est, opts, detect_cycles=False)
    R, t, w, v, c, it, conv = ref_gnc.gnc_irls(s.f1, s.f2, opts, residual, all_cand)
    assert int(g.num_iterations[0]) == it and bool(g.converged[0]) == conv
    assert rotation_error_deg(g.R[0], R) < 1e-7
    np.testing.assert_allclose(g.weights[0], w, atol=1e-7)
    np.testing.assert_allclose(g.c[0], c, rtol=1e-7)


def test_gnc_cycle_exit_is_exact():
    rng = np.random.default_rng(0)
    est = get_estimator("lirp", "ligt")
    for seed in range(15):
        s = sim.make_scene(300, noise_px=1.0, outlier_fraction=0.5, seed=seed)
        idx = np.stack([rng.choice(300, 30, replace=False) for _ in range(8)])
        a = gnc_irls_batch(s.f1[idx], s.f2[idx], est, GNCOptions(), detect_cycles=False)
        b = gnc_irls_batch(s.f1[idx], s.f2[idx], est, GNCOptions())
        for field in ("R", "t", "weights", "residuals", "c", "num_iterations", "converged"):
            np.testing.assert_array_equal(getattr(a, field), getattr(b, field))


def test_generic_loop_on_a_line_estimator():
    """The loop of src/core/ransac.h is generic: a 2-D line estimator runs through it unchanged."""
    rng = np.random.default_rng(5)
    n_in, n_out = 120, 280
    x = rng.uniform(-1, 1, n_in)
    inl = np.c_[x, 0.3 * x + 0.1 + rng.normal(0, 0.002, n_in)]
    pts = np.ascontiguousarray(np.r_[inl, rng.uniform(-1, 1, (n_out, 2))])
    (a, b, c), st = _core.ransac_line(pts, 0.01, 3)
    # the line 0.3 x - y + 0.1 = 0, normalised and sign-fixed
    ref = np.array([0.3, -1.0, 0.1]) / np.hypot(0.3, 1.0)
    got = np.array([a, b, c]) * np.sign(b) * -1
    np.testing.assert_allclose(got, ref, atol=5e-3)
    assert st["num_inliers"] >= 0.95 * n_in and st["num_inliers"] <= n_in + 10
    assert st["iterations"] < 1000  # adaptive stopping
    assert _core.ransac_line(pts, 0.01, 3)[0] == (a, b, c)  # seeded


def test_min_inlier_ratio_stops_a_decision_search_early():
    """``min_inlier_ratio``: the stopping rule assumes at least this inlier ratio. Where the line's ratio
    (0.3) is below it (0.5) the loop stops after the samples a 0.5 ratio needs (log(1e-3) / log(0.75),
    25) instead of the 0.3 ratio's 73; where the ratio is above it, the same line is found."""
    rng = np.random.default_rng(11)
    x = rng.uniform(-1, 1, 120)
    pts = np.ascontiguousarray(np.r_[np.c_[x, 0.3 * x + 0.1 + rng.normal(0, 0.002, 120)], rng.uniform(-1, 1, (280, 2))])
    need = int(np.ceil(np.log(1e-3) / np.log(1.0 - 0.5**2)))
    for seed in range(5):
        _, plain = _core.ransac_line(pts, 0.01, seed)
        _, fast = _core.ransac_line(pts, 0.01, seed, min_inlier_ratio=0.5)
        assert fast["iterations"] <= need < plain["iterations"]
        line, st = _core.ransac_line(pts, 0.01, seed, min_inlier_ratio=0.2)
        assert st["num_inliers"] >= 0.95 * 120
        assert abs(abs(line[0]) - 0.3 / np.hypot(0.3, 1.0)) < 5e-3
    for bad in (-0.1, 1.5, float("nan")):
        with pytest.raises(ValueError, match="min_inlier_ratio"):
            _core.ransac_line(pts, 0.01, 0, min_inlier_ratio=bad)


def test_rotation_search_with_a_support_floor():
    """The pure-rotation test's search (min_inlier_ratio = half the pose's inlier share): on a pure
    rotation at 50 % outliers the rotation is still found; with a translation it stops after ~150
    hypotheses instead of running to the cap."""
    from poseonly.analysis import ROTATION_MAX_ITERATIONS, robust_rotation

    s = sim.make_scene(400, kind="rotation", noise_px=0.5, outlier_fraction=0.5, seed=3)
    tau = 2.0 / 800.0  # 2 px at the scenes' focal 800
    R0, m0, k0 = robust_rotation(s.f1, s.f2, tau)
    R1, m1, k1 = robust_rotation(s.f1, s.f2, tau, 0.25)
    assert rotation_error_deg(R1, s.R) < 0.05 and m1.sum() >= 0.95 * m0.sum()
    assert k1 <= k0
    t = sim.make_scene(400, noise_px=0.5, outlier_fraction=0.5, seed=3)
    _, _, k_full = robust_rotation(t.f1, t.f2, tau)
    _, _, k_floor = robust_rotation(t.f1, t.f2, tau, 0.25)
    assert k_full >= ROTATION_MAX_ITERATIONS and k_floor < 200  # (+ the Kabsch refits)
    with pytest.raises(ValueError, match="min_inlier_ratio"):
        _core.robust_rotation(t.f1, t.f2, 0.01, 0, min_inlier_ratio=2.0)


def test_challengers_rescue_a_search_stuck_on_the_first_optimised_basin():
    """Two lines: A tight (60 points), B noisier but larger (90 points; its least-squares fit has the
    lower MSAC cost). With one LO run (the first best's), a search whose first best lies on A ends on
    A: B's raw two-point models score worse than A's optimised one. Challengers (the best models of
    other basins, optimised after the loop) find B on every seed."""
    rng = np.random.default_rng(0)
    xa = rng.uniform(-1, 1, 60)
    a = np.c_[xa, 0.5 + rng.normal(0, 0.0005, 60)]
    xb = rng.uniform(-1, 1, 90)
    b = np.c_[xb, xb + rng.normal(0, 0.006, 90)]
    pts = np.ascontiguousarray(np.r_[a, b, rng.uniform(-1, 1, (250, 2))])

    def on_b(line: tuple[float, float, float]) -> bool:
        return abs(abs(line[0]) - 1 / np.sqrt(2)) < 0.05

    kw = dict(max_iterations=1000, confidence=0.999, max_lo=1, scoring=0)
    plain = [_core.ransac_line(pts, 0.01, s, **kw) for s in range(30)]
    chal = [_core.ransac_line(pts, 0.01, s, challengers=4, **kw) for s in range(30)]
    assert sum(not on_b(r[0]) for r in plain) >= 1  # the failure the challengers address
    assert all(on_b(r[0]) for r in chal)
    for (l0, s0), (l4, s4) in zip(plain, chal):
        assert s4["cost"] <= s0["cost"]  # never worse under the search's own objective
        if s4["challenger_won"]:
            assert s4["cost"] < s0["cost"] and s4["num_challenger_lo"] >= 1
        else:
            assert l4 == l0
    for bad in (dict(challengers=-1), dict(challengers=65), dict(challengers=2, challenger_distance=-1.0), dict(challengers=2, challenger_distance=float("nan"))):
        with pytest.raises(ValueError):
            _core.ransac_line(pts, 0.01, 0, **bad)


def test_core_releases_the_gil_and_threads_agree():
    s = sim.make_scene(300, noise_px=1.0, outlier_fraction=0.5, seed=2)
    idx = np.stack([np.random.default_rng(i).choice(300, 30, replace=False) for i in range(40)])
    est = get_estimator("lirp", "ligt")
    serial = [gnc_irls_batch(s.f1[idx[i::4]], s.f2[idx[i::4]], est).R for i in range(4)]
    out: list = [None] * 4

    def work(i: int) -> None:
        out[i] = gnc_irls_batch(s.f1[idx[i::4]], s.f2[idx[i::4]], est).R

    th = [threading.Thread(target=work, args=(i,)) for i in range(4)]
    for x in th:
        x.start()
    for x in th:
        x.join()
    for a, b in zip(serial, out):
        np.testing.assert_array_equal(a, b)


def test_bad_shapes_raise_value_error():
    with pytest.raises(ValueError):
        _core.residual_matrix(0, np.eye(3)[None], np.ones((1, 3)), np.ones((4, 2)), np.ones((4, 2)))
    with pytest.raises(ValueError):
        _core.lirp_batch(np.ones((1, 8, 3)), np.ones((1, 7, 3)))
    with pytest.raises(ValueError):
        _core.ransac_relpose(np.ones((10, 3)), np.ones((10, 3)), -1.0, 0)


@pytest.mark.parametrize("scoring", ["msac", "msac-multi"])
@pytest.mark.parametrize("n", [7, 33, 300])
def test_ransac_score_is_the_cost_of_its_model(scoring, n):
    """The scorers' vectorised block path (residual_block, blocks of 32) gives the cost the formula
    gives on the returned model's Sampson residuals (block edges: n = 7, 33, 300)."""
    from poseonly.robust.ransac import ransac_relpose
    from poseonly.sim import make_scene

    sc = make_scene(n, camera="pinhole", noise_px=0.5, outlier_fraction=0.3, seed=n)
    tau = 2.0 / 800.0
    r = ransac_relpose(sc.f1, sc.f2, tau, 5, scoring=scoring, min_iterations=50)
    v2 = RESIDUALS["sampson"](r.R, r.t, sc.f1, sc.f2) ** 2
    scales = [tau**2] if scoring == "msac" else [tau**2, tau**2 / 4, tau**2 / 16]
    cost = sum(np.sum(np.minimum(v2, s)) / (1.0 if scoring == "msac" else s) for s in scales)
    assert r.score == pytest.approx(cost, rel=1e-9)


def test_epipolar_singular_values_match_numpy():
    """The API's rank test: the core's singular values of the n x 9 epipolar matrix are numpy's
    (to 1e-12 relative), for generic, planar-ish and rank-deficient (repeated point) input."""
    from poseonly import _core
    from poseonly.sim import make_scene

    for seed, n in [(1, 6), (2, 9), (3, 40), (4, 300)]:
        sc = make_scene(n, "planar" if seed % 2 else "normal", seed=seed)
        cases = [(sc.f1, sc.f2), (np.repeat(sc.f1[:3], 4, axis=0), np.repeat(sc.f2[:3], 4, axis=0))]
        for f1, f2 in cases:
            f1 = np.ascontiguousarray(f1)
            f2 = np.ascontiguousarray(f2)
            A = (f1[:, :, None] * f2[:, None, :]).reshape(len(f1), 9)
            ref = np.zeros(9)
            sv = np.linalg.svd(A, compute_uv=False)
            ref[: len(sv)] = sv
            s = _core.epipolar_singular_values(f1, f2)
            np.testing.assert_allclose(s, ref, rtol=0, atol=1e-12 * ref[0])


def test_identify_matches_reference_on_perturbed_essentials():
    """The core's SVD-free decomposition (smallest eigenvector of E^T E by Newton on its
    characteristic cubic, u3 = cof(E) v3) identifies the same pose as the numpy reference's SVD, to
    1e-9, for candidates near the true E and for matrices with a small but distinct third singular
    value; the t sign of an invalid candidate with M2 = 0 follows v3's sign convention, so the
    comparison is on valid candidates (|M2| > 0 fixes the sign)."""
    from reference.identify import identify_and_rank

    rng = np.random.default_rng(5)
    compared = 0
    for seed in range(6):
        s = sim.make_scene(40, noise_px=1.0, seed=seed, camera="wide" if seed % 2 else "pinhole")
        w = rng.uniform(0.2, 1.0, 40)
        for k in range(40):
            if k % 2:
                E = s.E + 10.0 ** rng.uniform(-6, -2) * rng.normal(size=(3, 3))
            else:
                U, _, Vt = np.linalg.svd(rng.normal(size=(3, 3)))
                E = U @ np.diag([1.0, rng.uniform(0.05, 1.0), rng.uniform(0.0, 0.02)]) @ Vt
            c = _core.identify(np.ascontiguousarray(E), s.f1, s.f2, w, True)
            r = identify_and_rank(E[None, None], s.f1[None], s.f2[None], w[None])
            assert bool(c["valid"][0]) == bool(r["valid"][0, 0])
            assert np.all(np.isfinite(c["R"])) and np.all(np.isfinite(c["t"]))
            if not c["valid"][0]:
                continue
            compared += 1
            np.testing.assert_allclose(c["R"][0], r["R"][0, 0], atol=1e-9)
            np.testing.assert_allclose(c["t"][0], r["t"][0, 0], atol=1e-9)
            np.testing.assert_allclose(c["M1"][0], r["M1"][0, 0], atol=1e-12)
            np.testing.assert_allclose(c["cost"][0], r["cost"][0, 0], rtol=1e-9, atol=1e-12)
    assert compared > 100


@pytest.mark.parametrize("E", ["rank1", "double", "zero_third"])
def test_identify_degenerate_spectra_return_rotations(E):
    """Where E^T E's smallest eigenvalue is repeated (rank one, or two equal small singular values)
    v3 is any vector of a plane (the reference's SVD picks another): the decomposition still returns
    a finite R and a unit t; for a true essential matrix R is a rotation to rounding."""
    rng = np.random.default_rng(2)
    s = sim.make_scene(30, seed=1)
    U, _, Vt = np.linalg.svd(rng.normal(size=(3, 3)))
    d = {"rank1": [1.0, 0.0, 0.0], "double": [1.0, 0.3, 0.3], "zero_third": [0.7, 0.7, 0.0]}[E]
    c = _core.identify(np.ascontiguousarray(U @ np.diag(d) @ Vt), s.f1, s.f2, None, True)
    R, t = c["R"][0], c["t"][0]
    if E == "zero_third":  # a true essential matrix: R is a rotation
        np.testing.assert_allclose(R @ R.T, np.eye(3), atol=1e-12)
        assert np.linalg.det(R) == pytest.approx(1.0, abs=1e-12)
    assert np.all(np.isfinite(R))
    assert np.linalg.norm(t) == pytest.approx(1.0, abs=1e-12)


def test_core_stub_declares_exactly_the_core():
    """src/poseonly/_core.pyi (what mypy checks the package against) declares every name the compiled
    core exports, and nothing else."""
    import ast
    from pathlib import Path

    import poseonly
    from poseonly import _core

    tree = ast.parse((Path(poseonly.__file__).parent / "_core.pyi").read_text())
    declared = {n.name for n in tree.body if isinstance(n, (ast.FunctionDef, ast.ClassDef))}
    declared |= {n.target.id for n in tree.body if isinstance(n, ast.AnnAssign) and isinstance(n.target, ast.Name)}
    exported = {k for k in dir(_core) if not k.startswith("__")}
    assert exported - declared == set(), "exported by the core, missing from _core.pyi"
    assert declared - exported == set(), "declared in _core.pyi, not exported by the core"
