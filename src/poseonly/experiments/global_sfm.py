"""Global SfM on Strecha scenes (issue 15): the paper's pipeline without bundle adjustment.

``poseonly experiment global PATH [--scenes NAME ...] [--cache DIR (default OUT/cache)] [--max-features N]
[--threshold-px T] [--reweight K] [--ligt-normalization noise|unit] [--no-anchor] [--ba]``

For every scene folder at or below ``PATH`` (:func:`poseonly.io.strecha.find_scenes`): SIFT
features (strongest ``--max-features``), mutual ratio-test matches of all pairs, the two-view
poses of :func:`poseonly.estimate_relative_pose` (default method), then rotation averaging (L1RA +
IRLS), tracks, LiGT and the analytical reconstruction (:func:`poseonly.sfm.pipeline.run_global`).

Reported per scene: per-camera rotation error and position error after a 7-DoF similarity fitted
on the camera centres (openMVG's ``main_evalQuality``: the rotation error uses that similarity's
rotation), the rotation error after the best rotation-only alignment beside it, the mean error of
the relative rotations of all pairs (alignment-free), position errors in
ground-truth units (metres) and as a fraction of the extent (largest distance of a ground-truth
centre from their mean), the AUC of max(dR, dt) over all pairs at 0.5 / 1 / 5 / 10 deg (COLMAP's
benchmark), the mean error of the input two-view rotations, and the runtime of every stage.
When pycolmap is installed, its rotation averaging and global positioning on the same relative poses
and tracks, and its own global (GLOMAP) and incremental mappers (bundle adjustment included) on the
same images, keypoints and putative matches, are reported beside ours (:mod:`poseonly.sfm.colmap_anchor`);
when pyTheia is installed, its robust rotation averaging + LiGT on the same relative poses and tracks,
and its LiGT on our rotations (:mod:`poseonly.sfm.theia_anchor`). With
``--ba`` our result after an optional pycolmap bundle adjustment (:mod:`poseonly.sfm.colmap_ba`) is
reported as a separate row; it is not part of the pipeline's figures.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ..argtypes import non_negative_int, positive_degrees
from ..geometry import InputError
from ..io.strecha import find_scenes, load_scene
from ..sfm.choices import LIGT_NORMALIZATIONS, LIGT_REWEIGHT, ROTATION_WEIGHTS
from ._common import code_version, machine, markdown_table, progress, write_outputs

if TYPE_CHECKING:  # the pipeline's modules (scipy) load when a scene runs, not when the CLI starts
    from ..sfm.pairwise import ImageGraph
    from ..sfm.pipeline import GlobalResult
    from ..sfm.tracks import Tracks

# openMVG GlobalSfM (bundle adjustment included), mean rotation error in degrees, as published by
# the LiGT authors (PoSDK benchmark data; docs/SFM.md)
OPENMVG_ROT_DEG = {"Herz-Jesus-P8": 0.0228, "fountain-P11": 0.0297, "entry-P10": 0.0321, "Herz-Jesus-P25": 0.0546, "castle-P30": 0.0843, "castle-P19": 0.0695}


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("path", help="a Strecha scene folder, or a folder holding scene folders")
    p.add_argument("--scenes", nargs="+", help="only these scene names")
    p.add_argument("--cache", default=None, help="feature / match / two-view cache (default OUT/cache: a researcher's trial found the run writing to a shared /tmp folder)")
    p.add_argument("--max-features", type=non_negative_int, default=8000, help="strongest SIFT features per image (default 8000; 0: every feature SIFT finds)")
    p.add_argument("--threshold-px", type=float, default=None, help="two-view RANSAC threshold in pixels (default: the method's, 1 px)")
    p.add_argument("--two-view-option", action="append", metavar="KEY=VALUE", help="an option of the two-view estimator, KEY=VALUE (repeatable; e.g. ml_tails=gauss)")
    p.add_argument("--no-noise-scales", action="store_true", help="do not pass the keypoints' sizes to the two-view estimator as noise scales")
    p.add_argument("--reweight", type=non_negative_int, default=LIGT_REWEIGHT, help=f"LiGT reweighting iterations (default {LIGT_REWEIGHT}; 0 = the paper's and openMVG's LiGT)")
    p.add_argument(
        "--ligt-normalization",
        choices=LIGT_NORMALIZATIONS,
        default=LIGT_NORMALIZATIONS[0],
        help="LiGT's scale: the expected noise of its rows (default) or the paper's unit norm of the centres",
    )
    p.add_argument(
        "--rotation-sigma",
        type=positive_degrees,
        default=None,
        metavar="DEG",
        help="rotation averaging's Geman-McClure scale in degrees (default: from the data, 5x the noise-corrected median edge residual, at most 5; 5 on sparse graphs)",
    )
    p.add_argument(
        "--rotation-weights",
        choices=ROTATION_WEIGHTS,
        default=ROTATION_WEIGHTS[0],
        help="rotation averaging's edge weights: the two-view inlier counts (default) or each relative rotation's information",
    )
    p.add_argument("--jobs", type=int, default=1, help="threads for the features, matching and two-view stages (default 1; the same result for any number)")
    p.add_argument("--no-anchor", action="store_true", help="skip the anchors (pycolmap's and pyTheia's global stages, pycolmap's mappers)")
    p.add_argument("--ba", action="store_true", help="also report our result after an optional pycolmap bundle adjustment")


def _gt(scene) -> tuple[np.ndarray, np.ndarray]:
    R = np.array([c.R_cw.T for c in scene.cameras])  # world -> camera
    C = np.array([c.C for c in scene.cameras])
    return R, C


def _input_rotation_error(graph, R_gt: np.ndarray) -> float:
    from ..sfm.so3 import angle_deg

    p = graph.pairs()
    Rg = R_gt[p[:, 1]] @ np.transpose(R_gt[p[:, 0]], (0, 2, 1))
    return float(angle_deg(np.einsum("eji,ejk->eik", Rg, graph.rotations())).mean())


def _scores(R: np.ndarray, C: np.ndarray, R_gt: np.ndarray, C_gt: np.ndarray) -> dict[str, Any]:
    from ..sfm.align import evaluate_poses, pose_auc, relative_pose_errors

    ev = evaluate_poses(R, C, R_gt, C_gt)
    dR, dt = relative_pose_errors(R, C, R_gt, C_gt)
    ev.update(pose_auc(np.maximum(dR, dt)))
    ev["rel_rot_mean_deg"] = float(dR[np.isfinite(dR)].mean()) if np.any(np.isfinite(dR)) else float("nan")
    return ev


def run_scene(path: Path, args: argparse.Namespace) -> dict[str, Any]:
    from ..sfm.pairwise import PairwiseOptions, image_view_graph, parse_estimator_options
    from ..sfm.pipeline import GlobalOptions, run_global

    sc = load_scene(path)
    R_gt, C_gt = _gt(sc)
    opt = PairwiseOptions(
        max_features=args.max_features,
        threshold_px=args.threshold_px,
        seed=args.seed,
        use_noise_scales=not args.no_noise_scales,
        estimator_options=parse_estimator_options(args.two_view_option),
    )
    gopt = GlobalOptions(ligt_reweight=args.reweight, ligt_normalization=args.ligt_normalization, rotation_weights=args.rotation_weights, rotation_sigma_deg=args.rotation_sigma)
    t0 = time.perf_counter()
    ig = image_view_graph(sc.image_paths, sc.K, options=opt, cache_dir=args.cache, progress=lambda it, **kw: progress(it, **kw), jobs=args.jobs)
    t_pairs = time.perf_counter() - t0
    out: dict[str, Any] = {
        "scene": sc.name,
        "views": len(sc),
        "edges": len(ig.graph),
        "pairs_rejected": len(ig.graph.rejected),
        "times_s": {"pairwise (cached parts excluded)": t_pairs, **ig.times_s},
    }
    # a scene our pipeline cannot pose is a row of the table, not the end of the run: the other scenes
    # and the anchors (which may pose it) are still reported
    if len(ig.graph) == 0:
        out["ours"] = {"error": "no pair was trusted (the view graph has no edges)"}
        return _with_mappers(out, ig, sc, R_gt, C_gt, args)
    out["input_rotation_error_deg"] = _input_rotation_error(ig.graph, R_gt)
    res = run_global(ig.graph, ig.bearings, float(sc.K[0, 0]), gopt)
    if "translation_undetermined" in res.info:
        out["ours"] = {"error": f"the camera centres are not determined ({res.info['translation_undetermined']})"}
        return _with_mappers(out, ig, sc, R_gt, C_gt, args)
    try:
        ev = _scores(res.rotations, res.centres, R_gt, C_gt)
    except InputError as exc:  # fewer than 3 cameras posed: no similarity to align
        out["ours"] = {"error": f"too few cameras posed to score ({exc})"}
        return _with_mappers(out, ig, sc, R_gt, C_gt, args)
    out |= {
        "outlier_edges": res.rotation.outlier_edges,
        "tracks": len(res.tracks),
        "observations": res.tracks.num_observations,
        "points_valid": res.reconstruction.num_valid,
        "ours": ev,
        "times_s": {"pairwise (cached parts excluded)": t_pairs, **ig.times_s, **res.times_s},
        "ligt_info": res.ligt.info,
        "rotation_sigma_deg": res.info["rotation_sigma_deg"],
    }
    if args.ba:
        from ..sfm.colmap_ba import bundle_adjust, poses_from_reconstruction
        from ..sfm.export import colmap_model_of

        model = colmap_model_of([p.name for p in sc.image_paths], ig, res)
        model, t_ba = bundle_adjust(model)
        R_ba, C_ba = poses_from_reconstruction(model, len(sc))
        out["ba"] = _scores(R_ba, C_ba, R_gt, C_gt) | {"time_s": t_ba}
    if not args.no_anchor:
        out["pycolmap"] = _colmap_anchors(ig, sc, R_gt, C_gt, res.tracks)
        out["pytheia"] = _theia_anchor(ig, res, R_gt, C_gt)
    return out


def _with_mappers(out: dict[str, Any], ig: ImageGraph, sc: Any, R_gt: np.ndarray, C_gt: np.ndarray, args: argparse.Namespace) -> dict[str, Any]:
    """``out`` of a scene our pipeline did not pose, with pycolmap's own mappers (which run on the
    images, not on our result) unless ``--no-anchor``."""
    if not args.no_anchor:
        out["pycolmap"] = _colmap_anchors(ig, sc, R_gt, C_gt, None)
    return out


def _colmap_anchors(ig: ImageGraph, sc: Any, R_gt: np.ndarray, C_gt: np.ndarray, tracks: Tracks | None) -> dict[str, Any]:
    """pycolmap's global stages on our view graph and ``tracks`` (skipped when None) and its own
    mappers on the scene's images, scored; an ``error`` entry where pycolmap is missing or fails."""
    try:
        from ..sfm import colmap_anchor
    except ImportError as exc:  # pragma: no cover - pycolmap missing
        return {"error": str(exc)}
    out: dict[str, Any] = {}
    runs = ([lambda: colmap_anchor.run(ig, tracks)] if tracks is not None else []) + [lambda: colmap_anchor.run_mappers(ig, sc.image_paths)]
    for fn in runs:
        try:
            a = fn()
        except Exception as exc:  # noqa: BLE001 - an anchor failure must not lose our numbers
            out["error"] = f"{type(exc).__name__}: {exc}"
            continue
        _add_scored(out, a, R_gt, C_gt)
    return out


