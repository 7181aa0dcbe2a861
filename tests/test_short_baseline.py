"""Short baselines: far points' cheirality is the noise's (the rival swap of
``poseonly.robust.default._better_rival`` counts them as the uniqueness test does). A VO trial scaled
KITTI's frame-to-frame flow to a 12 cm baseline: poses 25-60 deg off in translation were ``ok``, with
deviations of a few tenths of a degree, because a pose that trades 0.4 deg of rotation for a wrong
translation gives the far points parallax of consistent sign, while about half of them triangulate
behind the true pose."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from poseonly import estimate_relative_pose

KITTI = Path(__file__).resolve().parents[2] / "shared" / "data" / "realpairs" / "kitti_seq1"
FLOW_SCALE = 0.1  # the frame-to-frame flow scaled to a tenth: a 12 cm baseline
NOISE_PX = 0.3
WRONG_T_DEG = 5.0


def _kitti_sift(pid: str):
    cv2 = pytest.importorskip("cv2")
    from poseonly.experiments.real_bench import load_datasets

    if not (KITTI / "pairs.txt").is_file():
        pytest.skip("../shared/data/realpairs/kitti_seq1 is not here")
    pairs = [p for ps in load_datasets([str(KITTI)]).values() for p in ps if p.pid == pid]
    if not pairs:
        pytest.skip(f"pair {pid} is not in the KITTI folder")
    p = pairs[0]
    sift, bf = cv2.SIFT_create(4000), cv2.BFMatcher(cv2.NORM_L2)
    (k1, d1), (k2, d2) = (sift.detectAndCompute(cv2.imread(str(im), cv2.IMREAD_GRAYSCALE), None) for im in (p.im1, p.im2))
    good = [a for a, b in bf.knnMatch(d1, d2, k=2) if a.distance < 0.8 * b.distance]
    u1 = np.array([k1[m.queryIdx].pt for m in good])
    u2 = np.array([k2[m.trainIdx].pt for m in good])
    return p, u1, u2


@pytest.mark.parametrize(("pid", "seed"), [("seq1_015_016", 2), ("seq1_035_036", 0)])
def test_short_baseline_kitti_translation_is_not_tens_of_degrees_off(pid, seed):
    """Measured before the fix: 50.6 and 26.1 deg off, both ``ok``; after: 0.9 and 1.2 deg. (seq1_010_011
    with seed 0 stays 59.9 deg off, ``ok``: there the wrong pose also scores better by the cheirality-aware
    MSAC score; counting far points by their Sampson error in that score too fixed it but made the
    pose's R follow the rotation-only fit on small baselines, below its stated deviation:
    docs/RESULTS_real.md, "Far points in the pose choices".)"""
    p, u1, u2 = _kitti_sift(pid)
    v2 = u1 + FLOW_SCALE * (u2 - u1) + np.random.default_rng(seed).normal(0.0, NOISE_PX, u1.shape)
    r = estimate_relative_pose(u1, v2, p.K1, p.K2)
    err = np.degrees(np.arccos(np.clip(abs(r.t @ p.t) / np.linalg.norm(p.t), -1.0, 1.0)))
    assert err < WRONG_T_DEG, (r.status, err, r.message)
