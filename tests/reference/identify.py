"""numpy reference (oracle for tests) of the core's pose identification: pose identification with the pose-only depth conditions and the PPO residual (Section 5).

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

Speed (docs/speed_notes.md). Everything per point is a *scalar* function of four bilinear forms,
so one small matrix product per problem replaces the per-point cross products:

* decomposition without an SVD per candidate: with ``v3`` the right singular vector of the smallest
  singular value (eigenvector of ``E^T E``), ``u3 = cof(E) v3 / |cof(E) v3|`` is the matching left
  one (oriented so that ``E = U diag(s1, s2, s3') V^T`` with ``det U = det V = 1``), the proper polar
  factor is ``O = (E - [u3]x E [v3]x - s3' u3 v3^T) / (s1 + s2) + u3 v3^T`` and the two rotations
  are ``R = u3 v3^T +- F`` with ``F = [u3]x O`` (``U W V^T`` and ``U W^T V^T``; ``t = +-u3``). Equal
  to the SVD route to ~1e-14 (measured); which of the pair is called "a" differs, which only
  matters for the tie ``M1(a) = M1(b)``, i.e. for an invalid candidate;
* with ``a = R f1``, ``b = f2`` and unit ``t``: ``ab = b.a = u3.f2 v3.f1 +- f2^T F f1``,
  ``bt = u3.f2``, ``at = t.R f1 = v3.f1`` (``R^T u3 = v3`` for both rotations) and
  ``e = f2^T [t]x R f1 = -+ f2^T E' f1`` with ``E' = O - u3 v3^T``; then
  ``h^T t = ab bt - at`` and ``h'^T t = bt - at ab`` (Lagrange identity);
* ``v_PPO = 2 sin(phi / 2)`` with ``phi`` the angle between ``eps = |t x b| a + |b x a| t`` and ``b``:
  ``eps.b = alpha ab + beta bt`` and ``|eps x b| = 2 alpha beta sin(gamma / 2)`` with
  ``gamma = atan2(|e|, h)`` (``alpha = |t x b|``, ``beta = |b x a|``, ``h^2 + e^2 = alpha^2 beta^2``),
  evaluated with half-angle formulas that keep full accuracy near zero (the residual of an exact
  fit stays ~1e-16).

All four forms of every candidate come from one ``(4k x 15) @ (15 x n)`` product with the per-point
data ``[f2 f1^T (9), f1, f2]`` (:func:`point_data`, reusable across IRLS iterations). An optional
compiled kernel (numba, :mod:`poseonly._kernels`) does the same computation point by point.
"""

from __future__ import annotations

import numpy as np

from poseonly.geometry import essential_frames

__all__ = ["identify_poses", "select_candidate", "identify_and_rank", "point_data", "ppo_from_forms"]


def point_data(f1: np.ndarray, f2: np.ndarray) -> np.ndarray:
    """Per-point data ``(..., 15, n)``: rows ``f2_i f1_j`` (index ``3 i + j``), ``f1``, ``f2``.

    ``D[..., :9, :]^T @ M.reshape(9) = f2^T M f1`` for every point.
    """
    f1 = np.asarray(f1, dtype=float)
    f2 = np.asarray(f2, dtype=float)
    f1t = np.swapaxes(f1, -1, -2)
    f2t = np.swapaxes(f2, -1, -2)
    kr = (f2t[..., :, None, :] * f1t[..., None, :, :]).reshape(f1t.shape[:-2] + (9, f1t.shape[-1]))
    return np.concatenate([kr, f1t, f2t], axis=-2)


def ppo_from_forms(ab: np.ndarray, bt: np.ndarray, h: np.ndarray, e_abs: np.ndarray) -> np.ndarray:
    """``v_PPO`` from ``ab = f2.R f1``, ``bt = t.f2``, ``h = h^T t`` and ``|e| = |f2^T [t]x R f1|`` (unit ``t``).

    With ``alpha = |t x f2|``, ``beta = |f2 x R f1|`` (so ``h^2 + e^2 = alpha^2 beta^2``):
    ``|eps x f2|^2 = 2 alpha^2 beta^2 (1 - cos gamma)``, ``eps . f2 = alpha ab + beta bt`` and
    ``v = sqrt(2 (1 - cos phi))``, both ``1 - cos`` by the half-angle forms that avoid cancellation.
    Four square roots and two divisions per point. Equal to :func:`poseonly.residuals.v_PPO` to
    ~1e-15 absolute (module docstring).
    """
    alpha = np.sqrt(np.maximum((1.0 - bt) * (1.0 + bt), 0.0))  # |t x f2|
    beta = np.sqrt(np.maximum((1.0 - ab) * (1.0 + ab), 0.0))  # |f2 x R f1|
    p = alpha * ab + beta * bt  # eps . f2
    rho = alpha * beta
    pos = h > 0.0
    rho_ok = rho > 0.0
    rho1 = np.where(rho_ok, rho, 1.0)
    # 1 - cos(gamma), gamma = atan2(|e|, h), without cancellation
    omc = np.where(pos, e_abs * e_abs, rho1 - h) / np.where(pos, rho1 * (rho1 + h), rho1)
    q2 = 2.0 * rho * rho * np.where(rho_ok, omc, 0.0)  # |eps x f2|^2
    r = np.sqrt(p * p + q2)  # |eps|
    r_ok = r > 0.0
    r1 = np.where(r_ok, r, 1.0)
    ppos = p > 0.0
    omc2 = np.where(ppos, q2, r1 - p) / np.where(ppos, r1 * (r1 + p), r1)
    return np.where(r_ok, np.sqrt(2.0 * omc2), 1.0)  # eps = 0: normalize(eps) = 0, |0 - f2| = 1


