"""Writers of a global reconstruction: a COLMAP model through ``pycolmap.Reconstruction``
(optional dependency; COLMAP, GLOMAP and their viewers open it) and a PLY point cloud. Both are
written atomically (a temporary file / folder renamed into place)."""

from __future__ import annotations

import os
import shutil
import tempfile
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from .._fileutil import atomic_open, atomic_savefig
from .._pycolmap import import_pycolmap
from ..geometry import InputError
from .tracks import Tracks

if TYPE_CHECKING:
    from .pairwise import ImageGraph
    from .pipeline import GlobalResult

__all__ = ["build_colmap_reconstruction", "colmap_model_of", "plot_reconstruction", "point_colors", "replace_dir", "write_colmap_model", "write_ply"]


def point_colors(image_paths: Sequence[str | os.PathLike], keypoints: Sequence[np.ndarray], tracks: Tracks, base_obs: np.ndarray) -> np.ndarray:
    """``(T, 3)`` uint8 RGB of every track, sampled at its base observation's keypoint
    (``base_obs (T,)`` observation indices, -1: grey)."""
    import cv2

    out = np.full((len(tracks), 3), 128, dtype=np.uint8)
    ok = base_obs >= 0
    views = np.where(ok, tracks.views[np.maximum(base_obs, 0)], -1)
    for v in np.unique(views[ok]):
        img = cv2.imread(str(image_paths[v]), cv2.IMREAD_COLOR)
        if img is None:
            continue
        sel = np.flatnonzero(views == v)
        uv = keypoints[v][tracks.keypoints[base_obs[sel]]]
        x = np.clip(np.round(uv[:, 0]).astype(int), 0, img.shape[1] - 1)
        y = np.clip(np.round(uv[:, 1]).astype(int), 0, img.shape[0] - 1)
        out[sel] = img[y, x, ::-1]
    return out


def colmap_model_of(names: Sequence[str], ig: ImageGraph, res: GlobalResult, colors: np.ndarray | None = None) -> Any:
    """The ``pycolmap.Reconstruction`` of a global result ``res`` (:func:`poseonly.sfm.pipeline.run_global`)
    over the images ``names`` of the image graph ``ig`` (calibration, sizes, keypoints)."""
    rc = res.reconstruction
    return build_colmap_reconstruction(
        names,
        ig.K,
        [f.image_size for f in ig.features],
        [ig.camera_keypoints(k) for k in range(len(ig.features))],
        res.rotations,
        res.centres,
        res.tracks,
        rc.points,
        rc.valid,
        rc.obs_valid,
        colors,
        ig.cameras,
    )


