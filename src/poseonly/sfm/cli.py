"""The ``poseonly sfm`` command and the ``poseonly experiment global`` entry (thin: parse, call
the library, print; hooked into :mod:`poseonly.cli` by :func:`add_parsers`).

    poseonly sfm IMAGES_DIR --K K.txt --out DIR [--max-features N] [--max-images N] [--threshold-px T]
                 [--cache DIR] [--text] [--seed S]
    poseonly sfm IMAGES_DIR --camera-model OPENCV --camera-params fx,fy,cx,cy,k1,k2,p1,p2 --out DIR
                                                               (a distorted camera, COLMAP's model names)
    poseonly sfm IMAGES_DIR --database colmap.db --out DIR      (keypoints and matches from COLMAP)

Writes one model per part of the image set that trusted pairs join (at least 3 images; largest
first, :func:`poseonly.sfm.pipeline.run_global_models`): ``DIR/sparse/K`` (COLMAP binary model, or
text with ``--text``; needs pycolmap), ``DIR/points.ply`` / ``points_K.ply`` (valid points, coloured,
camera centres in red), ``DIR/reconstruction.png`` / ``reconstruction_K.png`` (cameras and points,
as the paper's last figure; needs matplotlib), and one ``DIR/poses.json`` (every image's model, R
and c; each model's status).
"""

from __future__ import annotations

import argparse
import json
import os
import re
import shutil
import sys
import time
from collections import Counter
from pathlib import Path
from typing import Any

import numpy as np

from .._pycolmap import import_pycolmap
from ..argtypes import non_negative_int, positive_degrees, positive_float, positive_int, seed_int
from ..geometry import InputError
from ..io.pair_list import parse_pair_names
from .choices import LIGT_NORMALIZATIONS, LIGT_REWEIGHT, ROTATION_WEIGHTS

__all__ = ["IMAGE_EXTS", "add_parsers", "cmd_sfm", "is_image_file"]

# image files of a folder, by extension, case-insensitive (those OpenCV's default build decodes)
IMAGE_EXTS = (".jpg", ".jpeg", ".png", ".tif", ".tiff", ".bmp", ".webp")


def is_image_file(p: Path) -> bool:
    """Is ``p`` a file whose extension names an image format (:data:`IMAGE_EXTS`, any case)?"""
    return p.is_file() and p.suffix.lower() in IMAGE_EXTS


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
        if self.started:  # all done: a filter round that finds nothing to drop skips its stages (a trial saw 6/10)
            self.bar.update(max(0, self.bar.total - self.bar.n))
        self.bar.close()


def _stage_bar(total: int) -> _StageBar | None:
    try:
        from tqdm import tqdm
    except ImportError:  # pragma: no cover
        return None
    return _StageBar(tqdm(total=total, leave=False, dynamic_ncols=True, bar_format="{desc} [{n}/{total} stages, {elapsed}]"))


def _camera_arg(args: argparse.Namespace) -> dict[str, Any] | None:
    """The shared camera of ``--camera-model`` / ``--camera-params`` (COLMAP's names and parameter
    order; width and height from the images), or None; checked before any image is read."""
    if args.camera_model is None and args.camera_params is None:
        return None
    if args.camera_model is None or args.camera_params is None:
        raise InputError("--camera-model and --camera-params go together (e.g. --camera-model SIMPLE_RADIAL --camera-params f,cx,cy,k)")
    if args.K:
        raise InputError("give one of --K and --camera-model / --camera-params")
    from ..cameras import camera_from_text
    from ..options import check_camera_threshold

    cam = camera_from_text(args.camera_model, args.camera_params, name="--camera-model / --camera-params")
    check_camera_threshold(cam, "poseonly", args.threshold_px, "--camera-model / --camera-params")
    return cam.to_dict()


