"""The core's precision check of the pure-rotation test (``_core.parallax_ratio`` behind
``poseonly.analysis.parallax_ratio``) against its numpy reference (tests/reference/parallax.py)."""

from __future__ import annotations

import numpy as np
import pytest

from poseonly import _core, sim
from poseonly.analysis import parallax_ratio, robust_rotation
from poseonly.residuals import v_sampson
from reference.parallax import parallax_ratio as ref_parallax_ratio

TAU = 2.0 / 800.0  # 2 px at the synthetic focal 800


def _case(kind: str, camera: str, outliers: float, noise: float, seed: int):
    s = sim.make_scene(300, kind=kind, camera=camera, noise_px=noise, outlier_fraction=outliers, seed=seed)
    t = s.t if kind != "rotation" else np.array([0.0, 0.0, 1.0])  # any direction: a pure rotation's pose
    v = v_sampson(s.R, t, s.f1, s.f2)
    Rr, _, _ = robust_rotation(s.f1, s.f2, TAU)
    return Rr, s.f1, s.f2, v


@pytest.mark.parametrize("kind", ["rotation", "normal", "planar"])
@pytest.mark.parametrize("camera", ["pinhole", "wide"])
@pytest.mark.parametrize("outliers", [0.0, 0.5, 0.8])
def test_core_parallax_ratio_matches_the_reference(kind, camera, outliers):
    for seed in range(3):
        Rr, f1, f2, v = _case(kind, camera, outliers, 0.5, seed)
        got = parallax_ratio(Rr, f1, f2, v, TAU)
        ref = ref_parallax_ratio(Rr, f1, f2, v, TAU)
        if ref[2] is None:
            assert got[2] is None and np.isnan(got[0]) and np.isnan(got[1])
            continue
        np.testing.assert_allclose(got[0], ref[0], rtol=1e-9)
        np.testing.assert_allclose(got[1], ref[1], rtol=1e-12)
        np.testing.assert_allclose(got[2], ref[2], atol=1e-12)


@pytest.mark.parametrize("baseline", [0.005, 0.01, 0.02])
def test_core_parallax_ratio_matches_the_reference_on_wide_low_parallax(baseline):
    """The wide camera with a translation: above, its normal and planar scenes have too much
    parallax for the rotation's band (both sides return None); a small translation (``baseline``
    times the median depth; 30 % outliers) gives ratios of 25-180, compared here."""
    for seed in range(3):
        s = sim.make_scene(300, kind="rotation", camera="wide", noise_px=0.5, outlier_fraction=0.3, seed=seed)
        t = baseline * float(np.median(np.linalg.norm(s.X, axis=1))) * np.array([1.0, 0.3, 0.1])
        P = s.X @ s.R.T + t
        f2 = P / np.linalg.norm(P, axis=1)[:, None]
        f2[~s.inliers] = s.f2[~s.inliers]
        Rr, _, _ = robust_rotation(s.f1, f2, TAU)
        v = v_sampson(s.R, t / np.linalg.norm(t), s.f1, f2)
        got, ref = parallax_ratio(Rr, s.f1, f2, v, TAU), ref_parallax_ratio(Rr, s.f1, f2, v, TAU)
        assert ref[2] is not None and ref[0] > 10.0, (seed, ref[0])
        np.testing.assert_allclose(got[0], ref[0], rtol=1e-9)
        np.testing.assert_allclose(got[1], ref[1], rtol=1e-12)
        np.testing.assert_allclose(got[2], ref[2], atol=1e-12)


def test_parallax_ratio_edge_cases():
    s = sim.make_scene(300, kind="rotation", noise_px=0.0, seed=1)
    v = v_sampson(s.R, np.array([0.0, 0.0, 1.0]), s.f1, s.f2)
    # noise-free pure rotation: no parallax beyond rounding -> ratio 0
    got, ref = parallax_ratio(s.R, s.f1, s.f2, v, TAU), ref_parallax_ratio(s.R, s.f1, s.f2, v, TAU)
    assert got[0] == ref[0] == 0.0
    # too few matches in the band -> NaN, no refit
    few = parallax_ratio(s.R, s.f1[:40], s.f2[:40], v[:40], TAU)
    assert np.isnan(few[0]) and np.isnan(few[1]) and few[2] is None
    # NaN errors are outside the band (as numpy's comparison makes them)
    vn = v.copy()
    vn[::2] = np.nan
    np.testing.assert_allclose(parallax_ratio(s.R, s.f1, s.f2, vn, TAU)[1], ref_parallax_ratio(s.R, s.f1, s.f2, vn, TAU)[1], rtol=1e-12)


def test_parallax_ratio_bad_input_raises_value_error():
    s = sim.make_scene(100, seed=0)
    v = np.zeros(100)
    args = (1.0, 1.0, 50, 5, 2.385, 0.455, 1e-4)
    with pytest.raises(ValueError):
        _core.parallax_ratio(np.eye(3), s.f1, s.f2, v[:50], TAU, *args)
    with pytest.raises(ValueError):
        _core.parallax_ratio(np.eye(2), s.f1, s.f2, v, TAU, *args)
    with pytest.raises(ValueError):
        _core.parallax_ratio(np.eye(3), s.f1, s.f2, v, -1.0, *args)
    with pytest.raises(ValueError):
        _core.parallax_ratio(np.eye(3), s.f1, s.f2, v, TAU, 1.0, 1.0, 0, 5, 2.385, 0.455, 1e-4)
