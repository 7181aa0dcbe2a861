"""LiGT on noise-free sparse scenes: every result it returns must be exact, the rest undetermined.

    python benchmarks/ligt_degenerate_sweep.py [--seeds 3]

Scenes of :func:`poseonly.sfm.synthetic.make_scene` with 5-50 views, 3-80 points, co-visibility
windows of 1-3 and tracks of 2-6 views, the true rotations: LiGT either returns centres (checked
against the truth up to translation and scale) or raises ``TranslationUndetermined``. Prints the
counts and any wrong result (docs/SFM.md quotes the counts).
"""

from __future__ import annotations

import argparse
import collections

import numpy as np

EXACT = 1e-6


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--seeds", type=int, default=3)
    a = p.parse_args(argv)
    from poseonly.sfm.ligt_global import TranslationUndetermined, ligt_positions
    from poseonly.sfm.synthetic import make_scene

    counts: collections.Counter[str] = collections.Counter()
    wrong = []
    for n in (5, 8, 10, 15, 20, 30, 50):
        for pts in (3, 5, 8, 12, 20, 40, 80):
            for win in (1, 2, 3):
                for max_track in (2, 3, 6):
                    for seed in range(a.seeds):
                        s = make_scene(n, pts, window=win, max_track=max_track, seed=seed)
                        try:
                            lg = ligt_positions(s.rotations, s.tracks, s.bearings)
                        except TranslationUndetermined:
                            counts["undetermined"] += 1
                            continue
                        A, B = lg.centres[lg.estimated], s.centres[lg.estimated]
                        A, B = A - A.mean(0), B - B.mean(0)
                        err = np.linalg.norm(np.sum(A * B) / np.sum(A * A) * A - B, axis=1).max() / np.linalg.norm(B, axis=1).max()
                        counts["exact" if err < EXACT else "wrong"] += 1
                        if err >= EXACT:
                            wrong.append(((n, pts, win, max_track, seed), float(err)))
    print(f"{sum(counts.values())} scenes: {counts['exact']} exact, {counts['undetermined']} undetermined, {counts['wrong']} wrong")
    for case, err in wrong:
        print(f"  wrong: views {case[0]}, points {case[1]}, window {case[2]}, max track {case[3]}, seed {case[4]}: {err:.3g} of the extent")
    return 0


if __name__ == "__main__":
    from poseonly.experiments.report import provenance

    print(provenance(), flush=True)
    raise SystemExit(main())
