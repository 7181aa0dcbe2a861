"""Neighbour consistency (poseonly.robust.consistency): the sampling order of ``consistency="always"`` or ``"fallback"``."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import poseonly
from poseonly import _core, sim
from poseonly.geometry import bearings_from_pixels, rotation_error_deg
from poseonly.robust.consistency import consistency_order_scores, neighbour_consistency
from reference import neighbours as ref_nb


def _plane_pair(n: int, outliers: float, seed: int):
    """Matches of a textured plane (neighbourhoods preserved between the views) plus random re-pairings."""
    s = sim.make_scene(n, kind="planar", camera="pinhole", noise_px=0.5, outlier_fraction=outliers, seed=seed)
    return s.f1, s.f2, s.inliers


def test_correct_matches_share_their_neighbours():
    f1, f2, inl = _plane_pair(400, 0.5, 3)
    c = neighbour_consistency(f1, f2, 10)
    assert c.shape == (400,) and c.dtype == np.int64 and c.min() >= 0 and c.max() <= 10
    assert c[inl].mean() > 3 * c[~inl].mean()


@pytest.mark.parametrize("kind", ["sphere", "cone", "duplicates", "ties", "collinear"])
def test_core_neighbours_match_the_reference(kind):
    rng = np.random.default_rng(len(kind))
    for _ in range(8):
        n = int(rng.integers(2, 300))
        k = int(rng.integers(1, min(n - 1, 24) + 1))
        f = rng.normal(size=(n, 3))
        if kind == "cone":
            f[:, 2] = np.abs(f[:, 2]) + 6.0
        elif kind == "duplicates":
            f = np.repeat(f[: max(n // 3, 1)], 3, axis=0)[:n]
        elif kind == "ties":
            f = np.round(f, 1)
        elif kind == "collinear":  # a great circle: a one-cell-thin grid
            a = rng.uniform(0.0, 2.0, n)
            f = np.column_stack([np.cos(a), np.sin(a), 1e-9 * rng.normal(size=n)])
        f = np.ascontiguousarray(f / np.linalg.norm(f, axis=1, keepdims=True))
        np.testing.assert_array_equal(_core.nearest_neighbours(f, k), ref_nb.nearest_neighbours(f, k))
    with pytest.raises(ValueError, match="k must be"):
        _core.nearest_neighbours(f, len(f))
    bad = f.copy()
    bad[0, 0] = np.nan
    with pytest.raises(ValueError, match="finite"):
        _core.nearest_neighbours(bad, 1)


def test_counts_match_a_brute_force_definition():
    rng = np.random.default_rng(0)
    f1 = rng.normal(size=(60, 3))
    f2 = rng.normal(size=(60, 3))
    f1 /= np.linalg.norm(f1, axis=1, keepdims=True)
    f2 /= np.linalg.norm(f2, axis=1, keepdims=True)
    k = 6

    def knn(f):
        d = np.linalg.norm(f[:, None] - f[None], axis=2)
        np.fill_diagonal(d, np.inf)
        return np.argsort(d, axis=1, kind="stable")[:, :k]

    a, b = knn(f1), knn(f2)
    want = np.array([len(set(a[i]) & set(b[i])) for i in range(60)])
    np.testing.assert_array_equal(neighbour_consistency(f1, f2, k), want)


def test_small_sets_duplicates_and_determinism():
    assert neighbour_consistency(np.array([[0.0, 0.0, 1.0]]), np.array([[0.0, 0.0, 1.0]]), 10).tolist() == [0]
    f1, f2, _ = _plane_pair(50, 0.0, 1)
    c = neighbour_consistency(f1, f2, 100)  # k capped at n - 1: every other match is a neighbour in both views
    assert np.all(c == 49)
    dup1, dup2 = np.repeat(f1, 2, axis=0), np.repeat(f2, 2, axis=0)  # every match twice (a keypoint matched twice)
    d = neighbour_consistency(dup1, dup2, 5)
    assert d.shape == (100,) and np.all(d >= 1)  # at least the twin is a neighbour in both views
    np.testing.assert_array_equal(d, neighbour_consistency(dup1, dup2, 5))


def test_equal_scores_keep_the_input_order():
    f1, f2, _ = _plane_pair(60, 0.0, 4)
    k = consistency_order_scores(f1, f2, np.array([1.0, 1.0, 1.0] + [0.0] * 57), 59)  # every match shares every neighbour
    assert np.argsort(-k, kind="stable")[:3].tolist() == [0, 1, 2]


def test_order_scores_break_ties_by_the_callers_scores():
    f1, f2, _ = _plane_pair(100, 0.3, 2)
    c = neighbour_consistency(f1, f2, 10)
    s = np.random.default_rng(1).uniform(-5, 50, 100)  # any scale
    key = consistency_order_scores(f1, f2, s, 10)
    assert np.array_equal(np.floor(key), c)
    same = c == np.bincount(c).argmax()
    idx = np.flatnonzero(same)
    assert np.array_equal(np.argsort(-key[idx], kind="stable"), np.argsort(-s[idx], kind="stable"))
    np.testing.assert_array_equal(consistency_order_scores(f1, f2, None, 10), c)


def test_the_default_with_the_consistency_order():
    s = sim.make_scene(300, camera="pinhole", noise_px=0.0, outlier_fraction=0.5, seed=4)
    r = poseonly.estimate_relative_pose(s.u1, s.u2, s.K, s.K, consistency="always", seed=0)
    assert r.status == "ok" and rotation_error_deg(r.R, s.R) < 1e-6
    r2 = poseonly.estimate_relative_pose(s.u1, s.u2, s.K, s.K, consistency="always", seed=0)
    assert np.array_equal(r.R, r2.R) and np.array_equal(r.inliers, r2.inliers)


BAD_OPTIONS = [
    ("consistency_k", 0),
    ("consistency_k", 65),
    ("consistency_k", 2.5),
    ("consistency", "sometimes"),
    ("consistency", True),
    ("consistency_after", 0),
    ("consistency_min_draws", -1),
    ("consistency_min_matches", 0),
]


@pytest.mark.parametrize(("name", "bad"), BAD_OPTIONS)
def test_bad_consistency_options_are_input_errors(name, bad):
    s = sim.make_scene(40, camera="pinhole", seed=0)
    with pytest.raises(ValueError, match=name):
        poseonly.estimate_relative_pose(s.u1, s.u2, s.K, s.K, **{name: bad})


def _scores(sc, seed: int) -> np.ndarray:
    """Informative match scores (PROSAC order): the true matches first on average."""
    return sc.inliers.astype(float) + np.random.default_rng(seed).normal(0.0, 0.7, len(sc.inliers))


def _same(a, b) -> bool:
    return np.array_equal(a.R, b.R) and np.array_equal(a.inliers, b.inliers) and a.num_iterations == b.num_iterations and a.status == b.status


@pytest.mark.parametrize("outliers", [0.0, 0.5])
def test_fallback_leaves_a_converged_search_alone(outliers):
    # the search ends before consistency_after samples: the plain search, draw for draw (PROSAC's
    # schedule is that of the whole budget, RansacOptions::prosac_trials)
    s = sim.make_scene(400, kind="planar", camera="pinhole", noise_px=0.5, outlier_fraction=outliers, seed=5)
    sc = _scores(s, 5)
    a = poseonly.estimate_relative_pose(s.u1, s.u2, s.K, s.K, scores=sc, seed=1, consistency="off")
    b = poseonly.estimate_relative_pose(s.u1, s.u2, s.K, s.K, scores=sc, seed=1, consistency="fallback")
    assert _same(a, b) and "consistency" not in b.diagnostics


def test_fallback_is_off_below_the_sample_floor():
    # min_iterations above consistency_after: a first stage would be cut by its cap, not its stopping
    # rule; the plain search runs (it used to start a second search, and crash with consistency_min_draws=0)
    s = sim.make_scene(400, camera="pinhole", noise_px=0.5, outlier_fraction=0.5, seed=8)
    kw = dict(scores=_scores(s, 8), seed=2, min_iterations=2000, floor_parallax_deg=0.0)
    a = poseonly.estimate_relative_pose(s.u1, s.u2, s.K, s.K, consistency="off", **kw)
    b = poseonly.estimate_relative_pose(s.u1, s.u2, s.K, s.K, consistency="fallback", consistency_after=1000, consistency_min_draws=0, **kw)
    assert _same(a, b) and a.num_iterations >= 2000


def test_a_staged_search_keeps_prosacs_schedule():
    # a search capped at K draws with prosac_trials = M draws as the search with M does, so where that
    # one ends before K the two are the same; with the cap's own schedule they are not
    from poseonly.robust.ransac import ransac_relpose

    s = sim.make_scene(400, camera="pinhole", noise_px=0.5, outlier_fraction=0.6, seed=9)
    sc = _scores(s, 9)
    kw = dict(scores=sc, confidence=0.9999, min_iterations=0, chiral=True)
    full = ransac_relpose(s.f1, s.f2, 1.0 / 800.0, 3, max_iterations=100000, **kw)
    assert full.num_iterations < 3000
    staged = ransac_relpose(s.f1, s.f2, 1.0 / 800.0, 3, max_iterations=3000, prosac_trials=100000, **kw)
    assert staged.num_iterations == full.num_iterations and np.array_equal(staged.R, full.R)
    assert np.isfinite(staged.stats["needed"]) and staged.stats["needed"] <= staged.num_iterations


def test_fallback_takes_over_a_long_search():
    # 85 % outliers: the first 3000 samples do not converge, the consistency order continues the search,
    # and the reported iterations hold both stages
    h = sim.make_scene(600, camera="pinhole", noise_px=0.5, outlier_fraction=0.85, seed=6)
    c = poseonly.estimate_relative_pose(h.u1, h.u2, h.K, h.K, seed=1, consistency="fallback", consistency_after=500)
    assert c.diagnostics["consistency"] in ("fallback", "fallback-unused")
    assert c.num_iterations > 500 and c.status == "ok" and rotation_error_deg(c.R, h.R) < 0.5


def _first_search_on(R, t, f1, f2, tau, o, iterations=3000):
    """A consistency-order search's result that ended on the pose (R, t) after ``iterations`` draws."""
    from poseonly.residuals import v_sampson
    from poseonly.robust.ransac import RansacResult, search_cost

    cost, _ = search_cost(R, t, f1, f2, tau, scoring=o.scoring, keypoint_once=o.keypoint_once)
    v = v_sampson(R, t, f1, f2)
    stats = {"rival_cost": np.inf, "num_challenger_lo": 0, "challenger_won": 0}
    return RansacResult(R=R, t=t, inliers=v < tau, residuals=v, score=float(cost), num_iterations=iterations, stats=stats)


