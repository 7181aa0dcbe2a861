"""Every writer is atomic under SIGKILL and the next run removes the killed writers' temp files.

A child process rewrites a target in a loop (a few MB each time, so kills land mid-write); the
parent kills it at seeded random moments. After every kill the target is absent or complete, and
one more write (by a new process) leaves no temp file behind.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pytest

import poseonly

# the folder the poseonly of this process comes from (the source tree of an editable install, or
# site-packages of a wheel): a child process imports the same one
SRC = str(Path(poseonly.__file__).resolve().parents[1])
KILLS = 4
MAX_KILLS = 40

CHILD = {
    # reports (markdown / JSON tables of every benchmark and experiment, bench_speed.write_report)
    # (written in flushed chunks, as a report that streams its rows: a single write() syscall
    # completes before SIGKILL is delivered, so it could not show a non-atomic writer)
    "report": """
        from poseonly._fileutil import atomic_open
        chunk = "x" * 4096
        while True:
            with atomic_open(TARGET, "w") as fh:
                fh.write("BEGIN\\n")
                for _ in range(1000):
                    fh.write(chunk)
                    fh.flush()
                fh.write("\\nEND\\n")
    """,
    # figures (experiments' savefig)
    "figure": """
        from poseonly.experiments._common import pyplot, savefig
        import numpy as np
        plt = pyplot()
        fig, ax = plt.subplots(figsize=(16, 12))
        ax.scatter(*np.random.default_rng(0).standard_normal((2, 60000)), s=1)
        while True:
            savefig(fig, TARGET)
    """,
    # the feature cache
    "cache": """
        import numpy as np
        from poseonly._fileutil import atomic_savez
        kp = np.arange(400_000, dtype=np.float64).reshape(-1, 2)
        desc = np.ones((2000, 128), np.float32)  # made once: the loop is (nearly) all writing
        while True:
            atomic_savez(Path(TARGET), keypoints=kp, descriptors=desc, image_size=np.array([7, 9]))
    """,
    # match drawings (CLI --draw)
    "drawing": """
        from poseonly._fileutil import atomic_write_bytes
        import cv2, numpy as np
        img = np.random.default_rng(0).integers(0, 255, (1500, 2000, 3), dtype=np.uint8)
        buf = cv2.imencode(".png", img)[1].tobytes()
        while True:
            atomic_write_bytes(TARGET, buf)
    """,
}
SUFFIX = {"report": ".md", "figure": ".png", "cache": ".npz", "drawing": ".png"}


def _complete(kind: str, p: Path) -> bool:
    if kind == "report":
        text = p.read_text()
        return text.startswith("BEGIN\n") and text.endswith("\nEND\n") and len(text) == 4_096_011
    if kind == "cache":
        with np.load(p) as z:
            return z["keypoints"].shape == (200_000, 2) and float(z["keypoints"][-1, 1]) == 399_999.0
    data = p.read_bytes()
    return data.startswith(b"\x89PNG") and data.rstrip(b"\x00").endswith(b"IEND\xaeB`\x82")


def _spawn(kind: str, target: Path) -> subprocess.Popen:
    code = f"from pathlib import Path\nTARGET = {str(target)!r}\n" + textwrap.dedent(CHILD[kind])
    env = dict(os.environ, PYTHONPATH=SRC)
    return subprocess.Popen([sys.executable, "-c", code], env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)


@pytest.mark.parametrize("kind", sorted(CHILD))
def test_writer_survives_sigkill(kind, tmp_path):
    if kind in ("figure",):
        pytest.importorskip("matplotlib")
    if kind == "drawing":
        pytest.importorskip("cv2")
    target = tmp_path / ("out" + SUFFIX[kind])
    rng = np.random.default_rng(14)
    killed_mid_write = 0
    kills = 0
    # at least KILLS kills, more (up to MAX_KILLS) until one lands while a temp file exists: on a disk
    # whose directory fsync after the rename is slow, a drawing's loop spends most of its time with no
    # temp file, and 4 kills at random moments all missed (a clean-clone CI run)
    while kills < KILLS or (killed_mid_write == 0 and kills < MAX_KILLS):
        kills += 1
        proc = _spawn(kind, target)
        # wait until this child has started a write (its own temp file appears), then a random delay,
        # then the next moment a temp file of this child exists (polled; it may be gone by the kill)
        t_end = time.time() + 60
        while time.time() < t_end and not _has_temp(tmp_path, proc.pid):
            if proc.poll() is not None:
                pytest.fail(f"writer exited early: {proc.stderr.read().decode()[-2000:]}")
            time.sleep(0.01)
        time.sleep(float(rng.uniform(0.05, 0.6)))
        t_end = time.time() + 5
        while time.time() < t_end and not _has_temp(tmp_path, proc.pid):
            time.sleep(0.0005)
        proc.send_signal(signal.SIGKILL)
        proc.wait()
        proc.stderr.close()
        killed_mid_write += _has_temp(tmp_path, proc.pid)
        if target.exists():
            assert _complete(kind, target), f"{kind}: a kill left a partial {target.name}"
    assert killed_mid_write >= 1, f"{kind}: none of {kills} kills landed during a write; the test did not test the writer"
    # the next write (a new process that is not killed) removes the dead writers' temp files
    proc = _spawn(kind, target)
    t_end = time.time() + 60
    while time.time() < t_end and not (target.exists() and _complete(kind, target) and not _dead_temps(tmp_path, proc.pid)):
        time.sleep(0.05)
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    proc.stderr.close()
    leftovers = _dead_temps(tmp_path, proc.pid)
    assert not leftovers, f"{kind}: temp files of killed writers were not cleaned: {leftovers}"
    assert target.exists() and _complete(kind, target)


def _temp_pid(f: Path) -> int | None:
    """The writer PID in a temp file's name ``.NAME.HOST-PID.RANDOM.poseonly-tmp`` (None otherwise;
    parsed here, independently of ``poseonly._fileutil``)."""
    parts = f.name.rsplit(".", 3)
    if len(parts) != 4 or parts[3] != "poseonly-tmp":
        return None
    pid = parts[1].rpartition("-")[2]
    return int(pid) if pid.isdigit() else None


def _has_temp(folder: Path, pid: int) -> bool:
    return any(_temp_pid(f) == pid for f in folder.iterdir())


def _dead_temps(folder: Path, exclude: int) -> list[str]:
    """Temp files in ``folder`` of writers that no longer run (``exclude``: a PID whose files count as
    alive, the last writer, killed only after the check)."""
    out = []
    for f in folder.iterdir():
        pid = _temp_pid(f)
        if pid is None or pid == exclude:
            continue
        try:
            os.kill(pid, 0)
        except ProcessLookupError:
            out.append(f.name)
    return out


def test_bench_speed_report_is_atomic(tmp_path, monkeypatch):
    """``bench_speed.write_report`` goes through the atomic writer for both of its files (the data of
    the committed report, docs/results/speed.json, so that both are written)."""
    from poseonly import bench_speed

    src = Path(__file__).resolve().parents[1] / "docs" / "results" / "speed.json"
    if not src.is_file():  # the sdist leaves docs/results out
        pytest.skip("docs/results/speed.json is not here (an unpacked sdist)")
    data = json.loads(src.read_text())
    calls = []
    monkeypatch.setattr(bench_speed, "atomic_write_text", lambda p, text: calls.append(Path(p).name))
    bench_speed.write_report(data, tmp_path)
    assert calls == ["speed.json", "speed.md"]
    assert not [f for f in tmp_path.iterdir()], "write_report wrote outside the atomic writer"


def test_stale_temp_of_dead_pid_removed(tmp_path):
    from poseonly._fileutil import TMP_SUFFIX, atomic_write_text

    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    stale = tmp_path / f".r.md.{dead.pid}.abc{TMP_SUFFIX}"
    stale.write_text("half")
    legacy = tmp_path / ".r.md.xyz.tmp"
    legacy.write_text("old")
    old = time.time() - 7200
    os.utime(legacy, (old, old))
    atomic_write_text(tmp_path / "r.md", json.dumps({"a": 1}))
    assert sorted(f.name for f in tmp_path.iterdir()) == ["r.md"]


def _small_reconstruction(points: int = 3000):
    pycolmap = pytest.importorskip("pycolmap")
    rec = pycolmap.Reconstruction()
    rec.add_camera_with_trivial_rig(pycolmap.Camera(model="PINHOLE", width=640, height=480, params=[500.0, 500.0, 320.0, 240.0], camera_id=1))
    kp = np.random.default_rng(0).uniform(0, 480, (points, 2))
    for k in (1, 2):
        pose = pycolmap.Rigid3d(np.concatenate([np.eye(3), np.array([[k - 1.0], [0.0], [0.0]])], axis=1))
        rec.add_image_with_trivial_frame(pycolmap.Image(name=f"{k}.jpg", keypoints=kp, camera_id=1, image_id=k), pose)
    for i in range(points):
        track = pycolmap.Track()
        track.add_element(1, i)
        track.add_element(2, i)
        rec.add_point3D(np.array([0.0, 0.0, 5.0 + i * 1e-3]), track, np.array([128, 128, 128], np.uint8))
    return rec


def test_colmap_model_that_does_not_read_back_is_an_error_and_keeps_the_old_one(tmp_path):
    """pycolmap's model writers do not report a failed write: a full disk (here a file-size limit) cut
    images.bin / points3D.bin short and ``poseonly sfm`` reported success (a reliability trial). The
    writer reads the model back: an OSError, the previous model in place, no temp folder left."""
    from poseonly.sfm.export import _model_counts, write_colmap_model

    rec = _small_reconstruction()
    dst = tmp_path / "sparse" / "0"
    write_colmap_model(rec, dst)
    assert _model_counts(type(rec)(str(dst))) == (1, 2, 3000, 6000)
    code = textwrap.dedent(
        f"""
        import resource, sys
        sys.path.insert(0, {str(Path(__file__).resolve().parent)!r})
        from test_writers_kill import _small_reconstruction
        from poseonly.sfm.export import write_colmap_model
        rec = _small_reconstruction(20000)
        resource.setrlimit(resource.RLIMIT_FSIZE, (100_000, 100_000))
        try:
            write_colmap_model(rec, {str(dst)!r})
        except OSError as exc:
            print("OSError", exc)
        """
    )
    env = dict(os.environ, PYTHONPATH=SRC)
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=120)
    assert "OSError writing the COLMAP model" in out.stdout, out.stdout + out.stderr
    assert _model_counts(type(rec)(str(dst))) == (1, 2, 3000, 6000)
    assert sorted(p.name for p in dst.parent.iterdir()) == ["0"]


def test_ply_and_figure_writers_use_the_atomic_scheme(tmp_path):
    """The sfm PLY and figure writers publish through ``atomic_open`` (a killed write leaves a temp file
    that the next write sweeps; a fixed ``NAME.tmp.png`` made two runs into one folder fail): nothing
    but the targets after a write."""
    from poseonly.sfm.export import plot_reconstruction, write_ply

    pts = np.random.default_rng(1).standard_normal((50, 3))
    write_ply(tmp_path / "pts.ply", pts, cameras=np.zeros((2, 3)))
    data = (tmp_path / "pts.ply").read_bytes()
    assert data.startswith(b"ply\n") and len(data) == data.index(b"end_header\n") + 11 + 52 * 15
    pytest.importorskip("matplotlib")
    assert plot_reconstruction(tmp_path / "fig.png", pts, np.zeros((2, 3)), np.stack([np.eye(3)] * 2)) is not None
    assert sorted(p.name for p in tmp_path.iterdir()) == ["fig.png", "pts.ply"]


def test_a_failed_write_names_its_file_and_leaves_no_temp(tmp_path):
    """``ulimit -f`` (EFBIG) during an atomic write: the error names the target (a bare "[Errno 27] File too
    large" did not; a reliability trial), the target keeps its old content, no temp file is left."""
    target = tmp_path / "out.bin"
    target.write_bytes(b"old")
    code = textwrap.dedent(
        f"""
        import resource, signal
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
        resource.setrlimit(resource.RLIMIT_FSIZE, (4096, 4096))
        from poseonly._fileutil import atomic_write_bytes
        try:
            atomic_write_bytes({str(target)!r}, b"x" * 100000)
        except OSError as exc:
            print(type(exc).__name__, exc.errno, exc)
        """
    )
    out = subprocess.run([sys.executable, "-c", code], env=dict(os.environ, PYTHONPATH=SRC), capture_output=True, text=True, timeout=60)
    assert f"OSError 27 [Errno 27] cannot write {target}" in out.stdout, out.stdout + out.stderr
    assert target.read_bytes() == b"old" and sorted(p.name for p in tmp_path.iterdir()) == ["out.bin"]
