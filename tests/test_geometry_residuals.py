"""Geometry core and the five residuals of Section 4."""

import numpy as np
import pytest

from poseonly import residuals as res
from poseonly.geometry import (
    as_bearings,
    bearings_from_pixels,
    decompose_essential,
    four_poses,
    project_to_so3,
    rotation_error_deg,
    rotation_from_rotvec,
    skew,
    translation_error_deg,
    triangulate_midpoint,
)
from poseonly.sim import make_scene

ALL = [res.v_E, res.v_BA, res.v_OpenGV, res.v_LiGT, res.v_PPO, res.v_sampson]


def test_skew():
    a, b = np.array([1.0, 2, 3]), np.array([-1.0, 0.5, 2])
    assert np.allclose(skew(a) @ b, np.cross(a, b))


def test_skew_stacked_and_shape_errors():
    rng = np.random.default_rng(3)
    a, b = rng.normal(size=(2, 4, 3)), rng.normal(size=(2, 4, 3))
    S = skew(a)
    assert S.shape == (2, 4, 3, 3)
    assert np.allclose(np.einsum("...ij,...j->...i", S, b), np.cross(a, b), atol=1e-15)
    assert np.array_equal(S, -np.swapaxes(S, -1, -2))
    with pytest.raises(ValueError, match="length 3"):
        skew(np.ones(2))


def test_rotation_error_stable_near_0_and_180():
    for ang in [1e-9, 1e-5, 0.3, 90.0, 179.9, 180.0 - 1e-7]:
        R = rotation_from_rotvec(np.radians(ang) * np.array([0.0, 0.6, 0.8]))
        assert abs(rotation_error_deg(np.eye(3), R) - ang) < 1e-9 * max(1, ang) + 1e-12
    assert translation_error_deg([1, 0, 0], [1, 1e-10, 0]) == pytest.approx(np.degrees(1e-10))
    assert translation_error_deg([1, 0, 0], [-1, 0, 0]) == pytest.approx(180)
    assert translation_error_deg([1, 0, 0], [-1, 0, 0], sign_invariant=True) == pytest.approx(0)


def test_decompose_essential_contains_truth():
    sc = make_scene(20, seed=2)
    E = 3.7 * skew(sc.t) @ sc.R
    Rs, ts = four_poses(-E)
    ok = [(rotation_error_deg(sc.R, R) < 1e-9) and (translation_error_deg(sc.t, t) < 1e-7) for R, t in zip(Rs, ts)]
    assert sum(ok) == 1
    Ra, Rb, t = decompose_essential(E)
    for R in (Ra, Rb):
        assert np.allclose(R @ R.T, np.eye(3)) and np.linalg.det(R) == pytest.approx(1)


def test_bearings_from_pixels_and_projection():
    sc = make_scene(30, camera="pinhole", seed=4)
    f1 = bearings_from_pixels(sc.u1, sc.K)
    assert np.allclose(f1, sc.f1)
    with pytest.raises(ValueError, match="singular"):
        bearings_from_pixels(sc.u1, np.zeros((3, 3)))
    with pytest.raises(ValueError, match="3x3"):
        as_bearings(sc.u1, np.eye(2))


def test_triangulation_exact():
    sc = make_scene(50, seed=5)
    X1, z1, z2 = triangulate_midpoint(sc.R, sc.t * sc.baseline, sc.f1, sc.f2)
    assert np.allclose(X1, sc.X, atol=1e-8)
    assert np.all(z1 > 0) and np.all(z2 > 0)


def test_project_to_so3():
    R = rotation_from_rotvec([0.1, -0.2, 0.3])
    Rn = project_to_so3(R + 1e-6 * np.random.default_rng(0).standard_normal((3, 3)))
    assert np.allclose(Rn @ Rn.T, np.eye(3), atol=1e-12) and rotation_error_deg(R, Rn) < 1e-3


@pytest.mark.parametrize("fn", ALL, ids=lambda f: f.__name__)
def test_residuals_zero_on_exact_and_grow_on_outliers(fn):
    sc = make_scene(200, outlier_fraction=0.3, seed=6)
    v = fn(sc.R, sc.t, sc.f1, sc.f2)
    assert v.shape == (200,)
    assert np.all(v[sc.inliers] < 1e-9)
    assert np.median(v[~sc.inliers]) > 1e-3
    # translation scale does not matter (unit t inside)
    assert np.allclose(fn(sc.R, 5 * sc.t, sc.f1, sc.f2), v)


