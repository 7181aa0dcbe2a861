"""One pair of another front-end (``real_frontends.py``'s ORB or resized SIFT) under the microscope:
how many matches the truth and the default's pose each explain, and the Lowe ratios of the matches
only one of them explains.

Used to tell whether a wrong ``ok`` pose is a search failure (the truth explains clearly more matches)
or the data's preference (the wrong pose explains more matches than the truth, so no two-view test on
these matches can prefer the truth), and whether the matches' distinctiveness (the ratio) would:

    python benchmarks/frontend_pair_probe.py /work/shared/data/strecha/entry-P10 2-8 4-8 4-9 --front-end orb --seeds 2
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

GT_PX = 1.0  # a match is on a geometry within this Sampson error (pixels)
DISTINCT_RATIO = 0.7  # a match whose Lowe ratio is below this is called distinctive


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("dataset", help="a realpairs dataset folder or a Strecha scene folder")
    ap.add_argument("pairs", nargs="+", help="pair ids as the benchmark names them (Strecha: 'i-j')")
    ap.add_argument("--front-end", default="orb")
    ap.add_argument("--seeds", type=int, default=2)
    ap.add_argument("--cache", default="/tmp/frontend_cache", help="real_frontends.py's feature cache")
    a = ap.parse_args(argv)
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    import real_frontends as RF

    import poseonly
    from poseonly.experiments import real_bench as RB
    from poseonly.features import sampson_error_px
    from poseonly.geometry import rotation_error_deg

    ds = RB.load_datasets([a.dataset])
    by_id = {p.pid: p for g in ds.values() for p in g}
    cache = Path(a.cache)
    for pid in a.pairs:
        if pid not in by_id:
            ap.error(f"no pair {pid!r} in {a.dataset}")
        p = by_id[pid]
        k1, d1, s1 = RF.features(Path(p.im1), a.front_end, cache)
        k2, d2, s2 = RF.features(Path(p.im2), a.front_end, cache)
        idx, ratio = RF.ratio_matches(d1, d2)
        u1, u2 = k1[idx[:, 0]], k2[idx[:, 1]]
        gt = sampson_error_px(u1, u2, p.K1, p.K2, p.R, p.t) < GT_PX
        print(f"{p.dataset} {pid} ({a.front_end}): {len(u1)} matches, {int(gt.sum())} within {GT_PX:g} px of the truth")
        for s in range(a.seeds):
            r = poseonly.estimate_relative_pose(u1, u2, p.K1, p.K2, scores=1 - ratio, noise_scales=np.sqrt(s1[idx[:, 0]] * s2[idx[:, 1]]), seed=s)
            if r.R is None or r.t is None:
                print(f"  seed {s}: {r.status}, no pose")
                continue
            est = sampson_error_px(u1, u2, p.K1, p.K2, r.R, r.t) < GT_PX
            parts = []
            for name, m in (("only the pose", est & ~gt), ("only the truth", gt & ~est), ("both", est & gt)):
                share = float(np.mean(ratio[m] < DISTINCT_RATIO)) if m.any() else float("nan")
                parts.append(f"{name} {int(m.sum())} (ratio < {DISTINCT_RATIO:g}: {share:.2f})")
            print(f"  seed {s}: {r.status:<16} R err {rotation_error_deg(r.R, p.R):6.2f} deg; within {GT_PX:g} px: " + ", ".join(parts))
    return 0


if __name__ == "__main__":
    from poseonly.experiments.report import provenance

    print(provenance(), flush=True)
    raise SystemExit(main())
