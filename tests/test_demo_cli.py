"""The README's main command: ``poseonly demo`` on the embedded real pair."""

import json

import numpy as np

from poseonly.cli import main


def test_demo_runs_and_is_accurate(tmp_path, capsys):
    draw = tmp_path / "matches.png"
    assert main(["demo", "--draw", str(draw), "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["rotation_error_deg"] < 0.5
    assert d["status"] == "ok"
    assert d["inlier_ratio"] > 0.5
    assert draw.exists() and draw.stat().st_size > 10_000
    R = np.array(d["R"])
    assert np.allclose(R @ R.T, np.eye(3), atol=1e-9)


def test_demo_text_output(capsys):
    assert main(["demo", "--no-draw"]) == 0
    out = capsys.readouterr().out
    assert "rotation error" in out and "ground truth" in out


def test_unknown_method_is_a_clean_error(capsys):
    assert main(["demo", "--no-draw", "--method", "nope"]) == 2
    assert "unknown method" in capsys.readouterr().err