def _wmean(x: np.ndarray, w: np.ndarray | None, wsum: np.ndarray | None) -> np.ndarray:
    """Weighted mean over the last axis; ``x (H, ..., n)``, ``w (H, n)``, ``wsum (H,)``."""
    if w is None:
        return np.mean(x, axis=-1)
    H = x.shape[0]
    flat = x.reshape(H, -1, x.shape[-1])
    s = np.matmul(flat, w[:, :, None])[..., 0].reshape(x.shape[:-1])
    return s / wsum.reshape((H,) + (1,) * (x.ndim - 2))


def _flatten_batch(E, f1, f2, w):
    """Broadcast the leading dimensions and flatten them: ``E (H,k,3,3)``, ``f (H,n,3)``, ``w (H,n)``."""
    E = np.asarray(E, dtype=float)
    f1 = np.asarray(f1, dtype=float)
    f2 = np.asarray(f2, dtype=float)
    lead = np.broadcast_shapes(E.shape[:-3], f1.shape[:-2], f2.shape[:-2], () if w is None else np.shape(w)[:-1])
    k, n = E.shape[-3], f1.shape[-2]
    E = np.broadcast_to(E, lead + E.shape[-3:]).reshape(-1, k, 3, 3)
    f1 = np.broadcast_to(f1, lead + (n, 3)).reshape(-1, n, 3)
    f2 = np.broadcast_to(f2, lead + (n, 3)).reshape(-1, n, 3)
    if w is not None:
        w = np.broadcast_to(np.asarray(w, dtype=float), lead + (n,)).reshape(-1, n)
    return lead, E, f1, f2, w


def _rank_numpy(E, D, w, with_cost=True):
    """Core of :func:`identify_and_rank` on flat arrays ``E (H,k,3,3)``, ``D (H,15,n)``, ``w (H,n) | None``."""
    H, k = E.shape[:2]
    u3, v3, F, Ep = essential_frames(E)
    C = np.zeros((H, 4, k, 15))
    C[:, 0, :, :9] = F.reshape(H, k, 9)
    C[:, 1, :, :9] = Ep.reshape(H, k, 9)
    C[:, 2, :, 9:12] = v3
    C[:, 3, :, 12:15] = u3
    X = np.matmul(C.reshape(H, 4 * k, 15), D).reshape(H, 4, k, -1)
    x, e, at, bt = X[:, 0], X[:, 1], X[:, 2], X[:, 3]
    base = bt * at
    ab = np.stack([base + x, base - x], axis=1)  # (H, 2, k, n): rotation a, rotation b
    h = ab * bt[:, None] - at[:, None]
    hp = bt[:, None] - at[:, None] * ab
    wsum = None if w is None else np.maximum(np.sum(w, axis=-1), 1e-300)
    hhp = h * hp
    m1 = _wmean(np.sign(hhp), w, wsum)  # (H, 2, k)
    # tie (both rotations equally often in front): the larger raw sum of h h' decides
    raw = _wmean(hhp, w, wsum)
    pick_b = (m1[:, 1] > m1[:, 0]) | ((m1[:, 1] == m1[:, 0]) & (raw[:, 1] > raw[:, 0]))
    M1 = np.where(pick_b, m1[:, 1], m1[:, 0])
    pb = pick_b[..., None]
    hsel = np.where(pb, h[:, 1], h[:, 0])
    M2 = _wmean(np.sign(hsel), w, wsum)
    flip = M2 < 0
    sg = np.where(flip, -1.0, 1.0)
    valid = (M1 > 0) & (np.abs(M2) > 0)
    uv = u3[..., :, None] * v3[..., None, :]
    R = uv + np.where(pick_b[..., None, None], -F, F)
    t = u3 * sg[..., None]
    if not with_cost:
        return R, t, valid, M1, None
    sgn = sg[..., None]
    v = ppo_from_forms(np.where(pb, ab[:, 1], ab[:, 0]), bt * sgn, hsel * sgn, np.abs(e))
    cost = _wmean(v, w, wsum)
    return R, t, valid, M1, cost


def _kernel():
    return None


