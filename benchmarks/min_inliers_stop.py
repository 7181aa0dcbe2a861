"""The default's ``stop_at_min_inliers`` on an all-pairs image set matched without scores (the
``poseonly colmap verify`` / ``sfm --database`` case, and any caller without match scores).

    python benchmarks/min_inliers_stop.py DIR [DIR ...] [--max-features 8000] [--cache /tmp/min_inliers_stop_cache]

Takes the images of the Strecha-style folders as one set (``DIR/images/*.jpg``, one ``K.txt``),
matches all pairs once (features and matches cached), then estimates every pair with
``use_scores=False`` twice in one process, ``stop_at_min_inliers`` on and off (each with its own
two-view cache, emptied first), and prints the summed two-view time, the samples drawn, the
statuses, and the pairs whose pose or status differ.
"""

from __future__ import annotations

import argparse
import collections
import shutil
import time
from pathlib import Path

import numpy as np


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("dirs", nargs="+")
    ap.add_argument("--max-features", type=int, default=8000)
    ap.add_argument("--cache", default="/tmp/min_inliers_stop_cache")
    a = ap.parse_args(argv)
    from poseonly import estimate_relative_pose
    from poseonly.features import match_noise_scales
    from poseonly.sfm.pairwise import PairwiseOptions, image_view_graph, pair_seed

    images: list[Path] = []
    for d in a.dirs:
        images += sorted((Path(d) / "images").glob("*.jpg"))
    K = np.loadtxt(Path(a.dirs[0]) / "images" / "K.txt")
    cache = Path(a.cache)
    ig = image_view_graph(images, K, options=PairwiseOptions(max_features=a.max_features), cache_dir=cache)
    shutil.rmtree(cache / "twoview", ignore_errors=True)
    n = len(images)
    feats = ig.features
    pairs = sorted(ig.putative)
    runs: dict[bool, list[tuple[str, np.ndarray, int, float]]] = {True: [], False: []}
    for k, (i, j) in enumerate(pairs):
        idx = ig.putative[(i, j)]
        if len(idx) < PairwiseOptions().min_matches:
            continue
        u1, u2 = feats[i].keypoints[idx[:, 0]], feats[j].keypoints[idx[:, 1]]
        ns = match_noise_scales(feats[i], feats[j], idx)
        for flag in (True, False) if k % 2 == 0 else (False, True):
            t0 = time.perf_counter()
            r = estimate_relative_pose(u1, u2, K, K, seed=pair_seed(0, i, j, n), noise_scales=ns, stop_at_min_inliers=flag)
            runs[flag].append((r.status, np.asarray(r.R), int(r.num_iterations), time.perf_counter() - t0))
    m = len(runs[True])
    print(f"{n} images, {len(pairs)} pairs, {m} with at least {PairwiseOptions().min_matches} putative matches, estimated without scores")
    print()
    print("| stop_at_min_inliers | two-view s (sum) | median s a pair | samples (sum) | ok | too_few_inliers | other |")
    print("|---|---|---|---|---|---|---|")
    for flag in (False, True):
        st = collections.Counter(s for s, *_ in runs[flag])
        ts = [t for *_, t in runs[flag]]
        it = sum(x for _, _, x, _ in runs[flag])
        other = m - st["ok"] - st["too_few_inliers"]
        print(f"| {flag} | {sum(ts):.1f} | {np.median(ts):.3f} | {it} | {st['ok']} | {st['too_few_inliers']} | {other} |")
    diff = [k for k in range(m) if runs[True][k][0] != runs[False][k][0] or not np.array_equal(runs[True][k][1], runs[False][k][1])]
    flips = [k for k in diff if runs[True][k][0] != runs[False][k][0]]
    print(f"\npairs with another pose: {len(diff)} (status flips: {len(flips)}: {[(runs[False][k][0], runs[True][k][0]) for k in flips]})")
    print(f"their statuses: {dict(collections.Counter(runs[False][k][0] for k in diff))}")
    return 0


if __name__ == "__main__":
    from poseonly.experiments.report import provenance

    print(provenance(), flush=True)
    raise SystemExit(main())
