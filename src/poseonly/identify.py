"""Pose identification with the pose-only depth conditions and the PPO residual (Section 5).

For each candidate essential matrix the four ``(R, t)`` decompositions are reduced to one with the
pose-only inequalities of Cai et al. (2019), written as (notes section 4, derived and checked
numerically; the original definitions are not public):

* ``M1(R) = sum_i w_i sign((h_i^T t)(h'_i^T t)) / sum_i w_i`` -- independent of the sign of ``t``; the
  twisted pair ``(2 t t^T - I) R`` makes every product negative, so the rotation with the larger
  ``M1`` is kept (a tie goes to the larger raw sum of ``h h'``);
* ``M2(R, t) = sum_i w_i sign(h_i^T t) / sum_i w_i`` -- ``t`` is flipped when ``M2 < 0``.

Decision: weighted *sign counts* rather than raw sums, so a few outliers with huge depth products
cannot flip the decision, and zero-weight points (IRLS outliers) do not vote. A candidate is
``valid`` when ``M1 > 0`` and ``M2 != 0``. Candidates are ranked by the weighted mean PPO residual
``sum w_i v_PPO_i / sum w_i`` (paper: "minimizing v^PPO"; the aggregate is not specified, the weighted
mean is what makes IRLS weights matter -- notes section 14), invalid ones after every valid one.

The computation is the core's (``src/core/lirp.cpp``: an SVD-free decomposition and the depth
numerators from four bilinear forms per point); the numpy reference is ``tests/reference/identify.py``.
"""

from __future__ import annotations

import numpy as np

from . import _core
from .geometry import normalize
from .residuals import v_PPO

__all__ = ["identify_poses", "select_candidate", "identify_and_rank", "INVALID_RANK_OFFSET"]

# PPO residuals are <= 2, so adding this to an invalid candidate's cost ranks it after every valid one
INVALID_RANK_OFFSET = 10.0


def _weights_or_none(w: np.ndarray | None, n: int) -> np.ndarray | None:
    return None if w is None else np.ascontiguousarray(np.broadcast_to(np.asarray(w, dtype=float), (n,)))


def identify_and_rank(E: np.ndarray, f1: np.ndarray, f2: np.ndarray, w: np.ndarray | None = None, with_cost: bool = True) -> dict[str, np.ndarray]:
    """Identify and rank candidate essential matrices ``E (..., k, 3, 3)`` on bearings ``(..., n, 3)``.

    ``w (..., n)`` optional weights. Returns a dict with ``R (..., k, 3, 3)``, ``t (..., k, 3)``,
    ``valid``, ``M1``, and with ``with_cost`` also ``cost`` (weighted mean PPO, ``inf`` if not finite)
    ``(..., k)`` and ``best (...)``.
    """
    E = np.asarray(E, dtype=float)
    f1 = np.asarray(f1, dtype=float)
    f2 = np.asarray(f2, dtype=float)
    lead = np.broadcast_shapes(E.shape[:-3], f1.shape[:-2], f2.shape[:-2], () if w is None else np.shape(w)[:-1])
    k, n = E.shape[-3], f1.shape[-2]
    Eb = np.broadcast_to(E, lead + (k, 3, 3)).reshape(-1, k, 3, 3)
    F1 = np.broadcast_to(f1, lead + (n, 3)).reshape(-1, n, 3)
    F2 = np.broadcast_to(f2, lead + (n, 3)).reshape(-1, n, 3)
    W = None if w is None else np.broadcast_to(np.asarray(w, dtype=float), lead + (n,)).reshape(-1, n)
    H = len(Eb)
    R = np.empty((H, k, 3, 3))
    t = np.empty((H, k, 3))
    valid = np.empty((H, k), bool)
    M1 = np.empty((H, k))
    cost = np.empty((H, k))
    for i in range(H):
        o = _core.identify(np.ascontiguousarray(Eb[i]), np.ascontiguousarray(F1[i]), np.ascontiguousarray(F2[i]), None if W is None else np.ascontiguousarray(W[i]), with_cost)
        R[i], t[i], valid[i], M1[i], cost[i] = o["R"], o["t"], o["valid"].astype(bool), o["M1"], o["cost"]
    out = {"R": R.reshape(lead + (k, 3, 3)), "t": t.reshape(lead + (k, 3)), "valid": valid.reshape(lead + (k,)), "M1": M1.reshape(lead + (k,))}
    if with_cost:
        key = np.where(valid, cost, cost + INVALID_RANK_OFFSET)
        out["cost"] = cost.reshape(lead + (k,))
        out["best"] = np.argmin(key, axis=-1).reshape(lead)
    return out


def identify_poses(E: np.ndarray, f1: np.ndarray, f2: np.ndarray, w: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Reduce candidate essential matrices to one pose each.

    ``E (..., k, 3, 3)``, bearings ``f1, f2 (..., n, 3)``, weights ``w (..., n)``. Returns
    ``R (..., k, 3, 3)``, unit ``t (..., k, 3)``, ``valid (..., k)`` (M1 > 0 and M2 != 0) and the
    margin ``M1 (..., k)`` in [-1, 1].
    """
    o = identify_and_rank(E, f1, f2, w, with_cost=False)
    return o["R"], o["t"], o["valid"], o["M1"]


def select_candidate(R: np.ndarray, t: np.ndarray, valid: np.ndarray, f1: np.ndarray, f2: np.ndarray, w: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Weighted mean PPO cost ``(..., k)`` of candidate poses ``R (..., k, 3, 3)``, ``t (..., k, 3)``
    and the index ``(...)`` of the best one (invalid candidates ranked after every valid one)."""
    R = np.asarray(R, dtype=float)
    t = normalize(np.asarray(t, dtype=float))
    f1 = np.asarray(f1, dtype=float)
    f2 = np.asarray(f2, dtype=float)
    if f1.ndim == 3:  # stacked problems: poses (h, k, ...) against points (h, n, 3)
        v = v_PPO.unchecked(R, t, f1[:, None], f2[:, None])
    else:
        v = v_PPO.unchecked(R, t, f1, f2)
    if w is None:
        cost = np.mean(v, axis=-1)
    else:
        wb = np.asarray(w, dtype=float)
        if wb.ndim == 2:
            wb = wb[:, None, :]
        cost = np.sum(v * wb, axis=-1) / np.maximum(np.sum(wb, axis=-1), 1e-300)
    cost = np.where(np.isfinite(cost), cost, np.inf)
    key = np.where(valid, cost, cost + INVALID_RANK_OFFSET)
    return cost, np.argmin(key, axis=-1)
