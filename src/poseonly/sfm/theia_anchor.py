"""pyTheia anchors of ``poseonly experiment global`` (optional: ``pip install pytheia``).

On exactly what our global stages consumed (the view graph's relative poses and our tracks):

* ``robust rotation averaging + LiGT``: Theia's ``RobustRotationEstimator`` (Chatterjee-Govindu L1
  rotation averaging, then IRLS; its defaults), started from the same maximum-weight spanning-tree
  rotations as ours (:func:`poseonly.sfm.rotation_averaging.spanning_tree_rotations`; Theia's own
  pipeline also starts from a spanning tree), then Theia's ``LiGTPositionEstimator`` (Cai et al.'s
  LiGT; its defaults) on our tracks with those rotations;
* ``LiGT on our rotations``: Theia's LiGT on our tracks with *our* averaged rotations, so that the two
  LiGT implementations are compared on identical input.

No bundle adjustment. Theia's conventions: orientations are world -> camera angle-axis vectors, a
view pair ``(i, j)`` (``i < j``) holds ``rotation_2 = R_j R_i^T`` and ``position_2`` the unit
direction of camera j's centre in camera i's frame. The observations are given as normalized image
coordinates (``x / z, y / z`` of our bearings) on cameras with unit focal length and zero principal
point, so both LiGTs see the same rays.
"""

from __future__ import annotations

import contextlib
import os
import sys
import time
from collections.abc import Callable, Iterator
from typing import Any

import numpy as np

from .rotation_averaging import spanning_tree_rotations
from .tracks import Tracks
from .viewgraph import ViewGraph, largest_component, view_components

__all__ = ["run"]

# a track observation whose bearing points this close to the image plane (z <= this) has no
# normalized coordinates; such observations (only possible with wide cameras) are left out
MIN_BEARING_Z = 1e-6


@contextlib.contextmanager
def _quiet_stdout() -> Iterator[None]:
    """Theia's LiGT prints its triplet count to the C-level stdout (file descriptor 1, whatever
    ``sys.stdout`` is): keep it off ours."""
    sys.stdout.flush()
    fd = 1
    saved = os.dup(fd)
    try:
        with open(os.devnull, "w") as null:
            os.dup2(null.fileno(), fd)
            yield
    finally:
        _flush_c_stdio()  # what the C/C++ side buffered goes to /dev/null, not to the restored stdout
        os.dup2(saved, fd)
        os.close(saved)


def _flush_c_stdio() -> None:
    """``fflush(NULL)`` of the C library (std::cout is synchronised with C stdio by default)."""
    import ctypes

    try:
        ctypes.CDLL(None).fflush(None)
    except (OSError, AttributeError):  # pragma: no cover - no C library handle on this platform
        pass


def _rotvec(R: np.ndarray) -> np.ndarray:
    from scipy.spatial.transform import Rotation

    return Rotation.from_matrix(R).as_rotvec()


def _matrices(rotvecs: dict[int, np.ndarray], n: int) -> np.ndarray:
    from scipy.spatial.transform import Rotation

    R = np.full((n, 3, 3), np.nan)
    for k, v in rotvecs.items():
        R[int(k)] = Rotation.from_rotvec(np.asarray(v, dtype=float)).as_matrix()
    return R


def _view_pairs(g: ViewGraph, views: np.ndarray, translation_only: bool = False) -> dict[tuple[int, int], Any]:
    """Theia's view pairs of the edges between ``views``; ``translation_only``: only the edges whose
    translation is trusted (LiGT's sign vote uses their directions)."""
    import pytheia as pt

    keep = np.zeros(g.num_views, dtype=bool)
    keep[views] = True
    out = {}
    for e in g.edges:
        if not (keep[e.i] and keep[e.j]) or (translation_only and not e.use_translation):
            continue
        info: Any = pt.sfm.TwoViewInfo()  # pyTheia's stubs type its fields wrongly
        info.rotation_2 = _rotvec(e.R)
        c = -e.R.T @ e.t  # camera j's centre in camera i's frame (X_j = R X_i + t)
        info.position_2 = c / np.linalg.norm(c)
        info.num_verified_matches = len(e.matches)
        out[(int(e.i), int(e.j))] = info
    return out


