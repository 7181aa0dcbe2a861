"""Adaptive stopping of the core's RANSAC with ``min_hits`` (``samples_needed`` in ransac.h)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from poseonly import estimate_relative_pose
from poseonly.robust.ransac import ransac_relpose
from poseonly.sim import make_scene

CONF = 0.9999
TAU = 1.0 / 800


def fewer_good(k: int, p: float, hits: int) -> float:
    """P(Bin(k, p) < hits), the reference of the core's log_fewer_good."""
    return sum(math.comb(k, j) * p**j * (1 - p) ** (k - j) for j in range(min(hits, k + 1)))


def needed(p: float, hits: int) -> int:
    """Smallest k with P(Bin(k, p) < hits) <= 1 - CONF (hits = 1: the classical formula)."""
    if hits == 1:
        return math.ceil(math.log(1 - CONF) / math.log1p(-p))
    k = hits
    while fewer_good(k, p, hits) > 1 - CONF:
        k += 1
    return k


@pytest.mark.parametrize("rate", [0.0, 0.3, 0.5])
def test_stop_waits_for_min_hits(rate):
    """The loop never stops before the samples the final consensus needs for ``min_hits`` good
    samples, and more hits never mean fewer samples."""
    sc = make_scene(300, camera="pinhole", noise_px=0.5, outlier_fraction=rate, seed=100)
    its = []
    for hits in (1, 3, 5):
        r = ransac_relpose(sc.f1, sc.f2, TAU, 0, min_iterations=0, confidence=CONF, lo="sampson", chiral=True, min_hits=hits)
        p = (int(r.stats["num_inliers"]) / len(sc.f1)) ** 5
        assert r.num_iterations >= needed(p, hits) >= hits
        its.append(r.num_iterations)
    assert its[0] <= its[1] <= its[2]
    assert its[2] > its[0]


def test_stop_terminates_when_good_samples_are_frequent():
    """Good-sample probabilities near 1 (a clean pair: few samples needed) end the loop at the exact
    count (a non-integer bisection bound once looped forever here)."""
    sc = make_scene(1200, camera="pinhole", noise_px=0.3, outlier_fraction=0.02, seed=100)
    for hits in (2, 3, 5, 8):
        r = ransac_relpose(sc.f1, sc.f2, TAU, 0, min_iterations=0, confidence=CONF, lo="sampson", chiral=True, min_hits=hits)
        p = (int(r.stats["num_inliers"]) / len(sc.f1)) ** 5
        assert needed(p, hits) <= r.num_iterations <= 3 * needed(p, hits)


def test_min_hits_is_validated():
    sc = make_scene(50, seed=1)
    with pytest.raises(ValueError, match="min_hits"):
        estimate_relative_pose(sc.u1, sc.u2, sc.K, sc.K, min_hits=0)
    with pytest.raises(ValueError, match="min_hits"):
        ransac_relpose(sc.f1, sc.f2, TAU, 0, min_hits=0)


def test_binomial_reference_matches_classical_rule():
    """For one hit the exact tail is the classical formula (the reference agrees with itself)."""
    for p in (0.01, 0.2, 0.7):
        k = needed(p, 1)
        assert fewer_good(k, p, 1) <= 1 - CONF < fewer_good(k - 1, p, 1)
    assert np.isclose(fewer_good(10, 0.5, 3), sum(math.comb(10, j) for j in range(3)) / 2**10)


def test_challengers_are_validated_and_never_worsen_the_search():
    sc = make_scene(300, camera="pinhole", noise_px=1.0, outlier_fraction=0.5, seed=3)
    for bad in (-1, 65, 2.5, True):
        with pytest.raises(ValueError, match="challengers"):
            estimate_relative_pose(sc.u1, sc.u2, sc.K, sc.K, challengers=bad)
    with pytest.raises(ValueError, match="challenger_distance"):
        ransac_relpose(sc.f1, sc.f2, TAU, 0, challengers=2, challenger_distance=float("inf"))
    for seed in range(6):
        kw = dict(min_iterations=100, lo="sampson", chiral=True, rival_distance=5.0)
        a = ransac_relpose(sc.f1, sc.f2, TAU, seed, **kw)
        b = ransac_relpose(sc.f1, sc.f2, TAU, seed, challengers=4, **kw)
        assert b.score <= a.score
        if not b.stats["challenger_won"]:
            np.testing.assert_array_equal(a.R, b.R)
            # the same best model; the challengers' runs can only offer the uniqueness test a rival
            # (a finite rival cost) where the plain search had none or a costlier one
            assert b.stats["rival_cost"] <= a.stats["rival_cost"], seed


