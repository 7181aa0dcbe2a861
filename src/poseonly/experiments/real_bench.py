"""Real-data benchmark: ``poseonly bench real DIR... [--seeds K] [--methods ...] [--out DIR]
[--cache DIR] [--max-pairs N]``.

Every ``DIR`` is either a *realpairs* dataset folder (``pairs.json`` as described in
``shared/data/realpairs/README.md``: images, ``K1``, ``K2``, ``R``, ``t`` with ``X2 = R X1 + t``) or a
Strecha scene folder (``images/``, ``images/K.txt``, ``gt_dense_cameras/``; loaded by
:mod:`poseonly.io.strecha`, every view pair ``i < j``). A folder holding several Strecha scenes is
expanded into its scenes.

Matches: OpenCV SIFT on the full-resolution images (features cached by
:func:`poseonly.features.extract_features`), brute-force two-nearest-neighbour matching with Lowe's
ratio test at 0.8 (the rule of :func:`poseonly.features.match_features`: keep ``d1 < 0.8 d2``).
The ratio ``d1 / d2`` of every match is kept; its quality score is ``1 - ratio`` (higher is
better). Matches are cached in ``<cache>/matches`` so every method and every run sees the same ones.

Pair sets: realpairs -- every pair (SuperGlue's protocol: a pair without a pose counts as an
infinite error). Strecha -- ``all``: every pair with more than ``MIN_MATCHES`` (30) matches (most
castle-like pairs do not overlap); ``overlap``: pairs with at least ``GT_MIN`` (30) matches within
``GT_PX`` (1 px) Sampson distance of the ground-truth epipolar geometry.

Methods are a registry (:data:`METHODS`) of named callables
``(u1, u2, K1, K2, scores, seed) -> MethodOutput(R, t, inliers, status)`` on pixel matches
``u1, u2 (n, 2)``, intrinsics ``(3, 3)``, ``scores (n,)`` (higher is better) and an int seed;
``status`` is ``None`` for estimators that do not report one. A variant of the default is one line::

    METHODS["poseonly@1px"] = ours(threshold_px=1.0)

Metrics per dataset, pair set and method: rotation error ``angle(R_gt^T R)`` and translation
direction error (SuperGlue: ``min(e, 180 - e)`` of the angle between the directions), median and
mean; pose AUC at 5 / 10 / 20 deg of ``max(R err, t err)`` (SuperGlue's ``pose_auc``); time per pair
(the call only, BLAS and OpenCV on one thread), median / mean, and its ratio to PoseLib (1 px) in
the same run; status honesty: ``ok`` poses with a rotation error above 5 deg, and pairs where the
pose and PoseLib's are both within 2 deg yet the status is not ``ok``. With ``--seeds K`` every
method runs seeds ``0 .. K-1`` and AUC@10's spread over seeds is reported (tables: seed 0).

Outputs in ``--out``: ``real_bench.md``, ``real_bench.json`` (config, summaries, per-pair records),
``real_bench.png`` (cumulative error curves). ``--methods`` defaults to :data:`DEFAULT_METHODS`; the
registry also holds ablations of the default (``poseonly@1px``, ``poseonly-fixed-thr``,
``poseonly-no-refine``, ``poseonly-min1000``). ``--diagnose N`` re-runs the N pairs the default
loses most to PoseLib and reports its final threshold, wrong inliers, MSAC cost against PoseLib's
and the truth's, iterations, seed dependence and the ablations (``real_bench_diagnosis.md``);
``--from-json`` skips the run and works on stored results (re-render or diagnose).
"""

from __future__ import annotations

import argparse
import hashlib
import json
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any, NamedTuple, Protocol, cast

import numpy as np

from .._fileutil import new_results_dir
from ..geometry import (
    InputError,
    check_intrinsics,
    rotation_error_deg,
    translation_error_deg,
)
from ._common import (
    atomic_write_text,
    code_version,
    machine,
    markdown_table,
    progress,
    pyplot,
    savefig,
    single_thread,
    strict_json,
    write_json,
)

RATIO = 0.8  # Lowe's ratio of the SIFT matching
MIN_MATCHES = 30  # Strecha "all pairs": more than this many matches
GT_PX = 1.0  # a match is consistent with the ground truth within this Sampson distance (px)
GT_MIN = 30  # a Strecha pair truly overlaps with at least this many GT-consistent matches
MIN_SOLVE = 8  # fewer matches: no method is run, the pair counts as a failure
AUC_DEG = (5.0, 10.0, 20.0)
WRONG_DEG = 5.0  # an `ok` pose with a larger rotation error is dishonest
GOOD_DEG = 2.0  # a pose within this rotation error of the truth is good
REFERENCE = "poselib-1px"  # time ratios and the "good pose" reference
_CACHE_VERSION = 2  # 2: the matches' noise scales (keypoint sizes) cached


# ------------------------------------------------------------------------------------------------
# method registry


class MethodOutput(NamedTuple):
    """``R (3, 3)``, unit ``t (3,)`` (``X2 = R X1 + t``; ``None`` on failure), ``inliers (n,)`` bool
    and the estimator's status (``None`` when it reports none)."""

    R: np.ndarray | None
    t: np.ndarray | None
    inliers: np.ndarray
    status: str | None


class MethodFn(Protocol):
    """``(u1, u2 (n, 2) pixels, K1, K2, scores (n,), seed, noise_scales (n,) | None) -> MethodOutput``."""

    def __call__(self, u1: np.ndarray, u2: np.ndarray, K1: np.ndarray, K2: np.ndarray, scores: np.ndarray, seed: int, noise_scales: np.ndarray | None = None) -> MethodOutput: ...


def ours(method: str = "poseonly", use_scores: bool = False, use_scales: bool = False, **options: Any) -> MethodFn:
    """poseonly's :func:`~poseonly.estimate_relative_pose` with ``method`` and fixed ``options``;
    ``use_scores`` passes the match scores (PROSAC sampling), ``use_scales`` the matches' noise
    scales (the keypoints' sizes)."""

    def run(u1: np.ndarray, u2: np.ndarray, K1: np.ndarray, K2: np.ndarray, scores: np.ndarray, seed: int, noise_scales: np.ndarray | None = None) -> MethodOutput:
        from ..api import estimate_relative_pose

        extra: dict[str, Any] = {"scores": scores} if use_scores else {}
        if use_scales and noise_scales is not None:
            extra["noise_scales"] = noise_scales
        r = estimate_relative_pose(u1, u2, K1, K2, method=method, seed=int(seed), **extra, **options)
        good = r.status not in ("degenerate", "failed") and r.R is not None and np.all(np.isfinite(r.R))
        return MethodOutput(r.R if good else None, r.t if good else None, np.asarray(r.inliers, bool), r.status)

    return run


def poselib(threshold_px: float) -> MethodFn:
    """``poselib.estimate_relative_pose`` (PINHOLE cameras, its defaults) at ``max_epipolar_error``
    ``threshold_px`` (:func:`poseonly.anchors.poselib_relpose`)."""

    def run(u1: np.ndarray, u2: np.ndarray, K1: np.ndarray, K2: np.ndarray, scores: np.ndarray, seed: int, noise_scales: np.ndarray | None = None) -> MethodOutput:
        from ..anchors import poselib_relpose

        R, t, inl, _ = poselib_relpose(u1, u2, K1, K2, threshold_px=threshold_px, seed=int(seed))
        return MethodOutput(R, t, inl, None)

    return run


