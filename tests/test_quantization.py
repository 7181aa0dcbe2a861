"""Rounded pixel coordinates (poseonly.quantization): the grid detection, the noise floor in the core's
scales against the numpy references, and the VO trial's failure (a pure yaw on integer keypoints came
back `ok` with R = I, a sideways translation and "1565 inliers within 0.000342 px")."""

from __future__ import annotations

import numpy as np
import pytest

import poseonly
from poseonly import _core, sim
from poseonly.analysis import parallax_ratio, robust_rotation
from poseonly.geometry import as_bearings, rotation_error_deg, rotation_from_rotvec
from poseonly.quantization import axis_step, grid_step, image_grid_step, pair_grid_step, rounding_sigma_px
from poseonly.residuals import v_sampson
from reference.parallax import parallax_ratio as ref_parallax_ratio
from reference.pose_covariance import pose_covariance as reference_covariance

K_KITTI = np.array([[707.09, 0.0, 601.89], [0.0, 707.09, 183.11], [0.0, 0.0, 1.0]])


def _points(n=500, seed=0):
    return np.random.default_rng(seed).uniform(0, 1000, (n, 2))


def test_grid_step_detects_the_grids_detectors_round_to():
    rng = np.random.default_rng(0)
    u = _points()
    assert grid_step(u, u + rng.normal(0, 1, u.shape)) == 0.0  # sub-pixel (SIFT, KLT)
    assert grid_step(u[:30], u[:30] + 2.0) == 0.0  # few sub-pixel values with large gaps
    assert grid_step(np.round(u), np.round(u + 3.3)) == 1.0  # FAST, goodFeaturesToTrack, SuperPoint at full size
    assert grid_step(np.round(u).astype(np.float32), np.round(u + 2.0).astype(np.float32)[:, None, :]) == 1.0  # float32, OpenCV shape
    assert grid_step(np.round(u[:30]), np.round(u[:30] + 5.5)) == 1.0  # sparse: the least gap a multiple of the step
    s = 0.8  # SuperPoint on an image resized by 0.8, mapped back: (i + 0.5) / s - 0.5
    assert grid_step((np.round(u * s) + 0.5) / s - 0.5, (np.round((u + 3.3) * s) + 0.5) / s - 0.5) == pytest.approx(1.25, abs=1e-9)
    orb = np.round(u / 1.2) * 1.2  # one pyramid level's grid in one view, another in the other: exact ties
    mixed = orb.copy()
    mixed[::2] = np.round(u[::2] / 1.44) * 1.44
    assert grid_step(mixed, mixed + [3.5, 0.0]) == 1.0
    off = np.round(u)
    off[0] = [-3.3, -2.7]  # an off-grid smallest value
    assert grid_step(off, off + 2.0) == 1.0
    assert rounding_sigma_px(1.0) == pytest.approx(0.2886751345948129)
    # sparse integers whose least gap is 2: half lie on a 2 px grid by parity, all on the pixel's (a review)
    assert axis_step(np.array([0, 2, 6, 10, 14, 18, 22, 26, 30, 33, 47, 51.0])) == 1.0
    rng = np.random.default_rng(5)
    assert all(axis_step(np.round(rng.uniform(0, 1000, rng.integers(8, 21)))) == 1.0 for _ in range(200))
    assert not any(axis_step(rng.uniform(0, 1000, rng.integers(8, 21))) for _ in range(200))
    # matches that did not move at all (a static overlay, failed tracks) are no evidence of rounding
    still = rng.uniform(0, 1000, (150, 2))
    assert grid_step(np.vstack([u, still]), np.vstack([u + rng.normal(0, 1, u.shape), still])) == 0.0
    assert image_grid_step(np.round(u) + 0.5) == 1.0 and image_grid_step(u) == 0.0
    assert pair_grid_step(1.0, 1.25) == 1.0 and pair_grid_step(1.0, 0.0) == 0.0


