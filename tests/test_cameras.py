"""Camera models (issue 13 item 1): native unprojection equals pycolmap's, round trips, bad input,
and the pose through a distorted camera is as accurate as through the undistorted one."""

import numpy as np
import pytest

from poseonly import estimate_relative_pose, rotation_error_deg
from poseonly.cameras import MODELS, Camera, as_camera, camera_from_text, from_opencv
from poseonly.geometry import InputError, rotation_from_rotvec
from poseonly.sim import default_K, make_scene

PARAMS = {
    "SIMPLE_PINHOLE": [800, 320, 240],
    "PINHOLE": [800, 810, 320, 240],
    "SIMPLE_RADIAL": [800, 320, 240, -0.1],
    "RADIAL": [800, 320, 240, -0.1, 0.02],
    "OPENCV": [800, 810, 320, 240, -0.2, 0.05, 0.001, -0.002],
    "OPENCV_FISHEYE": [400, 410, 320, 240, 0.05, -0.01, 0.003, -0.0005],
    "FULL_OPENCV": [800, 810, 320, 240, -0.2, 0.05, 0.001, -0.002, 0.01, 0.02, 0.003, 0.001],
    "FOV": [500, 505, 320, 240, 0.9],
    "SIMPLE_RADIAL_FISHEYE": [400, 320, 240, 0.05],
    "RADIAL_FISHEYE": [400, 320, 240, 0.05, -0.01],
    "THIN_PRISM_FISHEYE": [400, 410, 320, 240, 0.05, -0.01, 0.001, -0.002, 0.003, -0.0005, 0.001, -0.001],
    "RAD_TAN_THIN_PRISM_FISHEYE": [400, 410, 320, 240, 0.05, -0.01, 0.003, -0.0005, 0.0001, -0.00001, 0.001, -0.002, 0.001, -0.0005, 0.0008, 0.0002],
    "SIMPLE_DIVISION": [800, 320, 240, -0.1],
    "DIVISION": [800, 810, 320, 240, -0.15],
    "SIMPLE_FISHEYE": [400, 320, 240],
    "FISHEYE": [400, 410, 320, 240],
    "EUCM": [400, 410, 320, 240, 0.6, 1.1],
}
assert set(PARAMS) == set(MODELS)


def _pixels(n=500, seed=0):
    return np.random.default_rng(seed).uniform(0, 1, (n, 2)) * [640, 480]


@pytest.mark.parametrize("model", sorted(PARAMS))
def test_equals_pycolmap(model):
    pycolmap = pytest.importorskip("pycolmap")
    pc = pycolmap.Camera(model=model, width=640, height=480, params=PARAMS[model])
    cam = as_camera(pc)
    uv = _pixels()
    b = cam.unproject(uv)
    x = pc.cam_from_img(uv)
    bp = np.column_stack([x, np.ones(len(x))])
    bp /= np.linalg.norm(bp, axis=1)[:, None]
    assert np.abs(b - bp).max() < 1e-9
    X = b * np.random.default_rng(1).uniform(1, 5, (len(b), 1))
    assert np.abs(cam.project(X) - pc.img_from_cam(X)).max() < 1e-9
    assert cam.focal_px == pytest.approx(pc.mean_focal_length())


@pytest.mark.parametrize("model", sorted(PARAMS))
def test_round_trip(model):
    cam = Camera(model, 640, 480, tuple(float(v) for v in PARAMS[model]))
    uv = _pixels(seed=2)
    b = cam.unproject(uv)
    assert b.shape == (500, 3) and np.allclose(np.linalg.norm(b, axis=1), 1.0)
    assert np.abs(cam.project(b) - uv).max() < 1e-9


def test_fisheye_beyond_90_degrees():
    cam = Camera("OPENCV_FISHEYE", 0, 0, (300.0, 300.0, 500.0, 500.0, 0.01, -0.002, 0.0, 0.0))
    b = np.array([[np.sin(np.radians(100.0)), 0.0, np.cos(np.radians(100.0))], [0.0, 0.0, 1.0]])
    assert np.allclose(cam.unproject(cam.project(b)), b, atol=1e-12)


def test_specs_agree():
    K = np.array([[800.0, 0, 320], [0, 810.0, 240], [0, 0, 1]])
    d = [-0.2, 0.05, 0.001, -0.002]
    a = from_opencv(K, d, 640, 480)
    assert a.model == "OPENCV" and a.params == tuple(PARAMS["OPENCV"])
    assert as_camera((K, d)) == Camera("OPENCV", 0, 0, a.params)
    assert as_camera({"K": K, "dist": d, "width": 640, "height": 480}) == a
    assert as_camera(a.to_dict()) == a
    assert from_opencv(K).model == "PINHOLE" and from_opencv(K).is_undistorted and not a.is_undistorted
    assert from_opencv(K, d + [0.01]).model == "FULL_OPENCV"
    assert from_opencv(K, [0.1, 0, 0, 0], fisheye=True).model == "OPENCV_FISHEYE"


def test_equals_opencv_undistort_points():
    cv2 = pytest.importorskip("cv2")
    K = np.array([[800.0, 0, 320], [0, 810.0, 240], [0, 0, 1]])
    d = np.array([-0.2, 0.05, 0.001, -0.002, 0.01])
    uv = _pixels(seed=3)
    x = cv2.undistortPoints(uv[:, None], K, d, criteria=(cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 200, 1e-15))[:, 0]
    b = from_opencv(K, d).unproject(uv)
    assert np.abs(b[:, :2] / b[:, 2:] - x).max() < 1e-6  # OpenCV's fixed-point iteration is the less precise


