"""The core's final-pose analysis (src/core/analysis.cpp): chance counts on re-paired matches and the
homography twin, against the numpy formulas and the numpy reference twin (tests/reference/twin.py)."""

from __future__ import annotations

import numpy as np
import pytest

from poseonly import _core
from poseonly.analysis import ROTATION_THRESHOLD_FACTOR, _permutations, chance_rate, rotation_chance_rate
from poseonly.geometry import rotation_error_deg, translation_error_deg
from poseonly.residuals import v_sampson
from poseonly.sim import make_scene
from poseonly.twin import decompose_homography, homography_twin, homography_twin_dlt
from reference import twin as ref_twin


@pytest.mark.parametrize("outliers", [0.0, 0.5])
def test_chance_rates_match_the_numpy_formulas(outliers):
    sc = make_scene(200, camera="pinhole", noise_px=0.5, outlier_fraction=outliers, seed=3)
    tau = 2.0 / 800.0
    perms = _permutations(len(sc.f1))
    v = v_sampson(sc.R, sc.t, np.tile(sc.f1, (len(perms), 1)), sc.f2[perms.ravel()])
    assert chance_rate(sc.R, sc.t, sc.f1, sc.f2, tau) == (np.count_nonzero(v < tau) + 1) / (v.size + 2)
    d = (sc.f1 @ sc.R.T)[None] - sc.f2[perms]
    hit = np.einsum("rni,rni->rn", d, d) < (2.0 * np.sin(0.5 * ROTATION_THRESHOLD_FACTOR * tau)) ** 2
    assert rotation_chance_rate(sc.R, sc.f1, sc.f2, tau) == (np.count_nonzero(hit) + 1) / (hit.size + 2)


def test_chance_count_rejects_bad_permutations():
    sc = make_scene(20, seed=0)
    bad = np.zeros((2, 20), dtype=np.int64)
    bad[0, 3] = 20
    with pytest.raises(ValueError, match="indices"):
        _core.chance_count(sc.R, sc.t, sc.f1, sc.f2, bad, 0.01)
    with pytest.raises(ValueError, match="shape"):
        _core.rotation_chance_count(sc.R, sc.f1, sc.f2, np.zeros((2, 19), dtype=np.int64), 0.01)


@pytest.mark.parametrize("camera", ["wide", "pinhole"])
def test_homography_twin_matches_the_reference(camera):
    found = 0
    for seed in range(30):
        sc = make_scene(120, kind="planar", camera=camera, noise_px=0.3 * (seed % 3), seed=seed)
        a = homography_twin(sc.R, sc.t, sc.f1, sc.f2)
        b = ref_twin.homography_twin(sc.R, sc.t, sc.f1, sc.f2)
        assert (a is None) == (b is None), seed
        if a is None:
            continue
        found += 1
        assert rotation_error_deg(a[0], b[0]) < 1e-7 and translation_error_deg(a[1], b[1]) < 1e-7, seed
        assert abs(a[2] - b[2]) < 1e-9 * max(1.0, b[2])
    assert found >= 10


@pytest.mark.parametrize("camera", ["wide", "pinhole"])
def test_homography_twin_dlt_matches_the_reference(camera):
    found = 0
    for seed in range(30):
        sc = make_scene(120, kind="planar", camera=camera, noise_px=0.3 * (seed % 3), seed=seed)
        a = homography_twin_dlt(sc.R, sc.t, sc.f1, sc.f2)
        b = ref_twin.homography_twin_dlt(sc.R, sc.t, sc.f1, sc.f2)
        assert (a is None) == (b is None), seed
        if a is None:
            continue
        found += 1
        assert rotation_error_deg(a[0], b[0]) < 1e-7 and translation_error_deg(a[1], b[1]) < 1e-7, seed
    assert found >= 10
    assert homography_twin_dlt(sc.R, sc.t, sc.f1[:3], sc.f2[:3]) is None  # fewer than 4 matches


def test_homography_twin_dlt_refuses_an_undetermined_homography():
    """Matches of points on one 3-D line do not determine a homography (a null space of several
    dimensions): no twin, in the core and the reference, where the fit used to pick an arbitrary H."""
    rng = np.random.default_rng(3)
    R = np.eye(3)
    t = np.array([0.3, 0.0, 0.05])
    X = np.array([0.2, -0.1, 5.0]) + np.outer(rng.uniform(-1, 1, 40), [1.0, 0.4, 0.5])
    f1 = X / np.linalg.norm(X, axis=1, keepdims=True)
    X2 = X @ R.T + t
    f2 = X2 / np.linalg.norm(X2, axis=1, keepdims=True)
    assert homography_twin_dlt(R, t, f1, f2) is None
    assert ref_twin.homography_twin_dlt(R, t, f1, f2) is None


