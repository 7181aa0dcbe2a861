"""Per-match noise scales in the ML stage (``noise_scales`` of :func:`poseonly.estimate_relative_pose`,
``scales`` of ``poseonly._core.ml_refine``): a match's inlier scale is ``sigma c_i^alpha`` with
``alpha`` chosen with nu by the profile likelihood; where the scales explain the noise they are used
and the pose is better, where they explain nothing alpha = 0 and the stage is the one without them;
and the SIFT front-end, match files and the benchmark carry them."""

from __future__ import annotations

from collections import Counter

import numpy as np
import pytest

from poseonly import InputError, _core, estimate_relative_pose
from poseonly.features import Features, load_matches_npz, match_noise_scales, save_matches_npz
from poseonly.geometry import rotation_error_deg
from poseonly.sim import make_scene

T_PX = 3.0  # the outlier range (the default's ml_range x its 1 px threshold)
ALPHA_GRID = (0.0, 0.5, 1.0)  # ml_refine.cpp kAlphaGrid


def _bearings(u: np.ndarray, K: np.ndarray) -> np.ndarray:
    x = np.c_[u, np.ones(len(u))] @ np.linalg.inv(K).T
    return x / np.linalg.norm(x, axis=1, keepdims=True)


def _scaled_scene(seed: int, base_px: float = 0.15, outliers: float = 0.3):
    """Pinhole scene whose matches' Gaussian pixel noise is proportional to a known scale c_i
    (log-uniform over [1, 8], as SIFT keypoint sizes spread), and uniform outlier matches."""
    sc = make_scene(300, "normal", "pinhole", 0.0, 0.0, seed)
    rng = np.random.default_rng(2000 + seed)
    c = np.exp(rng.uniform(0.0, np.log(8.0), len(sc.u1)))
    sig = base_px * c[:, None]
    u1 = sc.u1 + sig * rng.normal(size=sc.u1.shape)
    u2 = sc.u2 + sig * rng.normal(size=sc.u2.shape)
    k = int(outliers * len(u1))
    lo, hi = sc.u2.min(0), sc.u2.max(0)
    u2[:k] = rng.uniform(lo, hi, (k, 2))
    return sc, u1, u2, c


def _ml(R, t, f1, f2, focal: float, scales=None, student: bool = True) -> dict:
    return _core.ml_refine(R, t, f1, f2, T_PX / focal, rounds=50, pose_tol=1e-10, student=student, scales=scales)


@pytest.mark.parametrize("student", [True, False])
def test_informative_scales_are_used_and_give_a_better_pose(student):
    ratios = []
    for seed in range(10):
        sc, u1, u2, c = _scaled_scene(seed)
        f1, f2 = _bearings(u1, sc.K), _bearings(u2, sc.K)
        focal = sc.K[0, 0]
        with_scales = _ml(sc.R, sc.t, f1, f2, focal, c, student)
        without = _ml(sc.R, sc.t, f1, f2, focal, None, student)
        assert with_scales["alpha"] in ALPHA_GRID and with_scales["alpha"] >= 0.5
        ratios.append(rotation_error_deg(sc.R, with_scales["R"]) / rotation_error_deg(sc.R, without["R"]))
    assert np.exp(np.mean(np.log(ratios))) < 0.85  # geometric mean over the 10 scenes


def test_uninformative_scales_are_not_used():
    chosen, ratios = [], []
    for seed in range(8):
        sc = make_scene(300, "normal", "pinhole", 0.5, 0.3, seed)
        c = np.exp(np.random.default_rng(seed).uniform(0.0, np.log(8.0), sc.n))  # independent of the noise
        a = _ml(sc.R, sc.t, sc.f1, sc.f2, sc.K[0, 0], c)
        b = _ml(sc.R, sc.t, sc.f1, sc.f2, sc.K[0, 0], None)
        chosen.append(a["alpha"])
        ratios.append(rotation_error_deg(sc.R, a["R"]) / rotation_error_deg(sc.R, b["R"]))
    assert chosen.count(0.0) >= 6
    assert np.exp(np.mean(np.log(ratios))) < 1.05


