"""Strecha loader: file parsing, relative-pose convention, and agreement with SIFT matches."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest

from poseonly.geometry import InputError, rotation_from_rotvec
from poseonly.io.strecha import find_scenes, load_scene, read_camera_file, relative_pose

STRECHA = Path(os.environ.get("POSEONLY_STRECHA", Path(__file__).parents[1] / ".." / "shared" / "data" / "strecha"))

K_TXT = "2759.48 0 1520.69\n0 2764.16 1006.81\n0 0 1\n"


def _camera_text(K: np.ndarray, R_cw: np.ndarray, C: np.ndarray, w: int = 3072, h: int = 2048) -> str:
    rows = [" ".join(f"{v:.9g}" for v in r) for r in K]
    rows.append("0 0 0")
    rows += [" ".join(f"{v:.9g}" for v in r) for r in R_cw]
    rows.append(" ".join(f"{v:.9g}" for v in C))
    rows.append(f"{w} {h}")
    return "\n".join(rows) + "\n"


def _write_scene(root: Path, R_cw: list[np.ndarray], C: list[np.ndarray]) -> Path:
    K = np.array([[2759.48, 0, 1520.69], [0, 2764.16, 1006.81], [0, 0, 1]])
    (root / "images").mkdir(parents=True)
    (root / "gt_dense_cameras").mkdir()
    (root / "images" / "K.txt").write_text(K_TXT)
    for k, (R, c) in enumerate(zip(R_cw, C)):
        (root / "images" / f"{k:04d}.jpg").write_bytes(b"")  # loader does not decode images
        (root / "gt_dense_cameras" / f"{k:04d}.jpg.camera").write_text(_camera_text(K, R, c))
    return root


def test_relative_pose_convention_synthetic(tmp_path: Path) -> None:
    rng = np.random.default_rng(0)
    R_cw = [rotation_from_rotvec(rng.normal(size=3) * 0.4) for _ in range(3)]
    C = [rng.normal(size=3) * 2 for _ in range(3)]
    scene = load_scene(_write_scene(tmp_path / "synth", R_cw, C))
    assert scene.name == "synth" and len(scene) == 3
    assert [p.name for p in scene.image_paths] == ["0000.jpg", "0001.jpg", "0002.jpg"]
    X = rng.normal(size=(20, 3)) * 3  # world points
    for i, j in [(0, 1), (2, 0)]:
        R, t, b = relative_pose(scene, i, j)
        Xi = (X - C[i]) @ R_cw[i]  # R_cw^T (X - C), row-wise
        Xj = (X - C[j]) @ R_cw[j]
        np.testing.assert_allclose(Xi @ R.T + b * t, Xj, atol=1e-6)
        assert abs(np.linalg.norm(t) - 1) < 1e-12
        np.testing.assert_allclose(R @ R.T, np.eye(3), atol=1e-12)


def test_find_scenes(tmp_path: Path) -> None:
    eye = [np.eye(3)] * 2
    C = [np.zeros(3), np.ones(3)]
    _write_scene(tmp_path / "b_scene", eye, C)
    _write_scene(tmp_path / "nested" / "a_scene", eye, C)
    (tmp_path / "not_a_scene" / "images").mkdir(parents=True)
    found = find_scenes(tmp_path)
    assert found == sorted(found)
    assert sorted(p.name for p in found) == ["a_scene", "b_scene"]
    assert find_scenes(tmp_path / "b_scene") == [tmp_path / "b_scene"]
    with pytest.raises(ValueError, match="not found"):
        find_scenes(tmp_path / "missing")


@pytest.mark.parametrize(
    "text, match",
    [
        ("1 0 0\n0 1 0\n0 0 1\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n0 0 0\n", "26 numbers"),
        ("1 0 0\n0 1 0\n0 0 1\n0 0 0\n1 0 0\n0 1 0\n0 0 one\n0 0 0\n3072 2048\n", "non-numeric"),
        ("1 0 0\n0 1 0\n0 0 1\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n0 0 0\n3072 2048 7\n", "26 numbers"),
        ("1 0 0\n0 1 0\n0 0 1\n0 0 0\n2 0 0\n0 1 0\n0 0 1\n0 0 0\n3072 2048\n", "not a rotation"),
        ("1 0 0\n0 1 0\n0 0 1\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n0 0 0\n3072.5 2048\n", "positive integers"),
        ("", "26 numbers"),
    ],
)
def test_malformed_camera_file(tmp_path: Path, text: str, match: str) -> None:
    f = tmp_path / "0000.jpg.camera"
    f.write_text(text)
    with pytest.raises(ValueError, match=match) as ei:
        read_camera_file(f)
    assert isinstance(ei.value, InputError)
    assert "0000.jpg.camera" in str(ei.value)


def test_malformed_scene(tmp_path: Path) -> None:
    root = _write_scene(tmp_path / "s", [np.eye(3)] * 2, [np.zeros(3), np.ones(3)])
    (root / "gt_dense_cameras" / "0001.jpg.camera").write_text("1 2 3\n")
    with pytest.raises(ValueError, match="0001.jpg.camera"):
        load_scene(root)
    (root / "gt_dense_cameras" / "0001.jpg.camera").unlink()
    with pytest.raises(ValueError, match="missing.*0001.jpg"):
        load_scene(root)
    (root / "images" / "K.txt").unlink()
    with pytest.raises(ValueError, match="K.txt"):
        load_scene(root)
    with pytest.raises(ValueError, match="not a Strecha scene"):
        load_scene(tmp_path)
    with pytest.raises(ValueError, match="not found"):
        load_scene(tmp_path / "nope")


def test_relative_pose_bad_indices(tmp_path: Path) -> None:
    scene = load_scene(_write_scene(tmp_path / "s", [np.eye(3)] * 2, [np.zeros(3), np.ones(3)]))
    with pytest.raises(ValueError, match="out of range"):
        relative_pose(scene, 0, 5)
    with pytest.raises(ValueError, match="different views"):
        relative_pose(scene, 1, 1)


# --------------------------------------------------------------------------------------------
# real data (skipped when the shared Strecha folder is absent)


def _real_scene() -> Path:
    if not STRECHA.is_dir():
        pytest.skip(f"Strecha data not found at {STRECHA} (set POSEONLY_STRECHA)")
    scenes = {p.name: p for p in find_scenes(STRECHA)}
    if not scenes:
        pytest.skip(f"no Strecha scene under {STRECHA}")
    return scenes.get("fountain-P11", next(iter(scenes.values())))


def test_real_scene_loads() -> None:
    scene = load_scene(_real_scene())
    assert len(scene) == len(scene.cameras) >= 2
    for cam in scene.cameras:
        np.testing.assert_allclose(cam.R_cw @ cam.R_cw.T, np.eye(3), atol=1e-12)
        assert np.linalg.det(cam.R_cw) > 0
        np.testing.assert_allclose(cam.K, scene.K, rtol=1e-6)
        assert cam.width > 0 and cam.height > 0


def test_gt_pose_agrees_with_sift_matches(tmp_path: Path) -> None:
    pytest.importorskip("cv2")
    from poseonly.features import match_images, sampson_error_px

    scene = load_scene(_real_scene())
    i, j = len(scene) // 2 - 1, len(scene) // 2  # two neighbouring views
    R, t, _ = relative_pose(scene, i, j)
    m = match_images(scene.image_paths[i], scene.image_paths[j], ratio=0.8)
    assert len(m) > 200
    e = sampson_error_px(m.u1, m.u2, scene.cameras[i].K, scene.cameras[j].K, R, t)
    best = np.sort(e)[: len(e) // 2]
    assert np.median(best) < 1.0, np.median(best)
    assert np.mean(e < 2.0) > 0.5
    # the wrong reading (R world->camera) is far off, so the test really checks the convention
    R_bad = scene.cameras[j].R_cw @ scene.cameras[i].R_cw.T
    e_bad = sampson_error_px(m.u1, m.u2, scene.K, scene.K, R_bad, t)
    assert np.median(e_bad) > 5.0
