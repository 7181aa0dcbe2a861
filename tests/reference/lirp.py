"""numpy reference (oracle for tests) of the core's LiRP: the linear six-point relative pose solver (Section 5, Algorithm 1).

Construction (notes section 5, every step vectorized over ``h`` stacked problems):

1. ``A_i = w_i kron(f1_i, f2_i)`` (``vec`` column-major, ``A_i q = f2^T Q f1``). Decision: rows are
   scaled by ``w_i`` as written in Alg. 1 (IRLS theory would use ``sqrt(w_i)``; with the near-binary
   GNC weights the two are indistinguishable, notes section 14).
2. ``q1, q2, q3``: right singular vectors of the three smallest singular values (``q3`` smallest).
   For ``n > 9`` the SVD is taken of the 9x9 ``R`` factor of a QR of ``A`` (same right singular
   vectors, no squaring of the condition number).
3. Case 1 (``c = 1``): the nine Demazure cubics ``2 Q Q^T Q - tr(Q Q^T) Q = 0`` of
   ``Q = a Q1 + b Q2 + Q3`` as ``B y = 0`` (Eq. 14), ``M = B1^+ B2``, the 6x6 action matrices
   ``C1 g = a g`` and ``C2 g = b g`` with ``g = (a^2, ab, b^2, a, b, 1)``: 12 candidates.
   Decision: complex eigenvectors contribute the real parts of ``a, b`` (paper silent); ``a, b`` are
   read homogeneously (``Re(g4 conj(g6)) q1 + Re(g5 conj(g6)) q2 + |g6|^2 q3``) so that ``g6 -> 0``
   cannot divide by zero.
4. Case 2 (``c = 0, b = 1``): ``det(a Q1 + Q2) = 0`` (Eq. 15), a cubic in ``a`` (or in ``1/a`` when
   its leading coefficient is the smaller one): 3 candidates.
5. ``q1, q2, q3`` themselves: 3 candidates; 18 in all.
6. Each candidate is decomposed and identified with the pose-only depth conditions and ranked by
   the weighted mean PPO residual (:mod:`poseonly.identify`).

``d_min`` is the paper's Table 2 indicator ``min_{i != j} |lambda_i - lambda_j|`` over the
eigenvalues of the action matrix ``C1`` (``d_min_C2`` for ``C2`` is reported beside it).

Exactness: the true ``E`` lies in the 3-D null space for general scenes (rank 8, ``q3``), planar
scenes and pure rotation (rank 6); in both cases one candidate is exact. In a planar scene a second
candidate (the homography twin, notes section 5) can be exact too, which PPO cannot break.
"""

from __future__ import annotations

from itertools import product

import numpy as np

from poseonly.geometry import check_correspondences
from poseonly.solvers.lirp import LiRPResult  # the result type is shared; the algorithm is the reference's own

from .identify import identify_and_rank

__all__ = ["lirp", "lirp_batch", "LiRPResult", "lirp_candidates"]

NUM_CANDIDATES = 18
# sigma_7 / sigma_1 below this: the epipolar system has an exactly 3-D null space (noise-free planar
# scene or pure rotation), whose basis - and so the non-exact candidates - any SVD picks arbitrarily
DEGENERATE_NULL = 1e-9

# monomial index of a^p b^q in y = (a^3, a^2 b, a b^2, b^3, a^2, ab, b^2, a, b, 1)
_MONO = {(3, 0): 0, (2, 1): 1, (1, 2): 2, (0, 3): 3, (2, 0): 4, (1, 1): 5, (0, 2): 6, (1, 0): 7, (0, 1): 8, (0, 0): 9}
_G = np.zeros((3, 3, 3, 10))
for _i, _j, _k in product(range(3), repeat=3):
    _G[_i, _j, _k, _MONO[((_i, _j, _k).count(0), (_i, _j, _k).count(1))]] += 1.0
# action matrices: C1 g = a g and C2 g = b g built from M (4x6); rows of e_k select g entries
_C1_UNIT = np.zeros((3, 6))
_C1_UNIT[[0, 1, 2], [0, 1, 3]] = 1.0  # rows a^2, ab, a of a*g are g0, g1, g3
_C2_UNIT = np.zeros((3, 6))
_C2_UNIT[[0, 1, 2], [1, 2, 4]] = 1.0  # rows ab, b^2, b of b*g are g1, g2, g4


