"""Images as a distorted camera sees them, for the tests of the camera-model paths."""

from __future__ import annotations

from typing import Any

import numpy as np


def warp_to_camera(img: np.ndarray, K: np.ndarray, camera: dict[str, Any]) -> np.ndarray:
    """``img`` (taken by the pinhole camera ``K``, OpenCV's pixel convention) as ``camera`` (COLMAP's
    convention: pixel centres at + 0.5) sees it: pixel ``u`` of the result shows ``img`` at ``K b(u)``,
    ``b(u)`` the camera model's bearing of ``u + 0.5`` (same size as ``img``)."""
    import cv2

    from poseonly.cameras import OPENCV_TO_COLMAP_PX, as_camera

    h, w = img.shape[:2]
    u, v = np.meshgrid(np.arange(w, dtype=np.float64), np.arange(h, dtype=np.float64))
    b = as_camera(camera).unproject(np.column_stack([u.ravel(), v.ravel()]) + OPENCV_TO_COLMAP_PX)
    x = b @ np.asarray(K, dtype=np.float64).T
    mx = (x[:, 0] / x[:, 2]).reshape(h, w).astype(np.float32)
    my = (x[:, 1] / x[:, 2]).reshape(h, w).astype(np.float32)
    return cv2.remap(img, mx, my, cv2.INTER_LINEAR)
