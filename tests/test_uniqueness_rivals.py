"""The uniqueness test compares the pose with every basin the search kept, not only its best rival
(``poseonly.robust.default.rival_candidates``, ``poseonly.status.finish``)."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

from poseonly.api import estimate_relative_pose
from poseonly.geometry import rotation_error_deg, rotation_from_rotvec
from poseonly.robust import default
from poseonly.robust.ransac import RansacResult
from poseonly.sim_hard import second_motion

KITTI = Path(__file__).resolve().parents[2] / "shared" / "data" / "realpairs" / "kitti_seq1"
BENCHMARKS = Path(__file__).resolve().parents[1] / "benchmarks"
WRONG_DEG = 5.0


def _pose(deg: float, axis: int = 1) -> tuple[np.ndarray, np.ndarray]:
    w = np.zeros(3)
    w[axis] = np.radians(deg)
    return rotation_from_rotvec(w), np.array([1.0, 0.0, 0.0])


def _result(stats: dict) -> RansacResult:
    R, t = _pose(0.0)
    return RansacResult(R=R, t=t, inliers=np.zeros(0, bool), residuals=np.zeros(0), score=100.0, num_iterations=1, stats=stats)


def test_rival_candidates_keep_one_model_per_far_basin_best_first():
    rival = _pose(20.0)
    others = [_pose(20.3), _pose(2.0), _pose(40.0), _pose(60.0), _pose(30.0)]
    costs = [100.5, 100.1, 130.0, 151.0, 120.0]  # 20.3: rival's basin; 2: too near; 60: too costly
    stats = {
        "rival_R": rival[0],
        "rival_t": rival[1],
        "rival_cost": 100.5,
        "others_R": np.array([R for R, _ in others]),
        "others_t": np.array([t for _, t in others]),
        "others_cost": np.array(costs),
    }
    got = [rotation_error_deg(np.eye(3), R) for R, _ in default.rival_candidates(_result(stats), 5.0)]
    assert np.allclose(got, [20.0, 30.0, 40.0])
    assert default.rival_candidates(_result({**stats, "rival_cost": np.inf}), 5.0) == []
    assert default.rival_candidates(_result(stats), 0.0) == []
    assert len(default.rival_candidates(_result({k: v for k, v in stats.items() if not k.startswith("others_")}), 5.0)) == 1


@pytest.fixture(scope="module")
def two_motions():
    return second_motion(120, 120, 60, seed=0)


def test_a_rival_behind_one_in_the_pose_basin_makes_the_pose_ambiguous(two_motions, monkeypatch):
    """The first candidate refines into the pose's own basin (no rival); the second is the other
    motion, as well supported: the pose is ambiguous, and that rival is the one reported."""
    c = two_motions
    geometries = [(c.R, c.t), (c.R_wrong, c.t_wrong)]

    def candidates(r: RansacResult, distance: float, keep_second: bool) -> list[tuple[np.ndarray, np.ndarray]]:
        far = max(geometries, key=lambda g: rotation_error_deg(r.R, g[0]))
        return [(r.R, r.t), far] if keep_second else [(r.R, r.t)]

    monkeypatch.setattr(default, "rival_candidates", lambda r, d: candidates(r, d, True))
    both = estimate_relative_pose(c.u1, c.u2, c.K, c.K, seed=0)
    assert both.status == "ambiguous", both.message
    assert both.diagnostics["rivals_tested"] == 2
    assert both.diagnostics["rival_separation_deg"] > 5.0
    monkeypatch.setattr(default, "rival_candidates", lambda r, d: candidates(r, d, False))
    one = estimate_relative_pose(c.u1, c.u2, c.K, c.K, seed=0)
    assert one.status != "ambiguous"
    assert one.diagnostics["rivals_tested"] == 1
    assert "rivals" not in one.diagnostics


def _orb_kitti_matches(tmp_path: Path):
    cv2 = pytest.importorskip("cv2")
    del cv2
    if not (KITTI / "pairs.txt").is_file():
        pytest.skip("../shared/data/realpairs/kitti_seq1 is not here")
    sys.path.insert(0, str(BENCHMARKS))
    try:
        import real_frontends as rf
    finally:
        sys.path.pop(0)
    from poseonly.experiments.real_bench import load_datasets

    pairs = [p for ps in load_datasets([str(KITTI)]).values() for p in ps if p.pid == "seq1_040_050"]
    if not pairs:
        pytest.skip("pair seq1_040_050 is not in the KITTI folder")
    p = pairs[0]
    k1, d1, s1 = rf.features(p.im1, "orb", tmp_path)
    k2, d2, s2 = rf.features(p.im2, "orb", tmp_path)
    idx, ratio = rf.ratio_matches(d1, d2)
    return p, k1[idx[:, 0]], k2[idx[:, 1]], 1.0 - ratio, np.sqrt(s1[idx[:, 0]] * s2[idx[:, 1]])


def test_orb_on_kitti_is_never_a_wrong_ok(tmp_path):
    """ORB on KITTI seq1 40-50: at 1 px the search's objective prefers a broad basin 22-25 deg off.
    Some seeds' best rival lay in that basin too and refined back into it, so the wrong pose was
    ``ok``; the truth's basin was among the other models the search kept (measured: seeds 2-3 of 6
    ``ok`` 22-25 deg off before every kept basin was tested)."""
    p, u1, u2, scores, scales = _orb_kitti_matches(tmp_path)
    for seed in range(4):
        r = estimate_relative_pose(u1, u2, p.K1, p.K2, scores=scores, noise_scales=scales, seed=seed)
        assert not (r.status == "ok" and rotation_error_deg(p.R, r.R) > WRONG_DEG), (seed, r.message)


def test_a_refined_rival_that_beats_the_pose_replaces_it():
    """The rivals are refined after the search ranked them unrefined; one that then scores better under
    the search's objective is the result, the search's pose one of the rivals (a VO trial with
    ``challengers=0``: `ambiguous` with the pose 5.2 deg off, the rival 0.1 deg off)."""
    from poseonly.sim import make_scene

    sc = make_scene(200, camera="pinhole", noise_px=0.3, outlier_fraction=0.3, seed=2)
    tau = 1.0 / 800.0
    wrong = (rotation_from_rotvec(np.radians([0.0, 3.0, 0.0])) @ sc.R, sc.t)
    right = (sc.R, sc.t)
    diag = {"rivals": [right], "rival_R": right[0], "rival_t": right[1]}
    R, t = default._better_rival(*wrong, sc.f1, sc.f2, tau, diag)
    assert rotation_error_deg(R, sc.R) < 1e-12 and diag["rival_swapped"]
    assert rotation_error_deg(diag["rivals"][0][0], wrong[0]) < 1e-12 and diag["rival_R"] is diag["rivals"][0][0]
    diag = {"rivals": [wrong], "rival_R": wrong[0], "rival_t": wrong[1]}
    R, t = default._better_rival(*right, sc.f1, sc.f2, tau, diag)  # the pose is the better one: kept
    assert R is right[0] and "rival_swapped" not in diag


def test_after_a_swap_the_rivals_are_best_first_with_their_support_ratio():
    """After a swap the rivals are ordered by the search's objective again (the former pose may be
    better than the other rivals) and the support ratio compares the best of them with the returned
    pose, not the search's unrefined models."""
    from poseonly.sim import make_scene

    sc = make_scene(200, camera="pinhole", noise_px=0.3, outlier_fraction=0.3, seed=2)
    tau = 1.0 / 800.0
    worse = (rotation_from_rotvec(np.radians([0.0, 0.1, 0.0])) @ sc.R, sc.t)
    wrong = (rotation_from_rotvec(np.radians([0.0, 0.05, 0.0])) @ sc.R, sc.t)
    right = (sc.R, sc.t)
    diag = {"rivals": [worse, right], "rival_R": worse[0], "rival_t": worse[1], "rival_support_ratio": 0.9}
    R, t = default._better_rival(*wrong, sc.f1, sc.f2, tau, diag)
    assert rotation_error_deg(R, sc.R) < 1e-12 and diag["rival_swapped"]
    scores = [default.msac_chiral(Rv, tv, sc.f1, sc.f2, tau) for Rv, tv in diag["rivals"]]
    assert scores == sorted(scores, reverse=True) and rotation_error_deg(diag["rival_R"], wrong[0]) < 1e-12
    best = default.msac_chiral(R, t, sc.f1, sc.f2, tau)
    assert 0 <= diag["rival_support_ratio"] < 1 and abs(diag["rival_support_ratio"] - scores[0] / best) < 1e-12


