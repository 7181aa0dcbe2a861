"""Pose identification with the pose-only depth conditions and the PPO residual (Section 5).

For each candidate essential matrix the four ``(R, t)`` decompositions are reduced to one with the
pose-only inequalities of Cai et al. (2019), written here as (notes section 4, derived and checked
numerically; the original definitions are not public):

* ``M1(R) = sum_i w_i sign((h_i^T t)(h'_i^T t))`` -- independent of the sign of ``t``; the twisted
  pair ``(2 t t^T - I) R`` makes every product negative, so the rotation with the larger ``M1`` is kept;
* ``M2(R, t) = sum_i w_i sign(h_i^T t)`` -- ``t`` is flipped when ``M2 < 0``.

Decision: weighted *sign counts* rather than raw sums, so a few outliers with huge depth products
cannot flip the decision, and zero-weight points (IRLS outliers) do not vote. A candidate is
``valid`` when ``M1 > 0`` and ``M2 > 0`` after the flip. Candidates are then ranked by the weighted
mean PPO residual ``sum w_i v_PPO_i / sum w_i`` (paper: "minimizing v^PPO"; the aggregate is not
specified, the weighted mean is what makes IRLS weights matter -- notes section 14).
"""

from __future__ import annotations

import numpy as np

from .geometry import cross, decompose_essential
from .residuals import v_PPO

__all__ = ["identify_poses", "select_candidate"]


def _depth_signs(R: np.ndarray, t: np.ndarray, f1: np.ndarray, f2: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``h^T t`` and ``h'^T t`` for ``R (..., k, 3, 3)``, ``t (..., k, 3)``, ``f (..., n, 3)`` -> ``(..., k, n)``."""
    Rf1 = np.einsum("...kij,...nj->...kni", R, f1)
    f2b = f2[..., None, :, :]
    tt = t[..., None, :]
    c = cross(Rf1, f2b)
    h = np.sum(c * cross(f2b, tt), axis=-1)
    hp = np.sum(c * cross(Rf1, tt), axis=-1)
    return h, hp


def identify_poses(
    E: np.ndarray, f1: np.ndarray, f2: np.ndarray, w: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Reduce candidate essential matrices to one pose each.

    Parameters: ``E (..., k, 3, 3)``, bearings ``f1, f2 (..., n, 3)``, weights ``w (..., n)``.
    Returns ``R (..., k, 3, 3)``, unit ``t (..., k, 3)``, ``valid (..., k)`` (M1 > 0 and M2 > 0) and
    the margin ``M1 (..., k)`` normalised to [-1, 1].
    """
    Ra, Rb, t = decompose_essential(E)
    if w is None:
        w = np.ones(f1.shape[:-1])
    wk = w[..., None, :]
    wsum = np.maximum(np.sum(w, axis=-1), 1e-300)[..., None]
    R2 = np.stack([Ra, Rb], axis=-4)  # (..., 2, k, 3, 3)
    h, hp = _depth_signs(R2, t[..., None, :, :], f1[..., None, :, :], f2[..., None, :, :])
    m1 = np.sum(wk[..., None, :, :] * np.sign(h * hp), axis=-1) / wsum[..., None, :]  # (..., 2, k)
    pick_b = m1[..., 1, :] > m1[..., 0, :]
    R = np.where(pick_b[..., None, None], Rb, Ra)
    M1 = np.where(pick_b, m1[..., 1, :], m1[..., 0, :])
    hsel = np.where(pick_b[..., None], h[..., 1, :, :], h[..., 0, :, :])
    M2 = np.sum(wk * np.sign(hsel), axis=-1) / wsum
    flip = M2 < 0
    t = np.where(flip[..., None], -t, t)
    valid = (M1 > 0) & (np.abs(M2) > 0)
    return R, t, valid, M1


def select_candidate(
    R: np.ndarray, t: np.ndarray, valid: np.ndarray, f1: np.ndarray, f2: np.ndarray, w: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Weighted-mean PPO cost of every candidate and the index of the best one.

    Invalid candidates (failing the depth conditions) are ranked after every valid one. Returns
    ``cost (..., k)`` and ``best (...)``.
    """
    v = v_PPO(R, t, f1[..., None, :, :], f2[..., None, :, :])  # (..., k, n)
    if w is None:
        cost = np.mean(v, axis=-1)
    else:
        cost = np.sum(v * w[..., None, :], axis=-1) / np.maximum(np.sum(w, axis=-1), 1e-300)[..., None]
    cost = np.where(np.isfinite(cost), cost, np.inf)
    key = np.where(valid, cost, cost + 10.0)  # PPO residual <= 2, so +10 ranks invalid last
    return cost, np.argmin(key, axis=-1)
