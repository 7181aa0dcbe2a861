"""The default method's uniqueness test (status ``ambiguous``): a second pose far from the result that
explains about as many matches of its own (``poseonly.analysis.rival_test``)."""

from __future__ import annotations

import numpy as np
import pytest

from poseonly import estimate_relative_pose
from poseonly.analysis import AMBIGUITY_LEVEL, rival_test, sign_test
from poseonly.geometry import rotation_error_deg
from poseonly.sim import make_scene


def _two_motions(seed: int):
    """Two independent scenes of 150 matches each (0.5 px, 20 % outliers): two camera motions with the
    same support."""
    a = make_scene(150, "normal", "pinhole", 0.5, 0.2, seed=seed)
    b = make_scene(150, "normal", "pinhole", 0.5, 0.2, seed=100 + seed)
    return a, b, np.r_[a.u1, b.u1], np.r_[a.u2, b.u2]


@pytest.mark.parametrize("seed", [1, 2, 4])
def test_two_equally_supported_motions_are_ambiguous(seed):
    a, b, u1, u2 = _two_motions(seed)
    assert rotation_error_deg(a.R, b.R) > 10
    r = estimate_relative_pose(u1, u2, a.K, seed=seed)
    assert r.status == "ambiguous", r.message
    assert "second pose" in r.message
    # the pose is one of the motions and the reported rival the other
    errs = sorted([rotation_error_deg(a.R, r.R), rotation_error_deg(b.R, r.R)])
    assert errs[0] < 1.0
    rv = r.diagnostics["rival_R"]
    assert min(rotation_error_deg(a.R, rv), rotation_error_deg(b.R, rv)) < 1.0
    assert rotation_error_deg(r.R, rv) > 10
    assert r.diagnostics["rival_log10_p"] >= np.log10(AMBIGUITY_LEVEL)
    # the test off: the same pose with status ok
    r0 = estimate_relative_pose(u1, u2, a.K, seed=seed, rival_distance=0.0)
    assert r0.status == "ok" and "rival_R" not in r0.diagnostics
    assert rotation_error_deg(r0.R, r.R) < 1e-9


@pytest.mark.parametrize("seed", [1, 2, 4])
def test_one_motion_is_not_ambiguous(seed):
    a = make_scene(300, "normal", "pinhole", 0.5, 0.4, seed=seed)
    r = estimate_relative_pose(a.u1, a.u2, a.K, seed=seed)
    assert r.status == "ok", r.message
    assert rotation_error_deg(a.R, r.R) < 0.5


def test_rival_test_decision():
    sc = make_scene(200, "normal", "pinhole", 0.0, 0.0, seed=3)
    tau = 1.0 / 800.0
    same = rival_test(sc.R, sc.t, sc.R, sc.t, sc.f1, sc.f2, tau, 5.0)
    assert not same["ambiguous"] and same["rival_separation_deg"] < 1e-6 and same["pose_only"] == same["rival_only"] == 0
    # a far pose that explains nothing: the sign test prefers the pose
    c, s = np.cos(0.5), np.sin(0.5)
    Rf = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]) @ sc.R
    far = rival_test(sc.R, sc.t, Rf, sc.t, sc.f1, sc.f2, tau, 5.0)
    assert not far["ambiguous"] and far["pose_only"] > 150 and far["rival_log10_p"] < -40
    assert far["rival_log10_p"] == pytest.approx(sign_test(far["pose_only"], far["rival_only"]))
    # the other way round: the pose is the one that explains nothing
    back = rival_test(Rf, sc.t, sc.R, sc.t, sc.f1, sc.f2, tau, 5.0)
    assert back["ambiguous"]
