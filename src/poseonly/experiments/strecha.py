"""Real data: relative rotation accuracy on Strecha scenes (the paper's Sec. "Real Data Experiment
with Strecha", Table 3 and the identified-outlier bar figure).

``poseonly experiment strecha PATH [--scenes NAME ...] [--cache DIR] [--ratio 0.8] [--methods ...]
[--threshold-px ...] [--max-pairs N] [--max-features N]``

For every scene folder under ``PATH`` (:func:`poseonly.io.strecha.find_scenes`: ``images/``,
``images/K.txt``, ``gt_dense_cameras/``) and every view pair ``i < j`` with more than
``--min-matches`` (30) putative SIFT matches (full resolution, Lowe ratio ``--ratio``), every
method estimates the relative pose from the same matches:

* ``poseonly`` -- :func:`poseonly.estimate_relative_pose` with its defaults, on the matches alone (no
  match scores, no noise scales: the paper's protocol; ``poseonly bench real`` runs the default as the
  SIFT front-end calls it);
* ``gnc-ransac+LiGTopt`` / ``gnc-ransac`` -- the paper's Algorithm 3 as written (``method="gnc-ransac"``)
  with and without the LiGTopt refinement;
* ``opengv-ransac-5pt`` -- RANSAC + 5pt with OpenGV's defaults (when
  :mod:`poseonly.experiments.opengv_ransac` is available);
* ``opencv-ransac``, ``opencv-magsac``, ``poselib`` -- :data:`poseonly.anchors.ANCHORS` at their
  default threshold (1 px).

Reported per scene and method: number of pairs, mean / median rotation error (deg) against the
ground-truth relative rotation, mean identified-outlier percentage (1 - inliers / matches), mean
estimation time per pair (features and matching excluded), on two pair sets: (a) all pairs with
more than 30 putative matches (the paper's wording) and (b) the pairs that truly overlap (at least
``--gt-min`` (30) matches with Sampson error below ``--gt-px`` (2) px under the ground-truth pose).
On the remaining, non-overlapping pairs we count how often each method returns a confident pose
(ours: ``status == "ok"``; anchors: at least ``--min-confident-inliers`` (15) inliers) -- an honest
estimator should say "no reliable pose" there.

Outputs in ``--out``: ``strecha.md``, ``strecha.json`` (summaries and per-pair records),
``strecha.png``. Features are cached in ``--cache`` (default ``<out>/cache``) and putative
matches next to them, so an interrupted or repeated run skips extraction and matching.
"""

from __future__ import annotations

import argparse
import hashlib
import inspect
import json
import os
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable

import numpy as np

from ..argtypes import non_negative_int, positive_float, positive_int
from ..geometry import InputError, bearings_from_pixels, rotation_error_deg, translation_error_deg
from ._common import atomic_write_text, code_version, fmt, machine, markdown_table, progress, savefig, strict_json, write_json

OURS = ("poseonly", "gnc-ransac+LiGTopt", "gnc-ransac")
OPENGV = "opengv-ransac-5pt"
ANCHOR_NAMES = ("opencv-ransac", "opencv-magsac", "poselib")
ALL_METHODS = OURS + (OPENGV,) + ANCHOR_NAMES

# the paper's Table 3 (GNC-RANSAC and OpenGV columns), mean / median rotation error in degrees
PAPER_TABLE3 = {
    "Herz-Jesus-P8": {"opengv": (0.125, 0.096), "gnc-ransac": (0.072, 0.044)},
    "Herz-Jesus-P25": {"opengv": (0.364, 0.162), "gnc-ransac": (0.214, 0.078)},
    "fountain-P11": {"opengv": (0.149, 0.101), "gnc-ransac": (0.0647, 0.0480)},
    "entry-P10": {"opengv": (0.748, 0.180), "gnc-ransac": (0.0412, 0.0367)},
    "castle-P19": {"opengv": (2.535, 0.468), "gnc-ransac": (0.449, 0.100)},
    "castle-P30": {"opengv": (2.385, 0.365), "gnc-ransac": (1.949, 0.089)},
}


