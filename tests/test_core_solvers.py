"""The compiled five-point solver and LM refinements of poseonly._core (bind_solvers.cpp).

Exactness on noise-free scenes (incl. wide-angle bearings with negative z and near-degenerate
geometry), agreement with the numpy implementations where the math is the same (Stewenius
essentials, LiGT residual Jacobians and LM iterates, Sampson Jacobian vs finite differences),
and bad-input errors. Skipped when the extension is not built.
"""

from __future__ import annotations

import numpy as np
import pytest

core = pytest.importorskip("poseonly._core")
if not hasattr(core, "fivept"):
    pytest.skip("poseonly._core was built without the solvers", allow_module_level=True)

from scipy.optimize import least_squares

from poseonly import lirp
from poseonly.geometry import (
    normalize,
    rotation_error_deg,
    rotation_from_rotvec,
    skew,
    translation_error_deg,
)
from poseonly.refine._manifold import PoseChart
from poseonly.refine.ligt import NORMALIZATIONS, _residual_and_jacobian
from poseonly.residuals import v_sampson
from poseonly.sim import make_scene
from poseonly.solvers.fivept import fivept as fivept_numpy
from reference.ligt_lm import ligt_refine_numpy_lm

EXACT_DEG = 1e-6
LOSSES = ("linear", "soft_l1", "huber", "cauchy", "arctan")


def _best_error(R_true, t_true, Rs, ts) -> float:
    """Smallest max(rotation, translation) error over the returned poses (inf if none)."""
    errs = [max(rotation_error_deg(R_true, R), translation_error_deg(t_true, t)) for R, t in zip(Rs, ts)]
    return min(errs) if errs else np.inf


def _custom_scene(rng, baseline=1.0, forward=False, spread=1.0, depth=6.0, n=5, all_around=False):
    """Noise-free bearings of n points for a random pose; all_around: points on every side (negative z)."""
    R = rotation_from_rotvec(rng.normal(0, 0.3, 3))
    C = np.array([0.0, 0.0, 1.0]) if forward else normalize(rng.standard_normal(3))
    C = C * baseline
    if all_around:
        X = normalize(rng.standard_normal((n, 3))) * rng.uniform(2.0, 8.0, (n, 1))
    else:
        X = np.column_stack([rng.uniform(-spread, spread, (n, 2)) * depth / 4, depth + rng.uniform(-spread, spread, n)])
    t = -R @ C
    X2 = X @ R.T + t
    return normalize(X), normalize(X2), R, t / np.linalg.norm(t)


# ------------------------------------------------------------------------------------------------
# five-point


@pytest.mark.parametrize("kind", ["normal", "planar"])
@pytest.mark.parametrize("camera", ["wide", "pinhole"])
def test_fivept_exact_on_noise_free_scenes(kind, camera):
    for seed in range(40):
        sc = make_scene(5, kind, camera, seed=seed)
        R, t = core.fivept(sc.f1, sc.f2)
        assert R.shape[1:] == (3, 3) and t.shape[1:] == (3,) and len(R) == len(t) <= 10
        assert _best_error(sc.R, sc.t, R, t) < EXACT_DEG, (kind, camera, seed)
        # every returned pose is a rotation with unit t and all five points in front of both cameras
        for Rk, tk in zip(R, t):
            np.testing.assert_allclose(Rk.T @ Rk, np.eye(3), atol=1e-12)
            assert np.linalg.det(Rk) > 0 and abs(np.linalg.norm(tk) - 1) < 1e-12
            c = np.cross(sc.f1 @ Rk.T, sc.f2)
            assert np.all(np.sum(c * np.cross(sc.f2, tk), axis=1) > 0)
            assert np.all(np.sum(c * np.cross(sc.f1 @ Rk.T, tk), axis=1) > 0)


def test_fivept_wide_angle_bearings_with_negative_z():
    rng = np.random.default_rng(11)
    count_negative = 0
    for _ in range(60):
        f1, f2, R, t = _custom_scene(rng, all_around=True)
        count_negative += int(np.any(f1[:, 2] < 0) or np.any(f2[:, 2] < 0))
        Rs, ts = core.fivept(f1, f2)
        assert _best_error(R, t, Rs, ts) < EXACT_DEG
    assert count_negative > 30


