"""numpy reference (oracle for tests) of the keypoint-conflict groups and the demotion rule of
``src/core/conflicts.h``: matches sharing a keypoint (identical bearings in one view) among two or
more distinct correspondences form a group; in a group only the correspondence of lowest cost keeps
its cost (ties: the lowest match index), the other members score as outliers (at most once)."""

from __future__ import annotations

import numpy as np


def _ids(rows: np.ndarray) -> np.ndarray:
    _, inv = np.unique(rows, axis=0, return_inverse=True)
    return inv.ravel()


def keypoint_groups(f1: np.ndarray, f2: np.ndarray) -> tuple[list[np.ndarray], np.ndarray]:
    """``(groups, corr)``: each group the sorted match indices of one shared keypoint (view 1's
    groups first, each view's in the order of its keypoints' coordinates); ``corr (n,)`` a
    correspondence id per match (equal ids: identical correspondences)."""
    corr = _ids(np.hstack([f1, f2]))
    groups = []
    for f in (f1, f2):
        order = np.lexsort(f.T[::-1])  # by x, then y, then z
        key = _ids(f)
        for k in dict.fromkeys(key[order]):  # keypoints in coordinate order
            members = np.flatnonzero(key == k)
            if len(np.unique(corr[members])) > 1:
                groups.append(members)
    return groups, corr


def demoted(groups: list[np.ndarray], corr: np.ndarray, cost: np.ndarray) -> np.ndarray:
    """Sorted indices of the matches the rule demotes for per-match costs ``cost (n,)``."""
    out: set[int] = set()
    for g in groups:
        best = int(g[np.argmin(cost[g])])  # argmin returns the first minimum: the lowest index
        out.update(int(i) for i in g if corr[i] != corr[best])
    return np.array(sorted(out), dtype=int)
