"""Geometry core: bearings, skew matrices, essential decomposition, triangulation, errors.

Conventions (used everywhere in poseonly, the paper's Eq. (1) and OpenCV ``recoverPose``):

* a point ``X1`` in camera 1's frame maps to ``X2 = R @ X1 + t`` in camera 2's frame;
* ``E = [t]x R`` and ``f2^T E f1 = 0`` for corresponding bearings ``f1`` (view 1), ``f2`` (view 2);
* ``t`` is returned with unit norm (the scale is unobservable from two views).

All functions accept leading batch dimensions where it makes sense (``(..., 3, 3)`` rotations,
``(..., n, 3)`` bearings) and never loop in Python over points.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from . import _core
from .median import median

__all__ = [
    "InputError",
    "NonFiniteInputError",
    "as_bearings",
    "as_real_array",
    "bearings_from_normalized",
    "bearings_from_pixels",
    "check_correspondences",
    "check_intrinsics",
    "cross",
    "decompose_essential",
    "essential_frames",
    "essential_from_pose",
    "normalize",
    "project_to_so3",
    "rotation_angle_deg",
    "rotation_error_deg",
    "rotation_from_rotvec",
    "skew",
    "translation_error_deg",
    "triangulate_midpoint",
]


class InputError(ValueError):
    """Invalid input (shape, NaN/inf, zero vectors, too few points, bad options).

    Subclass of :class:`ValueError`, so ``except ValueError`` catches it.
    """


class NonFiniteInputError(InputError):
    """Coordinates with NaN or inf rows (an :class:`InputError`); the message counts them and names the
    first. :func:`poseonly.estimate_relative_pose` adds how to make such matches outliers."""


def nonfinite_rows_error(a: np.ndarray, name: str) -> NonFiniteInputError:
    """The error for the NaN / inf rows of the 2-D array ``a``: their count and the first row."""
    bad = np.flatnonzero(~np.all(np.isfinite(a), axis=1))
    return NonFiniteInputError(f"{name} contains NaN or inf values ({len(bad)} rows, the first is row {int(bad[0]) if len(bad) else '?'})")


# --------------------------------------------------------------------------------------------
# small helpers


def skew(v: np.ndarray) -> np.ndarray:
    """Skew-symmetric matrix ``[v]x`` with ``[v]x @ u == cross(v, u)``; ``(..., 3) -> (..., 3, 3)``
    (filled in place: four ``np.stack`` calls cost ~20 us on a single vector)."""
    v = np.asarray(v, dtype=float)
    if v.shape[-1:] != (3,):
        raise ValueError(f"skew needs vectors of length 3 on the last axis, got shape {v.shape}")
    out = np.zeros(v.shape[:-1] + (3, 3))
    out[..., 0, 1] = -v[..., 2]
    out[..., 0, 2] = v[..., 1]
    out[..., 1, 0] = v[..., 2]
    out[..., 1, 2] = -v[..., 0]
    out[..., 2, 0] = -v[..., 1]
    out[..., 2, 1] = v[..., 0]
    return out


def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Broadcasting cross product over the last axis: ``a, b (..., 3)`` -> ``(..., 3)`` (leading axes
    broadcast; several times faster than ``np.cross`` on small stacked arrays, which pays for
    ``moveaxis`` on every call)."""
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    return np.stack([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0], axis=-1)


def normalize(v: np.ndarray, axis: int = -1) -> np.ndarray:
    """Unit vectors along ``axis``: ``v (..., d)`` (with the default ``axis=-1``) -> the same shape,
    as float (zero vectors stay zero)."""
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


