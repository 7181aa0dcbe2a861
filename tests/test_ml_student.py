"""The ML stage's Student-t inlier model (``poseonly._core.ml_refine``, ``student=True``; option
``ml_tails``): the degrees of freedom chosen by the profile likelihood, the Gaussian (MLESAC) where
the errors are Gaussian, a heavy tail where they are heavy-tailed, and the pose it gives there."""

from __future__ import annotations

import numpy as np
import pytest

from poseonly import _core, estimate_relative_pose
from poseonly.geometry import rotation_error_deg
from poseonly.residuals import v_sampson
from poseonly.sim import make_scene

T_PX = 3.0  # the outlier range (the default's ml_range x its 1 px threshold)
NU_GRID = (1.0, 1.5, 2.0, 3.0, 5.0, 10.0, 30.0, np.inf)  # ml_refine.cpp kNuGrid


def _bearings(u: np.ndarray, K: np.ndarray) -> np.ndarray:
    x = np.c_[u, np.ones(len(u))] @ np.linalg.inv(K).T
    return x / np.linalg.norm(x, axis=1, keepdims=True)


def _heavy_scene(seed: int, nu: float = 2.0, scale_px: float = 0.3, outliers: float = 0.3):
    """Pinhole scene whose matches have their own noise scale (a keypoint's scale sets its
    localisation error): Gaussian pixel noise of variance scale_px^2 nu / chi2_nu per match, so that
    the Sampson errors are Student-t with nu dof; and uniform outlier matches."""
    sc = make_scene(300, "normal", "pinhole", 0.0, 0.0, seed)
    rng = np.random.default_rng(1000 + seed)
    sig = scale_px * np.sqrt(nu / rng.chisquare(nu, len(sc.u1)))[:, None]
    u1 = sc.u1 + sig * rng.normal(size=sc.u1.shape)
    u2 = sc.u2 + sig * rng.normal(size=sc.u2.shape)
    k = int(outliers * len(u1))
    lo, hi = sc.u2.min(0), sc.u2.max(0)
    u2[:k] = rng.uniform(lo, hi, (k, 2))
    return sc, u1, u2


def _ml(R, t, f1, f2, focal: float, student: bool) -> dict:
    return _core.ml_refine(R, t, f1, f2, T_PX / focal, rounds=50, pose_tol=1e-10, student=student)


@pytest.mark.parametrize("seed", range(4))
def test_gaussian_errors_choose_the_gaussian(seed):
    sc = make_scene(300, "normal", "pinhole", 0.5, 0.3, seed)
    focal = sc.K[0, 0]
    t_model = _ml(sc.R, sc.t, sc.f1, sc.f2, focal, True)
    g_model = _ml(sc.R, sc.t, sc.f1, sc.f2, focal, False)
    assert t_model["nu"] >= 30.0
    if np.isinf(t_model["nu"]):
        assert rotation_error_deg(t_model["R"], g_model["R"]) < 1e-6
        assert t_model["sigma"] == pytest.approx(g_model["sigma"], rel=1e-6)
    else:
        assert rotation_error_deg(t_model["R"], g_model["R"]) < 0.01


def test_heavy_tailed_errors_choose_a_heavy_tail_and_a_better_pose():
    ratios = []
    for seed in range(12):
        sc, u1, u2 = _heavy_scene(seed)
        f1, f2 = _bearings(u1, sc.K), _bearings(u2, sc.K)
        focal = sc.K[0, 0]
        t_model = _ml(sc.R, sc.t, f1, f2, focal, True)
        g_model = _ml(sc.R, sc.t, f1, f2, focal, False)
        assert t_model["nu"] in NU_GRID and 1.5 <= t_model["nu"] <= 5.0  # 2, seen through the 3 px range
        ratios.append(rotation_error_deg(sc.R, t_model["R"]) / rotation_error_deg(sc.R, g_model["R"]))
    assert np.exp(np.mean(np.log(ratios))) < 0.95  # measured 0.887 (geometric mean over the 12 scenes)


def test_noise_free_matches_give_the_exact_pose():
    sc = make_scene(200, "normal", "wide", 0.0, 0.3, 3)
    rng = np.random.default_rng(0)
    w = rng.normal(0.0, 1e-3, 3)
    c, s = np.cos(np.linalg.norm(w)), np.sin(np.linalg.norm(w))
    k = w / np.linalg.norm(w)
    Kx = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    R0 = (np.eye(3) + s * Kx + (1 - c) * Kx @ Kx) @ sc.R
    m = _ml(R0, sc.t, sc.f1, sc.f2, 800.0, True)
    assert rotation_error_deg(sc.R, m["R"]) < 1e-6
    assert np.linalg.norm(m["t"] - sc.t) < 1e-8