def _default_thresholds() -> str:
    """The API's default thresholds of our methods, as the report states them."""
    from ..options import OPTIONS

    return "the API defaults (" + ", ".join(f"{m} {OPTIONS[m]().threshold_px:g} px" for m in ("poseonly", "gnc-ransac")) + ")"


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("path", nargs="?", default=os.environ.get("POSEONLY_STRECHA"), help="folder holding Strecha scene folders (or one scene folder); default $POSEONLY_STRECHA")
    p.add_argument("--scenes", nargs="+", metavar="NAME", help="only these scene folder names (default: all found)")
    p.add_argument("--cache", help="feature/match cache directory (default: <out>/cache)")
    p.add_argument("--ratio", type=positive_float, default=0.8, help="Lowe ratio of the SIFT matching (default 0.8)")
    p.add_argument("--methods", nargs="+", choices=ALL_METHODS, metavar="METHOD", help=f"methods to run (default: all available): {', '.join(ALL_METHODS)}")
    p.add_argument(
        "--threshold-px",
        nargs="+",
        type=positive_float,
        metavar="PX",
        help="inlier threshold(s) in pixels of our methods (default: the API default); several values run every one of our methods once per value, named METHOD@PXpx",
    )
    p.add_argument(
        "--noise-factor", type=positive_float, metavar="K", help="noise_factor option of the default method (its final threshold is K robust sigmas; default: the API default)"
    )
    p.add_argument("--anchor-threshold-px", type=positive_float, default=1.0, help="threshold of OpenCV and PoseLib in pixels (default 1, their defaults)")
    p.add_argument("--opengv-threshold-px", type=positive_float, help="threshold of RANSAC+5pt in pixels per view (default: OpenGV's own, 0.5 sqrt(2) px at f = 800)")
    p.add_argument("--max-pairs", type=positive_int, help="at most this many pairs per scene (in (i, j) order; for smoke tests)")
    p.add_argument("--max-features", type=non_negative_int, help="keep the strongest N SIFT features per image (default: all)")
    p.add_argument("--min-matches", type=non_negative_int, default=30, help="process pairs with MORE than this many putative matches")
    p.add_argument("--gt-px", type=positive_float, default=2.0, help="Sampson error (px) under the GT pose of a GT-consistent match")
    p.add_argument("--gt-min", type=non_negative_int, default=30, help="a pair truly overlaps with at least this many GT-consistent matches")
    p.add_argument("--min-confident-inliers", type=non_negative_int, default=15, help="an anchor's pose counts as confident with at least this many inliers")
    p.add_argument("--wrong-deg", type=positive_float, default=5.0, help="a confident pose with a larger rotation error is 'wrong'")


# ------------------------------------------------------------------------------------------------
# matches (cached)


def _match_cache_file(cache: Path, p1: Path, p2: Path, ratio: float, max_features: int | None) -> Path:
    key = {"v": 1, "ratio": float(ratio), "max_features": int(max_features or 0), "detector": "sift"}
    for k, p in (("a", p1), ("b", p2)):
        st = p.stat()
        key[k] = [str(p.resolve()), st.st_size, st.st_mtime_ns]
    h = hashlib.sha256(json.dumps(key, sort_keys=True).encode()).hexdigest()[:32]
    return cache / "matches" / f"match_{h}.npz"


