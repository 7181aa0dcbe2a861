"""Reference of the pure-rotation test's precision check (``poseonly.analysis.parallax_ratio``) as it
was written in numpy before the core's ``parallax_ratio``: the band selection, the Cauchy-weighted
Kabsch refits by ``numpy.linalg.svd`` and the two medians by ``numpy.median``. The core must agree to
rounding (tests/test_parallax.py)."""

from __future__ import annotations

import numpy as np

from poseonly.analysis import (
    CAUCHY_C,
    CHI2_1_MEDIAN,
    EXTRA_FACTOR,
    PRECISION_BAND,
    PRECISION_IRLS,
    PRECISION_MIN_MATCHES,
    PRECISION_MIN_PARALLAX,
    ROTATION_THRESHOLD_FACTOR,
)


def kabsch(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Rotation ``R`` minimising ``sum ||b_i - R a_i||^2`` (``(m, 3)`` each)."""
    U, _, Vt = np.linalg.svd(b.T @ a)
    D = np.diag([1.0, 1.0, np.sign(np.linalg.det(U @ Vt))])
    return U @ D @ Vt


def parallax_ratio(R_rot, f1, f2, v_pose, tau, noise_floor: float = 0.0) -> tuple[float, float, np.ndarray | None]:
    """``(ratio, noise, R)`` as :func:`poseonly.analysis.parallax_ratio` documents them."""
    R_rot = np.asarray(R_rot, dtype=float)
    d0 = f1 @ R_rot.T - f2
    chord = 2.0 * np.sin(0.5 * EXTRA_FACTOR * ROTATION_THRESHOLD_FACTOR * tau)
    sel = (v_pose < PRECISION_BAND * tau) & (np.einsum("ni,ni->n", d0, d0) < chord**2)
    if np.count_nonzero(sel) < PRECISION_MIN_MATCHES:
        return float("nan"), float("nan"), None
    a, b = f1[sel], f2[sel]
    e2 = v_pose[sel] ** 2
    med_e2 = max(float(np.median(e2)), CHI2_1_MEDIAN * noise_floor**2)
    s2 = med_e2 / CHI2_1_MEDIAN
    R = R_rot
    if s2 > 0.0:
        for _ in range(PRECISION_IRLS):
            d = a @ R.T - b
            w = 1.0 / (1.0 + 0.5 * np.sum(d * d, axis=1) / (CAUCHY_C**2 * s2))
            R = kabsch(a * w[:, None], b)
    d = a @ R.T - b
    med_par = float(np.median(0.5 * np.sum(d * d, axis=1) - e2))
    if not med_par > (PRECISION_MIN_PARALLAX * tau) ** 2:
        ratio = 0.0
    elif med_e2 > 0.0:
        ratio = med_par / med_e2
    else:
        ratio = float("inf")
    return ratio, float(np.sqrt(s2)) / float(tau), R
