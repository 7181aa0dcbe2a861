"""Bad input to the library's public functions beyond the two-view estimate (an audit of the API,
tenth session): each is a ValueError (poseonly.InputError) naming the problem, never a TypeError,
IndexError, AttributeError, LinAlgError or an escaping RuntimeWarning; degenerate but valid input
returns a result."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import poseonly
from poseonly import InputError, sim
from poseonly.sfm import synthetic


@pytest.fixture(autouse=True)
def _warnings_are_errors():
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        yield


def test_rotation_averaging_arguments():
    from poseonly.sfm.rotation_averaging import average_rotations

    sc = synthetic.make_scene(8, 300)
    E, I3 = len(sc.pairs), np.tile(np.eye(3), (4, 1, 1))
    with pytest.raises(InputError, match=r"views \(0, 1\) more than once"):
        average_rotations(3, [[0, 1], [1, 2], [0, 2], [1, 0]], I3)
    for kw, msg in (
        ({"outlier_rounds": -1}, "outlier_rounds"),
        ({"irls_iterations": "3"}, "irls_iterations"),
        ({"l1_outer": 2.5}, "l1_outer"),
        ({"irls_tol": "x"}, "irls_tol"),
        ({"max_error_deg": 0}, "max_error_deg"),
        ({"sigma_deg": 1e308}, "sigma_deg"),
        ({"sigma_deg": 1e-300}, "sigma_deg"),
        ({"information": np.full((E, 3, 3), None)}, "information"),
    ):
        with pytest.raises(InputError, match=msg):
            average_rotations(8, sc.pairs, sc.R_rel, **kw)
    # extreme but valid scales: only ratios matter
    ref = average_rotations(8, sc.pairs, sc.R_rel).rotations
    for kw in ({"weights": np.full(E, 1e308)}, {"information": np.tile(np.eye(3) * 1e-320, (E, 1, 1))}, {"information": np.tile(np.eye(3) * 1e300, (E, 1, 1))}):
        r = average_rotations(8, sc.pairs, sc.R_rel, **kw)
        assert np.all(np.isfinite(r.rotations)) and np.allclose(r.rotations, ref, atol=1e-6)
    # an inconsistent triangle of half turns: a result, no warning
    average_rotations(3, [[0, 1], [1, 2], [0, 2]], np.tile(np.diag([1.0, -1.0, -1.0]), (3, 1, 1)))


def test_sfm_types_and_options():
    from poseonly.sfm import ViewGraph, align_similarity, evaluate_poses, ligt_positions
    from poseonly.sfm.pairwise import PairwiseOptions, image_view_graph
    from poseonly.sfm.pipeline import GlobalOptions, run_global
    from poseonly.sfm.tracks import Tracks, build_tracks

    for kw in ({"filter_rounds": 1.5}, {"filter_rounds": -1}, {"min_rotation_error_deg": None}, {"conflicts": "x"}, {"min_track_length": 1}):
        with pytest.raises(InputError):
            GlobalOptions(**kw)
    for kw in ({"ratio": None}, {"min_matches": None}, {"seed": None}, {"estimator_options": None}, {"mutual": 1}, {"threshold_px": 0}):
        with pytest.raises(InputError):
            PairwiseOptions(**kw)
    with pytest.raises(InputError, match="Tracks.views"):
        Tracks(np.array([0, 2]), np.array([0.5, 1.0]), np.array([0, 1]))
    with pytest.raises(InputError, match="ptr must run"):
        Tracks(np.array([0, 3]), np.array([0, 1]), np.array([0, 1]))
    with pytest.raises(InputError, match=">= 0"):
        Tracks(np.array([0, 2]), np.array([-1, 1]), np.array([0, 1]))
    sc = synthetic.make_scene(6, 100)
    with pytest.raises(InputError, match="tracks must be"):
        ligt_positions(sc.rotations, None, np.zeros((0, 3)))  # type: ignore[arg-type]
    with pytest.raises(InputError, match="edges must be an iterable of Edge"):
        ViewGraph(3, None)  # type: ignore[arg-type]
    with pytest.raises(InputError, match="an edge must be"):
        ViewGraph(3).add_edge(5)  # type: ignore[arg-type]
    with pytest.raises(InputError, match="graph must be"):
        build_tracks(None)  # type: ignore[arg-type]
    with pytest.raises(InputError, match="edge_mask must have one entry per edge"):
        build_tracks(ViewGraph(3), edge_mask=np.ones(2, bool))
    with pytest.raises(InputError, match="options must be a GlobalOptions"):
        run_global(ViewGraph(3), lambda t: np.zeros((0, 3)), 800.0, {"filter_rounds": 1})  # type: ignore[arg-type]
    with pytest.raises(InputError, match="images must be"):
        image_view_graph(None, np.eye(3))  # type: ignore[arg-type]
    with pytest.raises(InputError, match="options must be a PairwiseOptions"):
        image_view_graph(["a.jpg", "b.jpg"], np.eye(3), options={"ratio": 0.8})  # type: ignore[arg-type]
    R, C = sc.rotations, sc.centres
    with pytest.raises(InputError, match="ground truth must be finite"):
        evaluate_poses(R, C, R, C * np.nan)
    with pytest.raises(InputError, match="R_gt must have shape"):
        evaluate_poses(R, C, R[:3], C)
    with pytest.raises(InputError, match="rotations must have shape"):
        evaluate_poses(R.reshape(-1, 9), C, R, C)
    with pytest.raises(InputError, match="destination points are all identical"):
        align_similarity(C, np.zeros_like(C))
    with pytest.raises(InputError, match="finite points"):
        align_similarity(C * 1e300, C)


def test_batch_arguments_and_bad_pairs():
    from poseonly.batch import Pair

    s = sim.make_scene(60, noise_px=0.5, seed=1)
    with pytest.raises(InputError, match="pairs must be an iterable"):
        poseonly.estimate_relative_poses(None, progress=False)  # type: ignore[arg-type]
    with pytest.raises(InputError, match="client must be"):
        poseonly.estimate_relative_poses([], client=5, progress=False)
    for bad in ({"chunk_size": True}, {"retries": True}):
        with pytest.raises(InputError):
            poseonly.estimate_relative_poses([], progress=False, **bad)
    good = Pair(s.f1, s.f2, key="good", options={"focal_px": 800.0})
    bad = [
        Pair(s.f1, s.f2, key="none", options=None),  # type: ignore[arg-type]
        Pair(s.f1, s.f2, key="list", options=[1]),  # type: ignore[arg-type]
        Pair(s.f1, s.f2, key="data", options={"focal_px": 800.0, "K1": np.eye(3)}),
        Pair(s.f1, s.f2, key="seed", options={"focal_px": 800.0, "seed": None}),
        Pair(s.f1, s.f2, key="camera", camera1={"model": "PINHOLE", "width": None, "height": 1, "params": [1, 1, 1, 1]}),
    ]
    out = {r.key: r for r in poseonly.estimate_relative_poses([good, *bad], progress=False)}
    assert out["good"].result is not None and out["good"].error is None
    for p in bad:
        assert out[p.key].result is None and out[p.key].error, p.key


def test_cameras_features_residuals():
    from poseonly.cameras import Camera, as_camera, camera_from_text, from_opencv
    from poseonly.demo_data import load_demo_pair
    from poseonly.features import match_images

    K = np.array([[800.0, 0.0, 320.0], [0.0, 800.0, 240.0], [0.0, 0.0, 1.0]])
    for make in (
        lambda: Camera(["PINHOLE"], 1, 1, (1, 1, 1, 1)),  # type: ignore[arg-type]
        lambda: Camera("PINHOLE", "640", 480, (1, 1, 1, 1)),  # type: ignore[arg-type]
        lambda: Camera("PINHOLE", 640, 480, (1 + 1j, 1, 1, 1)),  # type: ignore[arg-type]
        lambda: as_camera({"model": "PINHOLE", "width": None, "height": 480, "params": [1, 1, 1, 1]}),
        lambda: as_camera({"model": "PINHOLE", "width": np.inf, "height": 480, "params": [1, 1, 1, 1]}),
        lambda: from_opencv(K, object()),
        lambda: camera_from_text(5, "1"),  # type: ignore[arg-type]
    ):
        with pytest.raises(InputError):
            make()
    assert from_opencv(K, None, 640.0, 480).width == 640  # an integral float is a whole number
    d = load_demo_pair()
    for kw in ({"max_features": 10**30}, {"max_features": np.inf}, {"ratio": None}):
        with pytest.raises(InputError):
            match_images(d.image1, d.image2, **kw)
    s = sim.make_scene(20, seed=1)
    for args, msg in (
        ((s.R, s.t, None, s.f2), "f1"),
        ((s.R, s.t, s.f1[0], s.f2), "f1"),
        ((s.R, None, s.f1, s.f2), "t"),
        ((s.R[:2], s.t, s.f1, s.f2), "R"),
        ((s.R, s.t, s.f1, s.f2[:5]), "differ in length"),
    ):
        with pytest.raises(InputError, match=msg):
            poseonly.v_E(*args)
    with pytest.raises(InputError, match="R_gt"):
        poseonly.rotation_error_deg(None, s.R)


def test_valid_inputs_at_the_edges_stay_accepted():
    """What the checks above must not refuse (a review of them found each refused at first): numpy
    and integral-float counts kept as ints, bounds that switch a limit off, separators and 0-d arrays."""
    from poseonly.batch import Pair
    from poseonly.cameras import Camera, camera_from_text
    from poseonly.features import match_features
    from poseonly.sfm import ViewGraph
    from poseonly.sfm.pairwise import PairwiseOptions
    from poseonly.sfm.pipeline import GlobalOptions
    from poseonly.sfm.rotation_averaging import average_rotations
    from poseonly.sfm.tracks import Tracks

    o = PairwiseOptions(max_features=100.0, ratio=np.int64(1), seed=np.int64(3), estimator_options=[["ml_tails", "gauss"]])  # type: ignore[arg-type]
    assert (o.max_features, o.ratio, o.seed, o.estimator_options) == (100, 1.0, 3, (("ml_tails", "gauss"),))
    assert type(o.max_features) is int and type(o.seed) is int
    g = GlobalOptions(filter_rounds=2.0, min_rotation_error_deg=0, max_rotation_error_deg=np.inf)  # type: ignore[arg-type]
    assert g.filter_rounds == 2 and type(g.filter_rounds) is int
    sc = synthetic.make_scene(8, 300)
    r = average_rotations(8, sc.pairs, sc.R_rel, min_error_deg=0, max_error_deg=np.inf, irls_tol=0, l1_tol=0, sigma_deg=360)
    assert np.all(np.isfinite(r.rotations)) and r.info["sigma_deg"] == 360.0
    assert camera_from_text("SIMPLE_RADIAL", "800,320,240,0,").params == (800.0, 320.0, 240.0, 0.0)
    assert Camera("PINHOLE", np.array(640), np.int32(480), (1, 1, 1, 1)).width == 640  # type: ignore[arg-type]
    assert len(Tracks([0, 2], [0, 1], [0, 0])) == 1  # type: ignore[arg-type]
    assert ViewGraph(3, (e for e in [])).num_views == 3  # type: ignore[arg-type]
    assert match_features(np.zeros((0, 128), np.float32), np.zeros((0, 128), np.float32), ratio=np.array(0.8)).shape == (0, 2)
    s = sim.make_scene(60, noise_px=0.5, seed=1)
    pairs = [
        Pair(s.f1, s.f2, key="scores", options={"focal_px": 800.0, "scores": np.linspace(1, 0, 60)}),
        Pair(s.f1, s.f2, key="seed", options={"focal_px": 800.0, "seed": 7.0}),
    ]
    out = {r.key: r for r in poseonly.estimate_relative_poses(pairs, seed=2**64 - 1, progress=False)}  # the range's top
    assert all(r.error is None and r.result is not None for r in out.values()), {k: r.error for k, r in out.items()}


def test_non_numeric_dtypes_are_refused():
    """numpy casts strings, dates and durations to float without complaint; none of them are
    coordinates. Object arrays of numbers stay accepted."""
    s = sim.make_scene(50, camera="pinhole", seed=0)
    for bad in (s.u1.astype("datetime64[s]"), s.u1.astype("timedelta64[s]"), s.u1.astype(str), s.u1.astype(bytes), np.array([[str(v) for v in row] for row in s.u1], dtype=object)):
        with pytest.raises(InputError, match="numeric array"):
            poseonly.estimate_relative_pose(bad, s.u2, s.K, s.K)
    assert poseonly.estimate_relative_pose(s.u1.astype(object), s.u2, s.K, s.K).status == "ok"


def test_residuals_any_finite_t_and_no_hidden_nan():
    """The residuals normalise t, so its scale does not matter, up to 1e+-160 (its square overflowed to
    zeros, or underflowed); NaN or inf in any argument is an error (some residuals returned finite
    values for a NaN bearing)."""
    s = sim.make_scene(50, camera="pinhole", noise_px=0.5, seed=1)
    for name in ("v_E", "v_BA", "v_PPO", "v_LiGT", "v_OpenGV"):
        fn = getattr(poseonly, name)
        base = fn(s.R, s.t, s.f1, s.f2)
        for scale in (1e200, 1e160, 1e-160, 1e-170, 1e-300):
            np.testing.assert_allclose(fn(s.R, s.t * scale, s.f1, s.f2), base, rtol=1e-9, atol=1e-15)
            np.testing.assert_allclose(fn(s.R[None], (s.t * scale)[None], s.f1, s.f2)[0], base, rtol=1e-9, atol=1e-15)
        f = s.f1.copy()
        f[3] = np.nan
        with pytest.raises(InputError, match="f1 contains NaN"):
            fn(s.R, s.t, f, s.f2)
        with pytest.raises(InputError, match="t contains NaN or inf"):
            fn(s.R, np.array([np.inf, 0.0, 0.0]), s.f1, s.f2)


def test_lirp_result_to_dict_is_strict_json():
    import json

    s = sim.make_scene(30, seed=1)
    d = poseonly.lirp(s.f1, s.f2).to_dict()
    assert json.loads(json.dumps(d, allow_nan=False))["status"] == "ok"
    assert np.shape(d["candidates_E"]) == (18, 3, 3) and isinstance(d["candidate_valid"][0], bool)


def test_seed_out_of_the_cores_range_and_an_ill_conditioned_K_name_the_problem():
    from poseonly.sim import make_scene

    sc = make_scene(60, camera="pinhole", seed=1)
    with pytest.raises(InputError, match=r"\[0, 2\*\*64\)"):
        poseonly.estimate_relative_pose(sc.u1, sc.u2, sc.K, seed=2**64)  # would alias seed 0
    assert poseonly.estimate_relative_pose(sc.u1, sc.u2, sc.K, seed=2**64 - 1).R.shape == (3, 3)
    K = np.array([[800.0, 0.0, 1e9], [0.0, 800.0, 1e9], [0.0, 0.0, 1.0]])
    with pytest.raises(InputError, match="numerically singular.*largest entry"):
        poseonly.estimate_relative_pose(sc.u1, sc.u2, K)


def test_input_trial_twentieth_session():
    """A new user's input trial (twentieth session): homogeneous pixels ``[u, v, 1]`` were taken as
    bearings (``ok`` poses degrees off), complex and string pixels passed the camera path, a masked
    array's filler values were used as data, boolean arrays were coordinates, a zero translation scored
    a perfect 0 deg, non-rotations had a rotation error, and a scaled K, 0-d option arrays, float seeds,
    lowercase model names and fractional widths were treated unlike their other forms."""
    from poseonly.cameras import Camera, camera_from_text, from_opencv
    from poseonly.geometry import rotation_error_deg, translation_error_deg

    s = sim.make_scene(200, camera="pinhole", noise_px=0.3, seed=0)
    h1, h2 = (np.c_[u, np.ones(len(u))] for u in (s.u1, s.u2))
    with pytest.raises(InputError, match="homogeneous pixels"):
        poseonly.estimate_relative_pose(h1, h2, focal_px=800.0)
    f1 = s.f1 / s.f1[:, 2:]  # normalized homogeneous coordinates stay bearings
    assert poseonly.estimate_relative_pose(f1, s.f2, focal_px=float(s.K[0, 0])).status == "ok"
    cam = Camera("PINHOLE", 640, 480, (s.K[0, 0], s.K[1, 1], s.K[0, 2], s.K[1, 2]))
    for bad, msg in ((s.u1 + 50j, "must be real"), (s.u1.astype(str), "numeric array"), (s.u1 > 100, "boolean")):
        with pytest.raises(InputError, match=msg):
            poseonly.estimate_relative_pose(bad, s.u2, camera1=cam, camera2=cam)
        with pytest.raises(InputError, match=msg):
            poseonly.estimate_relative_pose(bad, s.u2, s.K, s.K)
    lost = s.u2.copy()
    lost[0] = np.nan  # (a lost row made float copies of both views before the boolean check: a review)
    with pytest.raises(InputError, match="boolean"):
        poseonly.estimate_relative_pose(s.u1 > 100, lost, s.K, s.K, unliftable="outlier")
    with pytest.raises(InputError, match="numeric array"):
        poseonly.estimate_relative_pose([[1, 2], [3]] * 4, [[1, 2], [3]] * 4, focal_px=800.0)
    mask = np.zeros_like(s.u1, bool)
    mask[:40] = True
    masked = np.ma.masked_array(np.where(mask, 0.0, s.u1), mask)
    with pytest.raises(InputError, match="NaN"):
        poseonly.estimate_relative_pose(masked, s.u2, s.K, s.K)
    r = poseonly.estimate_relative_pose(masked, s.u2, s.K, s.K, unliftable="outlier")
    ref = poseonly.estimate_relative_pose(s.u1[40:], s.u2[40:], s.K, s.K)
    assert not r.inliers[:40].any() and np.allclose(r.R, ref.R, atol=1e-9)
    scores = np.linspace(1.0, 0.0, 200)
    scores[:40] = np.nan  # the lost rows' scores are not looked at
    assert poseonly.estimate_relative_pose(masked, s.u2, s.K, s.K, unliftable="outlier", scores=scores).status == "ok"
    assert np.isnan(translation_error_deg(np.zeros(3), [0, 0, 1])) and np.isnan(translation_error_deg([0, 0, 1], np.zeros(3)))
    assert translation_error_deg([0, 0, 1e200], [0, 1e-200, 0]) == 90.0
    with pytest.raises(InputError, match="shape"):
        translation_error_deg([1, 0], [0, 0, 1])
    for bad_R in (2 * np.eye(3), -np.eye(3)):
        with pytest.raises(InputError, match="not a rotation"):
            rotation_error_deg(np.eye(3), bad_R)
    assert np.isnan(rotation_error_deg(np.eye(3), np.full((3, 3), np.nan)))
    assert from_opencv(2 * s.K).params == from_opencv(s.K).params
    assert Camera("pinhole", 640, 480, (1, 1, 1, 1)).model == "PINHOLE"
    with pytest.raises(InputError, match="whole number"):
        camera_from_text("PINHOLE", "800,800,320,240", width=640.7)  # type: ignore[arg-type]
    assert camera_from_text("PINHOLE", "800,800,320,240", "640", "480").width == 640  # type: ignore[arg-type]
    with pytest.raises(InputError, match="broadcast"):
        rotation_error_deg(np.tile(np.eye(3), (2, 1, 1)), np.tile(np.eye(3), (3, 1, 1)))
    assert np.isnan(rotation_error_deg(np.eye(3), np.full((3, 3), np.inf)))
    a = poseonly.estimate_relative_pose(s.u1, s.u2, s.K, s.K, threshold_px=np.array(2.0), seed=3.0)  # type: ignore[arg-type]
    b = poseonly.estimate_relative_pose(s.u1, s.u2, s.K, s.K, threshold_px=2.0, seed=3)
    assert np.array_equal(a.R, b.R)
    with pytest.raises(InputError, match="seed"):
        poseonly.estimate_relative_pose(s.u1, s.u2, s.K, s.K, seed=3.5)  # type: ignore[arg-type]


def test_nonfinite_rows_are_counted_named_and_the_way_out_said():
    """A batch trial: ``x1 contains NaN or inf values (3 rows)`` said neither which rows nor what to do. The
    error (:class:`poseonly.geometry.NonFiniteInputError`, an ``InputError``) names the first row and,
    from ``estimate_relative_pose``, how to make such matches outliers (with K or a camera) or to drop
    them (bearings)."""
    from poseonly import estimate_relative_pose
    from poseonly.geometry import NonFiniteInputError
    from poseonly.sim import make_scene

    sc = make_scene(50, camera="pinhole", noise_px=0.5, seed=1)
    u1 = sc.u1.copy()
    u1[[3, 7]] = np.nan
    with pytest.raises(NonFiniteInputError, match=r"x1 contains NaN or inf values \(2 rows, the first is row 3\): unliftable='outlier' makes them outliers"):
        estimate_relative_pose(u1, sc.u2, sc.K)
    with pytest.raises(NonFiniteInputError, match=r"x1: uv contains NaN or inf values \(2 rows, the first is row 3\): unliftable='outlier'"):
        estimate_relative_pose(u1, sc.u2, camera1={"K": sc.K, "dist": np.zeros(4)})
    f2 = sc.f2.copy()
    f2[5] = np.inf
    with pytest.raises(NonFiniteInputError, match=r"x2 contains NaN or inf values \(1 rows, the first is row 5\): drop them"):
        estimate_relative_pose(sc.f1, f2)
    assert estimate_relative_pose(u1, sc.u2, sc.K, unliftable="outlier").diagnostics["unliftable"] == 2
    # unliftable='outlier' already given, but bearings (or unequal lengths) it cannot handle (a review)
    with pytest.raises(NonFiniteInputError, match=r"needs pixel arrays \(n, 2\) of equal length with K1 or a camera; got \(50, 3\)"):
        estimate_relative_pose(sc.f1, f2, unliftable="outlier")


def test_other_libraries_option_names_point_to_ours():
    """A migrating user's trial: OpenCV's / PoseLib's option names and a typo got the list of all options."""
    from poseonly.sim import make_scene

    sc = make_scene(30, seed=1)
    for name, ours in (("prob", "confidence"), ("max_epipolar_error", "threshold_px"), ("maxIters", "max_iterations")):
        with pytest.raises(InputError, match=rf"unknown option '{name}' for method 'poseonly' \(poseonly's name for it: '{ours}'\)"):
            poseonly.estimate_relative_pose(sc.u1, sc.u2, sc.K, **{name: 1})
    with pytest.raises(InputError, match=r"unknown option 'treshold_px' .*\(did you mean 'threshold_px'\?\)"):
        poseonly.estimate_relative_pose(sc.u1, sc.u2, sc.K, treshold_px=1.0)
