"""GNC-RANSAC vs the state of the art (paper Section 7.1.3, Fig. "accuracy of the GNC-RANSAC fusion
scheme"): n = 300, 1 px noise, outlier fractions 0-80 %, normal and planar scenes.

Methods (one call per scene each; time = wall clock of the call, single-threaded BLAS/OpenCV):

* ``GNC-RANSAC``: the paper's Algorithm 3 as written, ``estimate_relative_pose(f1, f2,
  method="gnc-ransac", refine=False, focal_px=800, seed=...)`` (n_s = 30, 50 iterations, MS-TLS with
  the adaptive median bound, inliers ``v_LiGT < 2 px / 800``);
* ``GNC-RANSAC + LiGTopt``: the same with ``refine=True`` (the paper's solid "LiGTopt" line);
* ``poseonly (default)``: ``method="poseonly"`` (LO-RANSAC of LiRP samples + GNC-IRLS LO + LiGTopt);
* ``RANSAC+5pt (OpenGV)`` and ``+ OpenGV nonlinear``: :mod:`poseonly.experiments.opengv_ransac`
  (OpenGV's test defaults: 50 iterations, p = 0.99, its bearing-vector threshold);
* anchors on the pixel coordinates ``sc.u1, sc.u2`` with ``sc.K`` and a 1 px threshold
  (:data:`poseonly.anchors.ANCHORS`): OpenCV ``findEssentialMat`` RANSAC with ``maxIters=50`` and
  with its default (1000), OpenCV ``USAC_MAGSAC``, PoseLib with ``max_iterations=50`` and default;
* ``noise floor``: LiRP + LiGTopt on the true inliers.

Scenes are the paper's wide OpenGV-style ones (``make_scene(n, kind, "wide", 1.0, frac, seed)``),
not a 640x480 pinhole camera. Every bearing has ``z > 0`` in its own view (the chirality filter;
outliers are drawn in front of camera 2), so its pixel coordinates ``K f / f_z`` are a valid
pinhole projection -- but far outside a real image (up to ~1e5 px for rays near 90 deg) and with
the angular noise magnified by ``1 / cos^2`` of the off-axis angle in the pixel plane. A fixed
1 px threshold therefore rejects many true inliers far from the axis: the anchors are measured
on an unusual camera, which favours the bearing-vector methods. This is stated, not corrected.

Planar scenes are also scored against the **nearer of the truth and its homography twin**. The twin
(:func:`planar_twin`) is the best *other* candidate of :func:`poseonly.lirp` on the noise-free
bearings of the true 3-D points: a LiRP candidate that passes the pose-only depth conditions,
whose rotation differs from the truth by more than 0.5 deg and whose mean PPO residual on the
noise-free data is below 1e-6 (an exact second solution); the one with the smallest PPO residual.
When no such candidate exists, the scene has no twin and is scored against the truth only. In
these wide-angle planar scenes such a twin exists only rarely (a few % of the scenes): over all
points the homography twin puts some points behind a camera, which the PPO residual sees. A second
score therefore uses the **homography twin ignoring chirality** (:func:`homography_twin`, from the
known plane): estimators that keep only near-axis points (OpenCV with a 1 px threshold in the pixel
plane) converge to it, and on their inlier subset it is an exact, chirality-consistent pose. No
method can tell a pose from its twin from two views of a plane alone; the paper resolves it with
the ground truth (Table 2 caption).
"""

from __future__ import annotations

import argparse
import os
import time
from typing import Any

import numpy as np

from ..argtypes import non_negative_float, positive_float, positive_int
from ..geometry import normalize, rotation_error_deg
from ..sim import make_scene
from ._common import figure_writer, finish_run, fmt, markdown_table, progress, single_thread, stamp

OUTLIERS = (0.0, 0.2, 0.4, 0.5, 0.6, 0.7, 0.8)
QUICK_OUTLIERS = (0.0, 0.5, 0.8)
KINDS = ("normal", "planar")

