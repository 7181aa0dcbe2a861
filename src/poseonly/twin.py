"""The planar two-fold ambiguity: the homography twin of a pose (notes section 5).

Points on a plane ``n^T X1 = d`` satisfy ``X2 = (R + t n^T / d) X1 = H X1``. A homography has (up
to sign) two decompositions ``(R, t, n)`` with all points in front of both cameras; both explain the
plane's correspondences exactly, so no two-view residual can tell them apart. Given a pose and its
inliers, :func:`homography_twin` fits the dominant plane to the midpoint-triangulated inliers, forms
``H`` and returns the other decomposition. Decomposition: Ma, Soatto, Kosecka, Sastry, *An Invitation
to 3-D Vision*, Sec. 5.3.3 (the SVD method of Faugeras & Lustman 1988). Both run in the core
(``src/core/analysis.cpp``); the numpy reference is ``tests/reference/twin.py``.
"""

from __future__ import annotations

import numpy as np

from . import _core

__all__ = ["decompose_homography", "homography_twin", "homography_twin_dlt"]


def _c(a: np.ndarray) -> np.ndarray:
    return np.ascontiguousarray(a, dtype=float)


def decompose_homography(H: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The four ``(R, t/d, n)`` of a calibrated homography ``H (3, 3) ~ R + t n^T / d``.

    Returns ``R (4, 3, 3)``, ``T (4, 3)`` (``t / d``) and unit normals ``N (4, 3)``, the middle
    singular value of ``H`` scaled to 1. Raises :class:`ValueError` when ``H`` is not finite or has
    a vanishing middle singular value.
    """
    H = _c(H)
    if H.shape != (3, 3):
        raise ValueError(f"H must have shape (3, 3), got {H.shape}")
    out = _core.decompose_homography(H)
    if out is None:
        raise ValueError("H must be finite with a non-zero middle singular value")
    return out


def homography_twin(R: np.ndarray, t: np.ndarray, f1: np.ndarray, f2: np.ndarray) -> tuple[np.ndarray, np.ndarray, float] | None:
    """The other physically valid decomposition of the homography induced by the dominant plane.

    ``R (3, 3)``, ``t (3,)``: the pose; ``f1, f2 (m, 3)``: its inlier bearings. Returns ``(R_twin,
    t_twin (unit), planarity)`` where planarity is the ratio of the smallest to the middle singular
    value of the centred triangulated points (0 for an exact plane), or ``None`` when fewer than 4
    points triangulate in front of the cameras or the plane fit / decomposition is degenerate.
    """
    return _core.homography_twin(_c(R), _c(t), _c(f1), _c(f2))


def homography_twin_dlt(R: np.ndarray, t: np.ndarray, f1: np.ndarray, f2: np.ndarray, max_transfer: float = float("inf")) -> tuple[np.ndarray, np.ndarray] | None:
    """The other physically valid decomposition of the homography fitted to the inliers ``f1, f2 (m, 3)``
    of ``(R (3, 3), t (3,))`` directly (DLT on the bearings, ``f2 x H f1 = 0``, ``H`` signed so that
    ``H f1`` points along ``f2`` for most matches): ``(R_twin, t_twin (unit))`` or ``None`` (fewer than 4
    matches, a degenerate fit or decomposition, ``H`` carrying fewer than 90 % of the matches to within
    ``max_transfer`` radians, fewer than two valid decompositions). The status analysis's fallback (at
    twice its threshold) where :func:`homography_twin`'s triangulated plane misses the twin (forward
    motion triangulates the points near the focus of expansion poorly)."""
    return _core.homography_twin_dlt(_c(R), _c(t), _c(f1), _c(f2), float(max_transfer))