def test_homography_twin_dlt_is_exact_on_a_noise_free_plane():
    """Noise-free planar scene: the directly fitted homography's twin reproduces the plane's
    correspondences exactly, and it is the triangulated plane's twin."""
    for seed in range(20):
        sc = make_scene(60, kind="planar", camera="pinhole", noise_px=0.0, seed=seed)
        tw, tri = homography_twin_dlt(sc.R, sc.t, sc.f1, sc.f2), homography_twin(sc.R, sc.t, sc.f1, sc.f2)
        if tw is None or tri is None:
            continue
        assert np.max(v_sampson(tw[0], tw[1], sc.f1, sc.f2)) < 1e-9
        assert rotation_error_deg(tw[0], tri[0]) < 1e-6 and rotation_error_deg(sc.R, tw[0]) > 1e-3
        return
    pytest.fail("no scene gave a twin")


def test_homography_twin_is_exact_on_a_noise_free_plane():
    """Noise-free planar scene: the twin reproduces the plane's correspondences exactly."""
    for seed in range(20):
        sc = make_scene(60, kind="planar", camera="pinhole", noise_px=0.0, seed=seed)
        tw = homography_twin(sc.R, sc.t, sc.f1, sc.f2)
        if tw is None:
            continue
        assert tw[2] < 1e-9  # exact plane
        assert np.max(v_sampson(tw[0], tw[1], sc.f1, sc.f2)) < 1e-9
        assert rotation_error_deg(sc.R, tw[0]) > 1e-3  # another pose, not the truth
        return
    pytest.fail("no scene gave a twin")


def test_decompose_homography_matches_the_reference_and_rejects_bad_input():
    rng = np.random.default_rng(1)
    for _ in range(20):
        H = np.eye(3) + 0.3 * rng.standard_normal((3, 3))
        Rc, Tc, Nc = decompose_homography(H)
        Rr, Tr, Nr = ref_twin.decompose_homography(H)
        # the same set of four solutions (the order of the SVD's vectors may differ)
        for k in range(4):
            d = [np.max(np.abs(Rc[k] - Rr[j])) + np.max(np.abs(Tc[k] - Tr[j])) + np.max(np.abs(Nc[k] - Nr[j])) for j in range(4)]
            assert min(d) < 1e-9
    with pytest.raises(ValueError, match="finite"):
        decompose_homography(np.full((3, 3), np.nan))
    with pytest.raises(ValueError, match="shape"):
        decompose_homography(np.eye(2))


def test_sign_test_is_the_exact_binomial_tail():
    from math import comb, log10

    from poseonly.analysis import sign_test

    for a, b in [(5, 2), (29, 10), (33, 6), (4, 0), (0, 7), (841, 23)]:
        m = a + b
        tail = sum(comb(m, j) for j in range(a, m + 1)) / 2**m
        assert sign_test(a, b) == pytest.approx(log10(tail), abs=1e-9)
    assert sign_test(0, 0) == 0.0


def test_planar_twin_flags_only_an_indistinguishable_distant_twin():
    from poseonly.analysis import AMBIGUITY_LEVEL, TWIN_MIN_SEPARATION_DEG, TWIN_SUPPORT_RATIO, planar_twin

    flagged = 0
    for s in range(12):
        sc = make_scene(200, "planar", camera="pinhole", noise_px=0.2, seed=s)
        tau = 1.0 / 800.0
        inl = v_sampson(sc.R, sc.t, sc.f1, sc.f2) < tau
        twin, info = planar_twin(sc.R, sc.t, sc.f1, sc.f2, tau, inl)
        if "twin_support" not in info:
            assert twin is None
            continue
        rule = (
            info["twin_support"] >= TWIN_SUPPORT_RATIO * info["support"]
            and info["twin_log10_p"] >= np.log10(AMBIGUITY_LEVEL)
            and info["twin_separation_deg"] > TWIN_MIN_SEPARATION_DEG
        )
        assert (twin is not None) == rule
        flagged += twin is not None
    assert flagged > 0  # exact planes: the twin explains every point as well as the truth
