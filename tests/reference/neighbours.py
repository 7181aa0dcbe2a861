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


def distinct_rows(f1: np.ndarray, f2: np.ndarray, tol: float = 0.0) -> np.ndarray | None:
    """poseonly.status.distinct_rows as it was in numpy (thirteenth session). Indices (ascending) of the first match of each group of repeated matches, or ``None`` where every
    match is distinct. ``f1, f2 (n, 3)`` unit bearings; two matches repeat each other when their rows are
    identical or, with ``tol > 0`` (radians), within ``tol`` of each other in both views (chord
    distance); groups are the connected components of that relation."""
    X = np.ascontiguousarray(np.concatenate([f1, f2], axis=1), dtype=float)
    _, first = np.unique(X.view(np.dtype((np.void, X.dtype.itemsize * X.shape[1]))).ravel(), return_index=True)
    first = np.sort(first)
    if tol > 0.0 and len(first) > 1:
        pairs = near_pairs(X[first], tol)
        if len(pairs):
            # connected components by min-label propagation with pointer jumping (groups of near copies
            # are small: a few rounds); a group's label is its lowest index, which represents it
            label = np.arange(len(first))
            while True:
                low = np.minimum(label[pairs[:, 0]], label[pairs[:, 1]])
                nxt = label.copy()
                np.minimum.at(nxt, pairs[:, 0], low)
                np.minimum.at(nxt, pairs[:, 1], low)
                nxt = nxt[nxt]
                if np.array_equal(nxt, label):
                    break
                label = nxt
            first = first[label == np.arange(len(first))]
    return None if len(first) == len(X) else first


# a fixed generic unit direction in the 6-D space of a match's two bearings: matches within tol of each
# other in both views lie within sqrt(2) tol of each other along it
SWEEP = np.array([0.41, -0.27, 0.53, 0.37, 0.45, -0.38]) / np.linalg.norm([0.41, -0.27, 0.53, 0.37, 0.45, -0.38])
SWEEP_MAX_OFFSET = 64  # sweep offsets before a k-d tree takes over (many matches in one thin slab)


def near_pairs(Y: np.ndarray, tol: float) -> np.ndarray:
    """Index pairs ``(k, 2)`` of the rows of ``Y (m, 6)`` (two unit bearings a row) within ``tol`` of each
    other in both halves: a sweep along :data:`SWEEP` (sorted projections, offsets 1, 2, ... while some
    neighbours lie within ``sqrt(2) tol``; ~0.1 ms for thousands of matches), a k-d tree where the sweep
    would take more than :data:`SWEEP_MAX_OFFSET` offsets."""
    proj = Y @ SWEEP
    order = np.argsort(proj, kind="stable")
    ps = proj[order]
    bound = np.sqrt(2.0) * tol
    out = []
    for k in range(1, len(Y)):
        close = ps[k:] - ps[:-k] < bound
        if not close.any():
            break
        if k > SWEEP_MAX_OFFSET:
            from scipy.spatial import cKDTree

            cand = cKDTree(Y).query_pairs(bound, output_type="ndarray").reshape(-1, 2)
            out = [cand]
            break
        out.append(np.column_stack([order[:-k][close], order[k:][close]]))
    if not out:
        return np.zeros((0, 2), dtype=np.int64)
    P = np.concatenate(out)
    near = (np.linalg.norm(Y[P[:, 0], :3] - Y[P[:, 1], :3], axis=1) < tol) & (np.linalg.norm(Y[P[:, 0], 3:] - Y[P[:, 1], 3:], axis=1) < tol)
    return P[near]


def locally_supported(f1: np.ndarray, extra: np.ndarray, explained: np.ndarray, k_max: int = 10, min_count: int = 2) -> np.ndarray:
    """poseonly.analysis._locally_supported as it was in numpy: ``extra`` kept where at least
    ``min(min_count, k)`` of the ``k`` nearest view-1 bearings among ``explained | extra`` are extra and
    not the same bearing."""
    idx = np.flatnonzero(explained | extra)
    k = min(k_max, len(idx) - 1)
    if k < 1:
        return extra.copy()
    g = np.ascontiguousarray(f1[idx], dtype=float)
    nb = nearest_neighbours(g, k)
    sub = extra[idx]
    other = np.any(g[nb] != g[:, None, :], axis=2)
    out = np.zeros_like(extra)
    out[idx] = sub & (np.count_nonzero(sub[nb] & other, axis=1) >= min(min_count, k))
    return out
