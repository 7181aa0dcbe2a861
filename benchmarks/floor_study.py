"""Option variants of the default method over seeds on one realpairs dataset (the sample-floor study).

For each variant (a JSON list of option dicts) and seeds 0..S-1, the default method runs on every
pair of the dataset with the SIFT front-end's ratio scores and keypoint-size noise scales (the real benchmark's cached matches);
prints the mean over seeds of the median rotation error, of AUC@5/10/20 of max(rotation,
translation-direction error), the seed spread of AUC@10 and the median time per pair.

    python benchmarks/floor_study.py /work/shared/data/realpairs/middlebury_temple \\
        '[{}, {"min_iterations": 200}, {"min_iterations": 100}, {"min_iterations": 0}]' --cache /tmp/realbench_cache
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("dataset", type=Path, help="a dataset folder in the realpairs format")
    ap.add_argument("variants", help="JSON list of option dicts, e.g. '[{}, {\"min_iterations\": 0}]'")
    ap.add_argument("--seeds", type=int, default=5)
    ap.add_argument("--cache", type=Path, default=Path("/tmp/realbench_cache"), help="the real benchmark's match cache")
    a = ap.parse_args(argv)
    import poseonly
    from poseonly.experiments.real_bench import load_datasets, pair_match_data, pose_auc
    from poseonly.geometry import rotation_error_deg, translation_error_deg

    pairs = next(iter(load_datasets([str(a.dataset)]).values()))
    data = [(p, *pair_match_data(p, a.cache)) for p in pairs]
    for opts in json.loads(a.variants):
        meds, aucs, times = [], [], []
        for seed in range(a.seeds):
            e, te = [], []
            for p, u1, u2, ratio, scales in data:
                t0 = time.perf_counter()
                r = poseonly.estimate_relative_pose(u1, u2, p.K1, K2=p.K2, scores=1 - ratio, noise_scales=scales, seed=seed, **opts)
                times.append(time.perf_counter() - t0)
                e.append(rotation_error_deg(p.R, r.R) if r.R is not None else 180.0)
                te.append(float(translation_error_deg(p.t, r.t, sign_invariant=True)) if r.t is not None else 180.0)
            ea, ta = np.array(e), np.array(te)
            meds.append(float(np.median(ea)))
            aucs.append(pose_auc(np.maximum(ea, ta)))
        A = np.array(aucs)
        print(
            f"{json.dumps(opts):45s} median R {np.mean(meds):.4f}  AUC@5/10/20 {'/'.join(f'{x:.2f}' for x in A.mean(0))}"
            f"  AUC@10 std {A[:, 1].std():.2f}  time {1e3 * np.median(times):.1f} ms",
            flush=True,
        )
    return 0


if __name__ == "__main__":
    from poseonly.experiments.report import provenance

    print(provenance(), flush=True)
    raise SystemExit(main())
