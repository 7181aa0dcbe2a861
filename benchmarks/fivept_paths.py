"""Which construction of the five-point solver takes the samples of real pairs, and its time per sample.

For random minimal samples (uniform, seeded) of the matches of real pairs (Strecha scenes or realpairs
folders, ``poseonly bench real``'s SIFT cache), made hard as ``benchmarks/hard_pair_time.py`` makes
them (wrong matches added to ``--target`` inliers; ``--target 0`` keeps the real matches), prints the
share of samples each construction of the solver solves (``fivept.h``: Nister's elimination; where it
fails its pivot test or its Sturm chain breaks down, the action matrix) and the time of ``fivept_batch`` per sample (every construction's cost included).

    S=/work/shared/data/strecha; P=/work/shared/data/realpairs
    python benchmarks/fivept_paths.py $S/entry-P10 $S/fountain-P11 $S/Herz-Jesus-P8 $P/middlebury_temple $P/kitti_seq1 \\
        --samples 300 --target 0
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("dirs", nargs="+")
    ap.add_argument("--cache", default="/tmp/realbench_cache")
    ap.add_argument("--target", type=float, default=0.08, help="inlier share after adding wrong matches (0: the real matches)")
    ap.add_argument("--samples", type=int, default=2000, help="random minimal samples per pair")
    args = ap.parse_args(argv)

    from hard_pair_time import AUG_SEED, augment

    from poseonly import _core
    from poseonly.experiments.real_bench import GT_PX, load_datasets, pair_match_data
    from poseonly.features import sampson_error_px
    from poseonly.geometry import normalize

    aug_rng, rng = np.random.default_rng(AUG_SEED), np.random.default_rng(0)
    taken = np.zeros(3, dtype=np.int64)  # samples per construction the solver took (Nister, action matrix, none)
    total, seconds = 0, 0.0
    for name, pairs in load_datasets(args.dirs).items():
        for p in pairs:
            u1, u2, r, sc = pair_match_data(p, Path(args.cache))
            if len(u1) < 5:
                continue
            if args.target > 0:
                err = sampson_error_px(u1, u2, p.K1, p.K2, p.R, p.t)
                on = err < GT_PX
                if on.sum() < 30 or on.sum() / len(u1) > 0.3:
                    continue
                u1, u2, _, _ = augment(u1, u2, r, sc, on, err, args.target, aug_rng, lambda a, b, p=p: sampson_error_px(a, b, p.K1, p.K2, p.R, p.t))
            f1 = normalize(np.column_stack([u1, np.ones(len(u1))]) @ np.linalg.inv(p.K1).T)
            f2 = normalize(np.column_stack([u2, np.ones(len(u2))]) @ np.linalg.inv(p.K2).T)
            idx = np.array([rng.choice(len(f1), 5, replace=False) for _ in range(args.samples)])
            S1, S2 = np.ascontiguousarray(f1[idx]), np.ascontiguousarray(f2[idx])
            for a, b in zip(S1, S2):
                used = _core._fivept_essentials_path(a, b, -1)[1]  # the automatic choice's construction
                taken[used if used >= 0 else 2] += 1
            t0 = time.perf_counter()
            _core.fivept_batch(S1, S2)
            seconds += time.perf_counter() - t0
            total += len(idx)
            print(f"{name} {p.pid}: {len(f1)} matches", flush=True)
    if not total:
        print("no pair qualified")
        return 1
    share = 100.0 * taken / total
    print(f"\n{total} random samples ({'real matches' if args.target <= 0 else f'wrong matches added to {args.target:.0%} inliers'}):")
    print(f"  Nister's elimination                 {share[0]:5.1f} %")
    print(f"  action matrix (Nister's test fails)  {share[1]:5.1f} %")
    print(f"  rank-deficient (no solution)         {share[2]:5.1f} %")
    print(f"  fivept_batch {1e6 * seconds / total:.2f} us per sample")
    return 0


if __name__ == "__main__":
    from poseonly.experiments.report import provenance

    print(provenance(), flush=True)
    raise SystemExit(main())
