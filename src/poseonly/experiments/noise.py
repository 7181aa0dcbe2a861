"""Noise test of the paper's Section 7.1 (Figs. "noise test of initial methods" and "of optimisation
methods"): rotation error vs image noise, n = 30, no outliers, normal and planar scenes.

* **initial methods**, all on all ``n`` points and all reduced to one pose the same way
  (:func:`poseonly.solvers.common.pose_from_essentials`: pose-only depth conditions, then the
  smallest mean PPO residual; no ground truth): LiRP (:func:`poseonly.solvers.lirp.lirp_batch`),
  "5pt (m)" (Stewenius on the least-squares 4-D subspace), 7pt (cubic on the LS 2-D subspace),
  8pt, linear 6pt (Philip) and Pizarro's 6pt. All are vectorized over the trials.
* **optimisation methods** initialised by LiRP: eigensolver (Kneip & Lynen), OpenGV nonlinear,
  two-view BA, LiGTopt (:mod:`poseonly.refine`), and the N-point SDP (Zhao 2020; needs cvxpy; not
  initialised). A method whose import fails is skipped with a note in the output. Extension (not
  in the paper): "LiGTopt (angular, ext.)" = ``ligt_refine(..., normalization="angular")``, the
  LiGT residual of each point divided by ``theta_i^2 ||z_i R f1_i + t||`` (same zero set).

Scenes: ``make_scene(n, kind, "wide", noise_px, seed + trial)`` (OpenGV-style geometry, chirality
filter, Gaussian noise of ``noise_px`` pixels per tangent axis at f = 800; ``--noise-model opengv``
switches to OpenGV's uniform noise). The same seeds are used at every noise level. A solver that
returns no candidate (Pizarro: no real root pair) or raises counts as a failure: it is left out of
the mean/median and counted in ``fail``.
"""

from __future__ import annotations

import argparse
import time
from typing import Any

import numpy as np

from ..argtypes import points_int
from ..geometry import rotation_error_deg
from ..sim import make_scene
from ..solvers.common import pose_from_essentials
from ..solvers.eightpt import eightpt_batch
from ..solvers.fivept import fivept_batch
from ..solvers.lirp import lirp_batch
from ..solvers.sevenpt import sevenpt_batch
from ..solvers.sixpt import sixpt_philip_batch, sixpt_pizarro_batch
from ._common import figure_writer, finish_run, fmt, markdown_table, progress, stamp
from .opengv_ransac import get_refiner

KINDS = ("normal", "planar")
LEVELS = tuple(float(x) for x in range(11))
QUICK_LEVELS = (0.0, 1.0, 5.0, 10.0)

INITIAL = {
    "LiRP": None,
    "5pt (m)": fivept_batch,
    "7pt": sevenpt_batch,
    "8pt": eightpt_batch,
    "linear 6pt (Philip)": sixpt_philip_batch,
    "6pt (Pizarro)": sixpt_pizarro_batch,
}


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--n", type=points_int(8, "the 8-point solver needs 8"), default=30, help="points per scene (paper: 30)")
    p.add_argument("--levels", type=float, nargs="+", default=None, help="noise levels in px (default 0..10 step 1)")
    p.add_argument(
        "--noise-model",
        default="gaussian",
        choices=["gaussian", "opengv"],
        help="gaussian: pixel noise on the image points; opengv: OpenGV's angular noise model (default gaussian)",
    )
    p.add_argument("--no-npt", action="store_true", help="leave out the N-point SDP (slowest method)")


def _optimisers(use_npt: bool) -> tuple[dict, dict]:
    """name -> fn(R0, t0, f1, f2) -> R, plus name -> reason for skipped methods."""
    ops, skipped = {}, {}
    specs = [
        ("eigensolver", "eigensolver", lambda fn: lambda R0, t0, f1, f2: fn(R0, f1, f2).R),
        ("OpenGV nonlinear", "opengv_nonlinear", lambda fn: lambda R0, t0, f1, f2: fn(R0, t0, f1, f2).R),
        ("BA", "bundle_adjust", lambda fn: lambda R0, t0, f1, f2: fn(R0, t0, f1, f2).R),
        ("LiGTopt", "ligt_refine", lambda fn: lambda R0, t0, f1, f2: fn(R0, t0, f1, f2).R),
        # extension, not in the paper: the same zero set with each point's residual divided by
        # theta_i^2 ||z_i R f1_i + t|| (the sine of the view-2 reprojection angle)
        ("LiGTopt (angular, ext.)", "ligt_refine", lambda fn: lambda R0, t0, f1, f2: fn(R0, t0, f1, f2, normalization="angular").R),
    ]
    for label, name, wrap in specs:
        fn = get_refiner(name)
        if fn is None:
            skipped[label] = f"poseonly.refine.{name} could not be imported"
        else:
            ops[label] = wrap(fn)
    if not use_npt:
        skipped["Npt"] = "left out (--no-npt)"
    else:
        fn = get_refiner("npt")
        if fn is None:
            skipped["Npt"] = "poseonly.refine.npt could not be imported (needs cvxpy)"
        else:
            try:
                import cvxpy  # noqa: F401

                def npt_m(R0, t0, f1, f2, fn=fn):
                    out = fn(f1, f2)
                    return out[0] if isinstance(out, tuple) else out.R

                ops["Npt"] = npt_m
            except ImportError:
                skipped["Npt"] = "cvxpy is not installed"
    return ops, skipped


