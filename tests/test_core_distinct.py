"""The core's repeated-match groups and local translation support (src/core/neighbours.cpp) against
their numpy references (tests/reference/neighbours.py): the same indices and masks, exactly."""

from __future__ import annotations

import numpy as np
import pytest

from poseonly import _core
from poseonly.analysis import LOCAL_SUPPORT_K, LOCAL_SUPPORT_MIN, _locally_supported
from poseonly.sim import make_scene
from poseonly.status import distinct_rows
from reference import neighbours as ref_nb


def _unit(x: np.ndarray) -> np.ndarray:
    return x / np.linalg.norm(x, axis=1, keepdims=True)


def _with_repeats(n: int, seed: int, tol: float) -> tuple[np.ndarray, np.ndarray]:
    """``n`` matches, then exact copies, near copies (within and beyond ``tol`` in one or both views) and
    chains of near copies (a group connected through intermediate matches), shuffled."""
    rng = np.random.default_rng(seed)
    sc = make_scene(n, camera="pinhole", noise_px=0.5, outlier_fraction=0.3, seed=seed)
    f1, f2 = sc.f1.copy(), sc.f2.copy()
    pick = rng.integers(0, n, 40)
    jit = lambda a, s: _unit(a + rng.normal(0.0, s, a.shape))  # noqa: E731
    parts1, parts2 = [f1, f1[pick[:10]]], [f2, f2[pick[:10]]]  # exact copies
    parts1.append(jit(f1[pick[10:20]], 0.2 * tol))  # near copies in both views
    parts2.append(jit(f2[pick[10:20]], 0.2 * tol))
    parts1.append(jit(f1[pick[20:30]], 0.2 * tol))  # near in view 1 only
    parts2.append(jit(f2[pick[20:30]], 20.0 * tol))
    # chains: each link within tol of the previous one, the ends farther apart than tol
    for c in pick[30:40]:
        a, b = f1[c], f2[c]
        d1, d2 = _unit(rng.normal(size=(1, 3)))[0], _unit(rng.normal(size=(1, 3)))[0]
        steps = np.arange(1, 5)[:, None] * 0.7 * tol
        parts1.append(_unit(a + steps * d1))
        parts2.append(_unit(b + steps * d2))
    g1, g2 = np.concatenate(parts1), np.concatenate(parts2)
    order = rng.permutation(len(g1))
    return np.ascontiguousarray(g1[order]), np.ascontiguousarray(g2[order])


@pytest.mark.parametrize("seed", range(6))
@pytest.mark.parametrize("tol", [0.0, 1e-4, 1e-3])
def test_distinct_matches_equal_the_reference(seed, tol):
    g1, g2 = _with_repeats(150 + 50 * seed, seed, max(tol, 1e-4))
    a, b = distinct_rows(g1, g2, tol), ref_nb.distinct_rows(g1, g2, tol)
    assert (a is None) == (b is None)
    assert a is not None  # the exact copies are always there
    np.testing.assert_array_equal(a, b)
    assert a.dtype == np.int64 and np.all(np.diff(a) > 0)


def test_distinct_matches_edge_cases():
    sc = make_scene(30, seed=1)
    assert distinct_rows(sc.f1, sc.f2, 1e-3) is None  # all distinct
    one = np.ascontiguousarray(np.repeat(sc.f1[:1], 5, axis=0)), np.ascontiguousarray(np.repeat(sc.f2[:1], 5, axis=0))
    np.testing.assert_array_equal(distinct_rows(*one, 0.0), [0])
    assert distinct_rows(sc.f1[:0], sc.f2[:0], 1e-3) is None
    # -0.0 and 0.0 differ bit for bit (as numpy's unique on the rows' bytes): not an exact repeat, a near one
    z1 = np.array([[0.0, 0.0, 1.0], [-0.0, 0.0, 1.0]])
    z2 = np.array([[0.0, 0.6, 0.8], [0.0, 0.6, 0.8]])
    assert distinct_rows(z1, z2, 0.0) is None and ref_nb.distinct_rows(z1, z2, 0.0) is None
    np.testing.assert_array_equal(distinct_rows(z1, z2, 1e-6), [0])
    # a dense cluster: every match a near copy of every other (the reference's k-d tree path)
    rng = np.random.default_rng(0)
    c1 = _unit(np.array([0.1, 0.2, 1.0]) + rng.normal(0.0, 1e-6, (300, 3)))
    c2 = _unit(np.array([-0.1, 0.0, 1.0]) + rng.normal(0.0, 1e-6, (300, 3)))
    np.testing.assert_array_equal(distinct_rows(c1, c2, 1e-4), ref_nb.distinct_rows(c1, c2, 1e-4))
    with pytest.raises(ValueError, match="tol"):
        _core.distinct_matches(sc.f1, sc.f2, -1.0)
    with pytest.raises(ValueError, match="same number"):
        _core.distinct_matches(sc.f1, sc.f2[:-1], 0.0)


@pytest.mark.parametrize("seed", range(8))
def test_local_support_equals_the_reference(seed):
    rng = np.random.default_rng(seed)
    n = [5, 12, 60, 300, 800, 300, 300, 1][seed]
    sc = make_scene(n, camera="pinhole", noise_px=0.5, outlier_fraction=0.4, seed=seed)
    f1 = sc.f1.copy()
    if seed == 5 and n > 20:
        f1[10:20] = f1[0]  # one keypoint matched again: neighbours at the same bearing do not count
    extra = rng.random(n) < 0.3
    explained = rng.random(n) < [0.5, 0.0, 1.0, 0.5, 0.5, 0.7, 0.05, 0.5][seed]
    got = _locally_supported(f1, extra, explained)
    want = ref_nb.locally_supported(f1, extra, explained, LOCAL_SUPPORT_K, LOCAL_SUPPORT_MIN)
    assert got.dtype == bool
    np.testing.assert_array_equal(got, want)
    assert not np.any(got & ~extra)


def test_local_support_rejects_bad_input():
    sc = make_scene(20, seed=0)
    m = np.zeros(20, dtype=bool)
    with pytest.raises(ValueError, match="masks"):
        _core.locally_supported(sc.f1, m[:-1], m, 10, 2)
    bad = sc.f1.copy()
    bad[3, 0] = np.nan
    with pytest.raises(ValueError, match="finite"):
        _core.locally_supported(bad, m, m, 10, 2)


def test_distinct_matches_refuse_nan_and_keep_tiny_tolerances():
    sc = make_scene(30, seed=2)
    bad = sc.f1.copy()
    bad[4, 1] = np.nan
    with pytest.raises(ValueError, match="finite"):
        _core.distinct_matches(bad, sc.f2, 1e-3)
    # a pair within 1e-13 of each other in both views (the sweep's bound has a slack for the projections'
    # rounding): one group
    g1 = np.ascontiguousarray(np.vstack([sc.f1[:1], _unit(sc.f1[:1] + 3e-14)]))
    g2 = np.ascontiguousarray(np.vstack([sc.f2[:1], _unit(sc.f2[:1] - 3e-14)]))
    assert np.linalg.norm(g1[0] - g1[1]) < 1e-13 and np.linalg.norm(g2[0] - g2[1]) < 1e-13
    np.testing.assert_array_equal(distinct_rows(g1, g2, 1e-13), [0])