def rotvec_from_rotation(R: np.ndarray) -> np.ndarray:
    """The inverse of :func:`rotation_from_rotvec`: rotation matrix ``(..., 3, 3)`` -> rotation vector
    ``(..., 3)`` (angle in [0, pi]). Through the unit quaternion by Shepperd's method (the largest of
    ``1 + trace`` and the diagonal picks the stable formula, as scipy does), angle ``2 atan2(|v|, w)``:
    stable near 0 and pi. In numpy: scipy.spatial's import cost 0.35-0.9 s on the first pair that
    reached it (a VO trial)."""
    R = np.asarray(R, dtype=float)
    M = R.reshape(-1, 3, 3)
    m = len(M)
    d = np.stack([M[:, 0, 0], M[:, 1, 1], M[:, 2, 2], M[:, 0, 0] + M[:, 1, 1] + M[:, 2, 2]], axis=-1)
    k = np.argmax(d, axis=-1)  # 0-2: the largest diagonal entry, 3: the trace
    q = np.empty((m, 4))  # (x, y, z, w)
    t = k == 3
    if np.any(t):
        Mt = M[t]
        q[t, 3] = 1.0 + d[t, 3]
        q[t, 0] = Mt[:, 2, 1] - Mt[:, 1, 2]
        q[t, 1] = Mt[:, 0, 2] - Mt[:, 2, 0]
        q[t, 2] = Mt[:, 1, 0] - Mt[:, 0, 1]
    for i in range(3):
        s = k == i
        if not np.any(s):
            continue
        j, k2 = (i + 1) % 3, (i + 2) % 3
        Ms = M[s]
        q[s, i] = 1.0 - d[s, 3] + 2.0 * Ms[:, i, i]
        q[s, j] = Ms[:, j, i] + Ms[:, i, j]
        q[s, k2] = Ms[:, k2, i] + Ms[:, i, k2]
        q[s, 3] = Ms[:, k2, j] - Ms[:, j, k2]
    q /= np.linalg.norm(q, axis=-1, keepdims=True)
    q[q[:, 3] < 0] *= -1.0  # w >= 0: the angle in [0, pi]
    nv = np.linalg.norm(q[:, :3], axis=-1)
    angle = 2.0 * np.arctan2(nv, q[:, 3])
    small = nv < 1e-8  # angle / sin(angle / 2) -> 2 / w (relative error ~|v|^2)
    scale = np.where(small, 2.0 / np.where(small, q[:, 3], 1.0), angle / np.where(small, 1.0, nv))
    return (q[:, :3] * scale[:, None]).reshape(R.shape[:-2] + (3,))


# a returned R must satisfy |R^T R - I|_max < ORTHO_TOL and det R > 0 (else no valid pose was found; the core's
# checked poses use the same bound)
ORTHO_TOL = 1e-6


def valid_pose(R: np.ndarray, t: np.ndarray) -> bool:
    """``R (3, 3)`` a finite rotation and ``t (3,)`` finite and non-zero.

    Checked in Python floats (nine products per entry of ``R^T R``: a tenth of the numpy version's
    time, which this per-pair check paid in the status analysis); ``R^T R - I`` and ``det R`` as
    numpy rounds them to within the tolerance's resolution."""
    R, t = np.asarray(R, float), np.asarray(t, float)
    if R.shape != (3, 3) or t.shape != (3,):
        return False
    (a, b, c), (d, e, f), (g, h, i) = R.tolist()
    tx, ty, tz = t.tolist()
    if not all(math.isfinite(x) for x in (a, b, c, d, e, f, g, h, i, tx, ty, tz)):
        return False
    cols = ((a, d, g), (b, e, h), (c, f, i))
    ortho = max(abs(sum(p * q for p, q in zip(cols[j], cols[k])) - (1.0 if j == k else 0.0)) for j in range(3) for k in range(3))
    det = a * (e * i - f * h) - b * (d * i - f * g) + c * (d * h - e * g)
    return ortho < ORTHO_TOL and det > 0 and max(abs(tx), abs(ty), abs(tz)) > 0