@pytest.mark.parametrize(
    "case",
    [
        {"baseline": 0.02},  # short baseline (1/300 of the depth)
        {"forward": True},  # translation along the optical axis (epipole inside the image)
        {"spread": 0.05},  # narrow field of view: points within ~1 degree
        # distant, shallow points (baseline 1/60 of the depth, depth range +-1/60): numpy's Stewenius E
        # is off by up to 0.3 (Frobenius-normalised entries) in these samples
        {"depth": 60.0},
    ],
    ids=["short-baseline", "forward", "narrow-fov", "distant"],
)
def test_fivept_near_degenerate_geometry(case):
    """Near-degenerate but valid samples stay exact (the Newton polish of the pose removes the
    null space's error amplification at small parallax)."""
    rng = np.random.default_rng(3)
    for _ in range(30):
        f1, f2, R, t = _custom_scene(rng, **case)
        Rs, ts = core.fivept(f1, f2)
        assert _best_error(R, t, Rs, ts) < EXACT_DEG, case


def test_fivept_essentials_match_numpy():
    """The real essential matrices are numpy's Stewenius (real_only) solutions (same construction; the
    compiled roots are Newton-polished, numpy's are not: they agree to ~1e-7, the compiled ones satisfy
    the constraints to rounding)."""
    for seed in range(30):
        sc = make_scene(5, "normal" if seed % 2 else "planar", "wide" if seed % 3 else "pinhole", seed=100 + seed)
        E = core.fivept_essentials(sc.f1, sc.f2)
        En = fivept_numpy(sc.f1, sc.f2, real_only=True)
        assert len(E) == len(En)
        for e in E:
            np.testing.assert_allclose(np.linalg.norm(e), 1.0, rtol=1e-14)
            d = min(min(np.abs(e - x).max(), np.abs(e + x).max()) for x in En)
            assert d < 1e-6
            assert np.abs(np.einsum("ni,ij,nj->n", sc.f2, e, sc.f1)).max() < 1e-13
            assert np.abs(2 * e @ e.T @ e - np.trace(e @ e.T) * e).max() < 1e-12 and abs(np.linalg.det(e)) < 1e-13
        Et = skew(sc.t) @ sc.R
        Et /= np.linalg.norm(Et)
        assert min(min(np.abs(e - Et).max(), np.abs(e + Et).max()) for e in E) < 1e-10


