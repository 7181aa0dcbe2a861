"""`poseonly experiment global` end to end on four views of a shared Strecha scene, with every anchor
that is installed (pycolmap's global stages and mappers, pyTheia's rotation averaging + LiGT). Skips
when the shared data are absent."""

from __future__ import annotations

import json
import os
from pathlib import Path

import pytest

pytest.importorskip("cv2")

from poseonly.cli import main  # noqa: E402

STRECHA = Path(os.environ.get("POSEONLY_STRECHA", Path(__file__).parents[1] / ".." / "shared" / "data" / "strecha"))
SCENE = STRECHA / "Herz-Jesus-P8"
VIEWS = ("0000", "0001", "0002", "0003")


def test_global_experiment_on_four_views(tmp_path: Path, capsys) -> None:
    if not (SCENE / "images" / "K.txt").is_file():
        pytest.skip("shared Strecha data not available")
    scene = tmp_path / "data" / "P8-4"
    (scene / "images").mkdir(parents=True)
    (scene / "gt_dense_cameras").mkdir()
    for v in VIEWS:
        (scene / "images" / f"{v}.jpg").symlink_to((SCENE / "images" / f"{v}.jpg").resolve())
        (scene / "gt_dense_cameras" / f"{v}.jpg.camera").symlink_to((SCENE / "gt_dense_cameras" / f"{v}.jpg.camera").resolve())
    (scene / "images" / "K.txt").write_text((SCENE / "images" / "K.txt").read_text())
    out = tmp_path / "out"
    rc = main(["experiment", "global", str(scene.parent), "--cache", str(tmp_path / "cache"), "--max-features", "2000", "--out", str(out)])
    assert rc == 0
    res = json.loads((out / "global_sfm.json").read_text())
    (r,) = res["results"]
    assert r["scene"] == "P8-4" and r["views"] == 4 and r["edges"] == 6
    ours = r["ours"]
    assert ours["num_estimated"] == 4 and ours["rot_mean_deg_rotalign"] < 0.2 and ours["pos_mean_frac"] < 0.01
    md = (out / "global_sfm.md").read_text()
    assert "poseonly (RA + LiGT, no BA)" in md
    assert res["command"].startswith("poseonly experiment global ") and f"Command: `{res['command']}`" in md  # as every experiment's
    anchors = {"pycolmap": "rotation averaging + global positioning", "pytheia": "robust rotation averaging + LiGT"}
    for lib, row in anchors.items():
        try:
            __import__(lib)
        except ImportError:
            continue
        a = r[lib]
        assert "error" not in a, a.get("error")
        assert a[row]["num_estimated"] == 4 and a[row]["rot_mean_deg_rotalign"] < 0.2, lib
        assert f"{lib} {row}" in md
    capsys.readouterr()


def test_global_experiment_reports_a_scene_it_cannot_pose(tmp_path: Path, capsys) -> None:
    """A scene of three copies of one image (no translation anywhere) is a row saying why, and the
    run goes on to the next scene instead of ending with an error."""
    if not (SCENE / "images" / "K.txt").is_file():
        pytest.skip("shared Strecha data not available")
    root = tmp_path / "data"
    for name, views in (("A-same", ("0000", "0000", "0000")), ("B-P8-3", VIEWS[:3])):
        scene = root / name
        (scene / "images").mkdir(parents=True)
        (scene / "gt_dense_cameras").mkdir()
        for k, v in enumerate(views):
            (scene / "images" / f"{k:04d}.jpg").symlink_to((SCENE / "images" / f"{v}.jpg").resolve())
            (scene / "gt_dense_cameras" / f"{k:04d}.jpg.camera").symlink_to((SCENE / "gt_dense_cameras" / f"{VIEWS[k]}.jpg.camera").resolve())
        (scene / "images" / "K.txt").write_text((SCENE / "images" / "K.txt").read_text())
    out = tmp_path / "out"
    # with the anchors: pycolmap's mappers cannot pose the copies either, which must not end the run
    rc = main(["experiment", "global", str(root), "--cache", str(tmp_path / "cache"), "--max-features", "2000", "--out", str(out)])
    assert rc == 0
    res = json.loads((out / "global_sfm.json").read_text())
    bad, good = res["results"]
    assert bad["scene"] == "A-same" and set(bad["ours"]) == {"error"}
    assert good["scene"] == "B-P8-3" and good["ours"]["num_estimated"] == 3
    md = (out / "global_sfm.md").read_text()
    assert f"A-same | poseonly (RA + LiGT, no BA): {bad['ours']['error']} | 0/3" in md
    capsys.readouterr()
