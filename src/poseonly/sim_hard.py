"""Hard synthetic two-view cases seen on real images (issue 12), for regression tests.

All generators use the 640x480, ``f = 800`` pinhole camera of :mod:`poseonly.sim`, return pixel
matches with Gaussian noise of ``noise_px`` per axis (default 0.3 px, the level of real SIFT
matches) and are seeded (``seed``: int or ``numpy`` Generator). Camera 1 is the world frame; the
truth is ``X2 = R X1 + t`` with unit ``t``.

* :func:`repetitive_texture` -- a facade with relief; part of its features are matched to the
  feature one period along the facade (windows, floors). Those matches are *exactly* consistent with
  a second, wrong geometry (camera 2 displaced by the period), not random.
* :func:`second_motion` -- a static scene plus an independently moving rigid object (a car) whose
  matches obey their own epipolar geometry.
* :func:`critical_surface` -- points on a critical surface: a second pose fits every match exactly,
  with every point in front of both cameras under both.
* :func:`low_parallax` -- a small baseline: the rays meet at ~1-2 deg at the scene centre, so the
  translation is weakly determined and the rotation must not pay for it.

Every case carries ``group (n,)``: ``0`` true inliers, ``1`` structured outliers (consistent with
``R_wrong, t_wrong``), ``2`` random outliers (uniform in both images).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .geometry import normalize, rotation_from_rotvec
from .sim import FOCAL, HEIGHT, WIDTH, default_K

__all__ = ["NOISE_PX", "HardCase", "critical_surface", "low_parallax", "repetitive_texture", "second_motion", "structured_first_scores"]

NOISE_PX = 0.3  # real SIFT keypoint noise (px per axis)
INLIER, STRUCTURED, RANDOM = 0, 1, 2
_MAX_DRAWS = 200


@dataclass(frozen=True)
class HardCase:
    """Pixel matches ``u1, u2 (n, 2)`` with calibration ``K (3, 3)``, the true pose ``R (3, 3)``,
    unit ``t (3,)``, ``group (n,)`` (0 inlier, 1 structured outlier, 2 random outlier) and, where the
    structured outliers obey one (or, on a critical surface, every match does), the wrong geometry
    ``R_wrong, t_wrong`` (unit; else ``None``).
    ``parallax_deg`` is the median angle between the two rays of the true inliers."""

    u1: np.ndarray
    u2: np.ndarray
    K: np.ndarray
    R: np.ndarray
    t: np.ndarray
    group: np.ndarray
    R_wrong: np.ndarray | None
    t_wrong: np.ndarray | None
    parallax_deg: float
    kind: str

    @property
    def inliers(self) -> np.ndarray:
        """``(n,)`` bool: the true inliers."""
        return self.group == INLIER

    @property
    def n(self) -> int:
        return len(self.u1)


def _rng(seed: int | np.random.Generator | None) -> np.random.Generator:
    return seed if isinstance(seed, np.random.Generator) else np.random.default_rng(seed)


def _look_at(C: np.ndarray, target: np.ndarray, rng: np.random.Generator, jitter_deg: float) -> np.ndarray:
    """World -> camera rotation of a camera at ``C (3,)`` looking at ``target (3,)`` (y down), with
    a random extra rotation of ``jitter_deg`` (std, per axis)."""
    z = normalize(target - C)
    x = normalize(np.cross(np.array([0.0, -1.0, 0.0]), z))
    y = np.cross(z, x)
    Rwc = np.stack([x, y, z], axis=1)
    return (Rwc @ rotation_from_rotvec(rng.normal(0.0, np.radians(jitter_deg), 3))).T


def _project(K: np.ndarray, R: np.ndarray, C: np.ndarray, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Pixels ``(m, 2)`` of world points ``X (m, 3)`` in the camera ``(R, C)`` and a visibility mask
    (in front of the camera and inside the image)."""
    P = (X - C) @ R.T
    with np.errstate(divide="ignore", invalid="ignore"):
        p = P @ K.T
        u = p[:, :2] / p[:, 2:3]
    vis = (P[:, 2] > 0.1) & (u[:, 0] >= 0) & (u[:, 0] < WIDTH) & (u[:, 1] >= 0) & (u[:, 1] < HEIGHT)
    return u, vis


