"""The core's ``log P(Bin(n, p) >= k)`` (behind ``poseonly.analysis.log_binom_sf``, the a-contrario
tests' NFA and the sign test) against its numpy reference (tests/reference/nfa.py) and scipy."""

from __future__ import annotations

import math
import threading

import numpy as np
import pytest

from poseonly.analysis import log10_nfa, log_binom_sf
from reference.nfa import log_binom_sf as ref_log_binom_sf


@pytest.mark.parametrize("n", [1, 2, 7, 30, 300, 4266, 100000])
def test_core_matches_the_reference(n):
    rng = np.random.default_rng(n)
    for k in sorted({1, n, max(1, n // 2), *rng.integers(1, n + 1, 6).tolist()}):
        for p in (1e-300, 1e-12, 1e-4, 0.003, 0.05, 0.5, 0.9, 1.0 - 1e-12):
            got, ref = log_binom_sf(k, n, p), ref_log_binom_sf(k, n, p)
            assert math.isfinite(got) and math.isfinite(ref)
            assert abs(got - ref) <= 1e-12 * max(1.0, abs(ref)), (k, n, p, got, ref)


def test_against_scipy_and_the_edge_cases():
    stats = pytest.importorskip("scipy.stats")
    for k, n, p in ((5, 10, 0.5), (30, 300, 0.01), (200, 300, 0.2), (1, 1, 0.3)):
        assert log_binom_sf(k, n, p) == pytest.approx(float(stats.binom.logsf(k - 1, n, p)), rel=1e-10, abs=1e-12)
    assert log_binom_sf(0, 10, 0.3) == 0.0 and log_binom_sf(-3, 10, 0.3) == 0.0
    assert log_binom_sf(11, 10, 0.3) == -math.inf
    assert log_binom_sf(3, 10, 0.0) == -math.inf and log_binom_sf(3, 10, 1.0) == 0.0
    assert math.isnan(log_binom_sf(3, 10, float("nan")))
    assert log10_nfa(250, 300, 0.01, 1000, 5) < -300  # no underflow to -inf


def test_threads_share_the_table():
    """The table of log j! grows under a lock: concurrent calls of growing n (beyond any other test's,
    so the table grows while the threads run) agree with the same calls made serially afterwards."""
    cases = [(k, n, 0.01) for n in (210000, 260000, 330000, 400000) for k in (10, n // 100, n // 10)]
    out: list = [None] * 4

    def work(i: int) -> None:
        out[i] = [log_binom_sf(*c) for c in cases[i::4]]

    th = [threading.Thread(target=work, args=(i,)) for i in range(4)]
    for x in th:
        x.start()
    for x in th:
        x.join()
    serial = [log_binom_sf(*c) for c in cases]
    for i in range(4):
        assert out[i] == serial[i::4]
    assert abs(serial[-1] - ref_log_binom_sf(*cases[-1])) <= 1e-12 * abs(serial[-1])
