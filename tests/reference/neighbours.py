"""numpy reference of the core's neighbour search (src/core/neighbours.cpp): brute force."""

from __future__ import annotations

import numpy as np


def nearest_neighbours(f: np.ndarray, k: int) -> np.ndarray:
    """``(n, k)``: each bearing's ``k`` nearest other bearings by chord distance, nearest first, ties by index."""
    n = len(f)
    d2 = ((f[:, None, :] - f[None, :, :]) ** 2).sum(axis=2)
    out = np.empty((n, k), dtype=np.int64)
    idx = np.arange(n)
    for i in range(n):
        mask = idx != i
        order = np.lexsort((idx[mask], d2[i, mask]))  # by distance, then index
        out[i] = idx[mask][order[:k]]
    return out


def neighbour_consistency(f1: np.ndarray, f2: np.ndarray, k: int) -> np.ndarray:
    a, b = nearest_neighbours(f1, k), nearest_neighbours(f2, k)
    return np.array([len(np.intersect1d(a[i], b[i])) for i in range(len(f1))], dtype=np.int64)