def _pair_matches(scene, i: int, j: int, feats: dict, cache: Path, ratio: float, max_features: int | None):
    """Putative matches ``(u1, u2)`` of views ``i, j`` (cached in ``cache/matches``)."""
    from .._fileutil import atomic_savez
    from ..features import extract_features, match_features

    p1, p2 = scene.image_paths[i], scene.image_paths[j]
    f = _match_cache_file(cache, p1, p2, ratio, max_features)
    if f.is_file():
        try:
            with np.load(f, allow_pickle=False) as z:
                u1, u2 = np.asarray(z["u1"], float), np.asarray(z["u2"], float)
            if u1.ndim == 2 and u1.shape[1:] == (2,) and u1.shape == u2.shape:
                return u1, u2, 0.0
        except Exception:  # noqa: BLE001 - unreadable cache: recompute
            pass
    t0 = time.perf_counter()
    for k in (i, j):
        if k not in feats:
            feats[k] = extract_features(scene.image_paths[k], max_features=max_features, cache_dir=cache)
    idx = match_features(feats[i].descriptors, feats[j].descriptors, ratio=ratio)
    u1 = feats[i].keypoints[idx[:, 0]].reshape(-1, 2)
    u2 = feats[j].keypoints[idx[:, 1]].reshape(-1, 2)
    atomic_savez(f, u1=u1, u2=u2)
    return u1, u2, time.perf_counter() - t0


# ------------------------------------------------------------------------------------------------
# methods


@dataclass
class Method:
    name: str
    run: Callable[..., dict]  # (u1, u2, K, seed) -> {"R", "t", "num_inliers", "status", "time_s"}
    ours: bool


def _ours(api_method: str, refine: bool | None, threshold: float | None, extra: dict[str, Any] | None = None) -> Callable[..., dict]:
    from ..api import estimate_relative_pose

    def run(u1, u2, K, seed):
        opts: dict[str, Any] = {"seed": int(seed), **(extra or {})}
        if refine is not None:
            opts["refine"] = refine
        if threshold is not None:
            opts["threshold_px"] = float(threshold)
        t0 = time.perf_counter()
        r = estimate_relative_pose(u1, u2, K, K, method=api_method, **opts)
        dt = time.perf_counter() - t0
        return {"R": r.R, "t": r.t, "num_inliers": r.num_inliers, "status": r.status, "time_s": dt}

    return run


def _anchor(name: str, thr: float, min_inl: int) -> Callable[..., dict]:
    from ..anchors import ANCHORS

    fn = ANCHORS[name]

    def run(u1, u2, K, seed):
        kw = {"seed": int(seed)} if name == "poselib" else {}
        if name.startswith("opencv"):
            import cv2

            cv2.setRNGSeed(int(seed))
        R, t, inl, dt = fn(u1, u2, K, K, thr, **kw)
        n = int(np.count_nonzero(inl)) if R is not None else 0
        status = "failed" if R is None else ("ok" if n >= min_inl else "too_few_inliers")
        return {"R": R, "t": t, "num_inliers": n, "status": status, "time_s": dt}

    return run


def _opengv(thr_px: float | None, min_inl: int) -> Callable[..., dict] | None:
    """RANSAC + 5pt with OpenGV's defaults, if :mod:`poseonly.experiments.opengv_ransac` exists.

    ``thr_px=None`` keeps OpenGV's default threshold (its test files': 0.5 sqrt(2) px at f = 800 in
    each view, on the symmetric ``1 - cos`` residual); a number converts ``thr_px`` at the scene's
    focal to that residual: ``2 (1 - cos(atan(thr_px / f)))``.
    """
    try:
        from . import opengv_ransac as ogv
    except ImportError:
        return None
    fn = getattr(ogv, "opengv_ransac_5pt", None)
    if fn is None:
        return None
    params = inspect.signature(fn).parameters

    def run(u1, u2, K, seed):
        f1, f2 = bearings_from_pixels(u1, K), bearings_from_pixels(u2, K)
        focal = 0.5 * (K[0, 0] + K[1, 1])
        kw: dict[str, Any] = {}
        if thr_px is not None and "threshold" in params:
            kw["threshold"] = 2.0 * (1.0 - np.cos(np.arctan(thr_px / focal)))
        rng = np.random.default_rng(int(seed))
        t0 = time.perf_counter()
        out = fn(f1, f2, rng, **kw)
        dt = time.perf_counter() - t0
        if isinstance(out, dict):
            R, t, inl = out.get("R"), out.get("t"), out.get("inliers")
        elif isinstance(out, tuple):
            R, t, inl = out[0], out[1], out[2] if len(out) > 2 else None
        else:
            R, t, inl = getattr(out, "R", None), getattr(out, "t", None), getattr(out, "inliers", None)
        if inl is None:
            n = 0
        else:
            inl = np.asarray(inl)
            n = int(np.count_nonzero(inl)) if inl.dtype == bool else int(len(inl))
        ok = R is not None and bool(np.all(np.isfinite(R)))
        status = "failed" if not ok else ("ok" if n >= min_inl else "too_few_inliers")
        return {"R": R if ok else None, "t": t, "num_inliers": n, "status": status, "time_s": dt}

    return run


