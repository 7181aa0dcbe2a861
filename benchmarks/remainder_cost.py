"""The cost of ``consistency_remainder`` on ordinary scenes (docs/RESULTS_real.md, "Hard pairs"):
a synthetic pinhole scene of 1500 matches at 50, 60 and 80 % random outliers, the default with
``consistency="always", consistency_rule="expected"`` without and with the remainder search; median
time of three seeds, each seed's draws and status.

    python benchmarks/remainder_cost.py
"""

from __future__ import annotations

import time

import numpy as np


def main() -> int:
    import poseonly
    from poseonly import sim

    for rate in (0.5, 0.6, 0.8):
        s = sim.make_scene(1500, kind="normal", camera="pinhole", noise_px=0.5, outlier_fraction=rate, seed=1)
        for rem in (False, True):
            ts, draws, status = [], [], []
            for k in range(3):
                t0 = time.perf_counter()
                r = poseonly.estimate_relative_pose(s.u1, s.u2, s.K, s.K, seed=k, consistency="always", consistency_rule="expected", consistency_remainder=rem)
                ts.append(time.perf_counter() - t0)
                draws.append(r.num_iterations)
                status.append(r.status)
            print(f"outliers {rate:.0%} remainder {rem}: {1e3 * np.median(ts):.0f} ms (median of 3 seeds), draws {draws}, {status}", flush=True)
    return 0


if __name__ == "__main__":
    from poseonly.experiments.report import provenance

    print(provenance(), flush=True)
    raise SystemExit(main())
