"""The SfM pipeline's two-view estimator options (``PairwiseOptions.estimator_options``, the CLI's
``--two-view-option KEY=VALUE``): passed to the estimator, part of the cache key, checked early."""

from __future__ import annotations

import numpy as np
import pytest

from poseonly import InputError, estimate_relative_pose
from poseonly.sfm.pairwise import PAIRWISE_MAX_ITERATIONS, PairwiseOptions, parse_estimator_options, two_view
from poseonly.sim import make_scene


def test_parse_estimator_options():
    assert parse_estimator_options(["ml_tails=gauss", "min_hits=3", "chiral_scoring=false"]) == (
        ("ml_tails", "gauss"),
        ("min_hits", 3),
        ("chiral_scoring", False),
    )
    assert parse_estimator_options(None) == ()
    assert parse_estimator_options(["max_rotation_std_deg=inf", "x=Infinity"]) == (("max_rotation_std_deg", float("inf")), ("x", float("inf")))
    PairwiseOptions(estimator_options=(("max_rotation_std_deg", float("inf")),))
    for bad in ("ml_tails", "=gauss"):
        with pytest.raises(InputError, match="KEY=VALUE"):
            parse_estimator_options([bad])


def test_options_are_checked_at_construction():
    PairwiseOptions(estimator_options=(("ml_tails", "gauss"),))
    with pytest.raises(InputError, match="unknown option"):
        PairwiseOptions(estimator_options=(("no_such_option", 1),))
    with pytest.raises(ValueError, match="ml_tails"):
        PairwiseOptions(estimator_options=(("ml_tails", "laplace"),))
    with pytest.raises(InputError, match="set by the pipeline"):
        PairwiseOptions(estimator_options=(("seed", 3),))


def test_two_view_passes_the_options_and_keys_the_cache_by_them(tmp_path):
    sc = make_scene(200, "normal", "pinhole", 0.5, 0.3, 4)
    gauss = PairwiseOptions(use_scores=False, estimator_options=(("ml_tails", "gauss"),))
    a = two_view(sc.u1, sc.u2, sc.K, sc.K, gauss, 0, tmp_path)
    ref = estimate_relative_pose(sc.u1, sc.u2, sc.K, sc.K, seed=0, ml_tails="gauss")
    np.testing.assert_array_equal(a.R, ref.R)
    b = two_view(sc.u1, sc.u2, sc.K, sc.K, PairwiseOptions(use_scores=False), 0, tmp_path)  # the default: its own entry
    default = estimate_relative_pose(sc.u1, sc.u2, sc.K, sc.K, seed=0, max_iterations=PAIRWISE_MAX_ITERATIONS)
    np.testing.assert_array_equal(b.R, default.R)
    assert len(list((tmp_path / "twoview").iterdir())) == 2


def test_the_pairwise_stage_caps_the_default_method_at_colmaps_trials(monkeypatch):
    """The default method runs at PAIRWISE_MAX_ITERATIONS (10000) in the pairwise stage unless
    estimator_options sets max_iterations; other methods keep their own (their max_iterations means
    something else: GNC-RANSAC's 50 samples of 30)."""
    import poseonly.sfm.pairwise as pw

    seen: list[dict] = []
    real = pw.estimate_relative_pose

    def spy(*args, **kw):
        seen.append(kw)
        return real(*args, **kw)

    monkeypatch.setattr(pw, "estimate_relative_pose", spy)
    sc = make_scene(60, "normal", "pinhole", 0.2, 0.3, 7)
    two_view(sc.u1, sc.u2, sc.K, sc.K, PairwiseOptions(use_scores=False), 0, None)
    two_view(sc.u1, sc.u2, sc.K, sc.K, PairwiseOptions(use_scores=False, estimator_options=(("max_iterations", 123),)), 0, None)
    two_view(sc.u1, sc.u2, sc.K, sc.K, PairwiseOptions(use_scores=False, method="gnc-ransac"), 0, None)
    assert PAIRWISE_MAX_ITERATIONS == 10000
    assert [kw.get("max_iterations") for kw in seen] == [10000, 123, None]


def test_two_view_passes_the_noise_scales_unless_turned_off(tmp_path):
    rng = np.random.default_rng(5)
    sc = make_scene(200, "normal", "pinhole", 0.0, 0.3, 5)
    c = np.exp(rng.uniform(0.0, np.log(8.0), sc.n))
    u1 = sc.u1 + 0.15 * c[:, None] * rng.normal(size=sc.u1.shape)
    u2 = sc.u2 + 0.15 * c[:, None] * rng.normal(size=sc.u2.shape)
    on = two_view(u1, u2, sc.K, sc.K, PairwiseOptions(use_scores=False), 0, tmp_path, noise_scales=c)
    off = two_view(u1, u2, sc.K, sc.K, PairwiseOptions(use_scores=False, use_noise_scales=False), 0, tmp_path, noise_scales=c)
    with_scales = estimate_relative_pose(u1, u2, sc.K, sc.K, seed=0, noise_scales=c)
    without = estimate_relative_pose(u1, u2, sc.K, sc.K, seed=0)
    np.testing.assert_allclose(on.R, with_scales.R, atol=1e-12)
    np.testing.assert_allclose(off.R, without.R, atol=1e-12)
    assert not np.allclose(on.R, off.R, atol=1e-9)
    assert len(list((tmp_path / "twoview").glob("*.npz"))) == 2  # two cache entries, not one