def _draw(rng: np.random.Generator, m: int, sampler, keep) -> np.ndarray:
    """``m`` rows of ``sampler(rng, k) -> (k, 3)`` that pass ``keep(X) -> (k,)`` bool."""
    out, got = [], 0
    for _ in range(_MAX_DRAWS):
        X = sampler(rng, max(4 * m, 64))
        X = X[keep(X)]
        out.append(X)
        got += len(X)
        if got >= m:
            return np.concatenate(out)[:m]
    raise RuntimeError("could not draw enough visible points; the requested geometry is too restrictive")


def _random_matches(rng: np.random.Generator, m: int) -> tuple[np.ndarray, np.ndarray]:
    size = np.array([WIDTH, HEIGHT], float)
    return rng.uniform(0, 1, (m, 2)) * size, rng.uniform(0, 1, (m, 2)) * size


def _parallax_deg(X: np.ndarray, C: np.ndarray) -> float:
    a, b = normalize(X), normalize(X - C)
    return float(np.degrees(np.median(np.arccos(np.clip(np.sum(a * b, axis=1), -1.0, 1.0)))))


def _finish(rng, kind, K, R, C, groups: list[tuple[np.ndarray, np.ndarray, int]], noise_px, R_wrong, t_wrong, X_in) -> HardCase:
    """Stack the groups ``(u1, u2, label)``, add the noise, shuffle, and express the truth as ``(R, t)``."""
    u1 = np.concatenate([g[0] for g in groups])
    u2 = np.concatenate([g[1] for g in groups])
    group = np.concatenate([np.full(len(g[0]), g[2]) for g in groups])
    if noise_px < 0:
        raise ValueError(f"noise_px must be >= 0, got {noise_px}")
    u1 = u1 + noise_px * rng.standard_normal(u1.shape)
    u2 = u2 + noise_px * rng.standard_normal(u2.shape)
    perm = rng.permutation(len(u1))
    t = normalize(-R @ C)
    tw = None if t_wrong is None else normalize(t_wrong)
    return HardCase(u1[perm], u2[perm], K, R, t, group[perm], R_wrong, tw, _parallax_deg(X_in, C), kind)


def _check_counts(**counts: int) -> None:
    for name, v in counts.items():
        if not isinstance(v, (int, np.integer)) or v < 0:
            raise ValueError(f"{name} must be a non-negative integer, got {v!r}")


def repetitive_texture(
    n_inliers: int = 150,
    n_repeated: int = 90,
    n_random: int = 160,
    period: tuple[float, float, float] = (0.0, 0.8, 0.0),
    baseline: float = 1.2,
    noise_px: float = NOISE_PX,
    seed: int | np.random.Generator | None = 0,
) -> HardCase:
    """A facade (x in [-3, 3], y in [-2.2, 2.2], depth 8 +- 1 relief) seen from two views ``baseline``
    apart (mostly sideways), camera 2 aimed at the facade centre.

    ``n_repeated`` features at ``X`` in view 1 are matched to the feature at ``X + period`` in view 2
    (a repeated window one floor up, by default): ``X2 = R (X + period - C)`` -- exactly the
    geometry ``R_wrong = R``, ``t_wrong = -R (C - period)`` of a camera displaced by ``-period``. The
    period is chosen across the baseline so that the wrong translation differs from the true one
    (a period along the baseline leaves the essential matrix unchanged).
    """
    _check_counts(n_inliers=n_inliers, n_repeated=n_repeated, n_random=n_random)
    rng = _rng(seed)
    K = default_K()
    s = np.asarray(period, float)
    C = baseline * normalize(np.array([1.0, rng.normal(0, 0.15), rng.normal(0, 0.15)]))
    R = _look_at(C, np.array([0.0, 0.0, 8.0]), rng, jitter_deg=2.0)
    I3, O3 = np.eye(3), np.zeros(3)

    def facade(r: np.random.Generator, m: int) -> np.ndarray:
        return np.column_stack([r.uniform(-3, 3, m), r.uniform(-2.2, 2.2, m), 8.0 + r.uniform(-1.0, 1.0, m)])

    def seen(shift: np.ndarray):
        return lambda X: _project(K, I3, O3, X)[1] & _project(K, R, C, X + shift)[1]

    Xi = _draw(rng, n_inliers, facade, seen(np.zeros(3)))
    Xr = _draw(rng, n_repeated, facade, seen(s)) if n_repeated else np.zeros((0, 3))
    ga = (_project(K, I3, O3, Xi)[0], _project(K, R, C, Xi)[0], INLIER)
    gb = (_project(K, I3, O3, Xr)[0], _project(K, R, C, Xr + s)[0], STRUCTURED)
    gc = (*_random_matches(rng, n_random), RANDOM)
    return _finish(rng, "repetitive_texture", K, R, C, [ga, gb, gc], noise_px, R.copy(), -R @ (C - s), Xi)


