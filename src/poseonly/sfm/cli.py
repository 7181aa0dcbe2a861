"""The ``poseonly sfm`` command and the ``poseonly experiment global`` entry (thin: parse, call
the library, print; hooked into :mod:`poseonly.cli` by :func:`add_parsers`).

    poseonly sfm IMAGES_DIR --K K.txt --out DIR [--max-features N] [--max-images N] [--threshold-px T]
                 [--cache DIR] [--text] [--seed S]
    poseonly sfm IMAGES_DIR --database colmap.db --out DIR      (keypoints and matches from COLMAP)

Writes ``DIR/sparse/0`` (COLMAP binary model, or text with ``--text``; needs pycolmap),
``DIR/points.ply`` (valid points, coloured, camera centres in red), ``DIR/poses.json`` and
``DIR/reconstruction.png`` (cameras and points, as the paper's last figure; needs matplotlib).
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path
from typing import Any

import numpy as np

from ..argtypes import non_negative_int, positive_int
from ..geometry import InputError, check_intrinsics
from ..io.pair_list import parse_pair_names
from .choices import LIGT_NORMALIZATIONS, ROTATION_WEIGHTS, checked_sigma_deg

__all__ = ["IMAGE_EXTS", "add_parsers", "cmd_sfm"]

IMAGE_EXTS = (".jpg", ".jpeg", ".png", ".JPG", ".JPEG", ".PNG")


def positive_degrees(text: str) -> float:
    """argparse type of ``--rotation-sigma``: a finite number of degrees > 0 (checked before any image
    is read)."""
    try:
        v = checked_sigma_deg(float(text), "--rotation-sigma")
    except (ValueError, InputError) as e:
        raise argparse.ArgumentTypeError(str(e)) from None
    assert v is not None
    return v


def _progress(it, **kw):
    try:
        from tqdm import tqdm
    except ImportError:  # pragma: no cover
        return it
    return tqdm(it, leave=False, dynamic_ncols=True, **kw)


class _StageBar:
    """A progress bar over the global stages (tqdm; ``stage(name)`` names the stage that starts and
    counts the one before it as done)."""

    def __init__(self, bar: Any) -> None:
        self.bar, self.started = bar, False

    def stage(self, name: str) -> None:
        if self.started:
            self.bar.update(1)
        self.started = True
        self.bar.set_description_str(f"global: {name}")

    def close(self) -> None:
        if self.started:
            self.bar.update(1)
        self.bar.close()


def _stage_bar(total: int) -> _StageBar | None:
    try:
        from tqdm import tqdm
    except ImportError:  # pragma: no cover
        return None
    return _StageBar(tqdm(total=total, leave=False, dynamic_ncols=True, bar_format="{desc} [{n}/{total} stages, {elapsed}]"))


def _read_K(path: str) -> np.ndarray:
    p = Path(path)
    if not p.is_file():
        raise InputError(f"calibration file not found: {path}")
    try:
        K = np.loadtxt(p, dtype=float)
    except ValueError as exc:
        raise InputError(f"could not read a 3x3 matrix from {path}: {exc}") from None
    if K.shape != (3, 3):
        raise InputError(f"{path} must contain a 3x3 matrix, found shape {K.shape}")
    return check_intrinsics(K, f"K in {path}")


def cmd_sfm(args: argparse.Namespace) -> int:
    from .._fileutil import atomic_write_text
    from .export import (
        colmap_model_of,
        plot_reconstruction,
        point_colors,
        write_colmap_model,
        write_ply,
    )
    from .pairwise import PairwiseOptions, image_view_graph, parse_estimator_options
    from .pipeline import GlobalOptions, num_stages, run_global

    d = Path(args.images)
    if not d.is_dir():
        raise InputError(f"image folder not found: {d}")
    out = Path(args.out)
    t0 = time.perf_counter()
    opt = PairwiseOptions(
        max_features=args.max_features,
        threshold_px=args.threshold_px,
        seed=args.seed,
        use_noise_scales=not args.no_noise_scales,
        estimator_options=parse_estimator_options(args.two_view_option),
    )
    cache = args.cache if args.cache else out / "cache"
    prog = None if args.no_progress else _progress
    if args.database:
        from .colmap_db import database_view_graph

        if args.pairs is not None or args.sequential is not None:
            raise InputError("--pairs and --sequential choose the pairs to match; with --database the database's matches decide")
        if args.resident_images is not None:
            raise InputError("--resident-images bounds the memory of our features; with --database no descriptors are read")

        ig, names = database_view_graph(args.database, options=opt, cache_dir=cache, progress=prog, jobs=args.jobs)
        images = [d / nm for nm in names]
        missing = [str(p) for p in images if not p.is_file()]
        if missing:
            raise InputError(f"images of the database not found in {d}: {missing[:3]}")
        K = ig.K[0]
    else:
        if not args.K:
            raise InputError("give --K K.txt (or --database colmap.db, which holds the cameras)")
        images = sorted(p for p in d.iterdir() if p.is_file() and p.suffix in IMAGE_EXTS)
        held = len(images)
        if args.max_images:
            images = images[: args.max_images]
        if len(images) < 3:
            used = f" (--max-images {args.max_images} of {held})" if len(images) < held else ""
            raise InputError(f"{d} gives {len(images)} images{used}; global SfM needs at least 3")
        K = _read_K(args.K)
        pairs = _pair_list(args, images)
        resident = {} if args.resident_images is None else {"resident_images": args.resident_images}
        ig = image_view_graph(images, K, options=opt, cache_dir=cache, pairs=pairs, progress=prog, jobs=args.jobs, **resident)
    print(
        f"pairs: {len(ig.graph)} edges kept, {len(ig.graph.rejected)} rejected "
        f"(features {ig.times_s['features']:.1f} s, matching {ig.times_s['matching']:.1f} s, two-view {ig.times_s['two_view']:.1f} s)"
    )
    gopt = GlobalOptions(rotation_weights=args.rotation_weights, rotation_sigma_deg=args.rotation_sigma, ligt_normalization=args.ligt_normalization)
    bar = None if args.no_progress else _stage_bar(num_stages(gopt))
    try:
        res = run_global(ig.graph, ig.bearings, float(0.5 * (K[0, 0] + K[1, 1])), gopt, on_stage=None if bar is None else bar.stage)
    finally:
        if bar is not None:
            bar.close()
    est = np.all(np.isfinite(res.centres), axis=1)
    has_R = np.all(np.isfinite(res.rotations), axis=(1, 2))
    rec = res.reconstruction
    undetermined = res.info.get("translation_undetermined")
    print(f"cameras: {int(est.sum())}/{len(images)} posed; outlier edges: {len(res.rotation.outlier_edges)}; points: {rec.num_valid}/{len(res.tracks)} valid")
    if not undetermined and est.sum() < len(images):
        li = res.ligt.info
        reasons = {
            "without a rotation (no trusted pair joins them to the largest component)": int(np.sum(~res.rotation.estimated)),
            "not joined to the solved component by usable tracks": _count(li, "views_disconnected"),
            "whose tracks do not fix their centre": _count(li, "views_weak"),
        }
        reasons["without usable tracks"] = len(images) - int(est.sum()) - sum(reasons.values())
        print("not posed: " + ", ".join(f"{k} {why}" for why, k in reasons.items() if k > 0))
    print("stages: " + ", ".join(f"{k} {v:.2f} s" for k, v in res.times_s.items()))
    poses: dict[str, Any] = {"convention": "X_cam = R (X_world - c)", "status": "translation_undetermined" if undetermined else "ok", "images": []}
    for k, p in enumerate(images):
        poses["images"].append({"name": p.name, "R": res.rotations[k].tolist() if has_R[k] else None, "c": res.centres[k].tolist() if est[k] else None})
    poses["outlier_edges"] = res.rotation.outlier_edges
    poses["times_s"] = {**ig.times_s, **res.times_s}
    out.mkdir(parents=True, exist_ok=True)
    if undetermined:
        poses["reason"] = undetermined
        atomic_write_text(out / "poses.json", json.dumps(poses, indent=1))
        print(f"the camera centres are not determined: {undetermined} (a pure rotation or a panorama?)")
        print(f"poses.json holds the {int(has_R.sum())} averaged rotations; no model, point cloud or figure written")
        print(f"total {time.perf_counter() - t0:.1f} s; outputs in {out}")
        return 0
    colors = point_colors(images, [f.keypoints for f in ig.features], res.tracks, rec.base[:, 0])
    write_ply(out / "points.ply", rec.points[rec.valid], colors[rec.valid], res.centres)
    fig = plot_reconstruction(out / "reconstruction.png", rec.points[rec.valid], res.centres, res.rotations, colors[rec.valid])
    if fig is not None:
        print(f"figure: {fig}")
    atomic_write_text(out / "poses.json", json.dumps(poses, indent=1))
    try:
        import pycolmap  # noqa: F401
    except ImportError:
        print("pycolmap is not installed: COLMAP model not written (points.ply and poses.json are)")
    else:
        model = colmap_model_of([p.name for p in images], ig, res, colors)
        write_colmap_model(model, out / "sparse" / "0", binary=not args.text)
        print(f"COLMAP model: {out / 'sparse' / '0'} ({model.num_reg_images()} images, {model.num_points3D()} points)")
    print(f"total {time.perf_counter() - t0:.1f} s; outputs in {out}")
    return 0


def _count(info: dict[str, object], key: str) -> int:
    """A count of a stage's ``info`` (0 when absent)."""
    v = info.get(key, 0)
    return int(v) if isinstance(v, (int, np.integer)) else 0