@pytest.mark.parametrize("student", [True, False])
@pytest.mark.parametrize("seed", [1, 2])
def test_constant_scales_change_nothing(student, seed):
    sc = make_scene(300, "normal", "pinhole", 0.5, 0.3, seed)
    a = _ml(sc.R, sc.t, sc.f1, sc.f2, sc.K[0, 0], np.full(sc.n, 7.0), student)
    b = _ml(sc.R, sc.t, sc.f1, sc.f2, sc.K[0, 0], None, student)
    assert a["alpha"] == 0.0
    np.testing.assert_array_equal(a["R"], b["R"])
    np.testing.assert_array_equal(a["posterior"], b["posterior"])


def test_noise_free_matches_give_the_exact_pose_with_scales():
    sc = make_scene(200, "normal", "wide", 0.0, 0.3, 3)
    c = np.exp(np.random.default_rng(0).uniform(0.0, 2.0, sc.n))
    R0 = sc.R @ np.array([[1.0, -1e-3, 0.0], [1e-3, 1.0, 0.0], [0.0, 0.0, 1.0]])
    U, _, Vt = np.linalg.svd(R0)
    m = _ml(U @ Vt, sc.t, sc.f1, sc.f2, 800.0, c)
    assert rotation_error_deg(sc.R, m["R"]) < 1e-6
    assert np.linalg.norm(m["t"] - sc.t) < 1e-8


def test_the_mixture_with_scales_matches_its_formula():
    """Posteriors and log-likelihood at the returned parameters against the model's density
    q_i f(q_i r_i) (half-t of scale sigma, nu dof; or half-normal), q_i = c_i^-alpha."""
    from scipy import stats

    from poseonly.residuals import v_sampson

    sc, u1, u2, c = _scaled_scene(4)
    f1, f2 = _bearings(u1, sc.K), _bearings(u2, sc.K)
    T = T_PX / sc.K[0, 0]
    m = _ml(sc.R, sc.t, f1, f2, sc.K[0, 0], c)
    assert m["alpha"] > 0  # the scaled model is the one checked
    r = np.abs(v_sampson(m["R"], m["t"], f1, f2))
    q = (c / np.median(c)) ** -m["alpha"]
    s, g, nu = m["sigma"], m["inlier_fraction"], m["nu"]
    dens = 2 * (stats.t.pdf(q * r / s, nu) if np.isfinite(nu) else stats.norm.pdf(q * r / s)) * q / s
    lin = g * dens
    p = np.where(r < T, lin / (lin + (1 - g) / T), 0.0)
    np.testing.assert_allclose(m["posterior"], p, rtol=1e-7, atol=1e-12)
    rc = np.minimum(r, T)
    qc = q
    dc = 2 * (stats.t.pdf(qc * rc / s, nu) if np.isfinite(nu) else stats.norm.pdf(qc * rc / s)) * qc / s
    assert m["log_likelihood"] == pytest.approx(np.sum(np.log(g * dc + (1 - g) / T)), rel=1e-9)


def test_core_rejects_bad_scales():
    sc = make_scene(50, "normal", "pinhole", 0.5, 0.0, 0)
    for bad in (np.zeros(sc.n), np.full(sc.n, np.nan), -np.ones(sc.n)):
        with pytest.raises(ValueError, match="scales"):
            _ml(sc.R, sc.t, sc.f1, sc.f2, 800.0, bad)
    with pytest.raises(ValueError, match="shape"):
        _ml(sc.R, sc.t, sc.f1, sc.f2, 800.0, np.ones(sc.n - 1))


def test_estimate_relative_pose_uses_and_checks_noise_scales():
    sc, u1, u2, c = _scaled_scene(2)
    r0 = estimate_relative_pose(u1, u2, sc.K)
    r1 = estimate_relative_pose(u1, u2, sc.K, noise_scales=c)
    assert r1.diagnostics["ml_alpha"] >= 0.5
    assert r0.diagnostics["ml_alpha"] == 0.0
    with_c = [rotation_error_deg(sc.R, estimate_relative_pose(u1, u2, sc.K, seed=s, noise_scales=c).R) for s in range(3)]
    without = [rotation_error_deg(sc.R, estimate_relative_pose(u1, u2, sc.K, seed=s).R) for s in range(3)]
    assert np.mean(with_c) < np.mean(without)
    for bad, msg in ((c[:-1], "shape"), (np.where(np.arange(len(c)) == 3, 0.0, c), "> 0"), (np.where(np.arange(len(c)) == 3, np.inf, c), "> 0"), (c.astype(str), "numeric")):
        with pytest.raises(InputError, match=msg):
            estimate_relative_pose(u1, u2, sc.K, noise_scales=bad)


