"""Features, matching, match files, feature cache and the embedded demo pair."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("cv2")

import poseonly.features as feat  # noqa: E402
from poseonly.demo_data import load_demo_pair  # noqa: E402
from poseonly.features import (  # noqa: E402
    extract_features,
    load_matches_npz,
    match_features,
    match_images,
    read_image,
    sampson_distance,
    sampson_error_px,
    save_matches_npz,
)
from poseonly.geometry import InputError, rotation_from_rotvec  # noqa: E402


@pytest.fixture(scope="module")
def demo():
    return load_demo_pair()


@pytest.fixture(scope="module")
def demo_matches(demo):
    return match_images(demo.image1, demo.image2)


# --------------------------------------------------------------------------------------------
# demo pair


def test_demo_pair_loads(demo) -> None:
    assert demo.image1.is_file() and demo.image2.is_file()
    assert demo.K1.shape == (3, 3) and demo.K2.shape == (3, 3)
    np.testing.assert_allclose(demo.R_gt @ demo.R_gt.T, np.eye(3), atol=1e-10)
    assert np.linalg.det(demo.R_gt) == pytest.approx(1.0, abs=1e-10)
    assert np.linalg.norm(demo.t_gt) == pytest.approx(1.0)
    img = read_image(demo.image1)
    assert img.ndim == 2 and (img.shape[1], img.shape[0]) == demo.image_size
    assert "Strecha" in demo.meta["provenance"] and "openMVG" in demo.meta["provenance"]
    total = demo.image1.stat().st_size + demo.image2.stat().st_size
    assert total < 600 * 1024


def test_demo_pair_matches_agree_with_gt(demo, demo_matches) -> None:
    m = demo_matches
    assert len(m) > 300
    assert m.u1.shape == m.u2.shape == (len(m), 2) and m.idx.shape == (len(m), 2)
    assert m.image_size1 == demo.image_size
    e = sampson_error_px(m.u1, m.u2, demo.K1, demo.K2, demo.R_gt, demo.t_gt)
    assert np.mean(e < 2.0) > 0.3
    assert np.median(np.sort(e)[: len(e) // 2]) < 1.0
    # swapping the roles of the images breaks the epipolar constraint
    e_swap = sampson_error_px(m.u2, m.u1, demo.K1, demo.K2, demo.R_gt, demo.t_gt)
    assert np.mean(e_swap < 2.0) < 0.3


def test_match_features_ratio_and_mutual(demo) -> None:
    f1 = extract_features(demo.image1, max_features=500)
    f2 = extract_features(demo.image2, max_features=500)
    assert f1.keypoints.dtype == np.float64 and f1.descriptors.dtype == np.float32
    assert f1.descriptors.shape == (len(f1), 128) and len(f1) <= 520  # ties may exceed nfeatures a bit
    idx = match_features(f1.descriptors, f2.descriptors, ratio=0.8)
    idx_m = match_features(f1.descriptors, f2.descriptors, ratio=0.8, mutual=True)
    idx_s = match_features(f1.descriptors, f2.descriptors, ratio=0.6)
    assert idx.dtype.kind == "i" and idx.shape[1] == 2
    assert len(idx_s) <= len(idx) and len(idx_m) <= len(idx)
    assert set(map(tuple, idx_m)) <= set(map(tuple, idx))
    assert len(np.unique(idx_m[:, 1])) == len(idx_m)  # mutual: one-to-one
    # reference: brute force in numpy
    D = np.linalg.norm(f1.descriptors[:, None, :] - f2.descriptors[None, :, :], axis=2)
    o = np.argsort(D, axis=1)
    d0, d1 = D[np.arange(len(D)), o[:, 0]], D[np.arange(len(D)), o[:, 1]]
    ref = np.flatnonzero(d0 < 0.8 * d1)
    assert abs(len(ref) - len(idx)) <= 2  # float32 vs float64 rounding at the threshold
    common = np.intersect1d(ref, idx[:, 0])
    np.testing.assert_array_equal(o[common, 0], idx[np.searchsorted(idx[:, 0], common), 1])


def test_match_features_edge_cases() -> None:
    d = np.random.default_rng(0).random((5, 128)).astype(np.float32)
    assert match_features(d, d[:1]).shape == (0, 2)
    assert match_features(d[:0], d).shape == (0, 2)
    with pytest.raises(ValueError, match="descriptor lengths"):
        match_features(d, d[:, :64])
    with pytest.raises(ValueError, match="ratio"):
        match_features(d, d, ratio=1.5)


def test_extract_features_from_array(demo) -> None:
    gray = read_image(demo.image1)
    color = read_image(demo.image1, grayscale=False)
    fa = extract_features(gray, max_features=200)
    fc = extract_features(color, max_features=200)
    assert fa.image_size == demo.image_size == fc.image_size
    assert len(fa) > 100 and len(fc) > 100


# --------------------------------------------------------------------------------------------
# cache


def test_feature_cache(tmp_path: Path, demo, monkeypatch) -> None:
    img = tmp_path / "img.jpg"
    img.write_bytes(demo.image1.read_bytes())
    cache = tmp_path / "cache"
    calls = []
    real_sift = feat._sift

    def counting_sift(*a, **k):
        calls.append(1)
        return real_sift(*a, **k)

    monkeypatch.setattr(feat, "_sift", counting_sift)
    f1 = extract_features(img, max_features=300, cache_dir=cache)
    assert len(calls) == 1
    files = list(cache.glob("*.npz"))
    assert len(files) == 1 and not list(cache.glob("*.tmp"))
    f2 = extract_features(img, max_features=300, cache_dir=cache)
    assert len(calls) == 1  # served from the cache
    np.testing.assert_array_equal(f1.keypoints, f2.keypoints)
    np.testing.assert_array_equal(f1.descriptors, f2.descriptors)
    assert f1.image_size == f2.image_size and f2.descriptors.dtype == np.float32

    # other parameters get another entry
    extract_features(img, max_features=100, cache_dir=cache)
    assert len(calls) == 2 and len(list(cache.glob("*.npz"))) == 2

    # a truncated cache file is ignored and rewritten
    data = files[0].read_bytes()
    files[0].write_bytes(data[: len(data) // 2])
    f3 = extract_features(img, max_features=300, cache_dir=cache)
    assert len(calls) == 3
    np.testing.assert_array_equal(f1.descriptors, f3.descriptors)
    assert files[0].stat().st_size == len(data)
    extract_features(img, max_features=300, cache_dir=cache)
    assert len(calls) == 3

    # garbage is ignored too
    files[0].write_bytes(b"not an npz")
    extract_features(img, max_features=300, cache_dir=cache)
    assert len(calls) == 4

    # and an empty file (EOFError), a missing field (KeyError) or a field of the wrong type (TypeError)
    good = files[0].stat().st_size
    fields = {"keypoints": f1.keypoints, "descriptors": f1.descriptors, "image_size": np.array(f1.image_size), "sizes": f1.sizes}
    for k, bad in enumerate(({}, {k: v for k, v in fields.items() if k != "sizes"}, fields | {"image_size": np.array(5)})):
        if bad:
            np.savez(files[0], **bad)
        else:
            files[0].write_bytes(b"")
        f4 = extract_features(img, max_features=300, cache_dir=cache)
        assert len(calls) == 5 + k
        np.testing.assert_array_equal(f1.descriptors, f4.descriptors)
        assert files[0].stat().st_size == good  # rewritten


def test_feature_cache_read_errors_other_than_a_bad_file_propagate(tmp_path: Path, demo, monkeypatch) -> None:
    """Only what a corrupt cache file raises means "recompute"; anything else (a bug) is not swallowed."""
    img = tmp_path / "img.jpg"
    img.write_bytes(demo.image1.read_bytes())
    extract_features(img, max_features=100, cache_dir=tmp_path / "cache")

    def broken_load(*a, **k):
        raise AttributeError("a bug, not a corrupt cache")

    monkeypatch.setattr(feat.np, "load", broken_load)
    with pytest.raises(AttributeError, match="a bug"):
        extract_features(img, max_features=100, cache_dir=tmp_path / "cache")


# --------------------------------------------------------------------------------------------
# match files


def test_matches_npz_roundtrip(tmp_path: Path) -> None:
    rng = np.random.default_rng(1)
    u1, u2 = rng.random((50, 2)) * 900, rng.random((50, 2)) * 900
    K = np.array([[800.0, 0, 480], [0, 800, 320], [0, 0, 1]])
    p = save_matches_npz(tmp_path / "m.npz", u1, u2, K=K)
    d = load_matches_npz(p)
    np.testing.assert_array_equal(d.u1, u1)
    np.testing.assert_array_equal(d.u2, u2)
    np.testing.assert_array_equal(d.K1, K)
    np.testing.assert_array_equal(d.K2, K)
    K2 = K * np.array([[1.1], [1.1], [1]])
    d = load_matches_npz(save_matches_npz(tmp_path / "m2.npz", u1, u2, K1=K, K2=K2))
    np.testing.assert_array_equal(d.K2, K2)
    d = load_matches_npz(save_matches_npz(tmp_path / "m3.npz", u1, u2))
    assert d.K1 is None and d.K2 is None and len(d) == 50
    assert not list(tmp_path.glob("*.tmp"))
    # a shared K and a different K1 / K2: refused (one of them was used silently: an adversarial trial)
    np.savez(tmp_path / "m4.npz", u1=u1, u2=u2, K=K, K2=K2)
    _expect("both 'K' and a different 'K2'", load_matches_npz, tmp_path / "m4.npz")
    np.savez(tmp_path / "m5.npz", u1=u1, u2=u2, K=K, K1=K, K2=K)  # the same calibration: fine
    np.testing.assert_array_equal(load_matches_npz(tmp_path / "m5.npz").K2, K)
    # OpenCV's (k, 1, 2) float32 arrays, as the Python API takes them (a migrating user's trial: refused)
    np.savez(tmp_path / "m6.npz", u1=u1.astype(np.float32).reshape(-1, 1, 2), u2=u2.astype(np.float32).reshape(-1, 1, 2), K=K)
    d = load_matches_npz(tmp_path / "m6.npz")
    np.testing.assert_array_equal(d.u1, u1.astype(np.float32).astype(float))
    assert d.u2.shape == (50, 2)


# --------------------------------------------------------------------------------------------
# bad inputs


def _expect(match: str, fn, *a, **k) -> None:
    with pytest.raises(ValueError, match=match) as ei:
        fn(*a, **k)
    assert isinstance(ei.value, InputError)


def test_bad_image_paths(tmp_path: Path) -> None:
    _expect("not found", read_image, tmp_path / "missing.jpg")
    _expect("not a file", read_image, tmp_path)
    bad = tmp_path / "bad.jpg"
    bad.write_bytes(b"\xff\xd8 this is not really a jpeg")
    _expect("cannot decode", read_image, bad)
    empty = tmp_path / "empty.png"
    empty.write_bytes(b"")
    _expect("cannot decode", read_image, empty)
    _expect("not found", extract_features, tmp_path / "missing.jpg")
    _expect("not found", extract_features, tmp_path / "missing.jpg", cache_dir=tmp_path / "c")
    _expect("not found", match_images, tmp_path / "missing.jpg", bad)


def test_bad_match_files(tmp_path: Path) -> None:
    good = np.zeros((10, 2))
    _expect("not found", load_matches_npz, tmp_path / "missing.npz")

    txt = tmp_path / "text.npz"
    txt.write_text("u1,u2\n1,2\n")
    _expect("not a readable .npz", load_matches_npz, txt)

    p = save_matches_npz(tmp_path / "ok.npz", good, good)
    raw = p.read_bytes()
    trunc = tmp_path / "trunc.npz"
    trunc.write_bytes(raw[: len(raw) // 2])
    _expect("trunc.npz is not a readable .npz archive", load_matches_npz, trunc)

    npy = tmp_path / "single.npy"
    np.save(npy, good)
    _expect("single .npy", load_matches_npz, npy)

    def write(name: str, **arrays) -> Path:
        f = tmp_path / name
        with open(f, "wb") as fh:
            np.savez(fh, **arrays)
        return f

    _expect(r"lacks required key\(s\) \['u2'\]", load_matches_npz, write("a.npz", u1=good))
    _expect("lacks required key", load_matches_npz, write("b.npz", x1=good, x2=good))
    _expect(r"'u1' must have shape \(k, 2\)", load_matches_npz, write("c.npz", u1=np.zeros((10, 3)), u2=good))
    _expect("differ in length", load_matches_npz, write("d.npz", u1=good, u2=good[:5]))
    nan = good.copy()
    nan[3, 1] = np.nan
    _expect("NaN", load_matches_npz, write("e.npz", u1=good, u2=nan))
    _expect("no matches", load_matches_npz, write("f.npz", u1=good[:0], u2=good[:0]))
    _expect("3x3", load_matches_npz, write("g.npz", u1=good, u2=good, K=np.eye(2)))
    _expect("'K2' is missing", load_matches_npz, write("h.npz", u1=good, u2=good, K1=np.eye(3)))
    _expect("numeric", load_matches_npz, write("i.npz", u1=np.array([["a", "b"]] * 10), u2=good))
    _expect("cannot read key 'u1'", load_matches_npz, write("j.npz", u1=np.array([object()] * 2), u2=good))

    _expect("shape", save_matches_npz, tmp_path / "x.npz", good, np.zeros(10))
    assert not (tmp_path / "x.npz").exists()


# --------------------------------------------------------------------------------------------
# Sampson distance


def test_sampson_distance_synthetic() -> None:
    rng = np.random.default_rng(3)
    K = np.array([[700.0, 0, 320], [0, 710, 240], [0, 0, 1]])
    R = rotation_from_rotvec(np.array([0.02, -0.1, 0.03]))
    t = np.array([1.0, 0.1, 0.05])
    t /= np.linalg.norm(t)
    X = rng.uniform(-2, 2, (100, 3)) + [0, 0, 8]
    x1 = X @ K.T
    u1 = x1[:, :2] / x1[:, 2:]
    x2 = (X @ R.T + t) @ K.T
    u2 = x2[:, :2] / x2[:, 2:]
    assert np.max(sampson_error_px(u1, u2, K, K, R, t)) < 1e-8
    # a small shift perpendicular to the epipolar line gives about that many pixels
    F = feat.fundamental_from_pose(K, K, R, t)
    l2 = np.c_[u1, np.ones(len(u1))] @ F.T
    n = l2[:, :2] / np.linalg.norm(l2[:, :2], axis=1, keepdims=True)
    e = sampson_distance(u1, u2 + 0.7 * n, F)
    np.testing.assert_allclose(e, 0.7 / np.sqrt(2), rtol=0.05)  # shared between both images


def test_match_scores_round_trip_and_validation(tmp_path):
    from poseonly.features import load_matches_npz, save_matches_npz

    u = np.random.default_rng(0).uniform(0, 100, (10, 2))
    p = save_matches_npz(tmp_path / "m.npz", u, u + 1, K=np.eye(3), scores=np.linspace(0, 1, 10))
    md = load_matches_npz(p)
    np.testing.assert_array_equal(md.scores, np.linspace(0, 1, 10))
    np.savez(tmp_path / "bad.npz", u1=u, u2=u, scores=np.ones(3))
    with pytest.raises(ValueError, match="scores"):
        load_matches_npz(tmp_path / "bad.npz")


def test_match_features_scores_are_one_minus_ratio():
    from poseonly.features import match_features

    rng = np.random.default_rng(4)
    d2 = rng.random((50, 128)).astype(np.float32)
    d1 = d2[:20] + 0.01 * rng.random((20, 128)).astype(np.float32)
    idx, sc = match_features(d1, d2, return_scores=True)
    assert len(idx) == len(sc) > 0 and np.all((sc > 0.2) & (sc <= 1.0))
    np.testing.assert_array_equal(idx, match_features(d1, d2))


def test_match_features_agree_with_opencv_batchdistance(demo, monkeypatch) -> None:
    """The blocked matrix-product matcher against the OpenCV reference it replaced: the same matches
    (up to float32 ties) and scores, with blocks smaller than the sets (the mutual check spans blocks)."""
    import sys

    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from reference.ratio_matching import match_features_batchdistance

    f1 = extract_features(demo.image1, max_features=3000)
    f2 = extract_features(demo.image2, max_features=3000)
    for block in (feat.MATCH_BLOCK_ROWS, 97):
        monkeypatch.setattr(feat, "MATCH_BLOCK_ROWS", block)
        for mutual in (False, True):
            idx, sc = match_features(f1.descriptors, f2.descriptors, ratio=0.8, mutual=mutual, return_scores=True)
            ref, rsc = match_features_batchdistance(f1.descriptors, f2.descriptors, ratio=0.8, mutual=mutual)
            assert len(idx) > 300
            both = set(map(tuple, idx)) & set(map(tuple, ref))
            assert len(both) >= max(len(idx), len(ref)) - 2, (block, mutual)
            common = np.array(sorted(both))
            a = sc[np.searchsorted(idx[:, 0], common[:, 0])]
            b = rsc[np.searchsorted(ref[:, 0], common[:, 0])]
            np.testing.assert_allclose(a, b, atol=1e-5)


def test_match_features_huge_and_tiny_descriptors_match_as_scaled() -> None:
    """Descriptors whose squares leave float32's range are scaled first: the same matches and scores
    as the unit-scale set (no overflow to inf or underflow to 0)."""
    rng = np.random.default_rng(7)
    d2 = rng.random((60, 128)).astype(np.float32)
    d1 = d2[:25] + 0.02 * rng.random((25, 128)).astype(np.float32)
    idx, sc = match_features(d1, d2, mutual=True, return_scores=True)
    assert len(idx) == 25
    for s in (1e25, 1e-25):
        i2, s2 = match_features(d1 * np.float32(s), d2 * np.float32(s), mutual=True, return_scores=True)
        np.testing.assert_array_equal(i2, idx)
        np.testing.assert_allclose(s2, sc, atol=1e-6)


def test_match_features_with_a_large_common_offset() -> None:
    """Descriptors sharing a large offset (the products' rounding scales with |a|^2): centred first, so
    the matches are those of the offset-free set (a review found 12 of 1500 left at an offset of 1e4)."""
    rng = np.random.default_rng(3)
    d2 = rng.random((1500, 64)).astype(np.float32)
    d1 = (d2 + 0.3 * rng.standard_normal(d2.shape) / 8).astype(np.float32)
    ref, rsc = match_features(d1, d2, mutual=True, return_scores=True)
    assert len(ref) > 1000
    for off in (1e3, 1e4):
        idx, sc = match_features(d1 + np.float32(off), d2 + np.float32(off), mutual=True, return_scores=True)
        assert len(set(map(tuple, idx)) ^ set(map(tuple, ref))) <= 3, off


def test_match_features_float64_beyond_float32_range_and_small_blocks(monkeypatch) -> None:
    """float64 descriptors at 1e-50 or 1e40 (outside float32) match as the unit-scale set; a block
    budget smaller than one row of distances still matches row by row."""
    rng = np.random.default_rng(5)
    d2 = rng.random((80, 32))
    d1 = d2[:30] + 0.02 * rng.random((30, 32))
    ref = match_features(d1, d2, mutual=True)
    assert len(ref) == 30
    for s in (1e-50, 1e40):
        np.testing.assert_array_equal(match_features(d1 * s, d2 * s, mutual=True), ref)
    monkeypatch.setattr(feat, "MATCH_BLOCK_BYTES", 8)
    np.testing.assert_array_equal(match_features(d1, d2, mutual=True), ref)


def test_a_cache_that_cannot_be_written_is_a_warning_not_an_error(tmp_path: Path, demo, monkeypatch) -> None:
    """A full cache disk ended ``poseonly relpose --cache`` (ENOSPC; a reliability trial): a cache entry
    that cannot be written warns once per folder and the features are returned."""
    import errno

    import poseonly._fileutil as fu

    img = tmp_path / "img.jpg"
    img.write_bytes(demo.image1.read_bytes())

    def full(path, **arrays):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(fu, "atomic_savez", full)
    monkeypatch.setattr(fu, "_CACHE_WARNED", set())
    with pytest.warns(RuntimeWarning, match="cannot write to the cache folder .*No space left on device"):
        f = extract_features(img, max_features=300, cache_dir=tmp_path / "cache")
    assert len(f.keypoints) == 300
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error")  # the second failure in the same folder is silent
        extract_features(img, max_features=200, cache_dir=tmp_path / "cache")
