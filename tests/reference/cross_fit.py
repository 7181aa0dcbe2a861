"""Reference of the default's cross-fit (``poseonly.robust.default._cross_fit``) as it was written in
Python before the core's ``ml_cross_fit``: the folds' EMs by ``_core.ml_refine`` on copied subsets, the
Sampson errors by ``poseonly.residuals.v_sampson``. The core must give the same pose bit for bit
(tests/test_cross_fit.py)."""

from __future__ import annotations

import numpy as np

from poseonly import _core
from poseonly.residuals import v_sampson
from poseonly.robust.default import CF_LM_ITERATIONS, CF_POSE_TOL, CF_ROUNDS, CROSS_FIT_MIN, ML_POSE_TOL, ML_ROUNDS


def cross_fit(
    R: np.ndarray,
    t: np.ndarray,
    f1: np.ndarray,
    f2: np.ndarray,
    T: float,
    decision: float,
    student: bool,
    scales: np.ndarray | None,
    folds: int,
    tails: tuple[float, float] | None = None,
    start: tuple[float, float] | None = None,
) -> tuple[np.ndarray, np.ndarray, int] | None:
    """``_cross_fit``'s contract: ``(R, t, vetoed)`` or None."""
    n = len(f1)
    c = np.ascontiguousarray
    nu, alpha = tails if tails is not None else (None, None)
    s0, g0 = start if start is not None and np.isfinite(start[0]) and start[0] > 0.0 and 0.0 < start[1] < 1.0 else (None, None)
    fold = np.arange(n) % folds
    held_out = np.zeros(n, dtype=bool)
    for j in range(folds):
        test = fold == j
        train = ~test
        sc = None if scales is None else c(scales[train])
        m = _core.ml_refine(
            R,
            t,
            c(f1[train]),
            c(f2[train]),
            T,
            rounds=CF_ROUNDS,
            pose_tol=CF_POSE_TOL,
            lm_iterations=CF_LM_ITERATIONS,
            student=student,
            scales=sc,
            nu=nu,
            alpha=alpha,
            pose_only=True,
            sigma_init=s0,
            g_init=g0,
        )
        if not (m["rounds"] > 0 and np.all(np.isfinite(m["R"])) and np.all(np.isfinite(m["t"]))):
            return None
        held_out[test] = v_sampson(m["R"], m["t"], f1[test], f2[test]) < decision
    own = v_sampson(R, t, f1, f2) < decision
    if np.count_nonzero(own & held_out) < CROSS_FIT_MIN:
        return None
    vetoed = own & ~held_out
    n_vetoed = int(np.count_nonzero(vetoed))
    if n_vetoed == 0:
        return R, t, 0
    keep = ~vetoed
    sc = None if scales is None else c(scales[keep])
    m = _core.ml_refine(
        R, t, c(f1[keep]), c(f2[keep]), T, rounds=ML_ROUNDS, pose_tol=ML_POSE_TOL, student=student, scales=sc, nu=nu, alpha=alpha, pose_only=True, sigma_init=s0, g_init=g0
    )
    if not (m["rounds"] > 0 and np.all(np.isfinite(m["R"])) and np.all(np.isfinite(m["t"]))):
        return None
    return m["R"], m["t"], n_vetoed