def cmd_sfm(args: argparse.Namespace) -> int:
    from .._fileutil import staging_dir
    from ..io.calibration import read_K
    from .pairwise import DEFAULT_MAX_FEATURES, PairwiseOptions, image_view_graph, parse_estimator_options
    from .pipeline import MIN_MODEL_VIEWS, GlobalOptions, num_stages, run_global_models

    d = Path(args.images)
    if not d.is_dir():
        raise InputError(f"image folder not found: {d}")
    out = Path(args.out)
    if out.exists() and not out.is_dir():
        raise InputError(f"--out {out}: is a file; give a folder")
    if out.resolve() == d.resolve():  # a user's trial: the next run read reconstruction.png as an image
        raise InputError(f"--out {out} is the image folder: the outputs (reconstruction.png among them) would become images of the next run; give another folder")
    if args.database and args.K:
        raise InputError("give --K or --database (which holds the cameras), not both")
    foreign = _foreign_outputs(out)
    if foreign and not args.overwrite:  # a user's trial: a COLMAP project's sparse/0 was replaced, its sparse/1 kept beside it
        shown = ", ".join(f.relative_to(out).as_posix() for f in foreign[:3]) + (f" and {len(foreign) - 3} more" if len(foreign) > 3 else "")
        raise InputError(
            f"--out {out} holds outputs no poseonly run wrote there ({shown}), which this run would replace or leave beside its own; give another folder, or --overwrite"
        )
    try:  # now, not after the pipeline: a Ctrl-C landing in this import reads as a broken pycolmap
        import_pycolmap()
    except ImportError:
        pass  # reported where the model would be written
    t0 = time.perf_counter()
    opt = PairwiseOptions(
        max_features=DEFAULT_MAX_FEATURES if args.max_features is None else args.max_features,
        threshold_px=args.threshold_px,
        seed=args.seed,
        use_noise_scales=not args.no_noise_scales,
        estimator_options=parse_estimator_options(args.two_view_option),
    )
    cache = args.cache if args.cache else out / "cache"
    # bars only where stderr is a terminal, as colmap verify's (a user's trial: `2> log` filled the log with them)
    bars = not args.no_progress and sys.stderr.isatty()
    prog = _progress if bars else None
    camera = _camera_arg(args)
    if args.database:
        from .colmap_db import database_view_graph

        if args.pairs is not None or args.sequential is not None:
            raise InputError("--pairs and --sequential choose the pairs to match; with --database the database's matches decide")
        if args.resident_images is not None:
            raise InputError("--resident-images bounds the memory of our features; with --database no descriptors are read")
        if args.max_images is not None or args.max_features is not None:
            # (they were ignored silently: a COLMAP user's trial)
            raise InputError("--max-images and --max-features choose our images and features; with --database its images, keypoints and matches are used as they are")

        def images_exist(names: list[str]) -> None:  # before any pair is estimated
            missing = [str(d / nm) for nm in names if not (d / nm).is_file()]
            if missing:
                raise InputError(f"{len(missing)} images of the database not found in {d}: {missing[:3]}")

        ig, names = database_view_graph(
            args.database,
            options=opt,
            cache_dir=cache,
            progress=prog,
            jobs=args.jobs,
            check_names=images_exist,
            trust_guessed_focal=args.trust_guessed_focal,
            camera=camera,
        )
        images = [d / nm for nm in names]
        K = ig.K[0]
    else:
        if args.trust_guessed_focal:
            raise InputError("--trust-guessed-focal applies to --database (a COLMAP database whose cameras COLMAP guessed)")
        if not args.K and camera is None:
            raise InputError("give --K K.txt, --camera-model / --camera-params, or --database colmap.db (which holds the cameras)")
        images = sorted(p for p in d.iterdir() if is_image_file(p))
        held = len(images)
        if args.max_images:
            images = images[: args.max_images]
        if len(images) < 3:
            used = f" (--max-images {args.max_images} of {held})" if len(images) < held else ""
            raise InputError(f"{d} gives {len(images)} image{'' if len(images) == 1 else 's'}{used}; global SfM needs at least 3")
        K_arg = None if camera is not None else read_K(args.K, "--K")
        lens = {"camera": camera} if K_arg is None else {"K": K_arg}
        if K_arg is not None and K_arg[0, 1] != 0.0:  # a user's trial: the model's reprojections were 0.87 px off, silently
            print(
                f"note: --K has a skew of {K_arg[0, 1]:g} px: the poses use it, but the COLMAP model is written with a PINHOLE "
                "camera, which has none, so its reprojections are off by up to the skew times half the image height over the focal length"
            )
        pairs = _pair_list(args, images)
        resident = {} if args.resident_images is None else {"resident_images": args.resident_images}
        ig = image_view_graph(images, options=opt, cache_dir=cache, pairs=pairs, progress=prog, jobs=args.jobs, **lens, **resident)
        K = ig.K[0]
    out_pairs = {(i, j) for i, j, _ in ig.graph.rejected}
    rejected = Counter(st for i, j, _, _, st in ig.pair_stats if (i, j) in out_pairs)
    why = f": {', '.join(f'{k} {v}' for k, v in sorted(rejected.items()))}" if rejected else ""
    print(
        f"pairs: {len(ig.graph)} edges kept, {len(ig.graph.rejected)} rejected{why} "
        f"(features {ig.times_s['features']:.1f} s, matching {ig.times_s['matching']:.1f} s, two-view {ig.times_s['two_view']:.1f} s)"
    )
    if len(ig.graph) == 0:
        why = ", ".join(f"{k} {v}" for k, v in sorted(Counter(st for *_, st in ig.pair_stats).items()))
        raise InputError(f"no pair of the {len(images)} images gave a trusted pose (pairs by two-view status: {why or 'none matched'})")
    gopt = GlobalOptions(
        rotation_weights=args.rotation_weights, rotation_sigma_deg=args.rotation_sigma, ligt_normalization=args.ligt_normalization, ligt_reweight=args.ligt_reweight
    )
    bar: list[_StageBar | None] = [None]

    def on_model(k: int, views: int) -> Any:
        if bar[0] is not None:
            bar[0].close()
        bar[0] = _stage_bar(num_stages(gopt)) if bars else None
        return None if bar[0] is None else bar[0].stage

    try:
        models = run_global_models(ig.graph, ig.bearings, float(0.5 * (K[0, 0] + K[1, 1])), gopt, on_model=on_model)
    finally:
        if bar[0] is not None:
            bar[0].close()
    if not models:
        raise InputError(f"no model: the trusted pairs join no {MIN_MODEL_VIEWS} of the {len(images)} images ({len(ig.graph)} pairs kept, {len(ig.graph.rejected)} rejected)")
    out.mkdir(parents=True, exist_ok=True)
    n = len(images)
    model_of = np.full(n, -1)
    for k, res in enumerate(models):
        model_of[np.all(np.isfinite(res.rotations), axis=(1, 2))] = k
    print(f"models: {len(models)} ({', '.join(str(int(np.sum(model_of == k))) for k in range(len(models)))} images)")
    previous = _previous_outputs(out)  # read before this run writes over them
    poses: dict[str, Any] = {"convention": _CONVENTION, "status": "", "models": [], "images": []}
    # every output is written into a staging folder first and moved into place once all are written: a
    # failed write (a full disk) leaves the previous run's set whole (a reliability trial: a new points.ply
    # beside the old poses.json and model)
    stage = staging_dir(out)
    try:
        _write_outputs(stage, out, poses, models, model_of, images, ig, args)
    finally:
        shutil.rmtree(stage, ignore_errors=True)
    _remove_stale(out, previous - _model_outputs(out, poses["models"]))
    print(f"total {time.perf_counter() - t0:.1f} s; outputs in {out}")
    return 0


