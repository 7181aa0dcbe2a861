"""Geometry core: bearings, skew matrices, essential decomposition, triangulation, errors.

Conventions (used everywhere in poseonly, the paper's Eq. (1) and OpenCV ``recoverPose``):

* a point ``X1`` in camera 1's frame maps to ``X2 = R @ X1 + t`` in camera 2's frame;
* ``E = [t]x R`` and ``f2^T E f1 = 0`` for corresponding bearings ``f1`` (view 1), ``f2`` (view 2);
* ``t`` is returned with unit norm (the scale is unobservable from two views).

All functions accept leading batch dimensions where it makes sense (``(..., 3, 3)`` rotations,
``(..., n, 3)`` bearings) and never loop in Python over points.
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "InputError",
    "skew",
    "cross",
    "normalize",
    "bearings_from_pixels",
    "bearings_from_normalized",
    "as_bearings",
    "check_correspondences",
    "check_intrinsics",
    "essential_from_pose",
    "decompose_essential",
    "essential_frames",
    "triangulate_midpoint",
    "rotation_angle_deg",
    "rotation_error_deg",
    "translation_error_deg",
    "project_to_so3",
    "rotation_from_rotvec",
]


class InputError(ValueError):
    """Invalid input (shape, NaN/inf, zero vectors, too few points, bad options).

    Subclass of :class:`ValueError`, so ``except ValueError`` catches it.
    """


# --------------------------------------------------------------------------------------------
# small helpers


def skew(v: np.ndarray) -> np.ndarray:
    """Skew-symmetric matrix ``[v]x`` with ``[v]x @ u == cross(v, u)``; ``(..., 3) -> (..., 3, 3)``."""
    v = np.asarray(v, dtype=float)
    z = np.zeros(v.shape[:-1])
    return np.stack(
        [
            np.stack([z, -v[..., 2], v[..., 1]], axis=-1),
            np.stack([v[..., 2], z, -v[..., 0]], axis=-1),
            np.stack([-v[..., 1], v[..., 0], z], axis=-1),
        ],
        axis=-2,
    )


def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Broadcasting cross product over the last axis (several times faster than ``np.cross`` on
    small stacked arrays, which pays for ``moveaxis`` on every call)."""
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    return np.stack([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0], axis=-1)


def normalize(v: np.ndarray, axis: int = -1) -> np.ndarray:
    """Unit vectors along ``axis`` (zero vectors stay zero)."""
    v = np.asarray(v, dtype=float)
    nrm = np.linalg.norm(v, axis=axis, keepdims=True)
    return v / np.where(nrm > 0, nrm, 1.0)


def rotation_from_rotvec(rv: np.ndarray) -> np.ndarray:
    """Rodrigues: rotation vector ``(..., 3)`` -> rotation matrix ``(..., 3, 3)``."""
    rv = np.asarray(rv, dtype=float)
    th = np.linalg.norm(rv, axis=-1)[..., None, None]
    K = skew(rv)
    small = th < 1e-8
    ths = np.where(small, 1.0, th)
    a = np.where(small, 1.0 - th**2 / 6.0, np.sin(ths) / ths)
    b = np.where(small, 0.5 - th**2 / 24.0, (1.0 - np.cos(ths)) / ths**2)
    return np.eye(3) + a * K + b * (K @ K)


def project_to_so3(M: np.ndarray) -> np.ndarray:
    """Nearest rotation (Frobenius) to ``M`` ``(..., 3, 3)`` via SVD."""
    U, _, Vt = np.linalg.svd(np.asarray(M, dtype=float))
    d = np.sign(np.linalg.det(U @ Vt))
    D = np.ones(U.shape[:-1])
    D[..., 2] = d
    return (U * D[..., None, :]) @ Vt


# --------------------------------------------------------------------------------------------
# input normalisation and validation