def opencv_magsac(threshold_px: float = 1.0) -> MethodFn:
    """``cv2.findEssentialMat(..., USAC_MAGSAC, prob 0.999, threshold)`` + ``cv2.recoverPose``
    (:func:`poseonly.anchors.opencv_relpose`; OpenCV's default threshold is 1 px)."""

    def run(u1: np.ndarray, u2: np.ndarray, K1: np.ndarray, K2: np.ndarray, scores: np.ndarray, seed: int, noise_scales: np.ndarray | None = None) -> MethodOutput:
        import cv2

        from ..anchors import opencv_relpose

        cv2.setRNGSeed(int(seed))
        R, t, inl, _ = opencv_relpose(u1, u2, K1, K2, method="USAC_MAGSAC", threshold_px=threshold_px)
        return MethodOutput(R, t, inl, None)

    return run


# SupeRANSAC's essential-matrix settings of its authors' benchmark (danini/superansac,
# benchmark/tester-E-superansac.py): PROSAC sampling on matches sorted by score, MAGSAC scoring,
# nested-RANSAC local optimisation, least-squares final optimisation, confidence 0.9999999,
# at most 5000 iterations. Their 5 px threshold was tuned for SuperPoint+LightGlue; with SIFT we
# keep the library's default threshold (1.5 px) -- MAGSAC marginalises the noise scale below it.
# Their script's neighborhood_grid_density = 6 is not set: with the installed pysuperansac it made
# the estimator return no model (0 inliers after 5000 iterations) on about a third of the calls on
# a Herz-Jesus pair where the default grid never fails (measured, docs/RESULTS_real.md).
SUPERANSAC_THRESHOLD_PX = 1.5
SUPERANSAC_CONFIDENCE = 0.9999999
SUPERANSAC_MAX_ITERATIONS = 5000


def superansac(threshold_px: float = SUPERANSAC_THRESHOLD_PX) -> MethodFn:
    """``pysuperansac.estimateEssentialMatrix`` with its authors' settings (see above), matches in
    decreasing score order (PROSAC), then ``cv2.recoverPose`` on the normalised inliers (as the
    authors' benchmark does)."""

    def run(u1: np.ndarray, u2: np.ndarray, K1: np.ndarray, K2: np.ndarray, scores: np.ndarray, seed: int, noise_scales: np.ndarray | None = None) -> MethodOutput:
        import cv2
        import pysuperansac as sr

        n = len(u1)
        order = np.argsort(-np.asarray(scores, float), kind="stable")
        corr = np.ascontiguousarray(np.hstack([u1[order], u2[order]]), dtype=np.float64)
        cfg = sr.RANSACSettings()
        cfg.inlier_threshold = float(threshold_px)
        cfg.confidence = SUPERANSAC_CONFIDENCE
        cfg.max_iterations = SUPERANSAC_MAX_ITERATIONS
        cfg.sampler = sr.SamplerType.PROSAC
        cfg.scoring = sr.ScoringType.MAGSAC
        cfg.local_optimization = sr.LocalOptimizationType.NestedRANSAC
        cfg.final_optimization = sr.LocalOptimizationType.LSQ
        size = [2.0 * K1[0, 2] + 1, 2.0 * K1[1, 2] + 1, 2.0 * K2[0, 2] + 1, 2.0 * K2[1, 2] + 1]
        E, inl_idx, _, _ = sr.estimateEssentialMatrix(corr, K1, K2, size, [], config=cfg)
        inl = np.zeros(n, bool)
        idx = np.asarray(inl_idx, dtype=np.int64)
        if E is None or len(idx) < 5 or not np.all(np.isfinite(E)):
            return MethodOutput(None, None, inl, None)
        inl[order[idx]] = True

        def norm(u: np.ndarray, K: np.ndarray) -> np.ndarray:
            h = np.column_stack([u, np.ones(len(u))]) @ np.linalg.inv(K).T
            return np.ascontiguousarray(h[:, :2] / h[:, 2:])

        p1, p2 = norm(u1[inl], K1), norm(u2[inl], K2)
        _, R, t, _ = cv2.recoverPose(np.asarray(E, float), p1, p2, np.eye(3))
        t = np.asarray(t, float).ravel()
        return MethodOutput(np.asarray(R, float), t / max(float(np.linalg.norm(t)), 1e-300), inl, None)

    return run


