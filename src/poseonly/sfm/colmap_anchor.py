"""pycolmap anchors of ``poseonly experiment global``.

* :func:`run`: pycolmap's (GLOMAP's) rotation averaging and global positioning on exactly what our
  global stages consumed: the view graph's relative poses (``PoseGraphEdge(cam2_from_cam1,
  num_matches = inliers)``) and our tracks (points3D of a ``pycolmap.Reconstruction`` with one
  PINHOLE camera per image); pycolmap's defaults, fixed seed, no bundle adjustment.
* :func:`run_mappers`: pycolmap's own end-to-end pipelines, the global mapper (GLOMAP) and the
  incremental mapper, with their defaults (bundle adjustment included) except that the known
  calibration is a focal prior and is kept fixed (as in ours), seed 0, on the same images, SIFT
  keypoints and putative matches as ours, written to a fresh COLMAP database; their own two-view
  verification (``pycolmap.verify_matches``) replaces ours.
"""

from __future__ import annotations

import os
import shutil
import tempfile
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from .._pycolmap import import_pycolmap
from .colmap_ba import poses_from_reconstruction
from .pairwise import ImageGraph
from .tracks import Tracks

__all__ = ["SEED", "run", "run_mappers", "write_database"]

SEED = 0


def _camera(ig: ImageGraph, k: int, **kw: Any) -> Any:
    """Image ``k``'s ``pycolmap.Camera``: PINHOLE from ``ig.K``, or the COLMAP camera its keypoints
    were lifted through (``ig.cameras``)."""
    pycolmap = import_pycolmap()

    if ig.cameras is not None:
        c = ig.cameras[k]
        return pycolmap.Camera(model=str(c["model"]), width=int(c["width"]), height=int(c["height"]), params=[float(v) for v in c["params"]], **kw)
    K, (w, h) = ig.K[k], ig.features[k].image_size
    return pycolmap.Camera(model="PINHOLE", width=int(w), height=int(h), params=[K[0, 0], K[1, 1], K[0, 2], K[1, 2]], **kw)


def _base_reconstruction(ig: ImageGraph, tracks: Tracks | None) -> Any:
    pycolmap = import_pycolmap()

    rec = pycolmap.Reconstruction()
    for k in range(len(ig.features)):
        rec.add_camera_with_trivial_rig(_camera(ig, k, camera_id=k + 1))
        rec.add_image_with_trivial_frame(pycolmap.Image(name=f"{k:06d}", keypoints=np.asarray(ig.camera_keypoints(k), dtype=np.float64), camera_id=k + 1, image_id=k + 1))
    return rec


def run(ig: ImageGraph, tracks: Tracks) -> dict[str, dict[str, Any]]:
    """``{"rotation averaging + global positioning": {"rotations", "centres", "time_s"}}`` from
    pycolmap on ``ig``'s view graph and ``tracks`` (world -> camera, NaN where not posed)."""
    pycolmap = import_pycolmap()

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
    R_ra, _ = poses_from_reconstruction(rec, n)
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
    R, C = poses_from_reconstruction(rec, n)
    return {"rotation averaging + global positioning": {"rotations": R, "centres": C, "time_s": t_ra + t_gp, "rotation_averaging_rotations": R_ra}}


def write_database(db_path: Path, names: Sequence[str], ig: ImageGraph) -> None:
    """A new COLMAP database at ``db_path``: one camera (PINHOLE from ``ig.K``, or ``ig.cameras``'
    model), trivial rig and frame per image (``names``), the keypoints (in the cameras' pixel
    convention) and the putative matches of ``ig``."""
    pycolmap = import_pycolmap()

    with pycolmap.Database.open(str(db_path)) as db:
        for k, name in enumerate(names):
            cam = _camera(ig, k)
            cam.has_prior_focal_length = True  # the calibration is known, as for our pipeline
            cid = db.write_camera(cam)
            sensor = pycolmap.sensor_t(pycolmap.SensorType.CAMERA, cid)
            rig = pycolmap.Rig()
            rig.add_ref_sensor(sensor)
            rid = db.write_rig(rig)
            iid = db.write_image(pycolmap.Image(name=str(name), camera_id=cid))
            frame = pycolmap.Frame()
            frame.rig_id = rid
            frame.add_data_id(pycolmap.data_t(sensor, iid))
            db.write_frame(frame)
            db.write_keypoints(iid, np.asarray(ig.camera_keypoints(k), dtype=np.float32))
        for (i, j), idx in sorted(ig.putative.items()):
            db.write_matches(i + 1, j + 1, np.asarray(idx, dtype=np.uint32))


def run_mappers(ig: ImageGraph, image_paths: Sequence[str | os.PathLike]) -> dict[str, dict[str, Any]]:
    """``{"global mapper (GLOMAP)": ..., "incremental mapper": ...}`` with ``rotations``, ``centres``
    (NaN where not registered; the largest model) and ``time_s`` (verification included)."""
    pycolmap = import_pycolmap()

    paths = [Path(p) for p in image_paths]
    if len({p.parent for p in paths}) != 1:
        raise ValueError("run_mappers needs all images in one folder")
    names = [p.name for p in paths]
    n = len(paths)
    work = Path(tempfile.mkdtemp(prefix="poseonly_colmap_"))
    try:
        db = work / "database.db"
        write_database(db, names, ig)
        pairs = work / "pairs.txt"
        pairs.write_text("".join(f"{names[i]} {names[j]}\n" for (i, j) in sorted(ig.putative)))
        t0 = time.perf_counter()
        pycolmap.verify_matches(str(db), str(pairs))
        t_verify = time.perf_counter() - t0
        out: dict[str, dict[str, Any]] = {}
        gopt = pycolmap.GlobalPipelineOptions()
        gopt.random_seed = SEED
        gopt.mapper.bundle_adjustment.refine_focal_length = False  # known calibration, as ours
        gopt.mapper.bundle_adjustment.refine_extra_params = False
        iopt = pycolmap.IncrementalPipelineOptions()
        iopt.random_seed = SEED
        iopt.ba_refine_focal_length = False
        iopt.ba_refine_extra_params = False
        for label, fn, o in (("global mapper (GLOMAP)", pycolmap.global_mapping, gopt), ("incremental mapper", pycolmap.incremental_mapping, iopt)):
            sub = work / label.split()[0]
            sub.mkdir()
            t0 = time.perf_counter()
            recs = fn(str(db), str(paths[0].parent), str(sub), o)
            dt = time.perf_counter() - t0 + t_verify
            R = np.full((n, 3, 3), np.nan)
            C = np.full((n, 3), np.nan)
            if recs:
                best = max(recs.values(), key=lambda r: r.num_reg_images())
                for img in best.images.values():
                    if img.has_pose:
                        T = img.cam_from_world().matrix()
                        k = names.index(img.name)
                        R[k], C[k] = T[:, :3], -T[:, :3].T @ T[:, 3]
            out[label] = {"rotations": R, "centres": C, "time_s": dt}
        return out
    finally:
        shutil.rmtree(work, ignore_errors=True)