def build_methods(names, thresholds, anchor_thr: float, min_inl: int, notes: list[str], opengv_thr: float | None = None, noise_factor: float | None = None) -> list[Method]:
    from ..anchors import available_anchors

    names = list(names or ALL_METHODS)
    thresholds = list(thresholds) if thresholds else [None]
    methods: list[Method] = []
    spec = {"poseonly": ("poseonly", None), "gnc-ransac+LiGTopt": ("gnc-ransac", True), "gnc-ransac": ("gnc-ransac", False)}
    for n in names:
        if n in spec:
            for thr in thresholds:
                label = n if len(thresholds) == 1 else f"{n}@{thr:g}px"
                extra = {"noise_factor": float(noise_factor)} if (noise_factor is not None and n == "poseonly") else None
                methods.append(Method(label, _ours(*spec[n], thr, extra), True))
        elif n == OPENGV:
            run = _opengv(opengv_thr, min_inl)
            if run is None:
                notes.append(f"{OPENGV} skipped: poseonly.experiments.opengv_ransac (opengv_ransac_5pt) is not available")
            else:
                methods.append(Method(n, run, False))
        elif n in ANCHOR_NAMES:
            if n not in available_anchors():
                notes.append(f"{n} skipped: its library is not installed")
            else:
                methods.append(Method(n, _anchor(n, anchor_thr, min_inl), False))
    if not methods:
        raise InputError("no method to run (all requested methods are unavailable)")
    return methods


# ------------------------------------------------------------------------------------------------
# the experiment


def _select_scenes(root: Path, names: list[str] | None) -> list[Path]:
    from ..io.strecha import find_scenes

    found = find_scenes(root)
    if not found:
        raise InputError(f"no Strecha scene folders (with images/ and gt_dense_cameras/) under {root}")
    if names:
        by = {p.name: p for p in found}
        missing = [n for n in names if n not in by]
        if missing:
            raise InputError(f"scene(s) {missing} not found under {root}; available: {sorted(by)}")
        found = [by[n] for n in names]
    return found


