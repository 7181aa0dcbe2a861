"""Frame-to-frame relative pose on consecutive KITTI frames, as a monocular VO front-end uses it.

ORB (3000 features, brute-force Hamming with cross-check, OpenCV's defaults otherwise) or SIFT (3000,
ratio 0.8) on every pair of ``pairs.json`` with ``meta.gap == 1`` of a realpairs folder (format:
../shared/data/realpairs/README.md), then the default, the video-rate options (``ml_folds=0,
challengers=0, min_iterations=100``), OpenCV's USAC_MAGSAC and PoseLib (1 px) on the same matches:
rotation / translation-direction errors against the ground truth (median, mean, max), statuses and
time per pair (the methods one after another in this process; timing on a shared machine is rough).

    python benchmarks/vo_frames.py /work/shared/data/realpairs/kitti_seq1 --features orb
    python benchmarks/vo_frames.py /work/shared/data/realpairs/kitti_seq1 --features sift --round   # rounded keypoints

A VO trial's script (2026-12-07), which found the video-rate options returning 3 of 50 ORB poses
5-11 deg off (flagged) before a refined rival that beats the search's pose replaced it.
"""

from __future__ import annotations

import argparse
import json
import time
from collections import Counter
from pathlib import Path

import numpy as np


def _matches(cv2, kind: str, img1, img2):
    det = cv2.ORB_create(3000) if kind == "orb" else cv2.SIFT_create(3000)
    (k1, d1), (k2, d2) = det.detectAndCompute(img1, None), det.detectAndCompute(img2, None)
    if kind == "orb":
        ms = cv2.BFMatcher(cv2.NORM_HAMMING, crossCheck=True).match(d1, d2)
    else:
        ms = [m for m, n in cv2.BFMatcher(cv2.NORM_L2).knnMatch(d1, d2, k=2) if m.distance < 0.8 * n.distance]
    return np.float64([k1[m.queryIdx].pt for m in ms]), np.float64([k2[m.trainIdx].pt for m in ms])


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("folder", help="a realpairs folder (pairs.json, images/)")
    ap.add_argument("--features", default="orb", choices=("orb", "sift"))
    ap.add_argument("--pairs", type=int, default=50, help="the first N consecutive pairs")
    ap.add_argument("--round", action="store_true", help="round the keypoints to whole pixels (as FAST / SuperPoint / ORB's first level give them)")
    a = ap.parse_args(argv)
    import cv2
    import poselib

    import poseonly
    from poseonly.geometry import rotation_error_deg, translation_error_deg

    folder = Path(a.folder)
    pairs = [p for p in json.loads((folder / "pairs.json").read_text())["pairs"] if p["meta"].get("gap") == 1][: a.pairs]
    data = []
    for p in pairs:
        u1, u2 = _matches(cv2, a.features, cv2.imread(str(folder / p["im1"]), 0), cv2.imread(str(folder / p["im2"]), 0))
        if a.round:
            u1, u2 = np.round(u1), np.round(u2)
        data.append((u1, u2, np.array(p["K1"]), np.array(p["R"]), np.array(p["t"]), p["size1"]))

    def po(**opts):
        def run(u1, u2, K, size):
            r = poseonly.estimate_relative_pose(u1, u2, K, **opts)
            return r.R, r.t, r.status

        return run

    def magsac(u1, u2, K, size):
        E, mask = cv2.findEssentialMat(u1, u2, K, cv2.USAC_MAGSAC, 0.999, 1.0)
        if E is None or E.shape != (3, 3):
            return None, None, "no E"
        _, R, t, _ = cv2.recoverPose(E, u1, u2, K, mask=mask)
        return R, t.ravel(), "-"

    def pl(u1, u2, K, size):
        cam = {"model": "PINHOLE", "width": int(size[0]), "height": int(size[1]), "params": [K[0, 0], K[1, 1], K[0, 2], K[1, 2]]}
        pose, _ = poselib.estimate_relative_pose(u1, u2, cam, cam, {"max_epipolar_error": 1.0}, {})
        return pose.R, pose.t, "-"

    methods = {"poseonly": po(), "poseonly-video": po(ml_folds=0, challengers=0, min_iterations=100), "opencv-magsac": magsac, "poselib-1px": pl}
    kind = a.features + (" rounded to whole pixels" if a.round else "")
    print(f"{len(data)} consecutive pairs of {folder.name}, {kind}: median {int(np.median([len(d[0]) for d in data]))} matches")
    for name, fn in methods.items():
        re, te, ms, st = [], [], [], Counter()
        for u1, u2, K, R, t, size in data:
            t0 = time.perf_counter()
            Re, tr, s = fn(u1, u2, K, size)
            ms.append(1e3 * (time.perf_counter() - t0))
            st[s] += 1
            re.append(rotation_error_deg(R, Re) if Re is not None else np.nan)
            te.append(translation_error_deg(t, tr) if tr is not None else np.nan)
        r, d = np.array(re), np.array(te)
        stat = "" if name.startswith(("opencv", "poselib")) else f"  statuses {dict(st)}"
        print(
            f"{name:15s} R err median {np.nanmedian(r):.4f} mean {np.nanmean(r):.4f} max {np.nanmax(r):.3f} deg | t dir median {np.nanmedian(d):.3f} "
            f"max {np.nanmax(d):.2f} deg | {np.median(ms):.1f} ms median{stat}"
        )
    return 0


if __name__ == "__main__":
    from poseonly.experiments.report import provenance

    print(provenance(), flush=True)
    raise SystemExit(main())