def _pair_list(args: argparse.Namespace, images: list[Path]) -> list[tuple[int, int]] | None:
    """The image pairs to match: ``--sequential N`` (each image with its next N in name order),
    ``--pairs FILE`` (one pair of image names per line, as COLMAP's and hloc's pair lists; blank
    lines and ``#`` comments skipped, pairs of images not used are left out), or None (all pairs)."""
    if args.sequential is not None and args.pairs is not None:
        raise InputError("give --pairs or --sequential, not both")
    n = len(images)
    if args.sequential is not None:
        return [(i, j) for i in range(n) for j in range(i + 1, min(n, i + 1 + args.sequential))]
    if args.pairs is None:
        return None
    path = Path(args.pairs)
    if not path.is_file():
        raise InputError(f"pair list not found: {path}")
    index = {p.name: k for k, p in enumerate(images)}
    folder = Path(args.images)
    known = {p.name for p in folder.iterdir() if p.is_file() and p.suffix in IMAGE_EXTS} if folder.is_dir() else set()
    out: set[tuple[int, int]] = set()
    for a, b in parse_pair_names(path.read_text(encoding="utf-8", errors="replace").splitlines(), str(path)):
        for nm in (a, b):
            if nm not in known:  # names of the folder's images, as they are: no directories
                raise InputError(f"{path}: {nm!r} is not the name of an image in {folder}")
        if a in index and b in index:  # both used (not cut by --max-images)
            out.add((min(index[a], index[b]), max(index[a], index[b])))
    if not out:
        raise InputError(f"{path}: no pair of the images used")
    return sorted(out)