METHODS = (
    "GNC-RANSAC",
    "GNC-RANSAC + LiGTopt",
    "poseonly (default)",
    "RANSAC+5pt (OpenGV)",
    "RANSAC+5pt + OpenGV nonlinear",
    "OpenCV RANSAC (50 it)",
    "OpenCV RANSAC (default)",
    "OpenCV USAC_MAGSAC",
    "PoseLib (50 it)",
    "PoseLib (default)",
    "noise floor (LiRP + LiGTopt, true inliers)",
)
# dashed (initial) vs solid (optimised) in the figure, as in the paper
INITIAL = {"GNC-RANSAC", "RANSAC+5pt (OpenGV)", "OpenCV RANSAC (50 it)", "PoseLib (50 it)"}


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--n", type=positive_int, default=300, help="points per scene (paper: 300)")
    p.add_argument("--noise", type=non_negative_float, default=1.0, help="noise in px (paper: 1)")
    p.add_argument("--outliers", type=float, nargs="+", default=None, help="outlier fractions (default 0 .2 .4 .5 .6 .7 .8)")
    p.add_argument("--jobs", type=positive_int, default=1, help="worker processes (each single-threaded)")
    p.add_argument("--threshold-px", type=positive_float, default=1.0, help="pixel threshold of the OpenCV/PoseLib anchors")


def planar_twin(sc, min_angle_deg: float = 0.5, ppo_tol: float = 1e-6) -> np.ndarray | None:
    """Rotation of the homography twin of a planar scene, or ``None`` (module docstring)."""
    from ..solvers.lirp import lirp

    X = sc.X
    b1 = normalize(X)
    b2 = normalize(X @ sc.R.T + sc.baseline * sc.t)
    try:
        o = lirp(b1, b2)
    except ValueError:
        return None
    far = o.candidate_valid & (rotation_error_deg(sc.R, o.candidates_R) > min_angle_deg) & (o.candidate_cost < ppo_tol)
    if not np.any(far):
        return None
    k = np.nonzero(far)[0][np.argmin(o.candidate_cost[far])]
    return o.candidates_R[k]


def homography_twin(sc, min_angle_deg: float = 0.5) -> np.ndarray | None:
    """Rotation of the homography twin of a planar scene *ignoring chirality*, or ``None``.

    ``H = R + t_true n^T / d`` from the scene's plane (``n^T X = d`` in camera 1) decomposed with
    OpenCV's ``decomposeHomographyMat`` (identity calibration); the twin is the decomposition whose
    rotation differs from the truth by more than ``min_angle_deg``. Over the whole wide-angle point
    set this pose usually puts some points behind a camera (so :func:`planar_twin` rejects it), but
    on a subset of near-axis points it is an exact, chirality-consistent solution -- which is what
    estimators that keep only those points (e.g. a 1 px threshold in the pixel plane) converge to.
    """
    if getattr(sc, "plane", None) is None:
        return None
    try:
        import cv2
    except ImportError:  # pragma: no cover
        return None
    nrm, d = np.asarray(sc.plane[:3], float), float(sc.plane[3])
    H = sc.R + np.outer(sc.baseline * sc.t, nrm) / d
    _, Rs_cv, _, _ = cv2.decomposeHomographyMat(H, np.eye(3))
    Rs = np.asarray(Rs_cv, float)
    e = rotation_error_deg(sc.R, Rs)
    far = e > min_angle_deg
    return Rs[far][0] if np.any(far) else None