METHODS: dict[str, MethodFn] = {
    # the default as the SIFT front-end calls it: the ratio test's 1 - ratio as match scores (PROSAC),
    # the keypoints' sizes as noise scales
    "poseonly": ours(use_scores=True, use_scales=True),
    "poseonly-noscale": ours(use_scores=True),
    # the sampling order by neighbour consistency first (poseonly.robust.consistency), the ratio scores breaking ties
    "poseonly-consistency": ours(use_scores=True, use_scales=True, consistency="always"),
    # the default before the consistency fallback (a search in the order of the ratio scores alone)
    "poseonly-noconsistency": ours(use_scores=True, use_scales=True, consistency="off"),
    "poseonly-noscores": ours(),
    "gnc-ransac": ours("gnc-ransac"),
    "poselib-1px": poselib(1.0),
    "poselib-2px": poselib(2.0),
    "opencv-magsac": opencv_magsac(1.0),
    "superansac": superansac(),
    # ablations of the default (issue 12's suspects); not run unless asked for with --methods
    "poseonly@1px": ours(threshold_px=1.0),
    # the default (scores, scales) at a 2 px threshold: for keypoints noisier than SIFT's (ORB; benchmarks/real_frontends.py)
    "poseonly-2px": ours(use_scores=True, use_scales=True, threshold_px=2.0),
    "poseonly-fixed-thr": ours(adaptive_threshold=False),
    "poseonly@1px-fixed-thr": ours(threshold_px=1.0, adaptive_threshold=False),
    "poseonly-no-refine": ours(refine=False),
    "poseonly-min1000": ours(min_iterations=1000, confidence=0.9999),  # PoseLib's min_iterations / success_prob
    # the sample floor: none (adaptive stopping only), and none with three all-inlier samples waited for
    "poseonly-min0": ours(use_scores=True, min_iterations=0),
    "poseonly-min0-hits3": ours(use_scores=True, min_iterations=0, min_hits=3),
    # variants of the core-era default (C++ search, ML refinement)
    "v-ml-2px": ours(final="ml", threshold_px=2.0),
    "v-ml-1px-1000": ours(final="ml", threshold_px=1.0, min_iterations=1000, confidence=0.9999),
    "v-ml-1px-1000-prosac": ours(use_scores=True, final="ml", threshold_px=1.0, min_iterations=1000, confidence=0.9999),
    "v-ml-1px-1000-slo": ours(final="ml", lo="sampson", threshold_px=1.0, min_iterations=1000, confidence=0.9999),
    "v-ml-1.5px-1000": ours(final="ml", threshold_px=1.5, min_iterations=1000, confidence=0.9999),
    "v-ligt-1px-1000": ours(final="ligt", threshold_px=1.0, min_iterations=1000, confidence=0.9999),
    # the ML stage's inlier errors Gaussian (MLESAC's mixture; the default before the Student-t)
    "poseonly-gauss": ours(use_scores=True, use_scales=True, ml_tails="gauss"),
    "poseonly-gauss-noscale": ours(use_scores=True, ml_tails="gauss"),
    # the search without its challengers (the default before the sixth session)
    "poseonly-nochal": ours(use_scores=True, use_scales=True, challengers=0),
    # the search scored by plain MSAC at tau instead of the multi-scale sum (tau, tau/2, tau/4)
    "poseonly-msac": ours(use_scores=True, use_scales=True, scoring="msac"),
    # the search's LO on its own score (the truncated quadratics of msac-multi) / on MSAC's at tau (PoseLib's LO)
    "poseonly-lomulti": ours(use_scores=True, use_scales=True, lo="sampson-multi"),
    "poseonly-lotruncated": ours(use_scores=True, use_scales=True, lo="sampson-truncated"),
    "poseonly-noscale-lomulti": ours(use_scores=True, lo="sampson-multi"),
    "poseonly-noscale-lotruncated": ours(use_scores=True, lo="sampson-truncated"),
    "poseonly-locm": ours(use_scores=True, use_scales=True, lo="sampson-cauchy-multi"),
    "poseonly-noscale-locm": ours(use_scores=True, lo="sampson-cauchy-multi"),
    "poseonly-loct": ours(use_scores=True, use_scales=True, lo="sampson-cauchy-truncated"),
    "poseonly-noscale-loct": ours(use_scores=True, lo="sampson-cauchy-truncated"),
    "poseonly-loauto": ours(use_scores=True, use_scales=True, lo="sampson-cauchy-auto"),
    "poseonly-noscale-loauto": ours(use_scores=True, lo="sampson-cauchy-auto"),
    "poseonly-cauchy": ours(use_scores=True, use_scales=True, final="cauchy"),
    # the ML stage's EM started from the least-squares refit of the matches within its range, or from both starts
    "poseonly-mlband": ours(use_scores=True, use_scales=True, ml_start="band"),
    "poseonly-mlboth": ours(use_scores=True, use_scales=True, ml_start="both"),
    # every match scored, also those sharing a keypoint with a better one (the default before the ninth session)
    "poseonly-nokp": ours(use_scores=True, use_scales=True, keypoint_once=False),
    # the ML stage deciding its own inliers (the default before the twelfth session), and other fold counts
    "poseonly-nofold": ours(use_scores=True, use_scales=True, ml_folds=0),
    "poseonly-folds2": ours(use_scores=True, use_scales=True, ml_folds=2),
    "poseonly-folds3": ours(use_scores=True, use_scales=True, ml_folds=3),
    "poseonly-folds10": ours(use_scores=True, use_scales=True, ml_folds=10),
    # the opt-in second search at 3 sigma (docs/RESULTS.md section 2)
    "poseonly-research": ours(use_scores=True, use_scales=True, research_noise=0.5),
    # the search also ended by PROSAC's stopping rule (progressive_stop, the default since the thirteenth
    # session), and without it (the classical rule alone)
    "poseonly-prosacstop": ours(use_scores=True, use_scales=True, progressive_stop=True),
    # the sample floor of 500 whatever the parallax (the default before the fourteenth session)
    "poseonly-floor500": ours(use_scores=True, use_scales=True, floor_parallax_deg=0.0),
    # the sample floor of the current default (min_iterations 500) measured again (fourteenth session)
    "poseonly-min200": ours(use_scores=True, use_scales=True, min_iterations=200),
    "poseonly-min100": ours(use_scores=True, use_scales=True, min_iterations=100),
    "poseonly-min50": ours(use_scores=True, use_scales=True, min_iterations=50),
    "poseonly-min0-scales": ours(use_scores=True, use_scales=True, min_iterations=0),
    "poseonly-noprosacstop": ours(use_scores=True, use_scales=True, progressive_stop=False),
    # the search ended where the expected all-inlier draws of the sampler's schedule reach the confidence
    # (progressive_rule="expected", fifteenth session) instead of by PROSAC's per-top-n rule
    "poseonly-expectedstop": ours(use_scores=True, use_scales=True, progressive_rule="expected"),
    # that rule in the consistency fallback's second stage only (fourth session of 2026-12-06, not adopted)
    "poseonly-consistencyexpected": ours(use_scores=True, use_scales=True, consistency_rule="expected"),
    "poseonly-remainder": ours(use_scores=True, use_scales=True, consistency_rule="expected", consistency_remainder=True),
    # a search that PROSAC's rule ended followed by one in the score order of the matches outside its band
    # (prosac_remainder, the default since the eleventh session of 2026-12-06), and the default before it
    "poseonly-prosacremainder": ours(use_scores=True, use_scales=True, prosac_remainder=True),
    "poseonly-noprosacremainder": ours(use_scores=True, use_scales=True, prosac_remainder=False),
    # the uniqueness test against the search's best rival alone (the default before the twelfth session
    # of 2026-12-06), and against every basin it kept (rivals=8, the default since)
    "poseonly-onerival": ours(use_scores=True, use_scales=True, rivals=1),
    "poseonly-allrivals": ours(use_scores=True, use_scales=True, rivals=8),
    # the default without its costliest extra stages for video-rate use (a SLAM user's trial, twelfth
    # session): no cross-fitted inliers, no challengers, a 100-sample floor
    "poseonly-lean": ours(use_scores=True, use_scales=True, ml_folds=0, challengers=0, min_iterations=100),
}
DEFAULT_METHODS = ("poseonly", "gnc-ransac", "poselib-1px", "poselib-2px", "opencv-magsac", "superansac")
# the library each method needs (a missing one skips the method with a note)
_REQUIRES = {"poselib-1px": "poselib", "poselib-2px": "poselib", "opencv-magsac": "cv2", "superansac": "pysuperansac"}


def available_methods(names: list[str] | None) -> tuple[list[str], list[str]]:
    """The requested method names (default: :data:`DEFAULT_METHODS`) whose libraries import, and notes
    on the others."""
    import importlib.util

    names = list(names or DEFAULT_METHODS)
    bad = [n for n in names if n not in METHODS]
    if bad:
        raise InputError(f"unknown method(s) {bad}; choose from {sorted(METHODS)}")
    keep, notes = [], []
    for n in names:
        lib = _REQUIRES.get(n)
        if lib and importlib.util.find_spec(lib) is None:
            notes.append(f"{n} skipped: {lib} is not installed")
        else:
            keep.append(n)
    if not keep:
        raise InputError("no method to run (all requested methods are unavailable)")
    return keep, notes


# ------------------------------------------------------------------------------------------------
# datasets


@dataclass(frozen=True)
class Pair:
    """One image pair with its ground truth: ``K1, K2 (3, 3)``, ``R (3, 3)``, unit ``t (3,)``
    (``X2 = R X1 + t``); ``kind`` is ``"realpairs"`` or ``"strecha"``."""

    dataset: str
    pid: str
    im1: Path
    im2: Path
    K1: np.ndarray
    K2: np.ndarray
    R: np.ndarray
    t: np.ndarray
    kind: str


def _unit(t: np.ndarray, what: str) -> np.ndarray:
    n = float(np.linalg.norm(t))
    if not np.isfinite(n) or n <= 0:
        raise InputError(f"{what}: the ground-truth translation must be a finite non-zero 3-vector")
    return t / n