def compute(
    root: str | Path,
    *,
    scenes: list[str] | None = None,
    cache: str | Path,
    ratio: float = 0.8,
    methods: list[str] | None = None,
    thresholds: list[float] | None = None,
    anchor_thr: float = 1.0,
    opengv_thr: float | None = None,
    noise_factor: float | None = None,
    max_pairs: int | None = None,
    max_features: int | None = None,
    min_matches: int = 30,
    gt_px: float = 2.0,
    gt_min: int = 30,
    min_conf_inliers: int = 15,
    wrong_deg: float = 5.0,
    seed: int = 0,
) -> dict:
    from ..features import sampson_error_px
    from ..io.strecha import load_scene, relative_pose

    if not 0 < ratio <= 1:
        raise InputError(f"--ratio must be in (0, 1], got {ratio}")
    if max_pairs is not None and max_pairs < 1:
        raise InputError(f"--max-pairs must be >= 1, got {max_pairs}")
    root = Path(root)
    cache = Path(cache)
    notes: list[str] = []
    ms = build_methods(methods, thresholds, anchor_thr, min_conf_inliers, notes, opengv_thr, noise_factor)
    loaded = [load_scene(p) for p in _select_scenes(root, scenes)]
    plan = []
    for sc in loaded:
        pairs = [(i, j) for i in range(len(sc)) for j in range(i + 1, len(sc))]
        plan += [(sc, i, j) for i, j in pairs[: max_pairs or None]]
    records: list[dict] = []
    feats: dict[str, dict] = {}
    t_feat = 0.0
    t_start = time.perf_counter()
    for sc, i, j in progress(plan, total=len(plan), desc="strecha pairs"):
        u1, u2, dt = _pair_matches(sc, i, j, feats.setdefault(sc.name, {}), cache, ratio, max_features)
        t_feat += dt
        R_gt, t_gt, base = relative_pose(sc, i, j)
        K = sc.K
        n = len(u1)
        rec: dict[str, Any] = {
            "scene": sc.name,
            "i": i,
            "j": j,
            "images": [sc.image_paths[i].name, sc.image_paths[j].name],
            "matches": n,
            "baseline_m": base,
            "processed": n > min_matches,
        }
        if n > 0:
            e_gt = sampson_error_px(u1, u2, K, K, R_gt, t_gt)
            rec["gt_matches"] = int(np.count_nonzero(e_gt < gt_px))
        else:
            rec["gt_matches"] = 0
        rec["overlap"] = rec["gt_matches"] >= gt_min
        if rec["processed"]:
            rec["methods"] = {}
            for m in ms:
                try:
                    o = m.run(u1, u2, K, seed)
                except (ValueError, np.linalg.LinAlgError) as exc:  # a method refusing the input is a failure
                    o = {"R": None, "t": None, "num_inliers": 0, "status": "failed", "time_s": float("nan"), "error": str(exc)}
                R = o["R"]
                ok = R is not None
                rerr = float(rotation_error_deg(R_gt, R)) if ok else float("nan")
                terr = float(translation_error_deg(t_gt, o["t"])) if ok and o["t"] is not None else float("nan")
                d = {
                    "rot_err_deg": rerr,
                    "t_err_deg": terr,
                    "inliers": int(o["num_inliers"]),
                    "inlier_ratio": o["num_inliers"] / n,
                    "outlier_pct": 100.0 * (1.0 - o["num_inliers"] / n),
                    "status": o["status"],
                    "confident": o["status"] == "ok",
                    "time_s": float(o["time_s"]),
                }
                if "error" in o:
                    d["error"] = o["error"]
                rec["methods"][m.name] = d
        records.append(rec)
    out = {
        "config": {
            "path": str(root),
            "scenes": [sc.name for sc in loaded],
            "cache": str(cache),
            "ratio": ratio,
            "max_features": max_features,
            "max_pairs": max_pairs,
            "min_matches": min_matches,
            "gt_px": gt_px,
            "gt_min": gt_min,
            "min_confident_inliers": min_conf_inliers,
            "wrong_deg": wrong_deg,
            "seed": seed,
            "threshold_px": thresholds,
            "anchor_threshold_px": anchor_thr,
            "opengv_threshold_px": opengv_thr,
            "noise_factor": noise_factor,
        },
        "methods": [m.name for m in ms],
        "ours": [m.name for m in ms if m.ours],
        "notes": notes,
        "time_features_matching_s": t_feat,
        "time_total_s": time.perf_counter() - t_start,
        "machine": machine(),
        "code_version": code_version(),
        "pairs": records,
    }
    out["summary"] = summarize(out)
    return out


# ------------------------------------------------------------------------------------------------
# summaries


def _stats(recs: list[dict], m: str, wrong_deg: float) -> dict:
    e = np.array([r["methods"][m]["rot_err_deg"] for r in recs], float)
    o = np.array([r["methods"][m]["outlier_pct"] for r in recs], float)
    tt = np.array([r["methods"][m]["time_s"] for r in recs], float)
    conf = np.array([r["methods"][m]["confident"] for r in recs], bool)
    fin = np.isfinite(e)
    return {
        "pairs": len(recs),
        "failed": int(np.count_nonzero(~fin)),
        "mean_err_deg": float(np.mean(e[fin])) if fin.any() else float("nan"),
        "median_err_deg": float(np.median(e[fin])) if fin.any() else float("nan"),
        "max_err_deg": float(np.max(e[fin])) if fin.any() else float("nan"),
        "mean_outlier_pct": float(np.mean(o)) if len(o) else float("nan"),
        "mean_time_ms": float(1e3 * np.nanmean(tt)) if np.isfinite(tt).any() else float("nan"),
        "confident": int(np.count_nonzero(conf)),
        "not_confident": int(np.count_nonzero(~conf)),
        "confident_wrong": int(np.count_nonzero(conf & fin & (e > wrong_deg))),
    }


