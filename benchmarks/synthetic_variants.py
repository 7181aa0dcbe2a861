"""The default method against variants of its options on the robust benchmark's synthetic scenes.

The scenes, the seeds and the noise floor of ``poseonly bench robust`` (n = 300, 1 px noise; planar
errors against the nearer of the truth and the homography twin), only the default and the given
option variants, so a change of the default can be measured per cell without the anchors' hour:

    python benchmarks/synthetic_variants.py '[{}, {"challengers": 0}]' --trials 200 --outliers 0 0.5
    python benchmarks/synthetic_variants.py '[{}, {"challengers": 0}]' --trials 60 --outliers 0.8

Prints, per camera, scene and outlier rate, each variant's median rotation error, its ratio to the
floor and its median time, the share of scenes where the variants' errors differ, and each later
variant's paired ratio to the first (geometric mean over the scenes, +- one standard error).
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np

from poseonly import estimate_relative_pose
from poseonly.bench_robust import _twin_R, ml_floor
from poseonly.geometry import rotation_error_deg
from poseonly.sim import make_scene


def _run(sc, seed: int, opts: dict) -> np.ndarray:
    if sc.camera == "pinhole":
        return estimate_relative_pose(sc.u1, sc.u2, sc.K, seed=seed, **opts).R
    return estimate_relative_pose(sc.f1, sc.f2, focal_px=800.0, seed=seed, **opts).R


def _err(sc, R, tw) -> float:
    e = float(rotation_error_deg(sc.R, R))
    return min(e, float(rotation_error_deg(tw, R))) if tw is not None else e


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("variants", help="JSON list of option dicts ({} is the default)")
    ap.add_argument("--trials", type=int, default=200)
    ap.add_argument("--outliers", type=float, nargs="+", default=[0.0, 0.5, 0.8])
    ap.add_argument("--cameras", nargs="+", default=["wide", "pinhole"])
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--noise", type=float, default=1.0, help="pixel noise (the robust benchmark's 1; the speed benchmark's scenes have 0.5)")
    a = ap.parse_args(argv)
    variants = json.loads(a.variants)
    for cam in a.cameras:
        for kind in ("normal", "planar"):
            for frac in a.outliers:
                errs = np.zeros((len(variants), a.trials))
                times = np.zeros((len(variants), a.trials))
                floor = np.zeros(a.trials)
                for s in range(a.trials):
                    sc = make_scene(300, kind, cam, a.noise, frac, a.seed + s)
                    tw = _twin_R(sc) if kind == "planar" else None
                    floor[s] = _err(sc, ml_floor(sc), tw)
                    for k, v in enumerate(variants):
                        t0 = time.perf_counter()
                        R = _run(sc, a.seed + s, v)
                        times[k, s] = time.perf_counter() - t0
                        errs[k, s] = _err(sc, R, tw)
                fm = float(np.median(floor))
                cells = "  ".join(f"{json.dumps(v)}: {np.median(errs[k]):.4f} ({np.median(errs[k]) / fm:.3f}x, {1e3 * np.median(times[k]):.1f} ms)" for k, v in enumerate(variants))
                differ = float(np.mean(np.any(errs != errs[:1], axis=0)))
                # paired: geometric mean over the scenes of each variant's error over the first's
                lr = np.log(np.maximum(errs[1:], 1e-12) / np.maximum(errs[:1], 1e-12))
                paired = "  ".join(f"{np.exp(lr[k].mean()):.3f} +- {np.exp(lr[k].mean()) * lr[k].std() / np.sqrt(a.trials):.3f}" for k in range(len(lr)))
                print(f"{cam} {kind} {100 * frac:.0f} %: floor {fm:.4f}  {cells}  differ {100 * differ:.0f} %  paired vs the first: {paired}", flush=True)
    return 0


if __name__ == "__main__":
    from poseonly.experiments.report import provenance

    print(provenance(), flush=True)
    raise SystemExit(main())
