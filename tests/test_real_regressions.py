"""Seeded regressions on real pairs of the shared data (skipped where ../shared is absent).

entry-P10 views 4 and 9 (430 SIFT matches, 73 within 1 px of the true epipolar geometry): with
seeds 1 and 7 the search used to end on a locally optimised model of a wrong consensus (46 inliers,
2.37 deg off, status ``ok`` on seed 1) while a model of the right basin, 0.12 deg off, has the lower
cost under the search's own objective; its raw minimal models never beat the wrong optimised one,
and LO runs only on new bests. The challengers of the search (``PoseonlyOptions.challengers``) find
it on every seed (docs/history/RESULTS_real_sessions.md).
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest

from poseonly import estimate_relative_pose
from poseonly.experiments import real_bench as rb

STRECHA = Path(os.environ.get("POSEONLY_STRECHA", Path(__file__).resolve().parents[2] / "shared/data/strecha"))
if not STRECHA.is_dir():
    STRECHA = Path("/work/shared/data/strecha")
P10 = STRECHA / "entry-P10"


def _angle_deg(R: np.ndarray, R_gt: np.ndarray) -> float:
    return float(np.degrees(np.arccos(np.clip((np.trace(R @ R_gt.T) - 1.0) / 2.0, -1.0, 1.0))))


@pytest.mark.skipif(not P10.is_dir(), reason="shared Strecha data not available")
def test_entry_p10_4_9_search_is_not_stuck_on_a_wrong_consensus(tmp_path: Path) -> None:
    pytest.importorskip("cv2")
    pair = next(p for p in rb.load_datasets([P10])["entry-P10"] if p.pid == "4-9")
    u1, u2, ratio, scales = rb.pair_match_data(pair, tmp_path)
    for seed in (1, 7):
        kw = dict(scores=1.0 - ratio, noise_scales=scales, seed=seed)
        r = estimate_relative_pose(u1, u2, pair.K1, pair.K2, **kw)
        assert _angle_deg(r.R, pair.R) < 0.5, seed
        assert r.num_inliers >= 60
        # never a worse search under its own objective than without the challengers
        old = estimate_relative_pose(u1, u2, pair.K1, pair.K2, challengers=0, **kw)
        assert r.diagnostics["ransac_score"] <= old.diagnostics["ransac_score"]


P8 = STRECHA / "Herz-Jesus-P8"


@pytest.mark.skipif(not P8.is_dir(), reason="shared Strecha data not available")
def test_herz_jesus_p8_0_6_no_consensus_of_one_keypoint(tmp_path: Path) -> None:
    """Herz-Jesus-P8 views 0 and 6 (175 matches, 19 within 1 px of the true epipolar geometry): seven
    keypoints of view 0 were matched to one keypoint of view 6; a model with its epipole there gives
    them a zero epipolar error, and with every match scored the search ended on such models, 80-130 deg
    off, on every seed. With the matches of a shared keypoint scored once (``keypoint_once``, the
    default since the ninth session; src/core/conflicts.h) no seed ends there; the pair stays hard
    (19 true matches of 175), and an ``ok`` pose is a right one."""
    pytest.importorskip("cv2")
    pair = next(p for p in rb.load_datasets([P8])["Herz-Jesus-P8"] if p.pid == "0-6")
    u1, u2, ratio, scales = rb.pair_match_data(pair, tmp_path)
    errs, statuses = [], []
    for seed in range(6):
        r = estimate_relative_pose(u1, u2, pair.K1, pair.K2, scores=1.0 - ratio, noise_scales=scales, seed=seed)
        errs.append(_angle_deg(r.R, pair.R))
        statuses.append(r.status)
    assert max(errs) < 30.0, errs
    # no pose more than 2 deg off is called ok; the seeds do end off (measured 1.2-15.9 deg: ambiguous
    # on four seeds, too_few_inliers on two), so this checks the statuses of wrong poses
    assert all(s != "ok" or e < 2.0 for s, e in zip(statuses, errs)), list(zip(statuses, errs))
    assert sum(e > 2.0 for e in errs) >= 2, errs