def summarize(res: dict) -> dict:
    wrong = res["config"]["wrong_deg"]
    proc = [r for r in res["pairs"] if r["processed"]]
    sets = {
        "all": lambda r: True,
        "overlap": lambda r: r["overlap"],
        "non_overlap": lambda r: not r["overlap"],
    }
    scenes = list(res["config"]["scenes"]) + ["all scenes"]
    out: dict[str, Any] = {}
    for sname, pred in sets.items():
        out[sname] = {}
        for sc in scenes:
            recs = [r for r in proc if pred(r) and (sc == "all scenes" or r["scene"] == sc)]
            out[sname][sc] = {m: _stats(recs, m, wrong) for m in res["methods"]} if recs else {}
    out["counts"] = {
        sc: {
            "pairs": sum(1 for r in res["pairs"] if sc == "all scenes" or r["scene"] == sc),
            "processed": sum(1 for r in proc if sc == "all scenes" or r["scene"] == sc),
            "overlap": sum(1 for r in proc if r["overlap"] and (sc == "all scenes" or r["scene"] == sc)),
        }
        for sc in scenes
    }
    return out


def _paper_key(scene: str) -> str | None:
    for k in PAPER_TABLE3:
        if k.lower() == scene.lower():
            return k
    return None


def to_markdown(res: dict, command: str | None = None) -> str:
    S = res["summary"]
    ms = res["methods"]
    cfg = res["config"]
    lines = ["# Strecha: relative rotation accuracy on real images", ""]
    if command:
        lines += ["Command:", "", "```bash", command, "```", ""]
    thr = cfg["threshold_px"]
    lines += [
        f"Scenes: {', '.join(cfg['scenes'])} under `{cfg['path']}`. SIFT (OpenCV) on full-resolution images"
        + (f" (strongest {cfg['max_features']} features)" if cfg["max_features"] else "")
        + f", brute-force matching with Lowe ratio {cfg['ratio']}; pairs with more than {cfg['min_matches']} putative "
        f"matches" + (f", at most {cfg['max_pairs']} per scene" if cfg["max_pairs"] else "") + ". "
        f"Our methods at threshold {_default_thresholds() if not thr else ', '.join(f'{v:g} px' for v in thr)}; "
        f"OpenCV / PoseLib at {cfg['anchor_threshold_px']:g} px; RANSAC+5pt (OpenGV) at "
        + (
            f"{cfg['opengv_threshold_px']:g} px"
            if cfg.get("opengv_threshold_px")
            else "OpenGV's default threshold (0.5 sqrt(2) px at f = 800 per view, i.e. about 0.71 * f / 800 px here) and 50 iterations"
        )
        + f". Seed {cfg['seed']}. "
        f"Rotation error = angle of R_gt^T R (deg). Outlier % = 1 - inliers / putative matches, each method's own "
        f"inlier set. Time = estimation only, mean per pair (features + matching: "
        f"{res['time_features_matching_s']:.0f} s in total, cached ones excluded).",
        "",
        f"Machine: {res['machine']}" + (f"; code `{res['code_version']}`" if res.get("code_version") else "") + ".",
        "",
    ]
    for n in res["notes"]:
        lines.append(f"Note: {n}.")
    if res["notes"]:
        lines.append("")
    cnt = S["counts"]
    lines += [
        "Pairs: " + "; ".join(f"{sc}: {c['pairs']} pairs, {c['processed']} with > {cfg['min_matches']} matches, {c['overlap']} truly overlapping" for sc, c in cnt.items()),
        "",
    ]

    def compact(setname: str, title: str) -> None:
        lines.extend([f"## {title}", "", "Mean / median rotation error (deg); failed pairs (no pose) are excluded and counted in the detailed table.", ""])
        header = ["scene", "pairs"] + ms
        rows = []
        for sc, st in S[setname].items():
            if not st:
                continue
            rows.append([sc, st[ms[0]]["pairs"]] + [f"{fmt(st[m]['mean_err_deg'])} / {fmt(st[m]['median_err_deg'])}" for m in ms])
        lines.append(markdown_table(header, rows))

    def detailed(setname: str) -> None:
        header = ["scene", "method", "pairs", "failed", "mean err (deg)", "median err (deg)", "max err (deg)", "outliers (%)", "time (ms)", "confident"]
        rows = []
        for sc, st in S[setname].items():
            for m in ms if st else []:
                s = st[m]
                rows.append(
                    [sc, m, s["pairs"], s["failed"], s["mean_err_deg"], s["median_err_deg"], s["max_err_deg"], f"{s['mean_outlier_pct']:.1f}", s["mean_time_ms"], s["confident"]]
                )
        lines.extend(["", markdown_table(header, rows)])

    compact("all", f"(a) All pairs with more than {cfg['min_matches']} putative matches (the paper's protocol)")
    detailed("all")
    compact("overlap", f"(b) Truly overlapping pairs (at least {cfg['gt_min']} matches within {cfg['gt_px']:g} px of the GT epipolar geometry)")
    detailed("overlap")
    lines += [
        "",
        f"## Non-overlapping pairs (fewer than {cfg['gt_min']} GT-consistent matches)",
        "",
        f'confident / not confident pose (ours: status == "ok"; anchors: at least {cfg["min_confident_inliers"]} '
        f"inliers), and confident poses with rotation error > {cfg['wrong_deg']:g} deg ('wrong').",
        "",
    ]
    header = ["scene", "pairs"] + ms
    rows = []
    for sc, st in S["non_overlap"].items():
        if st:
            rows.append([sc, st[ms[0]]["pairs"]] + [f"{st[m]['confident']} / {st[m]['not_confident']} (wrong {st[m]['confident_wrong']})" for m in ms])
    lines.append(markdown_table(header, rows) if rows else "none\n")
    # paper comparison
    keyed = [(sc, _paper_key(sc)) for sc in cfg["scenes"]]
    pk = [(sc, k) for sc, k in keyed if k]
    if pk:
        lines += ["", "## The paper's Table 3 (its own matches: SIFT + cascade hashing) next to ours (set a)", ""]
        header = ["scene", "paper OpenGV", "paper GNC-RANSAC"] + ms
        rows = []
        for sc, k in pk:
            st = S["all"].get(sc) or {}
            p = PAPER_TABLE3[k]
            rows.append(
                [sc, f"{p['opengv'][0]:g} / {p['opengv'][1]:g}", f"{p['gnc-ransac'][0]:g} / {p['gnc-ransac'][1]:g}"]
                + [f"{fmt(st[m]['mean_err_deg'])} / {fmt(st[m]['median_err_deg'])}" if st else "-" for m in ms]
            )
        lines.append(markdown_table(header, rows))
    # worst overlapping pairs of the first of our methods
    ours = res["ours"]
    if ours:
        m0 = ours[0]
        over = [r for r in res["pairs"] if r["processed"] and r["overlap"]]
        over.sort(key=lambda r: -np.nan_to_num(r["methods"][m0]["rot_err_deg"], nan=1e9))
        if over:
            ref = "poselib" if "poselib" in ms else ms[-1]
            lines += ["", f"## Worst overlapping pairs of `{m0}`", ""]
            header = ["scene", "pair", "matches", "GT-consistent", f"{m0} err (deg)", "inliers", "status", f"{ref} err (deg)", f"{ref} inliers"]
            rows = []
            for r in over[:10]:
                a, b = r["methods"][m0], r["methods"][ref]
                rows.append([r["scene"], f"{r['i']}-{r['j']}", r["matches"], r["gt_matches"], a["rot_err_deg"], a["inliers"], a["status"], b["rot_err_deg"], b["inliers"]])
            lines.append(markdown_table(header, rows))
    errs = [(r, m, d["error"]) for r in res["pairs"] if r["processed"] for m, d in r["methods"].items() if "error" in d]
    if errs:
        lines += ["", "## Exceptions raised (counted as failed pairs)", ""]
        lines.append(
            markdown_table(
                ["scene", "pair", "matches", "GT-consistent", "method", "error"], [[r["scene"], f"{r['i']}-{r['j']}", r["matches"], r["gt_matches"], m, e] for r, m, e in errs]
            )
        )
    lines += ["", f"Total run time {res['time_total_s']:.0f} s."]
    return "\n".join(lines) + "\n"