def _theia_ligt(tracks: Tracks, b: np.ndarray, R: np.ndarray, pairs: dict[tuple[int, int], Any]) -> np.ndarray:
    """Theia's LiGT centres ``(n, 3)`` (NaN where not estimated) from world -> camera rotations
    ``R (n, 3, 3)`` (NaN rows: views left out), the tracks and their observations' bearings
    ``b (M, 3)``."""
    import pytheia as pt

    n = len(R)
    posed = np.all(np.isfinite(R.reshape(n, 9)), axis=1)
    rec = pt.sfm.Reconstruction()
    vid = {}
    for k in np.flatnonzero(posed):
        v = rec.AddView(f"{k:06d}", 0, float(k))
        cam = rec.MutableView(v).MutableCamera()
        cam.SetFocalLength(1.0)
        cam.SetPrincipalPoint(0.0, 0.0)
        vid[int(k)] = v
    obs_view = tracks.views
    n_triplet_tracks = 0
    for t in range(len(tracks)):
        lo, hi = int(tracks.ptr[t]), int(tracks.ptr[t + 1])
        rows = [o for o in range(lo, hi) if posed[obs_view[o]] and b[o, 2] > MIN_BEARING_Z]
        if len(rows) < 2:
            continue
        n_triplet_tracks += len({int(obs_view[o]) for o in rows}) >= 3
        tid = rec.AddTrack()
        for o in rows:
            rec.AddObservation(vid[int(obs_view[o])], tid, pt.sfm.Feature(b[o, :2] / b[o, 2]))
    if len(vid) < 3 or n_triplet_tracks < 1:
        # Theia's LiGT needs a track seen by three posed views (it does not check; it would abort)
        raise ValueError(f"Theia's LiGT needs three posed views sharing a track ({len(vid)} posed views, {n_triplet_tracks} such tracks)")
    orient = {vid[k]: _rotvec(R[k]) for k in vid}
    vp = {(vid[i], vid[j]): info for (i, j), info in pairs.items() if i in vid and j in vid}
    est = pt.sfm.LiGTPositionEstimator(pt.sfm.LiGTPositionEstimatorOptions(), rec)
    with _quiet_stdout():
        pos = est.EstimatePositions(vp, orient)
    back = {v: k for k, v in vid.items()}
    C = np.full((n, 3), np.nan)
    for v, p in pos.items():
        C[back[int(v)]] = np.asarray(p, dtype=float)
    return C


def run(g: ViewGraph, tracks: Tracks, bearings: np.ndarray, rotations: np.ndarray, *, clock: Callable[[], float] = time.perf_counter) -> dict[str, dict[str, Any]]:
    """``{name: {"rotations", "centres", "time_s"}}`` (world -> camera rotations ``(n, 3, 3)`` and
    centres ``(n, 3)``, NaN where not estimated) of Theia's robust rotation averaging + LiGT and of
    Theia's LiGT on our ``rotations (n, 3, 3)``, on the view graph ``g`` and ``tracks`` with their
    observations' unit bearings ``bearings (M, 3)``."""
    import pytheia as pt

    n = g.num_views
    pairs = g.pairs()
    views = np.flatnonzero(largest_component(view_components(n, pairs)))
    vp = _view_pairs(g, views)
    vp_t = _view_pairs(g, views, translation_only=True)
    # our spanning-tree start on the same component (the root: the view of largest weighted degree)
    remap = np.full(n, -1, dtype=np.int64)
    remap[views] = np.arange(len(views))
    sel = (remap[pairs[:, 0]] >= 0) & (remap[pairs[:, 1]] >= 0)
    pe, w = remap[pairs[sel]], g.weights()[sel]
    deg = np.bincount(pe.ravel(), weights=np.repeat(w, 2), minlength=len(views))
    R0 = spanning_tree_rotations(len(views), pe, g.rotations()[sel], w, int(np.argmax(deg)))
    t0 = clock()
    est = pt.sfm.RobustRotationEstimator(pt.sfm.RobustRotationEstimatorOptions())
    rv = est.EstimateRotations(vp, {int(v): _rotvec(R0[k]) for k, v in enumerate(views)})
    t_ra = clock() - t0
    R_theia = _matrices(rv, n)
    t0 = clock()
    C_theia = _theia_ligt(tracks, bearings, R_theia, vp_t)
    t_ligt = clock() - t0
    t0 = clock()
    C_ours = _theia_ligt(tracks, bearings, np.asarray(rotations, dtype=float), vp_t)
    t_ligt_ours = clock() - t0
    return {
        "robust rotation averaging + LiGT": {"rotations": R_theia, "centres": C_theia, "time_s": t_ra + t_ligt},
        "LiGT on our rotations": {"rotations": np.asarray(rotations, dtype=float), "centres": C_ours, "time_s": t_ligt_ours},
    }
