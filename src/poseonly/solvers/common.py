"""Shared helpers of the baseline essential-matrix solvers (8pt, 7pt, 5pt, linear 6pt).

Conventions (as everywhere in :mod:`poseonly`): ``X2 = R X1 + t``, ``E = [t]x R``,
``f2^T E f1 = 0``; ``vec`` is column-major, so the epipolar row of a correspondence is
``kron(f1, f2)`` and ``row @ vec(E) = f2^T E f1`` (same as :mod:`poseonly.solvers.lirp`).

Every solver has a batched core ``*_batch(f1 (h, n, 3), f2 (h, n, 3), w (h, n) | None)`` that
returns a fixed number of candidate slots per problem plus a boolean ``mask`` of the slots that
hold a candidate (e.g. real roots); the public single-problem functions validate their input with
:func:`poseonly.geometry.check_correspondences` and return only the masked candidates.

:func:`pose_from_essentials` reduces candidates to one pose exactly the way LiRP does (pose-only
depth conditions of :func:`poseonly.identify.identify_poses`, then the weighted mean PPO residual of
:func:`poseonly.identify.select_candidate`), so that all solvers are compared on an equal footing.
"""

from __future__ import annotations

from collections.abc import Sequence
from itertools import product
from typing import Any, cast

import numpy as np

from ..geometry import check_correspondences
from ..identify import INVALID_RANK_OFFSET, identify_and_rank

__all__ = [
    "epipolar_rows",
    "right_singular",
    "vec_to_mat",
    "mat_to_vec",
    "project_essential",
    "normalize_frobenius",
    "det_cubic_tensor",
    "demazure_cubic_tensor",
    "cubic_template",
    "monomial_tensor",
    "pairwise_min_gap",
    "pose_from_essentials",
    "prepare",
]


def vec_to_mat(q: np.ndarray) -> np.ndarray:
    """Column-major ``vec`` -> matrix: ``(..., 9) -> (..., 3, 3)``."""
    q = np.asarray(q)
    return np.swapaxes(q.reshape(q.shape[:-1] + (3, 3)), -1, -2)


def pairwise_min_gap(lam: np.ndarray) -> np.ndarray:
    """``min_{i != j} |lam_i - lam_j|`` over the last axis: ``(..., k) -> (...)``."""
    d = np.abs(lam[..., :, None] - lam[..., None, :])
    k = lam.shape[-1]
    d[..., np.arange(k), np.arange(k)] = np.inf
    return d.min(axis=(-1, -2))