@pytest.mark.parametrize("floor_px", [0.3, 3.0])
def test_core_parallax_ratio_with_a_noise_floor_matches_the_reference(floor_px):
    tau = 2.0 / 800.0
    for seed in range(3):
        s = sim.make_scene(300, kind="rotation", camera="pinhole", noise_px=0.5, outlier_fraction=0.3, seed=seed)
        v = v_sampson(s.R, np.array([0.0, 0.0, 1.0]), s.f1, s.f2)
        Rr, _, _ = robust_rotation(s.f1, s.f2, tau)
        floor = floor_px / 800.0
        got, ref = parallax_ratio(Rr, s.f1, s.f2, v, tau, floor), ref_parallax_ratio(Rr, s.f1, s.f2, v, tau, floor)
        np.testing.assert_allclose(got[0], ref[0], rtol=1e-9)
        np.testing.assert_allclose(got[1], ref[1], rtol=1e-12)
        np.testing.assert_allclose(got[2], ref[2], atol=1e-12)
        if floor_px == 3.0:  # above the noise: the scale is the floor's
            assert got[1] == pytest.approx(floor / tau, rel=1e-12)


@pytest.mark.parametrize("rotation_only", [False, True])
def test_core_covariance_with_a_noise_floor_matches_the_reference(rotation_only):
    sc = sim.make_scene(150, "rotation" if rotation_only else "normal", camera="pinhole", noise_px=0.2, seed=4)
    t = None if rotation_only else sc.t
    for floor_px in (0.0, 0.1, 2.0):
        floor = floor_px / 800.0
        Cr, Ct, sigma, _, ok = _core.pose_covariance(sc.R, t, sc.f1, sc.f2, None, 0.0, noise_floor=floor)
        Rr, Rt, rs = reference_covariance(sc.R, t, sc.f1, sc.f2, None, 0.0, noise_floor=floor)
        assert ok and sigma == pytest.approx(rs, rel=1e-10)
        np.testing.assert_allclose(Cr, Rr, rtol=1e-7, atol=1e-9 * np.abs(Rr).max())
        if floor_px == 2.0:  # the floor binds: sqrt(2) of it for the chords of the two views
            assert sigma == pytest.approx(floor * (np.sqrt(2.0) if rotation_only else 1.0), rel=1e-12)
    with pytest.raises(ValueError, match="noise_floor"):
        _core.pose_covariance(sc.R, t, sc.f1, sc.f2, None, 0.0, noise_floor=-1.0)
    # the weights' constant cancels, the floor too (it bounds the highest-weight match's raw errors; a review)
    covs = [_core.pose_covariance(sc.R, t, sc.f1, sc.f2, np.full(150, c), 0.0, noise_floor=2.0 / 800.0)[0] for c in (1.0, 100.0, 0.01)]
    np.testing.assert_allclose(covs[1], covs[0], rtol=1e-9)
    np.testing.assert_allclose(covs[2], covs[0], rtol=1e-9)
    w = np.random.default_rng(0).uniform(0.5, 3.0, 150)
    got = _core.pose_covariance(sc.R, t, sc.f1, sc.f2, w, 0.0, noise_floor=2.0 / 800.0)
    ref = reference_covariance(sc.R, t, sc.f1, sc.f2, w, 0.0, noise_floor=2.0 / 800.0)
    assert got[2] == pytest.approx(ref[2], rel=1e-10)


def _rounded_yaw(deg: float, n: int = 2000, seed: int = 0):
    rng = np.random.default_rng(seed)
    u1 = np.c_[rng.uniform(0, 1226, n), rng.uniform(0, 370, n)]
    R = rotation_from_rotvec(np.array([0.0, np.radians(deg), 0.0]))
    h = np.c_[u1, np.ones(n)] @ (K_KITTI @ R @ np.linalg.inv(K_KITTI)).T
    return np.round(u1), np.round(h[:, :2] / h[:, 2:]), R