def _pair_records(ig: Any, images: list[Path], outliers: set[tuple[int, int]]) -> list[dict[str, Any]]:
    """poses.json's ``pairs``: every matched pair's two-view outcome (a pipeline trial: the statuses of the
    rejected pairs were nowhere): the images, putative matches, inliers, two-view status, whether it is a
    view-graph edge (its relative pose ``R``, ``t`` with ``X_j = R X_i + t``) or why not, and whether
    rotation averaging removed it as an outlier edge."""
    edges = {(e.i, e.j): e for e in ig.graph.edges}
    why = {(i, j): reason for i, j, reason in ig.graph.rejected}
    out = []
    for i, j, putative, inliers, status in ig.pair_stats:
        a, b = min(i, j), max(i, j)
        rec: dict[str, Any] = {"images": [images[a].name, images[b].name], "views": [a, b], "matches": int(putative), "inliers": int(inliers), "status": status}
        e = edges.get((a, b))
        if e is not None:
            # a pure rotation's translation is any direction (a user's trial found one written): null
            rec.update(edge=True, R=e.R.tolist(), t=e.t.tolist() if e.use_translation else None, outlier_edge=(a, b) in outliers)
        else:
            rec.update(edge=False, rejected=why.get((a, b)))
        out.append(rec)
    return out