def load_realpairs(folder: Path) -> list[Pair]:
    """Pairs of a realpairs dataset folder (``pairs.json``; see the module docstring)."""
    f = folder / "pairs.json"
    try:
        meta = json.loads(f.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise InputError(f"cannot read {f}: {exc}") from None
    if not isinstance(meta, dict):
        raise InputError(f"{f} must hold a JSON object with a 'pairs' list, got {type(meta).__name__}")
    name = str(meta.get("dataset") or folder.name)
    pairs = meta.get("pairs")
    if not isinstance(pairs, list) or not pairs:
        raise InputError(f"{f} holds no 'pairs' list")
    out = []
    for k, p in enumerate(pairs):
        where = f"{f} pair {k} ({p.get('id', '?') if isinstance(p, dict) else '?'})"
        try:
            K1 = check_intrinsics(np.asarray(p["K1"], float), "K1")
            K2 = check_intrinsics(np.asarray(p["K2"], float), "K2")
            R = np.asarray(p["R"], float).reshape(3, 3)
            t = _unit(np.asarray(p["t"], float).reshape(3), where)
            im1, im2 = folder / p["im1"], folder / p["im2"]
        except (KeyError, TypeError, ValueError) as exc:
            raise InputError(f"{where}: malformed entry ({type(exc).__name__}: {exc})") from None
        if abs(np.linalg.det(R) - 1) > 1e-3 or np.abs(R @ R.T - np.eye(3)).max() > 1e-3:
            raise InputError(f"{where}: R is not a rotation matrix")
        for im in (im1, im2):
            if not im.is_file():
                raise InputError(f"{where}: image not found: {im}")
        out.append(Pair(name, str(p.get("id", k)), im1, im2, K1, K2, R, t, "realpairs"))
    return out


def load_strecha(folder: Path) -> list[Pair]:
    """Every view pair ``i < j`` of a Strecha scene with :func:`poseonly.io.strecha.relative_pose`."""
    from ..io.strecha import load_scene, relative_pose

    sc = load_scene(folder)
    out = []
    for i in range(len(sc)):
        for j in range(i + 1, len(sc)):
            R, t, _ = relative_pose(sc, i, j)
            out.append(Pair(sc.name, f"{i}-{j}", sc.image_paths[i], sc.image_paths[j], sc.K, sc.K, R, t, "strecha"))
    return out


def load_datasets(dirs: list[str | Path]) -> dict[str, list[Pair]]:
    """``{dataset name: pairs}`` for realpairs folders, Strecha scene folders and folders of scenes."""
    from ..io.strecha import find_scenes

    out: dict[str, list[Pair]] = {}
    for d in dirs:
        p = Path(d)
        if not p.is_dir():
            raise InputError(f"dataset folder not found: {p}")
        if (p / "pairs.json").is_file():
            groups = [load_realpairs(p)]
        else:
            scenes = find_scenes(p)
            if not scenes:
                raise InputError(f"{p} is neither a realpairs folder (pairs.json) nor holds Strecha scenes (images/ + gt_dense_cameras/)")
            groups = [load_strecha(s) for s in scenes]
        for g in groups:
            name = g[0].dataset
            if name in out:
                raise InputError(f"dataset {name!r} given twice")
            out[name] = g
    return out


# ------------------------------------------------------------------------------------------------
# matches (computed once, cached)


def _match_cache_file(cache: Path, p1: Path, p2: Path) -> Path:
    key: dict[str, Any] = {"v": _CACHE_VERSION, "ratio": RATIO, "detector": "sift"}
    for k, p in (("a", p1), ("b", p2)):
        st = p.stat()
        key[k] = [str(p.resolve()), st.st_size, st.st_mtime_ns]
    h = hashlib.sha256(json.dumps(key, sort_keys=True).encode()).hexdigest()[:32]
    return cache / "matches" / f"ratio_{h}.npz"


def ratio_matches(d1: np.ndarray, d2: np.ndarray, ratio: float = RATIO) -> tuple[np.ndarray, np.ndarray]:
    """Lowe ratio matching of descriptors ``(m1, D)``, ``(m2, D)``: index pairs ``(k, 2)`` and the
    ratio ``d1 / d2 (k,)`` of every match (same rule as :func:`poseonly.features.match_features`)."""
    import cv2

    if len(d1) == 0 or len(d2) < 2:
        return np.zeros((0, 2), np.int64), np.zeros(0)
    dist, nn = cv2.batchDistance(np.ascontiguousarray(d1, np.float32), np.ascontiguousarray(d2, np.float32), cv2.CV_32F, normType=cv2.NORM_L2, K=2)
    keep = dist[:, 0] < ratio * dist[:, 1]
    i1 = np.flatnonzero(keep)
    r = dist[keep, 0].astype(np.float64) / np.maximum(dist[keep, 1].astype(np.float64), 1e-30)
    return np.stack([i1, nn[keep, 0].astype(np.int64)], axis=1), r


def _read_match_cache(f: Path) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray] | None:
    """Cached ``(u1, u2, ratio, noise_scales)``; ``None`` when absent, unreadable or inconsistent (recomputed)."""
    if not f.is_file():
        return None
    try:
        with np.load(f, allow_pickle=False) as z:
            u1, u2, r = np.asarray(z["u1"], float), np.asarray(z["u2"], float), np.asarray(z["ratio"], float)
            sc = np.asarray(z["noise_scales"], float)
    except Exception:  # noqa: BLE001 - any unreadable cache file is recomputed
        return None
    if u1.ndim == 2 and u1.shape[1:] == (2,) and u1.shape == u2.shape and r.shape == (len(u1),) and sc.shape == r.shape:
        return u1, u2, r, sc
    return None


def pair_match_data(pair: Pair, cache: Path) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``u1, u2 (k, 2)`` pixels, ``ratio (k,)`` and ``noise_scales (k,)`` (``sqrt(size1 size2)`` of
    the keypoints) of the pair's SIFT matches (cached)."""
    from .._fileutil import atomic_savez
    from ..features import extract_features, match_noise_scales

    f = _match_cache_file(cache, pair.im1, pair.im2)
    hit = _read_match_cache(f)
    if hit is not None:
        return hit
    a = extract_features(pair.im1, cache_dir=cache)
    b = extract_features(pair.im2, cache_dir=cache)
    idx, r = ratio_matches(a.descriptors, b.descriptors)
    u1 = a.keypoints[idx[:, 0]].reshape(-1, 2)
    u2 = b.keypoints[idx[:, 1]].reshape(-1, 2)
    sc = match_noise_scales(a, b, idx)
    sc = np.ones(len(idx)) if sc is None else sc
    atomic_savez(f, u1=u1, u2=u2, ratio=r, noise_scales=sc)
    return u1, u2, r, sc


def pair_matches(pair: Pair, cache: Path) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``u1, u2 (k, 2)`` pixels and ``ratio (k,)`` of the pair's SIFT matches (cached)."""
    u1, u2, r, _ = pair_match_data(pair, cache)
    return u1, u2, r


# ------------------------------------------------------------------------------------------------
# running