def test_critical_surface_generator_is_exact():
    """Noise-free matches of ``sim_hard.critical_surface`` fit both poses exactly (a 2-D null space of the
    epipolar system) with every point in front of both cameras under both."""
    from poseonly.geometry import normalize, rotation_error_deg
    from poseonly.sim_hard import _midpoint_depths, critical_surface

    for seed in range(3):
        c = critical_surface(200, noise_px=0.0, seed=seed)
        Ki = np.linalg.inv(c.K)
        f1 = normalize(np.c_[c.u1, np.ones(c.n)] @ Ki.T)
        f2 = normalize(np.c_[c.u2, np.ones(c.n)] @ Ki.T)
        sv = np.linalg.svd(np.einsum("ni,nj->nij", f2, f1).reshape(-1, 9), compute_uv=False)
        assert sv[-2] < 1e-12 * sv[0] and sv[-3] > 1e-5 * sv[0]
        assert rotation_error_deg(c.R, c.R_wrong) > 7.9
        for R, t in ((c.R, c.t), (c.R_wrong, c.t_wrong)):
            assert c.t_wrong is not None
            l1, l2 = _midpoint_depths(R, t, f1, f2)
            assert np.all(l1 > 0) and np.all(l2 > 0)


@pytest.mark.parametrize(("scene", "seeds"), [(16, (2,)), (8, (0, 1, 2))])
def test_the_search_result_stays_a_rival_when_the_pose_only_choice_leaves_its_basin(scene, seeds):
    """On a critical surface (two poses fit every match; 0.5 px) the pose-only choice's re-solve on the
    consensus set can jump to the other solution, and the uniqueness test never saw the search's own
    result: `ok` (scene 16, seed 2: 9 deg off). The search's result is now a rival of a pose that left its
    basin: `ambiguous`."""
    from poseonly import estimate_relative_pose
    from poseonly.sim_hard import critical_surface

    c = critical_surface(200, noise_px=0.5, seed=scene)
    for seed in seeds:
        r = estimate_relative_pose(c.u1, c.u2, c.K, c.K, seed=seed)
        assert r.status != "ok", (seed, r.message)
        assert r.diagnostics.get("rival_search_own") is True
