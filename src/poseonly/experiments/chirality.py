"""Appendix B of the paper: robust N-point and RANSAC + 5pt with and without the chirality filter.

The paper argues that Zhao's (2020) robust N-point results look better than they are because the
OpenGV-derived generator keeps points *behind* the cameras. Data sets, both OpenGV-style (camera 2
in ``[-2, 2]^3``, rotation angles ``U(-0.5, 0.5)`` rad, points from ``generateRandomPoint(8, 4)``),
n = 300, 1 px Gaussian noise, outlier fractions 0-90 %:

* ``chirality``: :func:`poseonly.sim.make_scene` (``kind="normal"``, ``camera="wide"``): only points
  with positive depth in both views are kept; outlier bearings come from random points in front of
  camera 2 (the paper's generator);
* ``none``: :func:`make_scene_no_chirality` (this module): OpenGV's points exactly as generated
  (about half of them behind at least one camera), outlier bearings from random points anywhere
  (OpenGV's ``test/experiment_helpers.cpp``). Built from the same :mod:`poseonly.sim` pieces
  (motion, point sampler, tangent-plane noise).

Methods:

* ``RANSAC+5pt (OpenGV)``: :func:`poseonly.experiments.opengv_ransac.opengv_ransac_5pt` (OpenGV's
  test defaults: 50 iterations, p = 0.99, threshold ``2 (1 - cos(atan(sqrt(2) 0.5 / 800)))``);
* ``robust Npt``: Zhao's robust N-point is not public (notes section 11: only the weight hook of
  :func:`poseonly.refine.npt` is). Our reading, stated: iteratively reweighted N-point SDP with
  Cauchy M-estimator weights ``w_i = 1 / (1 + (r_i / c)^2)`` of the algebraic epipolar residual
  ``r_i = |f2_i^T E f1_i|`` (``|E|_F = sqrt(2)``, so ``r`` is about the angular epipolar error),
  ``c = 2 px / 800``, uniform start, at most 20 reweightings, stop when the weights change by less
  than 1e-4. Needs cvxpy; skipped with a note otherwise.
* ``Npt (all points)``: the plain N-point SDP on all points, for reference.

Scores: mean and median rotation error (deg) per outlier fraction, generator and method.
"""

from __future__ import annotations

import argparse
import time
from typing import Any

import numpy as np

from .. import sim
from ..argtypes import non_negative_float, positive_float, positive_int
from ..geometry import normalize, rotation_error_deg
from ._common import figure_writer, finish_run, fmt, markdown_table, progress, stamp
from .opengv_ransac import get_refiner, opengv_ransac_5pt

OUTLIERS = tuple(round(0.1 * k, 1) for k in range(10))
QUICK_OUTLIERS = (0.0, 0.5, 0.9)
GENERATORS = ("chirality", "none")


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--n", type=positive_int, default=300, help="points per scene (paper App. B: 300)")
    p.add_argument("--noise", type=non_negative_float, default=1.0, help="noise in px (paper: 1)")
    p.add_argument("--cauchy-px", type=positive_float, default=2.0, help="Cauchy scale of the robust N-point (px at f = 800)")


def make_scene_no_chirality(n: int, noise_px: float, outlier_fraction: float, seed) -> sim.Scene:
    """OpenGV's generator without the chirality filter (module docstring). Returns a :class:`poseonly.sim.Scene`."""
    rng = seed if isinstance(seed, np.random.Generator) else np.random.default_rng(seed)
    R, C = sim.motion(rng, "normal", "wide")
    X = sim.opengv_points(rng, n)
    t = -R @ C
    baseline = float(np.linalg.norm(t))
    X2 = X @ R.T + t
    f1 = sim.add_noise(normalize(X), noise_px, rng, "gaussian")
    f2 = sim.add_noise(normalize(X2), noise_px, rng, "gaussian")
    inliers = np.ones(n, bool)
    k = int(np.floor(outlier_fraction * n))
    if k > 0:
        idx = rng.choice(n, size=k, replace=False)
        inliers[idx] = False
        f2[idx] = normalize(sim.opengv_points(rng, k))  # anywhere around camera 2, as OpenGV
    K = sim.default_K()
    nan = np.full((n, 2), np.nan)
    return sim.Scene(f1=f1, f2=f2, u1=nan, u2=nan.copy(), K=K, R=R, t=t / baseline, baseline=baseline, inliers=inliers, X=X, kind="normal", camera="wide", noise_px=float(noise_px))


