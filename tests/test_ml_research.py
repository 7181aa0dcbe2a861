"""The default's ML stage: EM to its fixed point, and the opt-in second search at 3 sigma when the
matches are noisier than the threshold assumes (``research_noise``; poseonly.robust.default step 4)."""

from __future__ import annotations

import numpy as np
import pytest

from poseonly import _core, estimate_relative_pose
from poseonly.bench_robust import ml_floor
from poseonly.geometry import rotation_error_deg
from poseonly.residuals import v_sampson
from poseonly.sim import make_scene

FOCAL = 800.0
RESEARCH = 0.5  # the studied value of research_noise
SEEDS = range(6)


def _scene(noise_px: float, outliers: float, seed: int):
    return make_scene(300, "normal", "pinhole", noise_px, outliers, seed)


def test_ml_refine_stops_at_its_fixed_point():
    sc = _scene(0.5, 0.3, 0)
    T = 3.0 / FOCAL
    full = _core.ml_refine(sc.R, sc.t, sc.f1, sc.f2, T, rounds=50)
    early = _core.ml_refine(sc.R, sc.t, sc.f1, sc.f2, T, rounds=50, pose_tol=1e-10)
    assert full["rounds"] == 50
    assert early["rounds"] < 50
    assert rotation_error_deg(full["R"], early["R"]) < 1e-6
    assert np.linalg.norm(full["t"] - early["t"]) < 1e-8


def test_ml_log_likelihood_is_the_mixture_of_the_returned_pose():
    sc = _scene(0.5, 0.3, 1)
    T = 3.0 / FOCAL
    m = _core.ml_refine(sc.R, sc.t, sc.f1, sc.f2, T, rounds=50, pose_tol=1e-10, student=False)
    r = np.minimum(v_sampson(m["R"][None], m["t"][None], sc.f1, sc.f2)[0], T)
    s, g = m["sigma"], m["inlier_fraction"]
    ll = np.sum(np.log(g * np.sqrt(2 / np.pi) / s * np.exp(-0.5 * (r / s) ** 2) + (1 - g) / T))
    assert m["log_likelihood"] == pytest.approx(ll, rel=1e-9)
    assert 0.3 / FOCAL < s < 0.8 / FOCAL and m["sigma_start"] > 0


def test_noisy_matches_are_searched_again_at_three_sigma():
    """1 px noise at the default's 1 px threshold: the second search (at ~3 px) and its ML pose reach
    the least-squares floor; without it the pose stays in the first search's basin (1.43x measured)."""
    ratio, ratio_off = [], []
    for s in SEEDS:
        sc = _scene(1.0, 0.0, s)
        floor = rotation_error_deg(sc.R, ml_floor(sc))
        r = estimate_relative_pose(sc.u1, sc.u2, sc.K, seed=s, research_noise=RESEARCH)
        assert 2.0 < r.diagnostics["research_threshold"] * FOCAL <= 3.0
        ratio.append(rotation_error_deg(sc.R, r.R) / floor)
        off = estimate_relative_pose(sc.u1, sc.u2, sc.K, seed=s)  # the default: off
        assert "research_threshold" not in off.diagnostics
        ratio_off.append(rotation_error_deg(sc.R, off.R) / floor)
    assert max(ratio) < 1.01
    assert max(ratio_off) > 1.2  # the case the second search exists for


def test_real_noise_is_searched_once():
    for s in SEEDS:
        r = estimate_relative_pose(*_uv(_scene(0.3, 0.5, s)), seed=s, research_noise=RESEARCH)
        assert "research_threshold" not in r.diagnostics
        assert r.diagnostics["sigma"] * FOCAL < 0.5


def _uv(sc):
    return sc.u1, sc.u2, sc.K
