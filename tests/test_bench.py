"""Smoke tests of the benchmarks (no timing assertions): they run end to end and write their files."""

import json

from poseonly.cli import main


def test_bench_robust_quick(tmp_path):
    assert main(["bench", "robust", "--quick", "--out", str(tmp_path)]) == 0
    res = json.loads((tmp_path / "robust.json").read_text())
    assert (tmp_path / "robust.md").exists() and (tmp_path / "robust.png").exists()
    methods = set(res["methods"])
    assert "poseonly (default)" in methods and "noise floor (ML on true inliers)" in methods
    ours = [r for r in res["rows"] if r["method"] == "poseonly (default)" and r["outliers"] == 0.5]
    assert all(r["median"] < 2.0 for r in ours)


def test_bench_speed_quick(tmp_path):
    assert main(["bench", "speed", "--quick", "--no-fresh", "--out", str(tmp_path)]) == 0
    assert (tmp_path / "speed.md").exists() and (tmp_path / "speed.json").exists()