def _scene(gen: str, n: int, noise: float, frac: float, seed: int) -> sim.Scene:
    if gen == "chirality":
        return sim.make_scene(n, "normal", "wide", noise, frac, seed)
    return make_scene_no_chirality(n, noise, frac, seed)


def solver_errors_types() -> tuple:
    """Exceptions a failed SDP solve raises (cvxpy's ``SolverError`` when cvxpy is installed)."""
    errs = [ValueError, np.linalg.LinAlgError, ArithmeticError]
    try:
        from cvxpy.error import SolverError

        errs.append(SolverError)
    except ImportError:
        pass
    return tuple(errs)


def robust_npt(f1: np.ndarray, f2: np.ndarray, npt_fn, c: float = 2.0 / 800.0, max_iterations: int = 20, tol: float = 1e-4):
    """IRLS N-point with Cauchy weights (module docstring). Returns ``R, t, weights, iterations``.

    A failed SDP solve in a later reweighting keeps the previous estimate; a failed first solve raises.
    """
    w = np.ones(len(f1))
    R = t = None
    it = 0
    errs = solver_errors_types()
    for it in range(1, max_iterations + 1):
        try:
            R, t, info = npt_fn(f1, f2, w)
        except errs:
            if R is None:
                raise
            break
        E = np.asarray(info["E"], float)
        E = E * (np.sqrt(2.0) / max(np.linalg.norm(E), 1e-300))
        r = np.abs(np.einsum("ni,ij,nj->n", f2, E, f1))
        w_new = 1.0 / (1.0 + (r / c) ** 2)
        done = np.max(np.abs(w_new - w)) < tol
        w = w_new
        if done:
            break
    return R, t, w, it


def _methods(cauchy_px: float):
    ms, skipped = {}, {}
    ms["RANSAC+5pt (OpenGV)"] = lambda sc, s: opengv_ransac_5pt(sc.f1, sc.f2, np.random.default_rng(s)).R
    npt_fn = get_refiner("npt")
    ok = npt_fn is not None
    if ok:
        try:
            import cvxpy  # noqa: F401
        except ImportError:
            ok = False
    if ok:
        assert npt_fn is not None  # ok implies the refiner was found
        c = cauchy_px / 800.0
        ms["robust Npt (IRLS, Cauchy)"] = lambda sc, s: robust_npt(sc.f1, sc.f2, npt_fn, c)[0]
        ms["Npt (all points)"] = lambda sc, s: npt_fn(sc.f1, sc.f2)[0]
    else:
        skipped["robust Npt"] = "poseonly.refine.npt or cvxpy is not available (pip install -e '.[sdp]', or '.[all]')"
    return ms, skipped


def compute(trials: int, n: int = 300, outliers=OUTLIERS, noise: float = 1.0, seed: int = 0, cauchy_px: float = 2.0) -> dict:
    methods, skipped = _methods(cauchy_px)
    names = list(methods)
    res = {
        "trials": trials,
        "n": n,
        "noise_px": noise,
        "outliers": list(outliers),
        "generators": list(GENERATORS),
        "seed": seed,
        "cauchy_px": cauchy_px,
        "methods": names,
        "skipped": skipped,
        "results": {},
        "time_s": {},
    }
    tsum = {m: 0.0 for m in names}
    solver_errs = solver_errors_types()
    ncall = 0
    behind = []
    total = len(GENERATORS) * len(outliers) * trials
    bar = progress(range(total), total=total, desc="chirality")
    it = iter(bar)
    for gen in GENERATORS:
        per: dict[str, dict[str, list[float]]] = {m: {"mean": [], "median": [], "fail": []} for m in names}
        for frac in outliers:
            errs: dict[str, list[float]] = {m: [] for m in names}
            for s in range(trials):
                sc = _scene(gen, n, noise, frac, seed + s)
                if gen == "none" and frac == outliers[0]:
                    X2 = sc.X @ sc.R.T + sc.baseline * sc.t
                    behind.append(float(np.mean((sc.X[:, 2] <= 0) | (X2[:, 2] <= 0))))
                for m, fn in methods.items():
                    t0 = time.perf_counter()
                    try:
                        R = fn(sc, seed + s)
                        e = float(rotation_error_deg(sc.R, R)) if R is not None and np.all(np.isfinite(R)) else float("nan")
                    except solver_errs:
                        e = float("nan")
                    tsum[m] += time.perf_counter() - t0
                    errs[m].append(e)
                ncall += 1
                next(it, None)
            for m in names:
                a = np.asarray(errs[m])
                ok = np.isfinite(a)
                per[m]["mean"].append(float(a[ok].mean()) if ok.any() else float("nan"))
                per[m]["median"].append(float(np.median(a[ok])) if ok.any() else float("nan"))
                per[m]["fail"].append(int((~ok).sum()))
        res["results"][gen] = per
    for _ in it:
        pass
    res["time_s"] = {m: v / max(ncall, 1) for m, v in tsum.items()}
    res["behind_fraction_none"] = float(np.mean(behind)) if behind else float("nan")
    return res