def project_to_so3(M: np.ndarray) -> np.ndarray:
    """Nearest rotation (Frobenius) to ``M`` ``(..., 3, 3)`` via SVD."""
    U, _, Vt = np.linalg.svd(np.asarray(M, dtype=float))
    d = np.sign(np.linalg.det(U @ Vt))
    D = np.ones(U.shape[:-1])
    D[..., 2] = d
    return (U * D[..., None, :]) @ Vt


# --------------------------------------------------------------------------------------------
# input normalisation and validation


# a bearing whose norm is below this (relative to nothing: bearings are directions given with
# components of order 1) is taken for a zero vector
ZERO_BEARING = 1e-12
# the lower-left entries of a calibration matrix must vanish (relative to its largest entry)
K_ZERO_RTOL = 1e-9
# dtype kinds that numpy would cast to float but that hold no coordinates: strings, bytes, dates,
# durations, structured records
NON_NUMERIC_KINDS = "USmMV"


def as_real_array(a: object, name: str) -> np.ndarray:
    """``a`` as a float array (any shape); complex, string, date / duration, structured or ragged input
    (and object arrays holding any of those) raises :class:`InputError`. A masked array's masked
    entries are NaN (missing values, which the callers refuse or treat as their NaN; its mask was
    dropped silently and the filler values used as data: a trial)."""
    if np.ma.isMaskedArray(a):
        m = np.ma.getmaskarray(a)
        out = as_real_array(np.ma.getdata(a), name)
        if m.any():
            out = out.copy()
            out[m] = np.nan
        return out
    try:
        raw = np.asarray(a)
    except (TypeError, ValueError) as exc:
        raise InputError(f"{name} must be a numeric array ({exc})") from None
    if np.iscomplexobj(raw):
        raise InputError(f"{name} must be real; got a complex array (dtype {raw.dtype})")
    if raw.dtype.kind in NON_NUMERIC_KINDS or (raw.dtype.kind == "O" and any(isinstance(x, (str, bytes, np.datetime64, np.timedelta64)) for x in raw.flat)):
        raise InputError(f"{name} must be a numeric array, got dtype {raw.dtype}")
    if raw.dtype.kind not in "biuf":
        try:
            raw = raw.astype(float)
        except (TypeError, ValueError) as exc:
            raise InputError(f"{name} must be a numeric array, got dtype {raw.dtype} ({exc})") from None
        if np.iscomplexobj(raw):  # pragma: no cover - astype(float) never yields complex
            raise InputError(f"{name} must be real")
    return np.asarray(raw, dtype=float)


def opencv_points(a: np.ndarray) -> np.ndarray:
    """OpenCV's point arrays ``(n, 1, k)`` (``goodFeaturesToTrack``, ``calcOpticalFlowPyrLK``,
    ``findEssentialMat``'s input) as ``(n, k)``; any other shape unchanged (a VO trial)."""
    return a[:, 0] if a.ndim == 3 and a.shape[1] == 1 else a


def as_coordinates(a: object, name: str) -> np.ndarray:
    """Image coordinates or bearings as a float array (:func:`as_real_array`, OpenCV's ``(n, 1, k)`` as
    ``(n, k)``); a boolean array (a mask passed for points) raises :class:`InputError`."""
    raw = np.ma.getdata(a) if np.ma.isMaskedArray(a) else a
    is_bool = isinstance(raw, np.ndarray) and (raw.dtype == np.bool_ or (raw.dtype.kind == "O" and raw.size > 0 and all(isinstance(x, (bool, np.bool_)) for x in raw.flat)))
    out = as_real_array(a, name)  # (its errors first: ragged input, complex, strings)
    if is_bool or (not isinstance(raw, np.ndarray) and np.asarray(raw, dtype=object).size and all(isinstance(x, (bool, np.bool_)) for x in np.asarray(raw, dtype=object).flat)):
        raise InputError(f"{name} must hold coordinates, got a boolean array (a mask?)")
    return opencv_points(out)