def _check_finite_2d(a: np.ndarray, name: str) -> np.ndarray:
    try:
        a = np.asarray(a, dtype=float)
    except (TypeError, ValueError) as exc:
        raise InputError(f"{name} must be a numeric array ({exc})") from None
    if a.ndim != 2 or a.shape[1] not in (2, 3):
        raise InputError(f"{name} must have shape (n, 2) or (n, 3), got {a.shape}")
    if not np.isfinite(a).all():
        bad = int(np.count_nonzero(~np.all(np.isfinite(a), axis=1)))
        raise InputError(f"{name} contains NaN or inf values ({bad} rows)")
    return a


def check_intrinsics(K: np.ndarray, name: str = "K") -> np.ndarray:
    """Validate a 3x3 calibration matrix (finite, invertible, K[2,2] != 0)."""
    try:
        K = np.asarray(K, dtype=float)
    except (TypeError, ValueError):
        raise InputError(f"{name} must be a numeric 3x3 matrix") from None
    if K.shape != (3, 3):
        raise InputError(f"{name} must be a 3x3 matrix, got shape {K.shape}")
    if not np.all(np.isfinite(K)):
        raise InputError(f"{name} contains NaN or inf values")
    if abs(np.linalg.det(K)) < 1e-12 * max(1.0, np.abs(K).max()) ** 3:
        raise InputError(f"{name} is singular (det = {np.linalg.det(K):.3g})")
    return K


def bearings_from_normalized(x: np.ndarray) -> np.ndarray:
    """Normalized image coordinates ``(n, 2)`` -> unit bearings ``(n, 3)``."""
    x = np.asarray(x, dtype=float)
    return normalize(np.concatenate([x, np.ones(x.shape[:-1] + (1,))], axis=-1))


def bearings_from_pixels(u: np.ndarray, K: np.ndarray) -> np.ndarray:
    """Pixel coordinates ``(n, 2)`` and intrinsics ``K`` -> unit bearings ``(n, 3)``."""
    u = np.asarray(u, dtype=float)
    K = check_intrinsics(K)
    h = np.concatenate([u, np.ones(u.shape[:-1] + (1,))], axis=-1)
    return normalize(np.linalg.solve(K, h.T).T)


def as_bearings(x: np.ndarray, K: np.ndarray | None = None, name: str = "x") -> np.ndarray:
    """Accept pixels (with ``K``), normalized coordinates (``(n, 2)``) or bearings (``(n, 3)``).

    Returns unit bearing vectors; raises :class:`InputError` for bad shapes, NaN/inf, zero vectors.
    """
    a = _check_finite_2d(x, name)
    if a.shape[1] == 2:
        return bearings_from_pixels(a, K) if K is not None else bearings_from_normalized(a)
    if K is not None:
        raise InputError(f"{name} has shape (n, 3) (bearing vectors) but a K was given; pass pixels (n, 2) with K")
    nrm = np.sqrt(a[:, 0] * a[:, 0] + a[:, 1] * a[:, 1] + a[:, 2] * a[:, 2])  # = np.linalg.norm(a, axis=1) bit for bit
    if (nrm < 1e-12).any():
        raise InputError(f"{name} contains {int(np.count_nonzero(nrm < 1e-12))} zero-length bearing vectors")
    return a / nrm[:, None]


def check_correspondences(
    f1: np.ndarray,
    f2: np.ndarray,
    weights: np.ndarray | None = None,
    min_points: int = 6,
    K1: np.ndarray | None = None,
    K2: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """Validate and convert a correspondence set; returns unit bearings and float weights."""
    b1 = as_bearings(f1, K1, "f1" if K1 is None else "x1")
    b2 = as_bearings(f2, K2, "f2" if K2 is None else "x2")
    if b1.shape != b2.shape:
        raise InputError(f"the two point sets differ in length: {len(b1)} vs {len(b2)}")
    if len(b1) < min_points:
        raise InputError(f"at least {min_points} correspondences are needed, got {len(b1)}")
    w = None
    if weights is not None:
        try:
            w = np.asarray(weights, dtype=float)
        except (TypeError, ValueError):
            raise InputError("weights must be numeric") from None
        if w.shape != (len(b1),):
            raise InputError(f"weights must have shape ({len(b1)},), got {w.shape}")
        if not np.all(np.isfinite(w)):
            raise InputError("weights contain NaN or inf values")
        if np.any(w < 0):
            raise InputError(f"weights must be non-negative ({int(np.count_nonzero(w < 0))} negative)")
        if np.count_nonzero(w > 0) < min_points:
            raise InputError(f"at least {min_points} correspondences need a positive weight, got {int(np.count_nonzero(w > 0))}")
    return b1, b2, w


# --------------------------------------------------------------------------------------------
# essential matrices


def essential_from_pose(R: np.ndarray, t: np.ndarray) -> np.ndarray:
    """``E = [t]x R`` (batched)."""
    return skew(t) @ R


_W = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])