def test_lo_max_points_subsamples_the_lo_and_is_validated():
    """The LO on an evenly strided subset of its window: validated; 0 runs every point; on a big pair a
    small subset still gives the exact pose on noise-free matches and the same pose to rounding as
    the full LO once the ML stage has run."""
    for bad in (-1, 2.5, True):
        sc = make_scene(60, camera="pinhole", noise_px=0.0, outlier_fraction=0.0, seed=1)
        with pytest.raises(ValueError, match="lo_max_points"):
            estimate_relative_pose(sc.u1, sc.u2, sc.K, sc.K, lo_max_points=bad)
    with pytest.raises(ValueError, match="lo_max_points"):
        ransac_relpose(sc.f1, sc.f2, TAU, 0, lo="sampson", lo_max_points=-1)
    exact = make_scene(2000, camera="wide", noise_px=0.0, outlier_fraction=0.3, seed=4)
    r = ransac_relpose(exact.f1, exact.f2, TAU, 0, lo="sampson", lo_max_points=40)
    from poseonly.geometry import rotation_error_deg

    assert rotation_error_deg(r.R, exact.R) < 1e-6
    sc = make_scene(2000, camera="wide", noise_px=0.5, outlier_fraction=0.3, seed=5)
    full = estimate_relative_pose(sc.u1, sc.u2, sc.K, sc.K, lo_max_points=0)
    sub = estimate_relative_pose(sc.u1, sc.u2, sc.K, sc.K, lo_max_points=200)
    assert full.status == sub.status == "ok"
    assert rotation_error_deg(full.R, sub.R) < 1e-4
    assert abs(full.num_inliers - sub.num_inliers) <= 2


def _small_scene(n_in: int, n_out: int, seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.random.Generator]:
    """``n_in`` matches of a 10-degree turn with a sideways step (0.3 px noise) and ``n_out`` random ones."""
    rng = np.random.default_rng(seed)
    K = np.array([[800.0, 0, 320], [0, 800, 240], [0, 0, 1]])
    a = np.radians(10.0)
    R = np.array([[np.cos(a), 0, np.sin(a)], [0, 1, 0], [-np.sin(a), 0, np.cos(a)]])
    t = np.array([-1.0, 0.1, 0.2])
    X = np.c_[rng.uniform(-2, 2, n_in), rng.uniform(-1.5, 1.5, n_in), rng.uniform(4, 8, n_in)]
    x1 = X @ K.T
    x2 = (X @ R.T + t) @ K.T
    x1 = x1[:, :2] / x1[:, 2:] + rng.normal(0, 0.3, (n_in, 2))
    x2 = x2[:, :2] / x2[:, 2:] + rng.normal(0, 0.3, (n_in, 2))
    o = rng.uniform([0, 0], [640, 480], (2, n_out, 2))
    return K, np.r_[x1, o[0]], np.r_[x2, o[1]], np.r_[np.ones(n_in, bool), np.zeros(n_out, bool)], rng


def test_min_inliers_stop_ends_searches_without_such_a_model_and_loses_none():
    """stop_at_min_inliers: on random matches without scores the search ends once a model with
    min_inliers inliers would have been drawn (the without-replacement bound), well before the cap;
    with scores (PROSAC, whose early draws come from the top of the order only) it does not end before
    the sampler is uniform; and on 16 true matches among 50 it changes no result, whatever the scores
    (none, random, or ranking the outliers first: a review found the first version, with the
    with-replacement ratio and PROSAC's draws counted, losing 1-10 of 20 such poses)."""
    rng = np.random.default_rng(0)
    K = np.array([[800.0, 0, 320], [0, 800, 240], [0, 0, 1]])
    x1, x2 = rng.uniform([0, 0], [640, 480], (2, 60, 2))
    r = estimate_relative_pose(x1, x2, K, K, seed=0)
    m, i = 5, 15  # sample size, min_inliers
    bound = math.log(1e-4) / math.log1p(-(((i - m + 1) / (60 - m + 1)) ** m))
    assert r.status == "too_few_inliers" and r.num_iterations == math.ceil(bound) < 40000
    assert estimate_relative_pose(x1, x2, K, K, seed=0, stop_at_min_inliers=False).num_iterations == 100000
    assert estimate_relative_pose(x1, x2, K, K, seed=0, scores=rng.uniform(0, 1, 60)).num_iterations == 100000
    for mode in ("none", "random", "outliers first"):
        for seed in range(12):
            K, x1, x2, inl, g = _small_scene(16, 34, seed)
            scores = None if mode == "none" else g.uniform(0.2, 0.9, 50) if mode == "random" else np.where(inl, 0.3, 0.7)
            a = estimate_relative_pose(x1, x2, K, K, seed=seed, scores=scores)
            b = estimate_relative_pose(x1, x2, K, K, seed=seed, scores=scores, stop_at_min_inliers=False)
            assert a.status == b.status and np.array_equal(a.R, b.R), (mode, seed)
