"""The core's bearing normalisation (``poseonly.geometry._unit_rows``, ``_core.unit_rows``) against
its numpy reference: the same unit rows on moderate, huge, tiny and mixed magnitudes, the same zero
rows rejected."""

from __future__ import annotations

import numpy as np
import pytest

from poseonly import InputError
from poseonly.geometry import _unit_rows
from reference.bearings import unit_rows as unit_rows_ref


@pytest.mark.parametrize("scale", [1.0, 1e-6, 1e140, 1e160, 1e300])
def test_unit_rows_match_the_reference(scale):
    rng = np.random.default_rng(0)
    a = rng.normal(size=(200, 3)) * scale
    np.testing.assert_allclose(_unit_rows(a, "a"), unit_rows_ref(a), rtol=1e-15, atol=1e-16)
    np.testing.assert_allclose(np.linalg.norm(_unit_rows(a, "a"), axis=1), 1.0, rtol=1e-15)


def test_mixed_magnitudes_keep_their_directions():
    rng = np.random.default_rng(1)
    d = rng.normal(size=(50, 3))
    a = d * np.where(np.arange(50) % 3 == 0, 1e300, np.where(np.arange(50) % 3 == 1, 1e-6, 1.0))[:, None]
    got = _unit_rows(a, "a")
    np.testing.assert_allclose(got, unit_rows_ref(a), rtol=1e-15, atol=1e-16)
    np.testing.assert_allclose(got, d / np.linalg.norm(d, axis=1, keepdims=True), rtol=1e-14, atol=1e-15)


@pytest.mark.parametrize("row", [[0.0, 0.0, 0.0], [1e-13, 0.0, 0.0], [1e-300, 1e-300, 0.0]])
@pytest.mark.parametrize("other", [1.0, 1e300])
def test_zero_rows_are_rejected_like_the_reference(row, other):
    a = np.array([[other, 0.5, 0.25], row, [0.0, 1.0, 0.0]])
    with pytest.raises(InputError, match="1 zero-length"):
        unit_rows_ref(a, "f1")
    with pytest.raises(InputError, match="f1 contains 1 zero-length"):
        _unit_rows(a, "f1")


def test_non_contiguous_and_integer_input():
    a = np.arange(1, 19, dtype=np.int64).reshape(6, 3)
    np.testing.assert_allclose(_unit_rows(a, "a"), unit_rows_ref(a.astype(float)), rtol=1e-15)
    b = np.asfortranarray(np.random.default_rng(2).normal(size=(7, 3)))
    np.testing.assert_allclose(_unit_rows(b, "b"), unit_rows_ref(b), rtol=1e-15)


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_non_finite_rows_are_counted_before_zero_rows(bad):
    a = np.array([[1.0, 0.5, 0.25], [bad, 0.0, 1.0], [0.0, 0.0, 0.0], [0.0, bad, bad]])
    with pytest.raises(InputError, match=r"f1 contains NaN or inf values \(2 rows, the first is row 1\)"):
        _unit_rows(a, "f1")


def test_pixels_to_rays_match_a_dense_solve():
    """``solve_intrinsics`` (back-substitution, no LAPACK call) against ``np.linalg.solve``."""
    from poseonly.geometry import check_intrinsics, solve_intrinsics

    rng = np.random.default_rng(4)
    for K in ([[2759.5, 0.0, 1520.7], [0.0, 2764.2, 1006.8], [0.0, 0.0, 1.0]], [[1520.4, 0.3, 302.3], [0.0, 1525.9, 246.9], [0.0, 0.0, 2.0]]):
        Kn = check_intrinsics(np.array(K))
        h = np.column_stack([rng.uniform(-100, 3100, (500, 2)), np.ones(500)])
        np.testing.assert_allclose(solve_intrinsics(Kn, h), np.linalg.solve(Kn, h.T).T, rtol=1e-14, atol=1e-17)
        np.testing.assert_allclose(solve_intrinsics(Kn, h[None]), solve_intrinsics(Kn, h)[None], rtol=0, atol=0)


def test_bearings_with_nan_and_a_K_report_the_nan_first():
    from poseonly.geometry import as_bearings

    a = np.array([[0.0, 0.0, 1.0], [np.nan, 0.0, 1.0], [0.1, 0.2, 1.0]])
    with pytest.raises(InputError, match="NaN or inf"):
        as_bearings(a, np.eye(3), "f1")
    with pytest.raises(InputError, match="a K was given"):
        as_bearings(np.nan_to_num(a), np.eye(3), "f1")


@pytest.mark.parametrize("scale", [1.0, 1e-3, 1e6, 1e140, 1e160])
def test_pixel_bearings_in_the_core_equal_the_numpy_path(scale):
    """``as_bearings(..., K_checked=True)`` (one core call) gives the bearings of the numpy path bit
    for bit, falls back to it for coordinates of 1e150 and more, and raises the same errors."""
    from poseonly.geometry import as_bearings, check_intrinsics

    rng = np.random.default_rng(2)
    K = check_intrinsics(np.array([[812.5, 0.3, 321.7], [0.0, 809.1, 243.2], [0.0, 0.0, 1.0]]))
    u = rng.uniform(-50, 700, size=(300, 2)) * scale
    fast = as_bearings(u, K, "x1", K_checked=True)
    slow = as_bearings(u, K, "x1")
    assert np.array_equal(fast, slow)
    bad = u.copy()
    bad[[3, 7]] = np.nan
    for checked in (True, False):
        with pytest.raises(InputError, match=r"x1 contains NaN or inf values \(2 rows, the first is row 3\)"):
            as_bearings(bad, K, "x1", K_checked=checked)
