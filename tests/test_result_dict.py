"""RelativePoseResult / PairResult records: to_dict(exact=True) and from_dict round trip through strict
JSON to an equal result (a typed integrator's trial: results could be written but not read back, and
inf / NaN both became null)."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

import poseonly
from poseonly.batch import Pair, PairResult
from poseonly.result import RESULT_SCHEMA_VERSION, STATUSES, NoPoseError, RelativePoseResult
from poseonly.sim import make_scene

FOCAL = 800.0


def _roundtrip(r: RelativePoseResult) -> RelativePoseResult:
    return RelativePoseResult.from_dict(json.loads(json.dumps(r.to_dict(exact=True), allow_nan=False)))


def _results() -> list[RelativePoseResult]:
    out = []
    for kind in ("normal", "planar", "rotation"):
        sc = make_scene(150, kind=kind, camera="pinhole", noise_px=0.5, outlier_fraction=0.3, seed=3)
        out.append(poseonly.estimate_relative_pose(sc.f1, sc.f2, focal_px=FOCAL))
    sc = make_scene(150, camera="pinhole", noise_px=0.5, outlier_fraction=0.3, seed=4)
    out.append(poseonly.estimate_relative_pose(sc.f1, sc.f2, focal_px=FOCAL, method="gnc-ransac"))
    out.append(poseonly.estimate_relative_pose(sc.f1[:12], sc.f2[:12], focal_px=FOCAL))  # few matches
    f = np.tile([0.0, 0.0, 1.0], (20, 1))
    out.append(poseonly.estimate_relative_pose(f, f, focal_px=FOCAL))  # degenerate: no pose
    rng = np.random.default_rng(0)
    a, b = rng.normal(size=(60, 3)), rng.normal(size=(60, 3))
    out.append(poseonly.estimate_relative_pose(a / np.linalg.norm(a, axis=1)[:, None], b / np.linalg.norm(b, axis=1)[:, None], focal_px=FOCAL))
    return out


RESULTS = _results()


def test_the_scenes_cover_several_statuses():
    assert len({r.status for r in RESULTS}) >= 4 and "degenerate" in {r.status for r in RESULTS}


@pytest.mark.parametrize("k", range(len(RESULTS)))
def test_exact_records_read_back_equal(k):
    r = RESULTS[k]
    back = _roundtrip(r)
    assert back == r, r.status
    assert back.to_dict(exact=True) == r.to_dict(exact=True)


def test_inf_and_nan_stay_apart():
    for r in RESULTS:
        back = _roundtrip(r)
        for key in ("rotation_std_deg", "translation_std_deg"):
            a, b = getattr(r, key), getattr(back, key)
            assert (math.isnan(a) and math.isnan(b)) or a == b, (r.status, key, a, b)
    assert any(math.isinf(r.rotation_std_deg) for r in RESULTS)


def test_default_records_read_back_with_nan_for_null():
    """A default record writes non-finite numbers as null: they read back as NaN, and the result's
    properties and repr work (a review: repr raised on float(None))."""
    for r in RESULTS:
        back = RelativePoseResult.from_dict(json.loads(json.dumps(r.to_dict(), allow_nan=False)))
        assert repr(back) and isinstance(back.rotation_std_deg, float) and back.status == r.status


def test_the_default_record_reads_back_with_the_inlier_mask_as_weights():
    r = RESULTS[0]
    d = json.loads(json.dumps(r.to_dict(), allow_nan=False))
    assert d["schema_version"] == RESULT_SCHEMA_VERSION and "weights" not in d
    back = RelativePoseResult.from_dict(d)
    assert np.array_equal(back.inliers, r.inliers) and np.array_equal(back.weights, r.inliers.astype(float))
    assert np.all(np.isnan(back.residuals_px)) and np.array_equal(back.R, r.R) and back.status == r.status


@pytest.mark.parametrize(
    "change, word",
    [
        ({"schema_version": 2}, "schema_version"),
        ({"status": "okay"}, "status"),
        ({"inliers": [10**6]}, "inliers"),
        ({"R": [[1.0, 0.0], [0.0, 1.0]]}, "'R'"),
        ({"num_inliers": -1}, "num_inliers"),
        ({"threshold_px": "wide"}, "threshold_px"),
        ({"threshold_px": 10**400}, "threshold_px"),
        ({"twin_inliers": None}, "twin_inliers"),
        ({"num_points": 10**29}, "num_points"),
        ({"num_inliers": 3}, "num_inliers"),
        ({"R": None}, "degenerate"),
        ({"message": 5}, "message"),
        ({"schema_version": True}, "schema_version"),
        ({"diagnostics": {"x": {"a": 1}}}, "diagnostics"),
        ({"diagnostics": {"x": 10**400}}, "diagnostics"),
    ],
)
def test_malformed_records_are_refused_naming_the_key(change, word):
    d = {**RESULTS[0].to_dict(exact=True), **change}
    assert RESULTS[0].status != "degenerate"
    with pytest.raises(poseonly.InputError, match=word):
        RelativePoseResult.from_dict(d)
    d = RESULTS[0].to_dict()
    del d["status"]
    with pytest.raises(poseonly.InputError, match="status"):
        RelativePoseResult.from_dict(d)


def test_pose_raises_only_without_a_pose():
    for r in RESULTS:
        if r.status == "degenerate":
            with pytest.raises(NoPoseError, match="degenerate"):
                r.pose()
            assert isinstance(NoPoseError("x"), ValueError)
        else:
            R, t = r.pose()
            assert R.shape == (3, 3) and t.shape == (3,)


def test_the_repr_is_one_line_with_the_status_first():
    text = repr(RESULTS[0])
    assert text.startswith(f"RelativePoseResult(status={RESULTS[0].status!r}") and "\n" not in text and len(text) < 600


def test_statuses_are_exported():
    assert poseonly.STATUSES == STATUSES and all(r.status in STATUSES for r in RESULTS)


def test_pair_results_read_back():
    sc = make_scene(120, camera="pinhole", noise_px=0.5, seed=5)
    pairs = [Pair(sc.f1, sc.f2, key=("a", 3)), Pair(sc.f1[:3], sc.f2[:3], key=7)]
    res = list(poseonly.estimate_relative_poses(pairs, focal_px=FOCAL))
    assert res[1].error is not None
    for p in res:
        back = PairResult.from_dict(json.loads(json.dumps(p.to_dict(exact=True), allow_nan=False)))
        assert back == p


def test_options_built_as_a_dataclass_pass_as_keywords():
    """The typed way to build options: the dataclass's fields (checked by a type checker), its
    non-default ones passed as keywords and checked by the call."""
    from poseonly.options import GncRansacOptions, PoseonlyOptions

    sc = make_scene(120, camera="pinhole", noise_px=0.5, outlier_fraction=0.2, seed=6)
    opts = PoseonlyOptions(threshold_px=2.0, seed=3)
    assert opts.as_kwargs() == {"threshold_px": 2.0, "seed": 3} and PoseonlyOptions().as_kwargs() == {}
    a = poseonly.estimate_relative_pose(sc.f1, sc.f2, focal_px=FOCAL, **opts.as_kwargs())
    assert a == poseonly.estimate_relative_pose(sc.f1, sc.f2, focal_px=FOCAL, threshold_px=2.0, seed=3)
    g = GncRansacOptions(max_iterations=20).as_kwargs()
    assert poseonly.estimate_relative_pose(sc.f1, sc.f2, focal_px=FOCAL, method="gnc-ransac", **g).num_iterations <= 20
    with pytest.raises(poseonly.InputError, match="threshold_px"):
        poseonly.estimate_relative_pose(sc.f1, sc.f2, focal_px=FOCAL, **PoseonlyOptions(threshold_px=-1.0).as_kwargs())


def test_gnc_irls_results_compare_by_value():
    sc = make_scene(60, camera="pinhole", noise_px=0.5, seed=7)
    assert poseonly.gnc_irls(sc.f1, sc.f2) == poseonly.gnc_irls(sc.f1, sc.f2)


def test_ransac_result_compares_by_value():
    """A concurrency trial: ``poseonly.gnc_ransac``'s result raised on ``==`` (a plain dataclass of arrays)."""
    import poseonly
    from poseonly.sim import make_scene

    sc = make_scene(80, seed=2)
    a = poseonly.gnc_ransac(sc.f1, sc.f2, theta=2 / 800, seed=3)
    assert a == poseonly.gnc_ransac(sc.f1, sc.f2, theta=2 / 800, seed=3)
    b = poseonly.gnc_ransac(sc.f1, sc.f2, theta=2 / 800, seed=3)
    b.R = b.R.copy()
    b.R[0, 0] += 1e-9
    assert a != b
