"""Short baselines from real matches: KITTI frame-to-frame flow scaled down, with 0.3 px noise.

A VO user's trial: SIFT matches of consecutive KITTI seq1 frames (gap 1, ~1.2 m apart), their flow
``u2 - u1`` scaled by ``s`` (``v2 = u1 + s (u2 - u1)``: the same epipole, a baseline ``s`` times as long,
the rotation scaled to first order) plus Gaussian noise of ``--noise`` px in view 2. The truth is the
pair's translation direction (rotation: its rotation vector times ``s``). Per scale: poseonly's statuses,
its median translation-direction error and rotation error, the largest translation error of an ``ok``
pose and how many ``ok`` poses are more than 5 deg off; PoseLib (1 px) and OpenCV MAGSAC (1 px) on the
same matches. At ``s = 0.1`` one of ten ``ok`` poses was 43 deg off (seed 0; 6 of 28 over three seeds) before the far points of the
rival swap counted by their Sampson error alone (docs/RESULTS_real.md, "Far points in the pose
choices").

    python benchmarks/short_baseline_kitti.py /work/shared/data/realpairs/kitti_seq1
"""

from __future__ import annotations

import argparse
from collections import Counter

import numpy as np

WRONG_DEG = 5.0


def _sift_matches(p, cv2):
    sift, bf = cv2.SIFT_create(4000), cv2.BFMatcher(cv2.NORM_L2)
    (k1, d1), (k2, d2) = (sift.detectAndCompute(cv2.imread(str(im), cv2.IMREAD_GRAYSCALE), None) for im in (p.im1, p.im2))
    good = [a for a, b in bf.knnMatch(d1, d2, k=2) if a.distance < 0.8 * b.distance]
    return np.array([k1[m.queryIdx].pt for m in good]), np.array([k2[m.trainIdx].pt for m in good])


def _t_err(t, tg) -> float:
    if t is None or not np.all(np.isfinite(t)):
        return float("nan")
    return float(np.degrees(np.arccos(np.clip(abs(np.ravel(t) @ tg) / np.linalg.norm(t), -1.0, 1.0))))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("kitti", help="the realpairs kitti_seq1 folder")
    ap.add_argument("--scales", type=float, nargs="+", default=[0.03, 0.1, 0.3], help="flow scales (default 0.03 0.1 0.3)")
    ap.add_argument("--pairs", type=int, default=10, help="gap-1 pairs, every fifth from the first (default 10)")
    ap.add_argument("--noise", type=float, default=0.3, help="noise added to view 2 (px, default 0.3)")
    ap.add_argument("--seed", type=int, default=0)
    a = ap.parse_args(argv)
    import cv2

    from poseonly import estimate_relative_pose, rotation_error_deg
    from poseonly.anchors import opencv_relpose, poselib_relpose
    from poseonly.experiments.real_bench import load_datasets

    # pair ids seq1_AAA_BBB: frames AAA and BBB
    pairs = [p for ps in load_datasets([a.kitti]).values() for p in ps if int(p.pid.split("_")[2]) - int(p.pid.split("_")[1]) == 1][::5][: a.pairs]
    data = [(p, *_sift_matches(p, cv2)) for p in pairs]
    for s in a.scales:
        st: Counter = Counter()
        rows = []
        for k, (p, u1, u2) in enumerate(data):
            v2 = u1 + s * (u2 - u1) + np.random.default_rng([a.seed, k]).normal(0.0, a.noise, u1.shape)
            tg = p.t / np.linalg.norm(p.t)
            Rs = cv2.Rodrigues(s * cv2.Rodrigues(p.R)[0])[0]
            r = estimate_relative_pose(u1, v2, p.K1, p.K2)
            st[r.status] += 1
            pl = poselib_relpose(u1, v2, p.K1, p.K2, threshold_px=1.0)
            cv = opencv_relpose(u1, v2, p.K1, p.K2, method="USAC_MAGSAC", threshold_px=1.0)
            rows.append((r.status, _t_err(r.t, tg), rotation_error_deg(Rs, r.R), _t_err(pl[1], tg), _t_err(cv[1], tg)))
        ok_err = [e for status, e, *_ in rows if status == "ok"]
        med = [float("nan"), *(float(np.nanmedian([row[j] for row in rows])) for j in range(1, 5))]
        print(
            f"s = {s:g}: {dict(sorted(st.items()))}; poseonly t err median {med[1]:.2f} deg (R {med[2]:.3f}), ok: largest t err "
            f"{max(ok_err) if ok_err else float('nan'):.2f}, {sum(e > WRONG_DEG for e in ok_err)} of {len(ok_err)} more than {WRONG_DEG:g} deg off"
            f" | PoseLib 1 px t err median {med[3]:.2f} | OpenCV MAGSAC 1 px {med[4]:.2f}",
            flush=True,
        )
    return 0


if __name__ == "__main__":
    from poseonly.experiments.report import provenance

    print(provenance(), flush=True)
    raise SystemExit(main())
