"""Regression tests of the findings of issue 14 (one test per finding, the issue's own examples)."""

from __future__ import annotations

import json
import threading
import warnings

import numpy as np
import pytest

import poseonly
from poseonly import InputError, estimate_relative_pose
from poseonly.sim import default_K, make_scene

FAST = {"max_iterations": 2000}


def _json_strict(r) -> dict:
    return json.loads(json.dumps(r.to_dict(), allow_nan=False))


# ------------------------------------------------------------------------------------------------
# status honesty


def test_random_matches_issue_example_not_ok():
    """n = 200 uniform pixels, default K, rng 200001: was "ok: 16 inliers within 2 px"."""
    rng = np.random.default_rng(200001)
    u1 = rng.uniform((0, 0), (640, 480), (200, 2))
    u2 = rng.uniform((0, 0), (640, 480), (200, 2))
    r = estimate_relative_pose(u1, u2, default_K(), **FAST)
    assert r.status == "too_few_inliers", r.message
    assert r.diagnostics["log10_nfa"] >= -3


@pytest.mark.parametrize("seed", range(4))
def test_pure_rotation_60pct_outliers_not_ok(seed):
    sc = make_scene(200, "rotation", camera="pinhole", noise_px=0.5, outlier_fraction=0.6, seed=100 + seed)
    r = estimate_relative_pose(sc.u1, sc.u2, sc.K, seed=seed, **FAST)
    assert r.status == "pure_rotation", r.message
    assert poseonly.rotation_error_deg(sc.R, r.R) < 0.5


@pytest.mark.parametrize("camera", ["wide", "pinhole"])
@pytest.mark.parametrize("outliers", [0.0, 0.5])
def test_pure_rotation_leaves_no_parallax(camera, outliers):
    """The precision test of the rotation-only model (poseonly.analysis.parallax_ratio): on a pure
    rotation at real noise the parallax the rotation leaves is the noise's (ratio ~1), far below
    PRECISION_RATIO, so the status stays pure_rotation."""
    from poseonly.analysis import PRECISION_RATIO

    for seed in range(3):
        sc = make_scene(300, "rotation", camera=camera, noise_px=0.3, outlier_fraction=outliers, seed=40 + seed)
        r = estimate_relative_pose(sc.u1, sc.u2, sc.K, seed=seed)
        assert r.status == "pure_rotation", r.message
        assert r.diagnostics["parallax_ratio"] < 0.3 * PRECISION_RATIO
        assert r.diagnostics["parallax_noise"] < 0.5
        assert poseonly.rotation_error_deg(sc.R, r.R) < (0.03 if camera == "wide" else 0.06)


@pytest.mark.parametrize("camera", ["wide", "pinhole"])
def test_pure_rotation_with_noise_at_the_threshold_is_not_ok(camera):
    """1500 matches with 1 px noise at the 1 px default: the rotation's noise tail beyond twice its
    threshold (~2 % of the inliers) was counted as translation support (22 / 40 pinhole and 35 / 40
    wide draws `ok` when measured); the far threshold now also spans 5.3 noise sigmas (far_angle)."""
    oks = 0
    for d in range(4):
        sc = make_scene(1500, "rotation", camera=camera, noise_px=1.0, seed=2_000_000 + d)
        r = estimate_relative_pose(sc.u1, sc.u2, sc.K, seed=d)
        oks += r.status == "ok"
    assert oks == 0


@pytest.mark.parametrize("outliers", [0.2, 0.6])
def test_pure_rotation_with_many_matches(outliers):
    """n = 2000 > ROTATION_SCORE_POINTS: the rotation hypotheses are scored on a 500-match subset, the
    fit and the decision use every match; a pure rotation is still found, a translation still ok."""
    from poseonly.analysis import ROTATION_SCORE_POINTS

    n = 2000
    assert n > ROTATION_SCORE_POINTS
    sc = make_scene(n, "rotation", camera="pinhole", noise_px=0.5, outlier_fraction=outliers, seed=7)
    r = estimate_relative_pose(sc.u1, sc.u2, sc.K, seed=0, **FAST)
    assert r.status == "pure_rotation", r.message
    assert poseonly.rotation_error_deg(sc.R, r.R) < 0.1
    assert r.num_inliers >= 0.9 * (1 - outliers) * n
    sc = make_scene(n, camera="pinhole", noise_px=0.5, outlier_fraction=outliers, seed=7)
    r = estimate_relative_pose(sc.u1, sc.u2, sc.K, seed=0, **FAST)
    assert r.status == "ok", r.message
    assert r.diagnostics["pure_rotation"] is False