def figure(res: dict, path: Path) -> Path | None:
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:  # pragma: no cover
        return None
    S = res["summary"]
    ms = res["methods"]
    scenes = [sc for sc in res["config"]["scenes"] if S["all"].get(sc)]
    if not scenes:
        return None
    fig, ax = plt.subplots(1, 3, figsize=(16, 4.2))
    x = np.arange(len(scenes))
    w = 0.8 / len(ms)
    panels = [
        ("all", "mean_outlier_pct", "identified outliers (%), pairs with > 30 matches", False),
        ("all", "median_err_deg", "median rotation error (deg), pairs with > 30 matches", True),
        ("overlap", "median_err_deg", "median rotation error (deg), truly overlapping pairs", True),
    ]
    for a, (sset, key, title, log) in zip(ax, panels):
        for k, m in enumerate(ms):
            vals = [S[sset][sc][m][key] if S[sset].get(sc) else np.nan for sc in scenes]
            a.bar(x + k * w, [v if np.isfinite(v) else 0 for v in vals], w, label=m)
        if log:
            a.set_yscale("log")
            for k, sc in enumerate(scenes):
                pk = _paper_key(sc)
                if pk:
                    a.hlines(
                        PAPER_TABLE3[pk]["gnc-ransac"][1], x[k] - w / 2, x[k] + 0.8 - w / 2, colors="k", linestyles="--", label="paper's GNC-RANSAC (Table 3)" if k == 0 else None
                    )
        a.set_xticks(x + 0.4 - w / 2, scenes)
        a.set_title(title, fontsize=9)
    handles, labels = ax[1].get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=min(len(labels), 8), fontsize=8, frameon=False)
    fig.tight_layout(rect=(0, 0.08, 1, 1))
    savefig(fig, path)
    plt.close(fig)
    return path


