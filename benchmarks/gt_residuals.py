"""Ground-truth Sampson errors of a real dataset's matches against the image radius.

Usage::

    python benchmarks/gt_residuals.py /work/shared/data/strecha/fountain-P11 /work/shared/data/realpairs/kitti_seq1

For every pair of each dataset (``poseonly bench real``'s folders and match cache), the matches
within ``WITHIN_PX`` of the ground-truth epipolar geometry; prints their median Sampson error (px)
in quintiles of the first image's radius ``|u - c| / f``. A radial trend would point at an
unmodelled lens distortion.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from poseonly.experiments import real_bench as rb
from poseonly.features import sampson_error_px

WITHIN_PX = 2.0
MIN_PAIR = 30  # pairs with fewer such matches are skipped
CACHE = Path("/tmp/realbench_cache")
QUANTILES = (0.0, 0.2, 0.4, 0.6, 0.8, 1.0)


def main(dirs: list[str]) -> None:
    for name, pairs in rb.load_datasets(dirs).items():
        rad_all, err_all = [], []
        for p in pairs:
            u1, u2, _ = rb.pair_matches(p, CACHE)
            if len(u1) < MIN_PAIR:
                continue
            e = sampson_error_px(u1, u2, p.K1, p.K2, p.R, p.t)
            m = e < WITHIN_PX
            if m.sum() < MIN_PAIR:
                continue
            rad = np.linalg.norm(u1 - p.K1[:2, 2], axis=1) / p.K1[0, 0]
            rad_all.append(rad[m])
            err_all.append(e[m])
        rad, err = np.concatenate(rad_all), np.concatenate(err_all)
        qs = np.quantile(rad, QUANTILES)
        cells = []
        for a, b in zip(qs[:-1], qs[1:], strict=True):
            k = (rad >= a) & (rad <= b)
            cells.append(f"r/f {a:.2f}-{b:.2f}: {np.median(err[k]):.3f} px")
        print(f"{name}: " + " | ".join(cells))


if __name__ == "__main__":
    from poseonly.experiments.report import provenance

    print(provenance(), flush=True)
    main(sys.argv[1:])