def _initial_errors(F1, F2, R_true) -> tuple[dict, dict, np.ndarray, np.ndarray]:
    """Rotation errors ``(T,)`` of every initial method (NaN = failure), seconds per call, LiRP R, t."""
    errs, secs = {}, {}
    t0 = time.perf_counter()
    o = lirp_batch(F1, F2)
    secs["LiRP"] = (time.perf_counter() - t0) / len(F1)
    errs["LiRP"] = rotation_error_deg(R_true, o["R"])
    for name, batch in INITIAL.items():
        if batch is None:
            continue
        t0 = time.perf_counter()
        out = batch(F1, F2)
        R, _, info = pose_from_essentials(out["E"], F1, F2, mask=out["mask"])
        secs[name] = (time.perf_counter() - t0) / len(F1)
        e = rotation_error_deg(R_true, R)
        errs[name] = np.where(info["best"] >= 0, e, np.nan)
    return errs, secs, o["R"], o["t"]


def _stats(e: np.ndarray) -> dict:
    e = np.asarray(e, float)
    ok = np.isfinite(e)
    if not ok.any():
        return {"mean": float("nan"), "median": float("nan"), "fail": int(len(e))}
    return {"mean": float(e[ok].mean()), "median": float(np.median(e[ok])), "fail": int((~ok).sum())}


def compute(trials: int, n: int = 30, levels=LEVELS, seed: int = 0, noise_model: str = "gaussian", use_npt: bool = True) -> dict:
    ops, skipped = _optimisers(use_npt)
    from .chirality import solver_errors_types

    solver_errors = solver_errors_types()
    methods_init = list(INITIAL)
    methods_opt = list(ops)
    res: dict[str, Any] = {
        "trials": trials,
        "n": n,
        "levels": list(levels),
        "kinds": list(KINDS),
        "noise_model": noise_model,
        "seed": seed,
        "groups": {"initial": methods_init, "optimisation": methods_opt},
        "skipped": skipped,
        "results": {},
        "time_s": {},
    }
    tsum = {m: 0.0 for m in methods_init + methods_opt}
    tcnt = {m: 0 for m in tsum}
    total = len(KINDS) * len(levels) * trials
    bar = progress(range(total), total=total, desc="noise")
    it = iter(bar)
    for kind in KINDS:
        per: dict[str, dict[str, list[float]]] = {m: {"mean": [], "median": [], "fail": []} for m in methods_init + methods_opt}
        for lev in levels:
            scenes = [make_scene(n, kind, "wide", noise_px=lev, seed=seed + s, noise_model=noise_model) for s in range(trials)]
            F1 = np.stack([s.f1 for s in scenes])
            F2 = np.stack([s.f2 for s in scenes])
            Rt = np.stack([s.R for s in scenes])
            errs, secs, R0, t0 = _initial_errors(F1, F2, Rt)
            for m, v in secs.items():
                tsum[m] += v * trials
                tcnt[m] += trials
            opt_err = {m: np.full(trials, np.nan) for m in methods_opt}
            for s, sc in enumerate(scenes):
                for m, fn in ops.items():
                    t_start = time.perf_counter()
                    try:
                        R = fn(R0[s], t0[s], sc.f1, sc.f2)
                        opt_err[m][s] = float(rotation_error_deg(sc.R, R)) if np.all(np.isfinite(R)) else np.nan
                    except solver_errors:  # a failed solve counts as a failure (NaN)
                        pass
                    tsum[m] += time.perf_counter() - t_start
                    tcnt[m] += 1
                next(it, None)
            for m in methods_init:
                st = _stats(errs[m])
                for k in st:
                    per[m][k].append(st[k])
            for m in methods_opt:
                st = _stats(opt_err[m])
                for k in st:
                    per[m][k].append(st[k])
        res["results"][kind] = per
    for _ in it:  # drain the bar
        pass
    res["time_s"] = {m: tsum[m] / max(tcnt[m], 1) for m in tsum}
    return res


