"""COLMAP database verification (issue 13 item 3): rows written with the right content, the
status -> configuration mapping, resume after SIGKILL with the same rows as an uninterrupted run."""

import os
import shutil
import signal
import sqlite3
import subprocess
import sys
import time
from collections import Counter
from contextlib import closing
from pathlib import Path

import numpy as np
import pytest

import poseonly

pycolmap = pytest.importorskip("pycolmap")

from poseonly import rotation_error_deg
from poseonly.cameras import Camera
from poseonly.colmap_verify import verify_database
from poseonly.io.colmap_geometry import homography_dlt

# the folder the poseonly of this process comes from (the source tree of an editable install, or
# site-packages of a wheel): a child process imports the same one
SRC = str(Path(poseonly.__file__).resolve().parents[1])
CAM = Camera("OPENCV", 640, 480, (600.0, 600.0, 320.0, 240.0, -0.15, 0.02, 0.001, 0.0))


def _look_at(C, target=(0.0, 0.0, 8.0)):
    target = np.asarray(target)
    z = (target - C) / np.linalg.norm(target - C)
    x = np.cross([0.0, -1.0, 0.0], z)
    x /= np.linalg.norm(x)
    return np.stack([x, np.cross(z, x), z])  # rows: camera axes -> R_cw


def make_db(path, n_images=6, n_points=150, seed=0, calibrated=True):
    """Images around a point cloud; image 1 is image 0 rotated in place (a pure-rotation pair)."""
    rng = np.random.default_rng(seed)
    X = rng.uniform([-3, -2, 6], [3, 2, 10], (n_points, 3))
    poses = []
    for k in range(n_images):
        C = np.array([0.6 * (k - n_images / 2), 0.1 * k, 0.0])
        if k == 1:
            C = poses[0][1]
            R = pycolmap.Rotation3d(np.array([0.0, 0.05, 0.02])).matrix() @ poses[0][0]
        else:
            R = _look_at(C)
        poses.append((R, C))
    db = pycolmap.Database.open(str(path))
    cam = pycolmap.Camera(model=CAM.model, width=640, height=480, params=list(CAM.params))
    cam.has_prior_focal_length = calibrated  # False: COLMAP's guess, as on import without calibration or EXIF
    cid = db.write_camera(cam)
    perms, ids = [], []
    for k, (R, C) in enumerate(poses):
        iid = db.write_image(pycolmap.Image(name=f"im{k}.jpg", camera_id=cid))
        ids.append(iid)
        perm = rng.permutation(n_points)  # keypoint j of the image is point perm[j]
        u = CAM.project((X[perm] - C) @ R.T) + rng.normal(0, 0.5, (n_points, 2))
        db.write_keypoints(iid, u.astype(np.float32))
        perms.append(perm)
    for a in range(n_images):
        for b in range(a + 1, n_images):
            inv_b = np.argsort(perms[b])
            m = np.column_stack([np.arange(n_points), inv_b[perms[a]]])
            bad = rng.choice(n_points, n_points // 5, replace=False)  # 20 % wrong matches
            m[bad, 1] = rng.integers(0, n_points, len(bad))
            db.write_matches(ids[a], ids[b], m.astype(np.uint32))
    db.close()
    return poses, ids


def _rows(path):
    with closing(sqlite3.connect(path)) as con:  # closed before pycolmap opens the file (two SQLite copies)
        return con.execute("SELECT pair_id, rows, cols, data, config, F, E, H, qvec, tvec FROM two_view_geometries ORDER BY pair_id").fetchall()


def _check_consistent(path):
    with closing(sqlite3.connect(path)) as con:
        assert con.execute("PRAGMA integrity_check").fetchone()[0] == "ok"
    for pid, rows, cols, data, config, F, E, H, q, t in _rows(path):
        assert (rows == 0 or cols == 2) and len(data or b"") == rows * cols * 4, pid
        if config == int(pycolmap.TwoViewGeometryConfiguration.CALIBRATED):
            assert rows >= 15 and len(E) == 72 and len(q) == 32 and len(t) == 24
    db = pycolmap.Database.open(str(path))
    db.read_two_view_geometries()  # pycolmap reads every row
    db.close()


def test_verify_rows_and_mapping(tmp_path):
    path = tmp_path / "db.db"
    poses, ids = make_db(path)
    s = verify_database(path, progress=False)
    assert s.selected == s.written == 15 and s.skipped == 0 and not s.errors
    assert s.configs["CALIBRATED"] >= 13 and s.configs["PANORAMIC"] == 1, s.configs
    _check_consistent(path)
    db = pycolmap.Database.open(str(path))
    g = db.read_two_view_geometry(ids[0], ids[1])
    assert g.config == pycolmap.TwoViewGeometryConfiguration.PANORAMIC
    assert np.allclose(g.cam2_from_cam1.translation, 0.0) and g.H is not None
    R_true = poses[1][0] @ poses[0][0].T
    assert rotation_error_deg(R_true, g.cam2_from_cam1.rotation.matrix()) < 0.2
    g = db.read_two_view_geometry(ids[2], ids[4])
    assert g.config == pycolmap.TwoViewGeometryConfiguration.CALIBRATED
    (R2, C2), (R4, C4) = poses[2], poses[4]
    R_true = R4 @ R2.T
    assert rotation_error_deg(R_true, g.cam2_from_cam1.rotation.matrix()) < 0.2
    t_true = -R4 @ C4 + R_true @ R2 @ C2
    assert np.degrees(np.arccos(g.cam2_from_cam1.translation @ t_true / np.linalg.norm(t_true))) < 2.0
    inl = g.inlier_matches
    m = db.read_matches(ids[2], ids[4])
    assert len(inl) >= 0.7 * len(m) and set(map(tuple, inl)) <= set(map(tuple, m))
    db.close()
    # a rerun keeps everything; --overwrite rewrites the same rows
    before = _rows(path)
    assert verify_database(path, progress=False).written == 0
    assert verify_database(path, progress=False, overwrite=True).written == 15
    assert _rows(path) == before
    assert verify_database(path, progress=False, overwrite=True, n_jobs=2, backend="processes", write_every=4).written == 15
    assert _rows(path) == before  # the same rows from 2 processes and other transaction sizes
    assert verify_database(path, progress=False, overwrite=True, n_jobs=2, backend="threads", write_every=3).written == 15
    assert _rows(path) == before  # and from 2 threads


def test_pairs_file_and_errors(tmp_path):
    path = tmp_path / "db.db"
    make_db(path, n_images=3)
    pf = tmp_path / "pairs.txt"
    pf.write_text("# comment\nim0.jpg im2.jpg\n")
    s = verify_database(path, pairs_file=pf, progress=False)
    assert s.selected == s.written == 1
    pf.write_text("im0.jpg nope.jpg\n")
    with pytest.raises(ValueError, match=r"pairs.txt line 1: .nope.jpg. is not an image of the database"):
        verify_database(path, pairs_file=pf, progress=False)
    with pytest.raises(ValueError, match="not found"):
        verify_database(tmp_path / "missing.db", progress=False)
    (tmp_path / "junk.db").write_text("not sqlite")
    with pytest.raises(ValueError, match="not an SQLite database|not a COLMAP database"):
        verify_database(tmp_path / "junk.db", progress=False)


def test_parse_pair_names():
    """The one pair-list parser (colmap verify --pairs, sfm --pairs): comments, blank lines, a byte-order
    mark, Windows line ends; three names or a self pair are errors naming the line."""
    from poseonly.io.pair_list import parse_pair_names

    text = "\ufeff# pairs\r\na.jpg b.jpg\r\n\n  c.jpg a.jpg # why\r\na.jpg b.jpg\n"
    assert parse_pair_names(text.splitlines(), "p") == [("a.jpg", "b.jpg"), ("c.jpg", "a.jpg"), ("a.jpg", "b.jpg")]
    with pytest.raises(ValueError, match="p line 2: expected"):
        parse_pair_names(["a b", "a b c"], "p")
    with pytest.raises(ValueError, match="p line 1: an image paired with itself"):
        parse_pair_names(["a a"], "p")


def test_homography_dlt():
    rng = np.random.default_rng(0)
    H = np.array([[1.1, 0.02, 5.0], [-0.03, 0.95, -3.0], [1e-4, -2e-4, 1.0]])
    u1 = rng.uniform(0, 640, (20, 2))
    h = np.column_stack([u1, np.ones(20)]) @ H.T
    assert np.allclose(homography_dlt(u1, h[:, :2] / h[:, 2:]), H, atol=1e-8)
    assert homography_dlt(u1[:3], u1[:3]) is None


def _run_until_rows(cmd, env, path, rows):
    """Start ``cmd`` and return the process once ``path`` holds ``rows`` two-view rows (or it ended)."""
    proc = subprocess.Popen(cmd, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    n = 0
    deadline = time.time() + 120
    while time.time() < deadline and proc.poll() is None:
        try:
            with closing(sqlite3.connect(f"file:{path}?mode=ro", uri=True, timeout=0.01)) as con:
                n = con.execute("SELECT COUNT(*) FROM two_view_geometries").fetchone()[0]
        except sqlite3.OperationalError:  # locked by the writer
            continue
        if n >= rows:
            break
        time.sleep(0.005)
    return proc


@pytest.mark.parametrize("sig", [signal.SIGKILL, signal.SIGTERM])
def test_kill_and_resume(tmp_path, sig):
    """Killed (SIGKILL) or terminated (SIGTERM: a clean exit 143, no native stack dump from the
    failure handler pycolmap's import installs) mid-run, the database is consistent and a rerun
    completes it with the rows of an uninterrupted run."""
    path = tmp_path / "db.db"
    make_db(path, n_images=8, n_points=120)
    ref = tmp_path / "ref.db"
    shutil.copy(path, ref)
    verify_database(ref, progress=False, seed=3)
    total = len(_rows(ref))
    assert total == 28
    env = {**os.environ, "PYTHONPATH": SRC}
    cmd = [sys.executable, "-c", "import sys; from poseonly.cli import main; sys.exit(main())", "colmap", "verify", str(path), "--seed", "3", "--write-every", "2", "--no-progress"]
    proc = _run_until_rows(cmd, env, path, 4)
    proc.send_signal(sig)
    proc.wait()
    err = proc.stderr.read().decode()
    if sig == signal.SIGKILL:
        assert proc.returncode == -signal.SIGKILL, err
    else:
        assert proc.returncode == 128 + signal.SIGTERM, err
        assert "poseonly: terminated" in err and "stack trace" not in err, err
    written = len(_rows(path))
    assert 4 <= written < total, written  # stopped mid-run
    _check_consistent(path)
    rr = subprocess.run(cmd, check=False, env=env, capture_output=True, text=True, timeout=300)
    assert rr.returncode == 0, rr.stderr
    assert f"{written} already verified" in rr.stdout
    _check_consistent(path)
    assert _rows(path) == _rows(ref)


def test_cli_errors(tmp_path, capsys):
    from poseonly.cli import main

    assert main(["colmap", "verify", str(tmp_path / "missing.db"), "--no-progress"]) == 2
    assert "COLMAP database not found" in capsys.readouterr().err
    path = tmp_path / "db.db"
    make_db(path, n_images=2)
    assert main(["colmap", "verify", str(path), "--no-progress"]) == 0
    assert main(["colmap", "verify", str(path), "--no-progress"]) == 0
    out = capsys.readouterr().out
    assert "1 already verified" in out and "--overwrite" in out


def test_sample_cap(tmp_path, monkeypatch, capsys):
    """The default method runs at MANY_PAIRS_MAX_ITERATIONS (COLMAP's two-view cap) unless the caller
    sets max_iterations; other methods keep their own; the CLI's --max-iterations reaches the estimator."""
    import poseonly.colmap_verify as cv
    from poseonly.cli import main
    from poseonly.options import MANY_PAIRS_MAX_ITERATIONS

    seen = []
    real = cv.estimate_relative_poses

    def spy(pairs, **kw):
        seen.append({k: kw.get(k) for k in ("method", "max_iterations")})
        return real(pairs, **kw)

    monkeypatch.setattr(cv, "estimate_relative_poses", spy)
    path = tmp_path / "db.db"
    make_db(path, n_images=2)
    assert MANY_PAIRS_MAX_ITERATIONS == 10000
    verify_database(path, progress=False)
    verify_database(path, progress=False, overwrite=True, max_iterations=300)
    verify_database(path, progress=False, overwrite=True, method="lirp")
    assert main(["colmap", "verify", str(path), "--no-progress", "--overwrite", "--max-iterations", "2000"]) == 0
    assert seen == [
        {"method": None, "max_iterations": MANY_PAIRS_MAX_ITERATIONS},
        {"method": None, "max_iterations": 300},
        {"method": "lirp", "max_iterations": None},
        {"method": "poseonly", "max_iterations": 2000},
    ]
    capsys.readouterr()
    assert main(["colmap", "verify", str(path), "--no-progress", "--overwrite", "--method", "lirp", "--max-iterations", "5"]) == 2
    assert "max_iterations" in capsys.readouterr().err


def test_camera_override(tmp_path, capsys):
    """``camera=`` (``--camera-model / --camera-params``) replaces every image's database camera: the
    database's own camera given this way writes the same rows; a camera without the distortion
    (the database's model guessed wrong) other rows, with larger errors; bad arguments are errors."""
    from poseonly.cli import main

    path = tmp_path / "db.db"
    poses, ids = make_db(path, n_images=3)
    verify_database(path, progress=False)
    base = _rows(path)
    assert verify_database(path, progress=False, overwrite=True, camera=CAM).written == 3
    assert _rows(path) == base
    params = ",".join(repr(v) for v in CAM.params)
    assert main(["colmap", "verify", str(path), "--no-progress", "--overwrite", "--camera-model", "opencv", "--camera-params", params]) == 0
    assert _rows(path) == base
    pinhole = ",".join(repr(v) for v in CAM.params[:4])
    assert main(["colmap", "verify", str(path), "--no-progress", "--overwrite", "--camera-model", "PINHOLE", "--camera-params", pinhole]) == 0
    assert _rows(path) != base
    db = pycolmap.Database.open(str(path))
    g = db.read_two_view_geometry(ids[0], ids[2])
    db.close()
    R_true = poses[2][0] @ poses[0][0].T
    assert rotation_error_deg(R_true, g.cam2_from_cam1.rotation.matrix()) > 0.2  # the distortion ignored
    capsys.readouterr()
    assert main(["colmap", "verify", str(path), "--no-progress", "--camera-model", "OPENCV"]) == 2
    assert "go together" in capsys.readouterr().err
    assert main(["colmap", "verify", str(path), "--no-progress", "--camera-model", "OPENCV", "--camera-params", "1,2"]) == 2
    assert "takes 8 parameters" in capsys.readouterr().err


def test_guessed_focal_is_refused_unless_trusted(tmp_path, capsys):
    """A database camera whose focal length COLMAP guessed (no prior focal length) would give
    calibrated poses from a guess: refused before any row is written, naming the camera and the two
    ways out; a calibration (camera=) or trust_guessed_focal=True runs as before."""
    from poseonly import InputError
    from poseonly.cli import main

    path = tmp_path / "db.db"
    make_db(path, n_images=4, calibrated=False)
    with pytest.raises(InputError, match=r"guessed the focal length of 1 camera.*camera 1 \(OPENCV, 640x480, f = 600.0 px\).*--trust-guessed-focal"):
        verify_database(path, progress=False)
    assert _rows(path) == []
    assert main(["colmap", "verify", str(path), "--no-progress"]) == 2
    assert "--camera-model / --camera-params" in capsys.readouterr().err
    assert _rows(path) == []
    assert verify_database(path, progress=False, trust_guessed_focal=True).written == 6
    ref = _rows(path)
    # --overwrite is refused before any row is deleted
    assert main(["colmap", "verify", str(path), "--no-progress", "--overwrite"]) == 2
    assert _rows(path) == ref
    assert main(["colmap", "verify", str(path), "--no-progress", "--overwrite", "--camera-model", "OPENCV", "--camera-params", ",".join(map(repr, CAM.params))]) == 0
    assert _rows(path) == ref  # the given calibration is the database's guess here
    from poseonly.sfm.colmap_db import database_view_graph

    with pytest.raises(InputError, match="ImageReader.camera_params"):
        database_view_graph(path)
    ig, names = database_view_graph(path, trust_guessed_focal=True)
    assert len(names) == 4 and len(ig.graph) > 0


def test_a_result_as_a_pycolmap_two_view_geometry():
    """poseonly.io.colmap_geometry.to_two_view_geometry: the geometry colmap verify writes, in memory,
    with COLMAP's conventions (cam2_from_cam1 = (R, t), F = K2^-T E K1^-1 up to scale)."""
    from poseonly import estimate_relative_pose
    from poseonly.geometry import InputError
    from poseonly.io.colmap_geometry import to_two_view_geometry
    from poseonly.sim import make_scene

    sc = make_scene(150, camera="pinhole", noise_px=0.5, outlier_fraction=0.2, seed=2)
    r = estimate_relative_pose(sc.u1, sc.u2, sc.K, sc.K)
    assert r.status == "ok"
    matches = np.column_stack([np.arange(150) + 1000, np.arange(150)[::-1]])
    g = to_two_view_geometry(r, matches, K1=sc.K, K2=sc.K)
    assert g.config == pycolmap.TwoViewGeometryConfiguration.CALIBRATED
    np.testing.assert_array_equal(np.asarray(g.inlier_matches), matches[r.inliers])
    np.testing.assert_allclose(g.cam2_from_cam1.rotation.matrix(), r.R, atol=1e-12)
    np.testing.assert_allclose(g.cam2_from_cam1.translation, r.t, atol=1e-12)
    F = np.linalg.inv(sc.K).T @ r.E @ np.linalg.inv(sc.K)
    np.testing.assert_allclose(np.asarray(g.F), F / np.linalg.norm(F), atol=1e-12)
    from poseonly.features import sampson_distance

    assert np.median(sampson_distance(sc.u1[r.inliers], sc.u2[r.inliers], np.asarray(g.F))) < 0.5  # pixels, 0.5 px noise
    g0 = to_two_view_geometry(r)  # match i is keypoint i in both images; no K: no F
    np.testing.assert_array_equal(np.asarray(g0.inlier_matches)[:, 0], np.flatnonzero(r.inliers))
    rng = np.random.default_rng(0)
    bad = estimate_relative_pose(rng.uniform(0, 640, (30, 2)), rng.uniform(0, 640, (30, 2)), sc.K, sc.K)
    gb = to_two_view_geometry(bad)
    assert gb.config == pycolmap.TwoViewGeometryConfiguration.DEGENERATE and len(np.asarray(gb.inlier_matches)) == 0
    with pytest.raises(InputError, match="matches must be"):
        to_two_view_geometry(r, matches[:-1])
    with pytest.raises(InputError, match=r"\[0, 2\*\*32\)"):  # COLMAP's uint32 would wrap 2**32 to 0
        to_two_view_geometry(r, matches + 2**32)


def test_database_references_and_bad_keypoints_are_named_not_tracebacks(tmp_path):
    """A reliability trial: an image whose camera row is missing, matches of an image id the images table
    lacks (KeyError tracebacks before) and one NaN keypoint no match uses (it stopped the whole run)."""
    from poseonly.sfm.colmap_db import database_view_graph

    path = tmp_path / "db.db"
    make_db(path, n_images=3, n_points=60)
    with closing(sqlite3.connect(path)) as con:
        con.execute("UPDATE images SET camera_id = 99 WHERE image_id = 3")
        con.commit()
    with pytest.raises(ValueError, match="refers to camera 99, which is not in the database"):
        verify_database(path, progress=False)
    with pytest.raises(ValueError, match="refers to camera 99, which is not in the database"):
        database_view_graph(path)
    path = tmp_path / "db2.db"
    _, ids = make_db(path, n_images=3, n_points=60)
    db = pycolmap.Database.open(str(path))
    kp = np.asarray(db.read_keypoints(ids[2]), dtype=np.float32)
    db.close()
    with closing(sqlite3.connect(path)) as con:  # a keypoint row no match uses, stored as NaN
        blob = np.vstack([kp, np.full((1, kp.shape[1]), np.nan, np.float32)]).astype(np.float32)
        con.execute("UPDATE keypoints SET rows = ?, data = ? WHERE image_id = ?", (len(blob), blob.tobytes(), ids[2]))
        con.commit()
    db = pycolmap.Database.open(str(path))
    db.write_matches(ids[0], 50, np.array([[k, k] for k in range(30)], np.uint32))  # image 50 does not exist
    db.close()
    s = verify_database(path, progress=False)
    missing = int(pycolmap.image_pair_to_pair_id(ids[0], 50))
    assert s.written == 4 and s.configs["UNDEFINED"] == 1 and list(s.errors) == [missing]  # the NaN keypoint is no error
    assert "image id 50 has matches but is not in the database's images table" in s.errors[missing]
    _check_consistent(path)


def test_a_batch_the_disk_cannot_hold_is_an_oserror_not_an_abort(tmp_path, monkeypatch):
    """pycolmap commits in a C++ destructor: a full disk aborted the process (SIGABRT; a reliability
    trial). The writer checks the file system's free space before each batch: ENOSPC with the numbers,
    nothing written."""
    import errno
    from types import SimpleNamespace

    import poseonly.io.colmap_db as cdb

    path = tmp_path / "db.db"
    make_db(path, n_images=3, n_points=60)
    monkeypatch.setattr(cdb.os, "statvfs", lambda p: SimpleNamespace(f_bavail=100, f_frsize=4096))
    with pytest.raises(OSError, match="bytes free on its file system") as e:
        verify_database(path, progress=False)
    assert e.value.errno == errno.ENOSPC
    assert _rows(path) == []


def test_an_interrupted_overwrite_leaves_every_pair_a_row(tmp_path, monkeypatch):
    """``overwrite`` replaces rows batch by batch: a run stopped after its first batch leaves the other
    pairs their old rows (it deleted every selected row first, so a kill lost them; a reliability trial)."""
    from poseonly.io.colmap_db import ColmapDatabase

    path = tmp_path / "db.db"
    make_db(path, n_images=4, n_points=60)
    verify_database(path, progress=False, threshold_px=3.0)
    old = {r[0]: r for r in _rows(path)}
    assert len(old) == 6
    calls = []
    write = ColmapDatabase.write_geometries

    def stop_after_first(self, rows):
        if calls:
            raise KeyboardInterrupt
        calls.append(1)
        return write(self, rows)

    monkeypatch.setattr(ColmapDatabase, "write_geometries", stop_after_first)
    with pytest.raises(KeyboardInterrupt):
        verify_database(path, progress=False, overwrite=True, write_every=2)
    new = {r[0]: r for r in _rows(path)}
    assert sorted(new) == sorted(old)  # every pair has a row
    assert 1 <= sum(new[k] != old[k] for k in new) <= 2  # only the first batch (two rows) is the new run's (1 px, not 3)
    _check_consistent(path)


@pytest.fixture
def python_sigint():
    """Python's KeyboardInterrupt handler for SIGINT during the test: a run started in the background of
    a shell without job control inherits SIGINT ignored, and the held signal was then dropped as the
    handler in place said (the test failed so, in a session's background run)."""
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)


@pytest.mark.skipif(sys.platform == "win32", reason="POSIX signals")
def test_ctrl_c_inside_a_write_batch_waits_for_its_commit(tmp_path, monkeypatch, python_sigint):
    """pycolmap's DatabaseTransaction commits when its block ends, an exception included: a Ctrl-C inside
    a batch committed half of it and, between a row's delete and its insert, left a pair with no row (a
    COLMAP user's trial). The signal is now held until the batch has committed: every row of the batch
    is the new run's, every other pair keeps its old row, and the KeyboardInterrupt comes after."""
    path = tmp_path / "db.db"
    make_db(path, n_images=4, n_points=60)
    verify_database(path, progress=False, threshold_px=3.0)
    old = {r[0]: r for r in _rows(path)}
    real = pycolmap.Database.update_two_view_geometry
    seen = []

    def update(db, *a):  # Ctrl-C arrives during the second row of the first batch
        seen.append(pycolmap.image_pair_to_pair_id(a[0], a[1]))
        if len(seen) == 2:
            os.kill(os.getpid(), signal.SIGINT)
            time.sleep(0.05)  # Python would run its handler here
        return real(db, *a)

    monkeypatch.setattr(pycolmap.Database, "update_two_view_geometry", update)
    with pytest.raises(KeyboardInterrupt):
        verify_database(path, progress=False, overwrite=True, write_every=3)
    new = {r[0]: r for r in _rows(path)}
    assert sorted(new) == sorted(old)  # every pair has a row
    assert len(seen) == 3  # the whole first batch was written (the interrupt came after its commit)
    assert all(new[k] == old[k] for k in new if k not in seen)  # nothing after it
    assert sum(new[k] != old[k] for k in seen) >= 1  # (1 px now, 3 px before: some rows differ)
    _check_consistent(path)


def test_sfm_reads_a_database_without_changing_it_while_another_connection_writes(tmp_path):
    """pycolmap opens a database read-write: ``sfm --database`` stopped on a database another process was
    writing and changed the file's header although no table changed (a COLMAP user's trial). It reads a
    copy now (``reading_snapshot``): the file keeps its bytes and time, the copy is removed, and the
    descriptors' rows are not copied."""
    from poseonly.io.colmap_db import reading_snapshot
    from poseonly.sfm.colmap_db import database_view_graph

    path = tmp_path / "db.db"
    make_db(path, n_images=4, n_points=60)
    with closing(sqlite3.connect(path)) as con:
        cols = [r[1] for r in con.execute("PRAGMA table_info(descriptors)")]  # (the schema differs between COLMAP versions)
        values = ", ".join({"image_id": "image_id", "data": "zeroblob(128)"}.get(c, "1") for c in cols)
        con.execute(f"INSERT INTO descriptors ({', '.join(cols)}) SELECT {values} FROM images LIMIT 1")
        con.commit()
    before = (path.read_bytes(), path.stat().st_mtime_ns)
    cache = tmp_path / "cache"
    with closing(sqlite3.connect(path, timeout=0.0)) as other:
        other.execute("BEGIN IMMEDIATE")  # another process's write transaction, held while we read
        ig, names = database_view_graph(path, cache_dir=cache)
        other.rollback()
    assert len(names) == 4 and len(ig.graph) > 0
    assert (path.read_bytes(), path.stat().st_mtime_ns) == before
    assert list(cache.glob(".db.db.*")) == []  # the copy and its journals are gone
    with reading_snapshot(path, tmp_path) as snap, closing(sqlite3.connect(snap)) as c:
        assert c.execute("SELECT COUNT(*) FROM descriptors").fetchone()[0] == 0
        assert c.execute("SELECT COUNT(*) FROM matches").fetchone()[0] == 6
        assert {r[0] for r in c.execute("SELECT name FROM sqlite_master WHERE type = 'index'")} >= {
            r[0] for r in sqlite3.connect(path).execute("SELECT name FROM sqlite_master WHERE type = 'index' AND sql IS NOT NULL")
        }
    assert not snap.exists()


def test_a_pair_id_colmap_does_not_write_is_refused(tmp_path):
    """A pair stored under (larger, smaller) image ids: pycolmap reads and writes it as its canonical twin
    (a reliability trial: its row overwrote the twin's, or its matches were never read)."""
    from poseonly.sfm.colmap_db import database_view_graph

    path = tmp_path / "db.db"
    make_db(path, n_images=3, n_points=40)
    with closing(sqlite3.connect(path)) as con:
        con.execute("UPDATE matches SET pair_id = ? WHERE pair_id = ?", (2 * 2147483647 + 1, 2147483647 + 2))
        con.commit()
    for run in (lambda: verify_database(path, progress=False), lambda: database_view_graph(path)):
        with pytest.raises(ValueError, match="image ids 2 > 1"):
            run()
    assert _rows(path) == []


def test_malformed_blobs_are_per_pair_errors_and_bad_camera_rows_name_the_database(tmp_path):
    """pycolmap's check failures on a malformed blob ended the whole run with a message naming nothing (a
    reliability trial): a pair whose matches blob is short is UNDEFINED with the images named; a camera
    row pycolmap cannot read is an error naming the database."""
    path = tmp_path / "db.db"
    make_db(path, n_images=3, n_points=40)
    with closing(sqlite3.connect(path)) as con:
        pid, data = con.execute("SELECT pair_id, data FROM matches ORDER BY pair_id LIMIT 1").fetchone()
        con.execute("UPDATE matches SET data = ? WHERE pair_id = ?", (data[: len(data) // 2], pid))
        con.commit()
    from poseonly.cli import main

    assert main(["colmap", "verify", str(path), "--no-progress"]) == 1  # finished, with an UNDEFINED row (it exited 0)
    assert main(["colmap", "verify", str(path), "--no-progress"]) == 0  # a rerun keeps every row: nothing invalid read
    s = verify_database(path, progress=False, overwrite=True)
    assert s.written == 3 and list(s.errors) == [pid]
    assert "pycolmap cannot read the keypoints or matches of images 'im0.jpg', 'im1.jpg'" in s.errors[pid]
    with closing(sqlite3.connect(path)) as con:
        con.execute("UPDATE cameras SET model = 77")
        con.commit()
    with pytest.raises(ValueError, match="db.db: pycolmap cannot read its images or cameras"):
        verify_database(path, progress=False, overwrite=True)


def test_the_report_has_a_line_per_written_pair_with_its_status(tmp_path, capsys):
    """A user's trial: ``CALIBRATED`` holds ``ok`` and ``uncertain`` poses and the summary only counts
    rows, so bad rows could not be audited. ``report=`` / ``--report`` writes poseonly's status of every
    pair of the run (invalid input included), published when the run ends; the summary counts statuses."""
    import csv

    from poseonly.cli import main
    from poseonly.colmap_verify import REPORT_COLUMNS

    path = tmp_path / "db.db"
    _, ids = make_db(path, n_images=4, n_points=80)
    db = pycolmap.Database.open(str(path))
    db.write_matches(ids[0], 50, np.array([[k, k] for k in range(30)], np.uint32))  # image 50 does not exist
    db.close()
    s = verify_database(path, progress=False, report=tmp_path / "r.csv")
    with open(tmp_path / "r.csv", newline="") as fh:
        lines = list(csv.reader(fh))
    assert tuple(lines[0]) == REPORT_COLUMNS and len(lines) == 1 + s.written == 1 + 7
    by_pid = {int(row[0]): dict(zip(REPORT_COLUMNS, row, strict=True)) for row in lines[1:]}
    assert sorted(by_pid) == sorted(p for p, *_ in _rows(path))
    missing = int(pycolmap.image_pair_to_pair_id(ids[0], 50))
    assert by_pid[missing]["status"] == "invalid input" and by_pid[missing]["config"] == "UNDEFINED" and "image id 50" in by_pid[missing]["message"]
    estimated = [r for p, r in by_pid.items() if p != missing]
    assert Counter(r["status"] for r in estimated) == s.statuses and sum(s.statuses.values()) == 6
    assert Counter(r["config"] for r in by_pid.values()) == s.configs
    assert all(r["image1"] and r["image2"] and int(r["matches"]) > 0 for r in estimated)
    assert main(["colmap", "verify", str(path), "--no-progress", "--overwrite", "--report", str(tmp_path / "r2.csv")]) == 1
    out = capsys.readouterr().out
    assert "poseonly statuses: " in out and "per-pair report" in out
    assert (tmp_path / "r2.csv").read_text() == (tmp_path / "r.csv").read_text()  # the pairs' seeds derive from their ids


def test_an_image_with_matches_but_no_keypoints_is_named(tmp_path):
    """A user's trial: an image whose keypoints row was deleted gave "matches index keypoints that do
    not exist"; the message now says which image has no keypoints (the pair UNDEFINED, exit 1)."""
    from poseonly.cli import main

    path = tmp_path / "db.db"
    _, ids = make_db(path, n_images=3, n_points=40)
    with closing(sqlite3.connect(path)) as con:
        con.execute("DELETE FROM keypoints WHERE image_id = ?", (ids[2],))
        con.commit()
    s = verify_database(path, progress=False)
    assert len(s.errors) == 2 and s.configs["UNDEFINED"] == 2
    assert all("image 'im2.jpg' has matches but no keypoints in the database" in e for e in s.errors.values())
    assert main(["colmap", "verify", str(path), "--no-progress", "--overwrite"]) == 1
    _check_consistent(path)


def test_database_fisheye_rays_beyond_90_degrees_are_lifted_natively(tmp_path):
    """``poseonly sfm --database`` lifted keypoints with pycolmap's ``cam_from_img``, whose normalized
    coordinates mirror a fisheye's rays beyond 90 deg (a camera user's trial: 310 of 400 clean matches
    kept, 4x the rotation error of the direct estimate). The native lifting gives the direct estimate."""
    from poseonly import estimate_relative_pose
    from poseonly.cameras import Camera
    from poseonly.geometry import rotation_from_rotvec
    from poseonly.sfm.colmap_db import database_view_graph

    params = (260.0, 260.0, 424.0, 400.0, 0.02, -0.004, 0.001, -0.0002)
    cam = Camera("OPENCV_FISHEYE", 848, 800, params)
    rng = np.random.default_rng(4)
    R, t = rotation_from_rotvec(np.radians([2.0, -3.0, 1.0])), np.array([0.05, 0.0, 0.3])
    u1 = u2 = np.zeros((0, 2))
    while len(u1) < 300:  # points all around the forward-looking cameras, up to ~110 deg off-axis
        d = rng.normal(size=(400, 3))
        d /= np.linalg.norm(d, axis=1)[:, None]
        X = d * rng.uniform(2.0, 6.0, (400, 1))
        a, b = cam.project(X), cam.project(X @ R.T + t)
        keep = np.all(np.isfinite(a) & np.isfinite(b), axis=1) & np.all((a > 0) & (a < [848, 800]) & (b > 0) & (b < [848, 800]), axis=1)
        u1, u2 = np.vstack([u1, a[keep]]), np.vstack([u2, b[keep]])
    u1, u2 = u1[:300] + rng.normal(0, 0.3, (300, 2)), u2[:300] + rng.normal(0, 0.3, (300, 2))
    beyond = np.degrees(np.arccos(cam.unproject(u1)[:, 2])) > 90.0
    assert beyond.sum() > 30
    path = tmp_path / "fisheye.db"
    db = pycolmap.Database.open(str(path))
    c = pycolmap.Camera(model="OPENCV_FISHEYE", width=848, height=800, params=list(params))
    c.has_prior_focal_length = True
    cid = db.write_camera(c)
    ids = []
    for k, uv in enumerate((u1, u2)):
        ids.append(db.write_image(pycolmap.Image(name=f"im{k}.png", camera_id=cid)))
        db.write_keypoints(ids[-1], uv.astype(np.float32))
    db.write_matches(ids[0], ids[1], np.column_stack([np.arange(300), np.arange(300)]).astype(np.uint32))
    db.close()
    ig, _ = database_view_graph(path)
    (st,) = ig.pair_stats
    direct = estimate_relative_pose(u1.astype(np.float32).astype(float), u2.astype(np.float32).astype(float), camera1=cam, seed=0)
    assert direct.status == "ok" and direct.num_inliers >= 280
    assert st[3] >= direct.num_inliers - 3, (st, direct.num_inliers)  # every ray lifted: the clean matches are inliers on both paths
    assert ig.normalized is not None and ig.normalized[0].shape == (300, 3)


def test_uncertain_written_calibrated_or_dropped(tmp_path, monkeypatch):
    """``uncertain`` is CALIBRATED with its inliers by default; ``keep_uncertain=False`` (``--drop-uncertain``)
    writes it DEGENERATE without inliers, as ``too_few_inliers`` (a pipeline user's trial asked for it)."""
    import dataclasses

    from poseonly.io.colmap_geometry import two_view_fields
    from poseonly.sim import make_scene

    sc = make_scene(60, camera="pinhole", noise_px=0.5, seed=1)
    r = dataclasses.replace(poseonly.estimate_relative_pose(sc.u1, sc.u2, sc.K, seed=0), status="uncertain")
    kept = two_view_fields(r)
    assert kept.config == "CALIBRATED" and len(kept.inlier_matches) == r.inliers.sum() > 0 and kept.E is not None
    dropped = two_view_fields(r, keep_uncertain=False)
    assert dropped.config == "DEGENERATE" and len(dropped.inlier_matches) == 0 and dropped.E is None
    ok = dataclasses.replace(r, status="ok")
    assert two_view_fields(ok, keep_uncertain=False).config == "CALIBRATED"  # only `uncertain` is dropped
    path = tmp_path / "db.db"
    make_db(path, n_images=3)
    with pytest.raises(ValueError, match="keep_uncertain must be True or False"):
        verify_database(path, progress=False, keep_uncertain="no")
    # the plumbing: every estimate made `uncertain`, then written CALIBRATED, or DEGENERATE with --drop-uncertain
    import poseonly.colmap_verify as cv
    from poseonly.cli import main

    orig = cv.estimate_relative_poses

    def uncertain(*a, **k):
        for pr in orig(*a, **k):
            if pr.result is not None:
                pr.result.status = "uncertain"
            yield pr

    monkeypatch.setattr(cv, "estimate_relative_poses", uncertain)
    s = verify_database(path, progress=False)
    assert s.written == 3 and s.configs["CALIBRATED"] == 3, s.configs
    assert main(["colmap", "verify", str(path), "--overwrite", "--drop-uncertain", "--no-progress"]) == 0
    assert [row[4] for row in _rows(path)] == [int(pycolmap.TwoViewGeometryConfiguration.DEGENERATE)] * 3
    assert all(row[1] == 0 for row in _rows(path))  # no inliers


def test_a_killed_runs_database_copy_is_swept(tmp_path):
    """The copy ``reading_snapshot`` makes (and pycolmap's journals beside it) carry an atomic writer's
    temporary name: a killed run's are removed by the next copy in that folder."""
    import subprocess

    from poseonly._fileutil import HOST
    from poseonly.io.colmap_db import reading_snapshot

    path = tmp_path / "db.db"
    make_db(path, n_images=3, n_points=40)
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    left = [tmp_path / "c" / f".db.db.{HOST}-{dead.pid}.abc123.poseonly-tmp{j}" for j in ("", "-wal", "-shm")]
    left[0].parent.mkdir()
    for f in left:
        f.write_bytes(b"x")
    with reading_snapshot(path, tmp_path / "c") as snap:
        assert snap.exists() and not any(f.exists() for f in left)


def test_a_write_waits_for_another_process_lock(tmp_path):
    """A batch that finds the database locked by another process is written again until the lock goes
    (a 20 ms lock ended a run: a COLMAP user's trial); the row is then there."""
    import subprocess

    from poseonly.io.colmap_db import ColmapDatabase, GeometryRow

    path = tmp_path / "db.db"
    make_db(path, n_images=3, n_points=40)
    hold = (
        "import sqlite3, sys, time\n"
        f"con = sqlite3.connect({str(path)!r}, isolation_level=None)\n"
        "con.execute('BEGIN IMMEDIATE'); print('held', flush=True); time.sleep(0.6); con.rollback()\n"
    )
    with ColmapDatabase(path, writable=True) as db:
        _, i1, i2 = db._pairs[0]
        row = GeometryRow.empty(i1, i2, "DEGENERATE")
        p = subprocess.Popen([sys.executable, "-c", hold], stdout=subprocess.PIPE, text=True)
        try:
            assert p.stdout is not None and p.stdout.readline().strip() == "held"
            t0 = time.perf_counter()
            assert db.write_geometries([row]) == 1
            assert time.perf_counter() - t0 > 0.2  # it waited for the lock
        finally:
            p.wait(30)
        assert db.read_geometry(i1, i2)["config"] == "DEGENERATE"


def test_verify_interrupted_and_unmatched_databases_say_what_to_do(tmp_path, monkeypatch, capsys):
    """A user's trial: Ctrl-C printed "interrupted" without saying what the database holds, and a database
    without matches printed "0 pairs selected" and nothing else."""
    import poseonly.colmap_verify as cv
    from poseonly.cli import main

    path = tmp_path / "db.db"
    make_db(path, n_images=2)
    with closing(sqlite3.connect(path)) as con:
        con.execute("DELETE FROM matches")
        con.commit()
    assert main(["colmap", "verify", str(path), "--no-progress"]) == 0
    assert "the database has no matched pairs: match its images first" in capsys.readouterr().out

    def interrupted(*a, **k):
        raise KeyboardInterrupt

    monkeypatch.setattr(cv, "verify_database", interrupted)
    assert main(["colmap", "verify", str(path), "--no-progress"]) == 130
    err = capsys.readouterr().err
    assert "the batches written before are in the database, and a rerun verifies the rest" in err and "poseonly: interrupted" in err
