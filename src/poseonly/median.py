"""The median of a 1-D sample, as :func:`numpy.median` computes it, without its per-call overhead.

``numpy.median`` costs ~15-25 us on the few hundred values of one image pair (argument handling,
``_median_nancheck``, a ``mean`` of the two middle values); the status analysis and the ML stage take
several medians per pair, all under the GIL. :func:`median` does the same partition (the two middle
positions and the last, where a NaN would be placed) and the same arithmetic (``(a + b) / 2``), so it
returns the same float, bit for bit (``tests/test_median.py``).
"""

from __future__ import annotations

import numpy as np

__all__ = ["median"]


def median(x: np.ndarray) -> float:
    """Median of the values of ``x`` (any shape, flattened; float64): ``nan`` if one is NaN or if
    ``x`` is empty (numpy also warns there); the mean of the two middle values for an even count."""
    a = np.asarray(x, dtype=float).reshape(-1)
    n = a.size
    if n == 0:
        return float("nan")
    k = n // 2
    p = np.partition(a, (k - 1, k, n - 1) if n % 2 == 0 else (k, n - 1))
    if np.isnan(p[n - 1]):
        return float("nan")
    return float(p[k]) if n % 2 else (float(p[k - 1]) + float(p[k])) / 2.0  # Python floats: IEEE doubles, no warning
