"""Reference of :func:`poseonly.features.match_features` as it was before the blocked matrix
products: OpenCV's ``cv2.batchDistance`` (the kernel of ``cv2.BFMatcher``) for the two nearest
neighbours, and a second full pass the other way for the mutual check. The library must give the
same matches up to neighbours whose distances tie to float32 precision, and the same scores to ~1e-6
(tests/test_matching.py, benchmarks/match_speed.py)."""

from __future__ import annotations

import numpy as np


def match_features_batchdistance(d1: np.ndarray, d2: np.ndarray, ratio: float = 0.8, mutual: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """``(k, 2)`` matches and their scores ``1 - dist1 / dist2`` (``(k,)``)."""
    import cv2

    d1 = np.ascontiguousarray(d1, dtype=np.float32)
    d2 = np.ascontiguousarray(d2, dtype=np.float32)
    dist, nn = cv2.batchDistance(d1, d2, cv2.CV_32F, normType=cv2.NORM_L2, K=2)
    keep = dist[:, 0] < float(ratio) * dist[:, 1]
    i1 = np.flatnonzero(keep)
    i2 = nn[keep, 0].astype(np.int64)
    if mutual and len(i1):
        _, back = cv2.batchDistance(d2, d1, cv2.CV_32F, normType=cv2.NORM_L2, K=1)
        ok = back[i2, 0] == i1
        i1, i2 = i1[ok], i2[ok]
    idx = np.stack([i1, i2], axis=1).astype(np.int64) if len(i1) else np.zeros((0, 2), np.int64)
    d = dist[i1].astype(float)
    return idx, 1.0 - d[:, 0] / np.maximum(d[:, 1], 1e-300)