def _methods(thr_px: float) -> tuple[dict, dict]:
    """name -> fn(sc, seed) -> R (None on failure); plus skipped name -> reason."""
    import poseonly

    from .opengv_ransac import get_refiner, opengv_ransac_5pt, opengv_ransac_nonlinear

    ms, skipped = {}, {}
    ms["GNC-RANSAC"] = lambda sc, s: poseonly.estimate_relative_pose(sc.f1, sc.f2, method="gnc-ransac", refine=False, focal_px=800, seed=s).R
    ms["GNC-RANSAC + LiGTopt"] = lambda sc, s: poseonly.estimate_relative_pose(sc.f1, sc.f2, method="gnc-ransac", refine=True, focal_px=800, seed=s).R
    ms["poseonly (default)"] = lambda sc, s: poseonly.estimate_relative_pose(sc.f1, sc.f2, focal_px=800, seed=s).R
    ms["RANSAC+5pt (OpenGV)"] = lambda sc, s: opengv_ransac_5pt(sc.f1, sc.f2, np.random.default_rng(s)).R
    if get_refiner("opengv_nonlinear") is not None:
        ms["RANSAC+5pt + OpenGV nonlinear"] = lambda sc, s: opengv_ransac_nonlinear(sc.f1, sc.f2, np.random.default_rng(s)).R
    else:
        skipped["RANSAC+5pt + OpenGV nonlinear"] = "poseonly.refine.opengv_nonlinear could not be imported"
    try:
        from ..anchors import ANCHORS, available_anchors

        avail = set(available_anchors())
    except ImportError:  # pragma: no cover
        ANCHORS, avail = {}, set()

    def anchor(key, **kw):
        def f(sc, s):
            kk = dict(kw)
            if key == "poselib":
                kk["seed"] = s
            R = ANCHORS[key](sc.u1, sc.u2, sc.K, sc.K, thr_px, **kk)[0]
            return R

        return f

    for name, key, kw in (
        ("OpenCV RANSAC (50 it)", "opencv-ransac", {"max_iters": 50}),
        ("OpenCV RANSAC (default)", "opencv-ransac", {}),
        ("OpenCV USAC_MAGSAC", "opencv-magsac", {}),
        ("PoseLib (50 it)", "poselib", {"max_iterations": 50}),
        ("PoseLib (default)", "poselib", {}),
    ):
        if key in avail:
            ms[name] = anchor(key, **kw)
        else:
            skipped[name] = f"{key} is not installed"
    ligt = get_refiner("ligt_refine")

    def floor(sc, s):
        from ..solvers.lirp import lirp_batch

        f1, f2 = sc.f1[sc.inliers], sc.f2[sc.inliers]
        o = lirp_batch(f1[None], f2[None])
        R, t = o["R"][0], o["t"][0]
        if ligt is not None:
            r = ligt(R, t, f1, f2)
            R = r.R
        return R

    ms["noise floor (LiRP + LiGTopt, true inliers)"] = floor
    if ligt is None:
        skipped["noise floor: LiGTopt"] = "poseonly.refine.ligt_refine could not be imported (LiRP only)"
    return ms, skipped


_WORKER_METHODS = None


def _trial(task):
    """One scene: ``(kind, frac, trial_index, n, noise, seed, thr_px)`` -> per-method (err, err_twin, seconds)."""
    global _WORKER_METHODS
    kind, frac, s, n, noise, seed, thr_px = task
    if _WORKER_METHODS is None:
        _WORKER_METHODS = _methods(thr_px)[0]
    sc = make_scene(n, kind, "wide", noise, frac, seed + s)
    twin = planar_twin(sc) if kind == "planar" else None
    htwin = homography_twin(sc) if kind == "planar" else None
    out = {"has_twin": twin is not None, "has_htwin": htwin is not None}
    for name, fn in _WORKER_METHODS.items():
        t0 = time.perf_counter()
        try:
            R = fn(sc, seed + s)
        except (ValueError, np.linalg.LinAlgError, ArithmeticError):
            R = None
        dt = time.perf_counter() - t0
        if R is None or not np.all(np.isfinite(R)):
            out[name] = (float("nan"), float("nan"), dt, float("nan"))
            continue
        e = float(rotation_error_deg(sc.R, R))
        et = float(rotation_error_deg(twin, R)) if twin is not None else float("inf")
        eh = float(rotation_error_deg(htwin, R)) if htwin is not None else float("inf")
        out[name] = (e, min(e, et), dt, min(e, eh))
    return kind, frac, s, out


