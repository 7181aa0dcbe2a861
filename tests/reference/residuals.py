"""numpy reference (oracle for tests) of the core's residuals: per-correspondence residuals of Section 4 of the paper, vectorized over points and hypotheses.

Every residual has the signature ``(R, t, f1, f2) -> v`` with ``R (..., 3, 3)``, ``t (..., 3)``,
bearings ``f1, f2 (n, 3)`` (or ``(..., n, 3)``) and returns ``v (..., n)``: one call scores ``h``
stacked hypotheses against all points. Bearings are unit vectors; ``t`` is normalized to unit length
inside each residual, because v_LiGT, v_E and v_PPO are homogeneous in ``t`` and thresholds are only
meaningful for a fixed scale (the paper does not say; notes section 3).

Convention: ``X2 = R X1 + t``, ``E = [t]x R``, ``f2^T E f1 = 0``.
"""

from __future__ import annotations

from typing import Callable

import numpy as np

from poseonly.geometry import cross, normalize, skew, triangulate_midpoint

__all__ = [
    "v_E",
    "v_BA",
    "v_OpenGV",
    "v_LiGT",
    "v_PPO",
    "v_sampson",
    "RESIDUALS",
    "get_residual",
    "ligt_depths",
]

Residual = Callable[[np.ndarray, np.ndarray, np.ndarray, np.ndarray], np.ndarray]


def _rot(R: np.ndarray, f1: np.ndarray) -> np.ndarray:
    """``R f1`` for every point and hypothesis: ``(..., n, 3)``."""
    return np.einsum("...ij,...nj->...ni", R, f1)


def _unit_t(t: np.ndarray) -> np.ndarray:
    return normalize(np.asarray(t, dtype=float))[..., None, :]


def v_E(R: np.ndarray, t: np.ndarray, f1: np.ndarray, f2: np.ndarray) -> np.ndarray:
    """Coplanar residual ``|f2^T [t]x R f1|`` (Eq. 4 in bearing form), unit ``t``."""
    Rf1 = _rot(R, f1)
    return np.abs(np.sum(cross(_unit_t(t), Rf1) * f2, axis=-1))


def v_sampson(R: np.ndarray, t: np.ndarray, f1: np.ndarray, f2: np.ndarray) -> np.ndarray:
    """Sampson distance on the unit sphere (first-order geometric epipolar error, radians).

    ``|f2^T E f1| / sqrt(|P_f2 E f1|^2 + |P_f1 E^T f2|^2)`` with tangent projections
    ``P_f = I - f f^T``; the residual PoseLib and COLMAP threshold (after scaling by the focal
    length). Not one of the paper's five residuals; used for pixel-calibrated inlier decisions.
    Written as two matrix products per hypothesis (the hot path of RANSAC scoring).
    """
    E = np.einsum("...ij,...jk->...ik", skew(normalize(np.asarray(t, dtype=float))), R)
    f1 = np.asarray(f1, dtype=float)
    f2 = np.asarray(f2, dtype=float)
    Ef1 = np.matmul(E, np.swapaxes(f1, -1, -2))  # (..., 3, n)
    Etf2 = np.matmul(np.swapaxes(E, -1, -2), np.swapaxes(f2, -1, -2))
    num = np.sum(Ef1 * np.swapaxes(f2, -1, -2), axis=-2)
    num2 = num * num
    den = np.sum(Ef1 * Ef1, axis=-2) + np.sum(Etf2 * Etf2, axis=-2) - 2.0 * num2
    return np.abs(num) / np.sqrt(np.maximum(den, 1e-300))


