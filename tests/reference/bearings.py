"""numpy reference of the core's ``unit_rows`` (``poseonly.geometry._unit_rows``)."""

from __future__ import annotations

import numpy as np

from poseonly.geometry import ZERO_BEARING, InputError


def unit_rows(a: np.ndarray, name: str = "a") -> np.ndarray:
    """Rows of ``a (n, 3)`` scaled to unit length; zero rows raise :class:`InputError`."""
    m = np.max(np.abs(a), axis=1)
    plain = (m < 1e150) & (m > 1e-150)
    if plain.all():
        nrm = np.sqrt(a[:, 0] * a[:, 0] + a[:, 1] * a[:, 1] + a[:, 2] * a[:, 2])  # = np.linalg.norm(a, axis=1) bit for bit
        zero = nrm < ZERO_BEARING
        if zero.any():
            raise InputError(f"{name} contains {int(np.count_nonzero(zero))} zero-length bearing vectors")
        return a / nrm[:, None]
    zero = m < ZERO_BEARING / np.sqrt(3.0)  # |row| <= sqrt(3) m (no overflow for m near 1.8e308)
    if zero.any():
        raise InputError(f"{name} contains {int(np.count_nonzero(zero))} zero-length bearing vectors")
    out = np.empty_like(a)
    ap = a[plain]
    nrm = np.sqrt(np.sum(ap * ap, axis=1))
    out[plain] = ap / nrm[:, None]
    b = a[~plain] / m[~plain, None]
    out[~plain] = b / np.sqrt(np.sum(b * b, axis=1))[:, None]
    return out
