"""Option study of the default method on one cell of the robust benchmark (same seeded scenes).

Usage::

    python benchmarks/default_variants.py [--camera pinhole] [--scene normal] [--outliers 0.8] [--trials 200]
        [--part 0 --parts 1]

Prints the median / mean rotation error (deg) and median time of ``estimate_relative_pose`` with a few
option settings (``threshold_px``, ``noise_factor``) next to the noise floor, on the scenes
``make_scene(300, scene, camera, 1.0, outliers, seed)`` for ``seed`` in ``range(trials)`` - the same
scenes as ``poseonly bench robust``. ``--part/--parts`` splits the seeds between processes.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

import poseonly
from poseonly.bench_robust import ml_floor
from poseonly.geometry import rotation_error_deg
from poseonly.sim import make_scene

VARIANTS = {
    "default (2 px, noise_factor 2.5)": {},
    "threshold_px 3": {"threshold_px": 3.0},
    "noise_factor 3.5": {"noise_factor": 3.5},
    "threshold_px 3, noise_factor 3.5": {"threshold_px": 3.0, "noise_factor": 3.5},
    "noise_factor 3.0": {"noise_factor": 3.0},
    "noise_factor 4.0": {"noise_factor": 4.0},
}


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--camera", default="pinhole")
    ap.add_argument("--scene", default="normal")
    ap.add_argument("--outliers", type=float, default=0.8)
    ap.add_argument("--trials", type=int, default=200)
    ap.add_argument("--part", type=int, default=0)
    ap.add_argument("--parts", type=int, default=1)
    ap.add_argument("--variants", nargs="+", type=int, help="indices into VARIANTS (default: all)")
    a = ap.parse_args()
    names = list(VARIANTS)
    variants = {names[i]: VARIANTS[names[i]] for i in (a.variants if a.variants is not None else range(len(names)))}
    err = {k: [] for k in variants}
    tim = {k: [] for k in variants}
    floor = []
    for s in range(a.part, a.trials, a.parts):
        sc = make_scene(300, a.scene, a.camera, 1.0, a.outliers, s)
        floor.append(rotation_error_deg(sc.R, ml_floor(sc)))
        for k, opts in variants.items():
            t0 = time.perf_counter()
            if a.camera == "pinhole":
                r = poseonly.estimate_relative_pose(sc.u1, sc.u2, sc.K, seed=s, **opts)
            else:
                r = poseonly.estimate_relative_pose(sc.f1, sc.f2, focal_px=800.0, seed=s, **opts)
            tim[k].append(time.perf_counter() - t0)
            err[k].append(rotation_error_deg(sc.R, r.R))
    print(f"{a.camera} {a.scene} {a.outliers:.0%} outliers, {len(floor)} scenes (part {a.part}/{a.parts}); noise floor median {np.median(floor):.4f}")
    for k in variants:
        print(f"  {k}: median {np.median(err[k]):.4f} ({np.median(err[k]) / np.median(floor):.2f}x floor), mean {np.mean(err[k]):.4f}, time {1e3 * np.median(tim[k]):.0f} ms")
    np.savez(f"/tmp/default_variants_{a.camera}_{a.scene}_{a.outliers}_{a.part}.npz", floor=floor, **{k: v for k, v in err.items()})


if __name__ == "__main__":
    from poseonly.experiments.report import provenance

    print(provenance(), flush=True)
    main()