@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_the_remainder_search_finds_the_scene_behind_a_compact_second_motion(seed):
    # 120 static matches, 60 on a compact moving object, 700 random: a consistency-order search that
    # ended on the object's motion (it tops the order) is followed by one on the remainder, which finds
    # the scene's, costs less on all the matches and replaces it; the object's motion is the rival
    from poseonly import sim_hard
    from poseonly.options import PoseonlyOptions
    from poseonly.robust.default import _with_remainder

    c = sim_hard.second_motion(n_static=120, n_moving=60, n_random=700, seed=seed)
    f1, f2 = bearings_from_pixels(c.u1, c.K), bearings_from_pixels(c.u2, c.K)
    o = PoseonlyOptions(consistency_remainder=True, consistency_rule="expected")
    tau = o.threshold_px / c.K[0, 0]
    first = _first_search_on(c.R_wrong, c.t_wrong, f1, f2, tau, o)
    out = _with_remainder(first, o.max_iterations, f1, f2, tau, o, None)
    assert rotation_error_deg(out.R, c.R) < 1.0 and out.score < first.score
    assert rotation_error_deg(np.asarray(out.stats["rival_R"]), c.R_wrong) < 1e-9
    assert out.num_iterations == 2 * first.num_iterations  # as many draws as the first search took
    # the budget caps it; off, without cheirality-aware scoring or with no budget left: the first result
    capped = _with_remainder(first, 4000, f1, f2, tau, o, None)
    assert capped.num_iterations <= 4000
    for opt, budget in ((dataclasses.replace(o, consistency_remainder=False), o.max_iterations), (dataclasses.replace(o, chiral_scoring=False), o.max_iterations), (o, 3000)):
        assert _with_remainder(first, budget, f1, f2, tau, opt, None) is first