@pytest.mark.parametrize(
    "spec, msg",
    [
        ({"model": "FOO", "params": [1, 2, 3]}, "unsupported camera model"),
        ({"model": "OPENCV", "params": [800, 800, 320, 240]}, "takes 8 parameters"),
        ({"model": "PINHOLE", "params": [0, 800, 320, 240]}, "focal length must be > 0"),
        ({"model": "PINHOLE", "params": [np.nan, 800, 320, 240]}, "NaN"),
        ({"width": 3}, "missing"),
        ("OPENCV", "must be a poseonly Camera"),
        ((np.eye(3), [0.1, 0.2, 0.3]), "4, 5, 8, 12 or 14 coefficients"),
        ((np.eye(3), np.zeros(7)), "4, 5, 8, 12 or 14 coefficients"),  # zeros too (was a pinhole)
        ((np.eye(3), [0.1, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.01, 0.0, 0.0, 0.0]), "thin-prism"),
        ((np.array([[1.0, 0.5, 0], [0, 1, 0], [0, 0, 1]]), None), "no skew"),
    ],
)
def test_bad_specs(spec, msg):
    with pytest.raises(ValueError, match=msg):
        as_camera(spec)


def test_bad_points_and_non_invertible():
    cam = Camera("SIMPLE_RADIAL", 640, 480, (100.0, 320.0, 240.0, -0.5))
    with pytest.raises(InputError, match=r"shape \(n, 2\)"):
        cam.unproject(np.zeros((3, 3)))
    with pytest.raises(InputError, match="NaN"):
        cam.unproject(np.array([[np.nan, 1.0]]))
    # r_d = r (1 - 0.5 r^2) has its maximum 0.544 at r = 0.816: a point at r_d = 3 has no preimage
    with pytest.raises(InputError, match="did not converge for 1 of 2 points"):
        cam.unproject(np.array([[320.0, 240.0], [620.0, 240.0]]))


def test_points_past_the_first_fold_or_180_degrees_are_refused():
    """A root on a later rising branch of the distortion (after the map folds back) or a fisheye angle
    past 180 deg is not the point's preimage (a user trial: 181-400 deg came back as 179-40 deg, and a
    polynomial that rises, falls and rises again gave 102 deg where its physical branch ends at 49)."""
    fe = Camera("OPENCV_FISHEYE", 2000, 2000, (300.0, 300.0, 1000.0, 1000.0, 0.0, 0.0, 0.0, 0.0))
    deg = np.array([45.0, 179.0, 181.0, 270.0, 400.0])
    uv = np.column_stack([1000.0 + 300.0 * np.radians(deg), np.full(5, 1000.0)])
    ok = np.isfinite(fe.unproject(uv, invalid="nan")[:, 0])
    assert ok.tolist() == [True, True, False, False, False]
    assert np.isnan(fe.project(np.array([[0.0, 0.0, -1.0]]))).all()  # 180 deg has no image (was the principal point)
    folded = Camera("OPENCV_FISHEYE", 2000, 2000, (300.0, 300.0, 1000.0, 1000.0, -0.6, 0.12, 0.0, 0.0))
    # theta (1 - 0.6 theta^2 + 0.12 theta^4) peaks at 0.5348 (49.2 deg), dips, then rises again
    rd = np.array([0.50, 0.53, 0.54, 0.6])
    assert np.isfinite(folded.unproject(np.column_stack([1000.0 + 300.0 * rd, np.full(4, 1000.0)]), invalid="nan")[:, 0]).tolist() == [True, True, False, False]
    radial = Camera("RADIAL", 2000, 2000, (300.0, 1000.0, 1000.0, -0.6, 0.12))
    assert np.isfinite(radial.unproject(np.column_stack([1000.0 + 300.0 * rd, np.full(4, 1000.0)]), invalid="nan")[:, 0]).tolist() == [True, True, False, False]


def test_unknown_camera_keys_and_flags_are_refused():
    """A distortion given beside a COLMAP model's params, or a fisheye flag that is not a bool, was
    silently ignored or read as true (a user trial: ok 11.7 deg off; ambiguous 18.7 deg off)."""
    with pytest.raises(InputError, match="unknown keys"):
        as_camera({"model": "PINHOLE", "width": 640, "height": 480, "params": [800, 800, 320, 240], "dist": [-0.28, 0.1, 0, 0]})
    with pytest.raises(InputError, match="fisheye must be True or False"):
        as_camera({"K": default_K(), "dist": [0.1, 0.0, 0.0, 0.0], "fisheye": "no"})
    assert as_camera({"K": default_K(), "dist": [0.1, 0.0, 0.0, 0.0], "fisheye": np.bool_(True)}).model == "OPENCV_FISHEYE"


def test_two_focal_lengths_share_one_threshold_by_their_noise():
    """A 300 px view beside a 3000 px one: the threshold's angle is the root mean square of the two
    views' (pair_focal), not the mean focal's, which put the short lens's 0.5 px noise outside 1 px."""
    from poseonly.geometry import pair_focal

    assert pair_focal(800.0, 800.0) == 800.0 and pair_focal(300.0, 3000.0) == pytest.approx(300.0 * np.sqrt(2.0 / 1.01))
    assert pair_focal(3000.0, 300.0) == pair_focal(300.0, 3000.0)
    rng = np.random.default_rng(1)
    X = np.column_stack([rng.uniform(-1, 1, 300), rng.uniform(-0.8, 0.8, 300), rng.uniform(6, 14, 300)])
    K1 = np.array([[300.0, 0, 320], [0, 300, 240], [0, 0, 1]])
    K2 = np.array([[3000.0, 0, 320], [0, 3000, 240], [0, 0, 1]])
    R = rotation_from_rotvec(np.radians([0.5, -1.0, 0.5]))
    C = np.array([1.0, 0.1, 0.2])

    def project(K: np.ndarray, Y: np.ndarray) -> np.ndarray:
        return (Y[:, :2] / Y[:, 2:]) * K[0, 0] + K[:2, 2] + rng.normal(0, 0.5, (len(Y), 2))

    u1, u2 = project(K1, X), project(K2, (X - C) @ R.T)
    r = estimate_relative_pose(u1, u2, K1, K2, seed=0)
    assert r.focal_px == pytest.approx(pair_focal(300.0, 3000.0))
    assert r.status == "ok" and r.num_inliers >= 0.95 * 300, r.message
    assert estimate_relative_pose(u1, u2, K1, K2, seed=0, focal_px=1650.0).num_inliers < 0.7 * 300  # the mean focal


