"""Ground-truth Sampson errors of real SIFT matches against the keypoints' scale.

Usage::

    python benchmarks/kp_scale_residuals.py [--pairs N] [--cache DIR] DATASET...

For the first ``N`` pairs of each dataset (``poseonly bench real``'s folders and its match cache:
OpenCV SIFT, ratio-0.8 matching, each match's noise scale ``sqrt(size1 * size2)`` of its
keypoints' sizes); the matches within ``WITHIN_PX``
of the ground-truth epipolar geometry are binned in quintiles of ``sqrt(size1 * size2)`` and the
robust spread of their Sampson errors (1.4826 x median |e|) is printed per bin. If a keypoint's
localisation error grows with its scale, the spread grows along the bins, and per-match noise
scales from keypoint sizes would be worth passing to the estimator.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from poseonly.experiments import real_bench as rb
from poseonly.features import sampson_error_px

WITHIN_PX = 2.0
MIN_PAIR = 30
QUANTILES = (0.0, 0.2, 0.4, 0.6, 0.8, 1.0)
MAD_TO_SIGMA = 1.4826


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("dirs", nargs="+")
    ap.add_argument("--pairs", type=int, default=1000)
    ap.add_argument("--cache", type=Path, default=Path("/tmp/realbench_cache"))
    a = ap.parse_args(argv)
    for name, pairs in rb.load_datasets(a.dirs).items():
        sz_all, err_all = [], []
        for p in pairs[: a.pairs]:
            u1, u2, _, scales = rb.pair_match_data(p, a.cache)
            if len(u1) < MIN_PAIR:
                continue
            e = sampson_error_px(u1, u2, p.K1, p.K2, p.R, p.t)
            m = e < WITHIN_PX
            if m.sum() < MIN_PAIR:
                continue
            sz_all.append(scales[m])
            err_all.append(e[m])
        if not sz_all:
            print(f"{name}: no pair with {MIN_PAIR} matches within {WITHIN_PX} px")
            continue
        sz, err = np.concatenate(sz_all), np.concatenate(err_all)
        qs = np.quantile(sz, QUANTILES)
        cells = []
        for lo, hi in zip(qs[:-1], qs[1:], strict=True):
            k = (sz >= lo) & (sz <= hi)
            cells.append(f"size {lo:.1f}-{hi:.1f}: {MAD_TO_SIGMA * np.median(err[k]):.3f} px")
        rho = np.corrcoef(np.log(sz), np.log(np.maximum(err, 1e-6)))[0, 1]
        print(f"{name} ({len(err)} matches): " + " | ".join(cells) + f" | corr(log size, log e) {rho:.3f}")


if __name__ == "__main__":
    from poseonly.experiments.report import provenance

    print(provenance(), flush=True)
    main()