def test_the_remainder_search_skips_a_search_its_inliers_certify():
    # 35-50 % outliers: the consistency-order search ends by the classical rule on its inlier share
    # (before consistency_min_draws, below which the progressive rule cannot end it), and nothing follows
    from poseonly.options import PoseonlyOptions
    from poseonly.robust.default import _search, _with_remainder

    for seed, rate in ((2, 0.5), (3, 0.35)):
        s = sim.make_scene(400, camera="pinhole", noise_px=0.5, outlier_fraction=rate, seed=seed)
        o = PoseonlyOptions(consistency_remainder=True, consistency_rule="expected", seed=seed)
        tau = o.threshold_px / s.K[0, 0]
        r = _search(s.f1, s.f2, tau, o, consistency_order_scores(s.f1, s.f2, None, o.consistency_k), True)
        assert r.num_iterations < o.consistency_min_draws and r.num_iterations >= r.stats["classical_needed"]
        assert _with_remainder(r, o.max_iterations, s.f1, s.f2, tau, o, None) is r
        e = poseonly.estimate_relative_pose(s.u1, s.u2, s.K, s.K, seed=seed, consistency="always", consistency_rule="expected")
        f = poseonly.estimate_relative_pose(s.u1, s.u2, s.K, s.K, seed=seed, consistency="always", consistency_rule="expected", consistency_remainder=True)
        assert _same(e, f)