def right_singular(A: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Singular values ``(h, 9)`` (descending) and right singular vectors as rows ``Vt (h, 9, 9)``
    of stacked ``A (h, n, 9)``: zero rows appended for ``n < 9``, the 9x9 ``R`` factor of a QR for
    ``n > 9`` (same right singular vectors without forming ``A^T A``). ``Vt[:, 9 - k:]`` is the
    ``k``-dimensional (least-squares) null space, the last row belonging to the smallest value."""
    h, n, _ = A.shape
    if n < 9:
        A = np.concatenate([A, np.zeros((h, 9 - n, 9))], axis=1)
    elif n > 9:
        A = cast(np.ndarray, np.linalg.qr(A, mode="r"))  # numpy's stub types every mode as QRResult; "r" returns R only
    _, s, Vt = np.linalg.svd(A)
    return s, Vt


def mat_to_vec(M: np.ndarray) -> np.ndarray:
    """Matrix -> column-major ``vec``: ``(..., 3, 3) -> (..., 9)`` (inverse of :func:`vec_to_mat`)."""
    M = np.asarray(M)
    return np.swapaxes(M, -1, -2).reshape(M.shape[:-2] + (9,))


def prepare(f1: np.ndarray, f2: np.ndarray, w: np.ndarray | None, min_points: int) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """Validate one correspondence set (``f1, f2 (n, 3)`` bearings, ``w (n,)`` or None) and add the
    batch axis: ``(1, n, 3), (1, n, 3), (1, n) | None``.

    Raises :class:`poseonly.geometry.InputError` (a ``ValueError``) for bad shapes, NaN/inf, zero
    vectors, negative weights or fewer than ``min_points`` (positively weighted) correspondences.
    """
    b1, b2, ww = check_correspondences(f1, f2, w, min_points=min_points)
    return b1[None], b2[None], None if ww is None else ww[None]


def epipolar_rows(f1: np.ndarray, f2: np.ndarray, w: np.ndarray | None = None) -> np.ndarray:
    """Rows ``w_i kron(f1_i, f2_i)`` of the epipolar system ``A vec(E) = 0``: ``(..., n, 3) -> (..., n, 9)``.

    Rows are scaled by ``w_i`` (not ``sqrt(w_i)``), the convention of the paper's Alg. 1 and of
    :mod:`poseonly.solvers.lirp`, so weighted baselines and weighted LiRP solve the same LS problem.
    """
    A = (f1[..., :, None] * f2[..., None, :]).reshape(f1.shape[:-1] + (9,))
    if w is not None:
        A = A * w[..., None]
    return A


def normalize_frobenius(E: np.ndarray) -> np.ndarray:
    """Scale ``(..., 3, 3)`` matrices to unit Frobenius norm (zero matrices stay zero)."""
    nrm = np.linalg.norm(E, axis=(-2, -1), keepdims=True)
    return E / np.where(nrm > 0, nrm, 1.0)


def project_essential(E: np.ndarray) -> np.ndarray:
    """Nearest essential matrix in Frobenius norm, scaled to unit norm: ``U diag(1, 1, 0) V^T / sqrt(2)``.

    Hartley & Zisserman, Result 11.1 / Sec. 11.7.3 ("enforce the internal constraint": replace the
    singular values by ``((s1 + s2) / 2, (s1 + s2) / 2, 0)``; the common scale is irrelevant).
    """
    U, _, Vt = np.linalg.svd(np.asarray(E, dtype=float))
    return (U * np.array([1.0, 1.0, 0.0]) / np.sqrt(2.0)) @ Vt


def monomial_tensor(nvar: int, monomials: Sequence[tuple[int, ...]]) -> np.ndarray:
    """Map ordered index triples ``(i, j, k)`` of ``nvar`` coefficients to cubic monomials.

    With ``E(c) = sum_i c_i E_i`` every cubic matrix expression is ``sum_{ijk} c_i c_j c_k T_ijk``;
    the returned ``G (nvar, nvar, nvar, m)`` has ``G[i, j, k, m] = 1`` when ``c_i c_j c_k`` is
    monomial ``m``. ``monomials`` lists exponent tuples of length ``nvar`` (summing to 3).
    """
    index = {tuple(e): m for m, e in enumerate(monomials)}
    G = np.zeros((nvar, nvar, nvar, len(monomials)))
    for i, j, k in product(range(nvar), repeat=3):
        e = [0] * nvar
        for v in (i, j, k):
            e[v] += 1
        G[i, j, k, index[tuple(e)]] += 1.0
    return G


def det_cubic_tensor(B: np.ndarray) -> np.ndarray:
    """Polarised determinant ``D[..., i, j, k] = B_i[0] . (B_j[1] x B_k[2])`` for ``B (..., m, 3, 3)``.

    ``det(sum_i c_i B_i) = sum_{ijk} c_i c_j c_k D_ijk`` (the determinant is linear in each row).
    Written as one cross product and one matrix product (no einsum: docs/speed_notes.md).
    """
    B = np.asarray(B, dtype=float)
    m = B.shape[-3]
    b1 = B[..., :, None, 1, :]
    b2 = B[..., None, :, 2, :]
    cr = np.stack(
        [b1[..., 1] * b2[..., 2] - b1[..., 2] * b2[..., 1], b1[..., 2] * b2[..., 0] - b1[..., 0] * b2[..., 2], b1[..., 0] * b2[..., 1] - b1[..., 1] * b2[..., 0]], axis=-1
    )  # (..., m, m, 3): B_j[1] x B_k[2]
    D = np.matmul(B[..., :, 0, :], np.swapaxes(cr.reshape(cr.shape[:-3] + (m * m, 3)), -1, -2))
    return D.reshape(D.shape[:-2] + (m, m, m))


def demazure_cubic_tensor(B: np.ndarray) -> np.ndarray:
    """Polarised Demazure cubics ``T[..., i, j, k] = 2 B_i B_j^T B_k - tr(B_i B_j^T) B_k`` ``(..., m, m, m, 3, 3)``.

    ``2 E E^T E - tr(E E^T) E = sum_{ijk} c_i c_j c_k T_ijk`` for ``E = sum_i c_i B_i``; the nine
    entries vanish exactly on the essential matrices (Demazure 1988; Faugeras & Maybank 1990).
    Two broadcast matrix products (einsum with three operands was the hot spot of the 5-point
    solver, docs/speed_notes.md).
    """
    B = np.asarray(B, dtype=float)
    P = np.matmul(B[..., :, None, :, :], np.swapaxes(B, -1, -2)[..., None, :, :, :])  # (..., m, m, 3, 3)
    Bf = B.reshape(B.shape[:-2] + (9,))
    tr = np.matmul(Bf, np.swapaxes(Bf, -1, -2))  # (..., m, m): tr(B_i B_j^T)
    Bk = B[..., None, None, :, :, :]
    return 2.0 * np.matmul(P[..., :, :, None, :, :], Bk) - tr[..., :, :, None, None, None] * Bk


def cubic_template(B: np.ndarray, G: np.ndarray) -> np.ndarray:
    """The nine Demazure cubics of ``E = sum_i c_i B_i`` over the monomials of ``G (m, m, m, M)``:
    ``(..., 9, M)``, row ``3 b + a`` for the entry ``(a, b)`` (:func:`monomial_tensor`)."""
    T = demazure_cubic_tensor(B)
    m = B.shape[-3]
    lead = T.shape[:-5]
    Tt = np.swapaxes(T, -1, -2).reshape(lead + (m**3, 9))  # index 3 b + a
    return np.matmul(np.swapaxes(Tt, -1, -2), G.reshape(m**3, -1))


def pose_from_essentials(
    E_cands: np.ndarray,
    f1: np.ndarray,
    f2: np.ndarray,
    w: np.ndarray | None = None,
    mask: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray, dict]:
    """Choose one pose among candidate essential matrices, exactly as LiRP does.

    Each candidate is reduced to one ``(R, t)`` with the pose-only depth conditions (``M1 > 0``,
    ``M2 > 0``; :func:`poseonly.identify.identify_and_rank`) and ranked by the weighted mean PPO
    residual ( candidates failing the depth conditions
    rank after all valid ones). ``f1, f2, w`` are the correspondences used for this choice: they
    may be a superset of the points the candidates were computed from (e.g. OpenGV's 5 + 3 scheme).

    Shapes: ``E_cands (k, 3, 3)`` with ``f (n, 3)``, or stacked ``E_cands (h, k, 3, 3)`` with
    ``f (h, n, 3)``; ``mask (k,)`` / ``(h, k)`` marks the slots that hold a candidate (default all).
    Returns ``R (3, 3)``, unit ``t (3,)`` (or stacked) and ``info`` with ``best`` (index into the
    slots, ``-1`` when there is no candidate, in which case ``R, t`` are NaN), ``E`` (the chosen
    candidate), ``cand_R``, ``cand_t``, ``cand_valid``, ``cand_cost`` (``inf`` for masked slots).
    """
    E = np.asarray(E_cands, dtype=float)
    f1 = np.asarray(f1, dtype=float)
    f2 = np.asarray(f2, dtype=float)
    single = E.ndim == 3
    if single:
        E, f1, f2 = E[None], f1[None], f2[None]
        w = None if w is None else np.asarray(w, dtype=float)[None]
        mask = None if mask is None else np.asarray(mask, bool)[None]
    h, k = E.shape[:2]
    if mask is None:
        mask = np.ones((h, k), bool)
    if k == 0:
        R = np.full((h, 3, 3), np.nan)
        t = np.full((h, 3), np.nan)
        info: dict[str, Any] = dict(
            best=np.full(h, -1),
            E=np.full((h, 3, 3), np.nan),
            cand_R=np.zeros((h, 0, 3, 3)),
            cand_t=np.zeros((h, 0, 3)),
            cand_valid=np.zeros((h, 0), bool),
            cand_cost=np.zeros((h, 0)),
        )
    else:
        # a slot whose E is not finite or zero has no pose (it was zeroed and identified as diag(0, 0, 1),
        # not a rotation: a review)
        mask = mask & np.isfinite(E).all(axis=(-2, -1)) & (np.abs(np.where(np.isfinite(E), E, 0.0)).max(axis=(-2, -1)) > 0)
        Es = np.where(mask[..., None, None], E, np.eye(3))  # harmless filler for empty slots
        Es = np.where(np.isfinite(Es), Es, 0.0)
        o = identify_and_rank(Es, f1, f2, w)
        R, t, valid = o["R"], o["t"], o["valid"]
        cost = np.where(mask, o["cost"], np.inf)
        key = np.where(valid, cost, cost + INVALID_RANK_OFFSET)
        best = np.argmin(key, axis=-1)
        none = ~np.any(mask, axis=-1)
        idx = np.arange(h)
        Rb = np.where(none[:, None, None], np.nan, R[idx, best])
        tb = np.where(none[:, None], np.nan, t[idx, best])
        info = dict(best=np.where(none, -1, best), E=np.where(none[:, None, None], np.nan, E[idx, best]), cand_R=R, cand_t=t, cand_valid=valid & mask, cand_cost=cost)
        R, t = Rb, tb
    if single:
        info = {key: (val[0] if isinstance(val, np.ndarray) else val) for key, val in info.items()}
        info["best"] = int(info["best"])
        return R[0], t[0], info
    return R, t, info