def test_match_noise_scales_and_match_files(tmp_path):
    fa = Features(np.zeros((3, 2)), np.zeros((3, 128), np.float32), (10, 10), np.array([2.0, 8.0, 0.0]))
    fb = Features(np.zeros((2, 2)), np.zeros((2, 128), np.float32), (10, 10), np.array([2.0, 4.0]))
    idx = np.array([[0, 0], [1, 1], [2, 0]])
    s = match_noise_scales(fa, fb, idx)
    np.testing.assert_allclose(s[:2], [2.0, np.sqrt(32.0)])
    assert s[2] == pytest.approx(np.median(s[:2]))  # a zero size counts as the median
    assert match_noise_scales(Features(fa.keypoints, fa.descriptors, (10, 10)), fb, idx) is None
    sc = make_scene(20, "normal", "pinhole", 0.5, 0.0, 0)
    ns = np.linspace(1.0, 3.0, sc.n)
    p = save_matches_npz(tmp_path / "m.npz", sc.u1, sc.u2, K=sc.K, noise_scales=ns)
    md = load_matches_npz(p)
    np.testing.assert_array_equal(md.noise_scales, ns)
    with pytest.raises(InputError, match="noise_scales"):
        save_matches_npz(tmp_path / "bad.npz", sc.u1, sc.u2, K=sc.K, noise_scales=-ns)
    assert not (tmp_path / "bad.npz").exists()


def test_colmap_keypoint_scales():
    from poseonly.io.colmap_db import keypoint_scales

    assert keypoint_scales(np.zeros((3, 2))) is None
    np.testing.assert_allclose(keypoint_scales(np.array([[1.0, 2.0, 3.5, 0.1]])), [3.5])
    a = 2.0 * np.array([[np.cos(0.3), -np.sin(0.3)], [np.sin(0.3), np.cos(0.3)]])  # similarity of scale 2
    np.testing.assert_allclose(keypoint_scales(np.array([[1.0, 2.0, *a.ravel()]])), [2.0])
    assert keypoint_scales(np.array([[1.0, 2.0, 0.0, 0.1]])) is None  # a zero scale: not usable


def test_colmap_database_keypoint_scales_reach_the_pairs(tmp_path):
    """A database whose keypoints carry an affine shape gives each verified pair the matches'
    ``sqrt(s1 s2)`` as noise scales; positions-only keypoints give none."""
    pycolmap = pytest.importorskip("pycolmap")
    from poseonly.colmap_verify import _Source
    from poseonly.io.colmap_db import ColmapDatabase

    sc = make_scene(60, "normal", "pinhole", 0.5, 0.0, 0)
    sizes = [np.linspace(1.0, 4.0, sc.n), np.linspace(2.0, 3.0, sc.n)]
    path = tmp_path / "db.db"
    db = pycolmap.Database.open(str(path))
    cam = pycolmap.Camera(model="PINHOLE", width=640, height=480, params=[sc.K[0, 0], sc.K[1, 1], sc.K[0, 2], sc.K[1, 2]])
    cam.has_prior_focal_length = True  # a calibrated camera (a guessed focal length is refused)
    cid = db.write_camera(cam)
    ids = []
    for k, u in enumerate((sc.u1, sc.u2)):
        iid = db.write_image(pycolmap.Image(name=f"im{k}.jpg", camera_id=cid))
        ids.append(iid)
        s = sizes[k]
        rows = np.column_stack([u, s, np.zeros(sc.n), np.zeros(sc.n), s])  # x, y, a11, a12, a21, a22: scale s
        db.write_keypoints(iid, rows.astype(np.float32))
    db.write_matches(ids[0], ids[1], np.column_stack([np.arange(sc.n), np.arange(sc.n)]).astype(np.uint32))
    db.close()
    with ColmapDatabase(path) as cdb:
        np.testing.assert_allclose(cdb.keypoint_scales(ids[0]), sizes[0], rtol=1e-6)
        pairs = list(_Source(cdb, cdb.matched_pairs(), {}, Counter()))
        plain = list(_Source(cdb, cdb.matched_pairs(), {}, Counter(), noise_scales=False))  # colmap verify --no-noise-scales
    assert len(pairs) == 1 and "noise_scales" not in plain[0].options
    np.testing.assert_allclose(pairs[0].options["noise_scales"], np.sqrt(sizes[0] * sizes[1]), rtol=1e-6)
