"""Optional final bundle adjustment through pycolmap (off by default; reported separately).

The global result is converted to a ``pycolmap.Reconstruction`` (:func:`.export.build_colmap_reconstruction`),
refined by ``pycolmap.bundle_adjustment`` with fixed intrinsics and a Cauchy loss (scale 1 px;
the tracks still hold a few wrong observations), and read back.
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np

from .._pycolmap import import_pycolmap

__all__ = ["bundle_adjust", "poses_from_reconstruction"]

LOSS_SCALE_PX = 1.0


def poses_from_reconstruction(rec: Any, n: int) -> tuple[np.ndarray, np.ndarray]:
    """World -> camera rotations ``(n, 3, 3)`` and centres ``(n, 3)`` of images ``1..n`` (NaN where
    the image has no pose)."""
    R = np.full((n, 3, 3), np.nan)
    C = np.full((n, 3), np.nan)
    for k in range(n):
        if not rec.exists_image(k + 1):
            continue
        img = rec.image(k + 1)
        if not img.has_pose:
            continue
        T = img.cam_from_world().matrix()
        R[k] = T[:, :3]
        C[k] = -T[:, :3].T @ T[:, 3]
    return R, C


def bundle_adjust(rec: Any, max_iterations: int = 100) -> tuple[Any, float]:
    """Bundle-adjust ``rec`` in place (poses and points; intrinsics fixed); returns ``(rec, seconds)``."""
    pycolmap = import_pycolmap()

    opts = pycolmap.BundleAdjustmentOptions()
    opts.refine_focal_length = False
    opts.refine_principal_point = False
    opts.refine_extra_params = False
    opts.print_summary = False
    opts.ceres.loss_function_type = pycolmap.LossFunctionType.CAUCHY
    opts.ceres.loss_function_scale = LOSS_SCALE_PX
    opts.ceres.solver_options.max_num_iterations = int(max_iterations)
    t0 = time.perf_counter()
    pycolmap.bundle_adjustment(rec, opts)
    return rec, time.perf_counter() - t0
