"""The default's second search at 3 sigma (``research_noise``) on the robust benchmark's scenes.

Usage::

    python benchmarks/research_study.py --camera pinhole --scene normal --outliers 0.8 --trials 60 [--study chiral]

Prints, for the scenes ``make_scene(300, scene, camera, 1.0, outliers, seed)`` (seed < trials, the
scenes of ``poseonly bench robust``), the median rotation error over the median noise floor of the
default (``research_noise=0``: no second search) and with ``research_noise=0.5``; planar scenes count the
nearer of the truth and the scene's homography twin. ``--study chiral`` compares the default with
``chiral_scoring=False`` instead, ``--study tails`` with the Gaussian ML stage (``ml_tails="gauss"``).
"""

from __future__ import annotations

import argparse

import numpy as np

import poseonly
from poseonly.bench_robust import _twin_R, ml_floor
from poseonly.geometry import rotation_error_deg
from poseonly.sim import make_scene

STUDIES = {
    "research": {"research_noise=0.5": {"research_noise": 0.5}, "default (research_noise=0)": {}},
    "chiral": {"chiral_scoring=False": {"chiral_scoring": False}, "default (chiral_scoring=True)": {}},
    "tails": {"ml_tails=gauss": {"ml_tails": "gauss"}, "default (ml_tails=student)": {}},
}


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--camera", default="pinhole", choices=("pinhole", "wide"))
    ap.add_argument("--scene", default="normal", choices=("normal", "planar"))
    ap.add_argument("--outliers", type=float, default=0.8)
    ap.add_argument("--trials", type=int, default=60)
    ap.add_argument("--study", default="research", choices=tuple(STUDIES), help="research: the second search; chiral: the cheirality-aware search scoring; tails: the ML stage's t")
    a = ap.parse_args()
    variants = STUDIES[a.study]
    floor, err = [], {k: [] for k in variants}
    for s in range(a.trials):
        sc = make_scene(300, a.scene, a.camera, 1.0, a.outliers, s)
        floor.append(rotation_error_deg(sc.R, ml_floor(sc)))
        twin = _twin_R(sc) if a.scene == "planar" else None
        for k, opts in variants.items():
            if a.camera == "pinhole":
                r = poseonly.estimate_relative_pose(sc.u1, sc.u2, sc.K, seed=s, **opts)
            else:
                r = poseonly.estimate_relative_pose(sc.f1, sc.f2, focal_px=800.0, seed=s, **opts)
            e = rotation_error_deg(sc.R, r.R) if r.R is not None else 180.0
            if twin is not None and r.R is not None:
                e = min(e, rotation_error_deg(twin, r.R))
            err[k].append(e)
    fl = float(np.median(floor))
    cells = ", ".join(f"{k} {np.median(v) / fl:.3f}x" for k, v in err.items())
    print(f"{a.camera} {a.scene} {a.outliers:.0%} outliers, {a.trials} scenes: median error over the floor ({fl:.4f} deg): {cells}")


if __name__ == "__main__":
    from poseonly.experiments.report import provenance

    print(provenance(), flush=True)
    main()