def _init_worker():
    single_thread()


def compute(trials: int, n: int = 300, outliers=OUTLIERS, noise: float = 1.0, seed: int = 0, jobs: int = 1, thr_px: float = 1.0) -> dict:
    single_thread()
    methods, skipped = _methods(thr_px)
    names = list(methods)
    tasks = [(k, f, s, n, noise, seed, thr_px) for k in KINDS for f in outliers for s in range(trials)]
    raw: dict[tuple[str, float], list[dict[str, Any]]] = {(k, f): [] for k in KINDS for f in outliers}
    if jobs > 1:
        from concurrent.futures import ProcessPoolExecutor, as_completed

        with ProcessPoolExecutor(max_workers=jobs, initializer=_init_worker) as ex:
            futs = [ex.submit(_trial, t) for t in tasks]
            for fu in progress(as_completed(futs), total=len(futs), desc="gnc-ransac"):
                k, f, s, o = fu.result()
                raw[(k, f)].append(o)
    else:
        global _WORKER_METHODS
        _WORKER_METHODS = methods
        for t in progress(tasks, total=len(tasks), desc="gnc-ransac"):
            k, f, s, o = _trial(t)
            raw[(k, f)].append(o)
    res: dict[str, Any] = {
        "trials": trials,
        "n": n,
        "noise_px": noise,
        "outliers": list(outliers),
        "kinds": list(KINDS),
        "seed": seed,
        "threshold_px_anchors": thr_px,
        "methods": names,
        "skipped": skipped,
        "results": {},
    }
    for k in KINDS:
        per: dict[str, dict[str, list[float]]] = {
            m: {"mean": [], "median": [], "mean_twin": [], "median_twin": [], "mean_htwin": [], "median_htwin": [], "time_s": [], "fail": []} for m in names
        }
        twins, htwins = [], []
        for f in outliers:
            rows = raw[(k, f)]
            twins.append(float(np.mean([r["has_twin"] for r in rows])))
            htwins.append(float(np.mean([r["has_htwin"] for r in rows])))
            for m in names:
                a = np.array([r[m] for r in rows], float)
                ok = np.isfinite(a[:, 0])
                per[m]["fail"].append(int((~ok).sum()))
                per[m]["time_s"].append(float(a[:, 2].mean()))
                for key, col in (("mean", 0), ("mean_twin", 1), ("mean_htwin", 3)):
                    per[m][key].append(float(a[ok, col].mean()) if ok.any() else float("nan"))
                for key, col in (("median", 0), ("median_twin", 1), ("median_htwin", 3)):
                    per[m][key].append(float(np.median(a[ok, col])) if ok.any() else float("nan"))
        res["results"][k] = per
        res.setdefault("twin_fraction", {})[k] = twins
        res.setdefault("homography_twin_fraction", {})[k] = htwins
    return res


