"""Strict-JSON conversions of numbers and arrays (non-finite values become ``None``, JSON's ``null``)."""

from __future__ import annotations

from typing import Any

import numpy as np

__all__ = ["json_array", "json_float"]


def json_float(x: Any) -> float | None:
    """``float(x)``, or ``None`` where it is NaN or infinite."""
    x = float(x)
    return x if np.isfinite(x) else None


def json_array(a: np.ndarray | None) -> list | None:
    """Nested lists with ``None`` for non-finite entries (``None`` for ``None``)."""
    if a is None:
        return None
    a = np.asarray(a, float)
    obj = a.astype(object)
    obj[~np.isfinite(a)] = None
    return obj.tolist()
