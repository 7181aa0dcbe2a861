"""Status and errors of the default method on a subset of /work/shared/data/realpairs (every k-th pair).

Prints one line per pair: dataset, pair id, status, inliers, matches, rotation and translation
direction errors (deg). Used to check that a change of the status logic keeps the statuses of real
pairs (docs/RELIABILITY.md).

    python benchmarks/realpairs_status.py --cache /tmp/realpairs_cache
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--root", type=Path, default=Path("/work/shared/data/realpairs"))
    ap.add_argument("--per-dataset", type=int, default=15)
    ap.add_argument("--cache", default=None, help="feature cache directory")
    a = ap.parse_args(argv)
    from poseonly.geometry import rotation_error_deg, translation_error_deg
    from poseonly.pipeline import relpose_images

    if not a.root.is_dir():
        print(f"no data at {a.root}", file=sys.stderr)
        return 1
    for ds in ("kitti_seq1", "middlebury_temple"):
        pairs = json.loads((a.root / ds / "pairs.json").read_text())["pairs"]
        for p in pairs[:: max(1, len(pairs) // a.per_dataset)][: a.per_dataset]:
            pr = relpose_images(a.root / ds / p["im1"], a.root / ds / p["im2"], np.array(p["K1"]), np.array(p["K2"]), cache_dir=a.cache)
            r = pr.result
            er = float(rotation_error_deg(np.array(p["R"]), r.R)) if r.R is not None else float("nan")
            et = float(translation_error_deg(np.array(p["t"]), r.t)) if r.t is not None else float("nan")
            print(ds, p["id"], r.status, r.num_inliers, len(pr.u1), f"{er:.4f}", f"{et:.4f}", flush=True)
    return 0


if __name__ == "__main__":
    from poseonly.experiments.report import provenance

    print(provenance(), flush=True)
    sys.exit(main())