def to_markdown(res: dict) -> str:
    out = []
    head = ["method"] + [f"{100 * f:.0f}%" for f in res["outliers"]]
    for kind in res["kinds"]:
        per = res["results"][kind]
        blocks = [("mean", "mean rotation error (deg)"), ("median", "median rotation error (deg)")]
        if kind == "planar":
            blocks += [
                ("mean_twin", "mean rotation error vs the nearer of truth and twin (LiRP twin, chirality-valid) (deg)"),
                ("median_twin", "median rotation error vs the nearer of truth and twin (LiRP twin, chirality-valid) (deg)"),
                ("mean_htwin", "mean rotation error vs the nearer of truth and homography twin (chirality ignored) (deg)"),
                ("median_htwin", "median rotation error vs the nearer of truth and homography twin (chirality ignored) (deg)"),
            ]
        for key, title in blocks:
            out.append(f"**{kind} scene: {title}**\n")
            rows = []
            for m in res["methods"]:
                cells = [m]
                for i in range(len(res["outliers"])):
                    c = fmt(per[m][key][i])
                    if per[m]["fail"][i]:
                        c += f" [{per[m]['fail'][i]} fail]"
                    cells.append(c)
                rows.append(cells)
            out.append(markdown_table(head, rows))
        out.append(f"**{kind} scene: mean time per call (ms)**\n")
        out.append(markdown_table(head, [[m] + [1e3 * v for v in per[m]["time_s"]] for m in res["methods"]]))
        if kind == "planar":
            out.append(
                "Fraction of planar scenes with a chirality-valid LiRP twin: "
                + ", ".join(f"{100 * f:.0f}%: {v:.2f}" for f, v in zip(res["outliers"], res["twin_fraction"]["planar"]))
                + "; with a homography twin (chirality ignored): "
                + ", ".join(f"{100 * f:.0f}%: {v:.2f}" for f, v in zip(res["outliers"], res["homography_twin_fraction"]["planar"]))
                + "\n"
            )
    if res.get("skipped"):
        out.append("\nSkipped: " + "; ".join(f"{m}: {why}" for m, why in res["skipped"].items()) + "\n")
    return "\n".join(out)


def run(args: argparse.Namespace) -> int:
    outliers = tuple(args.outliers) if args.outliers else (QUICK_OUTLIERS if args.quick else OUTLIERS)
    trials = args.trials or (2 if args.quick else 500)  # an explicit --trials wins over --quick
    t0 = time.perf_counter()
    res = stamp(compute(trials, args.n, outliers, args.noise, args.seed, max(1, min(args.jobs, os.cpu_count() or 1)), args.threshold_px), t0)
    res["jobs"] = args.jobs
    head = (
        f"GNC-RANSAC experiment (n = {args.n}, {args.noise:g} px, wide OpenGV-style scenes, {trials} trials per setting, "
        f"seed {args.seed}; OpenCV/PoseLib on pixel coordinates with a {args.threshold_px:g} px threshold; "
        f"{args.jobs} worker(s), {res['wall_s']:.0f} s)"
    )
    finish_run(args.out, "gnc-ransac", head, res, to_markdown(res), _figure)
    return 0


@figure_writer
def _figure(plt: Any, res: dict) -> Any:

    x = 100 * np.asarray(res["outliers"])
    panels = [
        ("normal", "mean", "mean"),
        ("planar", "mean", "mean"),
        ("planar", "mean_htwin", "mean, nearer of truth/homography twin"),
        ("normal", "median", "median"),
        ("planar", "median", "median"),
        ("planar", "median_htwin", "median, nearer of truth/homography twin"),
    ]
    fig, axes = plt.subplots(2, 3, figsize=(16, 9), squeeze=False)
    cyc = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    colors = {m: cyc[i % len(cyc)] for i, m in enumerate(res["methods"])}
    for ax, (kind, key, title) in zip(axes.ravel(), panels):
        per = res["results"][kind]
        for m in res["methods"]:
            ls = "--" if m in INITIAL else "-"
            if m.startswith("noise floor"):
                ls = ":"
            ax.plot(x, np.maximum(per[m][key], 1e-4), ls=ls, marker="o", ms=3, color=colors[m], label=m)
        ax.set_yscale("log")
        ax.set_xlabel("outlier fraction (%)")
        ax.set_ylabel("rotation error (deg)")
        ax.set_title(f"{kind}: {title}")
        ax.grid(True, which="both", alpha=0.3)
    axes[0, 0].legend(fontsize=7)
    fig.suptitle(f"Robust estimators (n = {res['n']}, {res['noise_px']:g} px, {res['trials']} trials; dashed: initial, solid: optimised)")
    fig.tight_layout(rect=(0, 0, 1, 0.96))
    return fig