def run(args: argparse.Namespace) -> int:
    if not args.path:
        raise InputError("give the folder holding the Strecha scenes (PATH), or set POSEONLY_STRECHA")
    out = Path(args.out)
    max_pairs, max_features = args.max_pairs, args.max_features
    if args.quick:
        max_pairs = max_pairs or 3
        max_features = max_features or 4000
    cache = Path(args.cache) if args.cache else out / "cache"
    res = compute(
        args.path,
        scenes=args.scenes,
        cache=cache,
        ratio=args.ratio,
        methods=args.methods,
        thresholds=args.threshold_px,
        anchor_thr=args.anchor_threshold_px,
        opengv_thr=args.opengv_threshold_px,
        noise_factor=args.noise_factor,
        max_pairs=max_pairs,
        max_features=max_features,
        min_matches=args.min_matches,
        gt_px=args.gt_px,
        gt_min=args.gt_min,
        min_conf_inliers=args.min_confident_inliers,
        wrong_deg=args.wrong_deg,
        seed=args.seed,
    )
    prog = Path(sys.argv[0]).name if sys.argv else ""
    cmd = "poseonly " + " ".join(sys.argv[1:]) if prog in ("poseonly", "poseonly.exe", "cli.py", "__main__.py") else None
    res["command"] = cmd
    md = to_markdown(res, cmd)
    atomic_write_text(out / "strecha.md", md)
    write_json(out / "strecha.json", strict_json(res))
    figure(res, out / "strecha.png")
    print(md)
    return 0
