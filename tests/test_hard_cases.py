"""Hard synthetic cases (issue 12): what a correct estimator must achieve on them.

The bounds are measured against PoseLib (``max_epipolar_error`` 1 px, its default) on the same
scenes, or against the first-order maximum-likelihood (Sampson) cost of the true inliers. Tests the current default
fails are marked ``xfail(strict=True, raises=AssertionError)``: they document the gap, fail the
run if they start passing (a new default that closes the gap must say so by removing the marker) and
count as expected failures only through their assertions (any other error fails them). Scenes are
kept small so the module stays fast.
"""

from __future__ import annotations

from functools import cache

import numpy as np
import pytest

from poseonly.api import estimate_relative_pose
from poseonly.features import sampson_error_px
from poseonly.geometry import rotation_error_deg, translation_error_deg
from poseonly.sim_hard import HardCase, low_parallax, repetitive_texture, second_motion, structured_first_scores

STRUCTURED = 1
RANDOM_GROUP = 2

REP_SEEDS = (0, 1, 2, 3)
# the accuracy comparison's scenes: on 4 the median swings by 1.4x between variants of the default
# that are equal over 24 (measured: seed 0 alone is 0.25 deg against PoseLib's 0.03)
REP_ACCURACY_SEEDS = tuple(range(16))
MOTION_SEEDS = (0, 1, 2, 3)
CLEAN_SEEDS = tuple(range(6))
LOWP_SCENE_SEED = 2  # a scene where the default's rotation depends on its seed (measured)
ESTIMATOR_SEEDS = (0, 1, 2, 3)


@cache
def _rep(seed: int) -> HardCase:
    return repetitive_texture(120, 90, 150, seed=seed)


@cache
def _motion(seed: int) -> HardCase:
    return second_motion(150, 110, 100, seed=seed)


@cache
def _lowp() -> HardCase:
    return low_parallax(300, 1.4, 0.6, seed=LOWP_SCENE_SEED)


@cache
def _clean(seed: int) -> HardCase:
    return low_parallax(200, 6.0, 0.0, seed=seed)


@cache
def _ours(case: str, scene: int, seed: int = 0):
    c = _scene(case, scene)
    r = estimate_relative_pose(c.u1, c.u2, c.K, c.K, seed=seed)
    return r.R, r.t, np.asarray(r.inliers, bool), r.status


@cache
def _poselib(case: str, scene: int, seed: int = 0):
    pytest.importorskip("poselib")
    from poseonly.anchors import poselib_relpose

    c = _scene(case, scene)
    R, t, inl, _ = poselib_relpose(c.u1, c.u2, c.K, c.K, threshold_px=1.0, seed=seed)
    return R, t, np.asarray(inl, bool), None


def _scene(case: str, scene: int) -> HardCase:
    return {"rep": _rep, "motion": _motion, "clean": _clean}[case](scene) if case != "lowp" else _lowp()


def _rerr(c: HardCase, R) -> float:
    return float(rotation_error_deg(c.R, R))


# ------------------------------------------------------------------------------------------------
# the generators


@pytest.mark.parametrize("make", [lambda s: repetitive_texture(seed=s), lambda s: second_motion(seed=s)])
def test_structured_outliers_follow_the_wrong_geometry(make):
    for s in range(3):
        c = make(s)
        e_true = sampson_error_px(c.u1, c.u2, c.K, c.K, c.R, c.t)
        e_wrong = sampson_error_px(c.u1, c.u2, c.K, c.K, c.R_wrong, c.t_wrong)
        st = c.group == STRUCTURED
        assert np.median(e_true[c.inliers]) < 0.5  # 0.3 px noise
        assert np.mean(e_wrong[st] < 1.0) > 0.97  # consistent with the second geometry ...
        assert np.mean(e_true[st] > 1.0) > 0.8  # ... and not with the true one
        # the wrong geometry is really different (translation for the facade, rotation for the object)
        assert max(float(translation_error_deg(c.t, c.t_wrong)), 10 * _rerr(c, c.R_wrong)) > 10.0


def test_generators_are_seeded_and_validate():
    for gen in (repetitive_texture, second_motion, low_parallax):
        a, b, d = gen(seed=5), gen(seed=5), gen(seed=6)
        np.testing.assert_array_equal(a.u1, b.u1)
        np.testing.assert_array_equal(a.group, b.group)
        assert not np.array_equal(a.u1, d.u1)
        with pytest.raises(ValueError):
            gen(noise_px=-1.0)
    with pytest.raises(ValueError):
        low_parallax(outlier_fraction=1.0)


def test_low_parallax_is_low():
    par = [low_parallax(seed=s).parallax_deg for s in range(6)]
    assert max(par) < 2.0 and min(par) > 0.2


# ------------------------------------------------------------------------------------------------
# what a correct estimator achieves


def test_repetitive_texture_never_returns_the_wrong_geometry():
    for s in REP_SEEDS:
        c = _rep(s)
        _, t, inl, status = _ours("rep", s)
        assert status == "ok"
        assert np.count_nonzero(inl & (c.group == STRUCTURED)) <= 2
        assert float(translation_error_deg(c.t, t)) < 3.0


MISLEADING_SCENES = tuple(range(6))