def _check_shape_2d(a: np.ndarray, name: str) -> np.ndarray:
    a = as_coordinates(a, name)
    if a.ndim != 2 or a.shape[1] not in (2, 3):
        raise InputError(f"{name} must have shape (n, 2) or (n, 3), got {a.shape}")
    return a


def _check_finite_2d(a: np.ndarray, name: str) -> np.ndarray:
    """``a`` as :func:`_check_shape_2d` returns it (a float array of shape ``(n, 2)`` or ``(n, 3)``
    is not converted again), with NaN / inf rows an error."""
    if not (type(a) is np.ndarray and a.dtype == np.float64 and a.ndim == 2 and a.shape[1] in (2, 3)):
        a = _check_shape_2d(a, name)
    if not np.isfinite(a).all():
        raise nonfinite_rows_error(a, name)
    return a


def pair_focal(f1: float, f2: float) -> float:
    """The focal length (pixels) converting a pixel threshold or noise to the angle of the Sampson error of
    matches between a view of focal length ``f1`` and one of ``f2``: that error weighs both views'
    angular errors alike, so pixel noise ``sigma`` in both gives the root mean square of ``sigma / f1``
    and ``sigma / f2``, i.e. ``sigma / pair_focal`` with ``pair_focal = sqrt(2 / (1 / f1^2 + 1 / f2^2))``:
    ``f`` for two equal focal lengths, ``sqrt(2)`` times the smaller for very different ones (a mean
    of the two put a 300 px fisheye's 0.5 px noise outside a 1 px threshold beside a 3000 px lens)."""
    a, b = float(f1), float(f2)
    if math.isnan(a) or math.isnan(b):
        return math.nan  # the caller's check rejects it
    lo, hi = min(a, b), max(a, b)
    if not hi > 0:
        return lo  # no usable focal: the caller's check rejects it
    if math.isinf(hi):
        return lo * math.sqrt(2.0)  # inf when both are
    return lo * math.sqrt(2.0 / (1.0 + (lo / hi) ** 2))


def check_intrinsics(K: np.ndarray, name: str = "K") -> np.ndarray:
    """Validate a 3x3 calibration matrix ``[[fx, s, cx], [0, fy, cy], [0, 0, 1]]``.

    Finite, real, upper triangular, ``K[2, 2] != 0`` (a scaled ``K`` is divided by it), positive
    focal lengths ``fx, fy`` and a finite inverse. Returns ``K / K[2, 2]`` as floats.
    """
    K = as_real_array(K, name)
    if K.shape != (3, 3):
        raise InputError(f"{name} must be a 3x3 matrix, got shape {K.shape}")
    # the checks in Python floats on the nine entries (a tenth of the time of numpy calls on a 3x3,
    # paid per estimate); the values and decisions are numpy's
    k = K.ravel().tolist()
    if not all(math.isfinite(v) for v in k):
        raise InputError(f"{name} contains NaN or inf values")
    scale = max(abs(v) for v in k)
    k22 = k[8]
    if scale == 0.0 or k22 == 0.0:
        raise InputError(f"{name} is singular (K[2, 2] = {k22:g})")
    if max(abs(k[3]), abs(k[6]), abs(k[7])) > K_ZERO_RTOL * scale:
        raise InputError(f"{name} must be upper triangular ([[fx, s, cx], [0, fy, cy], [0, 0, 1]]); got lower-left entries {k[3]:g}, {k[6]:g}, {k[7]:g}")
    with np.errstate(all="ignore"):
        Kn = K / K[2, 2]
    kn = Kn.ravel().tolist()
    if not all(math.isfinite(v) for v in kn):
        raise InputError(f"{name} / K[2, 2] overflows (K[2, 2] = {k22:g})")
    fx, fy = kn[0], kn[4]
    if not (fx > 0 and fy > 0):
        raise InputError(f"{name} must have positive focal lengths, got fx = {fx:g}, fy = {fy:g}")
    det = fx * fy
    Kinv_ok = math.isfinite(1.0 / fx) and math.isfinite(1.0 / fy) and math.isfinite(det) and det > 0
    if not Kinv_ok:
        raise InputError(f"{name} has focal lengths out of the representable range (fx = {fx:g}, fy = {fy:g})")
    big = max(1.0, max(abs(v) for v in kn))
    if det < 1e-12 * big * big:  # a product, not ** 2: an inf, not an OverflowError, for K entries ~1e200
        # relative to K's largest entry: a focal of 800 px with the principal point at 1e9 px is not
        # singular, but pixels lose all but a few digits of their angle through K^-1
        raise InputError(
            f"{name} is numerically singular: fx * fy = {det:.3g} is below 1e-12 times the square of its largest entry ({big:.3g}); "
            "the focal lengths are too small for the principal point and skew (pixels and K in different units?)"
        )
    return Kn


