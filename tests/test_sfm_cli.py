"""`poseonly sfm` end to end on a small subset of a shared Strecha scene, and the COLMAP model it
writes (read back by pycolmap). Skips when the data or pycolmap are absent."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest

from poseonly.cli import main

SCENE = Path("/work/shared/data/strecha/Herz-Jesus-P8")
N_IMAGES = 4


def _camera_errors(rec, sc):
    from poseonly.sfm import evaluate_poses

    R = np.zeros((N_IMAGES, 3, 3))
    C = np.zeros((N_IMAGES, 3))
    for img in rec.images.values():
        k = [p.name for p in sc.image_paths].index(img.name)
        T = img.cam_from_world().matrix()
        R[k], C[k] = T[:, :3], -T[:, :3].T @ T[:, 3]
    return evaluate_poses(R, C, np.array([c.R_cw.T for c in sc.cameras[:N_IMAGES]]), np.array([c.C for c in sc.cameras[:N_IMAGES]]))


def _reprojection_error(rec) -> float:
    """Mean reprojection error (px) of a model read back from disk (its stored errors are 0 until
    recomputed)."""
    rec.update_point_3d_errors()
    return float(rec.compute_mean_reprojection_error())


@pytest.fixture(scope="module")
def sfm_run(tmp_path_factory):
    if not (SCENE / "images" / "K.txt").is_file():
        pytest.skip("shared Strecha data not available")
    out = tmp_path_factory.mktemp("sfm")
    rc = main(["sfm", str(SCENE / "images"), "--K", str(SCENE / "images" / "K.txt"), "--out", str(out), "--max-images", str(N_IMAGES), "--max-features", "2000", "--no-progress"])
    return rc, out


def test_sfm_command_writes_outputs(sfm_run):
    rc, out = sfm_run
    assert rc == 0
    head = (out / "points.ply").read_bytes().split(b"end_header\n")[0].decode()
    n_vertex = int(head.split("element vertex ")[1].split()[0])
    assert n_vertex > 100 + N_IMAGES
    assert (out / "poses.json").is_file()
    import json

    poses = json.loads((out / "poses.json").read_text())
    pairs = poses["pairs"]  # every matched pair's outcome (a pipeline trial: the rejected pairs' statuses were nowhere)
    assert len(pairs) == N_IMAGES * (N_IMAGES - 1) // 2 and any(p["edge"] for p in pairs)
    for p in pairs:
        assert p["inliers"] <= p["matches"] and (("R" in p) == p["edge"]) and (p["edge"] or p["rejected"])
    assert (out / "reconstruction.png").stat().st_size > 1000
    mask = os.umask(0)
    os.umask(mask)
    assert (out / "points.ply").stat().st_mode & 0o777 == 0o666 & ~mask  # atomic writers keep the default mode
    assert (out / "sparse" / "0").stat().st_mode & 0o777 == 0o777 & ~mask


def test_sfm_colmap_model_reads_back_and_matches_ground_truth(sfm_run):
    pycolmap = pytest.importorskip("pycolmap")
    from poseonly.io.strecha import load_scene

    rc, out = sfm_run
    assert rc == 0
    rec = pycolmap.Reconstruction(str(out / "sparse" / "0"))
    assert rec.num_reg_images() == N_IMAGES
    assert rec.num_points3D() > 100
    stored = np.mean([p.error for p in rec.points3D.values()])
    assert 0 < stored < 2.0 and abs(stored - _reprojection_error(rec)) < 1e-6  # the stored errors are the points' errors
    # COLMAP's pixel convention (centres at +0.5): the K given in OpenCV's, the principal point shifted
    # (a user's trial: the --K model kept OpenCV's, 0.5 px off for COLMAP's tools that read the images)
    K = np.loadtxt(SCENE / "images" / "K.txt")
    (cam,) = rec.cameras.values()
    np.testing.assert_allclose(cam.params, [K[0, 0], K[1, 1], K[0, 2] + 0.5, K[1, 2] + 0.5])
    ev = _camera_errors(rec, load_scene(SCENE))
    assert ev["rot_mean_deg_rotalign"] < 0.1
    assert ev["pos_mean_frac"] < 0.01


def test_sfm_command_bad_input(tmp_path, capsys):
    assert main(["sfm", str(tmp_path / "nope"), "--K", "K.txt", "--out", str(tmp_path / "o")]) == 2
    assert "image folder not found" in capsys.readouterr().err
    # a bad --rotation-sigma is an argument error, before any image is read
    for bad in ("-1", "0", "nan", "x"):
        with pytest.raises(SystemExit) as e:
            main(["sfm", str(tmp_path / "nope"), "--K", "K.txt", "--rotation-sigma", bad])
        assert e.value.code == 2
        assert "--rotation-sigma" in capsys.readouterr().err
    # counts and seeds are checked by argparse too (--max-images -1 dropped the last image)
    for opt, bad in (("--max-images", "-1"), ("--max-images", "0"), ("--seed", "-3"), ("--max-features", "x"), ("--ligt-normalization", "gauge"), ("--ligt-reweight", "-1")):
        with pytest.raises(SystemExit) as e:
            main(["sfm", str(tmp_path / "nope"), "--K", "K.txt", "--out", str(tmp_path / "o"), opt, bad])
        assert e.value.code == 2
        assert opt in capsys.readouterr().err
    with pytest.raises(SystemExit):
        main(["experiment", "global", str(tmp_path), "--reweight", "-1"])
    assert "--reweight" in capsys.readouterr().err
    # too few images says how many the folder holds and how many were used
    img = tmp_path / "imgs"
    img.mkdir()
    for k in range(4):
        (img / f"{k}.png").write_bytes(b"")
    (tmp_path / "K.txt").write_text("800 0 320\n0 800 240\n0 0 1\n")
    assert main(["sfm", str(img), "--K", str(tmp_path / "K.txt"), "--out", str(tmp_path / "o"), "--max-images", "2"]) == 2
    assert "gives 2 images (--max-images 2 of 4)" in capsys.readouterr().err
    assert main(["sfm", str(img), "--K", str(tmp_path / "K.txt"), "--out", str(tmp_path / "o"), "--trust-guessed-focal"]) == 2
    assert "applies to --database" in capsys.readouterr().err
    # a skew the written PINHOLE model cannot hold is said (a user's trial: reprojections 0.87 px off, silently)
    (tmp_path / "Ks.txt").write_text("800 5 320\n0 800 240\n0 0 1\n")
    assert main(["sfm", str(img), "--K", str(tmp_path / "Ks.txt"), "--out", str(tmp_path / "o")]) == 2  # the empty images
    assert "skew of 5 px" in capsys.readouterr().out
    # the image folder as --out: its reconstruction.png would be an image of the next run (a user's trial)
    assert main(["sfm", str(img), "--K", str(tmp_path / "K.txt"), "--out", str(img / ".." / "imgs")]) == 2
    assert "is the image folder" in capsys.readouterr().err
    # the database's matches decide its pairs: --pairs / --sequential are refused there, not ignored
    assert main(["sfm", str(img), "--database", str(tmp_path / "x.db"), "--out", str(tmp_path / "o"), "--sequential", "1"]) == 2
    assert "with --database" in capsys.readouterr().err
    assert main(["sfm", str(img), "--database", str(tmp_path / "x.db"), "--out", str(tmp_path / "o"), "--resident-images", "8"]) == 2
    assert "with --database" in capsys.readouterr().err
    for opt in (["--max-images", "3"], ["--max-features", "2000"]):  # ignored silently before (a COLMAP user's trial)
        assert main(["sfm", str(img), "--database", str(tmp_path / "x.db"), "--out", str(tmp_path / "o"), *opt]) == 2
        assert "used as they are" in capsys.readouterr().err
    # a pair's two images must fit (before any image is read: these are empty files)
    assert main(["sfm", str(img), "--K", str(tmp_path / "K.txt"), "--out", str(tmp_path / "o"), "--resident-images", "1"]) == 2
    assert "resident_images must be an int >= 2" in capsys.readouterr().err


def test_sfm_command_from_colmap_database(tmp_path):
    """`poseonly sfm --database`: keypoints and matches read from a COLMAP database (written here
    from our own features of 4 images), the model read back by pycolmap."""
    pycolmap = pytest.importorskip("pycolmap")
    if not (SCENE / "images" / "K.txt").is_file():
        pytest.skip("shared Strecha data not available")
    from poseonly.io.strecha import load_scene
    from poseonly.sfm.colmap_anchor import write_database
    from poseonly.sfm.pairwise import PairwiseOptions, image_view_graph

    sc = load_scene(SCENE)
    paths = sc.image_paths[:N_IMAGES]
    ig = image_view_graph(paths, sc.K, options=PairwiseOptions(max_features=2000), cache_dir=tmp_path / "cache")
    db = tmp_path / "database.db"
    write_database(db, [p.name for p in paths], ig)
    out = tmp_path / "out"
    assert main(["sfm", str(SCENE / "images"), "--database", str(db), "--out", str(out), "--no-progress"]) == 0
    rec = pycolmap.Reconstruction(str(out / "sparse" / "0"))
    assert rec.num_reg_images() == N_IMAGES
    assert rec.num_points3D() > 100
    stored = np.mean([p.error for p in rec.points3D.values()])
    assert 0 < stored < 2.0 and abs(stored - _reprojection_error(rec)) < 1e-6  # the stored errors are the points' errors
    # COLMAP's pixel convention (centres at +0.5): the K given in OpenCV's, the principal point shifted
    # (a user's trial: the --K model kept OpenCV's, 0.5 px off for COLMAP's tools that read the images)
    K = np.loadtxt(SCENE / "images" / "K.txt")
    (cam,) = rec.cameras.values()
    np.testing.assert_allclose(cam.params, [K[0, 0], K[1, 1], K[0, 2] + 0.5, K[1, 2] + 0.5])
    # --camera-model replaces the database's cameras, as in colmap verify (a pipeline trial)
    out2 = tmp_path / "out2"
    given = [K[0, 0] * 1.001, K[1, 1] * 1.001, K[0, 2] + 0.5, K[1, 2] + 0.5]
    params = ",".join(repr(float(v)) for v in given)
    assert main(["sfm", str(SCENE / "images"), "--database", str(db), "--out", str(out2), "--no-progress", "--camera-model", "PINHOLE", "--camera-params", params]) == 0
    (cam2,) = pycolmap.Reconstruction(str(out2 / "sparse" / "0")).cameras.values()
    np.testing.assert_allclose(cam2.params, given)


DISTORTION = (-0.05, 0.01)  # OPENCV k1, k2 of the warped images: ~20 px at the corners


@pytest.fixture(scope="module")
def distorted_images(tmp_path_factory):
    """The first N_IMAGES images of SCENE at half size, warped so that they are what an OPENCV camera
    with DISTORTION sees (pixel u of the new image shows the undistorted image at K b(u), b the model's
    bearing of u); returns (folder, camera dict, scene)."""
    if not (SCENE / "images" / "K.txt").is_file():
        pytest.skip("shared Strecha data not available")
    import cv2

    from poseonly.io.strecha import load_scene
    from warped import warp_to_camera

    sc = load_scene(SCENE)
    K = sc.K.copy()
    K[:2, :2] *= 0.5
    K[:2, 2] = 0.5 * K[:2, 2] - 0.25  # cv2.resize by 1/2: pixel centres u -> (u + 0.5) / 2 - 0.5
    d = tmp_path_factory.mktemp("distorted")
    for p in sc.image_paths[:N_IMAGES]:
        img = cv2.resize(cv2.imread(str(p)), None, fx=0.5, fy=0.5, interpolation=cv2.INTER_AREA)
        h, w = img.shape[:2]
        # COLMAP's pixel convention: the principal point 0.5 px further than in K's (OpenCV's)
        cam = {"model": "OPENCV", "width": w, "height": h, "params": [K[0, 0], K[1, 1], K[0, 2] + 0.5, K[1, 2] + 0.5, *DISTORTION, 0.0, 0.0]}
        cv2.imwrite(str(d / p.name), warp_to_camera(img, K, cam))
    return d, cam, sc


def test_sfm_command_with_a_distorted_camera(distorted_images, tmp_path):
    """`--camera-model OPENCV --camera-params ...`: the keypoints are lifted through the model, and the
    COLMAP model written keeps it (with PINHOLE and the distorted keypoints its reprojection errors
    would be the distortion's, up to ~20 px); the poses match the ground truth as the undistorted
    images' do."""
    pycolmap = pytest.importorskip("pycolmap")
    d, cam, sc = distorted_images
    params = ",".join(repr(float(v)) for v in cam["params"])
    out = tmp_path / "out"
    assert main(["sfm", str(d), "--camera-model", "opencv", "--camera-params", params, "--out", str(out), "--max-features", "2000", "--no-progress"]) == 0
    rec = pycolmap.Reconstruction(str(out / "sparse" / "0"))
    assert rec.num_reg_images() == N_IMAGES and rec.num_points3D() > 100
    assert len(rec.cameras) == 1  # the images share their calibration, as in a COLMAP database
    for c in rec.cameras.values():
        assert c.model_name == "OPENCV" and (c.width, c.height) == (cam["width"], cam["height"])
        np.testing.assert_allclose(c.params, cam["params"])
    assert _reprojection_error(rec) < 2.0
    ev = _camera_errors(rec, sc)
    assert ev["rot_mean_deg_rotalign"] < 0.1 and ev["pos_mean_frac"] < 0.01, ev
    # the model written as PINHOLE (its distortion dropped) would reproject ~4 px off (measured 4.45)
    for cid, c in list(rec.cameras.items()):
        rec.cameras[cid] = pycolmap.Camera(model="PINHOLE", width=c.width, height=c.height, params=list(c.params[:4]), camera_id=cid)
    assert _reprojection_error(rec) > 2.0
    # the same images taken as pinhole (the distortion ignored) give poses ~15x further off (measured
    # rotations 0.228 against 0.016 deg after rotation alignment, centres 27 against 3.6 mm)
    out2 = tmp_path / "pinhole"
    Kp = tmp_path / "K.txt"
    f = cam["params"]
    Kp.write_text(f"{f[0]} 0 {f[2] - 0.5}\n0 {f[1]} {f[3] - 0.5}\n0 0 1\n")  # OpenCV's convention, as the keypoints
    assert main(["sfm", str(d), "--K", str(Kp), "--out", str(out2), "--max-features", "2000", "--no-progress"]) == 0
    ev2 = _camera_errors(pycolmap.Reconstruction(str(out2 / "sparse" / "0")), sc)
    assert ev2["rot_mean_deg_rotalign"] > 5 * ev["rot_mean_deg_rotalign"], (ev2, ev)
    # and the database path keeps the database's camera models in the model it writes
    from poseonly.sfm.colmap_anchor import write_database
    from poseonly.sfm.pairwise import PairwiseOptions, image_view_graph

    names = sorted(p.name for p in d.iterdir())
    ig = image_view_graph([d / nm for nm in names], camera=cam, options=PairwiseOptions(max_features=2000), cache_dir=out / "cache")
    assert ig.cameras is not None and ig.cameras[0]["model"] == "OPENCV"
    db = tmp_path / "database.db"
    write_database(db, names, ig)
    out3 = tmp_path / "db"
    assert main(["sfm", str(d), "--database", str(db), "--out", str(out3), "--no-progress"]) == 0
    rec3 = pycolmap.Reconstruction(str(out3 / "sparse" / "0"))
    assert {c.model_name for c in rec3.cameras.values()} == {"OPENCV"}
    assert _reprojection_error(rec3) < 2.0
    ev3 = _camera_errors(rec3, sc)
    assert ev3["rot_mean_deg_rotalign"] < 0.1, ev3


def test_sfm_camera_arguments_are_checked(tmp_path, capsys):
    img = tmp_path / "imgs"
    img.mkdir()
    for k in range(4):
        (img / f"{k}.png").write_bytes(b"")
    (tmp_path / "K.txt").write_text("800 0 320\n0 800 240\n0 0 1\n")
    base = ["sfm", str(img), "--out", str(tmp_path / "o"), "--no-progress"]
    cases = [
        (["--camera-model", "OPENCV"], "go together"),
        (["--camera-model", "OPENCV", "--camera-params", "800,800,320"], "takes 8 parameters"),
        (["--camera-model", "KANNALA", "--camera-params", "800,320,240"], "unsupported camera model"),
        (["--camera-model", "SIMPLE_RADIAL", "--camera-params", "800,320,x,0"], "numbers separated by commas or spaces"),
        (["--camera-model", "SIMPLE_RADIAL", "--camera-params", "800,,320,240"], "numbers separated by commas or spaces"),
        (["--camera-model", "SIMPLE_RADIAL", "--camera-params", "800 800,320,240,0"], "takes 4 parameters"),
        (["--camera-model", "SIMPLE_RADIAL", "--camera-params", "800,320,240,0", "--K", str(tmp_path / "K.txt")], "give one of --K"),
        ([], "give --K K.txt, --camera-model"),
    ]
    for extra, msg in cases:
        assert main([*base, *extra]) == 2
        assert msg in capsys.readouterr().err, extra


def test_pairwise_stage_on_threads_gives_the_same_graph(tmp_path):
    """``jobs`` threads extract, match and estimate concurrently; the graph is the one of one thread
    (seeds by pair index, results added in pair order)."""
    if not (SCENE / "images" / "K.txt").is_file():
        pytest.skip("shared Strecha data not available")
    from poseonly.sfm.pairwise import PairwiseOptions, image_view_graph

    images = sorted((SCENE / "images").glob("*.jpg"))[:3]
    K = np.loadtxt(SCENE / "images" / "K.txt")
    opt = PairwiseOptions(max_features=1500)
    one = image_view_graph(images, K, options=opt, jobs=1)
    two = image_view_graph(images, K, options=opt, jobs=2)
    assert one.pair_stats == two.pair_stats and len(one.graph) == len(two.graph) > 0
    for a, b in zip(one.graph.edges, two.graph.edges):
        assert (a.i, a.j) == (b.i, b.j) and np.array_equal(a.R, b.R) and np.array_equal(a.matches, b.matches)


def test_map_ordered_keeps_order_and_checks_jobs():
    import time

    from poseonly.geometry import InputError
    from poseonly.sfm.pairwise import map_ordered

    def slow_first(x):
        time.sleep(0.02 if x == 0 else 0.0)
        return x * x

    assert list(map_ordered(slow_first, range(10), jobs=3)) == [x * x for x in range(10)]
    assert list(map_ordered(slow_first, iter(range(5)), jobs=1)) == [0, 1, 4, 9, 16]
    for bad in (0, -2, 1.5, True):
        with pytest.raises(InputError, match="jobs"):
            list(map_ordered(slow_first, range(3), jobs=bad))
    # None is an item like any other
    items = [1, 2, 3, 4, None, 6, 7]
    assert list(map_ordered(lambda x: x, items, jobs=2)) == items == list(map_ordered(lambda x: x, items, jobs=1))


def test_map_ordered_raises_at_the_failing_item_and_cancels_the_queue():
    import threading

    from poseonly.sfm.pairwise import map_ordered

    ran = []
    lock = threading.Lock()

    def fn(x):
        with lock:
            ran.append(x)
        if x == 1:
            raise RuntimeError("item 1")
        return x

    gen = map_ordered(fn, range(1000), jobs=2)
    assert next(gen) == 0
    with pytest.raises(RuntimeError, match="item 1"):
        next(gen)
    assert len(ran) < 20  # the window (2 x jobs) and a few refills, not the 1000 items
    ran.clear()
    gen = map_ordered(fn, range(2, 1000), jobs=2)
    assert next(gen) == 2
    gen.close()  # the caller stops early: the queued items are cancelled
    assert len(ran) < 20


def test_command_line_start_does_not_load_the_pipeline():
    """Building the parsers (every `poseonly` command) imports no scipy and no pipeline module: the sfm
    hook and `experiment global` take their choices from poseonly.sfm.choices, and poseonly.sfm loads
    its stages on first use; the options' defaults are the first choices."""
    import json
    import subprocess
    import sys

    code = "import json, sys; from poseonly.cli import build_parser; build_parser(); print(json.dumps(sorted(m for m in sys.modules if m.startswith(('scipy', 'poseonly.sfm.')))))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert json.loads(out) == ["poseonly.sfm.choices", "poseonly.sfm.cli"]

    from poseonly.sfm import ligt_positions
    from poseonly.sfm.choices import LIGT_NORMALIZATIONS, ROTATION_WEIGHTS
    from poseonly.sfm.ligt_global import ligt_positions as direct
    from poseonly.sfm.pipeline import GlobalOptions

    assert ligt_positions is direct
    assert GlobalOptions().rotation_weights == ROTATION_WEIGHTS[0] and GlobalOptions().ligt_normalization == LIGT_NORMALIZATIONS[0]


def test_sfm_command_when_the_centres_are_undetermined(tmp_path, capsys, monkeypatch):
    """Valid images whose tracks fix no centre (LiGT's TranslationUndetermined, forced here): exit 0,
    poses.json with status "translation_undetermined", the rotations and the reason; no model, point
    cloud or figure."""
    import json

    import poseonly.sfm.pipeline as pipeline
    from poseonly.sfm.ligt_global import TranslationUndetermined

    if not (SCENE / "images" / "K.txt").is_file():
        pytest.skip("shared Strecha data not available")

    def undetermined(*a, **k):
        raise TranslationUndetermined("LiGT: no track constrains the translations (forced by the test)")

    monkeypatch.setattr(pipeline, "ligt_positions", undetermined)
    out = tmp_path / "o"
    rc = main(["sfm", str(SCENE / "images"), "--K", str(SCENE / "images" / "K.txt"), "--out", str(out), "--max-images", "3", "--max-features", "1000", "--no-progress"])
    assert rc == 0
    text = capsys.readouterr().out
    assert "camera centres are not determined" in text and "cameras: 3 rotations averaged, centres undetermined" in text
    poses = json.loads((out / "poses.json").read_text())
    assert poses["status"] == "translation_undetermined" and "forced by the test" in poses["reason"]
    assert all(im["R"] is not None and im["c"] is None for im in poses["images"])
    assert not (out / "points.ply").exists() and not (out / "sparse").exists() and not (out / "reconstruction.png").exists()


def test_pair_lists_sequential_and_from_a_file(tmp_path):
    """--sequential N and --pairs FILE (COLMAP / hloc pair lists: names, comments, duplicates and
    reversed pairs once each, pairs cut by --max-images left out); bad lists are InputErrors; the
    library's pairs are checked before any image is read, and a pair's seed does not depend on the
    other pairs matched."""
    import argparse

    from poseonly import InputError
    from poseonly.sfm.cli import _pair_list
    from poseonly.sfm.pairwise import image_view_graph, pair_seed

    d = tmp_path / "imgs"
    d.mkdir()
    for k in range(5):
        (d / f"{k}.jpg").write_bytes(b"")
    images = sorted(d.iterdir())

    def ns(**kw):
        return argparse.Namespace(**({"images": str(d), "pairs": None, "sequential": None} | kw))

    assert _pair_list(ns(), images) is None
    assert _pair_list(ns(sequential=2), images) == [(0, 1), (0, 2), (1, 2), (1, 3), (2, 3), (2, 4), (3, 4)]
    f = tmp_path / "pairs.txt"
    f.write_text("# a pair list\n0.jpg 1.jpg\n\n1.jpg 0.jpg  # reversed\n4.jpg 2.jpg\n0.jpg 1.jpg\n")
    assert _pair_list(ns(pairs=str(f)), images) == [(0, 1), (2, 4)]
    assert _pair_list(ns(pairs=str(f)), images[:3]) == [(0, 1)]  # 4.jpg cut by --max-images
    f.write_bytes("\ufeff0.jpg 2.jpg\r\n".encode())  # a byte-order mark and Windows line ends
    assert _pair_list(ns(pairs=str(f)), images) == [(0, 2)]
    (d / "notes.txt").write_text("")
    (d / "sub").mkdir()
    for text, msg in (
        ("0.jpg 1.jpg\n0.jpg 9.jpg\n", "line 2: '9.jpg' is not the name of an image"),
        ("0.jpg notes.txt\n", "not the name of an image"),  # not an image
        ("sub/0.jpg 1.jpg\n", "not the name of an image"),  # no directories: the folder's own images
        ("0.jpg 0.jpg\n", "itself"),
        ("0.jpg\n", "IMAGE_NAME1 IMAGE_NAME2"),
        ("# nothing\n", "no pair"),
    ):
        f.write_text(text)
        with pytest.raises(InputError, match=msg):
            _pair_list(ns(pairs=str(f)), images)
    with pytest.raises(InputError, match="not both"):
        _pair_list(ns(pairs=str(f), sequential=1), images)
    with pytest.raises(InputError, match="not found"):
        _pair_list(ns(pairs=str(tmp_path / "nope.txt")), images)
    K = np.array([[800.0, 0, 320], [0, 800, 240], [0, 0, 1]])
    for bad in ([(0, 0)], [(0, 7)], [(0.5, 1)], [], [("a", "b")]):
        with pytest.raises(InputError):
            image_view_graph(images, K, pairs=bad)  # before the (empty) images are read
    n = 6
    assert [pair_seed(3, i, j, n) for i in range(n) for j in range(i + 1, n)] == list(range(3, 3 + n * (n - 1) // 2))


def test_sfm_command_says_why_views_are_not_posed(tmp_path, capsys):
    """A pair list that leaves an image out: that view gets no rotation, and the command says so."""
    if not (SCENE / "images" / "K.txt").is_file():
        pytest.skip("shared Strecha data not available")
    pairs = tmp_path / "pairs.txt"
    pairs.write_text("0000.jpg 0001.jpg\n0001.jpg 0002.jpg\n0000.jpg 0002.jpg\n")
    out = tmp_path / "o"
    args = ["sfm", str(SCENE / "images"), "--K", str(SCENE / "images" / "K.txt"), "--out", str(out), "--max-images", "4"]
    assert main([*args, "--max-features", "1000", "--no-progress", "--pairs", str(pairs)]) == 0
    text = capsys.readouterr().out
    assert "model 0: cameras: 3/3 posed" in text and "in no model: 1 images" in text


def test_sfm_command_writes_one_model_per_scene(tmp_path, capsys):
    """Images of two scenes in one folder (quarter-size copies of three Herz-Jesus-P8 and three
    entry-P10 images): two models, sparse/0 and sparse/1, points.ply and points_1.ply, every image in
    the model of its scene in poses.json."""
    import json

    cv2 = pytest.importorskip("cv2")
    other = SCENE.parent / "entry-P10"
    if not (SCENE / "images" / "K.txt").is_file() or not (other / "images" / "K.txt").is_file():
        pytest.skip("shared Strecha data not available")
    K = np.loadtxt(SCENE / "images" / "K.txt")
    assert np.allclose(K, np.loadtxt(other / "images" / "K.txt"))  # one camera
    d = tmp_path / "imgs"
    d.mkdir()
    for tag, scene in (("a", SCENE), ("b", other)):
        for f in sorted((scene / "images").glob("*.jpg"))[:3]:
            im = cv2.imread(str(f))
            cv2.imwrite(str(d / f"{tag}_{f.name}"), cv2.resize(im, None, fx=0.25, fy=0.25, interpolation=cv2.INTER_AREA))
    K[:2] *= 0.25
    np.savetxt(tmp_path / "K.txt", K)
    out = tmp_path / "o"
    assert main(["sfm", str(d), "--K", str(tmp_path / "K.txt"), "--out", str(out), "--max-features", "1500", "--no-progress"]) == 0
    text = capsys.readouterr().out
    assert "models: 2 (3, 3 images)" in text
    poses = json.loads((out / "poses.json").read_text())
    assert [m["status"] for m in poses["models"]] == ["ok", "ok"] and poses["status"] == "ok"
    by_name = {im["name"]: im["model"] for im in poses["images"]}
    assert {by_name[n] for n in by_name if n.startswith("a_")} == {0} and {by_name[n] for n in by_name if n.startswith("b_")} == {1}
    assert all(im["c"] is not None for im in poses["images"])
    assert (out / "points.ply").is_file() and (out / "points_1.ply").is_file()
    try:
        import pycolmap
    except ImportError:
        return
    for k in (0, 1):
        assert pycolmap.Reconstruction(str(out / "sparse" / str(k))).num_reg_images() == 3
    written = json.loads((out / "poses.json").read_text())["models"][1]["outputs"]
    assert "points_1.ply" in written and "reconstruction_1.png" in written and any(f.startswith("sparse/1/") for f in written)
    # a rerun into the same folder with one scene: the other model's files, which no longer match
    # poses.json, are removed (a user's trial); files poseonly did not write stay, and so does a folder
    # holding one (a file of the user's in a model folder, which a run replaces whole, needs --overwrite)
    (out / "sparse" / "notes.txt").write_text("mine")
    (out / "sparse" / "1" / "mine.txt").write_text("mine")
    for f in d.glob("b_*"):
        f.unlink()
    assert main(["sfm", str(d), "--K", str(tmp_path / "K.txt"), "--out", str(out), "--max-features", "1500", "--no-progress"]) == 2
    assert "no poseonly run wrote there (sparse/1)" in capsys.readouterr().err
    assert main(["sfm", str(d), "--K", str(tmp_path / "K.txt"), "--out", str(out), "--max-features", "1500", "--no-progress", "--overwrite"]) == 0
    assert f"removed {len(written)} files of the previous run" in capsys.readouterr().out
    assert not (out / "points_1.ply").exists() and not (out / "reconstruction_1.png").exists()
    assert sorted(p.name for p in (out / "sparse" / "1").iterdir()) == ["mine.txt"]
    assert (out / "sparse" / "0").is_dir() and (out / "points.ply").is_file() and (out / "sparse" / "notes.txt").read_text() == "mine"
    assert len(json.loads((out / "poses.json").read_text())["models"]) == 1


def test_sfm_command_refuses_images_of_other_sizes_with_one_calibration(tmp_path, capsys):
    """A user's trial: one --K for images of different sizes gave a model 12-36 deg off, status ok."""
    cv2 = pytest.importorskip("cv2")
    if not (SCENE / "images" / "K.txt").is_file():
        pytest.skip("shared Strecha data not available")
    d = tmp_path / "imgs"
    d.mkdir()
    for k, f in enumerate(sorted((SCENE / "images").glob("*.jpg"))[:3]):
        im = cv2.imread(str(f))
        cv2.imwrite(str(d / f.name), cv2.resize(im, None, fx=0.25 if k < 2 else 0.2, fy=0.25 if k < 2 else 0.2, interpolation=cv2.INTER_AREA))
    K = np.loadtxt(SCENE / "images" / "K.txt")
    K[:2] *= 0.25
    np.savetxt(tmp_path / "K.txt", K)
    assert main(["sfm", str(d), "--K", str(tmp_path / "K.txt"), "--out", str(tmp_path / "o"), "--max-features", "1000", "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert "pixels but" in err and "one calibration for every image describes one image size" in err
    assert not (tmp_path / "o" / "poses.json").exists()


def test_sfm_database_with_keypoints_the_camera_cannot_undistort(distorted_images, tmp_path):
    """Keypoints beyond the region where a database camera's distortion is invertible lift to NaN in
    pycolmap (a SIMPLE_RADIAL camera with k < 0 beyond its turning radius); their matches are left out
    and the rest estimated, as ``colmap verify`` does (before, one such match ended the run with an
    input error)."""
    import dataclasses

    pycolmap = pytest.importorskip("pycolmap")
    from poseonly.sfm.colmap_anchor import write_database
    from poseonly.sfm.pairwise import PairwiseOptions, image_view_graph

    d, cam, sc = distorted_images
    names = sorted(p.name for p in d.iterdir())
    ig = image_view_graph([d / nm for nm in names], camera=cam, options=PairwiseOptions(max_features=2000), cache_dir=tmp_path / "cache")
    far = np.array([[-5000.0 - 10 * k, -4000.0 + 7 * k] for k in range(20)])
    feats = [dataclasses.replace(f, keypoints=np.vstack([f.keypoints, far]), sizes=None if f.sizes is None else np.r_[f.sizes, np.full(20, 3.0)]) for f in ig.features]
    putative = {}
    for (i, j), m in ig.putative.items():
        extra = np.column_stack([len(ig.features[i].keypoints) + np.arange(20), len(ig.features[j].keypoints) + np.arange(20)])
        putative[(i, j)] = np.vstack([m, extra])
    f, cx, cy = cam["params"][0], cam["params"][2], cam["params"][3]
    radial = [{"model": "SIMPLE_RADIAL", "width": cam["width"], "height": cam["height"], "params": [f, cx, cy, DISTORTION[0]]}] * len(names)
    assert np.isnan(pycolmap.Camera(**{k: radial[0][k] for k in ("model", "width", "height", "params")}).cam_from_img(far)).all()
    db = tmp_path / "database.db"
    write_database(db, names, dataclasses.replace(ig, features=feats, putative=putative, cameras=radial))
    out = tmp_path / "db"
    assert main(["sfm", str(d), "--database", str(db), "--out", str(out), "--no-progress"]) == 0
    rec = pycolmap.Reconstruction(str(out / "sparse" / "0"))
    assert rec.num_reg_images() == N_IMAGES and {c.model_name for c in rec.cameras.values()} == {"SIMPLE_RADIAL"}
    assert _camera_errors(rec, sc)["rot_mean_deg_rotalign"] < 0.1


def test_image_files_by_extension_any_case(tmp_path):
    """A user's trial: .tif images were skipped silently (only .jpg / .png were read)."""
    from poseonly.sfm.cli import is_image_file

    for n in ("a.JPG", "b.tif", "c.TIFF", "d.png", "e.webp", "K.txt", "f.jpeg.bak"):
        (tmp_path / n).write_bytes(b"x")
    (tmp_path / "g.jpg").mkdir()
    assert sorted(p.name for p in tmp_path.iterdir() if is_image_file(p)) == ["a.JPG", "b.tif", "c.TIFF", "d.png", "e.webp"]


def _small_scene_args(tmp_path: Path) -> list[str]:
    """``poseonly sfm`` arguments (without ``--out``) for four of Herz-Jesus-P8's images at a quarter of
    their size (skips without the data, OpenCV or pycolmap)."""
    cv2 = pytest.importorskip("cv2")
    pytest.importorskip("pycolmap")
    if not (SCENE / "images" / "K.txt").is_file():
        pytest.skip("shared Strecha data not available")
    d = tmp_path / "imgs"
    d.mkdir()
    for f in sorted((SCENE / "images").glob("*.jpg"))[:4]:
        cv2.imwrite(str(d / f.name), cv2.resize(cv2.imread(str(f)), None, fx=0.25, fy=0.25, interpolation=cv2.INTER_AREA))
    K = np.loadtxt(SCENE / "images" / "K.txt")
    K[:2] *= 0.25
    np.savetxt(tmp_path / "K.txt", K)
    return ["sfm", str(d), "--K", str(tmp_path / "K.txt"), "--max-features", "1500", "--no-progress"]


def test_outputs_no_poseonly_run_wrote_are_not_replaced_without_overwrite(tmp_path, capsys):
    """A user's trial: ``--out`` holding a COLMAP project (sparse/0, sparse/1) had its sparse/0 replaced and
    sparse/1 kept beside it, exit 0. Outputs that no earlier run listed in its poses.json are refused
    before any work, by name; ``--overwrite`` replaces them (other files kept); a rerun over the
    command's own outputs needs no flag."""
    args = _small_scene_args(tmp_path)
    out = tmp_path / "o"
    for foreign in ("sparse/0/cameras.bin", "sparse/1/images.bin", "points.ply", "poses.json"):
        (out / foreign).parent.mkdir(parents=True, exist_ok=True)
        (out / foreign).write_bytes(b"not ours")
    assert main([*args, "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "no poseonly run wrote there (poses.json, points.ply, sparse/0 and 1 more)" in err and "--overwrite" in err, err
    (out / "sparse" / "notes.txt").write_text("never touched: not a model folder")
    assert not (out / "cache").exists()  # refused before the features
    assert main([*args, "--out", str(out), "--overwrite"]) == 0
    assert (out / "sparse" / "1" / "images.bin").read_bytes() == b"not ours"  # kept
    assert (out / "sparse" / "notes.txt").read_text() == "never touched: not a model folder"
    assert (out / "points.ply").read_bytes() != b"not ours" and not (out / "sparse" / "0" / "cameras.bin").read_bytes() == b"not ours"
    capsys.readouterr()
    (out / "sparse" / "1" / "images.bin").unlink()
    (out / "sparse" / "1").rmdir()
    assert main([*args, "--out", str(out)]) == 0  # its own outputs only: no flag needed
    (out / "sparse" / "0" / "extra.txt").write_text("a file of the user's in our model folder")
    assert main([*args, "--out", str(out)]) == 2
    assert "(sparse/0)" in capsys.readouterr().err


def test_a_failed_write_leaves_the_previous_outputs_whole(tmp_path, monkeypatch, capsys):
    """Every output goes into a staging folder and moves into place once all are written: a write that
    fails (here the COLMAP model's, as on a full disk) leaves the previous run's poses.json, point cloud and
    model as they were, and no staging folder (a reliability trial: a new points.ply beside the old rest)."""
    out = tmp_path / "o"
    args = [*_small_scene_args(tmp_path), "--out", str(out)]
    assert main(args) == 0
    before = {p.relative_to(out).as_posix(): p.read_bytes() for p in out.rglob("*") if p.is_file() and "cache" not in p.parts}
    assert {"poses.json", "points.ply"} <= set(before)

    import poseonly.sfm.export as export

    def full(*a, **k):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(export, "write_colmap_model", full)
    assert main([*args, "--seed", "3"]) == 2
    assert "No space left on device" in capsys.readouterr().err
    after = {p.relative_to(out).as_posix(): p.read_bytes() for p in out.rglob("*") if p.is_file() and "cache" not in p.parts}
    assert after == before
    assert not [p.name for p in out.iterdir() if p.name.startswith(".staging.")]


def test_pose_records_give_no_translation_for_a_pure_rotation_edge():
    """poses.json's ``pairs``: an edge kept as ``pure_rotation`` has ``t: null`` (any direction fits it; a
    user's trial found one written), an ``ok`` edge its unit translation."""
    from types import SimpleNamespace

    from poseonly.sfm.cli import _pair_records
    from poseonly.sfm.viewgraph import Edge

    m = np.zeros((0, 2), int)
    edges = [Edge(0, 1, np.eye(3), np.array([1.0, 0, 0]), m, "ok"), Edge(1, 2, np.eye(3), np.array([0, 1.0, 0]), m, "pure_rotation")]
    ig = SimpleNamespace(graph=SimpleNamespace(edges=edges, rejected=[]), pair_stats=[(0, 1, 50, 40, "ok"), (1, 2, 60, 55, "pure_rotation")])
    recs = _pair_records(ig, [Path(f"{k}.jpg") for k in range(3)], set())
    assert recs[0]["t"] == [1.0, 0.0, 0.0] and recs[1]["edge"] and recs[1]["t"] is None and recs[1]["R"] == np.eye(3).tolist()


def test_outputs_of_an_older_version_and_other_names_are_not_foreign(tmp_path):
    """``--out`` checks (a review): a poses.json of a version that listed no ``outputs`` vouches for the
    names a run writes (points.ply, reconstruction_1.png, sparse/<k>'s model files), not for other files
    in a model folder; names a run never writes (points_clean.ply, sparse/notes.txt) are not checked; a
    poses.json of another tool is foreign."""
    import json

    from poseonly.sfm.cli import _foreign_outputs

    out = tmp_path / "o"
    for f in ("points.ply", "reconstruction_1.png", "points_clean.ply", "sparse/0/cameras.bin", "sparse/0/points3D.txt", "sparse/notes.txt", "cache/x.npz"):
        (out / f).parent.mkdir(parents=True, exist_ok=True)
        (out / f).write_bytes(b"x")
    (out / "poses.json").write_text(json.dumps({"convention": "X_cam = R (X_world - c)", "models": [{"model": 0}], "images": []}))
    assert _foreign_outputs(out) == []
    (out / "sparse" / "0" / "mine.txt").write_text("mine")
    assert _foreign_outputs(out) == [out / "sparse" / "0"]
    (out / "poses.json").write_text(json.dumps({"cameras": []}))
    assert _foreign_outputs(out) == [out / "poses.json", out / "points.ply", out / "reconstruction_1.png", out / "sparse" / "0"]
    assert _foreign_outputs(tmp_path / "none") == []
