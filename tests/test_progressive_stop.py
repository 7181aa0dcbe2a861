"""PROSAC's stopping rule in the core's search (``progressive_stop``; src/core/ransac.h ``progressive_needed``)."""

from __future__ import annotations

import numpy as np
import pytest

from poseonly import estimate_relative_pose, sim
from poseonly.geometry import InputError, rotation_error_deg
from poseonly.robust.ransac import ransac_relpose

TAU = 1.0 / 800.0  # 1 px at the wide camera's 800 px focal length


def _scene(outliers: float, seed: int):
    return sim.make_scene(400, camera="wide", noise_px=0.5, outlier_fraction=outliers, seed=seed)


def _informative_scores(sc, seed: int) -> np.ndarray:
    """Scores that rank the true matches first, on average (a ratio test's ranking, noisy)."""
    rng = np.random.default_rng(seed)
    return sc.inliers.astype(float) + rng.normal(0.0, 0.5, len(sc.inliers))


def _search(sc, scores, progressive_stop: bool, **kw):
    return ransac_relpose(sc.f1, sc.f2, TAU, 7, scores=scores, confidence=0.9999, min_iterations=0, chiral=True, progressive_stop=progressive_stop, **kw)


@pytest.mark.parametrize("seed", range(4))
def test_it_ends_a_hard_search_early_on_the_same_model(seed):
    # 70 % outliers: the classical rule needs thousands of draws at this inlier share, PROSAC's rule stops once
    # a non-random top-n set of the score order has been sampled enough
    sc = _scene(0.7, seed)
    s = _informative_scores(sc, seed)
    full, early = _search(sc, s, False), _search(sc, s, True)
    assert early.num_iterations < 0.2 * full.num_iterations
    assert rotation_error_deg(sc.R, early.R) < 1.0
    assert np.count_nonzero(early.inliers & sc.inliers) >= 0.9 * np.count_nonzero(full.inliers & sc.inliers)


def test_it_only_ends_the_search_earlier():
    # the same draws: the stopped search is a prefix of the full one, so it never runs longer
    for seed in range(6):
        sc = _scene(0.6, seed)
        s = np.random.default_rng(seed).random(len(sc.f1))
        assert _search(sc, s, True).num_iterations <= _search(sc, s, False).num_iterations


def test_without_scores_it_changes_nothing():
    sc = _scene(0.5, 0)
    a, b = _search(sc, None, False), _search(sc, None, True)
    assert a.num_iterations == b.num_iterations
    np.testing.assert_array_equal(a.R, b.R)


def test_random_matches_never_look_non_random():
    # no geometry at all: no top-n set's support passes the non-randomness test, the search runs to its cap
    sc = _scene(1.0, 3)
    s = np.random.default_rng(3).random(len(sc.f1))
    r = _search(sc, s, True, max_iterations=3000)
    assert r.num_iterations == 3000


def test_the_option_reaches_the_search_and_is_checked():
    sc = _scene(0.7, 1)
    s = _informative_scores(sc, 1)
    a = estimate_relative_pose(sc.f1, sc.f2, focal_px=800.0, scores=s, seed=0, progressive_stop=False)
    b = estimate_relative_pose(sc.f1, sc.f2, focal_px=800.0, scores=s, seed=0)  # the default
    assert b.num_iterations < a.num_iterations
    assert b.status == "ok" and rotation_error_deg(sc.R, b.R) < 0.5
    with pytest.raises(InputError):
        estimate_relative_pose(sc.f1, sc.f2, focal_px=800.0, progressive_stop="yes")