def _errors(pair: Pair, o: MethodOutput) -> tuple[float, float]:
    if o.R is None or o.t is None or not np.all(np.isfinite(o.R)):
        return float("inf"), float("inf")
    er = float(rotation_error_deg(pair.R, o.R))
    et = float(translation_error_deg(pair.t, o.t))
    return er, min(et, 180.0 - et)  # SuperGlue: the sign of t is not scored


def run_pair(pair: Pair, u1: np.ndarray, u2: np.ndarray, ratio: np.ndarray, methods: list[str], seeds: int, noise_scales: np.ndarray | None = None) -> dict:
    """Per-method, per-seed results of one pair: ``{method: [{"R_err", "t_err", "status", ...}]}``."""
    from ..features import sampson_error_px

    n = len(u1)
    gt = int(np.count_nonzero(sampson_error_px(u1, u2, pair.K1, pair.K2, pair.R, pair.t) < GT_PX)) if n else 0
    rec: dict[str, Any] = {"dataset": pair.dataset, "id": pair.pid, "im1": pair.im1.name, "im2": pair.im2.name, "matches": n, "gt_matches": gt, "methods": {}}
    scores = 1.0 - ratio
    for m in methods:
        runs = []
        for s in range(seeds):
            if n < MIN_SOLVE:
                runs.append({"R_err": None, "t_err": None, "status": "too_few_matches", "inliers": 0, "time_s": 0.0})
                continue
            t0 = time.perf_counter()
            try:
                o = METHODS[m](u1, u2, pair.K1, pair.K2, scores, s, noise_scales)
                err = None
            except (ValueError, np.linalg.LinAlgError) as exc:  # a method refusing the input is a failure
                o, err = MethodOutput(None, None, np.zeros(n, bool), "failed"), f"{type(exc).__name__}: {exc}"
            dt = time.perf_counter() - t0
            er, et = _errors(pair, o)
            d = {"R_err": er if np.isfinite(er) else None, "t_err": et if np.isfinite(et) else None, "status": o.status, "inliers": int(np.count_nonzero(o.inliers)), "time_s": dt}
            if err:
                d["error"] = err
            runs.append(d)
        rec["methods"][m] = runs
    return rec


def warm_up(plan: list[Pair], matches: list[tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]], methods: list[str]) -> None:
    """One untimed call of every method on the first pair with enough matches, so that imports and
    first-call costs are not charged to the first timed pair."""
    for p, (u1, u2, r, sc) in zip(plan, matches):
        if len(u1) > MIN_MATCHES:
            for m in methods:
                try:
                    METHODS[m](u1, u2, p.K1, p.K2, 1.0 - r, 0, sc)
                except (ValueError, np.linalg.LinAlgError):
                    pass
            return


def compute(dirs: list[str | Path], *, methods: list[str] | None = None, seeds: int = 1, cache: str | Path, max_pairs: int | None = None) -> dict:
    """Run the benchmark; returns ``{"config", "methods", "notes", "pairs", "summary", ...}``."""
    if seeds < 1:
        raise InputError(f"--seeds must be >= 1, got {seeds}")
    if max_pairs is not None and max_pairs < 1:
        raise InputError(f"--max-pairs must be >= 1, got {max_pairs}")
    ms, notes = available_methods(methods)
    data = load_datasets(dirs)
    cache = Path(cache)
    single_thread()
    plan = [p for pairs in data.values() for p in pairs[: max_pairs or None]]
    t_start = time.perf_counter()
    matches = [pair_match_data(p, cache) for p in progress(plan, total=len(plan), desc="matching")]
    t_match = time.perf_counter() - t_start
    warm_up(plan, matches, ms)
    records = [run_pair(p, mt[0], mt[1], mt[2], ms, seeds, mt[3]) for p, mt in progress(zip(plan, matches), total=len(plan), desc="real pairs")]
    res = {
        "config": {
            "dirs": [str(d) for d in dirs],
            "datasets": {k: v[0].kind for k, v in data.items()},
            "seeds": seeds,
            "max_pairs": max_pairs,
            "ratio": RATIO,
            "min_matches": MIN_MATCHES,
            "gt_px": GT_PX,
            "gt_min": GT_MIN,
            "wrong_deg": WRONG_DEG,
            "good_deg": GOOD_DEG,
            "reference": REFERENCE,
            "cache": str(cache),
            "superansac_threshold_px": SUPERANSAC_THRESHOLD_PX,
        },
        "methods": ms,
        "notes": notes,
        "time_total_s": time.perf_counter() - t_start,
        "time_matching_s": t_match,
        "machine": machine(),
        "code_version": code_version(),
        "pairs": records,
    }
    res["summary"] = summarize(res)
    return res


# ------------------------------------------------------------------------------------------------
# metrics


def pose_auc(errors: np.ndarray, thresholds: tuple[float, ...] = AUC_DEG) -> list[float]:
    """SuperGlue's ``pose_auc``: area under the recall-vs-error curve up to each threshold, divided by
    it (percent); ``errors (n,)`` in degrees, ``inf`` for a failed pair."""
    e = np.sort(np.asarray(errors, float))
    if e.size == 0:
        return [float("nan")] * len(thresholds)
    recall = (np.arange(len(e)) + 1) / len(e)
    e = np.r_[0.0, e]
    recall = np.r_[0.0, recall]
    out = []
    for thr in thresholds:
        last = int(np.searchsorted(e, thr))
        r = np.r_[recall[:last], recall[last - 1]]
        x = np.r_[e[:last], thr]
        out.append(float(100.0 * np.trapezoid(r, x=x) / thr))
    return out


def _arr(recs: list[dict], m: str, key: str, seed: int = 0) -> np.ndarray:
    v = [r["methods"][m][seed][key] for r in recs]
    return np.array([np.inf if x is None else x for x in v], float)


def _method_stats(recs: list[dict], m: str, seeds: int, ref: str | None) -> dict:
    er, et = _arr(recs, m, "R_err"), _arr(recs, m, "t_err")
    tt = _arr(recs, m, "time_s")
    fin = np.isfinite(er)
    status = [r["methods"][m][0]["status"] for r in recs]
    has_status = any(s is not None for s in status)
    ok = np.array([s == "ok" for s in status])
    d: dict[str, Any] = {
        "pairs": len(recs),
        "failed": int(np.count_nonzero(~fin)),
        "median_R_err": float(np.median(er)) if len(er) else float("nan"),
        "mean_R_err": float(np.mean(er[fin])) if fin.any() else float("nan"),
        "median_t_err": float(np.median(et)) if len(et) else float("nan"),
        "mean_t_err": float(np.mean(et[np.isfinite(et)])) if np.isfinite(et).any() else float("nan"),
        "auc": dict(zip([f"{a:g}" for a in AUC_DEG], pose_auc(np.maximum(er, et)))),
        "median_time_ms": float(1e3 * np.median(tt)) if len(tt) else float("nan"),
        "mean_time_ms": float(1e3 * np.mean(tt)) if len(tt) else float("nan"),
    }
    if seeds > 1:
        a10 = [pose_auc(np.maximum(_arr(recs, m, "R_err", s), _arr(recs, m, "t_err", s)), (10.0,))[0] for s in range(seeds)]
        d["auc10_seeds"] = a10
        d["auc10_mean"], d["auc10_std"] = float(np.mean(a10)), float(np.std(a10))
        d["auc10_range"] = float(np.max(a10) - np.min(a10))
    if has_status:
        wrong = ok & ~(er <= WRONG_DEG)  # inf (no pose) counts as wrong when `ok`
        d["ok"] = int(np.count_nonzero(ok))
        d["ok_wrong"] = int(np.count_nonzero(wrong))
        n_ok = int(np.count_nonzero(ok))
        d["ok_wrong_pct"] = 100.0 * int(np.count_nonzero(wrong)) / max(1, n_ok)
        if ref is not None:
            ref_good = _arr(recs, ref, "R_err") <= GOOD_DEG
            d["ref_good"] = int(np.count_nonzero(ref_good))
            d["ref_good_not_ok"] = int(np.count_nonzero(ref_good & ~ok))
            d["good_not_ok"] = int(np.count_nonzero(ref_good & (er <= GOOD_DEG) & ~ok))
    return d