def test_api_camera_arguments():
    sc = make_scene(100, camera="pinhole", noise_px=0.5, seed=4)
    cam = Camera("PINHOLE", 640, 480, (800.0, 800.0, 320.0, 240.0))
    r = estimate_relative_pose(sc.u1, sc.u2, camera1=cam)
    r0 = estimate_relative_pose(sc.u1, sc.u2, default_K())
    assert r.focal_px == 800.0 and np.allclose(r.R, r0.R, atol=1e-9)
    with pytest.raises(ValueError, match="not both"):
        estimate_relative_pose(sc.u1, sc.u2, default_K(), camera1=cam)
    with pytest.raises(ValueError, match="bearing vectors"):
        estimate_relative_pose(sc.f1, sc.f2, camera1=cam)


DISTORTED = {
    "OPENCV": Camera("OPENCV", 640, 480, (800.0, 800.0, 320.0, 240.0, -0.25, 0.08, 0.001, -0.0015)),
    "OPENCV_FISHEYE": Camera("OPENCV_FISHEYE", 640, 480, (800.0, 800.0, 320.0, 240.0, -0.05, 0.01, -0.002, 0.0003)),
}


@pytest.mark.parametrize("model", sorted(DISTORTED))
def test_distorted_camera_as_accurate(model):
    """The same scenes (1 px noise at f = 800 on the bearings, 20 % outliers) imaged by the distorted
    camera and by the undistorted one: median rotation error within 1.05x."""
    cam = DISTORTED[model]
    pin = Camera("PINHOLE", 640, 480, (800.0, 800.0, 320.0, 240.0))
    e0, e1 = [], []
    for s in range(8):
        sc = make_scene(200, camera="pinhole", noise_px=1.0, outlier_fraction=0.2, seed=s)
        d1, d2 = cam.project(sc.f1), cam.project(sc.f2)
        assert np.abs(d1 - pin.project(sc.f1)).max() > 5.0  # the distortion is not negligible
        r0 = estimate_relative_pose(pin.project(sc.f1), pin.project(sc.f2), default_K(), seed=s)
        r1 = estimate_relative_pose(d1, d2, camera1=cam, seed=s)
        e0.append(rotation_error_deg(sc.R, r0.R))
        e1.append(rotation_error_deg(sc.R, r1.R))
    assert np.median(e1) <= 1.05 * np.median(e0), (np.median(e0), np.median(e1))
    assert np.median(e0) < 1.0


@pytest.mark.parametrize(
    "k", [(-0.1, 0.01, 0.0, 0.0, 0, 0, 0, 0), (-0.3, 0.1, 0.002, -0.001, 0.01, 0.02, 0.001, 0.0001), (0.5, 0.0, 0, 0, 0, 0, 0, 0), (-0.6, 0, 0, 0, 0, 0, 0, 0)]
)
def test_core_undistortion_equals_the_numpy_reference(k):
    """The core's Newton undistortion gives the numpy reference's roots bit for bit, and the same
    verdicts, on points inside and far beyond the distortion's fold (tests/reference/cameras.py)."""
    from poseonly import _core
    from poseonly.cameras import NEWTON_MAX_ITER, NEWTON_TOL
    from reference import cameras as ref

    rng = np.random.default_rng(3)
    xd, yd = rng.uniform(-2.0, 2.0, 2000), rng.uniform(-2.0, 2.0, 2000)
    xd[:5] = [0.0, np.nan, np.inf, 1e6, -1e-300]
    u, v, ok = _core.undistort_brown(xd, yd, np.array(k, float), NEWTON_TOL, NEWTON_MAX_ITER)
    with np.errstate(all="ignore"):
        ur, vr, okr = ref.undistort_brown(xd, yd, np.array(k, float))
    same = ok.astype(bool) == okr
    assert same.all(), np.flatnonzero(~same)
    assert np.array_equal(u[okr], ur[okr]) and np.array_equal(v[okr], vr[okr])
    assert 0 < okr.sum() < len(okr) or k[0] >= 0


def test_core_fisheye_undistortion_equals_the_numpy_reference():
    from poseonly import _core
    from poseonly.cameras import NEWTON_MAX_ITER, NEWTON_TOL
    from reference import cameras as ref

    rd = np.concatenate([np.linspace(0.0, 4.0, 1500), [np.nan, np.inf, 1e-14]])
    for k in [(0.05, -0.01, 0.002, -0.0003), (-0.2, 0.05, 0.0, 0.0)]:
        th, ok = _core.undistort_fisheye(rd, np.array(k), NEWTON_TOL, NEWTON_MAX_ITER)
        with np.errstate(all="ignore"):
            thr, okr = ref.undistort_fisheye(rd, np.array(k))
        assert np.array_equal(ok.astype(bool), okr)
        assert np.array_equal(th[okr], thr[okr])