def _corrupt_npz_entries(good: dict[str, np.ndarray], wrong_type: dict[str, np.ndarray] | None = None):
    """Writers of a corrupt cache entry: truncated, garbage, empty, a missing field and (with
    ``wrong_type``, for a reader that converts its fields) a field of the wrong type."""

    def truncated(f):
        data = f.read_bytes()
        f.write_bytes(data[: len(data) // 2])

    def missing(f):
        np.savez(f, **dict(list(good.items())[1:]))

    out = [
        truncated,  # zipfile.BadZipFile
        lambda f: f.write_bytes(b"not an npz"),  # ValueError
        lambda f: f.write_bytes(b""),  # EOFError
        missing,  # KeyError
    ]
    if wrong_type is not None:
        out.append(lambda f: np.savez(f, **(good | wrong_type)))  # TypeError
    return out


def test_a_corrupt_two_view_cache_entry_is_recomputed(tmp_path, monkeypatch):
    import poseonly.sfm.pairwise as pw

    calls: list[int] = []
    real = pw.estimate_relative_pose
    monkeypatch.setattr(pw, "estimate_relative_pose", lambda *a, **k: calls.append(1) or real(*a, **k))
    sc = make_scene(80, "normal", "pinhole", 0.5, 0.2, 3)
    opt = PairwiseOptions(use_scores=False)
    a = two_view(sc.u1, sc.u2, sc.K, sc.K, opt, 0, tmp_path)
    (entry,) = (tmp_path / "twoview").glob("*.npz")
    assert two_view(sc.u1, sc.u2, sc.K, sc.K, opt, 0, tmp_path).num_inliers == a.num_inliers and len(calls) == 1  # served from the cache
    good = dict(np.load(entry))
    for k, corrupt in enumerate(_corrupt_npz_entries(good, {"num_inliers": np.array([1, 2])})):
        corrupt(entry)
        b = two_view(sc.u1, sc.u2, sc.K, sc.K, opt, 0, tmp_path)
        assert len(calls) == 2 + k
        np.testing.assert_array_equal(a.R, b.R)
        assert (a.num_inliers, a.status) == (b.num_inliers, b.status)
        np.testing.assert_array_equal(np.load(entry)["R"], a.R)  # rewritten


def test_a_corrupt_match_cache_entry_is_recomputed(tmp_path, monkeypatch):
    pytest.importorskip("cv2")
    import poseonly.sfm.pairwise as pw
    from poseonly.demo_data import load_demo_pair

    demo = load_demo_pair()
    calls: list[int] = []
    real = pw.match_features
    monkeypatch.setattr(pw, "match_features", lambda *a, **k: calls.append(1) or real(*a, **k))
    opt = PairwiseOptions(max_features=300)
    images = [demo.image1, demo.image2]
    ref = pw.image_view_graph(images, demo.K1, options=opt, cache_dir=tmp_path)
    (entry,) = (tmp_path / "matches").glob("*.npz")
    pw.image_view_graph(images, demo.K1, options=opt, cache_dir=tmp_path)
    assert len(calls) == 1  # served from the cache
    good = dict(np.load(entry))
    for k, corrupt in enumerate(_corrupt_npz_entries(good)):
        corrupt(entry)
        g = pw.image_view_graph(images, demo.K1, options=opt, cache_dir=tmp_path)
        assert len(calls) == 2 + k
        assert g.pair_stats == ref.pair_stats
        np.testing.assert_array_equal(np.load(entry)["idx"], good["idx"])  # rewritten


def test_pairwise_seeds_stay_in_the_cores_range():
    """A base seed near 2**64 is kept exactly (it went through float64: 2**64 - 1 became 2**64, and every
    pair then failed after features and matching) and the per-pair seeds wrap modulo 2**64."""
    from poseonly.geometry import InputError
    from poseonly.sfm.pairwise import PairwiseOptions, pair_seed

    o = PairwiseOptions(seed=2**64 - 1)
    assert o.seed == 2**64 - 1
    assert pair_seed(o.seed, 0, 1, 4) == 2**64 - 1 and pair_seed(o.seed, 0, 2, 4) == 0
    with pytest.raises(InputError, match=r"\[0, 2\*\*64\)"):
        PairwiseOptions(seed=2**64)