def _subsets(kind: str) -> dict[str, Callable[[dict], bool]]:
    if kind == "strecha":
        return {"overlap": lambda r: r["matches"] > MIN_MATCHES and r["gt_matches"] >= GT_MIN, "all": lambda r: r["matches"] > MIN_MATCHES}
    return {"all": lambda r: True}


def summarize(res: dict) -> dict:
    """``{dataset: {subset: {method: stats}}}``; time ratios to :data:`REFERENCE` in the same run."""
    ms = res["methods"]
    seeds = res["config"]["seeds"]
    ref = REFERENCE if REFERENCE in ms else None
    out: dict[str, Any] = {}
    for ds, kind in res["config"]["datasets"].items():
        out[ds] = {}
        for sub, pred in _subsets(kind).items():
            recs = [r for r in res["pairs"] if r["dataset"] == ds and pred(r)]
            if not recs:
                continue
            st = {m: _method_stats(recs, m, seeds, ref) for m in ms}
            if ref:
                for m in ms:
                    st[m]["median_time_ratio"] = st[m]["median_time_ms"] / st[ref]["median_time_ms"]
                    st[m]["mean_time_ratio"] = st[m]["mean_time_ms"] / st[ref]["mean_time_ms"]
            out[ds][sub] = st
    return out


# ------------------------------------------------------------------------------------------------
# outputs


_SUBSET_TITLE = {
    "overlap": f"overlapping pairs (>= {GT_MIN} matches within {GT_PX:g} px Sampson of the GT epipolar geometry)",
    "all": "all pairs",
}


def overview_markdown(res: dict) -> str:
    """One row per dataset (Strecha: overlapping pairs) and method: the headline numbers."""
    ms, S = res["methods"], res["summary"]
    header = ["dataset", "pairs", "method", "med / mean R err", "AUC@5 / @10 / @20", "med time x", "ok>5", "good-not-ok", "ref-good-not-ok"]
    rows = []
    for ds, subs in S.items():
        sub = "overlap" if "overlap" in subs else "all"
        st = subs[sub]
        for m in ms:
            s = st[m]
            a = s["auc"]
            rows.append(
                [
                    ds if sub == "all" else f"{ds} (overlap)",
                    s["pairs"],
                    m,
                    f"{s['median_R_err']:.3f} / {s['mean_R_err']:.3f}",
                    f"{a['5']:.1f} / {a['10']:.1f} / {a['20']:.1f}",
                    f"{s['median_time_ratio']:.2f}" if "median_time_ratio" in s else "-",
                    f"{s['ok_wrong']} / {s['ok']}" if "ok" in s else "-",
                    s.get("good_not_ok", "-"),
                    f"{s['ref_good_not_ok']} / {s['ref_good']}" if "ref_good" in s else "-",
                ]
            )
    return markdown_table(header, rows)


def to_markdown(res: dict, command: str | None = None) -> str:
    """The report: an overview, then one accuracy/time table and one status table per dataset and pair set."""
    ms, S, cfg = res["methods"], res["summary"], res["config"]
    lines = ["# Real-data benchmark (issue 12)", ""]
    if command:
        lines += ["Command:", "", "```bash", command, "```", ""]
    lines += [
        f"SIFT (OpenCV, full resolution) + Lowe ratio {cfg['ratio']}, identical matches for every method. "
        f"Seeds 0..{cfg['seeds'] - 1} (tables: seed 0)"
        + (f"; at most {cfg['max_pairs']} pairs per dataset" if cfg["max_pairs"] else "")
        + ". Errors in degrees; t err = angle between translation directions, sign ignored (SuperGlue). "
        "AUC of max(R err, t err), a pair without a pose counts as an infinite error (its mean errors exclude it). "
        f"Time = the estimator call, BLAS/OpenCV on one thread, **measured under load** on a shared machine; "
        f"ratios are to {REFERENCE} in the same run. Status: ok>5 = `ok` poses with R err > {WRONG_DEG:g} deg; "
        f"good-not-ok = pairs where this pose and {REFERENCE}'s are within {GOOD_DEG:g} deg yet not `ok`; "
        f"ref-good-not-ok = pairs where {REFERENCE} is within {GOOD_DEG:g} deg and this method is not `ok`. "
        f"SupeRANSAC: its authors' E settings (PROSAC by 1 - ratio, MAGSAC, nested-RANSAC LO, LSQ, conf 1-1e-7, "
        f"5000 iterations) at {cfg['superansac_threshold_px']:g} px.",
        "",
        f"Machine: {res['machine']}"
        + (f"; code `{res['code_version']}`" if res.get("code_version") else "")
        + f". Total {res['time_total_s']:.0f} s (matching {res['time_matching_s']:.0f} s, cached pairs excluded).",
        "",
    ]
    lines += [f"Note: {n}." for n in res["notes"]]
    lines += ["", "## Overview (seed 0; Strecha: overlapping pairs; ok>5 = wrong `ok` poses / `ok` poses)", "", overview_markdown(res)]
    for ds, subs in S.items():
        for sub, st in subs.items():
            n = st[ms[0]]["pairs"]
            lines += ["", f"## {ds}: {_SUBSET_TITLE[sub]}, {n} pairs", ""]
            header = ["method", "med R", "mean R", "med t", "mean t", "AUC@5", "AUC@10", "AUC@20", "failed", "med ms", "mean ms", "med x", "mean x"]
            if cfg["seeds"] > 1:
                header.append(f"AUC@10 over {cfg['seeds']} seeds")
            rows = []
            for m in ms:
                s = st[m]
                row = [
                    m,
                    s["median_R_err"],
                    s["mean_R_err"],
                    s["median_t_err"],
                    s["mean_t_err"],
                    f"{s['auc']['5']:.1f}",
                    f"{s['auc']['10']:.1f}",
                    f"{s['auc']['20']:.1f}",
                    s["failed"],
                    s["median_time_ms"],
                    s["mean_time_ms"],
                    s.get("median_time_ratio", float("nan")),
                    s.get("mean_time_ratio", float("nan")),
                ]
                if cfg["seeds"] > 1:
                    row.append(f"{s['auc10_mean']:.1f} +- {s['auc10_std']:.2f} (range {s['auc10_range']:.2f})")
                rows.append(row)
            lines.append(markdown_table(header, rows))
            srows = [
                [
                    m,
                    st[m]["ok"],
                    f"{st[m]['ok_wrong']} ({st[m]['ok_wrong_pct']:.1f} %)",
                    st[m].get("good_not_ok", "-"),
                    f"{st[m].get('ref_good_not_ok', '-')} / {st[m].get('ref_good', '-')}",
                ]
                for m in ms
                if "ok" in st[m]
            ]
            if srows:
                lines += ["", markdown_table(["method", "ok", "ok>5", "good-not-ok", "ref-good-not-ok / ref-good"], srows)]
    return "\n".join(lines) + "\n"