def _unit_rows(a: np.ndarray, name: str) -> np.ndarray:
    """Rows of ``a (n, 3)`` scaled to unit length without overflow or underflow (the core's
    ``unit_rows``; its numpy reference is ``tests/reference/bearings.py``).

    When every row's components are of moderate size (largest in (1e-150, 1e150)) the plain norm is
    used; otherwise the other rows are first divided by their largest absolute component, so
    components up to ``1.8e308`` keep their direction. Rows shorter than :data:`ZERO_BEARING` raise
    :class:`InputError`, and so do rows with a NaN or inf component (checked first).
    """
    out, zeros, nonfinite = _core.unit_rows(np.ascontiguousarray(a, dtype=np.float64), ZERO_BEARING)
    if nonfinite:
        raise nonfinite_rows_error(np.asarray(a, dtype=np.float64), name)
    if zeros:
        raise InputError(f"{name} contains {zeros} zero-length bearing vectors")
    return out


def bearings_from_normalized(x: np.ndarray) -> np.ndarray:
    """Normalized image coordinates ``(n, 2)`` -> unit bearings ``(n, 3)``."""
    x = np.asarray(x, dtype=float)
    return normalize(np.concatenate([x, np.ones(x.shape[:-1] + (1,))], axis=-1))


def bearings_from_pixels(u: np.ndarray, K: np.ndarray) -> np.ndarray:
    """Pixel coordinates ``(n, 2)`` and intrinsics ``K`` -> unit bearings ``(n, 3)``."""
    u = np.asarray(u, dtype=float)
    K = check_intrinsics(K)
    h = np.concatenate([u, np.ones(u.shape[:-1] + (1,))], axis=-1)
    return normalize(solve_intrinsics(K, h))


def solve_intrinsics(K: np.ndarray, h: np.ndarray) -> np.ndarray:
    """``K^-1 h`` for homogeneous pixels ``h (..., 3)`` and an upper-triangular ``K`` (as
    :func:`check_intrinsics` returns it), by back-substitution: ``(..., 3)`` rays.

    Written out rather than ``np.linalg.solve(K, h.T)``, whose LAPACK solve with ``n`` right-hand
    sides starts OpenBLAS's worker threads, which then spin on the caller's cores after every call
    (measured: 26 % more CPU than wall time, and the threads compete with a user's own thread pool).
    """
    # the order and the reciprocals of LAPACK's (OpenBLAS's) triangular solve, so the rays are those
    # np.linalg.solve gave before, bit for bit where K's lower-left entries are exactly 0 (check_intrinsics
    # admits up to 1e-9 of K's scale there, which this ignores: a relative change below 1e-9)
    r2 = h[..., 2] * (1.0 / K[2, 2])
    b1 = h[..., 1] - K[1, 2] * r2
    b0 = h[..., 0] - K[0, 2] * r2
    r1 = b1 * (1.0 / K[1, 1])
    r0 = (b0 - K[0, 1] * r1) * (1.0 / K[0, 0])
    return np.stack([r0, r1, r2], axis=-1)