def _write_outputs(stage: Path, out: Path, poses: dict[str, Any], models: list[Any], model_of: np.ndarray, images: list[Path], ig: Any, args: argparse.Namespace) -> None:
    """Write every model's files and poses.json into ``stage``, then move them into ``out`` (poses.json
    last; a model folder replaced whole)."""
    from .._fileutil import atomic_write_text
    from .export import replace_dir
    from .pipeline import MIN_MODEL_VIEWS

    for k, res in enumerate(models):
        poses["models"].append(_write_model(k, res, images, ig, stage, args, out))
    poses["status"] = poses["models"][0]["status"]
    if poses["status"] == "translation_undetermined":
        poses["reason"] = poses["models"][0]["reason"]
    for v, p in enumerate(images):
        k = int(model_of[v])
        R = c = None
        if k >= 0:
            R = models[k].rotations[v].tolist()
            c = models[k].centres[v].tolist() if np.all(np.isfinite(models[k].centres[v])) else None
        poses["images"].append({"name": p.name, "model": k if k >= 0 else None, "R": R, "c": c})
    poses["outlier_edges"] = sorted({tuple(e) for res in models for e in res.rotation.outlier_edges})
    poses["pairs"] = _pair_records(ig, images, {(min(e[0], e[1]), max(e[0], e[1])) for e in poses["outlier_edges"]})
    poses["times_s"] = {**ig.times_s, **{key: sum(res.times_s.get(key, 0.0) for res in models) for key in models[0].times_s}}
    unmodelled = int(np.sum(model_of < 0) - sum(m["views_not_posed"] for m in poses["models"]))
    if unmodelled > 0:
        print(f"in no model: {unmodelled} images (no trusted pair joins them to a model of at least {MIN_MODEL_VIEWS} images)")
    atomic_write_text(stage / "poses.json", json.dumps(poses, indent=1))
    for m in poses["models"]:
        for r in m.get("outputs", []):
            if not r.startswith("sparse/"):
                (out / r).parent.mkdir(parents=True, exist_ok=True)
                os.replace(stage / r, out / r)
    if (stage / "sparse").is_dir():
        for d in sorted((stage / "sparse").iterdir()):
            (out / "sparse").mkdir(exist_ok=True)
            replace_dir(d, out / "sparse" / d.name)
    os.replace(stage / "poses.json", out / "poses.json")


def _model_outputs(out: Path, models: list[Any]) -> set[Path]:
    """The files poses.json's ``models`` entries list as written (``outputs``, relative to ``out``; an
    entry that leaves ``out`` is ignored)."""
    root = out.resolve()
    files: set[Path] = set()
    for m in models:
        rel = m.get("outputs", []) if isinstance(m, dict) else []
        for r in rel if isinstance(rel, list) else []:
            if not isinstance(r, str) or Path(r).is_absolute() or ".." in Path(r).parts:
                continue
            f = out / r
            if f.resolve().parent.is_relative_to(root):
                files.add(f)
    return files