@pytest.mark.parametrize("fn", ALL, ids=lambda f: f.__name__)
def test_residuals_batched(fn):
    sc = make_scene(50, noise_px=1.0, seed=8)
    Rs = np.stack([sc.R, rotation_from_rotvec([0.01, 0, 0]) @ sc.R, np.eye(3)])
    ts = np.stack([sc.t, sc.t, [0.0, 0.0, 1.0]])
    V = fn(Rs, ts, sc.f1, sc.f2)
    assert V.shape == (3, 50)
    for k in range(3):
        assert np.allclose(V[k], fn(Rs[k], ts[k], sc.f1, sc.f2))


def test_ligt_identity_and_depths():
    sc = make_scene(40, seed=9)
    h, hp, th2 = res.ligt_depths(sc.R, sc.t, sc.f1, sc.f2)
    z1 = h / th2 * sc.baseline
    assert np.allclose(z1[:, None] * sc.f1, sc.X, atol=1e-8)
    assert np.all(h > 0) and np.all(hp > 0)


def test_get_residual():
    assert res.get_residual("LiGT") is res.v_LiGT
    assert res.get_residual("v_E") is res.v_E
    with pytest.raises(ValueError, match="unknown residual"):
        res.get_residual("nope")


def test_unchecked_residuals_equal_the_checked_ones():
    sc = make_scene(50, outlier_fraction=0.3, seed=4)
    for r in (res.v_sampson, res.v_sampson_chiral, res.v_LiGT):
        np.testing.assert_array_equal(r.unchecked(sc.R, 3.0 * sc.t, sc.f1, sc.f2), r(sc.R, 3.0 * sc.t, sc.f1, sc.f2))
        # not float64 C-contiguous: the checked path
        np.testing.assert_array_equal(r.unchecked(np.asfortranarray(sc.R), sc.t, sc.f1, sc.f2), r(sc.R, sc.t, sc.f1, sc.f2))
    bad = sc.R.copy()
    bad[0, 0] = np.nan
    assert np.all(np.isnan(res.v_sampson.unchecked(bad, sc.t, sc.f1, sc.f2)))
    with pytest.raises(ValueError, match="NaN"):
        res.v_sampson(bad, sc.t, sc.f1, sc.f2)


def test_rotvec_from_rotation_equals_scipy_near_0_and_pi():
    """The numpy log map (no scipy.spatial import on the estimator's path) equals scipy's to rounding,
    rotation angles from 1e-16 to pi - 1e-16 (near pi up to the rotation vector's sign)."""
    from scipy.spatial.transform import Rotation

    from poseonly.geometry import rotation_from_rotvec, rotvec_from_rotation

    rng = np.random.default_rng(0)
    axes = rng.normal(size=(1500, 3))
    axes /= np.linalg.norm(axes, axis=1, keepdims=True)
    angles = np.concatenate([rng.uniform(0, np.pi, 500), np.pi - 10.0 ** rng.uniform(-16, -2, 500), 10.0 ** rng.uniform(-16, -2, 500)])
    R = Rotation.from_rotvec(axes * angles[:, None]).as_matrix()
    ours, ref = rotvec_from_rotation(R), Rotation.from_matrix(R).as_rotvec()
    assert np.minimum(np.linalg.norm(ours - ref, axis=1), np.linalg.norm(ours + ref, axis=1)).max() < 1e-14
    assert np.abs(ours - ref)[angles < 3.0].max() < 1e-14
    assert np.abs(rotation_from_rotvec(ours) - R).max() < 1e-14
    assert rotvec_from_rotation(R[:6].reshape(2, 3, 3, 3)).shape == (2, 3, 3)
    assert np.array_equal(rotvec_from_rotation(np.eye(3)), np.zeros(3))


