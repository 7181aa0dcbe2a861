"""Adapters for the anchor libraries users compare with: OpenCV and PoseLib (optional imports).

Each adapter takes pixel matches ``u1, u2 (n, 2)`` and ``K1, K2`` and returns
``(R, t, inliers, seconds)`` in poseonly's convention (``X2 = R X1 + t``, unit ``t``); a failed call
returns ``R = None``. Timings cover the library call(s) only.
"""

from __future__ import annotations

import time

import numpy as np

__all__ = ["opencv_relpose", "poselib_relpose", "ANCHORS", "available_anchors"]

# (R (3, 3) or None, unit t (3,) or None, inliers (n,) bool, seconds)
AnchorResult = tuple[np.ndarray | None, np.ndarray | None, np.ndarray, float]


def opencv_relpose(
    u1: np.ndarray,
    u2: np.ndarray,
    K1: np.ndarray,
    K2: np.ndarray | None = None,
    *,
    method: str = "RANSAC",
    threshold_px: float = 1.0,
    max_iters: int | None = None,
    prob: float = 0.999,
) -> AnchorResult:
    """``cv2.findEssentialMat`` + ``cv2.recoverPose`` (classic ``RANSAC`` or ``USAC_MAGSAC``).

    With different ``K1, K2`` the points are first normalised and an identity camera is used with
    the threshold divided by the mean focal (OpenCV's single-K overload).
    """
    import cv2

    u1 = np.ascontiguousarray(u1, dtype=np.float64)
    u2 = np.ascontiguousarray(u2, dtype=np.float64)
    K2 = K1 if K2 is None else K2
    flag = {"RANSAC": cv2.RANSAC, "USAC_MAGSAC": cv2.USAC_MAGSAC, "USAC_DEFAULT": cv2.USAC_DEFAULT, "LMEDS": cv2.LMEDS}[method]
    if np.allclose(K1, K2):
        K = np.asarray(K1, float)
        p1, p2, thr = u1, u2, threshold_px
    else:

        def norm(u, K):
            h = np.column_stack([u, np.ones(len(u))]) @ np.linalg.inv(K).T
            return np.ascontiguousarray(h[:, :2] / h[:, 2:])

        p1, p2 = norm(u1, K1), norm(u2, K2)
        f = 0.25 * (K1[0, 0] + K1[1, 1] + K2[0, 0] + K2[1, 1])
        K, thr = np.eye(3), threshold_px / f
    t0 = time.perf_counter()
    args = (p1, p2, K, flag, prob, thr)
    E, mask = cv2.findEssentialMat(*args, maxIters=max_iters) if max_iters else cv2.findEssentialMat(*args)
    if E is None or E.shape != (3, 3):
        return None, None, np.zeros(len(u1), bool), time.perf_counter() - t0
    _, R, t, mask2 = cv2.recoverPose(E, p1, p2, K, mask=mask.copy())
    dt = time.perf_counter() - t0
    return R, t.ravel() / max(float(np.linalg.norm(t)), 1e-300), mask.ravel().astype(bool), dt


def poselib_relpose(
    u1: np.ndarray, u2: np.ndarray, K1: np.ndarray, K2: np.ndarray | None = None, *, threshold_px: float = 1.0, max_iterations: int | None = None, seed: int = 0
) -> AnchorResult:
    """``poselib.estimate_relative_pose`` with PINHOLE cameras (defaults unless given)."""
    import poselib

    K2 = K1 if K2 is None else K2

    def cam(K):
        return {"model": "PINHOLE", "width": int(2 * K[0, 2] + 1), "height": int(2 * K[1, 2] + 1), "params": [float(K[0, 0]), float(K[1, 1]), float(K[0, 2]), float(K[1, 2])]}

    ro = {"max_epipolar_error": float(threshold_px), "seed": int(seed)}
    if max_iterations is not None:
        ro.update(max_iterations=int(max_iterations), min_iterations=min(int(max_iterations), 1000))
    t0 = time.perf_counter()
    pose, info = poselib.estimate_relative_pose(np.asarray(u1, float), np.asarray(u2, float), cam(K1), cam(K2), ro, {})
    dt = time.perf_counter() - t0
    inl = np.asarray(info["inliers"], bool)
    if info["num_inliers"] == 0:
        return None, None, inl, dt
    t = np.asarray(pose.t, float)
    return np.asarray(pose.R, float), t / max(np.linalg.norm(t), 1e-300), inl, dt


ANCHORS = {
    "opencv-ransac": lambda u1, u2, K1, K2, thr, **kw: opencv_relpose(u1, u2, K1, K2, method="RANSAC", threshold_px=thr, **kw),
    "opencv-magsac": lambda u1, u2, K1, K2, thr, **kw: opencv_relpose(u1, u2, K1, K2, method="USAC_MAGSAC", threshold_px=thr, **kw),
    "poselib": lambda u1, u2, K1, K2, thr, **kw: poselib_relpose(u1, u2, K1, K2, threshold_px=thr, **kw),
}


def available_anchors() -> list[str]:
    out = []
    try:
        import cv2  # noqa: F401

        out += ["opencv-ransac", "opencv-magsac"]
    except ImportError:
        pass
    try:
        import poselib  # noqa: F401

        out.append("poselib")
    except ImportError:
        pass
    return out
