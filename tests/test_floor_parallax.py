"""The search's sample floor by parallax (``floor_parallax_deg``, ``min_iterations_parallax``; src/core/ransac.h)."""

from __future__ import annotations

import numpy as np
import pytest

from poseonly import estimate_relative_pose, sim, sim_hard
from poseonly.geometry import InputError, rotation_error_deg
from poseonly.robust.ransac import ransac_relpose

TAU = 1.0 / 800.0  # 1 px at the wide camera's 800 px focal length


def _search(sc, **kw):
    kw = {"confidence": 0.9999, "min_iterations": 500, "chiral": True, **kw}
    return ransac_relpose(sc.f1, sc.f2, TAU, 7, **kw)


def _bearings(u: np.ndarray, K: np.ndarray) -> np.ndarray:
    x = np.column_stack([u, np.ones(len(u))]) @ np.linalg.inv(K).T
    return np.ascontiguousarray(x / np.linalg.norm(x, axis=1, keepdims=True))


def _median_parallax_deg(R: np.ndarray, f1: np.ndarray, f2: np.ndarray, inl: np.ndarray) -> float:
    c = np.clip(np.sum((f1[inl] @ R.T) * f2[inl], axis=1), -1.0, 1.0)
    return float(np.degrees(np.median(np.arccos(c))))


def test_a_pose_with_parallax_ends_at_the_lower_floor():
    # no outliers: the stopping rule needs a handful of samples, the floor decides the length
    sc = sim.make_scene(300, camera="wide", noise_px=0.5, seed=4)
    assert _median_parallax_deg(sc.R, sc.f1, sc.f2, sc.inliers) > 3.0
    base = _search(sc)
    low = _search(sc, floor_parallax_deg=3.0, min_iterations_parallax=100)
    assert base.num_iterations == 500 and low.num_iterations == 100
    assert rotation_error_deg(sc.R, low.R) < 0.2
    # the lower floor is a prefix of the same draws: until it ends, the two searches are the same
    first = _search(sc, min_iterations=100)
    np.testing.assert_array_equal(first.R, low.R)


def test_a_weakly_constrained_pose_keeps_the_floor():
    c = sim_hard.low_parallax(parallax_deg=0.75, seed=2)
    f1, f2 = (_bearings(u, c.K) for u in (c.u1, c.u2))
    r = ransac_relpose(f1, f2, 1.0 / float(c.K[0, 0]), 7, confidence=0.9999, min_iterations=500, chiral=True, floor_parallax_deg=3.0, min_iterations_parallax=100)
    assert _median_parallax_deg(r.R, f1, f2, r.inliers) < 3.0
    assert r.num_iterations >= 500


def test_the_floor_never_rises_above_min_iterations():
    sc = sim.make_scene(300, camera="wide", noise_px=0.5, seed=5)
    r = _search(sc, min_iterations=50, floor_parallax_deg=3.0, min_iterations_parallax=400)
    assert r.num_iterations == 50


def test_the_default_uses_it_and_the_options_are_checked():
    sc = sim.make_scene(300, camera="wide", noise_px=0.5, seed=6)
    a = estimate_relative_pose(sc.u1, sc.u2, sc.K, sc.K, seed=0)
    b = estimate_relative_pose(sc.u1, sc.u2, sc.K, sc.K, seed=0, floor_parallax_deg=0.0)  # the floor before
    assert a.num_iterations == 100 and b.num_iterations == 500
    assert a.status == b.status == "ok"
    assert rotation_error_deg(sc.R, a.R) < 0.2
    for bad in ({"floor_parallax_deg": -1.0}, {"floor_parallax_deg": 200.0}, {"min_iterations_parallax": -5}, {"floor_parallax_deg": "3"}):
        with pytest.raises(InputError):
            estimate_relative_pose(sc.u1, sc.u2, sc.K, sc.K, **bad)
    with pytest.raises(ValueError):
        ransac_relpose(sc.f1, sc.f2, TAU, 7, floor_parallax_deg=181.0)
