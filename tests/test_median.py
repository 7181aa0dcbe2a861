"""poseonly.median.median against numpy.median, bit for bit."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from poseonly.median import median


@pytest.mark.parametrize("n", [1, 2, 3, 4, 5, 10, 11, 150, 301, 1000])
def test_median_equals_numpy_bit_for_bit(n):
    rng = np.random.default_rng(n)
    for trial in range(200):
        kind = trial % 5
        if kind == 0:
            x = rng.normal(size=n)
        elif kind == 1:
            x = rng.integers(0, 4, size=n).astype(float)  # ties
        elif kind == 2:
            x = np.exp(rng.normal(0, 30, size=n))  # wide range
        elif kind == 3:
            x = rng.normal(size=n) * 1e-300  # subnormal neighbourhood
        else:
            x = np.abs(rng.normal(size=(n,))) ** 2
        ref = float(np.median(x))
        got = median(x)
        assert got == ref or (np.isnan(got) and np.isnan(ref))
        assert np.float64(got).tobytes() == np.float64(ref).tobytes()


def test_median_nan_inf_and_empty():
    assert np.isnan(median(np.array([1.0, np.nan, 2.0])))
    assert np.isnan(median(np.array([np.nan])))
    assert median(np.array([1.0, np.inf, 2.0])) == 2.0
    assert median(np.array([-np.inf, np.inf])) != median(np.array([-np.inf, np.inf]))  # nan, as numpy's
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        assert np.isnan(np.median(np.array([-np.inf, np.inf])))
    assert np.isnan(median(np.zeros(0)))
    assert median(np.array([[3.0, 1.0], [2.0, 4.0]])) == 2.5  # flattened
    x = np.array([3.0, 1.0, 2.0])
    median(x)
    assert x.tolist() == [3.0, 1.0, 2.0]  # the input is not reordered