def identify_and_rank(
    E: np.ndarray,
    f1: np.ndarray,
    f2: np.ndarray,
    w: np.ndarray | None = None,
    D: np.ndarray | None = None,
    with_cost: bool = True,
) -> dict[str, np.ndarray]:
    """:func:`identify_poses` and :func:`select_candidate` in one pass (the hot path of every solver).

    ``E (..., k, 3, 3)``, bearings ``(..., n, 3)``, weights ``(..., n)``; ``D`` optional precomputed
    :func:`point_data` of ``f1, f2`` (flattened to ``(H, 15, n)``). Returns a dict with ``R (..., k,
    3, 3)``, ``t (..., k, 3)``, ``valid``, ``M1``, ``cost`` (weighted mean PPO, ``inf`` if not
    finite) ``(..., k)`` and ``best (...)`` (invalid candidates ranked after valid ones).
    """
    kern = _kernel()
    if kern is not None and E.ndim == 4 and f1.ndim == 3 and len(E) == len(f1) and (w is None or w.ndim == 2):
        R, t, valid, M1, cost, best = kern(E, f1, f2, w, with_cost)  # the hot path: already flat
        out = {"R": R, "t": t, "valid": valid, "M1": M1}
        if with_cost:
            out["cost"], out["best"] = cost, best
        return out
    lead, E, f1, f2, w = _flatten_batch(E, f1, f2, w)
    H, k = E.shape[:2]
    if kern is not None:
        R, t, valid, M1, cost, _ = kern(E, f1, f2, w, with_cost)
    else:
        if D is None:
            D = point_data(f1, f2)
        else:
            D = np.asarray(D, dtype=float).reshape(H, 15, -1)
        R, t, valid, M1, cost = _rank_numpy(E, D, w, with_cost)
    out = {"R": R.reshape(lead + (k, 3, 3)), "t": t.reshape(lead + (k, 3)), "valid": valid.reshape(lead + (k,)), "M1": M1.reshape(lead + (k,))}
    if with_cost:
        cost = np.where(np.isfinite(cost), cost, np.inf)
        key = np.where(valid, cost, cost + 10.0)  # PPO residual <= 2, so +10 ranks invalid last
        out["cost"] = cost.reshape(lead + (k,))
        out["best"] = np.argmin(key, axis=-1).reshape(lead)
    return out


def identify_poses(E: np.ndarray, f1: np.ndarray, f2: np.ndarray, w: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Reduce candidate essential matrices to one pose each.

    Parameters: ``E (..., k, 3, 3)``, bearings ``f1, f2 (..., n, 3)``, weights ``w (..., n)``.
    Returns ``R (..., k, 3, 3)``, unit ``t (..., k, 3)``, ``valid (..., k)`` (M1 > 0 and M2 > 0) and
    the margin ``M1 (..., k)`` normalised to [-1, 1].
    """
    o = identify_and_rank(E, f1, f2, w, with_cost=False)
    return o["R"], o["t"], o["valid"], o["M1"]


def select_candidate(R: np.ndarray, t: np.ndarray, valid: np.ndarray, f1: np.ndarray, f2: np.ndarray, w: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Weighted-mean PPO cost of every candidate and the index of the best one.

    Invalid candidates (failing the depth conditions) are ranked after every valid one. Returns
    ``cost (..., k)`` and ``best (...)``.
    """
    R = np.asarray(R, dtype=float)
    t = np.asarray(t, dtype=float)
    nt = np.linalg.norm(t, axis=-1, keepdims=True)
    t = t / np.where(nt > 0, nt, 1.0)
    lead, Rf, f1f, f2f, wf = _flatten_batch(R, f1, f2, w)
    H, k = Rf.shape[:2]
    tf = np.broadcast_to(t, lead + (k, 3)).reshape(H, k, 3)
    D = point_data(f1f, f2f)
    tx = np.zeros((H, k, 3, 3))
    tx[..., 0, 1], tx[..., 0, 2], tx[..., 1, 2] = -tf[..., 2], tf[..., 1], -tf[..., 0]
    tx[..., 1, 0], tx[..., 2, 0], tx[..., 2, 1] = tf[..., 2], -tf[..., 1], tf[..., 0]
    C = np.zeros((H, 4, k, 15))
    C[:, 0, :, :9] = Rf.reshape(H, k, 9)
    C[:, 1, :, :9] = np.matmul(tx, Rf).reshape(H, k, 9)
    C[:, 2, :, 9:12] = np.matmul(np.swapaxes(Rf, -1, -2), tf[..., None])[..., 0]
    C[:, 3, :, 12:15] = tf
    X = np.matmul(C.reshape(H, 4 * k, 15), D).reshape(H, 4, k, -1)
    ab, e, at, bt = X[:, 0], X[:, 1], X[:, 2], X[:, 3]
    v = ppo_from_forms(ab, bt, ab * bt - at, np.abs(e))
    wsum = None if wf is None else np.maximum(np.sum(wf, axis=-1), 1e-300)
    cost = _wmean(v, wf, wsum).reshape(lead + (k,))
    cost = np.where(np.isfinite(cost), cost, np.inf)
    key = np.where(valid, cost, cost + 10.0)  # PPO residual <= 2, so +10 ranks invalid last
    return cost, np.argmin(key, axis=-1)
