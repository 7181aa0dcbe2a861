"""Vectorised SO(3) maps used by the global stages (``(n, 3, 3)`` matrices, ``(n, 3)`` rotation
vectors), built on ``scipy.spatial.transform.Rotation`` (accurate near 0 and pi)."""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

__all__ = ["angle_deg", "exp_so3", "log_so3", "project_so3"]


def exp_so3(w: np.ndarray) -> np.ndarray:
    """``(n, 3)`` rotation vectors -> ``(n, 3, 3)`` matrices."""
    w = np.asarray(w, dtype=np.float64).reshape(-1, 3)
    return Rotation.from_rotvec(w).as_matrix().reshape(-1, 3, 3)


def log_so3(R: np.ndarray) -> np.ndarray:
    """``(n, 3, 3)`` rotations -> ``(n, 3)`` rotation vectors (angle in ``[0, pi]``)."""
    R = np.asarray(R, dtype=np.float64).reshape(-1, 3, 3)
    return Rotation.from_matrix(R).as_rotvec().reshape(-1, 3)


def angle_deg(R: np.ndarray) -> np.ndarray:
    """``(n,)`` rotation angles in degrees of ``(n, 3, 3)`` rotations."""
    return np.degrees(np.linalg.norm(log_so3(R), axis=1))


def project_so3(M: np.ndarray) -> np.ndarray:
    """Nearest rotations (SVD) of ``(n, 3, 3)`` matrices."""
    M = np.asarray(M, dtype=np.float64).reshape(-1, 3, 3)
    U, _, Vt = np.linalg.svd(M)
    d = np.sign(np.linalg.det(U @ Vt))
    U[:, :, 2] *= d[:, None]
    return U @ Vt
