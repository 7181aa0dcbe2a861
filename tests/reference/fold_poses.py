"""numpy reference of the cross-fit's leave-fold-out poses (``_core.ml_fold_poses``, ``src/core/refine.cpp``
``fold_poses``): Gauss-Newton on the weighted signed Sampson residuals of the other folds, the Jacobian
by central differences on the refinement chart."""

from __future__ import annotations

import numpy as np

from poseonly.refine._manifold import PoseChart

FD_STEP = 1e-7


def signed_sampson(R: np.ndarray, t: np.ndarray, f1: np.ndarray, f2: np.ndarray) -> np.ndarray:
    """``f2^T [t]x R f1 / sqrt(|t x R f1|^2 + |f2 x t|^2 - 2 num^2)`` per match (radians, signed)."""
    a = f1 @ R.T
    s = np.cross(f2, t)
    u = np.cross(t, a)
    num = np.sum(a * s, axis=1)
    den = np.sum(u * u, axis=1) + np.sum(s * s, axis=1) - 2.0 * num * num
    return num / np.sqrt(den)


def ml_weights(fit: dict, f1: np.ndarray, f2: np.ndarray, q: np.ndarray | None = None) -> np.ndarray:
    """The ML stage's last M-step weights at its fit: ``p_i q_i^2``, times the t's precision
    ``1 / (1 + q_i^2 r_i^2 / (nu s^2))`` for a finite ``nu``."""
    q2 = np.ones(len(f1)) if q is None else q * q
    w = fit["posterior"] * q2
    if np.isfinite(fit["nu"]):
        r = signed_sampson(fit["R"], fit["t"], f1, f2)
        w = w / (1.0 + q2 * r * r / (fit["nu"] * fit["sigma"] ** 2))
    return w


def fold_poses(R, t, f1, f2, w, folds: int, steps: int) -> tuple[np.ndarray, np.ndarray]:
    """``steps`` Gauss-Newton steps of ``sum_{i % folds != j} w_i r_i^2`` from ``(R, t)`` per fold ``j``."""
    chart = PoseChart(R, t)
    fold = np.arange(len(f1)) % folds
    Rs, ts = [], []
    for j in range(folds):
        tr = (fold != j) & (w > 0)
        a, b, wt = f1[tr], f2[tr], w[tr]
        x = np.zeros(5)
        for _ in range(steps):
            r = signed_sampson(*chart.retract(x), a, b)
            J = np.empty((len(a), 5))
            for k in range(5):
                e = np.zeros(5)
                e[k] = FD_STEP
                J[:, k] = (signed_sampson(*chart.retract(x + e), a, b) - signed_sampson(*chart.retract(x - e), a, b)) / (2 * FD_STEP)
            x = x - np.linalg.solve(J.T @ (wt[:, None] * J), J.T @ (wt * r))
        Rj, tj = chart.retract(x)
        Rs.append(Rj)
        ts.append(tj)
    return np.array(Rs), np.array(ts)