def second_motion(
    n_static: int = 180,
    n_moving: int = 120,
    n_random: int = 100,
    object_rotation_deg: float = 12.0,
    object_translation: tuple[float, float, float] = (0.6, 0.0, -0.8),
    baseline: float = 1.0,
    noise_px: float = NOISE_PX,
    seed: int | np.random.Generator | None = 0,
) -> HardCase:
    """A static scene (x in [-4, 4], y in [-3, 3], depth 6-14) and a rigid object (a 1.6 x 1.0 x 1.2
    box centred at (0.8, 0.6, 7)) that rotates by ``object_rotation_deg`` about its vertical axis and
    translates by ``object_translation`` between the views while camera 2 moves ``baseline`` forward
    and sideways.

    Object points move as ``X' = R_o (X - c) + c + t_o``, so their matches obey the second geometry
    ``R_wrong = R R_o``, ``t_wrong = R (c + t_o - R_o c - C)``.
    """
    _check_counts(n_static=n_static, n_moving=n_moving, n_random=n_random)
    rng = _rng(seed)
    K = default_K()
    C = baseline * normalize(np.array([1.0, rng.normal(0, 0.1), 0.6]))
    R = _look_at(C, np.array([0.0, 0.0, 10.0]), rng, jitter_deg=2.0)
    Ro = rotation_from_rotvec(np.array([0.0, np.radians(object_rotation_deg), 0.0]))
    c = np.array([0.8, 0.6, 7.0])
    to = np.asarray(object_translation, float)
    half = np.array([0.8, 0.5, 0.6])
    I3, O3 = np.eye(3), np.zeros(3)

    def static(r: np.random.Generator, m: int) -> np.ndarray:
        return np.column_stack([r.uniform(-4, 4, m), r.uniform(-3, 3, m), r.uniform(6, 14, m)])

    def box(r: np.random.Generator, m: int) -> np.ndarray:
        return c + r.uniform(-1, 1, (m, 3)) * half

    def moved(X: np.ndarray) -> np.ndarray:
        return (X - c) @ Ro.T + c + to

    def inside_box(X: np.ndarray) -> np.ndarray:
        return np.all(np.abs(X - c) <= half, axis=1)

    Xs = _draw(rng, n_static, static, lambda X: ~inside_box(X) & _project(K, I3, O3, X)[1] & _project(K, R, C, X)[1])
    Xm = _draw(rng, n_moving, box, lambda X: _project(K, I3, O3, X)[1] & _project(K, R, C, moved(X))[1]) if n_moving else np.zeros((0, 3))
    ga = (_project(K, I3, O3, Xs)[0], _project(K, R, C, Xs)[0], INLIER)
    gb = (_project(K, I3, O3, Xm)[0], _project(K, R, C, moved(Xm))[0], STRUCTURED)
    gc = (*_random_matches(rng, n_random), RANDOM)
    return _finish(rng, "second_motion", K, R, C, [ga, gb, gc], noise_px, R @ Ro, R @ (c + to - Ro @ c - C), Xs)