def test_real_pose_stays_ok_with_small_support():
    """The a-contrario test does not reject a genuine pose with 80 % outliers."""
    sc = make_scene(150, camera="pinhole", noise_px=0.5, outlier_fraction=0.8, seed=5)
    r = estimate_relative_pose(sc.u1, sc.u2, sc.K, seed=0)
    assert r.status == "ok", r.message
    assert poseonly.rotation_error_deg(sc.R, r.R) < 1.0


# ------------------------------------------------------------------------------------------------
# errors instead of crashes


@pytest.mark.parametrize(
    "edit,msg",
    [
        (lambda K: K.__setitem__((1, 1), -K[0, 0]), "positive focal"),  # fx = -fy
        (lambda K: K.__setitem__((slice(0, 2), slice(0, 2)), -K[:2, :2]), "positive focal"),
        (lambda K: K.__setitem__((0, 0), 0.0), "positive focal|singular"),
        (lambda K: K.__setitem__((2, 0), 0.3), "upper triangular"),
    ],
)
def test_bad_intrinsics(edit, msg):
    sc = make_scene(30, camera="pinhole", seed=1)
    K = sc.K.copy()
    edit(K)
    with pytest.raises(InputError, match=msg):
        estimate_relative_pose(sc.u1, sc.u2, K)


@pytest.mark.parametrize("kw", [{"threshold_px": 1e157}, {"threshold_px": 1e-300}, {"focal_px": 1e300}, {"focal_px": 1e-155}, {"threshold_px": np.inf}, {"threshold_px": np.nan}])
def test_threshold_overflow_is_an_error(kw):
    sc = make_scene(30, seed=1)
    with pytest.raises(InputError, match="threshold|focal"):
        estimate_relative_pose(sc.f1, sc.f2, **{"focal_px": 800.0, **kw})


@pytest.mark.parametrize(
    "fn,kw",
    [
        ("gnc_ransac", {"theta": None}),
        ("gnc_ransac", {"theta": 2e-3, "sample_size": 0}),
        ("gnc_ransac", {"theta": 2e-3, "sample_size": 6.5}),
        ("gnc_ransac", {"theta": 2e-3, "max_iterations": None}),
        ("gnc_ransac", {"theta": 2e-3, "max_iterations": 0}),
        ("gnc_ransac", {"theta": 2e-3, "seed": None}),
        ("gnc_ransac", {"theta": 2e-3, "seed": -1}),
        ("gnc_ransac", {"theta": np.inf}),
        ("gnc_irls", {"noise_bound": "mad"}),
        ("gnc_irls", {"max_iterations": 2.5}),
        ("lirp", {"rank_tol": "a"}),
        ("lirp", {"rank_tol": np.nan}),
    ],
)
def test_low_level_wrong_types(fn, kw):
    sc = make_scene(40, seed=1)
    with pytest.raises(InputError):
        getattr(poseonly, fn)(sc.f1, sc.f2, **kw)


def test_low_level_numpy_scalars_accepted():
    sc = make_scene(40, seed=1)
    r = poseonly.gnc_ransac(sc.f1, sc.f2, theta=np.float32(2.5e-3), seed=np.int64(3), sample_size=np.int32(20), max_iterations=np.int64(5))
    assert poseonly.rotation_error_deg(sc.R, r.R) < 1.0
    assert poseonly.lirp(sc.f1, sc.f2, rank_tol=np.float64(1e-9)).status == "ok"


def test_complex_input_rejected():
    sc = make_scene(30, seed=1)
    with pytest.raises(InputError, match="complex"):
        estimate_relative_pose(sc.f1 + 0j, sc.f2, focal_px=800.0)
    with pytest.raises(InputError, match="complex"):
        estimate_relative_pose(sc.u1, sc.u2, sc.K.astype(complex))


# ------------------------------------------------------------------------------------------------
# no silent garbage


