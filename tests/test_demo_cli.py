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


def test_relpose_exit_codes_and_save(tmp_path):
    import numpy as np

    from poseonly.cli import exit_code, main
    from poseonly.sim import make_scene

    assert (exit_code("ok"), exit_code("too_few_inliers"), exit_code("pure_rotation"), exit_code("degenerate")) == (0, 1, 1, 2)
    sc = make_scene(200, noise_px=0.5, outlier_fraction=0.2, camera="pinhole", seed=1)
    np.savez(tmp_path / "m.npz", u1=sc.u1, u2=sc.u2, K=sc.K)
    assert main(["relpose", "--matches", str(tmp_path / "m.npz"), "--save", str(tmp_path / "out.npz")]) == 0
    z = np.load(tmp_path / "out.npz")
    assert str(z["status"]) == "ok" and z["inliers"].shape == (200,) and abs(np.linalg.norm(z["t"]) - 1) < 1e-9
    rng = np.random.default_rng(0)  # random matches: a result, but not one to trust
    np.savez(tmp_path / "r.npz", u1=rng.uniform(0, 640, (60, 2)), u2=rng.uniform(0, 480, (60, 2)), K=sc.K)
    assert main(["relpose", "--matches", str(tmp_path / "r.npz")]) in (1, 2)
    assert main(["relpose", "--matches", str(tmp_path / "m.npz"), "--save", str(tmp_path / "out.txt")]) == 2