def low_parallax(
    n: int = 400,
    parallax_deg: float = 1.5,
    outlier_fraction: float = 0.5,
    rotation_deg: float = 8.0,
    noise_px: float = NOISE_PX,
    seed: int | np.random.Generator | None = 0,
) -> HardCase:
    """Points at depth 6-14 filling view 1; camera 2 displaced by ``10 tan(parallax_deg)`` in a random
    direction (for a sideways motion the rays meet at ``parallax_deg`` at the scene centre, depth 10; the
    realised median is ``case.parallax_deg``) and rotated by
    about ``rotation_deg`` towards the scene. ``floor(outlier_fraction * n)`` matches are random."""
    if not 0.0 <= outlier_fraction < 1.0:
        raise ValueError(f"outlier_fraction must be in [0, 1), got {outlier_fraction}")
    if not parallax_deg > 0:
        raise ValueError(f"parallax_deg must be > 0, got {parallax_deg}")
    _check_counts(n=n)
    rng = _rng(seed)
    K = default_K()
    k = int(np.floor(outlier_fraction * n))
    C = 10.0 * np.tan(np.radians(parallax_deg)) * normalize(rng.standard_normal(3) * np.array([1.0, 1.0, 0.5]))
    target = np.array([0.0, 0.0, 10.0]) + normalize(rng.standard_normal(3) * [1, 1, 0]) * 10.0 * np.tan(np.radians(rotation_deg))
    R = _look_at(C, target, rng, jitter_deg=1.0)
    I3, O3 = np.eye(3), np.zeros(3)

    def pts(r: np.random.Generator, m: int) -> np.ndarray:
        u = np.column_stack([r.uniform(0, WIDTH, m), r.uniform(0, HEIGHT, m)])
        d = r.uniform(6.0, 14.0, m)
        return np.column_stack([(u - [WIDTH / 2, HEIGHT / 2]) / FOCAL, np.ones(m)]) * d[:, None]

    X = _draw(rng, n - k, pts, lambda Y: _project(K, I3, O3, Y)[1] & _project(K, R, C, Y)[1])
    ga = (_project(K, I3, O3, X)[0], _project(K, R, C, X)[0], INLIER)
    gc = (*_random_matches(rng, k), RANDOM)
    return _finish(rng, "low_parallax", K, R, C, [ga, gc], noise_px, None, None, X)


