"""Reducing the matches before the default method (a study; not the library's behaviour).

Two reductions of a pair's matches, each run before ``estimate_relative_pose`` and mapped back to
the full match set: ``dedup`` keeps one of each set of exact copies of a correspondence (the same
pixel pair twice: SIFT detects a corner once per dominant orientation), ``1to1`` keeps, greedily by
match score, at most one match per keypoint in each image (what a mutual check would leave). Both
with the search as it was before the ninth session (every match scored: ``keypoint_once=False``),
under the multi-scale (``multi-*``) and the plain MSAC score (``msac-*``); ``multi`` is that
search without a reduction. Runs the real benchmark with these methods added to its registry:

    python benchmarks/match_reduction_study.py $S/Herz-Jesus-P8 $S/entry-P10 $S/fountain-P11 \\
        $P/middlebury_temple $P/kitti_seq1 --methods multi multi-dedup multi-1to1 msac msac-dedup \\
        msac-1to1 poselib-1px --cache /tmp/realbench_cache --out docs/results/real/match_reduction

(docs/results/real/match_reduction/ holds the run at c99fcb2, where ``poseonly`` was ``msac``.)
"""

from __future__ import annotations

import sys
from typing import Any

import numpy as np

from poseonly import estimate_relative_pose
from poseonly.experiments import real_bench as rb


def _ids(u: np.ndarray) -> np.ndarray:
    _, inv = np.unique(u, axis=0, return_inverse=True)
    return inv.ravel()


def reduce_matches(u1: np.ndarray, u2: np.ndarray, scores: np.ndarray, mode: str) -> np.ndarray:
    """Sorted indices of the matches kept (``mode`` "dedup" or "1to1"; higher score first)."""
    order = np.argsort(-scores, kind="stable")
    if mode == "dedup":
        key = _ids(np.c_[u1, u2])
        _, first = np.unique(key[order], return_index=True)
        return np.sort(order[first])
    g1, g2 = _ids(u1), _ids(u2)
    used1: set[int] = set()
    used2: set[int] = set()
    keep = []
    for i in order:
        if g1[i] in used1 or g2[i] in used2:
            continue
        used1.add(int(g1[i]))
        used2.add(int(g2[i]))
        keep.append(i)
    return np.sort(np.array(keep, dtype=int))


def reduced(mode: str, **options: Any) -> rb.MethodFn:
    def run(u1, u2, K1, K2, scores, seed, noise_scales=None) -> rb.MethodOutput:
        keep = reduce_matches(u1, u2, scores, mode)
        r = estimate_relative_pose(u1[keep], u2[keep], K1, K2, seed=int(seed), scores=scores[keep], noise_scales=None if noise_scales is None else noise_scales[keep], **options)
        good = r.status not in ("degenerate", "failed") and r.R is not None and np.all(np.isfinite(r.R))
        kept_inl = keep[np.asarray(r.inliers, bool)]
        if mode == "dedup":  # copies of an inlier are inliers
            key = _ids(np.c_[u1, u2])
            inl = np.isin(key, key[kept_inl])
        else:
            inl = np.zeros(len(u1), bool)
            inl[kept_inl] = True
        return rb.MethodOutput(r.R if good else None, r.t if good else None, inl, r.status)

    return run


OLD = {"keypoint_once": False}
rb.METHODS["multi"] = rb.ours(use_scores=True, use_scales=True, scoring="msac-multi", **OLD)
rb.METHODS["msac"] = rb.ours(use_scores=True, use_scales=True, scoring="msac", **OLD)
rb.METHODS["multi-dedup"] = reduced("dedup", scoring="msac-multi", **OLD)
rb.METHODS["multi-1to1"] = reduced("1to1", scoring="msac-multi", **OLD)
rb.METHODS["msac-dedup"] = reduced("dedup", scoring="msac", **OLD)
rb.METHODS["msac-1to1"] = reduced("1to1", scoring="msac", **OLD)

if __name__ == "__main__":
    from poseonly.experiments.report import provenance

    print(provenance(), flush=True)
    raise SystemExit(rb.main(sys.argv[1:]))
