"""Checks of the arrays the global stages take from callers: shapes, numbers, rotations that are
rotations, view indices in range. Every failure is an :class:`~poseonly.geometry.InputError`
naming the argument and the problem; a missing pose is an all-NaN row (the stages' convention)."""

from __future__ import annotations

import numpy as np

from ..geometry import InputError, as_bearings, as_real_array, project_to_so3

__all__ = [
    "MAX_COORDINATE",
    "ROTATION_ATOL",
    "checked_bearings",
    "checked_centres",
    "checked_count",
    "checked_indices",
    "checked_pairs",
    "checked_positive",
    "checked_rotation",
    "checked_rotations",
]

# a given rotation may be off SO(3) by this much (largest entry of R^T R - I, and |det R - 1|): a
# rotation printed with three decimals is up to ~3e-3 off (six digits: ~1e-6); it is then projected
# onto SO(3). Matrices that are not rotations (scaled, reflected, zero) are far beyond it.
ROTATION_ATOL = 5e-3
# centres beyond this magnitude (any unit) overflow the stages' squared distances
MAX_COORDINATE = 1e100


def checked_rotations(rotations: object, name: str, count: int | None = None, *, missing: bool = False) -> np.ndarray:
    """``rotations (N, 3, 3)`` as float64, each a rotation (projected onto SO(3) when it is off by
    less than :data:`ROTATION_ATOL`) or, with ``missing``, all NaN (a view without one)."""
    R = as_real_array(rotations, name)
    if R.ndim != 3 or R.shape[1:] != (3, 3):
        raise InputError(f"{name} must have shape (N, 3, 3), got {R.shape}")
    if count is not None and len(R) != count:
        raise InputError(f"{name} must hold {count} rotations, got {len(R)}")
    given = np.all(np.isfinite(R), axis=(1, 2))
    absent = np.all(np.isnan(R), axis=(1, 2))
    if missing and not np.all(given | absent):
        k = int(np.flatnonzero(~(given | absent))[0])
        raise InputError(f"{name}[{k}] has NaN or inf entries (a missing rotation is all NaN)")
    if not missing and not np.all(given):
        raise InputError(f"{name} contains NaN or inf values ({int(np.sum(~given))} rotations)")
    Rg = R[given]
    with np.errstate(all="ignore"):
        dev = np.abs(np.einsum("nji,njk->nik", Rg, Rg) - np.eye(3)).max(axis=(1, 2)) if len(Rg) else np.zeros(0)
        det = np.linalg.det(Rg) if len(Rg) else np.zeros(0)
    bad = ~((dev <= ROTATION_ATOL) & (np.abs(det - 1.0) <= ROTATION_ATOL))
    if np.any(bad):
        i = int(np.flatnonzero(bad)[0])
        k = int(np.flatnonzero(given)[i])
        raise InputError(f"{name}[{k}] is not a rotation matrix (R^T R - I up to {dev[i]:.3g}, det {det[i]:.6g})")
    out = R.copy()
    if len(Rg) and dev.max() > 1e-12:
        out[given] = project_to_so3(Rg)
    return out


def checked_rotation(rotation: object, name: str) -> np.ndarray:
    """One finite ``3 x 3`` rotation (see :func:`checked_rotations`)."""
    R = as_real_array(rotation, name)
    if R.shape != (3, 3):
        raise InputError(f"{name} must be a 3x3 rotation matrix, got shape {R.shape}")
    try:
        return checked_rotations(R[None], name)[0]
    except InputError as exc:
        raise InputError(str(exc).replace(f"{name}[0]", name, 1)) from None


def checked_count(value: object, name: str, minimum: int = 0) -> int:
    """A whole number ``>= minimum`` (an integral float or a 0-d array is accepted; a bool or a string is not)."""
    if isinstance(value, (bool, np.bool_, str, bytes)):
        raise InputError(f"{name} must be a whole number >= {minimum}, got {value!r}")
    if isinstance(value, (int, np.integer)):  # exactly (through float64 2**64 - 1 became 2**64)
        if int(value) < minimum:
            raise InputError(f"{name} must be a whole number >= {minimum}, got {value!r}")
        return int(value)
    try:
        v = float(np.asarray(value, dtype=np.float64))
    except (TypeError, ValueError):
        raise InputError(f"{name} must be a whole number >= {minimum}, got {value!r}") from None
    if not (np.isfinite(v) and v == np.round(v) and v >= minimum):
        raise InputError(f"{name} must be a whole number >= {minimum}, got {value!r}")
    return int(v)


def checked_positive(value: object, name: str) -> float:
    """A finite real number ``> 0`` (a 0-d array is accepted; a bool is not)."""
    if isinstance(value, (bool, np.bool_)):
        raise InputError(f"{name} must be a finite number > 0, got {value!r}")
    try:
        v = float(np.asarray(value, dtype=np.float64))
    except (TypeError, ValueError):
        raise InputError(f"{name} must be a finite number > 0, got {value!r}") from None
    if not (np.isfinite(v) and v > 0):
        raise InputError(f"{name} must be a finite number > 0, got {value!r}")
    return v


def checked_centres(centres: object, name: str, count: int) -> np.ndarray:
    """``centres (N, 3)`` as float64: rows finite and below :data:`MAX_COORDINATE`, or all NaN (not
    posed)."""
    C = as_real_array(centres, name)
    if C.shape != (count, 3):
        raise InputError(f"{name} must have shape ({count}, 3), got {C.shape}")
    given = np.all(np.isfinite(C), axis=1)
    if not np.all(given | np.all(np.isnan(C), axis=1)):
        raise InputError(f"{name} has rows with NaN or inf entries (a view without a centre is all NaN)")
    if np.any(np.abs(C[given]) > MAX_COORDINATE):
        raise InputError(f"{name} has coordinates beyond {MAX_COORDINATE:g}")
    return C


def checked_bearings(bearings: object, name: str, count: int) -> np.ndarray:
    """``bearings (M, 3)``, finite and non-zero, as unit rows (any finite magnitude keeps its direction)."""
    f = as_real_array(bearings, name)
    if f.shape != (count, 3):
        raise InputError(f"{name} must have shape ({count}, 3), got {f.shape}")
    return as_bearings(f, None, name)


def checked_indices(values: object, name: str) -> np.ndarray:
    """Whole non-negative indices (any shape) as int64: fractions, NaN, inf and negatives are errors,
    not truncated."""
    a = as_real_array(values, name)
    if not np.all(np.isfinite(a)) or np.any(a != np.round(a)):
        raise InputError(f"{name} must hold whole indices")
    if a.size and a.min() < 0:
        raise InputError(f"{name} must be non-negative")
    if a.size and a.max() >= 2**53:
        raise InputError(f"{name} must be below 2**53")
    return a.astype(np.int64)


def checked_pairs(pairs: object, num_views: int) -> np.ndarray:
    """``pairs (E, 2)`` of whole view indices in ``[0, num_views)``, no view paired with itself, as int64."""
    p = as_real_array(pairs, "pairs")
    if p.ndim != 2 or p.shape[1] != 2:
        raise InputError(f"pairs must have shape (E, 2), got {p.shape}")
    if not np.all(np.isfinite(p)) or np.any(p != np.round(p)):
        raise InputError("pairs must hold whole view indices")
    if len(p) and (p.min() < 0 or p.max() >= num_views):
        raise InputError(f"edge view indices must be in [0, {num_views})")
    q = p.astype(np.int64)
    if np.any(q[:, 0] == q[:, 1]):
        raise InputError("an edge joins a view to itself")
    return q
