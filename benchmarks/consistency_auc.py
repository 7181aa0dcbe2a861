"""How well a sampling order separates good matches from bad ones on real pairs (ROC AUC).

For every pair of the ``poseonly bench real`` datasets (cached SIFT matches, ratio 0.8) with at least
15 matches within 1 px (Sampson) of the ground-truth geometry and some beyond it, the ROC AUC of three
orders against that label: SIFT's ``1 - ratio`` (the default's PROSAC order with the front-end's
scores), the neighbour consistency of :mod:`poseonly.robust.consistency`, and the consistency with
the ratio breaking ties (``consistency_k > 0``). Also on the hard versions of the pairs that
``benchmarks/hard_pair_time.py`` builds (wrong matches added to an 8 % truth share). Mean AUC per
dataset.

    python benchmarks/consistency_auc.py /work/shared/data/strecha/Herz-Jesus-P8 /work/shared/data/strecha/entry-P10 \\
        /work/shared/data/strecha/fountain-P11 /work/shared/data/realpairs/middlebury_temple /work/shared/data/realpairs/kitti_seq1
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import hard_pair_time  # noqa: E402


def roc_auc(score: np.ndarray, label: np.ndarray) -> float:
    """P(score of a random positive > score of a random negative), ties counted half (Mann-Whitney)."""
    from scipy.stats import rankdata

    r = rankdata(score)
    n1 = int(label.sum())
    n0 = len(label) - n1
    return float((r[label].sum() - n1 * (n1 + 1) / 2) / max(n1 * n0, 1))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("dirs", nargs="+")
    ap.add_argument("--cache", default="/tmp/realbench_cache")
    ap.add_argument("--k", type=int, default=10, help="neighbours per view")
    args = ap.parse_args(argv)

    from poseonly.experiments.real_bench import GT_PX, load_datasets, pair_match_data
    from poseonly.features import sampson_error_px
    from poseonly.geometry import bearings_from_pixels
    from poseonly.robust.consistency import consistency_order_scores, neighbour_consistency

    rng = np.random.default_rng(hard_pair_time.AUG_SEED)
    rows: dict[str, list[tuple[float, float, float, float]]] = {}
    for name, pairs in load_datasets(args.dirs).items():
        for p in pairs:
            u1, u2, r, sc = pair_match_data(p, Path(args.cache))
            if len(u1) < 30:
                continue
            err = sampson_error_px(u1, u2, p.K1, p.K2, p.R, p.t)
            on = err < GT_PX
            if on.sum() < 15 or on.all():
                continue
            cases = {name: (u1, u2, r)}
            if on.sum() >= 30 and on.mean() <= 0.3:
                a1, a2, ar, _ = hard_pair_time.augment(u1, u2, r, sc, on, err, 0.08, rng, lambda a, b, p=p: sampson_error_px(a, b, p.K1, p.K2, p.R, p.t))
                cases[f"{name}, 8 % inliers"] = (a1, a2, ar)
            for key, (a1, a2, ar) in cases.items():
                y = sampson_error_px(a1, a2, p.K1, p.K2, p.R, p.t) < GT_PX
                f1, f2 = bearings_from_pixels(a1, p.K1), bearings_from_pixels(a2, p.K2)
                s = 1.0 - ar
                c = neighbour_consistency(f1, f2, args.k)
                both = consistency_order_scores(f1, f2, s, args.k)
                rows.setdefault(key, []).append((roc_auc(s, y), roc_auc(c, y), roc_auc(both, y), float(y.mean())))
    print(f"ROC AUC of the sampling orders against 'within {GT_PX:g} px of the ground truth' (k = {args.k}; `python benchmarks/consistency_auc.py {' '.join(args.dirs)}`)\n")
    print("| pairs | n | truth share | 1 - ratio | consistency | consistency, then ratio |")
    print("|---|---|---|---|---|---|")
    for key, v in rows.items():
        a = np.asarray(v)
        print(f"| {key} | {len(a)} | {a[:, 3].mean():.2f} | {a[:, 0].mean():.3f} | {a[:, 1].mean():.3f} | {a[:, 2].mean():.3f} |")
    return 0


if __name__ == "__main__":
    from poseonly.experiments.report import provenance

    print(provenance(), flush=True)
    raise SystemExit(main())
