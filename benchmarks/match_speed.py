"""Descriptor matching: :func:`poseonly.features.match_features` against the OpenCV reference it
replaced (``cv2.batchDistance`` both ways, tests/reference/ratio_matching.py), side by side in one
process on real SIFT features.

    python benchmarks/match_speed.py DIR [DIR ...] [--max-features 8000] [--pairs 20] [--cache /tmp/match_speed_cache]

For Strecha-style folders (``DIR/images/*.jpg``): SIFT features (cached), then ``--pairs`` pairs per
folder (consecutive images, and as many across folders: no overlap), each matched by both with the
ratio 0.8 and the mutual check (the ``poseonly sfm`` settings), alternating which goes first. Prints
the median time of each and their ratio, and the agreement: matches found by only one of them, and
the largest score difference on the common matches.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("dirs", nargs="+")
    ap.add_argument("--max-features", type=int, default=8000)
    ap.add_argument("--pairs", type=int, default=20)
    ap.add_argument("--cache", default="/tmp/match_speed_cache")
    a = ap.parse_args(argv)
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
    from poseonly.features import extract_features, match_features
    from reference.ratio_matching import match_features_batchdistance

    scenes = [sorted((Path(d) / "images").glob("*.jpg")) for d in a.dirs]
    feats = {p: extract_features(p, max_features=a.max_features, cache_dir=a.cache) for ims in scenes for p in ims}
    pairs = []
    for ims in scenes:
        pairs += [("overlap", ims[k], ims[k + 1]) for k in range(min(a.pairs, len(ims) - 1))]
    for s, ims in enumerate(scenes):
        other = scenes[(s + 1) % len(scenes)]
        if other is not ims:
            pairs += [("no overlap", ims[k % len(ims)], other[k % len(other)]) for k in range(min(a.pairs, len(ims)))]
    rows: dict[str, list[tuple[float, float, int, int, int, float]]] = {}
    for k, (kind, p, q) in enumerate(pairs):
        d1, d2 = feats[p].descriptors, feats[q].descriptors
        runs = {}
        for name in ("new", "ref") if k % 2 == 0 else ("ref", "new"):
            t0 = time.perf_counter()
            if name == "new":
                runs[name] = match_features(d1, d2, ratio=0.8, mutual=True, return_scores=True)
            else:
                runs[name] = match_features_batchdistance(d1, d2, ratio=0.8, mutual=True)
            runs[name] = (*runs[name], time.perf_counter() - t0)
        (i_new, s_new, t_new), (i_ref, s_ref, t_ref) = runs["new"], runs["ref"]
        sn, sr = set(map(tuple, i_new)), set(map(tuple, i_ref))
        common = np.array(sorted(sn & sr)).reshape(-1, 2)
        dmax = 0.0
        if len(common):
            a_ = s_new[np.searchsorted(i_new[:, 0], common[:, 0])]
            b_ = s_ref[np.searchsorted(i_ref[:, 0], common[:, 0])]
            dmax = float(np.max(np.abs(a_ - b_)))
        rows.setdefault(kind, []).append((t_new, t_ref, len(sr), len(sn - sr), len(sr - sn), dmax))
    head = ["median features", "match_features s", "batchDistance both ways s", "ratio", "matches (ref)", "only new", "only ref", "max score diff"]
    print(f"| pairs ({a.max_features} features max) | n | " + " | ".join(head) + " |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    nf = int(np.median([len(f.descriptors) for f in feats.values()]))
    for kind, r in rows.items():
        x = np.array(r)
        print(
            f"| {kind} | {len(r)} | {nf} | {np.median(x[:, 0]):.3f} | {np.median(x[:, 1]):.3f} | {np.median(x[:, 0] / x[:, 1]):.2f} | "
            f"{int(x[:, 2].sum())} | {int(x[:, 3].sum())} | {int(x[:, 4].sum())} | {x[:, 5].max():.1e} |"
        )
    return 0


if __name__ == "__main__":
    from poseonly.experiments.report import provenance

    print(provenance(), flush=True)
    raise SystemExit(main())