def _add_scored(out: dict[str, Any], runs: dict[str, Any], R_gt: np.ndarray, C_gt: np.ndarray) -> None:
    """``out[name]``: the scores of each anchor run (``rotations``, ``centres``, ``time_s``); a run that
    cannot be scored (fewer than 3 cameras posed) is added to ``out["error"]`` instead."""
    for k, v in runs.items():
        try:
            out[k] = _scores(v["rotations"], v["centres"], R_gt, C_gt) | {"time_s": v["time_s"]}
        except InputError as exc:
            out["error"] = "; ".join(filter(None, [out.get("error"), f"{k}: {exc}"]))


def _theia_anchor(ig: ImageGraph, res: GlobalResult, R_gt: np.ndarray, C_gt: np.ndarray) -> dict[str, Any]:
    """pyTheia's robust rotation averaging + LiGT, and its LiGT on our rotations, scored; an
    ``error`` entry where pyTheia is missing or fails (an anchor failure must not lose our numbers)."""
    try:
        import pytheia  # noqa: F401

        from ..sfm import theia_anchor
    except ImportError as exc:  # pragma: no cover - pytheia missing
        return {"error": f"pytheia not installed ({exc})"}
    try:
        a = theia_anchor.run(ig.graph, res.tracks, ig.bearings(res.tracks), res.rotations)
    except Exception as exc:  # noqa: BLE001
        return {"error": f"{type(exc).__name__}: {exc}"}
    out: dict[str, Any] = {}
    _add_scored(out, a, R_gt, C_gt)
    return out


