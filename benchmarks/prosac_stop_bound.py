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
from math import ceil, comb, log, log1p
from pathlib import Path

SAMPLE = 5
GT_PX = 1.0


def growth(N: int, m: int, TN: float) -> tuple[list[float], float]:
    """``grown[n]`` (``n <= N + 1``): the draw at which the pool first holds ``n`` points, infinite past
    ``N`` (``ProsacSampler::grown_at_`` in ``src/core/sampling.h``), and the last draw that still holds
    the N-th point (``last_with_newest``)."""
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
    return grown, Tp


def all_inlier(good: int, n: int, k: int) -> float:
    """P(k points drawn without replacement from n, `good` of them inliers, are all inliers)."""
    return comb(good, k) / comb(n, k) if good >= k and n >= k else 0.0


def schedule_expectation(inlier_in_order: list[bool], TN: float, need: float, draws: float, m: int = SAMPLE) -> tuple[float, float]:
    """The expected number of all-inlier samples of the given inliers (in the sampler's order) among the
    first ``draws`` PROSAC draws, and the draw at which that expectation reaches ``need`` (inf if never):
    the sum of ``expected_needed`` in ``src/core/ransac.h``, segment by segment (a draw while the pool
    holds the top n is point n with m - 1 of the top n - 1; after the last growth step, m of all N)."""
    N = len(inlier_in_order)
    inf = float("inf")
    if N <= m:
        return 0.0, inf
    grown, last_newest = growth(N, m, TN)

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
    # pool N: the N-th point with m - 1 of the top N - 1 until the last growth step is used up, then m of all N
    end = max(start, last_newest)
    segments.append((start, end, all_inlier(good, N - 1, m - 1) if inlier_in_order[N - 1] else 0.0))
    good += int(inlier_in_order[N - 1])
    segments.append((end, inf, all_inlier(good, N, m)))
    acc, cross, at_draws = 0.0, inf, None
    for a, b, q in segments:
        if at_draws is None and draws <= b:
            at_draws = acc + max(0.0, draws - a) * q
        if cross == inf and q > 0.0 and acc + (b - a) * q >= need:
            cross = a + (need - acc) / q
        acc += (b - a) * q if b < inf else 0.0
    return (at_draws if at_draws is not None else acc), cross


PROSAC_BETA, PROSAC_PSI, PROSAC_MIN_LENGTH = 0.05, 0.05, 100  # src/core/ransac.h kProsac*


def prosac_rule(inlier_in_order: list[bool], TN: float, confidence: float, m: int = SAMPLE) -> float:
    """The draws after which PROSAC's own rule (``progressive_needed`` in ``src/core/ransac.h``) may stop
    for these inliers: the least k_n over the non-random top-n sets whose draws within the top n reach it
    (inf if none)."""
    N = len(inlier_in_order)
    grown, _ = growth(N, m, TN)
    first = max(m + 1, min(N // 2, PROSAC_MIN_LENGTH))
    best, good = float("inf"), 0
    for n in range(1, N + 1):
        good += int(inlier_in_order[n - 1])
        k, d = good - m, n - m
        if n < first or not (d > 0 and k > PROSAC_BETA * d):
            continue
        q = k / d
        kl = q * log(q / PROSAC_BETA) + ((1 - q) * log((1 - q) / (1 - PROSAC_BETA)) if q < 1 else 0.0)
        if not -d * kl < log(PROSAC_PSI):
            continue
        r = (good - m + 1) / (n - m + 1)
        need = log(1 - confidence) / log1p(-(r**m)) if r < 1 else float(m)
        within = need if n >= N else max(0.0, min(need, grown[n + 1] - 1.0))
        if need < best and within >= need:
            best = need
    return best


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
    print("(each cell: the expectation at the cap, and the draw at which it reaches the rule's need; last column: the draw")
    print(" from which PROSAC's own per-top-n rule would stop, inf: not before the cap / the classical count)")
    print("| pair | matches | inlier ratio | uniform | " + " | ".join(f"PROSAC T_N = {t:g}" for t in a.tn) + " | PROSAC's own rule, T_N = " + f"{a.tn[0]:g} |")
    print("|---|---|---|---|" + "---|" * len(a.tn) + "---|")
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
            own = prosac_rule(order, a.tn[0], a.confidence)
            print(f"| {ds} {p.pid} | {len(u1)} | {w:.3f} | {a.draws * w**SAMPLE:.1f} at {min(uni, float('inf')):.0f} | " + " | ".join(cells) + f" | {own:.0f} |")
    return 0


if __name__ == "__main__":
    from poseonly.experiments.report import provenance

    print(provenance(), flush=True)
    raise SystemExit(main())
