"""numpy reference of the core's ``pose_covariance`` (``src/core/refine.cpp``): the first-order
covariance ``sigma^2 (J^T J)^-1`` of a pose from the Sampson errors of its inliers, ``J`` by central
differences in the chart of the Sampson LM (``R = exp([w]x) R0``, ``t = normalize(t0 + B v)``).

Shapes: ``R (3, 3)``, ``t (3,)`` or None (a rotation without translation: the chord residuals
``R f1 - f2`` in the tangent plane of ``f2``), ``f1, f2 (n, 3)``, ``w (n,)``; covariances ``(3, 3)``.
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import brentq
from scipy.special import erf

from poseonly.geometry import cross, rotation_from_rotvec
from poseonly.refine._manifold import tangent_basis
from poseonly.sfm.edge_information import signed_sampson

MAD_TO_SIGMA = 1.4826
RAYLEIGH_MEDIAN = np.sqrt(2.0 * np.log(2.0))
# central differences: residuals of 1e-4-1e-2 rad, second derivatives of order 1, so truncation ~STEP^2
# and rounding ~1e-16 / STEP stay below 1e-9 relative
STEP = 1e-6


def _jacobian(fun, k: int) -> np.ndarray:
    cols = []
    for a in range(k):
        e = np.zeros(k)
        e[a] = STEP
        cols.append((fun(e) - fun(-e)) / (2.0 * STEP))
    return np.stack(cols, axis=1)


def _chords(R: np.ndarray, f1: np.ndarray, f2: np.ndarray) -> np.ndarray:
    """``(2m,)`` the chord ``R f1 - f2`` in two tangent directions of ``f2`` per match."""
    a = np.where(np.abs(f2[:, :1]) < 0.9, np.array([[1.0, 0.0, 0.0]]), np.array([[0.0, 1.0, 0.0]]))
    u = cross(f2, a)
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    v = cross(f2, u)
    d = f1 @ R.T - f2
    return np.concatenate([np.einsum("ij,ij->i", d, u), np.einsum("ij,ij->i", d, v)])


def _below(x: float, chords: bool) -> float:
    return float(-np.expm1(-0.5 * x * x)) if chords else float(erf(x / np.sqrt(2.0)))


def _scale(med: float, threshold: float, chords: bool) -> float:
    """sigma from the median ``med`` of errors: untruncated (threshold 0) or truncated at ``threshold``
    (the root of F(q a) = F(a) / 2, a = threshold / sigma; inf where there is none)."""
    if threshold <= 0:
        return med / RAYLEIGH_MEDIAN if chords else MAD_TO_SIGMA * med
    q = med / threshold

    def g(a: float) -> float:
        return _below(q * a, chords) - 0.5 * _below(a, chords)

    if not g(1e-3) < 0:
        return float("inf")
    return threshold / brentq(g, 1e-3, 1e3, xtol=1e-14, rtol=1e-13)


def pose_covariance(R, t, f1, f2, w=None, threshold: float = 0.0, noise_floor: float = 0.0) -> tuple[np.ndarray, np.ndarray, float]:
    """``(rotation covariance, translation covariance, sigma)``, as the core's (without its checks); the
    covariances carry the small-sample factor ``k / (k - p)`` (k residuals, p parameters); a finite sigma
    is at least ``noise_floor sqrt(max w)`` (Sampson errors; ``sqrt(2)`` times it for chords): the floor of
    the highest-weight match's raw errors."""
    w = np.ones(len(f1)) if w is None else np.asarray(w, float)
    keep = w > 0
    f1, f2, sw = f1[keep], f2[keep], np.sqrt(w[keep])
    if t is None:
        m = len(f1)

        def res(p: np.ndarray) -> np.ndarray:
            return np.tile(sw, 2) * _chords(rotation_from_rotvec(p) @ R, f1, f2)

        r = res(np.zeros(3))
        sigma = _scale(float(np.median(np.hypot(r[:m], r[m:]))), threshold, True)
        if np.isfinite(sigma):  # (the floor on the highest-weight match's raw errors)
            sigma = max(sigma, np.sqrt(2.0) * noise_floor * float(np.sqrt(w.max())))
        J = _jacobian(res, 3)
        return sigma**2 * 2 * m / (2 * m - 3) * np.linalg.inv(J.T @ J), np.zeros((3, 3)), sigma
    tu = np.asarray(t, float) / np.linalg.norm(t)
    B = tangent_basis(tu)

    def pose(p: np.ndarray) -> np.ndarray:
        tp = tu + B @ p[3:]
        return sw * signed_sampson(rotation_from_rotvec(p[:3]) @ R, tp / np.linalg.norm(tp), f1, f2)

    sigma = _scale(float(np.median(np.abs(pose(np.zeros(5))))), threshold, False)
    if np.isfinite(sigma):
        sigma = max(sigma, noise_floor * float(np.sqrt(w.max())))
    J = _jacobian(pose, 5)
    m = len(f1)
    C = sigma**2 * m / (m - 5) * np.linalg.inv(J.T @ J)
    return C[:3, :3], B @ C[3:, 3:] @ B.T, sigma
