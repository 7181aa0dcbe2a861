"""Reference of ``log P(Bin(n, p) >= k)`` (``poseonly.analysis.log_binom_sf``) as it was written in
numpy before the core's ``log_binom_sf``: a table of ``log j!`` by ``numpy.cumsum`` and the log-sum-exp
of the terms. The core must agree to rounding (tests/test_nfa.py)."""

from __future__ import annotations

import numpy as np


def log_binom_sf(k: int, n: int, p: float) -> float:
    if k <= 0:
        return 0.0
    if k > n:
        return -np.inf
    if p <= 0.0:
        return -np.inf
    if p >= 1.0:
        return 0.0
    lf = np.concatenate([[0.0], np.cumsum(np.log(np.arange(1, n + 1, dtype=float)))])  # log j!, j = 0..n
    j = np.arange(k, n + 1)
    terms = lf[n] - lf[j] - lf[n - j] + j * np.log(p) + (n - j) * np.log1p(-p)
    m = float(terms.max())
    return m + float(np.log(np.sum(np.exp(terms - m))))
