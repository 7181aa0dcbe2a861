"""pycolmap's (GLOMAP's) rotation averaging and global positioning on the same relative poses and
tracks as ours: the side-by-side anchor of ``poseonly experiment global``.

Input is exactly what our pipeline consumed: the view graph's relative poses (as
``PoseGraphEdge(cam2_from_cam1, num_matches = inliers)``) and our tracks (as points3D of a
``pycolmap.Reconstruction`` with one PINHOLE camera per image). pycolmap's defaults are used, with
a fixed random seed; no bundle adjustment.
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np

from .pairwise import ImageGraph
from .tracks import Tracks

__all__ = ["SEED", "run"]

SEED = 0


def _base_reconstruction(ig: ImageGraph, tracks: Tracks | None) -> Any:
    import pycolmap

    rec = pycolmap.Reconstruction()
    for k, f in enumerate(ig.features):
        K = ig.K[k]
        cam = pycolmap.Camera(model="PINHOLE", width=int(f.image_size[0]), height=int(f.image_size[1]),
                              params=[K[0, 0], K[1, 1], K[0, 2], K[1, 2]], camera_id=k + 1)
        rec.add_camera_with_trivial_rig(cam)
        rec.add_image_with_trivial_frame(pycolmap.Image(name=f"{k:06d}", keypoints=np.asarray(f.keypoints, dtype=np.float64),
                                                        camera_id=k + 1, image_id=k + 1))
    return rec


def _poses(rec: Any, n: int) -> tuple[np.ndarray, np.ndarray]:
    R = np.full((n, 3, 3), np.nan)
    C = np.full((n, 3), np.nan)
    for k in range(n):
        img = rec.image(k + 1)
        if not img.has_pose:
            continue
        T = img.cam_from_world().matrix()
        R[k] = T[:, :3]
        C[k] = -T[:, :3].T @ T[:, 3]
    return R, C


def run(ig: ImageGraph, tracks: Tracks) -> dict[str, dict[str, Any]]:
    """``{"rotation averaging + global positioning": {"rotations", "centres", "time_s"}}`` from
    pycolmap on ``ig``'s view graph and ``tracks`` (world -> camera, NaN where not posed)."""
    import pycolmap

    n = len(ig.features)
    rec = _base_reconstruction(ig, tracks)
    pg = pycolmap.PoseGraph()
    for e in ig.graph.edges:
        edge = pycolmap.PoseGraphEdge(pycolmap.Rigid3d(np.concatenate([e.R, e.t[:, None]], axis=1)))
        edge.num_matches = len(e.matches)
        pg.add_edge(e.i + 1, e.j + 1, edge)
    opts = pycolmap.RotationEstimatorOptions()
    opts.random_seed = SEED
    t0 = time.perf_counter()
    ok = pycolmap.run_rotation_averaging(opts, pg, rec, [])
    t_ra = time.perf_counter() - t0
    if not ok:
        raise RuntimeError("pycolmap.run_rotation_averaging failed")
    R_ra, _ = _poses(rec, n)
    for t in range(len(tracks)):
        v, kp = tracks.track(t)
        tr = pycolmap.Track()
        for a, b in zip(v.tolist(), kp.tolist()):
            tr.add_element(a + 1, b)
        rec.add_point3D(np.zeros(3), tr, np.zeros(3, dtype=np.uint8))
    popts = pycolmap.GlobalPositionerOptions()
    popts.random_seed = SEED
    popts.use_gpu = False
    t0 = time.perf_counter()
    ok = pycolmap.run_global_positioning(popts, pg, rec)
    t_gp = time.perf_counter() - t0
    if not ok:
        raise RuntimeError("pycolmap.run_global_positioning failed")
    R, C = _poses(rec, n)
    return {"rotation averaging + global positioning": {"rotations": R, "centres": C, "time_s": t_ra + t_gp,
                                                        "rotation_averaging_rotations": R_ra}}
