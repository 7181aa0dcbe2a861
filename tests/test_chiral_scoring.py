"""The search's cheirality-aware scoring (``PoseonlyOptions.chiral_scoring``, the core's
``ChiralScorer``): a match whose point a hypothesis puts behind either camera scores as an outlier."""

from __future__ import annotations

import numpy as np

from poseonly import estimate_relative_pose
from poseonly.geometry import rotation_error_deg
from poseonly.robust.ransac import ransac_relpose
from poseonly.sim import make_scene

TAU = 1.0 / 800.0


def _mixed(seed: int):
    """100 matches of pose P in front of both cameras, and 160 of a second pose Q of which half are
    sign-flipped (they satisfy Q's epipolar constraint with their points behind both cameras)."""
    p = make_scene(100, "normal", "pinhole", 0.3, 0.0, seed=seed)
    q = make_scene(160, "normal", "pinhole", 0.3, 0.0, seed=500 + seed)
    s = np.where(np.arange(160) % 2 == 0, 1.0, -1.0)[:, None]
    f1 = np.r_[p.f1, s * q.f1]
    f2 = np.r_[p.f2, s * q.f2]
    return p, q, f1, f2


def test_chiral_scoring_prefers_the_pose_whose_points_are_in_front():
    for seed in range(3):
        p, q, f1, f2 = _mixed(seed)
        assert rotation_error_deg(p.R, q.R) > 5
        plain = ransac_relpose(f1, f2, TAU, seed, min_iterations=300, chiral=False)
        chiral = ransac_relpose(f1, f2, TAU, seed, min_iterations=300, chiral=True)
        # the plain Sampson score counts Q's 160 matches, the cheirality-aware one 80 of them
        assert rotation_error_deg(q.R, plain.R) < 1.0
        assert rotation_error_deg(p.R, chiral.R) < 1.0
        assert np.isfinite(chiral.score) and chiral.score > plain.score


def test_chiral_scoring_changes_nothing_on_a_clean_scene():
    for seed in range(3):
        sc = make_scene(300, "normal", "pinhole", 0.5, 0.5, seed=seed)
        a = estimate_relative_pose(sc.u1, sc.u2, sc.K, seed=seed, chiral_scoring=False)
        b = estimate_relative_pose(sc.u1, sc.u2, sc.K, seed=seed)  # the default: on
        assert a.status == b.status == "ok"
        assert rotation_error_deg(a.R, b.R) < 0.05 and rotation_error_deg(sc.R, b.R) < 0.5
