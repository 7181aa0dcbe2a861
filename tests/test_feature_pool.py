"""The pairwise stage's memory: descriptors are held only while an image has pairs left to match,
and with a feature cache at most ``resident_images`` images hold them; the graph is the same either
way. And the atomic writers sweep a directory's stale temp files once per process, not per write."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

SCENE = Path("/work/shared/data/strecha/Herz-Jesus-P8")


SCALE = 0.25  # quarter-size copies of the images: SIFT in a tenth of the time


@pytest.fixture(scope="module")
def small(tmp_path_factory) -> tuple[list[Path], np.ndarray]:
    if not (SCENE / "images" / "K.txt").is_file():
        pytest.skip("shared Strecha data not available")
    cv2 = pytest.importorskip("cv2")
    d = tmp_path_factory.mktemp("small")
    out = []
    for f in sorted((SCENE / "images").glob("*.jpg"))[:5]:
        im = cv2.imread(str(f))
        cv2.imwrite(str(d / f.name), cv2.resize(im, None, fx=SCALE, fy=SCALE, interpolation=cv2.INTER_AREA))
        out.append(d / f.name)
    K = np.loadtxt(SCENE / "images" / "K.txt")
    K[:2] *= SCALE
    return out, K


def _images(small, k: int) -> tuple[list[Path], np.ndarray]:
    return small[0][:k], small[1]


def _same_graph(a, b) -> None:
    assert a.pair_stats == b.pair_stats and len(a.graph) == len(b.graph) > 0
    for ea, eb in zip(a.graph.edges, b.graph.edges, strict=True):
        assert (ea.i, ea.j) == (eb.i, eb.j) and np.array_equal(ea.R, eb.R) and np.array_equal(ea.matches, eb.matches)
    for fa, fb in zip(a.features, b.features, strict=True):
        assert np.array_equal(fa.keypoints, fb.keypoints) and fa.image_size == fb.image_size


def test_sequential_pairs_hold_two_images_descriptors(tmp_path, small):
    from poseonly.sfm.pairwise import PairwiseOptions, image_view_graph

    images, K = _images(small, 5)
    opt = PairwiseOptions(max_features=1000)
    pairs = [(i, i + 1) for i in range(4)]
    ig = image_view_graph(images, K, options=opt, pairs=pairs, cache_dir=tmp_path / "c")
    assert ig.peak_resident_images == 2  # (i, i + 1): image i is released after its last pair
    assert len(ig.features) == 5
    for f in ig.features:
        assert f.descriptors.shape == (0, 128) and len(f.keypoints) > 100 and f.sizes is not None
    # without a cache (nothing to read back from) the release after the last pair still applies
    nocache = image_view_graph(images, K, options=opt, pairs=pairs)
    assert nocache.peak_resident_images == 2
    _same_graph(ig, nocache)


def test_resident_bound_reads_descriptors_back_from_the_cache(tmp_path, small):
    from poseonly.sfm.pairwise import PairwiseOptions, image_view_graph

    images, K = _images(small, 4)
    opt = PairwiseOptions(max_features=1000)
    # separate caches: the bounded run must read its features back, not find the matches cached
    full = image_view_graph(images, K, options=opt, cache_dir=tmp_path / "a")
    assert full.peak_resident_images == 4  # all pairs: image 0's row needs every image
    bounded = image_view_graph(images, K, options=opt, cache_dir=tmp_path / "b", resident_images=2)
    assert bounded.peak_resident_images == 2
    _same_graph(full, bounded)
    two = image_view_graph(images, K, options=opt, cache_dir=tmp_path / "c", resident_images=2, jobs=2)
    _same_graph(full, two)


def test_unpaired_images_get_features_and_bad_bounds_are_refused(tmp_path, small):
    from poseonly.geometry import InputError
    from poseonly.sfm.pairwise import PairwiseOptions, image_view_graph

    images, K = _images(small, 3)
    ig = image_view_graph(images, K, options=PairwiseOptions(max_features=800), pairs=[(0, 1)], cache_dir=tmp_path / "c")
    assert len(ig.features[2].keypoints) > 100 and ig.features[2].image_size == ig.features[0].image_size
    for bad in (1, 0, True, 2.5, "4"):
        with pytest.raises(InputError, match="resident_images"):
            image_view_graph(images, K, resident_images=bad)  # type: ignore[arg-type]


def test_atomic_writes_sweep_a_directory_once_per_process(tmp_path, monkeypatch):
    from poseonly import _fileutil

    calls: list[str] = []
    real = _fileutil.sweep_stale_temps
    monkeypatch.setattr(_fileutil, "sweep_stale_temps", lambda d: calls.append(str(d)) or real(d))
    for k in range(5):
        _fileutil.atomic_write_text(tmp_path / f"f{k}.txt", "x")
        _fileutil.atomic_savez(tmp_path / "sub" / f"a{k}.npz", a=np.zeros(2))
    assert sorted(calls) == sorted({str(tmp_path), str(tmp_path / "sub")})
    assert sorted(p.name for p in tmp_path.iterdir()) == ["f0.txt", "f1.txt", "f2.txt", "f3.txt", "f4.txt", "sub"]


def test_sweep_removes_only_dead_writers_temps(tmp_path):
    import os
    import subprocess
    import sys
    import time

    from poseonly._fileutil import TMP_SUFFIX, sweep_stale_temps

    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    from poseonly._fileutil import HOST

    stale = [
        tmp_path / f".m_1.npz.{HOST}-{dead.pid}.k2j_x{TMP_SUFFIX}",
        tmp_path / f".a.b.c.{HOST}-{dead.pid}.zz{TMP_SUFFIX}",
        tmp_path / f".m_0.npz.{dead.pid}.q{TMP_SUFFIX}",  # an earlier version's name (no host)
    ]
    live = [
        tmp_path / f".m_2.npz.{HOST}-{os.getpid()}.abc{TMP_SUFFIX}",
        tmp_path / f".m_4.npz.other-host-{dead.pid}.abc{TMP_SUFFIX}",  # another host sharing the folder
        tmp_path / ".my_editor_backup.tmp",  # not ours, however old
        tmp_path / "m_3.npz",
        tmp_path / f".odd{TMP_SUFFIX}",
    ]
    for f in stale + live:
        f.write_text("x")
    old = time.time() - 7200
    os.utime(tmp_path / ".my_editor_backup.tmp", (old, old))
    assert sweep_stale_temps(tmp_path) == 3
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(f.name for f in live)