def to_markdown(res: dict) -> str:
    out = []
    head = ["method / generator"] + [f"{100 * f:.0f}%" for f in res["outliers"]]
    for key in ("mean", "median"):
        out.append(f"**{key} rotation error (deg)**\n")
        rows = []
        for m in res["methods"]:
            for gen in res["generators"]:
                d = res["results"][gen][m]
                cells = [f"{m} / {gen}"]
                for i in range(len(res["outliers"])):
                    c = fmt(d[key][i])
                    if d["fail"][i]:
                        c += f" [{d['fail'][i]} fail]"
                    cells.append(c)
                rows.append(cells)
        out.append(markdown_table(head, rows))
    out.append(f"Points behind at least one camera in the 'none' generator: {100 * res['behind_fraction_none']:.0f}%\n")
    out.append("\nMean time per call (ms): " + ", ".join(f"{m} {1e3 * v:.1f}" for m, v in res["time_s"].items()) + "\n")
    if res["skipped"]:
        out.append("\nSkipped: " + "; ".join(f"{m}: {why}" for m, why in res["skipped"].items()) + "\n")
    return "\n".join(out)


def run(args: argparse.Namespace) -> int:
    outliers = QUICK_OUTLIERS if args.quick else OUTLIERS
    trials = args.trials or (3 if args.quick else 500)  # an explicit --trials wins over --quick
    t0 = time.perf_counter()
    res = stamp(compute(trials, args.n, outliers, args.noise, args.seed, args.cauchy_px), t0)
    head = (
        f"Appendix B: chirality filter in the generator (n = {args.n}, {args.noise:g} px Gaussian, OpenGV-style geometry, "
        f"{trials} trials per setting, seed {args.seed}; 'chirality' = points in front of both cameras, 'none' = OpenGV's "
        f"points as generated; {res['wall_s']:.0f} s)"
    )
    finish_run(args.out, "chirality", head, res, to_markdown(res), _figure)
    return 0


@figure_writer
def _figure(plt: Any, res: dict) -> Any:

    x = 100 * np.asarray(res["outliers"])
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.5), squeeze=False)
    cyc = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for ax, key in zip(axes[0], ("mean", "median")):
        for i, m in enumerate(res["methods"]):
            for gen, ls in zip(res["generators"], ("-", "--")):
                ax.plot(x, np.maximum(res["results"][gen][m][key], 1e-4), ls=ls, marker="o", ms=3, color=cyc[i % len(cyc)], label=f"{m} ({gen})")
        ax.set_yscale("log")
        ax.set_xlabel("outlier fraction (%)")
        ax.set_ylabel(f"{key} rotation error (deg)")
        ax.grid(True, which="both", alpha=0.3)
        ax.set_title(f"{key}: solid = chirality filter, dashed = none")
    axes[0, 0].legend(fontsize=7)
    fig.suptitle(f"Appendix B (n = {res['n']}, {res['noise_px']:g} px, {res['trials']} trials)")
    fig.tight_layout(rect=(0, 0, 1, 0.96))
    return fig
