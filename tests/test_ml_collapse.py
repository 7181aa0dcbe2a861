"""The ML stage's guard against a collapsed EM (``poseonly.robust.default.ML_COLLAPSE``) and the EM
start from the band's least-squares refit (``_core.ml_refine(..., band_start=True)``, option
``ml_start``)."""

from __future__ import annotations

import numpy as np
import pytest

from poseonly import _core, estimate_relative_pose
from poseonly.geometry import rotation_error_deg
from poseonly.options import PoseonlyOptions
from poseonly.robust import default as D
from poseonly.sim import make_scene


def test_collapsed_em_does_not_turn_a_good_pose_into_too_few_inliers():
    # 80 % outliers, 1 px noise at the 1 px threshold: from the chosen pose the Student-t EM (nu = 1)
    # shrinks sigma to its floor (1e-4 px) on ~9 matches the pose fits exactly, and the pair was
    # returned `too_few_inliers` with 9 inliers (a 0.17 deg pose); the guard restarts EM from the
    # band's refit, which does not collapse
    sc = make_scene(300, camera="wide", noise_px=1.0, outlier_fraction=0.8, seed=3)
    r = estimate_relative_pose(sc.f1, sc.f2, focal_px=800.0)
    assert r.status == "ok"
    assert np.count_nonzero(r.inliers) >= 40
    assert float(rotation_error_deg(sc.R, r.R)) < 0.15
    assert r.diagnostics["sigma"] * 800.0 > 0.3  # a noise scale near the simulated 1 px


def test_the_collapse_this_guards_against_exists():
    # the raw stage from the search's pose collapses on that scene (so the test above tests the guard)
    sc = make_scene(300, camera="wide", noise_px=1.0, outlier_fraction=0.8, seed=3)
    o = PoseonlyOptions()
    tau = 1.0 / 800.0
    r = D._search(sc.f1, sc.f2, tau, o, None)
    R, t = D.select_by_support(r.R, r.t, sc.f1, sc.f2, tau)
    m = _core.ml_refine(R, t, sc.f1, sc.f2, 3 * tau, rounds=D.ML_ROUNDS, pose_tol=D.ML_POSE_TOL, student=True)
    assert D._collapsed(m)
    mb = _core.ml_refine(R, t, sc.f1, sc.f2, 3 * tau, rounds=D.ML_ROUNDS, pose_tol=D.ML_POSE_TOL, student=True, band_start=True)
    assert not D._collapsed(mb)


@pytest.mark.parametrize("camera", ["wide", "pinhole"])
def test_band_start_is_exact_without_noise(camera):
    sc = make_scene(200, camera=camera, noise_px=0.0, outlier_fraction=0.3, seed=11)
    t = sc.t / np.linalg.norm(sc.t)
    # start 0.5 deg off: the band (3 sigma of the start's errors, at most T) refit and EM reach the truth
    w = np.radians(0.5) * np.array([0.6, -0.8, 0.0])
    th = np.linalg.norm(w)
    k = w / th
    Kx = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    R0 = (np.eye(3) + np.sin(th) * Kx + (1 - np.cos(th)) * Kx @ Kx) @ sc.R
    T = 20.0 / float(sc.K[0, 0]) if sc.K is not None else 20.0 / 800.0
    m = _core.ml_refine(np.ascontiguousarray(R0), t, sc.f1, sc.f2, T, rounds=50, pose_tol=1e-12, student=False, band_start=True)
    assert float(rotation_error_deg(sc.R, m["R"])) < 1e-6
    assert float(np.degrees(np.arccos(np.clip(abs(m["t"] @ t), -1, 1)))) < 1e-5


def test_ml_start_option_values():
    sc = make_scene(300, camera="pinhole", noise_px=0.5, outlier_fraction=0.5, seed=2)
    for start in ("search", "band", "both"):
        r = estimate_relative_pose(sc.u1, sc.u2, sc.K, sc.K, ml_start=start)
        assert r.status == "ok"
        assert float(rotation_error_deg(sc.R, r.R)) < 1.0
    with pytest.raises(ValueError, match="ml_start"):
        estimate_relative_pose(sc.u1, sc.u2, sc.K, sc.K, ml_start="truth")