@pytest.mark.parametrize("deg", [0.3, 1.0])
def test_pure_yaw_on_integer_keypoints_is_a_pure_rotation(deg):
    """Most matches keep their row, so R = I with a sideways translation fits them exactly; the median
    noise scales collapsed and the pose was `ok` (the trial: 0.3 deg off, 1565 inliers within 0.000342
    px). With the rounding noise as the floor the rotation is found: `pure_rotation`, R within 0.02 deg."""
    u1, u2, R = _rounded_yaw(deg)
    r = poseonly.estimate_relative_pose(u1, u2, K_KITTI)
    assert r.diagnostics["coordinate_step_px"] == 1.0
    assert r.status == "pure_rotation", r.message
    assert rotation_error_deg(R, r.R) < 0.02
    assert r.threshold_px > 0.25 and r.diagnostics["noise_sigma_px"] >= rounding_sigma_px(1.0) * np.sqrt(2.0) * (1 - 1e-9)
    # the same matches given as bearings carry no grid: the step is the caller's to give
    f1, f2 = (as_bearings(x, K_KITTI) for x in (u1, u2))
    rb = poseonly.estimate_relative_pose(f1, f2, focal_px=707.09, coordinate_step_px=1.0)
    assert rb.status == "pure_rotation" and rotation_error_deg(R, rb.R) < 0.02


def test_coordinate_step_option():
    sc = sim.make_scene(200, camera="pinhole", noise_px=0.5, outlier_fraction=0.2, seed=3)
    a = poseonly.estimate_relative_pose(sc.u1, sc.u2, sc.K, seed=0)
    b = poseonly.estimate_relative_pose(sc.u1, sc.u2, sc.K, seed=0, coordinate_step_px=0.0)
    assert "coordinate_step_px" not in a.diagnostics and np.array_equal(a.R, b.R)  # sub-pixel: no floor
    r = poseonly.estimate_relative_pose(np.round(sc.u1), np.round(sc.u2), sc.K, seed=0)
    assert r.status == "ok" and r.diagnostics["coordinate_step_px"] == 1.0 and rotation_error_deg(sc.R, r.R) < 0.5
    for bad in (-1.0, float("nan"), "1", True):
        with pytest.raises(ValueError, match="coordinate_step_px"):
            poseonly.estimate_relative_pose(sc.u1, sc.u2, sc.K, coordinate_step_px=bad)


def test_no_grid_on_sub_pixel_coordinates_of_any_size():
    """float32's relative tolerance at 2e5-5e5 px put sub-pixel values on a grid (a trial)."""
    rng = np.random.default_rng(0)
    for scale in (1e3, 2e5, 5e5, 1e8):
        u = rng.uniform(0, scale, (1000, 2))
        assert grid_step(u, u + rng.normal(0, 1, u.shape)) == 0.0


def test_the_grid_can_be_set_where_keypoints_are_lifted_first(tmp_path):
    """colmap verify's --coordinate-step and sfm's coordinate_step_px estimator option override the
    per-image detection (a trial found no way to set or turn it off)."""
    from poseonly.sfm.pairwise import PairwiseOptions

    assert dict(PairwiseOptions(estimator_options=(("coordinate_step_px", 0.0),)).estimator_options)["coordinate_step_px"] == 0.0
    with pytest.raises(ValueError, match="coordinate_step_px"):
        PairwiseOptions(estimator_options=(("coordinate_step_px", -1.0),))
    pytest.importorskip("pycolmap")
    from poseonly.colmap_verify import verify_database
    from test_colmap import make_db

    path = tmp_path / "db.db"
    make_db(path, n_images=3)
    with pytest.raises(ValueError, match="coordinate_step_px"):
        verify_database(path, progress=False, coordinate_step=-2.0)
    assert verify_database(path, progress=False, coordinate_step=1.0).written == 3
