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
from math import ceil, comb, log
from pathlib import Path

SAMPLE = 5
GT_PX = 1.0


def growth(N: int, m: int, TN: float) -> list[float]:
    """``grown[n]`` (``n <= N + 1``): the draw at which the pool first holds ``n`` points, infinite past
    ``N`` (``ProsacSampler::grown_at_`` in ``src/core/sampling.h``)."""
    Tn = TN
    for i in range(m):
        Tn *= (m - i) / (N - i)
    grown = [0.0] * (m + 1) + [float("inf")] * (N + 1 - m)
    n, Tp, t = m, 1.0, 0.0
    while n < N:
        t = max(t + 1.0, float(ceil(Tp)))
        T1 = Tn * (n + 1.0) / (n + 1.0 - m)
        Tp += float(ceil(T1 - Tn))
        Tn = T1
        n += 1
        grown[n] = t
    return grown


def all_inlier(good: int, n: int, k: int) -> float:
    """P(k points drawn without replacement from n, `good` of them inliers, are all inliers)."""
    return comb(good, k) / comb(n, k) if good >= k and n >= k else 0.0


def schedule_expectation(inlier_in_order: list[bool], TN: float, need: float, draws: float, m: int = SAMPLE) -> tuple[float, float]:
    """The expected number of all-inlier samples of the given inliers (in the sampler's order) among the
    first ``draws`` PROSAC draws, and the draw at which that expectation reaches ``need`` (inf if never):
    the sum of ``expected_needed`` in ``src/core/ransac.h``, segment by segment (a draw while the pool
    holds the top n < N is point n with m - 1 of the top n - 1; from the pool N on, m of all N)."""
    N = len(inlier_in_order)
    inf = float("inf")
    if N <= m:
        return 0.0, inf
    grown = growth(N, m, TN)

    def within(n: int) -> float:  # ProsacSampler::draws_within(n, inf)
        return inf if n >= N else max(0.0, grown[n + 1] - 1.0)

    segments = []  # (start, end, p)
    good = sum(int(x) for x in inlier_in_order[:m])
    start, end, p = 0.0, within(m), 1.0 if good == m else 0.0
    for n in range(m + 1, N + 1):
        segments.append((start, end, p))
        start = end
        if n > N - 1:
            break
        p = all_inlier(good, n - 1, m - 1) if inlier_in_order[n - 1] else 0.0
        good += int(inlier_in_order[n - 1])
        end = within(n)
    good += int(inlier_in_order[N - 1])
    segments.append((start, inf, all_inlier(good, N, m)))
    acc, cross, at_draws = 0.0, inf, None
    for a, b, q in segments:
        if at_draws is None and draws <= b:
            at_draws = acc + max(0.0, draws - a) * q
        if cross == inf and q > 0.0 and acc + (b - a) * q >= need:
            cross = a + (need - acc) / q
        acc += (b - a) * q if b < inf else 0.0
    return (at_draws if at_draws is not None else acc), cross


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
                hits, cross = schedule_expectation(order, t, need, a.draws)
                cells.append(f"{hits:.1f} at {cross:.0f}" if cross < float("inf") else f"{hits:.1f}, never")
            uni = need / w**SAMPLE if w > 0 else float("inf")
            print(f"| {ds} {p.pid} | {len(u1)} | {w:.3f} | {a.draws * w**SAMPLE:.1f} at {min(uni, float('inf')):.0f} | " + " | ".join(cells) + " |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