def _table(results: list[dict[str, Any]]) -> str:
    hdr = [
        "scene",
        "method",
        "cams",
        "rot mean (deg)",
        "rot median",
        "rot mean, rot-only align",
        "rel rot mean, all pairs",
        "pos mean (m)",
        "pos mean / extent",
        "AUC@1",
        "AUC@5",
        "time (s)",
    ]
    rows = []
    for r in results:
        ev = r["ours"]
        t = sum(v for k, v in r["times_s"].items() if k in ("rotation_averaging", "tracks", "ligt", "reconstruction"))
        if "error" in ev:
            rows.append([r["scene"], f"poseonly (RA + LiGT, no BA): {ev['error']}", f"0/{r['views']}"] + [""] * 9)
        else:
            rows.append(
                [
                    r["scene"],
                    "poseonly (RA + LiGT, no BA)",
                    f"{ev['num_estimated']}/{r['views']}",
                    ev["rot_mean_deg"],
                    ev["rot_median_deg"],
                    ev["rot_mean_deg_rotalign"],
                    ev["rel_rot_mean_deg"],
                    ev["pos_mean"],
                    ev["pos_mean_frac"],
                    ev["auc@1"],
                    ev["auc@5"],
                    t,
                ]
            )
        if "ba" in r:
            b = r["ba"]
            rows.append(
                [
                    r["scene"],
                    "poseonly + optional pycolmap BA",
                    f"{b['num_estimated']}/{r['views']}",
                    b["rot_mean_deg"],
                    b["rot_median_deg"],
                    b["rot_mean_deg_rotalign"],
                    b["rel_rot_mean_deg"],
                    b["pos_mean"],
                    b["pos_mean_frac"],
                    b["auc@1"],
                    b["auc@5"],
                    t + b["time_s"],
                ]
            )
        for lib, k, a in [(name, k, a) for name in ("pycolmap", "pytheia") for k, a in (r.get(name) or {}).items()]:
            if k == "error":
                rows.append([r["scene"], f"{lib}: {a}", "", "", "", "", "", "", "", "", "", ""])
                continue
            rows.append(
                [
                    r["scene"],
                    f"{lib} {k}",
                    f"{a['num_estimated']}/{r['views']}",
                    a["rot_mean_deg"],
                    a["rot_median_deg"],
                    a["rot_mean_deg_rotalign"],
                    a["rel_rot_mean_deg"],
                    a["pos_mean"],
                    a["pos_mean_frac"],
                    a["auc@1"],
                    a["auc@5"],
                    a["time_s"],
                ]
            )
        if r["scene"] in OPENMVG_ROT_DEG:
            rows.append([r["scene"], "openMVG GlobalSfM + BA (published)", "", OPENMVG_ROT_DEG[r["scene"]], "", "", "", "", "", "", "", ""])
    return markdown_table(hdr, rows)


