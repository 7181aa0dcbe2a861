"""How early PROSAC's stopping rule can end the search on a real pair, whatever the search finds.

For the pairs of a ``poseonly bench real`` dataset folder with at least ``--min-matches`` matches and
at most ``--max-inliers`` ground-truth inliers (within 1 px of the true epipolar geometry), taken as the
best model's inliers: the expected number of all-inlier samples that the default's PROSAC sampler
(``src/core/sampling.h``, growth schedule with ``T_N``; the matches in ratio-score order) draws in the
first ``--draws`` draws, against a uniform sampler's ``draws * w^5``. A stopping rule at confidence c can
end the search only once this sum reaches ``-ln(1 - c)`` (9.21 at 0.9999): with ``T_N`` = the iteration
cap (the default) the PROSAC sum at the cap is about the uniform one, so on pairs whose inlier ratio
keeps the classical rule at the cap, PROSAC's rule cannot end the search much earlier either; a slower
growth (larger ``T_N``) concentrates the draws on the top-ranked matches.

    python benchmarks/prosac_stop_bound.py /work/shared/data/strecha/entry-P10 --max-inliers 0.2
"""

from __future__ import annotations

import argparse
from math import comb, log
from pathlib import Path

SAMPLE = 5
GT_PX = 1.0


def growth(N: int, m: int, TN: float) -> list[float]:
    """``grown[n]``: the draw at which the pool first holds ``n`` points (``src/core/sampling.h``)."""
    Tn = TN
    for i in range(m):
        Tn *= (m - i) / (N - i)
    grown = [0.0] * (N + 1)
    n, Tp, t = m, 1.0, 0.0
    while n < N:
        t = max(t + 1.0, float(-(-Tp // 1)))
        T1 = Tn * (n + 1.0) / (n + 1.0 - m)
        Tp += float(-(-(T1 - Tn) // 1))
        Tn = T1
        n += 1
        grown[n] = t
    return grown


def expected_hits(inlier_in_order: list[bool], TN: float, draws: float, need: float, m: int = SAMPLE) -> tuple[float, float]:
    """Expected all-inlier samples among the first ``draws`` PROSAC draws (a draw with pool n holds point
    n and m - 1 of the top n - 1), and the draw at which that expectation first reaches ``need`` (inf
    when it does not within ``draws``)."""
    N = len(inlier_in_order)
    cum = [0]
    for x in inlier_in_order:
        cum.append(cum[-1] + int(x))
    grown = growth(N, m, TN)
    acc, cross = 0.0, float("inf")
    for n in range(m, N + 1):
        start, end = grown[n], min(grown[n + 1] if n < N else draws, draws)
        if end <= start:
            continue
        p = comb(cum[m], m) if n == m else int(inlier_in_order[n - 1]) * comb(cum[n - 1], m - 1) / comb(n - 1, m - 1)
        if acc < need <= acc + (end - start) * p:
            cross = start + (need - acc) / p
        acc += (end - start) * p
        if end >= draws:
            break
    return acc, cross


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("folder", help="a realpairs or Strecha dataset folder")
    ap.add_argument("--cache", default="/tmp/realbench_cache", help="the real benchmark's match cache")
    ap.add_argument("--min-matches", type=int, default=300)
    ap.add_argument("--max-inliers", type=float, default=0.3, help="largest ground-truth inlier ratio")
    ap.add_argument("--draws", type=float, default=1e5, help="the search's iteration cap")
    ap.add_argument("--confidence", type=float, default=0.9999)
    ap.add_argument("--tn", type=float, nargs="+", default=[1e5, 1e6], help="PROSAC growth T_N values")
    a = ap.parse_args(argv)
    import numpy as np

    from poseonly.experiments import real_bench as rb
    from poseonly.features import sampson_error_px

    need = -log(1.0 - a.confidence)
    print(f"expected all-inlier samples in the first {a.draws:g} draws (a stopping rule at confidence {a.confidence} needs {need:.2f})")
    print("(each cell: the expectation at the cap, and the draw at which it reaches the rule's need)")
    print("| pair | matches | inlier ratio | uniform | " + " | ".join(f"PROSAC T_N = {t:g}" for t in a.tn) + " |")
    print("|---|---|---|---|" + "---|" * len(a.tn))
    for ds, pairs in rb.load_datasets([a.folder]).items():
        for p in pairs:
            u1, u2, ratio, _ = rb.pair_match_data(p, Path(a.cache))
            if len(u1) < a.min_matches:
                continue
            gt = sampson_error_px(u1, u2, p.K1, p.K2, p.R, p.t) < GT_PX
            w = float(gt.mean())
            if w > a.max_inliers:
                continue
            order = gt[np.argsort(ratio, kind="stable")].tolist()
            cells = []
            for t in a.tn:
                hits, cross = expected_hits(order, t, a.draws, need)
                cells.append(f"{hits:.1f} at {cross:.0f}" if cross < float("inf") else f"{hits:.1f}, never")
            uni = need / w**SAMPLE if w > 0 else float("inf")
            print(f"| {ds} {p.pid} | {len(u1)} | {w:.3f} | {a.draws * w**SAMPLE:.1f} at {min(uni, float('inf')):.0f} | " + " | ".join(cells) + " |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