def test_default_estimator_path_imports_no_scipy():
    """The default method and its status analysis import no scipy: a lazy ``scipy.spatial`` import cost
    0.35-0.9 s on the first pair of a VO loop that reached the leverage test (a trial)."""
    import subprocess
    import sys

    code = (
        "import sys, poseonly\n"
        "from poseonly.sim import make_scene\n"
        "for seed, (kind, camera, out) in enumerate([('normal', 'pinhole', 0.0), ('normal', 'pinhole', 0.5), ('planar', 'wide', 0.3), ('normal', 'wide', 0.8)]):\n"
        "    sc = make_scene(200, kind=kind, camera=camera, noise_px=0.5, outlier_fraction=out, seed=seed)\n"
        "    poseonly.estimate_relative_pose(sc.u1, sc.u2, sc.K, seed=seed)\n"
        "poseonly.geometry.rotvec_from_rotation(sc.R)  # the leverage test's, which these scenes need not reach\n"
        "print(sorted(m for m in sys.modules if m.startswith('scipy')))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.strip()
    assert out == "[]", out


def test_opencv_point_arrays_are_accepted():
    """OpenCV's ``(n, 1, 2)`` point arrays (goodFeaturesToTrack, calcOpticalFlowPyrLK) give the same result
    as ``(n, 2)``, with K and with a distorted camera (a VO trial found them refused)."""
    import poseonly
    from poseonly.cameras import Camera

    sc = make_scene(80, camera="pinhole", noise_px=0.3, outlier_fraction=0.2, seed=4)
    a = poseonly.estimate_relative_pose(sc.u1, sc.u2, sc.K, seed=1)
    b = poseonly.estimate_relative_pose(sc.u1[:, None, :], sc.u2[:, None, :], sc.K, seed=1)
    assert b.status == a.status and np.allclose(b.R, a.R, atol=1e-12)
    K = sc.K
    cam = Camera("PINHOLE", 2 * int(K[0, 2]), 2 * int(K[1, 2]), (K[0, 0], K[1, 1], K[0, 2], K[1, 2]))
    c = poseonly.estimate_relative_pose(sc.u1[:, None, :], sc.u2[:, None, :], camera1=cam, seed=1)
    assert c.status == a.status and np.allclose(c.R, a.R, atol=1e-9)
    with pytest.raises(ValueError, match="shape"):
        poseonly.estimate_relative_pose(sc.u1[:, None, None, :], sc.u2, sc.K)
    with pytest.raises(ValueError, match="shape"):
        poseonly.estimate_relative_pose(sc.u1.reshape(-1, 2, 1), sc.u2, sc.K)


def test_residuals_refuse_broken_preconditions():
    """Bearings that are not unit, an R that is not a rotation and a zero t gave wrong residuals without an
    error (bearings times 3: negative v_OpenGV; t = 0: every match fit; an adversarial trial)."""
    sc = make_scene(30, camera="pinhole", seed=0)
    R, t, f1, f2 = sc.R, sc.t, sc.f1, sc.f2
    for fn in (res.v_E, res.v_LiGT, res.v_OpenGV, res.v_sampson):
        with pytest.raises(ValueError, match="f1 must be unit bearing vectors"):
            fn(R, t, 3 * f1, f2)
        with pytest.raises(ValueError, match="f2 must be unit bearing vectors"):
            fn(R, t, f1, np.zeros_like(f2))
        with pytest.raises(ValueError, match="rotation"):
            fn(np.zeros((3, 3)), t, f1, f2)
        with pytest.raises(ValueError, match="rotation"):
            fn(np.stack([R, -R]), np.stack([t, t]), f1, f2)  # det -1 in a stack
        with pytest.raises(ValueError, match="non-zero length"):
            fn(R, np.zeros(3), f1, f2)
        assert np.all(np.isfinite(fn(R, t, f1.astype(np.float32), f2)))  # float32 storage of unit bearings is unit


def test_library_calls_on_placeholder_poses_do_not_raise():
    """The library's own residual calls on a search's placeholder pose (no hypothesis scored) take the
    unchecked path for stacked poses too: final="ligt" raised "R must be rotation matrices" on random
    bearings (a review); the status says what happened."""
    import poseonly

    r = np.random.default_rng(25)
    r.integers(6, 12)
    a, b = r.normal(size=(9, 3)), r.normal(size=(9, 3))
    out = poseonly.estimate_relative_pose(a, b, focal_px=800, final="ligt", seed=25)
    assert out.status in ("degenerate", "too_few_inliers")
    R = np.zeros((2, 3, 3))  # unchecked: any values, the shapes only
    assert res.v_sampson.unchecked(R, np.zeros((2, 3)), a / np.linalg.norm(a, axis=1)[:, None], b / np.linalg.norm(b, axis=1)[:, None]).shape == (2, 9)
