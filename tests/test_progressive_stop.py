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


# --- the expected-draws rule (progressive_rule="expected"; src/core/ransac.h expected_needed) --------------


def _schedule_expectation():
    import sys
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
    try:
        from prosac_stop_bound import schedule_expectation
    finally:
        sys.path.pop(0)
    return schedule_expectation


@pytest.mark.parametrize("seed", range(3))
def test_expected_rule_stops_where_the_schedule_sum_reaches_the_confidence(seed):
    # the core's stop against the Python sum over the sampler's schedule (benchmarks/prosac_stop_bound.py) for
    # the returned model's inliers: no challengers and no cheirality, so the loop's last best is the result
    from poseonly.robust.ransac import prosac_order

    sc = _scene(0.7, seed)
    s = _informative_scores(sc, seed)
    r = ransac_relpose(sc.f1, sc.f2, TAU, 7, scores=s, confidence=0.9999, min_iterations=0, progressive_stop=True, progressive_rule="expected", max_iterations=100000)
    order = prosac_order(s)
    _, cross = _schedule_expectation()(r.inliers[order].tolist(), 100000.0, -np.log(1e-4), 100000.0)
    k = r.inliers.sum()
    classical = np.log(1e-4) / np.log1p(-((k / len(s)) ** 5))
    assert cross < classical  # informative scores: the schedule sum needs fewer draws than the classical rule
    assert abs(r.num_iterations - np.ceil(cross)) <= 1


@pytest.mark.parametrize("seed", range(4))
def test_expected_rule_ends_a_hard_search_earlier_on_the_same_model(seed):
    sc = _scene(0.8, seed)
    s = _informative_scores(sc, seed)
    prosac, expected = _search(sc, s, True), _search(sc, s, True, progressive_rule="expected")
    assert expected.num_iterations < prosac.num_iterations
    assert rotation_error_deg(sc.R, expected.R) < 1.0
    assert np.count_nonzero(expected.inliers & sc.inliers) >= 0.9 * np.count_nonzero(prosac.inliers & sc.inliers)


def test_expected_rule_with_uninformative_scores_is_the_classical_count():
    # random scores: the inliers are spread evenly over the order, the schedule sum is the uniform one
    for seed in range(3):
        sc = _scene(0.6, seed)
        s = np.random.default_rng(seed).random(len(sc.f1))
        classical, expected = _search(sc, s, False), _search(sc, s, True, progressive_rule="expected")
        assert 0.3 * classical.num_iterations <= expected.num_iterations <= classical.num_iterations


def test_expected_rule_option_reaches_the_search_and_is_checked():
    sc = _scene(0.8, 1)
    s = _informative_scores(sc, 1)
    # no sample floor, so that the stopping rules decide
    a = estimate_relative_pose(sc.f1, sc.f2, focal_px=800.0, scores=s, seed=0, min_iterations=0, min_iterations_parallax=0)
    b = estimate_relative_pose(sc.f1, sc.f2, focal_px=800.0, scores=s, seed=0, min_iterations=0, min_iterations_parallax=0, progressive_rule="expected")
    assert b.num_iterations < a.num_iterations
    assert b.status == "ok" and rotation_error_deg(sc.R, b.R) < 0.5
    with pytest.raises(InputError):
        estimate_relative_pose(sc.f1, sc.f2, focal_px=800.0, progressive_rule="uniform")
    with pytest.raises(ValueError):
        ransac_relpose(sc.f1, sc.f2, TAU, 0, scores=s, progressive_rule="uniform")


@pytest.mark.parametrize("seed", range(3))
def test_min_draws_bound_only_the_progressive_rule(seed):
    sc = _scene(0.7, seed)
    s = _informative_scores(sc, seed)
    early, full = _search(sc, s, True), _search(sc, s, False)
    floor = early.num_iterations + 500
    held = _search(sc, s, True, progressive_min_draws=floor)
    # the progressive rule waits for the floor, the classical rule still ends the search where it did
    assert held.num_iterations == min(floor, full.num_iterations)
    easy = _scene(0.0, seed)  # the classical rule alone stops an easy search long before the floor
    assert _search(easy, _informative_scores(easy, seed), True, progressive_min_draws=10**5).num_iterations < 1000
    with pytest.raises(ValueError, match="progressive_min_draws"):
        _search(sc, s, True, progressive_min_draws=-1)