def _pixels_to_rays(a: np.ndarray, K: np.ndarray) -> np.ndarray:
    """``K^-1 [u, v, 1]`` for upper-triangular ``K`` (``K[2, 2] = 1``), overflow-safe: pixels of
    any finite size are first divided by their row's largest component."""
    m = np.maximum(np.max(np.abs(a), axis=1), 1.0)
    h = np.concatenate([a / m[:, None], 1.0 / m[:, None]], axis=1)
    with np.errstate(over="ignore", invalid="ignore"):
        r = solve_intrinsics(K, h)
    return r


# median |coordinate| above which (n, 2) input without K is taken for pixels: a normalized coordinate
# of 10 lies 84 deg off the optical axis, beyond any perspective camera's field of view
PIXEL_LIKE_NORMALIZED = 10.0


def as_bearings(x: np.ndarray, K: np.ndarray | None = None, name: str = "x", *, K_checked: bool = False) -> np.ndarray:
    """Accept pixels ``(n, 2)`` (with ``K``), normalized coordinates ``(n, 2)`` or bearings ``(n, 3)``
    (OpenCV's ``(n, 1, 2)`` / ``(n, 1, 3)`` too).

    Returns unit bearing vectors ``(n, 3)``; raises :class:`InputError` for bad shapes, complex or
    non-numeric input, NaN/inf, zero vectors and rays that are not finite. Norms are scaled, so
    components of any finite magnitude keep their direction. ``K_checked``: ``K`` is already the
    output of :func:`check_intrinsics` (which it would return unchanged), so it is not checked again.
    """
    a = _check_shape_2d(x, name)
    if a.shape[1] == 2 and K is not None and K_checked:
        # the library's own path (K checked once for both views): one core call, the rays and their
        # unit rows as the numpy path below computes them, bit for bit
        r = _core.pixel_bearings(np.ascontiguousarray(a), np.ascontiguousarray(K, dtype=np.float64), ZERO_BEARING)
        if r is not None:
            out, bad, bad_rays, zeros = r
            if bad:
                raise nonfinite_rows_error(np.asarray(a, dtype=np.float64), name)
            if bad_rays:  # pragma: no cover - a checked K maps pixels below 1e150 to finite rays
                raise InputError(f"{name}: K^-1 [u, v, 1] is not finite for {bad_rays} rows")
            if zeros:  # pragma: no cover - the third component of a ray is 1 / K[2, 2] = 1
                raise InputError(f"{name} contains {zeros} zero-length bearing vectors")
            return out
    if a.shape[1] == 2:
        a = _check_finite_2d(a, name)
        if K is None:
            med = median(np.abs(a)) if len(a) else 0.0
            if med > PIXEL_LIKE_NORMALIZED:
                raise InputError(
                    f"{name}: (n, 2) coordinates without K have median |x| = {med:.4g}, which is pixel-sized, not a "
                    f"normalized image coordinate (tan of the angle off the axis); pass K (or a camera) with pixels"
                )
            return _unit_rows(np.concatenate([a, np.ones((len(a), 1))], axis=1), name)
        if not K_checked:
            K = check_intrinsics(K, "K")
        m = np.max(np.abs(a), axis=1) if len(a) else np.zeros(0)
        if np.all(m < 1e150):
            h = np.concatenate([a, np.ones((len(a), 1))], axis=1)
            rays = solve_intrinsics(K, h)  # as bearings_from_pixels
        else:
            rays = _pixels_to_rays(a, K)
        if not np.all(np.isfinite(rays)):
            raise InputError(f"{name}: K^-1 [u, v, 1] is not finite for {int(np.count_nonzero(~np.isfinite(rays).all(1)))} rows")
        return _unit_rows(rays, name)
    if K is not None:
        _check_finite_2d(a, name)  # the NaN error first, as for every shape
        raise InputError(f"{name} has shape (n, 3) (bearing vectors) but a K was given; pass pixels (n, 2) with K")
    if len(a) and np.all(a[:, 2] == 1.0):  # homogeneous [x, y, 1]: pixels too unless x, y are normalized
        med = median(np.abs(a[:, :2]))
        if med > PIXEL_LIKE_NORMALIZED:
            raise InputError(
                f"{name}: (n, 3) rows [x, y, 1] have median |x| = {med:.4g}, which is pixel-sized: homogeneous pixels, not "
                f"bearing vectors (they were taken as rays up to 89 deg off the axis); pass the (n, 2) pixels with K (or a camera)"
            )
    return _unit_rows(a, name)