def _midpoint_depths(R: np.ndarray, t: np.ndarray, f1: np.ndarray, f2: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Depths ``(l1, l2)`` along ``f1, f2 (m, 3)`` with ``l2 f2 ~ l1 R f1 + t`` (least squares)."""
    a = f1 @ R.T
    aa, ff, af = np.sum(a * a, 1), np.sum(f2 * f2, 1), np.sum(a * f2, 1)
    at, ft = a @ t, f2 @ t
    den = aa * ff - af * af
    with np.errstate(divide="ignore", invalid="ignore"):
        return (-at * ff + af * ft) / den, (aa * ft - af * at) / den


def critical_surface(
    n: int = 200,
    separation_deg: tuple[float, float] = (8.0, 20.0),
    noise_px: float = NOISE_PX,
    seed: int | np.random.Generator | None = 0,
) -> HardCase:
    """Points on a critical surface of the two views: every match fits the true pose ``(R, t)`` and a
    second pose ``(R_wrong, t_wrong)``, its rotation ``separation_deg`` (a range) away, exactly, with
    every point in front of both cameras under both (the 9-column epipolar system of the noise-free
    matches has a 2-D null space). Two views cannot tell the two apart; the honest status is not ``ok``.

    Each ray ``X = s d`` of view 1 meets the quadric ``(R X + b)^T [t']x R' X = 0`` at ``s = -(b^T E' d)
    / (d^T R^T E' d)`` (``E' = [t']x R'``, ``b = -R C`` the translation at the true baseline); kept are the
    points at depth 2-40 in view 1, in both images and in front of both cameras under both poses (``t'``
    with the sign most points take). Camera 2 sits 0.5-2 from camera 1, looking at the point 8 ahead;
    ``group`` is all inliers."""
    lo, hi = (float(v) for v in separation_deg)
    if not 0.0 < lo <= hi < 180.0:
        raise ValueError(f"separation_deg must be a range in (0, 180), got {separation_deg}")
    _check_counts(n=n)
    rng = _rng(seed)
    K, I3, O3 = default_K(), np.eye(3), np.zeros(3)
    for _ in range(_MAX_DRAWS):
        C = normalize(rng.standard_normal(3) * np.array([1.0, 1.0, 0.3])) * rng.uniform(0.5, 2.0)
        R = _look_at(C, np.array([0.0, 0.0, 8.0]), rng, jitter_deg=3.0)
        t = normalize(-R @ C)
        R2 = rotation_from_rotvec(normalize(rng.standard_normal(3)) * np.radians(rng.uniform(lo, hi))) @ R
        t2 = normalize(t + rng.normal(0.0, rng.uniform(0.1, 1.0), 3))
        E2 = np.array([[0.0, -t2[2], t2[1]], [t2[2], 0.0, -t2[0]], [-t2[1], t2[0], 0.0]]) @ R2  # [t2]x R2
        m = 40 * n
        u = np.column_stack([rng.uniform(0, WIDTH, m), rng.uniform(0, HEIGHT, m)])
        d = np.column_stack([(u - [WIDTH / 2, HEIGHT / 2]) / FOCAL, np.ones(m)])
        with np.errstate(divide="ignore", invalid="ignore"):
            s_ray = -(d @ (E2.T @ (-R @ C))) / np.einsum("ij,jk,ik->i", d, R.T @ E2, d)
        X = d * s_ray[:, None]
        keep = np.isfinite(s_ray) & (s_ray > 2.0) & (s_ray < 40.0)
        keep &= _project(K, I3, O3, np.where(keep[:, None], X, 1.0))[1] & _project(K, R, C, np.where(keep[:, None], X, 1.0))[1]
        X = X[keep]
        f1, f2 = normalize(X), normalize(X @ R.T - R @ C)
        l1, l2 = _midpoint_depths(R2, t2, f1, f2)
        front, back = (l1 > 0) & (l2 > 0), (l1 < 0) & (l2 < 0)
        if np.count_nonzero(back) > np.count_nonzero(front):
            t2, front = -t2, back
        X = X[front]
        if len(X) >= n:
            X = X[:n]
            g = (_project(K, I3, O3, X)[0], _project(K, R, C, X)[0], INLIER)
            return _finish(rng, "critical_surface", K, R, C, [g], noise_px, R2, t2, X)
    raise RuntimeError("could not draw a critical surface with enough visible points")


def structured_first_scores(case: HardCase, seed: int | np.random.Generator | None = 0) -> np.ndarray:
    """Match scores ``(n,)`` (higher is better, as ``estimate_relative_pose(..., scores=)`` takes them)
    that rank ``case``'s structured outliers first: structured ``U(0.5, 1)``, true inliers ``U(0, 1)``,
    random outliers ``U(0, 0.5)``. Informative against the random matches, misleading about the
    repeated structure: the order a ratio test gives a repeated facade's matches when its keypoints are
    coarse (ORB on Strecha's entry-P10 and fountain-P11, docs/RESULTS_real.md, "Other front-ends")."""
    rng = _rng(seed)
    lo = np.where(case.group == STRUCTURED, 0.5, 0.0)
    hi = np.where(case.group == RANDOM, 0.5, 1.0)
    return lo + (hi - lo) * rng.uniform(0.0, 1.0, case.n)
