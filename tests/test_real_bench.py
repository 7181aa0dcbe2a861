"""The real-data benchmark (``poseonly bench real``): metrics, loaders, registry and a small run."""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np
import pytest

from poseonly.experiments import real_bench as rb
from poseonly.geometry import InputError

REALPAIRS = Path(os.environ.get("POSEONLY_REALPAIRS", Path(__file__).resolve().parents[2] / "shared/data/realpairs"))
if not REALPAIRS.is_dir():
    REALPAIRS = Path("/work/shared/data/realpairs")
TEMPLE = REALPAIRS / "middlebury_temple"


def test_pose_auc_is_superglues():
    # sorted errors 1, 2, 30, inf: recall 0.25, 0.5, 0.75, 1; the area up to 5 deg is
    # 0.5 * 0.25 + 0.5 * (0.25 + 0.5) + 3 * 0.5 = 2.0, i.e. 40 %
    a5, a10 = rb.pose_auc(np.array([30.0, np.inf, 2.0, 1.0]), (5.0, 10.0))
    assert a5 == pytest.approx(40.0)
    assert a10 == pytest.approx(100 * (0.125 + 0.375 + 8 * 0.5) / 10)
    assert rb.pose_auc(np.zeros(4), (5.0,))[0] == pytest.approx(100.0)
    assert rb.pose_auc(np.full(3, np.inf), (5.0,))[0] == 0.0


def _rec(ds: str, R: float | None, status: str | None, ref_R: float, t: float = 0.1) -> dict:
    run = {"R_err": R, "t_err": None if R is None else t, "status": status, "inliers": 50, "time_s": 0.01}
    ref = {"R_err": ref_R, "t_err": 0.1, "status": None, "inliers": 50, "time_s": 0.02}
    return {"dataset": ds, "id": "x", "matches": 100, "gt_matches": 60, "methods": {"poseonly": [run], rb.REFERENCE: [ref]}}


def test_status_honesty_counts_and_time_ratio():
    recs = [
        _rec("d", 0.1, "ok", 0.1),  # good, ok
        _rec("d", 10.0, "ok", 0.1),  # ok but 10 deg off: dishonest
        _rec("d", 0.5, "too_few_inliers", 0.2),  # good, both within 2 deg, not ok
        _rec("d", None, "degenerate", 30.0),  # no pose; PoseLib wrong too
    ]
    res = {"config": {"datasets": {"d": "realpairs"}, "seeds": 1}, "methods": ["poseonly", rb.REFERENCE], "pairs": recs}
    st = rb.summarize(res)["d"]["all"]
    s = st["poseonly"]
    assert (s["ok"], s["ok_wrong"], s["good_not_ok"], s["ref_good"], s["ref_good_not_ok"]) == (2, 1, 1, 3, 1)
    assert s["failed"] == 1 and s["median_time_ratio"] == pytest.approx(0.5)
    assert "ok" not in st[rb.REFERENCE]  # no status reported: no honesty counts
    assert s["auc"]["5"] < st[rb.REFERENCE]["auc"]["5"]


def test_registry_is_pluggable_and_checked():
    assert {"poseonly", "gnc-ransac", "poselib-1px", "poselib-2px", "opencv-magsac", "superansac"} <= set(rb.METHODS)
    with pytest.raises(InputError, match="unknown method"):
        rb.available_methods(["no-such-method"])
    rb.METHODS["poseonly@1px"] = rb.ours(threshold_px=1.0)
    try:
        from poseonly.sim import make_scene

        sc = make_scene(60, camera="pinhole", noise_px=0.3, seed=1)
        o = rb.METHODS["poseonly@1px"](sc.u1, sc.u2, sc.K, sc.K, np.ones(sc.n), 0)
        assert o.status == "ok" and o.inliers.shape == (sc.n,)
        assert rb._errors(rb.Pair("s", "0", Path("a"), Path("b"), sc.K, sc.K, sc.R, sc.t, "realpairs"), o)[0] < 0.5
    finally:
        del rb.METHODS["poseonly@1px"]


