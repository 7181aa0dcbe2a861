"""Where GNC-RANSAC's time goes: GNC-IRLS on its samples of 30, against one LiRP solve.

Draws ``--samples`` random samples of ``n_s`` matches from one synthetic pinhole scene (bench speed's
GNC-RANSAC cell: 300 matches, 0.5 px noise, 30 % outliers) and times, in one process, GNC-IRLS on the
batch with its iteration cap at 1, 2, 3 and the paper's 100, and LiRP alone on the same samples; prints
the reported iteration counts (a limit-cycle exit reports the iteration where the full loop would stop).

    python benchmarks/gnc_ransac_cost.py
    python benchmarks/gnc_ransac_cost.py --samples 500 --outliers 0.5
"""

from __future__ import annotations

import argparse
import time


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--samples", type=int, default=250)
    ap.add_argument("--sample-size", type=int, default=30)
    ap.add_argument("--outliers", type=float, default=0.3)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--seed", type=int, default=200)
    a = ap.parse_args(argv)
    import numpy as np

    from poseonly import sim
    from poseonly.estimator import lirp_estimator
    from poseonly.robust.gnc import GNCOptions, gnc_irls_batch
    from poseonly.solvers.lirp import lirp_batch

    sc = sim.make_scene(300, camera="pinhole", noise_px=0.5, outlier_fraction=a.outliers, seed=a.seed)
    rng = np.random.default_rng(a.seed)
    idx = np.array([rng.choice(len(sc.f1), a.sample_size, replace=False) for _ in range(a.samples)])
    f1, f2 = np.ascontiguousarray(sc.f1[idx]), np.ascontiguousarray(sc.f2[idx])
    est = lirp_estimator()

    def best_of(fn) -> float:
        ts = []
        for _ in range(a.repeats):
            t0 = time.perf_counter()
            fn()
            ts.append(time.perf_counter() - t0)
        return min(ts) / a.samples * 1e6

    print(f"{a.samples} samples of {a.sample_size}, {a.outliers:.0%} outliers; best of {a.repeats}, us per sample")
    for cap in (1, 2, 3, 100):
        us = best_of(lambda cap=cap: gnc_irls_batch(f1, f2, est, GNCOptions(max_iterations=cap)))
        print(f"  GNC-IRLS, at most {cap:3d} iterations: {us:7.1f} us")
    print(f"  LiRP alone:                      {best_of(lambda: lirp_batch(f1, f2)):7.1f} us")
    its = gnc_irls_batch(f1, f2, est, GNCOptions()).num_iterations
    u, c = np.unique(its, return_counts=True)
    print("  reported iterations (count): " + ", ".join(f"{int(k)}: {int(v)}" for k, v in zip(u, c)))
    return 0


if __name__ == "__main__":
    from poseonly.experiments.report import provenance

    print(provenance(), flush=True)
    raise SystemExit(main())