def _t_density(nu: float, s: float):
    from scipy.special import gammaln

    c = 2 * np.exp(gammaln((nu + 1) / 2) - gammaln(nu / 2)) / (np.sqrt(nu * np.pi) * s)
    return lambda r: c * (1 + (r / s) ** 2 / nu) ** (-(nu + 1) / 2)


# the grid's exponents (nu + 1) / 2 = 5/4, 3/2, 2 (quarter, half and whole powers); the scenes' nu and
# scale that choose them (the t is not renormalised on [0, T), which biases the choice lighter when
# the scale is a large part of T: measured, docs/CORE.md)
@pytest.mark.parametrize(("want_nu", "nu", "scale_px"), [(1.5, 1.0, 0.1), (2.0, 2.0, 0.3), (3.0, 2.0, 0.3)])
def test_student_log_likelihood_posteriors_and_decision(want_nu, nu, scale_px):
    for seed in range(40):
        sc, u1, u2 = _heavy_scene(seed, nu=nu, scale_px=scale_px)
        f1, f2 = _bearings(u1, sc.K), _bearings(u2, sc.K)
        T = T_PX / sc.K[0, 0]
        m = _core.ml_refine(sc.R, sc.t, f1, f2, T, rounds=50, pose_tol=1e-10)
        if m["nu"] == want_nu:
            break
    else:
        pytest.fail(f"no scene chose nu = {want_nu}")
    s, g, nu = m["sigma"], m["inlier_fraction"], m["nu"]
    f = _t_density(nu, s)
    r = np.minimum(v_sampson(m["R"][None], m["t"][None], f1, f2)[0], T)
    assert m["log_likelihood"] == pytest.approx(np.sum(np.log(g * f(r) + (1 - g) / T)), rel=1e-9)
    post = np.where(r < T, g * f(r) / (g * f(r) + (1 - g) / T), 0.0)
    np.testing.assert_allclose(m["posterior"], post, rtol=1e-9, atol=1e-12)
    d = m["decision"]
    assert 0 < d <= T
    if d < T:  # where the t's density meets the outliers' (else it stays above it up to T)
        assert g * f(d) == pytest.approx((1 - g) / T, rel=1e-9)
    else:
        assert g * f(T) >= (1 - g) / T
    assert 0 < m["decision_gauss"] < d and 0 < m["sigma_gauss"]


def test_option_switches_the_tails():
    sc, u1, u2 = _heavy_scene(2)
    a = estimate_relative_pose(u1, u2, sc.K, seed=0)
    b = estimate_relative_pose(u1, u2, sc.K, seed=0, ml_tails="gauss")
    assert np.isfinite(a.diagnostics["ml_nu"]) and np.isinf(b.diagnostics["ml_nu"])
    with pytest.raises(ValueError, match="ml_tails"):
        estimate_relative_pose(u1, u2, sc.K, ml_tails="laplace")


@pytest.mark.parametrize("seed", range(3))
def test_given_tails_are_used_and_the_chosen_ones_reproduce_the_fixed_point(seed):
    """``nu`` / ``alpha`` given (the cross-fit's folds): no choice is made, and given the tails the
    stage chose, EM reaches the same fixed point (the EM restarts differ, the fixed point does not)."""
    sc, u1, u2 = _heavy_scene(seed)
    f1, f2 = _bearings(u1, sc.K), _bearings(u2, sc.K)
    focal = sc.K[0, 0]
    free = _ml(sc.R, sc.t, f1, f2, focal, True)
    given = _core.ml_refine(sc.R, sc.t, f1, f2, T_PX / focal, rounds=50, pose_tol=1e-10, student=True, nu=free["nu"], alpha=free["alpha"])
    assert given["nu"] == free["nu"]
    assert rotation_error_deg(given["R"], free["R"]) < 1e-6
    assert given["sigma"] == pytest.approx(free["sigma"], rel=1e-4)  # EM stops at 1e-6 relative steps
    forced = _core.ml_refine(sc.R, sc.t, f1, f2, T_PX / focal, rounds=50, pose_tol=1e-10, student=True, nu=30.0, alpha=0.0)
    assert forced["nu"] == 30.0 and forced["alpha"] == 0.0


def test_given_tails_are_checked():
    sc = make_scene(60, "normal", "pinhole", 0.5, 0.0, 0)
    args = (sc.R, sc.t, sc.f1, sc.f2, T_PX / sc.K[0, 0])
    with pytest.raises(ValueError, match="together"):
        _core.ml_refine(*args, nu=3.0)
    with pytest.raises(ValueError, match="nu must be"):
        _core.ml_refine(*args, nu=0.5, alpha=0.0)
    with pytest.raises(ValueError, match="alpha must be"):
        _core.ml_refine(*args, nu=3.0, alpha=0.3)
    with pytest.raises(ValueError, match="student"):
        _core.ml_refine(*args, nu=3.0, alpha=0.0, student=False)
    assert np.isinf(_core.ml_refine(*args, nu=np.inf, alpha=0.0, student=False)["nu"])