def build_colmap_reconstruction(
    names: Sequence[str],
    K: np.ndarray,
    image_sizes: Sequence[tuple[int, int]],
    keypoints: Sequence[np.ndarray],
    rotations: np.ndarray,
    centres: np.ndarray,
    tracks: Tracks,
    points: np.ndarray,
    point_valid: np.ndarray,
    obs_valid: np.ndarray,
    colors: np.ndarray | None = None,
    cameras: Sequence[Mapping[str, Any]] | None = None,
) -> Any:
    """A ``pycolmap.Reconstruction``: one camera per distinct calibration (images that share one share
    the camera, as in a COLMAP database), PINHOLE from ``K (N, 3, 3)`` or the COLMAP
    camera ``cameras[k]`` (``{"model", "width", "height", "params"}``: the model the keypoints
    were lifted through, so the model's reprojections are those of its distorted keypoints), the posed
    images (world -> camera ``rotations (N, 3, 3)``, ``centres (N, 3)``; NaN rows are left out)
    with all their keypoints as 2D points, and every valid track as a 3D point over its valid
    observations (``points (T, 3)``, ``point_valid (T,)``, ``obs_valid (M,)``)."""
    pycolmap = import_pycolmap()

    n = len(names)
    rec = pycolmap.Reconstruction()
    posed = np.all(np.isfinite(rotations), axis=(1, 2)) & np.all(np.isfinite(centres), axis=1)
    ids: dict[tuple[Any, ...], int] = {}  # one camera (and rig) per distinct calibration, as COLMAP shares them
    for k in range(n):
        w, h = image_sizes[k]
        if cameras is not None:
            c = cameras[k]
            key: tuple[Any, ...] = (str(c["model"]), int(c["width"]), int(c["height"]), *[float(v) for v in c["params"]])
        else:
            key = ("PINHOLE", int(w), int(h), float(K[k][0, 0]), float(K[k][1, 1]), float(K[k][0, 2]), float(K[k][1, 2]))
        if key not in ids:
            ids[key] = len(ids) + 1
            rec.add_camera_with_trivial_rig(pycolmap.Camera(model=key[0], width=key[1], height=key[2], params=list(key[3:]), camera_id=ids[key]))
        img = pycolmap.Image(name=str(names[k]), keypoints=np.asarray(keypoints[k], dtype=np.float64), camera_id=ids[key], image_id=k + 1)
        if posed[k]:
            R = rotations[k]
            pose = pycolmap.Rigid3d(np.concatenate([R, (-R @ centres[k])[:, None]], axis=1))
            rec.add_image_with_trivial_frame(img, pose)
        else:
            rec.add_image_with_trivial_frame(img)
    col = np.full((len(tracks), 3), 128, dtype=np.uint8) if colors is None else np.asarray(colors, dtype=np.uint8)
    for t in np.flatnonzero(point_valid):
        s = slice(tracks.ptr[t], tracks.ptr[t + 1])
        keep = obs_valid[s] & posed[tracks.views[s]]
        if keep.sum() < 2:
            continue
        track = pycolmap.Track()
        for v, kp in zip(tracks.views[s][keep].tolist(), tracks.keypoints[s][keep].tolist()):
            track.add_element(v + 1, kp)
        rec.add_point3D(np.asarray(points[t], dtype=np.float64), track, col[t])
    rec.update_point_3d_errors()  # each point's mean reprojection error (else stored as -1: a user's trial)
    return rec


def replace_dir(tmp: Path, dst: Path) -> None:
    """Move the finished folder ``tmp`` to ``dst`` (an older ``dst`` is replaced only after)."""
    if dst.exists():
        old = Path(tempfile.mkdtemp(dir=dst.parent, prefix=dst.name + ".old"))
        old.rmdir()  # a fresh unused name
        os.replace(dst, old)
        os.replace(tmp, dst)
        shutil.rmtree(old, ignore_errors=True)
    else:
        os.replace(tmp, dst)


def _model_counts(rec: Any) -> tuple[int, int, int, int]:
    """(cameras, posed images, points, observations) of a pycolmap reconstruction (its writers keep the
    images without a pose out of the files)."""
    return (rec.num_cameras(), rec.num_reg_images(), rec.num_points3D(), sum(p.track.length() for p in rec.points3D.values()))


def _check_written_model(rec: Any, tmp: Path, dst: Path) -> None:
    """Read the model written into ``tmp`` back and fsync its files: pycolmap's writers do not report a
    failed write (a full disk left ``images.bin`` and ``points3D.bin`` cut short, and the run reported
    success; a reliability trial), so a model that does not read back as written is an ``OSError`` and
    the previous ``dst`` stays."""
    want = _model_counts(rec)
    try:
        got = _model_counts(type(rec)(str(tmp)))
    except Exception as exc:  # pycolmap raises IndexError, MemoryError, RuntimeError ... on a cut file
        raise OSError(f"writing the COLMAP model {dst} failed: it does not read back ({type(exc).__name__}: {exc}); is the disk full?") from None
    if got != want:
        raise OSError(f"writing the COLMAP model {dst} failed: it reads back with (cameras, images, points, observations) = {got}, not {want}; is the disk full?")
    for f in tmp.iterdir():
        with open(f, "rb") as fh:
            os.fsync(fh.fileno())


def write_colmap_model(rec: Any, folder: str | os.PathLike, binary: bool = True) -> Path:
    """Write ``rec`` as a COLMAP model (``cameras``, ``images``, ``points3D``, ``rigs``, ``frames``;
    binary or text) into ``folder``, atomically."""
    dst = Path(folder)
    dst.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(dir=dst.parent, prefix=dst.name + ".tmp"))
    try:
        (rec.write_binary if binary else rec.write_text)(str(tmp))
        _check_written_model(rec, tmp, dst)
        mask = os.umask(0)
        os.umask(mask)
        os.chmod(tmp, 0o777 & ~mask)  # mkdtemp makes 0700; a plain mkdir would not
        replace_dir(tmp, dst)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    return dst