def to_markdown(res: dict) -> str:
    out = []
    for group, ms in res["groups"].items():
        for kind in res["kinds"]:
            per = res["results"][kind]
            out.append(f"**{kind} scene, {group} methods**: mean (median) rotation error in degrees" + (" (LiRP repeated for reference)" if group == "optimisation" else "") + "\n")
            cols = (["LiRP"] if group == "optimisation" else []) + list(ms)
            header = ["noise (px)"] + cols
            rows = []
            for i, lev in enumerate(res["levels"]):
                cells = [f"{lev:g}"]
                for m in cols:
                    d = per[m]
                    c = f"{fmt(d['mean'][i])} ({fmt(d['median'][i])})"
                    if d["fail"][i]:
                        c += f" [{d['fail'][i]} fail]"
                    cells.append(c)
                rows.append(cells)
            out.append(markdown_table(header, rows))
    # winners
    lines = ["\nLowest mean error among the initial methods per level:\n"]
    for kind in res["kinds"]:
        per = res["results"][kind]
        best = []
        for i, lev in enumerate(res["levels"]):
            vals = {m: per[m]["mean"][i] for m in res["groups"]["initial"] if np.isfinite(per[m]["mean"][i])}
            best.append(f"{lev:g} px: {min(vals, key=vals.__getitem__)}" if vals else f"{lev:g} px: -")
        lines.append(f"* {kind}: " + "; ".join(best))
    out.append("\n".join(lines) + "\n")
    t = res["time_s"]
    out.append("\nMean time per call (ms): " + ", ".join(f"{m} {1e3 * v:.2f}" for m, v in t.items()) + "\n")
    if res["skipped"]:
        out.append("\nSkipped: " + "; ".join(f"{m}: {why}" for m, why in res["skipped"].items()) + "\n")
    return "\n".join(out)


def run(args: argparse.Namespace) -> int:
    levels = tuple(args.levels) if args.levels else (QUICK_LEVELS if args.quick else LEVELS)
    trials = args.trials or (3 if args.quick else 500)  # an explicit --trials wins over --quick
    use_npt = not args.no_npt
    t0 = time.perf_counter()
    res = stamp(compute(trials, args.n, levels, args.seed, args.noise_model, use_npt), t0)
    head = (
        f"Noise test (n = {args.n}, wide OpenGV-style scenes, {args.noise_model} noise, {trials} trials per level, "
        f"seed {args.seed}; optimisation methods start from LiRP; {res['wall_s']:.0f} s)"
    )
    finish_run(args.out, "noise", head, res, to_markdown(res), _figure)
    return 0


@figure_writer
def _figure(plt: Any, res: dict) -> Any:

    fig, axes = plt.subplots(2, 2, figsize=(11, 8), squeeze=False)
    lv = np.asarray(res["levels"])
    # the noise-free level (errors ~1e-14) would flatten the log axis: plot it only if it is alone
    keep = lv > 0 if np.any(lv > 0) else np.ones(len(lv), bool)
    lv = lv[keep]
    for r, (group, ms) in enumerate(res["groups"].items()):
        for c, kind in enumerate(res["kinds"]):
            ax = axes[r, c]
            per = res["results"][kind]
            if group == "optimisation":
                ax.plot(lv, np.maximum(np.asarray(per["LiRP"]["mean"])[keep], 1e-16), "k--", lw=1, label="LiRP (start)")
            for m in ms:
                y = np.asarray(per[m]["mean"], float)[keep]
                ax.plot(lv, np.maximum(y, 1e-16), marker="o", ms=3, label=m)
            ax.set_yscale("log")
            ax.set_xlabel("noise (px)")
            ax.set_ylabel("mean rotation error (deg)")
            ax.set_title(f"{group} methods, {kind} scene")
            ax.grid(True, which="both", alpha=0.3)
            ax.legend(fontsize=7)
    fig.suptitle(f"Rotation error vs noise (n = {res['n']}, {res['trials']} trials; 0 px values in the table)")
    fig.tight_layout(rect=(0, 0, 1, 0.96))
    return fig
