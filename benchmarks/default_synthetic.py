"""The default method against the noise floor on synthetic scenes (the check in docs/RESULTS_real.md).

Usage: ``python benchmarks/default_synthetic.py [N]`` (N scenes per cell, default 40; seeds 7000 ...).
Prints, per camera and outlier rate, the median rotation error of ``estimate_relative_pose`` over the
median of the noise floor (Sampson least squares on the true inliers,
:func:`poseonly.bench_robust.ml_floor`).
"""

from __future__ import annotations

import sys

import numpy as np

import poseonly
from poseonly import sim
from poseonly.bench_robust import ml_floor
from poseonly.geometry import rotation_error_deg


def main(n: int = 40) -> None:
    for cam in ("pinhole", "wide"):
        for out in (0.0, 0.8):
            err, floor = [], []
            for s in range(n):
                sc = sim.make_scene(300, camera=cam, noise_px=1.0, outlier_fraction=out, seed=7000 + s)
                floor.append(rotation_error_deg(sc.R, ml_floor(sc)))
                err.append(rotation_error_deg(sc.R, poseonly.estimate_relative_pose(sc.u1, sc.u2, sc.K, sc.K).R))
            ratio = np.median(err) / np.median(floor)
            print(f"{cam} {out:.0%}: floor {np.median(floor):.4f} deg, default {np.median(err):.4f} deg, ratio {ratio:.3f}", flush=True)


if __name__ == "__main__":
    from poseonly.experiments.report import provenance

    print(provenance(), flush=True)
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 40)