def _previous_outputs(out: Path) -> set[Path]:
    """The files an earlier run listed as written in ``out``'s poses.json (none without a readable one,
    or from a version that did not list them)."""
    try:
        models = json.loads((out / "poses.json").read_text(encoding="utf-8")).get("models", [])
    except (OSError, ValueError, AttributeError):
        return set()
    return _model_outputs(out, models if isinstance(models, list) else [])


# the names of the files a run writes (model k > 0 with the suffix _k) and of a COLMAP model's files
_TOP_OUTPUT = re.compile(r"(points|reconstruction)(_\d+)?\.(ply|png)")
_MODEL_FILE = re.compile(r"(cameras|images|points3D|rigs|frames)\.(bin|txt)")
_CONVENTION = "X_cam = R (X_world - c)"


def _foreign_outputs(out: Path) -> list[Path]:
    """The paths in ``out`` that a run writes or replaces (``poses.json``, ``points[_k].ply``,
    ``reconstruction[_k].png``, the model folders ``sparse/<k>``, each replaced whole) holding what no
    earlier poseonly run wrote: a COLMAP project's models, a point cloud of another tool, a file of the
    user's in a model folder. A run's files are those its ``poses.json`` lists (``outputs``); a
    ``poses.json`` of an older version, which lists none, vouches for the names a run writes. Other files
    (``sparse/notes.txt``, ``points_clean.ply``) are never touched."""
    if not out.is_dir():
        return []
    ours = _previous_outputs(out)
    pj = out / "poses.json"
    found: list[Path] = []
    legacy = False
    if pj.exists():
        try:
            prev = json.loads(pj.read_text(encoding="utf-8"))
            own = isinstance(prev, dict) and prev.get("convention") == _CONVENTION
        except (OSError, ValueError):
            own = False
        if not own:
            found.append(pj)
        else:
            models = prev.get("models")
            legacy = not (isinstance(models, list) and any(isinstance(m, dict) and "outputs" in m for m in models))

    def theirs(f: Path, named: bool) -> bool:
        return f not in ours and not (legacy and named)

    found += [f for f in sorted(out.iterdir()) if _TOP_OUTPUT.fullmatch(f.name) and theirs(f, True)]
    sparse = out / "sparse"
    if sparse.is_dir():
        for d in sorted(sparse.iterdir()):
            if d.name.isdigit() and d.is_dir() and any(theirs(f, f.parent == d and bool(_MODEL_FILE.fullmatch(f.name))) for f in d.rglob("*") if not f.is_dir()):
                found.append(d)
    elif sparse.exists():
        found.append(sparse)
    return found


def _remove_stale(out: Path, stale: set[Path]) -> None:
    """Remove a previous run's output files that this run did not write (they would not match poses.json;
    a user's trial): regular files only, never through a symlink; a model folder left empty goes too.
    Runs after poses.json is written; a failure is reported, not raised (the new outputs are complete)."""
    removed: list[str] = []
    try:
        for f in sorted(stale):
            if f.is_symlink() or not f.is_file():
                continue
            f.unlink()
            removed.append(f.relative_to(out).as_posix())
        for d in sorted({f.parent for f in stale}, reverse=True):
            if d != out and not d.is_symlink() and d.is_dir() and not any(d.iterdir()):
                d.rmdir()
    except OSError as exc:
        print(f"could not remove every output of the previous run in {out}: {exc}")
    if removed:
        print(f"removed {len(removed)} files of the previous run in {out} that this run does not write: {', '.join(removed)}")


def _suffix(k: int) -> str:
    """Model ``k``'s file suffix: none for the largest (``points.ply``), ``_k`` for the others."""
    return "" if k == 0 else f"_{k}"


