"""The default's predicted rotation uncertainty against its real errors (the status ``uncertain``).

For every pair of the given ``poseonly bench real`` dataset folders (cached SIFT matches, scores and
noise scales as the bench passes them), seeds 0..S-1: the default's status, rotation error and
``diagnostics["rotation_std_deg"]`` (first-order, :func:`poseonly.analysis.pose_uncertainty`). Prints per
dataset the deviations of the poses that pass every other test (``ok`` or ``uncertain``), the quantiles
of error / deviation, and for a few bounds ``max_rotation_std_deg`` the poses more than 5 deg off that
would stay ``ok`` and the pairs where PoseLib's error is below 2 deg (``--poselib``) that would lose ``ok``.

    python benchmarks/pose_uncertainty_real.py $S/Herz-Jesus-P8 $S/entry-P10 $S/fountain-P11 \\
        $P/middlebury_temple $P/kitti_seq1 --seeds 1 --poselib
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

BOUNDS = (1.0, 5.0 / 3.0, 2.0, 3.0)
WRONG_DEG = 5.0
GOOD_DEG = 2.0


def main(argv: list[str] | None = None) -> int:
    from poseonly import estimate_relative_pose
    from poseonly.anchors import poselib_relpose
    from poseonly.experiments.real_bench import MethodOutput, _errors, load_datasets, pair_match_data

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("dirs", nargs="+")
    ap.add_argument("--seeds", type=int, default=1)
    ap.add_argument("--cache", default="/tmp/realbench_cache")
    ap.add_argument("--poselib", action="store_true", help="also run PoseLib 1 px (the kept-ok count)")
    a = ap.parse_args(argv)
    for name, pairs in load_datasets(a.dirs).items():
        rows = []
        for p in pairs:
            u1, u2, ratio, sc = pair_match_data(p, Path(a.cache))
            if len(u1) < 8:
                continue
            for s in range(a.seeds):
                r = estimate_relative_pose(u1, u2, p.K1, p.K2, seed=s, scores=1.0 - ratio, noise_scales=sc, max_rotation_std_deg=180.0)
                if r.status != "ok":  # every other test failed: not the uncertainty's decision
                    continue
                er, _ = _errors(p, MethodOutput(r.R, r.t, r.inliers, r.status))
                pl = np.inf
                if a.poselib:
                    R, t, inl, _ = poselib_relpose(u1, u2, p.K1, p.K2, threshold_px=1.0, seed=s)
                    pl, _ = _errors(p, MethodOutput(R, t, inl, None))
                rows.append((p.pid, s, er, float(r.diagnostics["rotation_std_deg"]), pl))
        if not rows:
            continue
        err = np.array([x[2] for x in rows])
        std = np.array([x[3] for x in rows])
        pl = np.array([x[4] for x in rows])
        z = err / std
        qs = " / ".join(f"{q:.2f}" for q in np.quantile(z, [0.5, 0.9, 0.99]))
        print(f"{name}: {len(rows)} poses passing the other tests; deviation median {np.median(std):.3f} max {std.max():.3f} deg; error / deviation quantiles 50 / 90 / 99 %: {qs}")
        for b in BOUNDS:
            keep = std <= b
            wrong = int(np.count_nonzero(keep & (err > WRONG_DEG)))
            lost = int(np.count_nonzero(~keep & (pl < GOOD_DEG))) if a.poselib else -1
            print(f"  bound {b:.3g} deg: ok {int(keep.sum())}, ok > {WRONG_DEG:g} deg {wrong}" + (f", PoseLib < {GOOD_DEG:g} deg but not ok {lost}" if a.poselib else ""))
        for pid, s, e, d, q in sorted(rows, key=lambda x: -x[3])[:6]:
            print(f"    {pid} seed {s}: error {e:.2f} deg, deviation {d:.2f} deg" + (f", PoseLib {q:.2f}" if a.poselib else ""))
    return 0


if __name__ == "__main__":
    from poseonly.experiments.report import provenance

    print(provenance(), flush=True)
    raise SystemExit(main())
