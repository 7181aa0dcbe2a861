"""Is each method of ``poseonly bench real`` deterministic? Two identical calls per pair, one process.

For every method (default: the benchmark's default set), the pairs of a dataset folder are estimated
twice with the same matches, scores and seed; prints how many pairs' rotation errors differ between
the two calls. A method that differs cannot be compared to its own single-run figures to the digits.

    python benchmarks/anchor_determinism.py /work/shared/data/realpairs/kitti_seq1 --pairs 30
    python benchmarks/anchor_determinism.py DIR --methods superansac opencv-magsac --cache /tmp/realbench_cache
"""

from __future__ import annotations

import argparse
from pathlib import Path

from poseonly.experiments import real_bench as rb
from poseonly.geometry import rotation_error_deg


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("folder")
    ap.add_argument("--pairs", type=int, default=30)
    ap.add_argument("--methods", nargs="+", default=list(rb.DEFAULT_METHODS))
    ap.add_argument("--cache", default="/tmp/realbench_cache")
    a = ap.parse_args(argv)
    methods, skipped = rb.available_methods(a.methods)
    for m in skipped:
        print(f"{m}: skipped (its library is missing)")
    name, pairs = next(iter(rb.load_datasets([a.folder]).items()))
    pairs = pairs[: a.pairs]
    data = [rb.pair_match_data(p, Path(a.cache)) for p in pairs]
    for m in methods:
        fn = rb.METHODS[m]
        differ = 0
        for p, (u1, u2, ratio, scales) in zip(pairs, data):
            e = []
            for _ in range(2):
                o = fn(u1, u2, p.K1, p.K2, 1.0 - ratio, 0, scales)
                e.append(None if o.R is None else float(rotation_error_deg(p.R, o.R)))
            differ += e[0] != e[1]
        print(f"{name} {m:14s} pairs whose two identical calls differ: {differ} of {len(pairs)}", flush=True)
    return 0


if __name__ == "__main__":
    from poseonly.experiments.report import provenance

    print(provenance(), flush=True)
    raise SystemExit(main())
