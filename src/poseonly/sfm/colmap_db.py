"""A view graph from a COLMAP database (``poseonly sfm --database colmap.db``; needs pycolmap).

Read: cameras (every perspective COLMAP model; keypoints are lifted to unit bearings by
:meth:`poseonly.cameras.Camera.unproject`, which also gives a fisheye's rays beyond 90 deg: pycolmap's
``cam_from_img`` returns normalized coordinates, which mirror them), images (sorted by name; view ``k`` is the ``k``-th name), keypoints and
the putative ``matches`` table. Every pair with at least ``min_matches`` matches is estimated by
:func:`poseonly.estimate_relative_pose` on the bearings (threshold in pixels at the
focal of the two cameras, :func:`poseonly.geometry.pair_focal`); COLMAP's own two-view geometries are not used. The exported
COLMAP model keeps the database's camera models and parameters.
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from .._pycolmap import import_pycolmap
from ..cameras import as_camera
from ..features import Features, match_noise_scales
from ..geometry import InputError, pair_focal
from ..io.colmap_db import database_unavailable, guessed_focal, keypoint_scales, matched_pair_ids, reading_snapshot, refuse_guessed_focal
from ..quantization import image_grid_step, pair_grid_step
from .pairwise import ImageGraph, PairwiseOptions, TwoView, map_ordered, pair_seed, two_view
from .viewgraph import ViewGraph

__all__ = ["database_view_graph"]


def database_view_graph(
    db_path: str | os.PathLike,
    *,
    options: PairwiseOptions | None = None,
    cache_dir: str | os.PathLike | None = None,
    progress: Callable | None = None,
    jobs: int = 1,
    check_names: Callable[[list[str]], None] | None = None,
    trust_guessed_focal: bool = False,
    camera: Any = None,
) -> tuple[ImageGraph, list[str]]:
    """``(ImageGraph, image names)`` from the COLMAP database ``db_path``; the pairs are estimated on
        ``jobs`` threads (:func:`poseonly.sfm.pairwise.map_ordered`: the same graph for any number).
        ``check_names(names)``, if given, runs on the image names before any pair is estimated (e.g. that
        the images exist). A pair whose matches index keypoints its images do not have is rejected, as
        ``poseonly colmap verify`` marks it; the file is checked to be a COLMAP database and never changed
    (pycolmap reads a copy without the descriptors' rows, in ``cache_dir``: :func:`poseonly.io.colmap_db.reading_snapshot`).
        A database with a camera whose focal length COLMAP guessed (no prior focal length) is refused
        (:func:`poseonly.io.colmap_db.refuse_guessed_focal`) unless ``trust_guessed_focal``. ``camera``
        (anything :func:`poseonly.cameras.as_camera` takes, in COLMAP's pixel convention) replaces every
        image's database camera, as ``poseonly colmap verify --camera-model`` does (the exported model holds
        it, with each image's size from the database)."""
    pycolmap = import_pycolmap()

    p = Path(db_path)
    matched_pair_ids(p)  # an existing COLMAP database (pycolmap would add its tables to any file)
    opt = options or PairwiseOptions()
    wrap = progress or (lambda it, **_: it)
    t0 = time.perf_counter()
    with reading_snapshot(p, cache_dir) as snap:  # pycolmap opens read-write: it reads a copy, the file stays as it is
        try:
            opened = pycolmap.Database.open(str(snap))
        except RuntimeError as exc:  # pycolmap: "No registered database factory succeeded"
            raise database_unavailable(p, exc, "opening a copy of it with pycolmap to read") from None
        with opened as db:
            images = sorted(db.read_all_images(), key=lambda im: im.name)
            if len(images) < 2:
                raise InputError(f"{p} holds {len(images)} images; need at least two")
            if check_names is not None:
                check_names([im.name for im in images])
            cams = {c.camera_id: c for c in db.read_all_cameras()}
            given = None if camera is None else as_camera(camera, "camera")
            if not trust_guessed_focal and given is None:
                used = {im.camera_id for im in images}
                refuse_guessed_focal(
                    p,
                    (g for c in cams.values() if c.camera_id in used and (g := guessed_focal(c)) is not None),
                    "Import the images with their calibration (COLMAP: ImageReader.camera_params), give it (--camera-model / --camera-params;"
                    " camera= in Python), or use the guess (--trust-guessed-focal; trust_guessed_focal=True in Python).",
                )
            index = {im.image_id: k for k, im in enumerate(images)}
            feats, normalized, Ks, focal, cameras = [], [], [], [], []
            for im in images:
                cam = cams.get(im.camera_id)
                if cam is None:
                    raise InputError(f"{p}: image {im.name!r} (id {im.image_id}) refers to camera {im.camera_id}, which is not in the database")
                native = as_camera(cam, f"{p}: camera {im.camera_id}") if given is None else given
                cameras.append({"model": native.model, "width": int(cam.width), "height": int(cam.height), "params": list(native.params)})
                raw = np.asarray(db.read_keypoints(im.image_id), dtype=np.float64)
                raw = raw.reshape(len(raw), -1) if raw.size else np.zeros((0, 2))
                kp = raw[:, :2]
                feats.append(Features(kp, np.zeros((len(kp), 0), np.float32), (int(cam.width), int(cam.height)), keypoint_scales(raw)))
                lifted = np.full((len(kp), 3), np.nan)
                finite = np.isfinite(kp).all(axis=1)  # a NaN keypoint leaves only its own matches out
                if finite.any():
                    lifted[finite] = native.unproject(kp[finite], invalid="nan")
                normalized.append(lifted)
                Ks.append(native.K)
                focal.append(native.focal_px)
            pair_ids, matches = db.read_all_matches()
    times = {"features": time.perf_counter() - t0, "matching": 0.0}
    pairs = []
    for pid, m in zip(pair_ids, matches):
        a, b = pycolmap.pair_id_to_image_pair(pid)
        if a > b:  # COLMAP writes the smaller image id first (as poseonly colmap verify, which refuses this too)
            raise InputError(f"{p}: pair id {pid} of the matches table has image ids {a} > {b}, which COLMAP does not write; the database was not written through COLMAP's API")
        if a not in index or b not in index:
            continue
        i, j = index[a], index[b]
        mm = np.asarray(m, dtype=np.int64).reshape(-1, 2)
        if i > j:
            i, j, mm = j, i, mm[:, ::-1]
        pairs.append((i, j, mm))
    pairs.sort(key=lambda x: (x[0], x[1]))
    graph = ViewGraph(len(images))
    stats: list[tuple[int, int, int, int, str]] = []
    putative: dict[tuple[int, int], np.ndarray] = {}
    cache = Path(cache_dir) if cache_dir is not None else None
    # keypoints the camera model cannot lift (NaN beyond the invertible region or the image disc)
    valid: list[np.ndarray | None] = [None if np.isfinite(x).all() else np.asarray(np.isfinite(x).all(axis=1)) for x in normalized]
    steps = [image_grid_step(f.keypoints) for f in feats]  # e.g. SuperPoint's pixel centres (hloc)
    t0 = time.perf_counter()

    def pair_job(kp: tuple[int, tuple[int, int, np.ndarray]]) -> tuple[np.ndarray, TwoView | None | str]:
        """The pair's matches (those whose keypoints both cameras lift) and its two-view result (or why
        it has none)."""
        k, (i, j, m) = kp
        if len(m) and (m.min() < 0 or m[:, 0].max() >= len(normalized[i]) or m[:, 1].max() >= len(normalized[j])):
            return m[:0], "matches index keypoints that do not exist"
        if valid[i] is not None or valid[j] is not None:
            ok = np.ones(len(m), bool)
            for v, col in ((valid[i], 0), (valid[j], 1)):
                if v is not None:
                    ok &= v[m[:, col]]
            m = m[ok]
        if len(m) < opt.min_matches:
            return m, None
        ns = match_noise_scales(feats[i], feats[j], m)
        seed = pair_seed(opt.seed, i, j, len(images))
        step = pair_grid_step(steps[i], steps[j])  # the keypoints' rounding (lifted to bearings, the estimate cannot see it)
        return m, two_view(
            normalized[i][m[:, 0]], normalized[j][m[:, 1]], None, None, opt, seed, cache, focal_px=pair_focal(focal[i], focal[j]), noise_scales=ns, coordinate_step_px=step
        )

    for (i, j, _), (pm, r) in zip(pairs, wrap(map_ordered(pair_job, enumerate(pairs), jobs), desc="pairs", total=len(pairs)), strict=True):
        putative[(i, j)] = pm
        if isinstance(r, str):
            graph.rejected.append((i, j, r))
            stats.append((i, j, 0, 0, "invalid_matches"))
            continue
        if r is None:
            graph.rejected.append((i, j, f"{len(pm)} putative matches"))
            stats.append((i, j, len(pm), 0, "few_matches"))
            continue
        graph.add_result(i, j, r, pm)
        stats.append((i, j, len(pm), int(r.num_inliers), r.status))
    times["two_view"] = time.perf_counter() - t0
    ig = ImageGraph(feats, np.array(Ks), graph, stats, times, putative, normalized, cameras=cameras)
    return ig, [im.name for im in images]