@pytest.mark.parametrize("path", [0, 1], ids=["nister", "action-matrix"])
def test_fivept_each_construction_exact_where_it_passes(path):
    """Each construction of the solver (Nister's elimination, the action matrix) returns the true E on
    noise-free samples wherever it passes its own reliability test, and the automatic choice takes
    Nister's where it passes, else the action matrix (and says which)."""
    passed = 0
    for seed in range(120):
        sc = make_scene(5, ("normal", "planar")[seed % 2], ("wide", "pinhole")[seed // 2 % 2], seed=seed)
        Et = np.array([[0, -sc.t[2], sc.t[1]], [sc.t[2], 0, -sc.t[0]], [-sc.t[1], sc.t[0], 0]]) @ sc.R
        Et /= np.linalg.norm(Et)
        E, used = core._fivept_essentials_path(sc.f1, sc.f2, path)
        if used != path:
            assert used == -2 and len(E) == 0 and path == 0
            assert core._fivept_essentials_path(sc.f1, sc.f2, -1)[1] == 1  # then the action matrix
            continue
        passed += 1
        assert min(min(np.abs(e - Et).max(), np.abs(e + Et).max()) for e in E) < 1e-10, seed
        auto, auto_used = core._fivept_essentials_path(sc.f1, sc.f2, -1)
        if auto_used == path:
            np.testing.assert_array_equal(auto, E)
    assert passed == 120 if path == 1 else 80 <= passed < 120  # some samples fail Nister's test


def test_fivept_path_rejects_bad_codes_and_reports_rank_deficient_samples():
    sc = make_scene(5, "normal", "wide", seed=0)
    for bad in (-3, -2, 2):
        with pytest.raises(ValueError, match="path"):
            core._fivept_essentials_path(sc.f1, sc.f2, bad)
    f = np.repeat(sc.f1[:1], 5, axis=0)  # five copies of one match
    E, used = core._fivept_essentials_path(f, np.repeat(sc.f2[:1], 5, axis=0), -1)
    assert used == -2 and E.shape == (0, 3, 3)


def test_fivept_batch_equals_single_calls():
    sc = make_scene(40, "normal", "wide", noise_px=0.5, seed=4)
    rng = np.random.default_rng(0)
    idx = np.array([rng.choice(40, 5, replace=False) for _ in range(25)])
    F1, F2 = sc.f1[idx], sc.f2[idx]
    R, t, sample = core.fivept_batch(F1, F2)
    assert sample.dtype == np.int64 and np.all(np.diff(sample) >= 0)
    for s in range(len(idx)):
        Rs, ts = core.fivept(F1[s], F2[s])
        np.testing.assert_array_equal(R[sample == s], Rs)
        np.testing.assert_array_equal(t[sample == s], ts)
    R0, t0, s0 = core.fivept_batch(np.zeros((0, 5, 3)), np.zeros((0, 5, 3)))
    assert R0.shape == (0, 3, 3) and t0.shape == (0, 3) and s0.shape == (0,)


def test_fivept_batch_on_random_bearings_returns_valid_poses():
    """Arbitrary (outlier) samples: every returned pose is a finite rotation with unit t, chiral on its sample."""
    rng = np.random.default_rng(21)
    F1, F2 = normalize(rng.standard_normal((300, 5, 3))), normalize(rng.standard_normal((300, 5, 3)))
    R, t, sample = core.fivept_batch(F1, F2)
    assert len(R) > 0 and np.all(np.isfinite(R)) and np.all(np.isfinite(t))
    np.testing.assert_allclose(np.einsum("mji,mjk->mik", R, R), np.broadcast_to(np.eye(3), R.shape), atol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(t, axis=1), 1.0, atol=1e-14)
    a = np.einsum("mij,mnj->mni", R, F1[sample])
    c = np.cross(a, F2[sample])
    assert np.all(np.sum(c * np.cross(F2[sample], t[:, None, :]), axis=2) > 0)
    assert np.all(np.sum(c * np.cross(a, t[:, None, :]), axis=2) > 0)
    # the epipolar equations hold to rounding for every returned pose
    E = np.einsum("mij,mjk->mik", np.stack([skew(x) for x in t]), R)
    assert np.abs(np.einsum("mni,mij,mnj->mn", F2[sample], E, F1[sample])).max() < 1e-12


def test_fivept_degenerate_sample_returns_nothing():
    sc = make_scene(5, "normal", "wide", seed=1)
    f1, f2 = sc.f1.copy(), sc.f2.copy()
    f1[1], f2[1] = f1[0], f2[0]  # a repeated correspondence: rank-deficient epipolar rows
    R, t = core.fivept(f1, f2)
    assert R.shape == (0, 3, 3) and t.shape == (0, 3)
    f1[0, 0] = np.nan
    assert len(core.fivept(f1, f2)[0]) == 0


def test_fivept_bad_shapes():
    sc = make_scene(6, seed=0)
    with pytest.raises(ValueError):
        core.fivept(sc.f1, sc.f2)  # 6 points
    with pytest.raises(ValueError):
        core.fivept(sc.f1[:5, :2], sc.f2[:5, :2])
    with pytest.raises(ValueError):
        core.fivept(sc.f1[:5], sc.f2[:4])
    with pytest.raises(ValueError):
        core.fivept_batch(sc.f1[None, :5], sc.f2[None, :4])
    with pytest.raises(ValueError):
        core.fivept_batch(np.zeros((2, 5, 3)), np.zeros((3, 5, 3)))
    with pytest.raises(ValueError):
        core.fivept_essentials(sc.f1, sc.f2)


# ------------------------------------------------------------------------------------------------
# refinements: residuals and Jacobians


def _perturbed_start(sc, rng, deg=1.0, dt=0.03):
    R0 = rotation_from_rotvec(np.radians(deg) * normalize(rng.standard_normal(3))) @ sc.R
    return R0, normalize(sc.t + dt * rng.standard_normal(3))


@pytest.mark.parametrize("norm", NORMALIZATIONS)
def test_ligt_residuals_and_jacobian_match_numpy(norm):
    sc = make_scene(50, "normal", "wide", noise_px=1.0, outlier_fraction=0.2, seed=7)
    rng = np.random.default_rng(7)
    R0, t0 = _perturbed_start(sc, rng, 2.0, 0.05)
    w = rng.random(50)
    chart = PoseChart(R0, t0)
    for x in (np.zeros(5), 0.02 * rng.standard_normal(5)):
        r, J = core._refine_residuals(1 + NORMALIZATIONS.index(norm), R0, t0, sc.f1, sc.f2, x, w)
        rn, Jn = _residual_and_jacobian(chart, x, sc.f1, sc.f2, np.sqrt(w), True, norm)
        np.testing.assert_allclose(r, rn, rtol=1e-11, atol=1e-15 * np.abs(rn).max())
        np.testing.assert_allclose(J, Jn, rtol=1e-10, atol=1e-13 * np.abs(Jn).max())


def test_sampson_residual_and_jacobian_vs_finite_differences():
    sc = make_scene(40, "normal", "wide", noise_px=1.0, seed=3)
    rng = np.random.default_rng(3)
    R0, t0 = _perturbed_start(sc, rng, 3.0, 0.1)
    w = 0.5 + rng.random(40)
    r, _ = core._refine_residuals(0, R0, t0, sc.f1, sc.f2, np.zeros(5), None)
    np.testing.assert_allclose(np.abs(r), v_sampson(R0, t0, sc.f1, sc.f2), rtol=1e-12, atol=1e-16)
    h = 1e-5
    for x in (np.zeros(5), 0.05 * rng.standard_normal(5)):
        _, J = core._refine_residuals(0, R0, t0, sc.f1, sc.f2, x, w)
        Jfd = np.empty_like(J)
        for k in range(5):
            e = np.zeros(5)
            e[k] = h
            rp, _ = core._refine_residuals(0, R0, t0, sc.f1, sc.f2, x + e, w)
            rm, _ = core._refine_residuals(0, R0, t0, sc.f1, sc.f2, x - e, w)
            Jfd[:, k] = (rp - rm) / (2 * h)
        np.testing.assert_allclose(J, Jfd, rtol=1e-7, atol=1e-9 * np.abs(J).max())


@pytest.mark.parametrize("n", [1, 31, 32, 33, 100])
def test_sampson_normal_equations_blocks_bit_identical(n):
    # the LM's SIMD blocks over coordinate arrays give the per-point path's cost, H and g exactly,
    # and both are the point-order sums of the residuals and Jacobians of _refine_residuals
    sc = make_scene(max(n, 6), "normal", "wide", noise_px=1.0, outlier_fraction=0.3, seed=n)
    f1, f2 = np.ascontiguousarray(sc.f1[:n]), np.ascontiguousarray(sc.f2[:n])
    rng = np.random.default_rng(n)
    R0, t0 = _perturbed_start(sc, rng, 2.0, 0.05)
    w = rng.random(n)
    for x in (np.zeros(5), 0.02 * rng.standard_normal(5)):
        cb, Hb, gb = core._refine_normal_equations(R0, t0, f1, f2, x, w, True)
        cp, Hp, gp = core._refine_normal_equations(R0, t0, f1, f2, x, w, False)
        assert cb == cp
        np.testing.assert_array_equal(Hb, Hp)
        np.testing.assert_array_equal(gb, gp)
        r, J = core._refine_residuals(0, R0, t0, f1, f2, x, w)
        cost, H, g = 0.0, np.zeros((5, 5)), np.zeros(5)
        for i in range(n):  # Python floats: the same roundings as the core's sequential sums
            ri, Ji = float(r[i]), [float(v) for v in J[i]]
            cost += ri * ri
            for a in range(5):
                g[a] += Ji[a] * ri
                for b in range(a, 5):
                    H[a, b] += Ji[a] * Ji[b]
        H = np.triu(H) + np.triu(H, 1).T
        assert cb == cost
        np.testing.assert_array_equal(Hb, H)
        np.testing.assert_array_equal(gb, g)


@pytest.mark.parametrize("loss", ["linear", "cauchy", "huber", "soft_l1", "arctan"])
@pytest.mark.parametrize("outside", [False, True])
def test_sampson_normal_equations_blocks_every_branch(loss, outside):
    # robust losses, weights outside the loss with zero weights and residual weights inside it, a
    # point with no epipolar geometry (f2 along t: the flat Jacobian) and a NaN point: the block path
    # and the per-point path agree bit for bit (NaN where both are NaN)
    n = 70
    sc = make_scene(n, "normal", "wide", noise_px=1.0, outlier_fraction=0.3, seed=11)
    f1, f2 = sc.f1.copy(), sc.f2.copy()
    rng = np.random.default_rng(11)
    R0, t0 = _perturbed_start(sc, rng, 2.0, 0.05)
    f2[5] = t0 / np.linalg.norm(t0)
    w = rng.random(n)
    w[::7] = 0.0
    v = 0.5 + rng.random(n)
    for nan in (False, True):
        if nan:
            f1[40] = np.nan
        for x in (np.zeros(5), 0.02 * rng.standard_normal(5)):
            kw = dict(loss=loss, loss_scale=1e-3, weights_outside=outside, residual_weights=v if outside else None)
            cb, Hb, gb = core._refine_normal_equations(R0, t0, f1, f2, x, w, True, **kw)
            cp, Hp, gp = core._refine_normal_equations(R0, t0, f1, f2, x, w, False, **kw)
            np.testing.assert_array_equal(np.array([cb]), np.array([cp]))
            np.testing.assert_array_equal(Hb, Hp)
            np.testing.assert_array_equal(gb, gp)
            assert np.isnan(cb) == (nan and not (outside and w[40] == 0.0))


# ------------------------------------------------------------------------------------------------
# refinements: exactness, agreement with the numpy LM, weights


@pytest.mark.parametrize("method", ["sampson", "none", "theta2", "angular"])
def test_refine_exact_from_perturbed_noise_free_start(method):
    rng = np.random.default_rng(5)
    for seed, (kind, camera) in enumerate([("normal", "wide"), ("planar", "pinhole"), ("normal", "pinhole")]):
        sc = make_scene(60, kind, camera, seed=5 + seed)
        R0, t0 = _perturbed_start(sc, rng, 0.5, 0.02)
        if method == "sampson":
            R, t, st = core.refine_sampson(R0, t0, sc.f1, sc.f2)
        else:
            R, t, st = core.refine_ligt(R0, t0, sc.f1, sc.f2, normalization=method)
        # (status -1 is possible here: at the zero of the cost no step decreases it below rounding)
        assert st["status"] != 0 and st["final_cost"] < 1e-12 * st["initial_cost"]
        assert rotation_error_deg(sc.R, R) < EXACT_DEG and translation_error_deg(sc.t, t) < 1e-5
        assert st["positive_depth_fraction"] == 1.0


@pytest.mark.parametrize("norm", NORMALIZATIONS)
def test_refine_ligt_matches_numpy_lm(norm):
    """The core's LM and the numpy reference LM (tests/reference/ligt_lm.py) reach the same minimum: both
    stop at their tolerance, so the poses agree to 1e-6 deg and the costs to 1e-9."""
    for s in range(6):
        sc = make_scene(200, "normal" if s % 2 else "planar", "pinhole" if s % 3 else "wide", noise_px=1.0, seed=50 + s)
        lr = lirp(sc.f1, sc.f2)
        for loss in LOSSES:
            scale = 2.0 / 800 if (norm == "angular" and loss != "linear") else None
            a = ligt_refine_numpy_lm(lr.R, lr.t, sc.f1, sc.f2, loss=loss, loss_scale=scale, normalization=norm)
            R, t, st = core.refine_ligt(lr.R, lr.t, sc.f1, sc.f2, normalization=norm, loss=loss, loss_scale=scale)
            assert rotation_error_deg(a.R, R) < 1e-6 and translation_error_deg(a.t, t) < 1e-6, (s, loss)
            np.testing.assert_allclose(st["initial_cost"], a.cost_initial, rtol=1e-12)
            np.testing.assert_allclose(st["final_cost"], a.cost_final, rtol=1e-9)
            assert (st["status"] > 0) == (a.info["status"] > 0) or st["status"] == -1 or a.info["status"] == -1
            if loss != "linear":
                np.testing.assert_allclose(st["loss_scale"], a.info["loss_scale"], rtol=1e-12)
            np.testing.assert_allclose(st["positive_depth_fraction"], a.info["positive_depth_fraction"])


def test_refine_ligt_weighted_matches_numpy_lm():
    sc = make_scene(120, "normal", "wide", noise_px=1.0, outlier_fraction=0.2, seed=9)
    w = np.random.default_rng(9).random(120)
    lr = lirp(sc.f1, sc.f2)
    for loss in ("linear", "cauchy"):
        a = ligt_refine_numpy_lm(lr.R, lr.t, sc.f1, sc.f2, weights=w, loss=loss, normalization="theta2")
        R, t, st = core.refine_ligt(lr.R, lr.t, sc.f1, sc.f2, w=w, normalization="theta2", loss=loss)
        assert rotation_error_deg(a.R, R) < 1e-6 and translation_error_deg(a.t, t) < 1e-6
        np.testing.assert_allclose(st["final_cost"], a.cost_final, rtol=1e-9)


def _sampson_scipy(R0, t0, f1, f2, loss, scale):
    """scipy least_squares on the Sampson residual in the same chart (scalar residuals: scipy's loss
    equals the per-point loss)."""
    chart = PoseChart(R0, t0)

    def fun(x):
        R, t = chart.retract(x)
        E = skew(t) @ R
        Ef1, Etf2 = f1 @ E.T, f2 @ E
        num = np.sum(f2 * Ef1, axis=1)
        den = np.sum(Ef1**2, axis=1) + np.sum(Etf2**2, axis=1) - 2 * num**2
        return num / np.sqrt(den)

    res = least_squares(fun, np.zeros(5), method="lm" if loss == "linear" else "trf", loss=loss, f_scale=scale, ftol=1e-15, xtol=1e-15, gtol=1e-15, max_nfev=200)
    return chart.retract(res.x)


def _sampson_cost(R, t, f1, f2, loss, scale):
    s = v_sampson(R, t, f1, f2) ** 2 / scale**2
    rho = {"linear": s, "cauchy": np.log1p(s), "soft_l1": 2 * (np.sqrt(1 + s) - 1)}[loss]
    return float(scale**2 * np.sum(rho))


@pytest.mark.parametrize("loss", ["linear", "cauchy", "soft_l1"])
def test_refine_sampson_reaches_the_scipy_minimum(loss):
    for s in range(3):
        sc = make_scene(100, "normal", "pinhole" if s % 2 else "wide", noise_px=1.0, seed=20 + s)
        lr = lirp(sc.f1, sc.f2)
        scale = 1.0 / 800
        R, t, st = core.refine_sampson(lr.R, lr.t, sc.f1, sc.f2, loss=loss, loss_scale=scale, max_iterations=200)
        Rs, ts = _sampson_scipy(lr.R, lr.t, sc.f1, sc.f2, loss, scale)
        assert st["status"] > 0 and st["final_cost"] <= st["initial_cost"]
        # scipy stops a little earlier (trf with rho''): the same minimum to 1e-5 deg, ours not above it
        assert rotation_error_deg(Rs, R) < 1e-5 and min(translation_error_deg(ts, t), translation_error_deg(-ts, t)) < 1e-5
        assert st["final_cost"] <= _sampson_cost(Rs, ts, sc.f1, sc.f2, loss, scale) * (1 + 1e-10)


@pytest.mark.parametrize("method", ["sampson", "angular"])
def test_refine_zero_weights_equal_dropping_points(method):
    sc = make_scene(80, "normal", "wide", noise_px=1.0, outlier_fraction=0.25, seed=12)
    lr = lirp(sc.f1, sc.f2)
    w = sc.inliers.astype(float)
    keep = sc.inliers

    def run(f1, f2, ww):
        if method == "sampson":
            return core.refine_sampson(lr.R, lr.t, f1, f2, w=ww)
        return core.refine_ligt(lr.R, lr.t, f1, f2, w=ww, normalization=method)

    Ra, ta, sa = run(sc.f1, sc.f2, w)
    Rb, tb, sb = run(np.ascontiguousarray(sc.f1[keep]), np.ascontiguousarray(sc.f2[keep]), None)
    assert rotation_error_deg(Ra, Rb) < 1e-9 and translation_error_deg(ta, tb) < 1e-9
    np.testing.assert_allclose(sa["final_cost"], sb["final_cost"], rtol=1e-10)


def test_refine_exact_start_stays():
    sc = make_scene(30, "normal", "wide", seed=1)
    R, t, st = core.refine_ligt(sc.R, sc.t, sc.f1, sc.f2)
    assert rotation_error_deg(sc.R, R) < 1e-9 and translation_error_deg(sc.t, t) < 1e-9 and st["final_cost"] < 1e-28
    R, t, st = core.refine_sampson(sc.R, -sc.t, sc.f1, sc.f2)  # sign of t is re-fixed
    assert rotation_error_deg(sc.R, R) < 1e-9 and translation_error_deg(sc.t, t) < 1e-7


def test_refine_max_iterations_caps_evaluations():
    sc = make_scene(60, "normal", "wide", noise_px=1.0, seed=2)
    rng = np.random.default_rng(2)
    R0, t0 = _perturbed_start(sc, rng, 5.0, 0.2)
    for fn in (core.refine_sampson, core.refine_ligt):
        _, _, st = fn(R0, t0, sc.f1, sc.f2, max_iterations=3)
        assert st["evaluations"] <= 3 and st["status"] == 0 and st["final_cost"] <= st["initial_cost"]


def test_refine_bad_input():
    sc = make_scene(20, "normal", "wide", seed=0)
    R, t, f1, f2 = sc.R, sc.t, sc.f1, sc.f2
    for fn in (core.refine_sampson, core.refine_ligt):
        with pytest.raises(ValueError, match="rotation"):
            fn(2 * R, t, f1, f2)
        with pytest.raises(ValueError, match="non-zero"):
            fn(R, np.zeros(3), f1, f2)
        with pytest.raises(ValueError):
            fn(R[:2], t, f1, f2)
        with pytest.raises(ValueError):
            fn(R, t[:2], f1, f2)
        with pytest.raises(ValueError):
            fn(R, t, f1, f2[:-1])
        with pytest.raises(ValueError, match="at least 6"):
            fn(R, t, f1[:5], f2[:5])
        with pytest.raises(ValueError, match="weights"):
            fn(R, t, f1, f2, w=np.ones(19))
        with pytest.raises(ValueError, match="weights"):
            fn(R, t, f1, f2, w=-np.ones(20))
        with pytest.raises(ValueError, match="loss"):
            fn(R, t, f1, f2, loss="tukey")
        with pytest.raises(ValueError, match="loss_scale"):
            fn(R, t, f1, f2, loss="cauchy", loss_scale=-1.0)
        with pytest.raises(ValueError, match="max_iterations"):
            fn(R, t, f1, f2, max_iterations=0)
        bad = f1.copy()
        bad[3, 1] = np.inf
        with pytest.raises(ValueError, match="finite"):
            fn(R, t, bad, f2)
    with pytest.raises(ValueError, match="normalization"):
        core.refine_ligt(R, t, f1, f2, normalization="theta")
