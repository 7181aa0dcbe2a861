"""Pure rotations on real images, and the rotation-only fit's precision.

A camera turning on a tripod over a repeated facade: the wrong matches to the facade's next period are
displaced along one direction, and a translation with its epipole at infinity there collects them. The
pose is then `ok` with a made-up translation unless the translation's support must show parallax over a
neighbourhood (``poseonly.analysis.LOCAL_SUPPORT_MIN``). Measured with
``python benchmarks/warped_statuses.py`` (docs/results/warped_statuses/): 39 of 200 pure rotations and
shifts `ok` before, 1 after."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from poseonly import estimate_relative_pose, rotation_error_deg
from poseonly.geometry import rotation_from_rotvec

ENTRY = Path("/work/shared/data/strecha/entry-P10/images")


@pytest.mark.skipif(not ENTRY.is_dir(), reason="needs the shared Strecha data")
@pytest.mark.parametrize(
    ("rotvec_deg", "seeds"),
    [
        ((5.0, 0.0, 0.0), range(4)),  # seeds 0-2 were `ok` with translations 25-90 deg apart
        # `ok` on seeds 0 and 3 before the translation's support left out matches on keypoints the rotation
        # pairs otherwise and matches behind a camera (the facade's next period, taken by a non-mutual matcher)
        ((2.0, 0.0, 0.0), (0, 3)),
        # seed 3 `ok`: points the rotation carries out of view 2 matched to the facade's copy ~280 px away
        ((0.0, 0.0, 30.0), (3,)),
    ],
)
def test_rotation_over_a_repeated_facade_is_a_pure_rotation(rotvec_deg, seeds):
    cv2 = pytest.importorskip("cv2")
    from poseonly.features import extract_features, match_features

    im = cv2.imread(str(ENTRY / "0004.jpg"))
    K0 = np.loadtxt(ENTRY / "K.txt")
    s = 1024 / im.shape[1]
    im = cv2.resize(im, (1024, round(im.shape[0] * s)), interpolation=cv2.INTER_AREA)
    K = K0.copy()
    K[:2, :2] *= s
    K[:2, 2] = s * (K0[:2, 2] + 0.5) - 0.5
    R = rotation_from_rotvec(np.radians(np.array(rotvec_deg)))
    im2 = cv2.warpPerspective(im, K @ R @ np.linalg.inv(K), im.shape[1::-1])
    f1, f2 = extract_features(im), extract_features(im2)
    idx, sc = match_features(f1.descriptors, f2.descriptors, return_scores=True)
    u1, u2 = f1.keypoints[idx[:, 0]].astype(float), f2.keypoints[idx[:, 1]].astype(float)
    for seed in seeds:
        r = estimate_relative_pose(u1, u2, K, K, scores=sc, seed=seed)
        assert r.status == "pure_rotation", (seed, r.message)
        # (the deviation includes the rotation-only fit's distance from the pose's R, which the wrong matches
        # pulled 0.03-0.1 deg away: conservative here, where the fit is 0.001 deg off)
        assert rotation_error_deg(R, r.R) < 0.02 and r.diagnostics["rotation_std_deg"] < 0.2


def _small_baseline(seed: int = 0):
    rng = np.random.default_rng(seed)
    K = np.array([[800.0, 0, 320], [0, 800, 240], [0, 0, 1]])
    R = rotation_from_rotvec(rng.normal(0, 0.1, 3))
    t = rng.normal(size=3)
    t /= np.linalg.norm(t)
    X = np.c_[rng.uniform(-2, 2, (300, 2)), rng.uniform(4, 10, 300)]
    X2 = X @ R.T + 0.03 * t
    u1 = ((X / X[:, 2:]) @ K.T)[:, :2] + rng.normal(0, 0.5, (300, 2))
    u2 = ((X2 / X2[:, 2:]) @ K.T)[:, :2] + rng.normal(0, 0.5, (300, 2))
    u2[:90] = rng.uniform([0, 0], [640, 480], (90, 2))
    return u1, u2, K, R


def test_pure_rotation_precision_includes_the_unresolved_parallax():
    """A 0.03 baseline at depths 4-10 is below what the matches resolve: `pure_rotation` is the honest
    status, but its rotation-only fit absorbs the parallax (0.2 deg off where its noise alone gives
    0.02): the reported deviation includes the fit's distance from the pose's R."""
    u1, u2, K, R = _small_baseline()
    r = estimate_relative_pose(u1, u2, K)
    assert r.status == "pure_rotation", r.message
    err = rotation_error_deg(R, r.R)
    assert 0.1 < err < r.diagnostics["rotation_std_deg"] and r.diagnostics["rotation_model_spread_deg"] > err
    assert np.degrees(np.sqrt(np.linalg.eigvalsh(r.rotation_covariance)[-1])) == pytest.approx(r.diagnostics["rotation_std_deg"])
    assert f"R is reliable to {r.diagnostics['rotation_std_deg']:.3g} deg" in r.message


def test_a_poor_pose_does_not_make_a_reliable_rotation():
    """The paper's methods on a scene with a real baseline (GNC-IRLS and GNC-RANSAC land on poses 125-150
    deg off): their translation support looks like chance, and a rotation explains the matches 5 deg off.
    That rotation is far from the pose's R, so nothing is reliable (`too_few_inliers`, no covariance),
    not a reliable `pure_rotation` (which `colmap verify` would write as PANORAMIC)."""
    from poseonly.sim import make_scene

    s = make_scene(200, camera="pinhole", noise_px=0.5, outlier_fraction=0.3, seed=1006)
    assert estimate_relative_pose(s.u1, s.u2, s.K, seed=0).status == "ok"
    for method in ("gnc-irls", "gnc-ransac"):
        r = estimate_relative_pose(s.u1, s.u2, s.K, method=method, seed=0)
        assert r.status == "too_few_inliers" and "from the pose's R" in r.message, (method, r.message)
        assert r.rotation_covariance is None and r.diagnostics["rotation_model_spread_deg"] > 100


def test_pure_rotation_keeps_the_epipolar_pose_in_the_diagnostics():
    """A pure_rotation result's R is the rotation-only fit; the epipolar pose it replaced stays available
    (a user's trial: at 10 cm sideways its translation was within a few degrees and nothing kept it)."""
    import json

    from poseonly import estimate_relative_pose, sim

    sc = sim.make_scene(200, "rotation", camera="pinhole", noise_px=0.5, seed=1)
    r = estimate_relative_pose(sc.u1, sc.u2, sc.K, sc.K)
    assert r.status == "pure_rotation"
    assert r.diagnostics["pose_R"].shape == (3, 3) and r.diagnostics["pose_t"].shape == (3,)
    assert json.loads(json.dumps(r.to_dict(), allow_nan=False))["diagnostics"]["pose_R"]


def test_a_moving_object_before_a_still_camera_widens_the_rotation_deviation():
    """A still camera, 600 static matches and one compact object of 80 matches shifted 10 px (a SLAM
    user's trial): from two views the geometry of a near surface before a distant background, so the pose
    is ok, but its R sat 0.17 deg off the identity with a first-order deviation of 0.03. The rotation-only
    fit, the other reading, now counts in the deviation and the message says where the translation rests."""
    from poseonly import estimate_relative_pose
    from poseonly.geometry import rotation_error_deg

    rng = np.random.default_rng(0)
    K = np.array([[707.0912, 0.0, 601.8873], [0.0, 707.0912, 183.1104], [0.0, 0.0, 1.0]])
    u1 = np.c_[rng.uniform(0, 1241, 600), rng.uniform(0, 376, 600)]
    u2 = u1.copy()
    c = np.array([rng.uniform(150, 1091), rng.uniform(80, 296)])
    p = c + np.c_[rng.uniform(-60, 60, 80), rng.uniform(-40, 40, 80)]
    d = rng.normal(0, 1, 2)
    u1, u2 = np.r_[u1, p], np.r_[u2, p + 10.0 * d / np.linalg.norm(d)]
    u1, u2 = u1 + rng.normal(0, 0.5, u1.shape), u2 + rng.normal(0, 0.5, u2.shape)
    r = estimate_relative_pose(u1, u2, K, K)
    err = rotation_error_deg(np.eye(3), r.R)
    assert r.status == "ok" and "fit a rotation alone" in r.message
    assert r.diagnostics["rotation_std_deg"] >= 0.5 * err > 0.05
    assert r.diagnostics["rotation_model_spread_deg"] > 0.05


def test_shares_keypoint_with_matches_its_definition():
    """A match shares a keypoint with ``other`` when another correspondence of ``other`` has its exact
    view-1 or view-2 bearing (copies of the same correspondence do not count): against the O(n^2)
    definition on matches with many repeated keypoints."""
    from poseonly.analysis import _shares_keypoint_with

    rng = np.random.default_rng(3)
    pts = rng.standard_normal((12, 3))
    pts /= np.linalg.norm(pts, axis=1, keepdims=True)
    i1, i2 = rng.integers(0, 12, 80), rng.integers(0, 12, 80)
    f1, f2 = pts[i1], pts[(i2 + 5) % 12]
    for trial in range(5):
        other = rng.random(80) < 0.3 + 0.1 * trial
        got = _shares_keypoint_with(f1, f2, other)
        want = np.array([any(other[j] and (i1[j], i2[j]) != (i1[k], i2[k]) and (i1[j] == i1[k] or i2[j] == i2[k]) for j in range(80)) for k in range(80)])
        assert np.array_equal(got, want)
    assert not _shares_keypoint_with(pts, np.roll(pts, 1, axis=0), np.ones(12, bool)).any()


def test_the_depth_mask_from_the_core_is_the_pose_only_depths_sign():
    """status.finish's depth mask (sampson-chiral below CHIRAL_PENALTY) is "both pose-only depths
    positive" (``ligt_depths``) on every match whose Sampson error is below the penalty."""
    from poseonly import sim
    from poseonly.residuals import CHIRAL_PENALTY, ligt_depths, v_sampson, v_sampson_chiral

    sc = sim.make_scene(400, camera="wide", noise_px=0.5, outlier_fraction=0.5, seed=4)
    for t in (sc.t, -sc.t):
        h, hp, _ = ligt_depths(sc.R, t, sc.f1, sc.f2)
        v = v_sampson.unchecked(sc.R, t, sc.f1, sc.f2)
        vc = v_sampson_chiral.unchecked(sc.R, t, sc.f1, sc.f2)
        below = v < CHIRAL_PENALTY
        assert np.array_equal((vc < CHIRAL_PENALTY)[below], ((h > 0) & (hp > 0))[below])
        assert np.all(vc[~((h > 0) & (hp > 0))] == CHIRAL_PENALTY)
        assert 0 < np.count_nonzero((h > 0) & (hp > 0)) < len(v)


def _lateral_pair(n: int, seed: int, outliers: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """A migrating user's scene: a 0.3 baseline, mostly sideways, depths 4-20, 0.5 px noise, f = 800,
    640 x 480; every match has 8 px or more of parallax once the true rotation is removed."""
    rng = np.random.default_rng(seed)
    K = np.array([[800.0, 0.0, 320.0], [0.0, 800.0, 240.0], [0.0, 0.0, 1.0]])
    R = rotation_from_rotvec(rng.normal(size=3) * 0.03)
    t = np.r_[rng.normal(size=2), 0.2]
    t = 0.3 * t / np.linalg.norm(t)
    u1 = rng.uniform([0, 0], [640, 480], (n, 2))
    X1 = (np.c_[u1, np.ones(n)] @ np.linalg.inv(K).T) * rng.uniform(4, 20, n)[:, None]
    x2 = (X1 @ R.T + t) @ K.T
    u2 = x2[:, :2] / x2[:, 2:]
    u1 = u1 + rng.normal(0, 0.5, u1.shape)
    u2 = u2 + rng.normal(0, 0.5, u2.shape)
    k = int(outliers * n)
    u2[:k] = rng.uniform([0, 0], [640, 480], (k, 2))
    return u1, u2, K, R


@pytest.mark.parametrize("outliers", [0.0, 0.3])
def test_few_clean_matches_with_parallax_are_not_a_pure_rotation(outliers):
    """40 matches, each with >= 8 px of parallax at 0.5 px noise: 4 of 12 were `pure_rotation` at 30 %
    outliers (the rotation-only fit, 1.3 deg off, returned for a pose 0.1 deg off), because the ML stage's
    decision threshold, with no outlier near its band, had moved to the band's edge (3 px) and the
    rotation was judged there (``poseonly.status.alternatives_cap``)."""
    statuses = []
    for seed in range(12):
        u1, u2, K, R = _lateral_pair(40, seed, outliers)
        r = estimate_relative_pose(u1, u2, K, seed=0)
        statuses.append(r.status)
        if r.status == "ok":
            assert rotation_error_deg(R, r.R) < 1.0, seed
    assert "pure_rotation" not in statuses, statuses
    assert statuses.count("ok") >= 11, statuses