def figure(res: dict, path: Path) -> Path | None:
    """Cumulative curves of max(R err, t err) (seed 0, 0.01-20 deg on a log axis), one panel per
    dataset and pair set."""
    plt = pyplot()
    if plt is None:
        return None
    panels = [(ds, sub) for ds, subs in res["summary"].items() for sub in subs]
    if not panels:
        return None
    cols = min(3, len(panels))
    rows = (len(panels) + cols - 1) // cols
    fig, axs = plt.subplots(rows, cols, figsize=(5.2 * cols, 3.8 * rows), squeeze=False)
    x = np.logspace(-2, np.log10(20.0), 400)  # log axis: Strecha's errors are ~0.05 deg, temple's ~1 deg
    for a, (ds, sub) in zip(axs.ravel(), panels):
        pred = _subsets(res["config"]["datasets"][ds])[sub]
        recs = [r for r in res["pairs"] if r["dataset"] == ds and pred(r)]
        for m in res["methods"]:
            e = np.maximum(_arr(recs, m, "R_err"), _arr(recs, m, "t_err"))
            a.plot(x, 100 * np.mean(e[None, :] <= x[:, None], axis=1), label=m, lw=1.4 if m.startswith("poseonly") else 1.0)
        a.set_title(f"{ds}: {sub} ({len(recs)} pairs)", fontsize=9)
        a.set_xscale("log")
        a.set_xlabel("max(R err, t err) (deg, log)")
        a.set_ylabel("pairs (%)")
        a.grid(alpha=0.3)
    for a in axs.ravel()[len(panels) :]:
        a.axis("off")
    axs[0, 0].legend(fontsize=7)
    fig.tight_layout()
    savefig(fig, path)
    plt.close(fig)
    return path


# ------------------------------------------------------------------------------------------------
# diagnosis of the pairs the default loses

FAR_PX = 3.0  # an inlier farther than this (Sampson, px) from the GT epipolar geometry is a wrong one
MSAC_PX = 1.0  # truncation of the MSAC cost used to compare poses


def _msac_cost(u1: np.ndarray, u2: np.ndarray, p: Pair, R: np.ndarray, t: np.ndarray, thr: float = MSAC_PX) -> float:
    """Truncated quadratic cost ``sum min(e^2, thr^2)`` of the Sampson distances (px) of all matches."""
    from ..features import sampson_error_px

    e = sampson_error_px(u1, u2, p.K1, p.K2, R, t)
    return float(np.sum(np.minimum(e * e, thr * thr)))


def _poselib_iterations(u1: np.ndarray, u2: np.ndarray, p: Pair) -> int:
    """RANSAC iterations PoseLib (1 px, seed 0) runs on the pair (``info["iterations"]``)."""
    import poselib as pl

    def cam(K: np.ndarray) -> dict:
        return {"model": "PINHOLE", "width": int(2 * K[0, 2] + 1), "height": int(2 * K[1, 2] + 1), "params": [float(K[0, 0]), float(K[1, 1]), float(K[0, 2]), float(K[1, 2])]}

    _, info = pl.estimate_relative_pose(u1, u2, cam(p.K1), cam(p.K2), {"max_epipolar_error": 1.0, "seed": 0}, {})
    return int(info["iterations"])


def diagnose(res: dict, cache: Path, n_worst: int = 8, method: str = "poseonly", seeds: int = 4, datasets: list[str] | None = None, overlap_only: bool = False) -> list[dict]:
    """Re-run the ``n_worst`` pairs where ``method`` loses most to :data:`REFERENCE` (rotation error
    difference, seed 0) and report for each: the default's final (noise-matched) threshold and inliers,
    its inliers farther than ``FAR_PX`` from the GT geometry against the reference's, the MSAC cost at
    ``MSAC_PX`` of both poses and of the truth, the rotation error over ``seeds`` seeds, and the errors
    of the ablations (1 px threshold, fixed threshold, no refinement). ``datasets`` restricts the
    candidates to those datasets, ``overlap_only`` to pairs with at least ``GT_MIN`` GT-consistent matches."""
    from ..anchors import poselib_relpose
    from ..api import estimate_relative_pose
    from ..features import sampson_error_px

    pairs = {(p.dataset, p.pid): p for d in load_datasets(res["config"]["dirs"]).values() for p in d}

    def loss(r: dict) -> float:
        a, b = r["methods"][method][0]["R_err"], r["methods"][REFERENCE][0]["R_err"]
        a = 180.0 if a is None else a
        b = 180.0 if b is None else b
        return a - b

    cand = [r for r in res["pairs"] if r["matches"] >= MIN_SOLVE and (not datasets or r["dataset"] in datasets) and (not overlap_only or r["gt_matches"] >= GT_MIN)]
    recs = sorted(cand, key=loss, reverse=True)[:n_worst]
    out = []
    for r in recs:
        p = pairs[(r["dataset"], r["id"])]
        u1, u2, ratio, scales = pair_match_data(p, cache)
        front: dict[str, Any] = {"scores": 1.0 - ratio, "noise_scales": scales}  # as the bench's "poseonly" runs
        e_gt = sampson_error_px(u1, u2, p.K1, p.K2, p.R, p.t)
        o = estimate_relative_pose(u1, u2, p.K1, p.K2, seed=0, **front)
        Ro, to = cast(np.ndarray, o.R), cast(np.ndarray, o.t)  # None only for status "degenerate"
        Rp, tp, inlp, _ = poselib_relpose(u1, u2, p.K1, p.K2, threshold_px=1.0, seed=0)
        d: dict[str, Any] = {
            "dataset": p.dataset,
            "id": p.pid,
            "matches": len(u1),
            "gt_1px": int(np.count_nonzero(e_gt < GT_PX)),
            "R_err": float(rotation_error_deg(p.R, Ro)),
            "status": o.status,
            "final_thr_px": float(o.threshold_px),
            "inliers": int(o.num_inliers),
            "inliers_far": int(np.count_nonzero(o.inliers & (e_gt > FAR_PX))),
            "msac": _msac_cost(u1, u2, p, Ro, to),
            "msac_gt": _msac_cost(u1, u2, p, p.R, p.t),
            "iterations": int(o.num_iterations),
            "ref_iterations": _poselib_iterations(u1, u2, p),
        }
        if Rp is not None and tp is not None:  # (None together: a failed call)
            d.update(
                ref_R_err=float(rotation_error_deg(p.R, Rp)),
                ref_inliers=int(np.count_nonzero(inlp)),
                ref_inliers_far=int(np.count_nonzero(inlp & (e_gt > FAR_PX))),
                ref_msac=_msac_cost(u1, u2, p, Rp, tp),
            )
        d["R_err_seeds"] = [float(rotation_error_deg(p.R, cast(np.ndarray, estimate_relative_pose(u1, u2, p.K1, p.K2, seed=s, **front).R))) for s in range(seeds)]
        for name, opts in (
            ("@1px", {"threshold_px": 1.0}),
            ("fixed-thr", {"adaptive_threshold": False}),
            ("no-refine", {"refine": False}),
            ("min1000", {"min_iterations": 1000, "confidence": 0.9999}),
        ):
            d[f"R_err_{name}"] = float(rotation_error_deg(p.R, cast(np.ndarray, estimate_relative_pose(u1, u2, p.K1, p.K2, seed=0, **front, **opts).R)))
        out.append(d)
    return out


