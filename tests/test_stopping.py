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
            assert a.stats["rival_cost"] == b.stats["rival_cost"] or np.isfinite(b.stats["rival_cost"])


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