def test_as_colmap_camera_converts_opencv_descriptions_only():
    """``as_colmap_camera``: an OpenCV ``(K, dist)`` (tuple or dict) moves its principal point by
    OPENCV_TO_COLMAP_PX, so that OpenCV pixels shifted by it lift to the bearings the OpenCV camera
    gives the unshifted pixels; COLMAP-style descriptions are taken as they are."""
    import numpy as np

    from poseonly.cameras import OPENCV_TO_COLMAP_PX, as_camera, as_colmap_camera

    K = np.array([[800.0, 0.0, 319.5], [0.0, 810.0, 239.5], [0.0, 0.0, 1.0]])
    dist = np.array([-0.1, 0.02, 0.001, -0.0005])
    u = np.random.default_rng(0).uniform([0, 0], [640, 480], (50, 2))
    for spec in ((K, dist), {"K": K, "dist": dist}):
        cam = as_colmap_camera(spec)
        assert cam.principal_point == (319.5 + OPENCV_TO_COLMAP_PX, 239.5 + OPENCV_TO_COLMAP_PX)
        np.testing.assert_allclose(cam.unproject(u + OPENCV_TO_COLMAP_PX), as_camera(spec).unproject(u), atol=1e-12)
    colmap = {"model": "SIMPLE_RADIAL", "width": 640, "height": 480, "params": [800.0, 320.0, 240.0, -0.1]}
    assert as_colmap_camera(colmap) == as_camera(colmap)


def test_relpose_matches_leaves_out_what_the_camera_cannot_lift():
    """Matches given as pixels with a camera model: a keypoint the model cannot undistort leaves its
    match out and counted, as with images (a user trial: the whole call failed on 3 corners of 303)."""
    from poseonly.pipeline import relpose_matches

    cam = Camera("OPENCV_FISHEYE", 2000, 2000, (300.0, 300.0, 1000.0, 1000.0, 0.0, 0.0, 0.0, 0.0))
    sc = make_scene(200, camera="pinhole", noise_px=0.0, seed=2)
    u1, u2 = cam.project(sc.f1), cam.project(sc.f2)
    past = np.array([[1000.0 + 300.0 * np.radians(200.0), 1000.0]] * 3)  # 200 deg off-axis
    x1, x2 = np.r_[u1, past], np.r_[u2, u2[:3]]
    scores = np.linspace(1.0, 0.0, len(x1))
    pr = relpose_matches(x1, x2, None, None, camera1=cam, scores=scores, seed=0)
    assert pr.dropped == 3 and len(pr.u1) == 200
    assert pr.result.status == "ok" and rotation_error_deg(sc.R, pr.result.R) < 1e-6
    with pytest.raises(InputError, match="did not converge for 3 of 203"):
        estimate_relative_pose(x1, x2, camera1=cam)


