"""Loader for the Strecha et al. (CVPR 2008) multi-view scenes in the openMVG layout.

Layout of a scene folder::

    scene/images/NNNN.jpg                 images (already undistorted)
    scene/images/K.txt                    shared 3x3 intrinsic matrix
    scene/gt_dense_cameras/NNNN.jpg.camera  ground truth, 9 lines / 26 numbers:
        K (3 rows), radial distortion k1 k2 k3, R (3 rows, camera -> world), centre C, width height

World -> camera is ``X_cam = R^T (X - C)``. The relative pose mapping camera ``i``'s frame to
camera ``j``'s (poseonly convention ``X_j = R_ij X_i + t_ij``) is ``R_ij = R_j^T R_i`` and
``t_ij = R_j^T (C_i - C_j)``.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..geometry import InputError, check_intrinsics, project_to_so3

__all__ = ["StrechaCamera", "StrechaScene", "read_camera_file", "read_K_file", "load_scene", "relative_pose", "find_scenes"]

_IMAGE_EXTS = {".jpg", ".jpeg", ".png"}
_N_CAMERA_VALUES = 9 + 3 + 9 + 3 + 2


@dataclass(frozen=True)
class StrechaCamera:
    """Ground-truth camera: ``K (3, 3)``, ``distortion (3,)``, ``R_cw`` (camera -> world, on SO(3)),
    centre ``C (3,)`` in world coordinates (metres), image ``width``, ``height``."""

    K: np.ndarray
    distortion: np.ndarray
    R_cw: np.ndarray
    C: np.ndarray
    width: int
    height: int

    @property
    def R_wc(self) -> np.ndarray:
        """World -> camera rotation ``R_cw^T``."""
        return self.R_cw.T


@dataclass(frozen=True)
class StrechaScene:
    """A loaded scene: ``name``, ``path``, sorted ``image_paths``, shared ``K`` (from ``K.txt``),
    and one :class:`StrechaCamera` per image."""

    name: str
    path: Path
    image_paths: list[Path]
    K: np.ndarray
    cameras: list[StrechaCamera]

    def __len__(self) -> int:
        return len(self.image_paths)


def _read_numbers(path: Path, what: str) -> np.ndarray:
    if not path.is_file():
        raise InputError(f"{what} not found: {path}")
    try:
        text = path.read_text(encoding="utf-8", errors="strict")
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"cannot read {what} {path}: {exc}") from None
    toks = text.split()
    try:
        vals = np.array([float(s) for s in toks], dtype=np.float64)
    except ValueError:
        bad = next(s for s in toks if not _is_float(s))
        raise InputError(f"{what} {path} contains a non-numeric value {bad!r}") from None
    if not np.all(np.isfinite(vals)):
        raise InputError(f"{what} {path} contains NaN or inf values")
    return vals


def _is_float(s: str) -> bool:
    try:
        float(s)
    except ValueError:
        return False
    return True


def read_K_file(path: str | os.PathLike) -> np.ndarray:
    """Read ``images/K.txt`` (9 numbers, row-major 3x3)."""
    p = Path(path)
    vals = _read_numbers(p, "intrinsics file K.txt")
    if vals.size != 9:
        raise InputError(f"intrinsics file {p} must hold 9 numbers (a 3x3 matrix), found {vals.size}")
    return check_intrinsics(vals.reshape(3, 3), f"K in {p}")


def read_camera_file(path: str | os.PathLike) -> StrechaCamera:
    """Parse one ``.camera`` file (26 numbers); raises :class:`InputError` if malformed."""
    p = Path(path)
    v = _read_numbers(p, "camera file")
    if v.size != _N_CAMERA_VALUES:
        raise InputError(f"camera file {p} must hold {_N_CAMERA_VALUES} numbers (K 3x3, distortion 3, R 3x3, C 3, width height), found {v.size}")
    K = check_intrinsics(v[0:9].reshape(3, 3), f"K in {p}")
    dist = v[9:12].copy()
    R_raw = v[12:21].reshape(3, 3)
    C = v[21:24].copy()
    w, h = v[24], v[25]
    if w != round(w) or h != round(h) or w <= 0 or h <= 0:
        raise InputError(f"camera file {p}: image size must be two positive integers, got {w:g} {h:g}")
    # stored with ~6 significant digits: accept small deviations, reject non-rotations
    orth = np.abs(R_raw @ R_raw.T - np.eye(3)).max()
    if orth > 1e-3 or np.linalg.det(R_raw) < 0:
        raise InputError(f"camera file {p}: the rotation block is not a rotation matrix (max |R R^T - I| = {orth:.3g}, det = {np.linalg.det(R_raw):.3g})")
    return StrechaCamera(K=K, distortion=dist, R_cw=project_to_so3(R_raw), C=C, width=int(w), height=int(h))


def _is_scene_dir(p: Path) -> bool:
    return (p / "images").is_dir() and (p / "gt_dense_cameras").is_dir()


def load_scene(path: str | os.PathLike) -> StrechaScene:
    """Load a scene folder (``images/``, ``images/K.txt``, ``gt_dense_cameras/``)."""
    root = Path(path)
    if not root.is_dir():
        raise InputError(f"Strecha scene folder not found: {root}")
    if not _is_scene_dir(root):
        raise InputError(f"{root} is not a Strecha scene folder (it needs 'images/' and 'gt_dense_cameras/' subfolders)")
    K = read_K_file(root / "images" / "K.txt")
    images = sorted(p for p in (root / "images").iterdir() if p.is_file() and p.suffix.lower() in _IMAGE_EXTS)
    if not images:
        raise InputError(f"no images (.jpg/.png) in {root / 'images'}")
    cam_dir = root / "gt_dense_cameras"
    missing = [p.name for p in images if not (cam_dir / f"{p.name}.camera").is_file()]
    if missing:
        raise InputError(f"{root}: ground-truth camera file(s) missing for {missing} in {cam_dir}")
    cams = [read_camera_file(cam_dir / f"{p.name}.camera") for p in images]
    return StrechaScene(name=root.resolve().name, path=root, image_paths=images, K=K, cameras=cams)


def relative_pose(scene: StrechaScene, i: int, j: int) -> tuple[np.ndarray, np.ndarray, float]:
    """Ground-truth pose from view ``i`` to view ``j``: ``(R_ij, t_ij (unit), baseline in metres)``.

    ``X_j = R_ij X_i + baseline * t_ij`` with ``R_ij = R_j^T R_i``, ``t_ij ~ R_j^T (C_i - C_j)``.
    """
    n = len(scene.cameras)
    for name, k in (("i", i), ("j", j)):
        if not isinstance(k, (int, np.integer)) or not -n <= k < n:
            raise InputError(f"view index {name}={k!r} out of range for scene {scene.name!r} with {n} views")
    if i % n == j % n:
        raise InputError(f"relative_pose needs two different views, got i = j = {i}")
    ci, cj = scene.cameras[i], scene.cameras[j]
    R = project_to_so3(cj.R_cw.T @ ci.R_cw)
    t = cj.R_cw.T @ (ci.C - cj.C)
    b = float(np.linalg.norm(t))
    if b <= 0:
        raise InputError(f"views {i} and {j} of {scene.name!r} share the same centre (zero baseline)")
    return R, t / b, b


def find_scenes(root: str | os.PathLike) -> list[Path]:
    """Scene folders (having ``images/`` and ``gt_dense_cameras/``) at or below ``root``, sorted."""
    r = Path(root)
    if not r.is_dir():
        raise InputError(f"Strecha data folder not found: {r}")
    found: list[Path] = []
    for dirpath, dirnames, _ in os.walk(r):
        d = Path(dirpath)
        if _is_scene_dir(d):
            found.append(d)
            dirnames[:] = []  # do not descend into a scene
        else:
            dirnames[:] = sorted(x for x in dirnames if not x.startswith("."))
    return sorted(found)