def decompose_essential(E: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Decompose ``E (..., 3, 3)`` into its two rotations and the translation direction.

    Returns ``Ra, Rb (..., 3, 3)`` (``U W V^T`` and ``U W^T V^T``, both proper rotations) and ``t
    (..., 3)`` (unit, ``+-u3``). The four poses are ``(Ra, t), (Ra, -t), (Rb, t), (Rb, -t)``; see
    :func:`four_poses` for them stacked. Hartley & Zisserman, Result 9.19.
    """
    U, _, Vt = np.linalg.svd(np.asarray(E, dtype=float))
    # E is defined up to sign, so flipping the sign of U or V keeps the same pair {Ra, Rb}
    su = np.sign(np.linalg.det(U))
    sv = np.sign(np.linalg.det(Vt))
    U = U * np.where(su == 0, 1.0, su)[..., None, None]
    Vt = Vt * np.where(sv == 0, 1.0, sv)[..., None, None]
    Ra = U @ _W @ Vt
    Rb = U @ _W.T @ Vt
    return Ra, Rb, U[..., :, 2]


def essential_frames(E: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """SVD-free decomposition of ``E (..., 3, 3)``: ``u3, v3 (..., 3)`` and ``F, E' (..., 3, 3)``.

    ``v3`` is the right singular vector of the smallest singular value (eigenvector of ``E^T E``),
    ``u3 = cof(E) v3 / |cof(E) v3|`` the left one oriented so that ``E = U diag(s1, s2, s3') V^T``
    with ``det U = det V = 1`` (``|cof(E) v3| = s1 s2``), ``E' = U diag(1, 1, 0) V^T`` and
    ``F = [u3]x U V^T``. The two rotations of :func:`decompose_essential` are ``u3 v3^T + F`` and
    ``u3 v3^T - F`` (``U W V^T`` and ``U W^T V^T``; which one is which depends on the sign of ``u3``)
    and its ``t`` is ``+-u3``. Derivation: ``E - [u3]x E [v3]x = U diag(s1 + s2, s1 + s2, s3') V^T``;
    ``U W U^T = u3 u3^T + [u3]x``. Matches the SVD route to ~1e-14 for any ``E`` of rank >= 2 (one
    batched 3x3 ``eigh`` instead of one 3x3 SVD per matrix plus sign fixes).
    """
    E = np.asarray(E, dtype=float)
    _, V = np.linalg.eigh(np.matmul(np.swapaxes(E, -1, -2), E))
    v3 = V[..., :, 0]
    c0, c1, c2 = E[..., :, 0], E[..., :, 1], E[..., :, 2]
    cof = np.stack([cross(c1, c2), cross(c2, c0), cross(c0, c1)], axis=-1)  # columns: cofactors
    u = np.matmul(cof, v3[..., None])[..., 0]
    s12 = np.sqrt(np.sum(u * u, axis=-1))  # s1 s2
    ok = s12 > 0
    u3 = np.where(ok[..., None], u / np.where(ok, s12, 1.0)[..., None], v3)  # rank < 2: any unit vector
    Ev3 = np.matmul(E, v3[..., None])[..., 0]
    s3 = np.sum(u3 * Ev3, axis=-1)
    sp = np.sqrt(np.maximum(np.sum(E * E, axis=(-2, -1)) - s3 * s3 + 2.0 * s12, 0.0))  # s1 + s2
    sp = np.where(sp > 0, sp, 1.0)
    Su, Sv = skew(u3), skew(v3)
    uv = u3[..., :, None] * v3[..., None, :]
    Ep = (E - np.matmul(np.matmul(Su, E), Sv) - s3[..., None, None] * uv) / sp[..., None, None]
    F = np.matmul(Su, Ep)
    return u3, v3, F, Ep


def four_poses(E: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """All four ``(R, t)`` of ``E``: ``R (..., 4, 3, 3)``, ``t (..., 4, 3)``."""
    Ra, Rb, t = decompose_essential(E)
    R = np.stack([Ra, Ra, Rb, Rb], axis=-3)
    T = np.stack([t, -t, t, -t], axis=-2)
    return R, T


# --------------------------------------------------------------------------------------------
# triangulation


def triangulate_midpoint(R: np.ndarray, t: np.ndarray, f1: np.ndarray, f2: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Midpoint two-view triangulation.

    Solves ``min || z1 R f1 + t - z2 f2 ||`` for the depths along each ray (in camera 2's frame),
    vectorized over points (and over leading pose dimensions). Returns ``(X1, z1, z2)`` with ``X1``
    the midpoint expressed in camera 1's frame and ``z1, z2`` the signed ray depths (negative means
    behind the camera). Points on the baseline (parallel rays) get zero depth.
    """
    R = np.asarray(R, dtype=float)
    t = np.asarray(t, dtype=float)
    a = np.einsum("...ij,...nj->...ni", R, f1)  # R f1 in frame 2
    b = np.broadcast_to(f2, a.shape)
    tt = t[..., None, :]
    ab = np.sum(a * b, axis=-1)
    at = np.sum(a * tt, axis=-1)
    bt = np.sum(b * tt, axis=-1)
    den = 1.0 - ab**2  # unit bearings
    ok = den > 1e-14
    den = np.where(ok, den, 1.0)
    # normal equations of min || z1 a - z2 b + t ||
    z1 = np.where(ok, (ab * bt - at) / den, 0.0)
    z2 = np.where(ok, (bt - ab * at) / den, 0.0)
    P2 = 0.5 * (z1[..., None] * a + tt + z2[..., None] * b)  # midpoint in frame 2
    X1 = np.einsum("...ji,...nj->...ni", R, P2 - tt)
    return X1, z1, z2


# --------------------------------------------------------------------------------------------
# errors


def rotation_angle_deg(R: np.ndarray) -> np.ndarray:
    """Rotation angle in degrees, accurate near 0 and 180 (atan2 of sin and cos)."""
    R = np.asarray(R, dtype=float)
    c = 0.5 * (np.trace(R, axis1=-2, axis2=-1) - 1.0)
    s = 0.5 * np.linalg.norm(
        np.stack([R[..., 2, 1] - R[..., 1, 2], R[..., 0, 2] - R[..., 2, 0], R[..., 1, 0] - R[..., 0, 1]], axis=-1),
        axis=-1,
    )
    return np.degrees(np.arctan2(s, c))


def rotation_error_deg(R_gt: np.ndarray, R: np.ndarray) -> np.ndarray:
    """``arccos((tr(R_gt^T R) - 1) / 2)`` in degrees, computed stably."""
    return rotation_angle_deg(np.swapaxes(np.asarray(R_gt, float), -1, -2) @ np.asarray(R, float))


def translation_error_deg(t_gt: np.ndarray, t: np.ndarray, sign_invariant: bool = False) -> np.ndarray:
    """Angle between translation directions in degrees (``sign_invariant`` ignores the sign)."""
    a = normalize(t_gt)
    b = normalize(t)
    c = np.sum(a * b, axis=-1)
    if sign_invariant:
        c = np.abs(c)
    s = np.linalg.norm(np.cross(a, b), axis=-1)
    return np.degrees(np.arctan2(s, c))