def _write_model(k: int, res: Any, images: list[Path], ig: Any, out: Path, args: argparse.Namespace, shown: Path) -> dict[str, Any]:
    """Print model ``k``'s summary and write its point cloud, figure and COLMAP model (``sparse/k``) into
    ``out`` (the staging folder; the messages name their places in ``shown``); returns its entry of
    poses.json's ``models``."""
    from .export import colmap_model_of, plot_reconstruction, point_colors, write_colmap_model, write_ply

    est = np.all(np.isfinite(res.centres), axis=1)
    has_R = np.all(np.isfinite(res.rotations), axis=(1, 2))
    component = res.rotation.estimated
    rec = res.reconstruction
    undetermined = res.info.get("translation_undetermined")
    entry: dict[str, Any] = {"model": k, "status": "translation_undetermined" if undetermined else "ok", "images": int(has_R.sum()), "points": int(rec.num_valid)}
    posed = f"{int(has_R.sum())} rotations averaged, centres undetermined" if undetermined else f"{int(est.sum())}/{int(component.sum())} posed"
    print(f"model {k}: cameras: {posed}; outlier edges: {len(res.rotation.outlier_edges)}; points: {rec.num_valid}/{len(res.tracks)} valid")
    li = res.ligt.info
    reasons = {
        "not joined to the solved component by usable tracks": _count(li, "views_disconnected"),
        "whose tracks do not fix their centre": _count(li, "views_weak"),
    }
    missing = 0 if undetermined else int(np.sum(component & ~est))
    reasons["without usable tracks"] = missing - sum(reasons.values())
    entry["views_not_posed"] = missing
    if missing > 0:
        print(f"model {k}: not posed: " + ", ".join(f"{c} {why}" for why, c in reasons.items() if c > 0))
    print(f"model {k}: stages: " + ", ".join(f"{key} {v:.2f} s" for key, v in res.times_s.items()))
    if undetermined:
        entry["reason"] = undetermined
        print(f"model {k}: the camera centres are not determined: {undetermined} (a pure rotation or a panorama?)")
        print(f"model {k}: poses.json holds its {int(has_R.sum())} averaged rotations; no COLMAP model, point cloud or figure written")
        return entry
    sfx = _suffix(k)
    # sampled at OpenCV's pixel centres (integers): the cameras' keypoints less COLMAP's half pixel (a
    # review: a database's keypoints, in COLMAP's convention, were sampled half a pixel off)
    from ..cameras import OPENCV_TO_COLMAP_PX

    kps = [f.keypoints for f in ig.features] if ig.cameras is None else [ig.camera_keypoints(k) - OPENCV_TO_COLMAP_PX for k in range(len(ig.features))]
    colors = point_colors(images, kps, res.tracks, rec.base[:, 0])
    write_ply(out / f"points{sfx}.ply", rec.points[rec.valid], colors[rec.valid], res.centres)
    entry["outputs"] = [f"points{sfx}.ply"]  # the files written, relative to out (a rerun removes stale ones)
    fig = plot_reconstruction(out / f"reconstruction{sfx}.png", rec.points[rec.valid], res.centres, res.rotations, colors[rec.valid])
    if fig is not None:
        entry["outputs"].append(f"reconstruction{sfx}.png")
        print(f"model {k}: figure: {shown / fig.name}")
    try:
        import_pycolmap()
    except ImportError:
        print(f"model {k}: pycolmap is not installed: COLMAP model not written (points{sfx}.ply and poses.json are)")
    else:
        model = colmap_model_of([p.name for p in images], ig, res, colors)
        folder = write_colmap_model(model, out / "sparse" / str(k), binary=not args.text)
        entry["outputs"] += sorted(f.relative_to(out).as_posix() for f in folder.iterdir() if f.is_file())
        print(f"model {k}: COLMAP model: {shown / 'sparse' / str(k)} ({model.num_reg_images()} images, {model.num_points3D()} points)")
    return entry


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
    known = {p.name for p in folder.iterdir() if is_image_file(p)} if folder.is_dir() else set()
    out: set[tuple[int, int]] = set()
    # names of the folder's images, as they are: no directories
    for a, b in parse_pair_names(path.read_text(encoding="utf-8", errors="replace").splitlines(), str(path), known, f"the name of an image in {folder}"):
        if a in index and b in index:  # both used (not cut by --max-images)
            out.add((min(index[a], index[b]), max(index[a], index[b])))
    if not out:
        raise InputError(f"{path}: no pair of the images used")
    return sorted(out)