def test_huge_bearing_components_keep_their_direction():
    sc = make_scene(60, noise_px=0.3, seed=4)
    ref = estimate_relative_pose(sc.f1, sc.f2, focal_px=800.0)
    big = estimate_relative_pose(sc.f1 * 1e200, sc.f2 * 1e300, focal_px=800.0)
    assert big.status == ref.status
    np.testing.assert_allclose(big.R, ref.R, atol=1e-9)
    rows = sc.f1.copy()
    rows[0] *= 1e300  # one huge row among normal ones
    assert np.all(np.isfinite(poseonly.geometry.as_bearings(rows)))
    np.testing.assert_allclose(poseonly.geometry.as_bearings(rows)[0], sc.f1[0] / np.linalg.norm(sc.f1[0]), atol=1e-15)


def test_degenerate_has_no_pose_and_json_is_strict():
    f = np.tile([0.1, 0.2, 1.0], (20, 1))
    r = estimate_relative_pose(f, f, focal_px=800.0)
    assert r.status == "degenerate" and r.R is None and r.t is None and r.E is None
    d = _json_strict(r)
    assert d["R"] is None and d["t"] is None and d["parallax_deg"] is None and d["inliers"] == []


def test_to_dict_has_E_and_inlier_indices():
    sc = make_scene(60, noise_px=0.3, seed=4)
    r = estimate_relative_pose(sc.f1, sc.f2, focal_px=800.0)
    d = _json_strict(r)
    assert np.allclose(d["E"], r.E) and d["inliers"] == np.nonzero(r.inliers)[0].tolist()
    assert abs(np.linalg.norm(d["t"]) - 1) < 1e-12


def test_numpy_bool_message_does_not_contradict_itself():
    sc = make_scene(30, seed=1)
    r = estimate_relative_pose(sc.f1, sc.f2, focal_px=800.0, refine=np.True_, threshold_px=np.float32(2), seed=np.int64(1))
    assert r.R is not None
    with pytest.raises(InputError) as e:
        estimate_relative_pose(sc.f1, sc.f2, focal_px=800.0, refine=1)
    assert "got int 1" in str(e.value) and "bool" in str(e.value)


def test_negative_seed_rejected_by_every_method():
    sc = make_scene(30, seed=1)
    for m in poseonly.METHODS:
        with pytest.raises(InputError, match="seed"):
            estimate_relative_pose(sc.f1, sc.f2, focal_px=800.0, method=m, seed=-1)


def test_no_runtime_warnings_escape():
    sc = make_scene(40, seed=2)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        for m in poseonly.METHODS:
            estimate_relative_pose(sc.f1 * 1e250, sc.f2, focal_px=800.0, method=m, **({"max_iterations": 5} if m != "lirp" else {}))
        poseonly.lirp(sc.f1, sc.f2, np.full(40, 1e100))


# ------------------------------------------------------------------------------------------------
# no process-global state: concurrent calls give the serial results


def test_threads_give_the_serial_results():
    scs = [make_scene(80, noise_px=0.5, outlier_fraction=0.3, seed=s) for s in range(4)]
    serial = [estimate_relative_pose(sc.f1, sc.f2, focal_px=800.0, seed=1).R for sc in scs]
    out: list = [None] * len(scs)

    def work(i):
        out[i] = estimate_relative_pose(scs[i].f1, scs[i].f2, focal_px=800.0, seed=1).R

    th = [threading.Thread(target=work, args=(i,)) for i in range(len(scs))]
    for t in th:
        t.start()
    for t in th:
        t.join()
    for a, b in zip(serial, out):
        np.testing.assert_array_equal(a, b)