def _cmd_global(args: argparse.Namespace) -> int:
    from .._fileutil import new_results_dir
    from ..experiments import global_sfm

    if args.out is None:
        args.out = str(new_results_dir("global"))
    return int(global_sfm.run(args) or 0)


def add_parsers(sub: Any, esub: Any) -> None:
    """Add ``sfm`` to the command subparsers ``sub`` and ``global`` to the experiment ones ``esub``."""
    s = sub.add_parser("sfm", help="global SfM of an image folder (rotation averaging + LiGT + analytical points)")
    s.add_argument("images", help="folder of images (.jpg / .png), one calibrated camera")
    s.add_argument("--K", help="text file with the 3x3 calibration matrix (not needed with --database)")
    s.add_argument("--database", help="COLMAP database with cameras, keypoints and matches (replaces our features and matching)")
    s.add_argument("--out", required=True, help="output folder")
    s.add_argument("--max-features", type=non_negative_int, default=8000, help="strongest SIFT features per image (default 8000)")
    s.add_argument("--max-images", type=positive_int, help="use only the first N images (sorted by name)")
    s.add_argument("--threshold-px", type=float, default=None, help="two-view inlier threshold (px; default: the method's, 1 px)")
    s.add_argument("--cache", help="feature / match cache (default OUT/cache)")
    s.add_argument("--text", action="store_true", help="write the COLMAP model as text")
    s.add_argument("--no-progress", action="store_true", help="no progress bars")
    s.add_argument("--seed", type=non_negative_int, default=0, help="seed of every random choice (default 0); the same seed gives the same result")
    s.add_argument(
        "--jobs",
        type=int,
        default=1,
        help="threads for the features, matching and two-view stages (-1: one per core; the same result for any number). Default 1: "
        "OpenCV's SIFT and matching already use every core, and each concurrent SIFT holds its own image pyramid in memory",
    )
    s.add_argument("--two-view-option", action="append", metavar="KEY=VALUE", help="an option of the two-view estimator, KEY=VALUE (repeatable; e.g. ml_tails=gauss)")
    s.add_argument("--no-noise-scales", action="store_true", help="do not pass the keypoints' sizes to the two-view estimator as noise scales")
    s.add_argument(
        "--rotation-sigma",
        type=positive_degrees,
        default=None,
        metavar="DEG",
        help="rotation averaging's Geman-McClure scale in degrees (default: from the data, 5x the noise-corrected median edge residual, at most 5; 5 on sparse graphs)",
    )
    s.add_argument(
        "--rotation-weights",
        choices=ROTATION_WEIGHTS,
        default=ROTATION_WEIGHTS[0],
        help="rotation averaging's edge weights: the two-view inlier counts (default) or each relative rotation's information (narrow fields of view)",
    )
    s.add_argument("--pairs", metavar="FILE", help="match only these pairs: one pair of image names per line (COLMAP's / hloc's pair lists); default all pairs")
    s.add_argument("--sequential", type=positive_int, metavar="N", help="match each image with its next N (in name order; video); default all pairs")
    s.add_argument(
        "--resident-images",
        type=positive_int,
        default=None,
        metavar="N",
        help="keep the descriptors of at most N images in memory (4 MB each at 8000 features), reading them back from the cache when needed (default 256)",
    )
    s.add_argument(
        "--ligt-normalization",
        choices=LIGT_NORMALIZATIONS,
        default=LIGT_NORMALIZATIONS[0],
        help="LiGT's scale: the expected noise of its rows (default) or the paper's unit norm of the centres",
    )
    s.set_defaults(func=cmd_sfm)

    from ..experiments import global_sfm

    e = esub.add_parser("global", help="global SfM on Strecha scenes against the ground truth")
    e.add_argument("--trials", type=int, default=None, help=argparse.SUPPRESS)
    e.add_argument("--quick", action="store_true", help=argparse.SUPPRESS)
    e.add_argument("--out", default=None, help="output folder (default: a new folder poseonly-global-<date>-<time> under the working directory)")
    e.add_argument("--seed", type=non_negative_int, default=0, help="seed of every random choice (default 0); the same seed gives the same result")
    global_sfm.add_arguments(e)
    e.set_defaults(func=_cmd_global)