def ligt_depths(R: np.ndarray, t: np.ndarray, f1: np.ndarray, f2: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Pose-only depth numerators ``h_i^T t``, ``h'_i^T t`` and ``theta_i^2`` (the equation after Eq. 7).

    ``h_i^T t = (R f1 x f2) . (f2 x t)`` and ``h'_i^T t = (R f1 x f2) . (R f1 x t)``; the depths are
    ``z1 = h^T t / theta^2`` and ``z2 = h'^T t / theta^2`` with ``theta = ||f2 x R f1||``.
    """
    tt = _unit_t(t)
    Rf1 = _rot(R, f1)
    c = cross(Rf1, f2)
    h = np.sum(c * cross(f2, tt), axis=-1)
    hp = np.sum(c * cross(Rf1, tt), axis=-1)
    return h, hp, np.sum(c * c, axis=-1)


def v_LiGT(R: np.ndarray, t: np.ndarray, f1: np.ndarray, f2: np.ndarray) -> np.ndarray:
    """LiGT residual ``||L_i t||`` (Eq. 8 with unit bearings and unit ``t``).

    ``L_i t = [f2]x R f1 (h_i^T t) + theta_i^2 [f2]x t`` (notes section 3: equals
    ``theta^2 * f2 x (z1 R f1 + t)``, a parallax-weighted reprojection error). Evaluated as
    ``theta_i |f2^T [t]x R f1|`` (Lagrange identity; equal to the vector form to rounding): the
    sine of the parallax times the algebraic epipolar error.
    """
    # ||L t|| = |c| |c . t| with c = [f2]x R f1: |c|^2 = theta^2 and the Lagrange identity
    # |c|^2 |f2 x t|^2 - (c . (f2 x t))^2 = (c . t)^2 (c is orthogonal to f2)
    tt = _unit_t(t)
    a = _rot(R, f1)
    f2 = np.asarray(f2, dtype=float)
    g0, g1, g2 = f2[..., 0], f2[..., 1], f2[..., 2]
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    c0 = g1 * a2 - g2 * a1
    c1 = g2 * a0 - g0 * a2
    c2 = g0 * a1 - g1 * a0
    ct = c0 * tt[..., 0] + c1 * tt[..., 1] + c2 * tt[..., 2]
    return np.sqrt(c0 * c0 + c1 * c1 + c2 * c2) * np.abs(ct)


def v_PPO(R: np.ndarray, t: np.ndarray, f1: np.ndarray, f2: np.ndarray) -> np.ndarray:
    """Pairwise pose-only residual ``||eps~_i - f2_i||`` (Eq. 7, Section 4).

    ``eps_i = ||t x f2|| R f1 + ||f2 x R f1|| t``: the right-view bearing predicted by the pose-only
    depths. Sign-blind in the depths (chirality is handled by :mod:`poseonly.identify`).
    """
    tt = _unit_t(t)
    Rf1 = _rot(R, f1)
    a = np.linalg.norm(cross(tt, f2), axis=-1)[..., None]
    b = np.linalg.norm(cross(f2, Rf1), axis=-1)[..., None]
    eps = a * Rf1 + b * tt
    return np.linalg.norm(normalize(eps) - f2, axis=-1)


def v_BA(R: np.ndarray, t: np.ndarray, f1: np.ndarray, f2: np.ndarray) -> np.ndarray:
    """Reprojection residual after midpoint triangulation (Section 4, v^BA).

    The triangulated point is projected into view 2 and compared with the observation on the
    tangent plane at ``f2``: ``|| eps / (f2 . eps) - f2 ||`` with ``eps = R X1 + t``. For a ray on
    the optical axis this is exactly the paper's ``||eps / e3^T eps - x'||`` in normalized image
    coordinates; the tangent-plane form stays defined for wide-angle bearings (decision: the paper
    uses ``e3``, which is undefined for rays at 90 degrees). A point reconstructed behind camera 2
    (``f2 . eps <= 0``) gets the residual 2 (a gross error).
    """
    tt = _unit_t(t)
    X1, _, _ = triangulate_midpoint(R, tt[..., 0, :], f1, f2)
    eps = _rot(R, X1) + tt
    d = np.sum(eps * f2, axis=-1)
    ok = d > 1e-12
    proj = eps / np.where(ok, d, 1.0)[..., None]
    r = np.linalg.norm(proj - f2, axis=-1)
    return np.where(ok, r, 2.0)


def v_OpenGV(R: np.ndarray, t: np.ndarray, f1: np.ndarray, f2: np.ndarray, symmetric: bool = False) -> np.ndarray:
    """OpenGV residual ``1 - eps~^T f2`` with ``eps = R X1 + t`` of the midpoint-triangulated point.

    ``symmetric=True`` gives OpenGV's actual SAC score ``(1 - f1 . r1) + (1 - f2 . r2)`` (both views,
    ``CentralRelativePoseSacProblem::getSelectedDistancesToModel``).
    """
    tt = _unit_t(t)
    X1, _, _ = triangulate_midpoint(R, tt[..., 0, :], f1, f2)
    eps = _rot(R, X1) + tt
    r = 1.0 - np.sum(normalize(eps) * f2, axis=-1)
    if symmetric:
        r = r + 1.0 - np.sum(normalize(X1) * f1, axis=-1)
    return r


def v_sampson_chiral(R: np.ndarray, t: np.ndarray, f1: np.ndarray, f2: np.ndarray) -> np.ndarray:
    """Sampson distance where the pose-only depths are positive, ``1`` (a gross error) elsewhere.

    Sampson's distance only sees ``E`` and so cannot tell a pose from its twisted pair, its
    ``-t`` or a planar scene's homography twin; the depth signs ``h^T t > 0`` and ``h'^T t > 0``
    (:func:`ligt_depths`) can. Used as the local-optimisation objective of the default method.
    """
    h, hp, _ = ligt_depths(R, t, f1, f2)
    return np.where((h > 0) & (hp > 0), v_sampson(R, t, f1, f2), 1.0)


RESIDUALS: dict[str, Residual] = {
    "ligt": v_LiGT,
    "ppo": v_PPO,
    "coplanar": v_E,
    "ba": v_BA,
    "opengv": v_OpenGV,
    "sampson": v_sampson,
    "sampson-chiral": v_sampson_chiral,
}
_ALIASES = {"e": "coplanar", "v_e": "coplanar", "v_ligt": "ligt", "v_ppo": "ppo", "v_ba": "ba", "v_opengv": "opengv", "reprojection": "ba"}


def get_residual(name: str | Residual) -> Residual:
    """Residual function by name (``ligt``, ``ppo``, ``coplanar``, ``ba``, ``opengv``, ``sampson``) or callable."""
    if callable(name):
        return name
    key = str(name).lower()
    key = _ALIASES.get(key, key)
    if key not in RESIDUALS:
        raise ValueError(f"unknown residual {name!r}; choose one of {sorted(RESIDUALS)}")
    return RESIDUALS[key]