def _stage_table(results: list[dict[str, Any]]) -> str:
    keys = ["features", "matching", "two_view", "rotation_averaging", "tracks", "ligt", "reconstruction"]
    rows = [
        [r["scene"], r["edges"], len(r.get("outlier_edges", ())), r.get("input_rotation_error_deg", ""), r.get("tracks", ""), r.get("points_valid", "")]
        + [r["times_s"].get(k, float("nan")) for k in keys]
        for r in results
    ]
    return markdown_table(["scene", "edges", "outlier edges", "two-view rot err (deg)", "tracks", "points"] + [f"{k} (s)" for k in keys], rows)


def run(args: argparse.Namespace) -> int:
    root = Path(args.path)
    scenes = find_scenes(root)
    if args.scenes:
        scenes = [s for s in scenes if s.name in set(args.scenes)]
    if not scenes:
        raise ValueError(f"no Strecha scene folders at or below {root}" + (f" named {args.scenes}" if args.scenes else ""))
    if args.cache is None:
        args.cache = str(Path(args.out) / "cache")
    t0 = time.perf_counter()
    results = [run_scene(s, args) for s in scenes]
    res = {
        "results": results,
        "config": {k: v for k, v in vars(args).items() if k != "func"},
        "wall_s": time.perf_counter() - t0,
        "machine": machine(),
        "code_version": code_version(),
    }
    md = (
        "# Global SfM on Strecha (rotation averaging + LiGT + analytical points, no bundle adjustment)\n\n"
        + _table(results)
        + "\nStages (times measured on a shared machine, under load; features / matching / two-view "
        "are 0 when cached):\n\n" + _stage_table(results) + f"\nMachine: {res['machine']}; code `{res['code_version']}`.\n"
    )
    write_outputs(args.out, "global_sfm", md, res)
    return 0
