"""Accuracy and speed of the refinement methods started from LiRP (poseonly.refine).

Scenes: ``poseonly.sim.make_scene`` (wide camera), 1 px Gaussian noise, n = 30, 100 normal and 100
planar scenes (seeds 0..99). Each refiner starts from the LiRP pose (``npt`` needs no start).
Prints the mean / median rotation error (degrees) and the time per call at n = 30 and n = 300.

    python benchmarks/refine_accuracy.py [--scenes 100] [--no-npt]
"""

from __future__ import annotations

import argparse
import time
import warnings

import numpy as np

from poseonly import lirp
from poseonly.geometry import rotation_error_deg, translation_error_deg
from poseonly.refine import bundle_adjust, eigensolver, ligt_refine, opengv_nonlinear
from poseonly.sim import make_scene

METHODS = {
    "LiGTopt (paper, LS)": lambda L, f1, f2: ligt_refine(L.R, L.t, f1, f2),
    "LiGTopt theta2": lambda L, f1, f2: ligt_refine(L.R, L.t, f1, f2, normalization="theta2"),
    "LiGTopt angular": lambda L, f1, f2: ligt_refine(L.R, L.t, f1, f2, normalization="angular"),
    "eigensolver": lambda L, f1, f2: eigensolver(L.R, f1, f2),
    "OpenGV nonlinear": lambda L, f1, f2: opengv_nonlinear(L.R, L.t, f1, f2),
    "bundle adjustment": lambda L, f1, f2: bundle_adjust(L.R, L.t, f1, f2),
}


def _npt_method():
    try:
        import cvxpy  # noqa: F401
    except ImportError:
        return None
    from poseonly.refine import npt

    class _R:
        def __init__(self, R, t):
            self.R, self.t = R, t

    return lambda L, f1, f2: _R(*npt(f1, f2)[:2])


def accuracy(kind: str, scenes: int, methods: dict) -> dict:
    errs = {"LiRP": ([], [])} | {k: ([], []) for k in methods}
    for seed in range(scenes):
        sc = make_scene(30, kind=kind, noise_px=1.0, seed=seed)
        L = lirp(sc.f1, sc.f2)
        errs["LiRP"][0].append(rotation_error_deg(sc.R, L.R))
        errs["LiRP"][1].append(translation_error_deg(sc.t, L.t))
        for name, m in methods.items():
            r = m(L, sc.f1, sc.f2)
            errs[name][0].append(rotation_error_deg(sc.R, r.R))
            errs[name][1].append(translation_error_deg(sc.t, r.t))
    return {k: (np.array(a), np.array(b)) for k, (a, b) in errs.items()}


def timing(n: int, methods: dict, reps: int = 10) -> dict:
    out = {k: 0.0 for k in ["LiRP", *methods]}
    for seed in range(reps):
        sc = make_scene(n, kind="normal", noise_px=1.0, seed=1000 + seed)
        t0 = time.perf_counter()
        L = lirp(sc.f1, sc.f2)
        out["LiRP"] += time.perf_counter() - t0
        for name, m in methods.items():
            t0 = time.perf_counter()
            m(L, sc.f1, sc.f2)
            out[name] += time.perf_counter() - t0
    return {k: 1e3 * v / reps for k, v in out.items()}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenes", type=int, default=100)
    ap.add_argument("--no-npt", action="store_true")
    args = ap.parse_args()
    warnings.simplefilter("ignore")
    methods = dict(METHODS)
    if not args.no_npt:
        m = _npt_method()
        if m is not None:
            methods["Zhao npt SDP"] = m
    acc = {kind: accuracy(kind, args.scenes, methods) for kind in ("normal", "planar")}
    timing(30, methods, reps=2)  # warm-up (imports, cvxpy canonicalisation caches)
    t30 = timing(30, methods)
    t300 = timing(300, methods)
    print(f"rotation error (deg), 1 px, n = 30, {args.scenes} scenes each; translation error (deg) mean in []")
    print(f"{'method':22s} {'normal mean':>11s} {'median':>8s} {'[t]':>7s} {'planar mean':>12s} {'median':>8s} {'[t]':>7s} {'ms n=30':>8s} {'ms n=300':>9s}")
    for name in ["LiRP", *methods]:
        rn, tn = acc["normal"][name]
        rp, tp = acc["planar"][name]
        print(f"{name:22s} {rn.mean():11.4f} {np.median(rn):8.4f} {tn.mean():7.3f} {rp.mean():12.4f} {np.median(rp):8.4f} {tp.mean():7.3f} {t30[name]:8.2f} {t300[name]:9.2f}")


if __name__ == "__main__":
    from poseonly.experiments.report import provenance

    print(provenance(), flush=True)
    main()