def _kron_rows(f1: np.ndarray, f2: np.ndarray) -> np.ndarray:
    """Unweighted epipolar rows ``kron(f1_i, f2_i)`` ``(h, n, 9)`` (column-major ``vec``)."""
    h, n, _ = f1.shape
    return (f1[..., :, None] * f2[..., None, :]).reshape(h, n, 9)


def right_singular(A: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Singular values ``(h, 9)`` (descending) and right singular vectors as rows ``Vt (h, 9, 9)``.

    ``A (h, n, 9)``: for ``n < 9`` zero rows are appended (right singular vectors unchanged, the
    missing singular values are 0); for ``n > 9`` the SVD is taken of the 9x9 ``R`` factor of a QR
    of ``A`` (same singular values and right singular vectors without forming ``A^T A``).
    ``Vt[:, 9 - k:]`` is the ``k``-dimensional (least-squares) null space, the last row belonging to
    the smallest singular value.
    """
    h, n, _ = A.shape
    if n < 9:
        A = np.concatenate([A, np.zeros((h, 9 - n, 9))], axis=1)
    elif n > 9:
        A = np.linalg.qr(A, mode="r")
    _, s, Vt = np.linalg.svd(A)
    return s, Vt


def _null_space3(A: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Singular values ``(h, 9)`` and ``q1, q2, q3`` as rows ``(h, 3, 9)`` of stacked ``A (h, n, 9)``.

    With the compiled kernels and ``n >= 9`` the QR (``n > 9``) is compiled (:func:`poseonly._kernels.qr_r9`:
    Householder up to 64 rows, LAPACK's beyond) and the 9x9 SVD a one-sided Jacobi (:func:`poseonly._kernels.svd9`, 2x faster than LAPACK's at this size,
    as accurate); where the
    null space is exactly 3-D (``n < 9``, or ``sigma_7 <= DEGENERATE_NULL sigma_1``: noise-free planar
    scenes and pure rotation) its basis is arbitrary and LAPACK's is kept, so that those problems
    reproduce the reference code's candidates (tests/test_speed_equivalence.py)."""
    s, Vt = right_singular(A)
    return s, Vt[:, 6:9, :]


def _mat(q: np.ndarray) -> np.ndarray:
    """Column-major ``vec`` -> matrix: ``(..., 9) -> (..., 3, 3)``."""
    return np.swapaxes(q.reshape(q.shape[:-1] + (3, 3)), -1, -2)


def _pairwise_min_gap(lam: np.ndarray) -> np.ndarray:
    d = np.abs(lam[..., :, None] - lam[..., None, :])
    k = lam.shape[-1]
    d[..., np.arange(k), np.arange(k)] = np.inf
    return d.min(axis=(-1, -2))


def _cubic_roots(c3: np.ndarray, c2: np.ndarray, c1: np.ndarray, c0: np.ndarray) -> np.ndarray:
    """Roots ``(h, 3)`` (complex) of stacked cubics via companion matrices (``c3 != 0`` assumed)."""
    h = c3.shape[0]
    C = np.zeros((h, 3, 3))
    inv = 1.0 / np.where(c3 == 0, 1e-300, c3)
    C[:, 0, 0] = -c2 * inv
    C[:, 0, 1] = -c1 * inv
    C[:, 0, 2] = -c0 * inv
    C[:, 1, 0] = 1.0
    C[:, 2, 1] = 1.0
    return np.linalg.eigvals(C)


_G27 = _G.reshape(27, 10)


def _demazure_rows(Q: np.ndarray) -> np.ndarray:
    """``B (h, 9, 10)``: the nine Demazure cubics of ``a Q1 + b Q2 + c Q3`` over the monomials ``y``.

    ``T_ijk = 2 Q_i Q_j^T Q_k - tr(Q_i Q_j^T) Q_k`` (27 small products as two broadcast matmuls),
    summed into the monomials with one ``(9 x 27) @ (27 x 10)`` product per problem.
    """
    h = Q.shape[0]
    P = np.matmul(Q[:, :, None], np.swapaxes(Q, -1, -2)[:, None])  # (h, 3, 3, 3, 3): Q_i Q_j^T
    qf = Q.reshape(h, 3, 9)
    tr = np.matmul(qf, np.swapaxes(qf, -1, -2))  # tr(Q_i Q_j^T)
    T = 2.0 * np.matmul(P[:, :, :, None], Q[:, None, None]) - tr[:, :, :, None, None, None] * Q[:, None, None]
    return np.matmul(np.swapaxes(T.reshape(h, 27, 9), -1, -2), _G27)


def _action_matrices(q: np.ndarray) -> np.ndarray:
    """The two 6x6 action matrices ``C (h, 2, 6, 6)`` of the Demazure system (``q (h, 3, 9)``)."""
    h = q.shape[0]
    B = _demazure_rows(_mat(q))
    # M = B1^+ B2 through the 4x4 normal equations (B1 has full column rank in every non-degenerate case)
    BtB = np.matmul(np.swapaxes(B[:, :, :4], -1, -2), B)  # (h, 4, 10)
    try:
        M = np.linalg.solve(BtB[:, :, :4], BtB[:, :, 4:])  # (h, 4, 6)
    except np.linalg.LinAlgError:  # an exactly singular block somewhere in the batch
        M = np.linalg.pinv(B[:, :, :4]) @ B[:, :, 4:]
    C = np.zeros((h, 2, 6, 6))
    C[:, 0, :3] = -M[:, 0:3]
    C[:, 0, 3:] = _C1_UNIT
    C[:, 1, :3] = -M[:, 1:4]
    C[:, 1, 3:] = _C2_UNIT
    return C


def _case2_roots(Q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Case 2 (``c = 0``): real parts ``(h, 3)`` of the roots of ``det(a Q1 + Q2)`` (in ``a`` when
    ``use_a``, else in ``1 / a``). Kept in numpy in both code paths: for noise-free planar scenes
    the cubic vanishes identically and its roots are rounding noise, reproduced only by the same
    LAPACK calls."""
    dets = np.linalg.det(np.stack([Q[:, 0], Q[:, 1], Q[:, 0] + Q[:, 1], Q[:, 1] - Q[:, 0]], axis=1))
    d3, d0, sp, sm = dets[:, 0], dets[:, 1], dets[:, 2], dets[:, 3]
    d2 = 0.5 * (sp + sm) - d0
    d1 = 0.5 * (sp - sm) - d3
    use_a = np.abs(d3) >= np.abs(d0)
    roots = _cubic_roots(np.where(use_a, d3, d0), np.where(use_a, d2, d1), np.where(use_a, d1, d2), np.where(use_a, d0, d3))
    return np.real(roots), use_a


def _candidates_numpy(q: np.ndarray, lam: np.ndarray, G: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The 18 unit candidate vecs ``(h, 18, 9)`` and ``d_min (h, 2)`` (twin of the compiled ``lirp_post``)."""
    h = q.shape[0]
    Q = _mat(q)
    g = np.swapaxes(G, -1, -2).reshape(h, 12, 6)  # eigenvectors as rows
    g6c = np.conj(g[..., 5])
    coef = np.empty((h, 15, 3))
    coef[:, :12, 0] = np.real(g[..., 3] * g6c)
    coef[:, :12, 1] = np.real(g[..., 4] * g6c)
    coef[:, :12, 2] = np.abs(g[..., 5]) ** 2
    r, use_a = _case2_roots(Q)
    ua = use_a[:, None]
    coef[:, 12:, 0] = np.where(ua, r, 1.0)
    coef[:, 12:, 1] = np.where(ua, 1.0, r)
    coef[:, 12:, 2] = 0.0
    cand = np.concatenate([np.matmul(coef, q), q], axis=1)  # (h, 18, 9)
    nrm = np.sqrt(np.sum(cand * cand, axis=-1, keepdims=True))
    cand = np.where(nrm > 0, cand / np.where(nrm > 0, nrm, 1.0), q[:, None, 2])
    return cand, _pairwise_min_gap(lam)


def lirp_candidates(f1: np.ndarray, f2: np.ndarray, w: np.ndarray | None = None, A: np.ndarray | None = None) -> dict[str, np.ndarray]:
    """The 18 candidate essential matrices of Alg. 1 for stacked problems.

    ``f1, f2 (h, n, 3)`` unit bearings, ``w (h, n)`` or ``None``; ``A (h, n, 9)`` optional
    precomputed unweighted rows ``kron(f1_i, f2_i)``. Returns a dict with ``E (h, 18, 3, 3)`` (unit
    Frobenius norm), ``singular_values (h, 9)``, ``d_min`` and ``d_min_C2 (h,)``.
    """
    h, n, _ = f1.shape
    if A is None:
        A = _kron_rows(f1, f2)
    if w is not None:
        A = A * w[..., None]
    s, q = _null_space3(A)
    lam, G = np.linalg.eig(_action_matrices(q))
    cand, dm = _candidates_numpy(q, lam, G)
    return {
        "E": _mat(cand),
        "singular_values": s,
        "d_min": dm[:, 0],
        "d_min_C2": dm[:, 1],
    }


def lirp_batch(f1: np.ndarray, f2: np.ndarray, w: np.ndarray | None = None, *, A: np.ndarray | None = None, D: np.ndarray | None = None) -> dict[str, np.ndarray]:
    """Weighted LiRP on ``h`` stacked problems (no validation; the hot path of the robust loops).

    ``A (h, n, 9)`` (rows ``kron(f1_i, f2_i)``) and ``D (h, 15, n)``
    (:func:`poseonly.identify.point_data`) are optional precomputations that IRLS reuses across
    iterations. Returns a dict with ``R (h, 3, 3)``, ``t (h, 3)``, ``E (h, 3, 3)``, ``best (h,)``
    and the per-candidate arrays ``cand_E``, ``cand_R``, ``cand_t``, ``cand_valid``, ``cand_cost``
    plus the diagnostics of :func:`lirp_candidates`.
    """
    out = lirp_candidates(f1, f2, w, A)
    cE = out["E"]
    o = identify_and_rank(cE, f1, f2, w, D)
    best = o["best"]
    idx = np.arange(len(best))
    out.update(cand_E=cE, cand_R=o["R"], cand_t=o["t"], cand_valid=o["valid"], cand_cost=o["cost"], best=best, R=o["R"][idx, best], t=o["t"][idx, best], E=cE[idx, best])
    return out


def lirp(f1: np.ndarray, f2: np.ndarray, weights: np.ndarray | None = None, *, rank_tol: float = 1e-9) -> LiRPResult:
    """Weighted LiRP (Alg. 1) on ``n >= 6`` correspondences.

    ``f1, f2``: ``(n, 3)`` bearing vectors or ``(n, 2)`` normalized image coordinates of views 1
    and 2; ``weights``: optional non-negative ``(n,)``. Returns a :class:`LiRPResult` with the pose
    ``X2 = R X1 + t`` (unit ``t``), all 18 candidates and the ``d_min`` diagnostic. Raises
    :class:`ValueError` on bad input; degenerate-but-valid input (e.g. all points identical)
    returns ``status == "degenerate"``.
    """
    f1, f2, w = check_correspondences(f1, f2, weights, min_points=6)
    o = lirp_batch(f1[None], f2[None], None if w is None else w[None])
    s = o["singular_values"][0]
    rank = int(np.count_nonzero(s > rank_tol * max(s[0], 1e-300)))
    status = "ok" if rank >= 6 else "degenerate"
    notes = []
    if status == "degenerate":
        notes.append(f"epipolar matrix A has rank {rank} < 6: the correspondences do not determine the pose")
    return LiRPResult(
        R=o["R"][0],
        t=o["t"][0],
        E=o["E"][0],
        candidates_E=o["cand_E"][0],
        candidates_R=o["cand_R"][0],
        candidates_t=o["cand_t"][0],
        candidate_valid=o["cand_valid"][0],
        candidate_cost=o["cand_cost"][0],
        best=int(o["best"][0]),
        d_min=float(o["d_min"][0]),
        d_min_C2=float(o["d_min_C2"][0]),
        singular_values=s,
        rank=rank,
        status=status,
        notes=notes,
    )
