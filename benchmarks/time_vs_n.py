"""Time per pair of the default against PoseLib as the number of matches grows.

Synthetic pinhole scenes (:func:`poseonly.sim.make_scene`, 0.3 px noise, the real matches' level),
n matches at each outlier rate, the default (its 1 px threshold) and PoseLib at 1 px side by side in
one process; prints the median time per pair of each and their ratio. Large match sets (SuperPoint +
LightGlue give thousands) are where the default's ML stage and cross-fit, linear in n per EM round,
weigh most:

    python benchmarks/time_vs_n.py --points 300 1000 3000 8000 --outliers 0.1 0.5 --scenes 6
"""

from __future__ import annotations

import argparse
import time

import numpy as np


def _median_time(fn, scenes) -> float:
    ts = []
    for sc in scenes:
        t0 = time.perf_counter()
        fn(sc)
        ts.append(time.perf_counter() - t0)
    return float(np.median(ts))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--points", type=int, nargs="+", default=[300, 1000, 3000, 8000])
    ap.add_argument("--outliers", type=float, nargs="+", default=[0.1, 0.5])
    ap.add_argument("--scenes", type=int, default=6)
    ap.add_argument("--noise", type=float, default=0.3, help="pixels")
    a = ap.parse_args(argv)
    from poseonly import estimate_relative_pose, sim
    from poseonly.anchors import available_anchors, poselib_relpose

    have_poselib = "poselib" in available_anchors()
    warm = sim.make_scene(300, camera="pinhole", noise_px=a.noise, outlier_fraction=0.5, seed=399)
    estimate_relative_pose(warm.u1, warm.u2, warm.K, warm.K)  # first-call costs (imports, caches) out of the timings
    if have_poselib:
        poselib_relpose(warm.u1, warm.u2, warm.K, warm.K, threshold_px=1.0)
    for n in a.points:
        for rate in a.outliers:
            scs = [sim.make_scene(n, camera="pinhole", noise_px=a.noise, outlier_fraction=rate, seed=400 + s) for s in range(a.scenes)]
            ours = _median_time(lambda sc: estimate_relative_pose(sc.u1, sc.u2, sc.K, sc.K), scs)
            line = f"n = {n}, {100 * rate:.0f} % outliers: poseonly {1e3 * ours:.1f} ms"
            if have_poselib:
                pl = _median_time(lambda sc: poselib_relpose(sc.u1, sc.u2, sc.K, sc.K, threshold_px=1.0), scs)
                line += f", PoseLib 1 px {1e3 * pl:.1f} ms, ratio {ours / pl:.2f}"
            print(line, flush=True)
    return 0


if __name__ == "__main__":
    from poseonly.experiments.report import provenance

    print(provenance(), flush=True)
    raise SystemExit(main())