def test_loaders_reject_bad_folders(tmp_path):
    with pytest.raises(InputError, match="not found"):
        rb.load_datasets([tmp_path / "missing"])
    with pytest.raises(InputError, match="neither a realpairs folder"):
        rb.load_datasets([tmp_path])
    (tmp_path / "pairs.json").write_text(json.dumps({"dataset": "x", "pairs": [{"id": "a", "im1": "a.png"}]}))
    with pytest.raises(InputError, match="malformed"):
        rb.load_datasets([tmp_path])
    (tmp_path / "pairs.json").write_text("{not json")
    with pytest.raises(InputError, match="cannot read"):
        rb.load_datasets([tmp_path])


@pytest.mark.skipif(not (TEMPLE / "pairs.json").is_file(), reason="shared realpairs data not available")
def test_small_run_on_temple(tmp_path):
    pytest.importorskip("cv2")
    pytest.importorskip("poselib")
    out = tmp_path / "out"
    argv = [str(TEMPLE), "--max-pairs", "2", "--methods", "poseonly", "poselib-1px", "--out", str(out), "--cache", str(tmp_path / "cache")]
    assert rb.main(argv) == 0
    res = json.loads((out / "real_bench.json").read_text())
    assert [p["id"] for p in res["pairs"]] == [p["id"] for p in json.loads((TEMPLE / "pairs.json").read_text())["pairs"][:2]]
    st = res["summary"]["middlebury_temple"]["all"]
    assert st["poselib-1px"]["median_time_ratio"] == pytest.approx(1.0)  # the reference
    assert st["poseonly"]["median_time_ratio"] == pytest.approx(st["poseonly"]["median_time_ms"] / st["poselib-1px"]["median_time_ms"])
    assert 0.0 < st["poseonly"]["median_time_ratio"] < np.inf
    assert all(p["matches"] > 30 and p["methods"]["poseonly"][0]["R_err"] < 10 for p in res["pairs"])
    assert "middlebury_temple: all pairs, 2 pairs" in (out / "real_bench.md").read_text()
    # the matches are cached: a second run reads them (same matches, same errors for the seeded default)
    files = sorted((tmp_path / "cache" / "matches").iterdir())
    assert len(files) == 2
    again = rb.compute([TEMPLE], methods=["poseonly"], cache=tmp_path / "cache", max_pairs=2)
    assert [p["matches"] for p in again["pairs"]] == [p["matches"] for p in res["pairs"]]
    assert [p["methods"]["poseonly"][0]["R_err"] for p in again["pairs"]] == pytest.approx([p["methods"]["poseonly"][0]["R_err"] for p in res["pairs"]])


@pytest.mark.parametrize("name", ["superansac", "opencv-magsac", "poselib-1px"])
def test_anchor_adapters_return_poses_and_inlier_masks_in_input_order(name):
    lib = {"superansac": "pysuperansac", "opencv-magsac": "cv2", "poselib-1px": "poselib"}[name]
    pytest.importorskip(lib)
    from poseonly.sim import make_scene

    sc = make_scene(200, camera="pinhole", noise_px=0.3, outlier_fraction=0.3, seed=3)
    scores = np.where(sc.inliers, 0.5, 0.1) + 0.01 * np.arange(sc.n) / sc.n  # PROSAC order != input order
    for seed in range(3):
        o = rb.METHODS[name](sc.u1, sc.u2, sc.K, sc.K, scores, seed)
        assert o.R is not None and o.status is None
        er, _ = rb._errors(rb.Pair("s", "0", Path("a"), Path("b"), sc.K, sc.K, sc.R, sc.t, "realpairs"), o)
        assert er < 0.5
        assert np.count_nonzero(o.inliers & sc.inliers) >= 0.9 * np.count_nonzero(sc.inliers)
        assert np.count_nonzero(o.inliers & ~sc.inliers) <= 5
