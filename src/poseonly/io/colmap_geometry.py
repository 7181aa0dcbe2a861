"""A result as COLMAP's two-view geometry: its configuration, inlier matches, E, F, H and pose.

One mapping for ``poseonly colmap verify`` (which writes the rows into a database) and for callers
who hold their own matches (:func:`to_two_view_geometry`, a ``pycolmap.TwoViewGeometry`` in memory):

=====================  ======================  =====================================================
our status             COLMAP configuration    content
=====================  ======================  =====================================================
``ok``, ``uncertain``  ``CALIBRATED``          inliers, E, F (given both K), cam2_from_cam1
``planar_ambiguous``   ``PLANAR_OR_PANORAMIC`` same + H (DLT on the inlier keypoints, given them)
``pure_rotation``      ``PANORAMIC``           inliers, H, cam2_from_cam1 with ``t = 0``
``ambiguous``          ``MULTIPLE``            no inliers (two poses explain the matches)
``too_few_inliers``,   ``DEGENERATE``          no inliers
``degenerate``
=====================  ======================  =====================================================

Conventions are COLMAP's and poseonly's alike: ``X2 = R X1 + t`` is ``cam2_from_cam1``,
``E = [t]x R``, ``F = K2^-T E K1^-1`` (scaled to unit norm), ``x2^T F x1 = 0`` in pixels.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from .._pycolmap import import_pycolmap
from ..geometry import InputError, check_intrinsics

if TYPE_CHECKING:
    from ..result import RelativePoseResult

__all__ = ["ERROR_CONFIG", "STATUS_CONFIG", "TwoViewFields", "homography_dlt", "pycolmap_geometry_kwargs", "to_two_view_geometry", "two_view_fields"]

STATUS_CONFIG = {
    "ok": "CALIBRATED",
    "planar_ambiguous": "PLANAR_OR_PANORAMIC",
    "ambiguous": "MULTIPLE",
    # the inliers single out the epipolar geometry, the rotation is only poorly determined: COLMAP gets the
    # inlier matches as calibrated two-view geometry (its bundle adjustment re-estimates every pose)
    "uncertain": "CALIBRATED",
    "pure_rotation": "PANORAMIC",
    "too_few_inliers": "DEGENERATE",
    "degenerate": "DEGENERATE",
}
ERROR_CONFIG = "UNDEFINED"
KEYPOINT_INDEX_LIMIT = 2**32  # COLMAP stores keypoint indices as uint32
WITH_INLIERS = ("CALIBRATED", "PLANAR_OR_PANORAMIC", "PANORAMIC")


def homography_dlt(u1: np.ndarray, u2: np.ndarray) -> np.ndarray | None:
    """Normalized DLT homography ``u2 ~ H u1`` of pixel matches ``(n, 2)``, ``n >= 4`` (Hartley &
    Zisserman Alg. 4.2); ``None`` when degenerate. ``H (3, 3)`` with ``H[2, 2] = 1`` when possible."""
    if len(u1) < 4:
        return None

    def norm(u: np.ndarray) -> np.ndarray:
        c = u.mean(axis=0)
        s = np.sqrt(2.0) / max(float(np.mean(np.linalg.norm(u - c, axis=1))), 1e-12)
        return np.array([[s, 0, -s * c[0]], [0, s, -s * c[1]], [0, 0, 1.0]])

    T1, T2 = norm(u1), norm(u2)
    a = np.column_stack([u1, np.ones(len(u1))]) @ T1.T
    b = np.column_stack([u2, np.ones(len(u2))]) @ T2.T
    z = np.zeros((len(a), 3))
    A = np.concatenate([np.hstack([z, -b[:, 2:3] * a, b[:, 1:2] * a]), np.hstack([b[:, 2:3] * a, z, -b[:, 0:1] * a])])
    _, s, Vt = np.linalg.svd(A, full_matrices=False)
    if s[-2] < 1e-12 * s[0]:
        return None
    H = np.linalg.inv(T2) @ Vt[-1].reshape(3, 3) @ T1
    return H / H[2, 2] if abs(H[2, 2]) > 1e-12 * np.abs(H).max() else H / np.abs(H).max()


@dataclass
class TwoViewFields:
    """A two-view geometry's fields: ``config`` (a ``pycolmap.TwoViewGeometryConfiguration`` name),
    ``inlier_matches (k, 2)`` keypoint indices, ``E, F, H (3, 3)`` or ``None``, ``R (3, 3)``, ``t (3,)``
    or ``None`` (cam2_from_cam1)."""

    config: str
    inlier_matches: np.ndarray
    E: np.ndarray | None = None
    F: np.ndarray | None = None
    H: np.ndarray | None = None
    R: np.ndarray | None = None
    t: np.ndarray | None = None


def two_view_fields(
    result: RelativePoseResult,
    matches: np.ndarray | None = None,
    K1: np.ndarray | None = None,
    K2: np.ndarray | None = None,
    keypoints1: np.ndarray | None = None,
    keypoints2: np.ndarray | None = None,
    keep_uncertain: bool = True,
) -> TwoViewFields:
    """The fields of ``result`` (one pair's, from ``n`` matches) by the table above.

    ``matches (n, 2)``: the keypoint indices of the matches the result was estimated from (default: match
    ``i`` is keypoint ``i`` in both images); ``K1, K2 (3, 3)``: the pinhole intrinsics for F (none without
    both: a distorted camera has no F); ``keypoints1 (m1, 2)``, ``keypoints2 (m2, 2)``: pixel keypoints
    for H (none without them); ``keep_uncertain=False``: a result with status ``uncertain`` is written
    ``DEGENERATE`` without inliers, as ``too_few_inliers`` is (for pipelines that keep only poses to trust)."""
    n = len(result.inliers)
    if matches is None:
        idx = np.arange(n)
        m = np.column_stack([idx, idx])
    else:
        m = np.asarray(matches)
        if m.ndim != 2 or m.shape != (n, 2) or m.dtype.kind not in "iu" or (m.size and (m.min() < 0 or m.max() >= KEYPOINT_INDEX_LIMIT)):
            raise InputError(f"matches must be keypoint indices in [0, 2**32) (COLMAP's point2D_idx) of shape ({n}, 2), the result's matches; got {m.dtype} {m.shape}")
    config = STATUS_CONFIG.get(result.status, ERROR_CONFIG)
    if result.status == "uncertain" and not keep_uncertain:
        config = "DEGENERATE"
    if config not in WITH_INLIERS:
        return TwoViewFields(config, np.zeros((0, 2), dtype=np.int64))
    inl = m[result.inliers]
    F = None
    if K1 is not None and K2 is not None and config != "PANORAMIC":
        F = np.linalg.inv(check_intrinsics(K2, "K2")).T @ result.E @ np.linalg.inv(check_intrinsics(K1, "K1"))
        F = F / np.linalg.norm(F)
    H = None
    if config != "CALIBRATED" and keypoints1 is not None and keypoints2 is not None:
        H = homography_dlt(np.asarray(keypoints1, float)[inl[:, 0]], np.asarray(keypoints2, float)[inl[:, 1]])
    pano = config == "PANORAMIC"
    return TwoViewFields(config, inl, E=None if pano else result.E, F=F, H=H, R=result.R, t=np.zeros(3) if pano else result.t)


def pycolmap_geometry_kwargs(f: TwoViewFields, pycolmap: Any) -> dict[str, Any]:
    """The keyword arguments of ``pycolmap.TwoViewGeometry`` for ``f``."""
    kw: dict[str, Any] = {
        "config": pycolmap.TwoViewGeometryConfiguration.__members__[f.config],
        "inlier_matches": np.ascontiguousarray(f.inlier_matches, dtype=np.uint32).reshape(-1, 2),
    }
    for name in ("E", "F", "H"):
        v = getattr(f, name)
        if v is not None:
            kw[name] = np.asarray(v, dtype=float)
    if f.R is not None and f.t is not None:
        kw["cam2_from_cam1"] = pycolmap.Rigid3d(pycolmap.Rotation3d(np.asarray(f.R, float)), np.asarray(f.t, float))
    return kw


def to_two_view_geometry(
    result: RelativePoseResult,
    matches: np.ndarray | None = None,
    *,
    K1: np.ndarray | None = None,
    K2: np.ndarray | None = None,
    keypoints1: np.ndarray | None = None,
    keypoints2: np.ndarray | None = None,
) -> Any:
    """``result`` as a ``pycolmap.TwoViewGeometry`` (pycolmap needed), as ``poseonly colmap verify``
    writes it: see :func:`two_view_fields` for the arguments and the module's table for the mapping."""
    pycolmap = import_pycolmap()
    return pycolmap.TwoViewGeometry(**pycolmap_geometry_kwargs(two_view_fields(result, matches, K1, K2, keypoints1, keypoints2), pycolmap))