def diagnosis_markdown(diag: list[dict]) -> str:
    """Table of :func:`diagnose`."""
    header = [
        "dataset",
        "pair",
        "matches",
        "GT<1px",
        "R err",
        "status",
        "final thr px",
        "inliers",
        f"far>{FAR_PX:g}px",
        f"MSAC@{MSAC_PX:g}",
        "MSAC GT",
        "PL R err",
        "PL inliers",
        "PL far",
        "PL MSAC",
        "R err seeds 0-3",
        "@1px",
        "fixed thr",
        "no refine",
        "min1000",
        "iters",
        "PL iters",
    ]
    rows = [
        [
            d["dataset"],
            d["id"],
            d["matches"],
            d["gt_1px"],
            d["R_err"],
            d["status"],
            d["final_thr_px"],
            d["inliers"],
            d["inliers_far"],
            d["msac"],
            d["msac_gt"],
            d.get("ref_R_err", float("nan")),
            d.get("ref_inliers", "-"),
            d.get("ref_inliers_far", "-"),
            d.get("ref_msac", float("nan")),
            " / ".join(f"{e:.3g}" for e in d["R_err_seeds"]),
            d["R_err_@1px"],
            d["R_err_fixed-thr"],
            d["R_err_no-refine"],
            d["R_err_min1000"],
            d["iterations"],
            d["ref_iterations"],
        ]
        for d in diag
    ]
    return (
        "# Pairs where the default loses most to PoseLib (1 px), seed 0\n\n"
        f"R errors in degrees. far = inliers more than {FAR_PX:g} px (Sampson) from the GT epipolar geometry; "
        f"MSAC@{MSAC_PX:g} = sum over all matches of min(e^2, {MSAC_PX:g}) (px^2) of the pose (lower is better); "
        "@1px / fixed thr / no refine / min1000 = the default with threshold_px=1, adaptive_threshold=False, "
        "refine=False, min_iterations=1000 + confidence=0.9999; "
        "iters = RANSAC iterations of the default and of PoseLib (1 px, seed 0).\n\n" + markdown_table(header, rows)
    )


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="poseonly bench real", description=__doc__.split("\n\n")[0])
    p.add_argument("dirs", nargs="*", metavar="DIR", help="realpairs dataset folders and/or Strecha scene folders")
    p.add_argument("--seeds", type=int, default=1, help="run seeds 0..K-1 (AUC@10 spread; default 1)")
    p.add_argument("--methods", nargs="+", metavar="METHOD", help=f"default: {' '.join(DEFAULT_METHODS)}; registered: {' '.join(METHODS)}")
    p.add_argument("--out", default=None, help="output folder (default: a new folder poseonly-real-<date>-<time> under the working directory)")
    p.add_argument("--cache", help="feature/match cache folder (default <out>/cache)")
    p.add_argument("--max-pairs", type=int, help="at most N pairs per dataset, in file order")
    p.add_argument("--diagnose", type=int, metavar="N", default=0, help="also re-run the N pairs where the default loses most to PoseLib and write real_bench_diagnosis.md")
    p.add_argument("--diagnose-datasets", nargs="+", metavar="NAME", help="diagnose only pairs of these datasets")
    p.add_argument("--diagnose-overlap", action="store_true", help=f"diagnose only pairs with >= {GT_MIN} matches within {GT_PX:g} px of the GT geometry")
    p.add_argument("--diagnose-name", default="real_bench_diagnosis", help="file name (no suffix) of the diagnosis")
    p.add_argument("--from-json", metavar="PATH", help="skip the run: read the results of an earlier run and re-render its report (or, with --diagnose, diagnose its losing pairs)")
    return p


def _check_stored(res: Any, path: str) -> dict:
    """An earlier run's results as :func:`compute` returns them (the keys the report reads)."""
    keys = ("methods", "summary", "config", "pairs")
    if not isinstance(res, dict) or any(k not in res for k in keys):
        raise InputError(f"{path} is not the real_bench.json of a run (needs the keys {list(keys)})")
    return res


def _check_diagnose(n: int, methods: list[str]) -> None:
    """``--diagnose N`` compares the default with the reference: both must have run."""
    if n < 0:
        raise InputError(f"--diagnose must be >= 0 (pairs to diagnose), got {n}")
    missing = [m for m in ("poseonly", REFERENCE) if m not in methods]
    if n and missing:
        raise InputError(f"--diagnose compares poseonly with {REFERENCE}: the run lacks {missing}")


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    if args.diagnose and not args.from_json:
        _check_diagnose(args.diagnose, list(args.methods or DEFAULT_METHODS))
    if args.out and Path(args.out).exists() and not Path(args.out).is_dir():
        raise InputError(f"--out {args.out}: is a file; give a folder")
    out = Path(args.out) if args.out else new_results_dir("real")
    cache = Path(args.cache) if args.cache else out / "cache"
    cmd = "poseonly bench real " + " ".join(argv if argv is not None else sys.argv[1:])
    if args.from_json:
        try:
            res = json.loads(Path(args.from_json).read_text(encoding="utf-8"))
        except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
            raise InputError(f"cannot read {args.from_json}: {exc}") from None
        res = _check_stored(res, args.from_json)
        _check_diagnose(args.diagnose, list(res["methods"]))
        if args.diagnose:
            single_thread()
            diag = diagnose(res, cache, args.diagnose, datasets=args.diagnose_datasets, overlap_only=args.diagnose_overlap)
            md = diagnosis_markdown(diag) + f"\nCommand: `{cmd}`\n"
            atomic_write_text(out / f"{args.diagnose_name}.md", md)
            print(md)
        else:  # re-render the report and the figure from the stored results
            md = to_markdown(res, res.get("command"))
            atomic_write_text(out / "real_bench.md", md)
            figure(res, out / "real_bench.png")
            print(md)
        return 0
    if not args.dirs:
        raise InputError("give at least one dataset folder (DIR), or --from-json PATH")
    res = compute(args.dirs, methods=args.methods, seeds=args.seeds, cache=cache, max_pairs=args.max_pairs)
    res["command"] = cmd
    md = to_markdown(res, cmd)
    atomic_write_text(out / "real_bench.md", md)
    write_json(out / "real_bench.json", strict_json(res))
    figure(res, out / "real_bench.png")
    print(md)
    if args.diagnose:
        _check_diagnose(args.diagnose, list(res["methods"]))  # a method may have been unavailable
        diag = diagnose(res, cache, args.diagnose, datasets=args.diagnose_datasets, overlap_only=args.diagnose_overlap)
        dmd = diagnosis_markdown(diag) + f"\nCommand: `{cmd}`\n"
        atomic_write_text(out / f"{args.diagnose_name}.md", dmd)
        print(dmd)
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