def write_ply(path: str | os.PathLike, points: np.ndarray, colors: np.ndarray | None = None, cameras: np.ndarray | None = None) -> Path:
    """Binary little-endian PLY of ``points (P, 3)`` with uint8 RGB ``colors (P, 3)``; camera
    centres ``(N, 3)`` (optional) are appended as red vertices. Written atomically."""
    P = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    if not np.all(np.isfinite(P)):
        raise InputError("write_ply: points contain NaN or inf (pass only the valid points)")
    col = np.full((len(P), 3), 200, np.uint8) if colors is None else np.asarray(colors, dtype=np.uint8).reshape(-1, 3)
    if cameras is not None:
        cams = np.asarray(cameras, dtype=np.float64).reshape(-1, 3)
        cams = cams[np.all(np.isfinite(cams), axis=1)]
        P = np.concatenate([P, cams])
        col = np.concatenate([col, np.tile(np.array([[255, 0, 0]], np.uint8), (len(cams), 1))])
    rec = np.empty(len(P), dtype=[("x", "<f4"), ("y", "<f4"), ("z", "<f4"), ("r", "u1"), ("g", "u1"), ("b", "u1")])
    rec["x"], rec["y"], rec["z"] = P[:, 0], P[:, 1], P[:, 2]
    rec["r"], rec["g"], rec["b"] = col[:, 0], col[:, 1], col[:, 2]
    header = (
        "ply\nformat binary_little_endian 1.0\n"
        f"element vertex {len(P)}\nproperty float x\nproperty float y\nproperty float z\n"
        "property uchar red\nproperty uchar green\nproperty uchar blue\nend_header\n"
    ).encode()
    dst = Path(path)
    with atomic_open(dst, "wb") as fh:
        fh.write(header)
        fh.write(rec.tobytes())
    return dst


def plot_reconstruction(
    path: str | os.PathLike, points: np.ndarray, centres: np.ndarray, rotations: np.ndarray, colors: np.ndarray | None = None, max_points: int = 50000, seed: int = 0
) -> Path | None:
    """Figure of the cameras (centres and optical axes) and points, as the paper's last figure
    (3D view, matplotlib; ``None`` when matplotlib is missing). ``points (P, 3)``, ``centres
    (N, 3)``, ``rotations (N, 3, 3)`` world -> camera; at most ``max_points`` points drawn
    (a seeded subsample)."""
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:  # pragma: no cover
        return None
    P = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    col = None if colors is None else np.asarray(colors)[: len(P)] / 255.0
    if len(P) > max_points:
        sel = np.random.default_rng(seed).choice(len(P), max_points, replace=False)
        P = P[sel]
        col = None if col is None else col[sel]
    ok = np.all(np.isfinite(centres), axis=1)
    C, R = centres[ok], rotations[ok]
    fig = plt.figure(figsize=(8, 6))
    ax = fig.add_subplot(111, projection="3d")
    ax.scatter(P[:, 0], P[:, 1], P[:, 2], s=0.3, c=col if col is not None else "0.4", depthshade=False)
    scale = 0.05 * float(np.ptp(P, axis=0).max()) if len(P) else 1.0
    axes = R[:, 2, :]  # optical axes in world coordinates
    ax.quiver(C[:, 0], C[:, 1], C[:, 2], axes[:, 0], axes[:, 1], axes[:, 2], length=scale, color="r")
    ax.scatter(C[:, 0], C[:, 1], C[:, 2], s=12, c="r")
    span = np.ptp(np.concatenate([P, C]), axis=0) if len(P) + len(C) else np.ones(3)
    ax.set_box_aspect(tuple(np.maximum(span, 1e-3 * max(float(span.max()), 1e-12))))  # true proportions
    ax.set_title(f"{len(C)} cameras, {len(points)} points (rotation averaging + LiGT, no BA)")
    try:
        return atomic_savefig(fig, path, dpi=110, bbox_inches="tight")
    finally:
        plt.close(fig)