def _cmd_global(args: argparse.Namespace) -> int:
    import shlex
    import sys

    from .. import experiments
    from .._fileutil import new_results_dir
    from ..experiments import global_sfm

    if args.out is None:
        args.out = str(new_results_dir("global"))
    # the reports record the command, as every other experiment's (a researcher's trial: global_sfm.md had none)
    experiments.set_command_line("poseonly " + shlex.join(getattr(args, "argv", None) or sys.argv[1:]))
    try:
        return int(global_sfm.run(args) or 0)
    finally:
        experiments.clear_command_line()


def add_parsers(sub: Any, esub: Any) -> None:
    """Add ``sfm`` to the command subparsers ``sub`` and ``global`` to the experiment ones ``esub``."""
    s = sub.add_parser("sfm", help="global SfM of an image folder (rotation averaging + LiGT + analytical points)")
    s.add_argument("images", help="folder of images (.jpg, .jpeg, .png, .tif, .tiff, .bmp, .webp, any case), one calibrated camera")
    s.add_argument("--K", help="text file with the 3x3 calibration matrix of the (undistorted) images")
    s.add_argument(
        "--camera-model",
        help="instead of --K (or of a --database's cameras): the images' camera model, a COLMAP name (any perspective model, e.g. PINHOLE,"
        " OPENCV, OPENCV_FISHEYE, FOV, EUCM; poseonly.cameras.MODELS)",
    )
    s.add_argument(
        "--camera-params",
        help="the camera model's parameters in COLMAP's order and pixel convention (as in its cameras.txt), separated by commas or spaces "
        "(e.g. f,cx,cy,k for SIMPLE_RADIAL; write --camera-params=... when the first value is negative)",
    )
    s.add_argument("--database", help="COLMAP database with cameras, keypoints and matches (replaces our features and matching)")
    s.add_argument(
        "--trust-guessed-focal",
        action="store_true",
        help="--database: use the focal length COLMAP guessed for cameras imported without calibration or EXIF focal length (refused otherwise)",
    )
    s.add_argument("--out", required=True, help="output folder")
    s.add_argument(
        "--overwrite",
        action="store_true",
        help="replace outputs in --out that no poseonly run wrote (e.g. a COLMAP project's sparse/0; refused without it); other files are kept",
    )
    s.add_argument("--max-features", type=non_negative_int, default=None, help="strongest SIFT features per image (default 8000; 0: every feature SIFT finds)")
    s.add_argument("--max-images", type=positive_int, help="use only the first N images (sorted by name)")
    s.add_argument("--threshold-px", type=positive_float, default=None, help="two-view inlier threshold (px; default: the method's, 1 px)")
    s.add_argument("--cache", help="feature / match cache (default OUT/cache)")
    s.add_argument("--text", action="store_true", help="write the COLMAP model as text")
    s.add_argument("--no-progress", action="store_true", help="no progress bars (there are bars only where stderr is a terminal)")
    s.add_argument("--seed", type=seed_int, default=0, help="seed of every random choice (default 0); the same seed gives the same result")
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
    s.add_argument(
        "--ligt-reweight",
        type=non_negative_int,
        default=LIGT_REWEIGHT,
        metavar="N",
        help=f"LiGT's reweighting rounds by the observations' angular errors (default {LIGT_REWEIGHT}; 0: the paper's LiGT)",
    )
    s.set_defaults(func=cmd_sfm)

    from ..experiments import global_sfm

    e = esub.add_parser("global", help="global SfM on Strecha scenes against the ground truth")
    e.add_argument("--out", default=None, help="output folder (default: a new folder poseonly-global-<date>-<time> under the working directory)")
    e.add_argument("--seed", type=seed_int, default=0, help="seed of every random choice (default 0); the same seed gives the same result")
    global_sfm.add_arguments(e)
    e.set_defaults(func=_cmd_global)