@pytest.mark.parametrize("scale", [1e160, 1e189])
def test_bearings_near_ninety_degrees_no_linalg_error(scale):
    """Normalized coordinates of 1e160 (every ray ~90 deg off-axis) made the 5-point solver's eig and
    the twin's SVD raise LinAlgError (benchmarks/fuzz.py cases 7458, 9602)."""
    rng = np.random.default_rng(7458)
    x1 = rng.standard_normal((25, 2)) * scale
    x2 = rng.standard_normal((25, 2))
    with pytest.raises(InputError, match="pixel-sized"):  # as (n, 2) coordinates they read as pixels
        estimate_relative_pose(x1, x2, focal_px=800.0)
    with pytest.raises(InputError, match="homogeneous pixels"):  # as [x, y, 1] rows too
        estimate_relative_pose(np.column_stack([x1, np.ones(len(x1))]), x2, focal_px=800.0)
    b1 = np.column_stack([x1, np.full(len(x1), 0.5)])  # rays as far off-axis as bearing vectors
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        r = estimate_relative_pose(b1, x2, focal_px=800.0, max_iterations=150)
    assert r.status != "ok" or r.R is not None
    _json_strict(r)


def test_pure_rotation_not_ok_when_the_ml_fit_shrinks_the_threshold():
    """benchmarks/status_calibration.py (pure rotation, 80 % outliers, draw 4): the ML refinement fitted
    22 of the 40 rotation inliers at a 0.19 px decision threshold, and the rotation-only test run at that
    threshold missed its own 0.5 px-noise inliers, so a translation looked supported and the result
    was ``ok``. The rotation test now uses at least the search threshold."""
    sc = make_scene(200, "rotation", camera="pinhole", noise_px=0.5, outlier_fraction=0.8, seed=1_000_004)
    r = estimate_relative_pose(sc.u1, sc.u2, sc.K, seed=1_000_004)
    assert r.status == "pure_rotation", r.message
    assert r.num_inliers >= 35 and poseonly.rotation_error_deg(sc.R, r.R) < 0.2


@pytest.mark.parametrize("final", ["ml", "ligt", "cauchy"])
def test_every_final_stage_refines_to_the_noise_level(final):
    """The three final stages on a plain scene: ok, the rotation within a few noise-floor widths, the
    inliers close to the true ones (``final="cauchy"``: PoseLib's last step, Cauchy-loss Sampson LM)."""
    sc = make_scene(300, camera="pinhole", noise_px=0.5, outlier_fraction=0.3, seed=11)
    r = estimate_relative_pose(sc.u1, sc.u2, sc.K, sc.K, seed=0, final=final)
    assert r.status == "ok", r.message
    assert poseonly.rotation_error_deg(sc.R, r.R) < 0.3
    assert np.count_nonzero(r.inliers & sc.inliers) >= 0.9 * np.count_nonzero(sc.inliers)


@pytest.mark.parametrize("camera", ["wide", "pinhole"])
def test_noise_free_pure_rotation_and_identical_images_stay_pure_rotations(camera):
    """Without noise the precision test's ratio is one of two rounding errors: a parallax below
    PRECISION_MIN_PARALLAX of the threshold counts as none (a review found noise-free pinhole
    rotations and an image matched with itself called ok with a random t)."""
    for seed in range(3):
        sc = make_scene(300, "rotation", camera=camera, noise_px=0.0, seed=seed)
        r = estimate_relative_pose(sc.u1, sc.u2, sc.K, seed=seed)
        assert r.status == "pure_rotation", (seed, r.message)
    sc = make_scene(300, camera=camera, noise_px=0.3, seed=5)
    r = estimate_relative_pose(sc.u1, sc.u1.copy(), sc.K, seed=0)
    assert r.status == "pure_rotation", r.message
    assert poseonly.rotation_error_deg(np.eye(3), r.R) < 1e-6


def test_parallax_ratio_edge_cases():
    from poseonly.analysis import PRECISION_MIN_MATCHES, parallax_ratio

    sc = make_scene(200, "rotation", camera="pinhole", noise_px=0.0, seed=1)
    ratio, noise, R = parallax_ratio(sc.R, sc.f1, sc.f2, np.zeros(200), 1e-3)
    assert ratio == 0.0 and noise == 0.0 and R is not None
    ratio, noise, R = parallax_ratio(sc.R, sc.f1[:10], sc.f2[:10], np.zeros(10), 1e-3)
    assert 10 < PRECISION_MIN_MATCHES and np.isnan(ratio) and R is None
    sc = make_scene(200, camera="pinhole", noise_px=0.0, seed=1)  # parallax, no noise
    ratio, _, _ = parallax_ratio(sc.R, sc.f1, sc.f2, np.zeros(200), 0.5)
    assert ratio == np.inf