def test_repetitive_texture_with_misleading_scores():
    """Scores that rank the repeated facade's matches first (:func:`structured_first_scores`): the
    true geometry explains 120 matches and the wrong one 90, so the search's own objective prefers the
    truth; the default must return it, or not call the wrong one ``ok``. PROSAC's stopping rule
    certifies the best model only within the top of the score order, so with the structure ranked first
    it ended on its 90 matches (the wrong geometry `ok` in 12 of 24 runs); the search of the remainder
    (``prosac_remainder``) finds the truth behind it. Without that search the test fails."""
    for s in MISLEADING_SCENES:
        c = _rep(s)
        sc = structured_first_scores(c, seed=100 + s)
        for es in ESTIMATOR_SEEDS:
            r = estimate_relative_pose(c.u1, c.u2, c.K, c.K, seed=es, scores=sc)
            wrong = np.count_nonzero(np.asarray(r.inliers, bool) & (c.group == STRUCTURED)) > 2 or float(translation_error_deg(c.t, r.t)) > 3.0
            assert not (wrong and r.status == "ok"), f"scene {s}, seed {es}: {r.status}, t {float(translation_error_deg(c.t, r.t)):.1f} deg off"
    # and without the remainder's search the wrong geometry is `ok` (the gap the option closes)
    c = _rep(5)
    r = estimate_relative_pose(c.u1, c.u2, c.K, c.K, seed=0, scores=structured_first_scores(c, seed=105), prosac_remainder=False)
    assert r.status == "ok" and float(translation_error_deg(c.t, r.t)) > 3.0


def test_structured_first_scores_rank_the_structure_first():
    c = _rep(0)
    sc = structured_first_scores(c, seed=1)
    np.testing.assert_array_equal(sc, structured_first_scores(c, seed=1))
    assert sc[c.group == STRUCTURED].min() >= 0.5 and sc[c.group == RANDOM_GROUP].max() <= 0.5
    assert np.median(sc[c.group == STRUCTURED]) > np.median(sc[c.inliers]) > np.median(sc[c.group == RANDOM_GROUP])


@pytest.mark.parametrize("scene", [1, 3, 8])
def test_low_parallax_is_not_a_pure_rotation(scene):
    """0.75 deg of parallax at 0.3 px noise: the parallax (1-7 px) stays within the rotation-only
    model's threshold, so the count test alone called these scenes (measured) pure rotations and
    returned the rotation-only fit, 0.64-0.70 deg off where the pose's R is 0.04-0.10 deg off. The
    rotation's residuals along the epipolar lines are 20-120 times the noise's (parallax_ratio)."""
    from poseonly.analysis import PRECISION_RATIO

    c = low_parallax(parallax_deg=0.75, seed=scene)
    r = estimate_relative_pose(c.u1, c.u2, c.K, c.K, seed=scene)
    assert r.status == "ok", r.message
    assert r.diagnostics["pure_rotation"] is False
    # 28.6-45.7 before the ML stage's inlier share was bounded by the outliers beyond its band (the
    # decision, and with it the band this ratio is measured in, tightened: 22.8-24.1)
    assert r.diagnostics["parallax_ratio"] > 1.5 * PRECISION_RATIO
    assert _rerr(c, r.R) < 0.2
    assert r.num_inliers >= 0.95 * np.count_nonzero(c.inliers)


def test_repetitive_texture_accuracy_matches_poselib():
    ours = [_rerr(_rep(s), _ours("rep", s)[0]) for s in REP_ACCURACY_SEEDS]
    ref = [_rerr(_rep(s), _poselib("rep", s)[0]) for s in REP_ACCURACY_SEEDS]
    assert np.median(ours) <= 1.1 * np.median(ref)


@pytest.mark.xfail(
    strict=True,
    raises=AssertionError,
    reason="issue 12: the ML stage admits more of the moving object's matches than PoseLib on scene 3 (13 against 8 when measured; "
    "0.175 against 0.106 deg, within the test's 1.5x + 0.05)",
)
def test_second_motion_is_rejected():
    for s in MOTION_SEEDS:
        c = _motion(s)
        R, _, inl, _ = _ours("motion", s)
        Rp, _, inlp, _ = _poselib("motion", s)
        st = c.group == STRUCTURED
        assert np.count_nonzero(inl & st) <= np.count_nonzero(inlp & st) + 3, f"scene {s}"
        assert _rerr(c, R) <= 1.5 * _rerr(c, Rp) + 0.05, f"scene {s}"


def test_low_parallax_rotation_does_not_depend_on_the_seed():
    c = _lowp()
    ours = [_rerr(c, _ours("lowp", 0, s)[0]) for s in ESTIMATOR_SEEDS]
    ref = [_rerr(c, _poselib("lowp", 0, s)[0]) for s in ESTIMATOR_SEEDS]
    assert max(ours) - min(ours) <= max(ref) - min(ref) + 0.05
    assert max(ours) <= 1.25 * max(ref) + 0.02


def test_real_noise_keeps_the_inliers():
    for s in CLEAN_SEEDS:
        c = _clean(s)
        _, _, inl, status = _ours("clean", s)
        assert status == "ok"
        assert np.count_nonzero(inl & c.inliers) >= 0.98 * np.count_nonzero(c.inliers), f"scene {s}"


def _inlier_cost(c: HardCase, R: np.ndarray, t: np.ndarray) -> float:
    """Sum of squared Sampson distances (px^2) of the true inliers: the first-order ML objective."""
    e = sampson_error_px(c.u1[c.inliers], c.u2[c.inliers], c.K, c.K, R, t)
    return float(np.sum(e**2))


def test_real_noise_reaches_the_maximum_likelihood_pose():
    for s in CLEAN_SEEDS:
        c = _clean(s)
        R, t, _, _ = _ours("clean", s)
        Rp, tp, _, _ = _poselib("clean", s)
        best = min(_inlier_cost(c, Rp, tp), _inlier_cost(c, c.R, c.t))
        assert _inlier_cost(c, R, t) <= 1.005 * best, f"scene {s}"