def test_relpose_cli_reports_inliers_as_the_files_rows(tmp_path, capsys):
    """`relpose --matches` with a camera: rows left out keep the reported inliers (--json indices,
    --save mask) in the file's numbering (a review: indices 0-119 for file rows 10-129)."""
    import json

    from poseonly.cli import main

    cam = Camera("SIMPLE_RADIAL", 640, 480, (800.0, 320.0, 240.0, -0.5))  # no preimage beyond 0.544 (435 px)
    sc = make_scene(120, camera="pinhole", noise_px=0.3, seed=1)
    bad = np.tile([[920.0, 240.0]], (10, 1))
    np.savez(tmp_path / "m.npz", u1=np.r_[bad, cam.project(sc.f1)], u2=np.r_[bad, cam.project(sc.f2)])
    args = ["relpose", "--matches", str(tmp_path / "m.npz"), "--camera-model", "SIMPLE_RADIAL", "--camera-params", "800,320,240,-0.5"]
    assert main([*args, "--json", "--save", str(tmp_path / "out.npz")]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["num_dropped"] == 10 and min(d["inliers"]) >= 10 and len(d["inliers"]) >= 110
    saved = np.load(tmp_path / "out.npz")["inliers"]
    assert saved.shape == (130,) and not saved[:10].any() and np.flatnonzero(saved).tolist() == d["inliers"]
    # the record reads back over the file's rows (a review: num_points counted the kept rows only)
    from poseonly.result import RelativePoseResult

    back = RelativePoseResult.from_dict(d)
    assert d["num_points"] == 130 and np.array_equal(back.inliers, saved.astype(bool))


@pytest.mark.parametrize(
    "model, params, size",
    [
        ("OPENCV_FISHEYE", (348.0, 348.0, 640.0, 480.0, -0.197, 0.139, 0.135, -0.038), (1280, 960)),
        ("FULL_OPENCV", (500.0, 500.0, 640.0, 480.0, 0.8, -0.5, 0.0005, 0.0003, 0.1, 1.2, -0.3, 0.05), (1280, 960)),
    ],
)
def test_strong_distortion_lifts_every_in_image_pixel(model, params, size):
    """Newton's method from the distorted point oscillates or lands past the fold on these cameras (a SLAM
    user's trial: the fisheye's corner pixel, whose ray is 80.88 deg off-axis, and 919 pixels of the
    rational camera were refused as "outside the invertible region"); the fallback (a bracketed radial
    root, damped Newton) lifts every pixel of the image, and each ray projects back onto its pixel."""
    cam = Camera(model, size[0], size[1], params)
    g = np.stack(np.meshgrid(np.linspace(0, size[0], 81), np.linspace(0, size[1], 61)), -1).reshape(-1, 2)
    rays = cam.unproject(g)
    assert np.all(np.isfinite(rays))
    assert np.allclose(cam.project(rays), g, atol=1e-7, rtol=0)
    if model == "OPENCV_FISHEYE":
        corner = cam.unproject(np.array([[0.0, 0.0]]))[0]
        assert abs(np.degrees(np.arccos(corner[2] / np.linalg.norm(corner))) - 80.8818) < 1e-3


def test_read_colmap_cameras(tmp_path):
    """COLMAP's cameras.txt (a SLAM user's trial: a full line had no parser)."""
    from poseonly.cameras import read_colmap_cameras

    f = tmp_path / "cameras.txt"
    f.write_text("# Camera list with one line of data per camera:\n\n1 OPENCV 640 480 500 502 320 240 -0.1 0.01 0.001 0.0\n2 PINHOLE 800 600 700 700 400 300\n")
    cams = read_colmap_cameras(f)
    assert sorted(cams) == [1, 2] and cams[1].model == "OPENCV" and cams[1].width == 640 and cams[2].focal_px == 700.0
    assert cams[1] == camera_from_text("OPENCV", "500 502 320 240 -0.1 0.01 0.001 0.0", 640, 480)
    with pytest.raises(ValueError, match="line 2: camera id 1 is given twice"):
        read_colmap_cameras(["1 PINHOLE 8 6 7 7 4 3", "1 PINHOLE 8 6 7 7 4 3"])
    with pytest.raises(ValueError, match="line 1: expected CAMERA_ID MODEL"):
        read_colmap_cameras(["1 PINHOLE 8"])
    with pytest.raises(ValueError, match="line 1: .*PINHOLE"):
        read_colmap_cameras(["1 PINHOLE 8 6 7 7"])  # too few parameters
    lines = ["1 PINHOLE 800 600 700 700 400 300", "2 EQUIRECTANGULAR 2000 1000 2000 1000"]
    with pytest.raises(ValueError, match="line 2: .*unsupported camera model 'EQUIRECTANGULAR'"):
        read_colmap_cameras(lines)
    assert sorted(read_colmap_cameras(lines, skip_unsupported=True)) == [1]
    with pytest.raises(ValueError, match="line 2: .*PINHOLE takes 4"):
        read_colmap_cameras(["2 EQUIRECTANGULAR 2000 1000 2000 1000", "1 PINHOLE 800 600 700 700 400"], skip_unsupported=True)


def test_core_fallback_equals_the_numpy_reference():
    """Where Newton fails (the rational camera of the SLAM trial: 919 pixels of its grid), the core's
    fallback gives the reference's roots bit for bit (a review: the earlier cases never reached it)."""
    from poseonly import _core
    from poseonly.cameras import NEWTON_MAX_ITER, NEWTON_TOL
    from reference import cameras as ref

    fx, fy, cx, cy, *k = (500.0, 500.0, 640.0, 480.0, 0.8, -0.5, 0.0005, 0.0003, 0.1, 1.2, -0.3, 0.05)
    g = np.stack(np.meshgrid(np.linspace(0, 1280, 161), np.linspace(0, 960, 121)), -1).reshape(-1, 2)
    xd, yd = (g[:, 0] - cx) / fx, (g[:, 1] - cy) / fy
    u, v, ok = _core.undistort_brown(xd, yd, np.array(k, float), NEWTON_TOL, NEWTON_MAX_ITER)
    with np.errstate(all="ignore"):
        ur, vr, okr = ref.undistort_brown(xd, yd, np.array(k, float))
        # the plain Newton verdicts: the fallback's points are those it refused
        ref_fb, ref.brown_fallback = ref.brown_fallback, lambda *a: None
        try:
            _, _, plain = ref.undistort_brown(xd, yd, np.array(k, float))
        finally:
            ref.brown_fallback = ref_fb
    assert okr.all() and (~plain).sum() > 500  # every pixel lifted, hundreds by the fallback
    assert np.array_equal(ok.astype(bool), okr)
    assert np.array_equal(u, ur) and np.array_equal(v, vr)


@pytest.mark.parametrize(
    "model, params",
    [
        ("RADIAL_FISHEYE", (300.0, 500.0, 500.0, 0.02, -0.003)),
        ("FISHEYE", (300.0, 310.0, 500.0, 500.0)),
        ("THIN_PRISM_FISHEYE", (300.0, 300.0, 500.0, 500.0, 0.02, -0.003, 0.001, -0.001, 0.0005, -0.0001, 0.002, -0.001)),
        ("RAD_TAN_THIN_PRISM_FISHEYE", (300.0, 300.0, 500.0, 500.0, 0.02, -0.003, 0.0005, -0.0001, 1e-5, -1e-6, 0.001, -0.001, 0.001, 0.0002, -0.001, 0.0001)),
        ("SIMPLE_DIVISION", (300.0, 500.0, 500.0, -0.4)),
        ("EUCM", (300.0, 300.0, 500.0, 500.0, 0.65, 1.2)),
    ],
)
def test_wide_models_beyond_90_degrees(model, params):
    """Rays up to 110 deg off the axis (behind the image plane, where COLMAP's normalized coordinates
    mirror them) project and lift back onto themselves."""
    cam = Camera(model, 1000, 1000, params)
    rng = np.random.default_rng(5)
    ang = np.radians(rng.uniform(0.0, 110.0, 300))
    phi = rng.uniform(0, 2 * np.pi, 300)
    b = np.column_stack([np.sin(ang) * np.cos(phi), np.sin(ang) * np.sin(phi), np.cos(ang)])
    uv = cam.project(b)
    assert np.all(np.isfinite(uv))
    assert np.abs(cam.unproject(uv) - b).max() < 1e-9


def _prism_oracle(model, params, uv):
    """Bearings by scipy's root finder on the published distortion equations (independent of the core)."""
    from scipy.optimize import root

    from poseonly.cameras import _prism_distort, _prism_params

    kind = {"THIN_PRISM_FISHEYE": 0, "RAD_TAN_THIN_PRISM_FISHEYE": 1}[model]
    k = _prism_params(model, tuple(params))
    fx, fy, cx, cy = params[:4]
    out = []
    for x, y in uv:
        xd, yd = (x - cx) / fx, (y - cy) / fy
        sol = root(lambda p: np.array(_prism_distort(kind, k, np.array([p[0]]), np.array([p[1]]))).ravel() - [xd, yd], [xd, yd], tol=1e-15)
        uu, vv = sol.x
        th = np.hypot(uu, vv)
        out.append([uu * np.sin(th) / th, vv * np.sin(th) / th, np.cos(th)])
    return np.array(out)


@pytest.mark.parametrize("model", ["THIN_PRISM_FISHEYE", "RAD_TAN_THIN_PRISM_FISHEYE"])
def test_prism_undistortion_equals_an_independent_root_finder(model):
    cam = Camera(model, 640, 480, tuple(float(v) for v in PARAMS[model]))
    uv = _pixels(n=60, seed=7)
    assert np.abs(cam.unproject(uv) - _prism_oracle(model, PARAMS[model], uv)).max() < 1e-9


def test_prism_without_tangential_terms_is_the_opencv_fisheye():
    """THIN_PRISM_FISHEYE with p = s = 0 is OPENCV_FISHEYE (the same theta polynomial): the same rays,
    up to the fold and past it (refused by both); with Newton cut to one step the fallback (the radial
    part's bracketed root, then damped Newton) gives them too."""
    from poseonly import _core
    from poseonly.cameras import NEWTON_TOL, _prism_params

    k = (-0.3, 0.02, 0.0, 0.0)
    prism = Camera("THIN_PRISM_FISHEYE", 1000, 1000, (350.0, 350.0, 500.0, 500.0, k[0], k[1], 0.0, 0.0, k[2], k[3], 0.0, 0.0))
    fish = Camera("OPENCV_FISHEYE", 1000, 1000, (350.0, 350.0, 500.0, 500.0, *k))
    g = np.stack(np.meshgrid(np.linspace(0, 1000, 61), np.linspace(0, 1000, 61)), -1).reshape(-1, 2)
    a, b = prism.unproject(g, invalid="nan"), fish.unproject(g, invalid="nan")
    ok = np.isfinite(b).all(axis=1)
    assert 0.2 < ok.mean() < 0.9  # the corners lie past the fold
    assert np.array_equal(np.isfinite(a).all(axis=1), ok)
    assert np.abs(a[ok] - b[ok]).max() < 1e-12
    xd, yd = (g[:, 0] - 500.0) / 350.0, (g[:, 1] - 500.0) / 350.0
    uu, vv, ok1 = _core.undistort_prism(xd, yd, 0, _prism_params("THIN_PRISM_FISHEYE", prism.params), NEWTON_TOL, 1)
    assert np.array_equal(ok1.astype(bool), ok)
    th = np.hypot(uu[ok], vv[ok])
    assert np.abs(np.cos(th) - b[ok, 2]).max() < 1e-12
    with pytest.raises(ValueError, match="did not converge for .* points"):
        prism.unproject(g)


def test_model_checks_and_pinhole_verdicts():
    with pytest.raises(ValueError, match="EUCM camera needs 0 <= alpha <= 1 and beta > 0"):
        Camera("EUCM", 0, 0, (300.0, 300.0, 0.0, 0.0, 1.2, 1.0))
    with pytest.raises(ValueError, match="EUCM camera needs"):
        Camera("EUCM", 0, 0, (300.0, 300.0, 0.0, 0.0, 0.5, 0.0))
    assert Camera("EUCM", 0, 0, (300.0, 300.0, 0.0, 0.0, 0.0, 1.0)).is_undistorted
    assert Camera("DIVISION", 0, 0, (300.0, 300.0, 0.0, 0.0, 0.0)).is_undistorted
    assert Camera("FOV", 0, 0, (300.0, 300.0, 0.0, 0.0, 0.0)).is_undistorted
    assert not Camera("FOV", 0, 0, (300.0, 300.0, 0.0, 0.0, 0.5)).is_undistorted
    # an equidistant fisheye bends straight lines even with zero coefficients: no fundamental matrix
    assert not Camera("FISHEYE", 0, 0, (300.0, 300.0, 0.0, 0.0)).is_undistorted
    assert not Camera("OPENCV_FISHEYE", 0, 0, (300.0, 300.0, 0.0, 0.0, 0, 0, 0, 0)).is_undistorted
    # FOV's image ends at r_d omega = pi / 2; a division model with k > 0 folds at k r^2 = 1
    fov = Camera("FOV", 0, 0, (100.0, 100.0, 0.0, 0.0, 1.0))
    assert np.isnan(fov.unproject(np.array([[170.0, 0.0]]), invalid="nan")).all()
    div = Camera("SIMPLE_DIVISION", 0, 0, (100.0, 0.0, 0.0, 0.25))
    assert np.isfinite(div.unproject(np.array([[190.0, 0.0]]))).all() and np.isnan(div.unproject(np.array([[210.0, 0.0]]), invalid="nan")).all()


def test_opencv_fisheye_tuple_needs_its_flag():
    """``(K, dist)`` with four coefficients is cv2.undistortPoints' (k1, k2, p1, p2); a cv2.fisheye user
    passes ``(K, dist, True)`` (a trial: the 2-tuple read the fisheye's coefficients as OPENCV's and
    returned poses 6-10 deg off as ``ok``)."""
    K = np.array([[300.0, 0, 320], [0, 300.0, 240], [0, 0, 1]])
    d = (0.02, -0.004, 0.001, -0.0002)
    assert as_camera((K, d)).model == "OPENCV"
    assert as_camera((K, d, True)) == as_camera({"K": K, "dist": d, "fisheye": True}) == from_opencv(K, d, fisheye=True)
    with pytest.raises(ValueError, match="third item of a"):
        as_camera((K, d, "fisheye"))


def _random_params(model, rng):
    p = []
    for nm in MODELS[model]:
        if nm in ("f", "fx", "fy"):
            p.append(rng.uniform(200, 1500))
        elif nm in ("cx", "cy"):
            p.append(rng.uniform(200, 800))
        elif nm == "omega":
            p.append(rng.uniform(0.0, 2.0))
        elif nm == "alpha":
            p.append(rng.uniform(0, 1))
        elif nm == "beta":
            p.append(rng.uniform(0.2, 3))
        elif nm == "k" and model in ("SIMPLE_DIVISION", "DIVISION"):
            p.append(rng.normal(0, 0.3))
        elif nm.startswith("k"):
            p.append(rng.normal(0, 0.1))
        else:
            p.append(rng.normal(0, 0.003))
    return tuple(p)


@pytest.mark.parametrize("model", sorted(MODELS))
def test_random_lenses_map_pixels_and_directions_consistently(model):
    """A fuzz of random lenses of every model: a pixel that lifts projects back onto itself, and a
    direction that projects lifts back onto itself (before, a direction past a Brown or fisheye map's
    first fold came back folded into the image, onto a pixel whose ray is another direction)."""
    rng = np.random.default_rng(11)
    for _ in range(25):
        cam = Camera(model, 1000, 1000, _random_params(model, rng))
        uv = rng.uniform(-200, 1200, (200, 2))
        b = cam.unproject(uv, invalid="nan")
        ok = np.isfinite(b).all(axis=1)
        if ok.any():
            assert np.abs(cam.project(b[ok]) - uv[ok]).max() < 1e-6
        d = rng.normal(size=(200, 3))
        d /= np.linalg.norm(d, axis=1)[:, None]
        px = cam.project(d)
        fin = np.isfinite(px).all(axis=1)
        if fin.any():
            back = cam.unproject(px[fin], invalid="nan")
            assert np.isfinite(back).all() and np.abs(back - d[fin]).max() < 1e-6


def test_directions_past_the_fold_have_no_pixel():
    cam = Camera("OPENCV", 0, 0, (500.0, 500.0, 0.0, 0.0, -0.3, 0.0, 0.0, 0.0))  # the radial map folds at r = 1.054
    px = cam.project(np.array([[1.0, 0.0, 1.0], [1.2, 0.0, 1.0]]))
    assert np.isfinite(px[0]).all() and np.isnan(px[1]).all()


def test_prism_root_beyond_the_radial_parts_largest_radius():
    """Tangential and prism terms carry this pixel past the radial part's largest distorted radius
    while its root (54.0 deg off-axis, before the radial fold at 58.1) is physical: the fallback starts
    at the fold (a review: the pixel was refused, its ray projected to NaN)."""
    p = (300.0, 300.0, 320.0, 240.0, 0.08904, 0.00734, 0.02004, 0.01321, 0.075, -0.18641, 0.00137, 0.01526)
    cam = Camera("THIN_PRISM_FISHEYE", 640, 480, p)
    uv = np.array([[593.5874776683793, 380.5559060053439]])
    b = cam.unproject(uv)
    assert abs(np.degrees(np.arccos(b[0, 2])) - 54.0) < 0.1
    assert np.abs(cam.project(b) - uv).max() < 1e-7


def test_fov_omega_and_huge_points():
    with pytest.raises(ValueError, match=r"FOV camera needs \|omega\| < pi"):
        Camera("FOV", 0, 0, (300.0, 300.0, 0.0, 0.0, 3.5))
    cam = Camera("OPENCV", 0, 0, (500.0, 500.0, 0.0, 0.0, -0.1, 0.01, 0.0, 0.0))
    X = np.array([[0.1, 0.2, 1.0]])
    assert np.allclose(cam.project(X * 1e200), cam.project(X)) and np.allclose(cam.project(X * 1e-200), cam.project(X))


def test_unliftable_matches_as_outliers():
    """A camera trial: one noisy keypoint just past a wide lens's fold stopped the whole pair. With
    unliftable="outlier" its match is left out and returned as an outlier; the rest is the estimate
    of the liftable matches."""
    cam = Camera("OPENCV", 640, 480, (300.0, 300.0, 320.0, 240.0, -0.3, 0.0, 0.0, 0.0))  # folds at r = 1.054
    sc = make_scene(120, camera="pinhole", noise_px=0.5, outlier_fraction=0.2, seed=3)
    d1, d2 = cam.project(sc.f1), cam.project(sc.f2)
    keep = np.isfinite(d1).all(axis=1) & np.isfinite(d2).all(axis=1)
    d1, d2 = d1[keep][:100], d2[keep][:100]
    far = np.array([[320.0 + 300.0 * 0.9, 240.0]])  # past the fold (distorted radius <= 0.703), inside the image
    x1, x2 = np.vstack([d1, far]), np.vstack([d2, d2[:1]])
    with pytest.raises(ValueError, match="did not converge for 1 of 101 points"):
        estimate_relative_pose(x1, x2, camera1=cam)
    r = estimate_relative_pose(x1, x2, camera1=cam, unliftable="outlier", scores=np.arange(101.0))
    ref = estimate_relative_pose(d1, d2, camera1=cam, scores=np.arange(100.0))
    assert r.diagnostics["unliftable"] == 1 and "1 of 101 matches without a bearing" in r.message
    assert r.inliers.shape == (101,) and not r.inliers[100] and np.isnan(r.residuals_px[100]) and r.weights[100] == 0
    assert np.array_equal(r.inliers[:100], ref.inliers) and np.allclose(r.R, ref.R) and r.status == ref.status
    with pytest.raises(ValueError, match="unliftable must be"):
        estimate_relative_pose(d1, d2, camera1=cam, unliftable="drop")


def test_fisheye624_with_strong_tangential_terms_finds_the_physical_root():
    """Damped Newton from the radial root stalled in a local minimum of the residual for this
    Fisheye624 lens (a review's fuzz, tangential / prism terms ~0.02): more starts along the pixel's
    direction find the ray pycolmap gives (54.91 deg off-axis, det J 0.70, before the fold)."""
    p = (300.0, 300.0, 320.0, 240.0, -0.01243, 0.04241, 0.10458, -0.04186, -0.029, -0.08154, 0.01603, 0.01592, 0.00498, 0.01608, 0.02653, -0.0362)
    cam = Camera("RAD_TAN_THIN_PRISM_FISHEYE", 640, 480, p)
    uv = np.array([[601.8912761094705, 128.8946825458357]])
    b = cam.unproject(uv)
    assert np.allclose(b, [[0.75505987, -0.31538377, 0.57481968]], atol=1e-7)
    assert np.abs(cam.project(b) - uv).max() < 1e-7


def test_opencv_12_and_14_coefficients_with_zero_extra_terms_are_full_opencv():
    from poseonly.cameras import from_opencv

    K = np.array([[800.0, 0, 320], [0, 800, 240], [0, 0, 1]])
    d8 = [0.1, -0.05, 0.001, 0.002, 0.01, 0.0, 0.0, 0.0]
    assert from_opencv(K, d8 + [0.0] * 4) == from_opencv(K, d8) == from_opencv(K, d8 + [0.0] * 6)
    assert from_opencv(K, np.zeros(14)).model == "PINHOLE"


def test_principal_point_outside_the_declared_image_is_refused():
    """A camera trial: a principal point in normalised units (0.5, 0.5) ... (-3000, 5000) under a declared
    1280x960 image was taken and gave `ok` / `uncertain` poses tens of degrees off. Outside the
    declared image it is refused; an unknown size (0 x 0) is not checked (a crop's principal point)."""
    with pytest.raises(InputError, match=r"principal point \(-3000, 5000\) lies outside its declared 1280x960 image"):
        Camera("OPENCV", 1280, 960, (900.0, 900.0, -3000.0, 5000.0, 0.0, 0.0, 0.0, 0.0))
    with pytest.raises(InputError, match=r"principal point \(480, 1000\) lies outside"):
        from_opencv(np.array([[900.0, 0, 480], [0, 900.0, 1000], [0, 0, 1]]), None, 1280, 960)
    assert Camera("PINHOLE", 0, 0, (900.0, 900.0, -3000.0, 5000.0)).principal_point == (-3000.0, 5000.0)
    assert Camera("PINHOLE", 1280, 960, (900.0, 900.0, 1280.0, 0.0)).principal_point == (1280.0, 0.0)  # the border is inside


def test_pixels_outside_the_declared_image_are_refused():
    """Pixels far outside the camera's declared image (keypoints of another resolution, or the other
    view's camera) are refused naming the view and the first row; within the margin (1 % of the larger
    side, at least 2 px) and with an unknown size they are taken."""
    sc = make_scene(60, camera="pinhole", noise_px=0.3, seed=4)
    K = default_K()
    w, h = int(2 * K[0, 2]), int(2 * K[1, 2])
    cam = from_opencv(K, None, w, h)
    inside = (sc.u1[:, 0] >= 0) & (sc.u1[:, 0] <= w) & (sc.u1[:, 1] >= 0) & (sc.u1[:, 1] <= h)
    inside &= (sc.u2[:, 0] >= 0) & (sc.u2[:, 0] <= w) & (sc.u2[:, 1] >= 0) & (sc.u2[:, 1] <= h)
    u1, u2 = sc.u1[inside], sc.u2[inside]
    assert len(u1) >= 20
    estimate_relative_pose(u1, u2, camera1=cam)
    far = u2.copy()
    far[4] = (w + 0.02 * w, 10.0)
    with pytest.raises(InputError, match=rf"x2: 1 of {len(u1)} pixels lie outside the camera's declared {w}x{h} image \(the first is row 4"):
        estimate_relative_pose(u1, far, camera1=cam)
    near = u2.copy()
    near[4] = (w + 0.005 * w, 10.0)  # within the margin
    estimate_relative_pose(u1, near, camera1=cam)
    estimate_relative_pose(u1, far, camera1=from_opencv(K))  # size unknown: not checked


def test_camera_errors_name_the_camera_and_refuse_non_numbers():
    """A camera trial: on a two-camera rig `distortion coefficients contain NaN` did not say which camera;
    a NaN in K was reported as a bad shape; params None read as "got 1" parameter; True and "900" were
    taken as numbers."""
    rng = np.random.default_rng(0)
    u1 = rng.uniform(0, 1000, (50, 2))
    K = default_K()
    with pytest.raises(InputError, match="^camera2: distortion coefficients contain NaN"):
        estimate_relative_pose(u1, u1 + 3, camera1=(K, np.zeros(4)), camera2=(K, [np.nan, 0, 0, 0]))
    with pytest.raises(InputError, match="^camera2: K contains NaN or inf values"):
        estimate_relative_pose(u1, u1 + 3, camera1=(K, np.zeros(4)), camera2=(K * np.nan, np.zeros(4)))
    with pytest.raises(InputError, match=r"^camera1: camera parameters must be real numbers, got None"):
        as_camera({"model": "PINHOLE", "params": None}, "camera1")
    for bad in [(True, True, 640, 480), ["900", "900", "640", "480"]]:
        with pytest.raises(InputError, match="camera parameters must be real numbers"):
            Camera("PINHOLE", 0, 0, bad)
