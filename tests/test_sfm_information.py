"""Rotation averaging weighted by each edge's information (poseonly.sfm.edge_information)."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

from poseonly import InputError, _core, sim
from poseonly.geometry import bearings_from_pixels
from poseonly.residuals import v_sampson
from poseonly.sfm.edge_information import rotation_information, signed_sampson
from poseonly.sfm.pipeline import GlobalOptions
from poseonly.sfm.rotation_averaging import average_rotations
from poseonly.sfm.so3 import angle_deg, log_so3, project_so3
from poseonly.sfm.synthetic import make_scene

EXACT = 1e-8
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))


def _aligned_mean(R, R_gt):
    Q = project_so3(np.einsum("nji,njk->ik", R, R_gt)[None])[0]
    return float(angle_deg(np.einsum("nji,njk->nik", R_gt, R @ Q)).mean())


def test_signed_sampson_is_the_residual_table_with_a_sign():
    sc = sim.make_scene(50, camera="pinhole", noise_px=1.0, seed=1)
    r = signed_sampson(sc.R, sc.t, sc.f1, sc.f2)
    np.testing.assert_allclose(np.abs(r), v_sampson(sc.R, sc.t, sc.f1, sc.f2), rtol=1e-12, atol=1e-15)
    assert np.any(r > 0) and np.any(r < 0)


def test_rotation_information_predicts_the_ml_pose_scatter():
    """Monte Carlo: the covariance of the Sampson-LM pose's rotation over noise draws matches the
    inverse information (pinhole camera: the strongly anisotropic case, sds 0.12 / 0.10 / 0.02 deg).
    The information is the core's pose_covariance (left perturbation) turned to the right one, so this
    checks both."""
    sc0 = sim.make_scene(200, camera="pinhole", noise_px=0.0, seed=3)
    rng = np.random.default_rng(0)
    ds, infos = [], []
    for _ in range(150):
        f1 = bearings_from_pixels(sc0.u1 + rng.normal(0, 0.5, sc0.u1.shape), sc0.K)
        f2 = bearings_from_pixels(sc0.u2 + rng.normal(0, 0.5, sc0.u2.shape), sc0.K)
        R, t, _ = _core.refine_sampson(np.ascontiguousarray(sc0.R), np.ascontiguousarray(sc0.t), f1, f2)
        ds.append(log_so3((sc0.R.T @ R)[None])[0])
        infos.append(rotation_information(R, t, f1, f2))
    C = np.cov(np.array(ds).T)
    P = np.linalg.inv(np.mean(infos, axis=0))
    # per-axis standard deviations within 25 % (150 draws: a sd's sampling error is ~6 %)
    np.testing.assert_allclose(np.sqrt(np.diag(C)), np.sqrt(np.diag(P)), rtol=0.25)
    # and the dominant direction (the rotation that trades against the translation)
    u_c, u_p = np.linalg.eigh(C)[1][:, -1], np.linalg.eigh(P)[1][:, -1]
    assert abs(u_c @ u_p) > 0.99


def test_rotation_information_of_a_pure_rotation_and_degenerate_inputs():
    sc = sim.make_scene(100, kind="rotation", camera="pinhole", noise_px=0.5, seed=2)
    info = rotation_information(sc.R, None, sc.f1, sc.f2)
    assert info is not None and np.all(np.linalg.eigvalsh(info) > 0)
    # a rotation fit is known about every axis; the sd about the optical axis is the largest
    sd = np.sqrt(np.diag(np.linalg.inv(info)))
    assert np.argmax(sd) == 2
    assert rotation_information(sc.R, sc.t if np.any(sc.t) else np.array([1.0, 0, 0]), sc.f1[:5], sc.f2[:5]) is None
    assert rotation_information(sc.R, None, sc.f1[:5], sc.f2[:5]) is None


def test_rotation_averaging_with_information_noise_free_exact():
    s = make_scene(20, 1500, seed=1)
    rng = np.random.default_rng(0)
    A = rng.normal(size=(len(s.pairs), 3, 3))
    info = A @ np.swapaxes(A, 1, 2) + 0.1 * np.eye(3)
    ra = average_rotations(20, s.pairs, s.R_rel, s.weights, information=info)
    assert np.radians(_aligned_mean(ra.rotations, s.rotations)) < EXACT
    assert ra.estimated.all() and not ra.outlier_edges


def test_rotation_averaging_information_checked():
    s = make_scene(10, 800, seed=4)
    with pytest.raises(InputError, match="information must be"):
        average_rotations(10, s.pairs, s.R_rel, s.weights, information=np.ones((2, 3, 3)))
    bad = np.tile(np.diag([1.0, 1.0, -1.0]), (len(s.pairs), 1, 1))
    with pytest.raises(InputError, match="positive definite"):
        average_rotations(10, s.pairs, s.R_rel, s.weights, information=bad)
    with pytest.raises(InputError, match="rotation_weights"):
        GlobalOptions(rotation_weights="bogus")


def test_information_weighting_beats_inlier_counts_on_narrow_cameras(monkeypatch):
    """Two-view ML edges of 12 cameras with a 20 deg half field of view (`python benchmarks/ra_information.py
    --views 12 --half-fov 20 --seeds 4`: 0.40x the inlier-weighted error): the information weighs the poorly constrained
    rotation axis of every edge down."""
    import ra_information

    import poseonly.sfm.synthetic as S

    monkeypatch.setattr(S, "HALF_FOV_DEG", 20.0)
    monkeypatch.setattr(S, "HOME_CONE_DEG", 12.0)
    e_inl, e_info = ra_information.run_seed(0, 12, 3000, 1.0)
    assert e_info < 0.7 * e_inl


@pytest.mark.parametrize("noise_px", [0.0, 1.0])
def test_run_global_with_information_weights(noise_px):
    """The pipeline with ``rotation_weights="information"``: exact on noise-free data, and on noisy
    wide-field data (where the two-view rotations are about isotropic) as accurate as the inlier counts."""
    import ra_information

    from poseonly.sfm.align import evaluate_poses
    from poseonly.sfm.pipeline import run_global

    s = make_scene(12, 1500, seed=5, noise_px=noise_px)
    g = ra_information.edge_graph(s)
    errs = {}
    for mode in ("inliers", "information"):
        res = run_global(g, lambda tr: s.bearings[tr.keypoints], s.focal, GlobalOptions(rotation_weights=mode))
        assert res.info["rotation_weights"] == mode
        errs[mode] = evaluate_poses(res.rotations, res.centres, s.rotations, s.centres)["rot_mean_deg_rotalign"]
    if noise_px == 0.0:
        assert np.radians(errs["information"]) < EXACT
    else:
        assert errs["information"] < 1.2 * errs["inliers"]


def test_rotation_information_of_the_reversed_edge_is_the_same_information_rotated():
    """Edge (j, i) = (R^T, -R^T t) with the views swapped: its right perturbation is d' = -R d, so its
    information is R I R^T."""
    sc = sim.make_scene(150, camera="pinhole", noise_px=0.5, seed=7)
    R, t, _ = _core.refine_sampson(np.ascontiguousarray(sc.R), np.ascontiguousarray(sc.t), sc.f1, sc.f2)
    info = rotation_information(R, t, sc.f1, sc.f2)
    back = rotation_information(R.T, -R.T @ t, sc.f2, sc.f1)
    np.testing.assert_allclose(back, R @ info @ R.T, rtol=1e-6, atol=1e-6 * np.abs(info).max())


def test_rotation_averaging_with_information_does_not_depend_on_edge_direction():
    """Half the edges reversed (views swapped, R^T, information R I R^T) give the same rotations: the
    information is applied in view i's frame (R_i^T I R_i). Measured at 0.5 px: 4e-6 deg apart (second
    order: the weights use the current rotations), against 4e-3 deg with the reversed edges' information
    left in the wrong frame."""
    import ra_information

    from poseonly.sfm.edge_information import edge_informations

    s = make_scene(12, 1500, seed=5, noise_px=0.5)
    g = ra_information.edge_graph(s)
    info, fallback = edge_informations(g, lambda tr: s.bearings[tr.keypoints])
    assert info is not None and not fallback.any()
    pairs, R_rel = g.pairs().copy(), g.rotations().copy()
    flip = np.arange(len(pairs)) % 2 == 1
    pairs[flip] = pairs[flip][:, ::-1]
    info2 = info.copy()
    info2[flip] = R_rel[flip] @ info[flip] @ np.swapaxes(R_rel[flip], 1, 2)
    R_rel[flip] = np.swapaxes(R_rel[flip], 1, 2)
    a = average_rotations(12, g.pairs(), g.rotations(), g.weights(), information=info)
    b = average_rotations(12, pairs, R_rel, g.weights(), information=info2)
    assert angle_deg(np.einsum("nji,njk->nik", a.rotations, b.rotations)).max() < 1e-4
    c = average_rotations(12, pairs, R_rel, g.weights(), information=info)
    assert angle_deg(np.einsum("nji,njk->nik", a.rotations, c.rotations)).max() > 1e-3


def test_edges_without_information_fall_back_to_their_inlier_counts():
    import ra_information

    from poseonly.sfm.edge_information import MIN_EDGE_MATCHES, edge_informations

    s = make_scene(10, 1200, seed=6, noise_px=0.5)
    g = ra_information.edge_graph(s)
    g.edges[0].matches = g.edges[0].matches[: MIN_EDGE_MATCHES - 1]
    info, fallback = edge_informations(g, lambda tr: s.bearings[tr.keypoints])
    assert fallback[0] and not fallback[1:].any()
    w = np.array([e.weight for e in g.edges])
    per_weight = np.median(np.trace(info[1:], axis1=1, axis2=2) / 3.0 / w[1:])
    np.testing.assert_allclose(info[0], w[0] * per_weight * np.eye(3))
    for e in g.edges:
        e.matches = e.matches[:3]
    assert edge_informations(g, lambda tr: s.bearings[tr.keypoints])[0] is None


def test_information_must_be_symmetric():
    s = make_scene(10, 800, seed=4)
    info = np.tile(np.eye(3), (len(s.pairs), 1, 1))
    info[0, 0, 1] = 0.5
    with pytest.raises(InputError, match="symmetric"):
        average_rotations(10, s.pairs, s.R_rel, s.weights, information=info)