@pytest.mark.parametrize("seed", range(3))
@pytest.mark.parametrize("nu", [1.0, 3.0, 10.0])
def test_the_reported_scale_and_share_are_a_fixed_point_of_em(seed, nu):
    # the E-step (ml_refine.cpp's fit_scale) ends at EM's fixed point for the returned pose: one more EM
    # step (numpy, from the mixture's equations; g capped by the outlier count just outside the band less
    # the inliers' tail there, ml_refine.cpp band_g_max) moves s and g by no more than its tolerance
    from math import lgamma, pi

    sc = make_scene(300, camera="wide", noise_px=1.0, outlier_fraction=0.5, seed=seed)
    T = 8.0 / 800.0
    m = _core.ml_refine(sc.R, sc.t, sc.f1, sc.f2, T, rounds=50, pose_tol=1e-6, student=True, nu=nu, alpha=0.0)
    s, g = float(m["sigma"]), float(m["inlier_fraction"])
    r = v_sampson(m["R"], m["t"], sc.f1, sc.f2)
    near = int(np.sum((r >= T) & (r < 2 * T)))
    r = r[r < T]
    norm = 2.0 * np.exp(lgamma(0.5 * (nu + 1.0)) - lgamma(0.5 * nu)) / np.sqrt(nu * pi) / s
    z2 = (r / s) ** 2
    lin = g * norm * (1.0 + z2 / nu) ** (-0.5 * (nu + 1.0))
    p = lin / (lin + (1.0 - g) / T)
    s1 = np.sqrt(np.sum(p * (nu + 1.0) / (nu + z2) * r**2) / np.sum(p))
    from scipy.stats import t as student_t

    sf = lambda x: 2.0 * student_t.sf(x / s, nu)  # noqa: E731  P(r >= x) of an inlier's error (half-t)
    sp = np.sum(p)
    b = max(near - sp * (sf(T) - sf(2 * T)) / (1.0 - sf(T)), 0.0)
    g_max = max(1.0 - b / len(r), sp / (len(r) + b))
    g1 = min(sp / len(r), g_max)
    assert abs(s1 - s) <= 1e-5 * s
    assert abs(g1 - g) <= 1e-5


@pytest.mark.parametrize("seed", range(3))
def test_pose_only_and_a_warm_start_reach_the_same_pose(seed):
    """The cross-fit's folds: ``pose_only`` computes the same pose (bit for bit), and EM started from
    the fit on all matches (``sigma_init``, ``g_init``) reaches the fixed point of EM started from its
    own robust start (the folds' stopping tolerance, 1e-5 rad a round, bounds the difference)."""
    sc, u1, u2 = _heavy_scene(seed)
    f1, f2 = _bearings(u1, sc.K), _bearings(u2, sc.K)
    T = T_PX / sc.K[0, 0]
    full = _core.ml_refine(sc.R, sc.t, f1, f2, T, rounds=50, pose_tol=1e-10, student=True)
    train = np.arange(len(f1)) % 5 != 0
    a1, a2 = np.ascontiguousarray(f1[train]), np.ascontiguousarray(f2[train])
    kw = dict(rounds=50, pose_tol=1e-10, student=True, nu=full["nu"], alpha=full["alpha"])
    cold = _core.ml_refine(full["R"], full["t"], a1, a2, T, **kw)
    lean = _core.ml_refine(full["R"], full["t"], a1, a2, T, **kw, pose_only=True)
    assert np.array_equal(lean["R"], cold["R"]) and np.array_equal(lean["t"], cold["t"]) and lean["rounds"] == cold["rounds"]
    assert lean["posterior"].shape == (len(a1),)
    for key in ("decision", "decision_gauss", "sigma_gauss", "log_likelihood"):  # not computed: NaN, never a number
        assert np.isnan(lean[key]), key
    warm = _core.ml_refine(full["R"], full["t"], a1, a2, T, **kw, sigma_init=full["sigma"], g_init=full["inlier_fraction"])
    assert rotation_error_deg(warm["R"], cold["R"]) < 1e-6
    assert np.linalg.norm(warm["t"] - cold["t"]) < 1e-7
    assert warm["sigma"] == pytest.approx(cold["sigma"], rel=1e-4)


def test_warm_start_is_checked():
    sc = make_scene(60, "normal", "pinhole", 0.5, 0.0, 0)
    args = (sc.R, sc.t, sc.f1, sc.f2, T_PX / sc.K[0, 0])
    with pytest.raises(ValueError, match="together"):
        _core.ml_refine(*args, sigma_init=1e-3)
    with pytest.raises(ValueError, match="sigma_init"):
        _core.ml_refine(*args, sigma_init=-1.0, g_init=0.5)
    with pytest.raises(ValueError, match="g_init"):
        _core.ml_refine(*args, sigma_init=1e-3, g_init=1.0)