def check_correspondences(
    f1: np.ndarray,
    f2: np.ndarray,
    weights: np.ndarray | None = None,
    min_points: int = 6,
    K1: np.ndarray | None = None,
    K2: np.ndarray | None = None,
    min_positive: int | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """Validate and convert a correspondence set: ``f1, f2 (n, 2)`` pixels (with ``K1, K2 (3, 3)``) or
    normalized image coordinates (without), or ``(n, 3)`` bearing vectors; ``weights (n,)`` or None,
    at least ``min_positive`` of them positive (default ``min_points``).
    Returns unit bearings ``b1, b2 (n, 3)`` and float weights ``(n,)`` (or None)."""
    b1 = as_bearings(f1, K1, "f1" if K1 is None else "x1")
    b2 = as_bearings(f2, K2, "f2" if K2 is None else "x2")
    if b1.shape != b2.shape:
        raise InputError(f"the two point sets differ in length: {len(b1)} vs {len(b2)}")
    if len(b1) < min_points:
        raise InputError(f"at least {min_points} correspondences are needed, got {len(b1)}")
    w = None
    if weights is not None:
        w = as_real_array(weights, "weights")  # complex refused (it was cast with a ComplexWarning: an adversarial trial)
        if w.shape != (len(b1),):
            raise InputError(f"weights must have shape ({len(b1)},), got {w.shape}")
        if not np.all(np.isfinite(w)):
            raise InputError("weights contain NaN or inf values")
        if np.any(w < 0):
            raise InputError(f"weights must be non-negative ({int(np.count_nonzero(w < 0))} negative)")
        need = min_points if min_positive is None else min_positive
        if np.count_nonzero(w > 0) < need:
            raise InputError(f"at least {need} correspondences need a positive weight, got {int(np.count_nonzero(w > 0))}")
        w = np.ascontiguousarray(w)
    return b1, b2, w


# --------------------------------------------------------------------------------------------
# essential matrices


def essential_from_pose(R: np.ndarray, t: np.ndarray) -> np.ndarray:
    """``E = [t]x R``: ``R (..., 3, 3)``, ``t (..., 3)`` -> ``E (..., 3, 3)`` (leading axes broadcast)."""
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
    vectorized over points (and over leading pose dimensions): ``R (..., 3, 3)``, ``t (..., 3)``,
    unit bearings ``f1, f2 (n, 3)`` (or stacked ``(..., n, 3)``). Returns ``(X1, z1, z2)`` with ``X1
    (..., n, 3)`` the midpoint expressed in camera 1's frame and ``z1, z2 (..., n)`` the signed ray
    depths (negative means behind the camera). Points on the baseline (parallel rays) get zero depth.
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
    """Rotation angle in degrees of ``R (..., 3, 3)`` -> ``(...)``, accurate near 0 and 180 (atan2 of
    sin and cos)."""
    R = np.asarray(R, dtype=float)
    c = 0.5 * (np.trace(R, axis1=-2, axis2=-1) - 1.0)
    s = 0.5 * np.linalg.norm(
        np.stack([R[..., 2, 1] - R[..., 1, 2], R[..., 0, 2] - R[..., 2, 0], R[..., 1, 0] - R[..., 0, 1]], axis=-1),
        axis=-1,
    )
    return np.degrees(np.arctan2(s, c))


# how far from orthonormal a matrix may be and still count as a rotation in rotation_error_deg (a
# rotation printed with three decimals, or float32 rounding, is well within it)
ROTATION_ERROR_TOL = 1e-2


def rotation_error_deg(R_gt: np.ndarray, R: np.ndarray) -> Any:
    """``arccos((tr(R_gt^T R) - 1) / 2)`` in degrees, computed stably; ``R_gt, R (..., 3, 3)`` (leading
    axes broadcast) -> ``(...)``: a ``numpy.float64`` (a ``float``) for two ``(3, 3)`` rotations, an
    array for stacks (typed ``Any``, as numpy's own functions of either shape)."""
    A, B = as_real_array(R_gt, "R_gt"), as_real_array(R, "R")
    for name, M in (("R_gt", A), ("R", B)):
        if M.ndim < 2 or M.shape[-2:] != (3, 3):
            raise InputError(f"{name} must have shape (..., 3, 3), got {M.shape}")
        with np.errstate(invalid="ignore"):  # NaN matrices (a failed estimate) give NaN errors
            off = np.abs(np.swapaxes(M, -1, -2) @ M - np.eye(3)).max(axis=(-2, -1))
            bad = (off > ROTATION_ERROR_TOL) | (np.linalg.det(M) <= 0.0)
        if np.any(bad & np.isfinite(M).all(axis=(-2, -1))):
            raise InputError(f"{name} is not a rotation (|R^T R - I| up to {np.nanmax(off):.3g}, or det <= 0); its angle would be meaningless")
    try:
        np.broadcast_shapes(A.shape[:-2], B.shape[:-2])
    except ValueError:
        raise InputError(f"R_gt {A.shape} and R {B.shape} do not broadcast") from None
    # a non-finite matrix (a failed estimate) has no angle: NaN, without numpy's warnings
    A, B = (np.where(np.isfinite(M).all(axis=(-2, -1))[..., None, None], M, np.nan) for M in (A, B))
    with np.errstate(invalid="ignore"):
        return rotation_angle_deg(np.swapaxes(A, -1, -2) @ B)


def translation_error_deg(t_gt: np.ndarray, t: np.ndarray, sign_invariant: bool = False) -> np.ndarray:
    """Angle between translation directions in degrees: ``t_gt, t (..., 3)`` (any length; leading
    axes broadcast) -> ``(...)`` (``sign_invariant`` ignores the sign). A zero (or non-finite) vector
    has no direction: its angle is NaN (it was 0, a perfect score: a trial)."""
    A, B = as_real_array(t_gt, "t_gt"), as_real_array(t, "t")
    for name, v in (("t_gt", A), ("t", B)):
        if v.ndim < 1 or v.shape[-1] != 3:
            raise InputError(f"{name} must have shape (..., 3), got {v.shape}")
    try:
        np.broadcast_shapes(A.shape, B.shape)
    except ValueError:
        raise InputError(f"t_gt {A.shape} and t {B.shape} do not broadcast") from None
    with np.errstate(invalid="ignore", divide="ignore"):  # scaled first: a norm of 1e200 would overflow
        ma, mb = np.max(np.abs(A), axis=-1, keepdims=True), np.max(np.abs(B), axis=-1, keepdims=True)
        a = normalize(A / np.where(ma > 0, ma, 1.0))
        b = normalize(B / np.where(mb > 0, mb, 1.0))
    no_direction = ~((ma[..., 0] > 0) & (mb[..., 0] > 0) & np.isfinite(ma[..., 0]) & np.isfinite(mb[..., 0]))
    c = np.sum(a * b, axis=-1)
    if sign_invariant:
        c = np.abs(c)
    s = np.linalg.norm(np.cross(a, b), axis=-1)
    return np.where(no_direction, np.nan, np.degrees(np.arctan2(s, c)))[()]
