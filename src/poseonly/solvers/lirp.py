"""LiRP: the linear six-point relative pose solver (Section 5, Algorithm 1).

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

from dataclasses import dataclass, field
from itertools import product

import numpy as np

from ..geometry import check_correspondences
from ..identify import identify_poses, select_candidate

__all__ = ["lirp", "lirp_batch", "LiRPResult", "lirp_candidates"]

NUM_CANDIDATES = 18

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


def _null_space3(A: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Singular values ``(h, 9)`` and ``q1, q2, q3`` as rows ``(h, 3, 9)`` of stacked ``A (h, n, 9)``."""
    h, n, _ = A.shape
    if n < 9:
        A = np.concatenate([A, np.zeros((h, 9 - n, 9))], axis=1)
    elif n > 9:
        A = np.linalg.qr(A, mode="r")
    _, s, Vt = np.linalg.svd(A)
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


def lirp_candidates(f1: np.ndarray, f2: np.ndarray, w: np.ndarray | None = None) -> dict[str, np.ndarray]:
    """The 18 candidate essential matrices of Alg. 1 for stacked problems.

    ``f1, f2 (h, n, 3)`` unit bearings, ``w (h, n)`` or ``None``. Returns a dict with ``E (h, 18, 3,
    3)`` (unit Frobenius norm), ``singular_values (h, 9)``, ``d_min`` and ``d_min_C2 (h,)``.
    """
    h, n, _ = f1.shape
    A = (f1[..., :, None] * f2[..., None, :]).reshape(h, n, 9)
    if w is not None:
        A = A * w[..., None]
    s, q = _null_space3(A)
    Q = _mat(q)  # (h, 3, 3, 3): Q1, Q2, Q3
    # Demazure: T[i,j,k] = 2 Qi Qj^T Qk - tr(Qi Qj^T) Qk, summed into the 10 monomials
    P = np.einsum("hiab,hjcb->hijac", Q, Q)
    tr = np.einsum("hijaa->hij", P)
    T = 2.0 * np.einsum("hijac,hkcd->hijkad", P, Q) - tr[:, :, :, None, None, None] * Q[:, None, None, :, :, :]
    B = np.einsum("hijkad,ijkm->hadm", T, _G).reshape(h, 9, 10)
    M = np.linalg.pinv(B[:, :, :4]) @ B[:, :, 4:]  # (h, 4, 6)
    C1 = np.concatenate([-M[:, 0:3], np.broadcast_to(_C1_UNIT, (h, 3, 6))], axis=1)
    C2 = np.concatenate([-M[:, 1:4], np.broadcast_to(_C2_UNIT, (h, 3, 6))], axis=1)
    lam, G = np.linalg.eig(np.stack([C1, C2], axis=1))  # (h, 2, 6), (h, 2, 6, 6)
    g = np.swapaxes(G, -1, -2).reshape(h, 12, 6)  # eigenvectors as rows
    g6c = np.conj(g[..., 5])
    ca = np.real(g[..., 3] * g6c)
    cb = np.real(g[..., 4] * g6c)
    cc = np.abs(g[..., 5]) ** 2
    qs = ca[..., None] * q[:, None, 0] + cb[..., None] * q[:, None, 1] + cc[..., None] * q[:, None, 2]
    # case 2: det(a Q1 + Q2) = d3 a^3 + d2 a^2 + d1 a + d0
    d3 = np.linalg.det(Q[:, 0])
    d0 = np.linalg.det(Q[:, 1])
    sp = np.linalg.det(Q[:, 0] + Q[:, 1])
    sm = np.linalg.det(Q[:, 1] - Q[:, 0])
    d2 = 0.5 * (sp + sm) - d0
    d1 = 0.5 * (sp - sm) - d3
    use_a = np.abs(d3) >= np.abs(d0)
    roots = _cubic_roots(np.where(use_a, d3, d0), np.where(use_a, d2, d1), np.where(use_a, d1, d2), np.where(use_a, d0, d3))
    r = np.real(roots)  # (h, 3)
    ua = use_a[:, None]
    ca2 = np.where(ua, r, 1.0)
    cb2 = np.where(ua, 1.0, r)
    qd = ca2[..., None] * q[:, None, 0] + cb2[..., None] * q[:, None, 1]
    cand = np.concatenate([qs, qd, q], axis=1)  # (h, 18, 9)
    nrm = np.linalg.norm(cand, axis=-1, keepdims=True)
    cand = np.where(nrm > 0, cand / np.where(nrm > 0, nrm, 1.0), q[:, None, 2])
    return {
        "E": _mat(cand),
        "singular_values": s,
        "d_min": _pairwise_min_gap(lam[:, 0]),
        "d_min_C2": _pairwise_min_gap(lam[:, 1]),
    }


def lirp_batch(f1: np.ndarray, f2: np.ndarray, w: np.ndarray | None = None) -> dict[str, np.ndarray]:
    """Weighted LiRP on ``h`` stacked problems (no validation; the hot path of the robust loops).

    Returns a dict with ``R (h, 3, 3)``, ``t (h, 3)``, ``E (h, 3, 3)``, ``best (h,)`` and the
    per-candidate arrays ``cand_E``, ``cand_R``, ``cand_t``, ``cand_valid``, ``cand_cost`` plus the
    diagnostics of :func:`lirp_candidates`.
    """
    out = lirp_candidates(f1, f2, w)
    R, t, valid, _ = identify_poses(out["E"], f1, f2, w)
    cost, best = select_candidate(R, t, valid, f1, f2, w)
    idx = np.arange(len(best))
    out.update(
        cand_E=out.pop("E"),
        cand_R=R,
        cand_t=t,
        cand_valid=valid,
        cand_cost=cost,
        best=best,
        R=R[idx, best],
        t=t[idx, best],
    )
    out["E"] = out["cand_E"][idx, best]
    return out


@dataclass
class LiRPResult:
    """Result of :func:`lirp`.

    ``R, t``: the identified pose (``X2 = R X1 + t``, unit ``t``); ``E``: its candidate essential
    matrix; ``candidates_E/R/t``: all 18 candidates (order: 12 action-matrix, 3 det-cubic, q1, q2,
    q3), ``candidate_valid`` (pose-only depth conditions), ``candidate_cost`` (weighted mean PPO);
    ``d_min``: Table 2 indicator for ``C1`` (``d_min_C2`` for ``C2``); ``singular_values`` of ``A``;
    ``rank``: numerical rank of ``A`` (8 general, 6 planar or pure rotation, < 6 degenerate);
    ``status``: ``"ok"`` or ``"degenerate"`` (rank < 6: the null space is larger than 3-D and the
    pose is not determined by the data).
    """

    R: np.ndarray
    t: np.ndarray
    E: np.ndarray
    candidates_E: np.ndarray
    candidates_R: np.ndarray
    candidates_t: np.ndarray
    candidate_valid: np.ndarray
    candidate_cost: np.ndarray
    best: int
    d_min: float
    d_min_C2: float
    singular_values: np.ndarray
    rank: int
    status: str
    notes: list[str] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        return self.status == "ok"


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
