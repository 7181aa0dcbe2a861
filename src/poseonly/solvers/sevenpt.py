"""Seven-point essential-matrix solver (Hartley & Zisserman Sec. 11.1.2, applied to bearings).

1. ``F1, F2``: right singular vectors of the two smallest singular values of ``A`` (rows
   ``w_i kron(f1_i, f2_i)``; ``F2`` the smallest). For ``n = 7`` this is the exact 2-D null space,
   for ``n > 7`` the least-squares one (decision: OpenGV's ``sevenpt`` with ``n > 7`` instead
   returns only the smallest singular vector, i.e. degenerates to the 8-point method, notes sec. 10;
   we keep the cubic so that the solver stays a 7-point method for every ``n``).
2. The rank-2 condition ``det(a F1 + b F2) = 0`` is a homogeneous cubic in ``(a : b)`` (H&Z write it
   as ``det(alpha F1 + (1 - alpha) F2) = 0``, which cannot represent ``a + b = 0``; the homogeneous
   form has no such gap). Its coefficients come from the polarised determinant
   (:func:`poseonly.solvers.common.det_cubic_tensor`); roots via a companion matrix in ``a / b`` or
   ``b / a``, whichever has the larger leading coefficient.
3. Up to three real roots (``|Im| <= 1e-8 (1 + |root|)``; the real part is used), each
   ``a F1 + b F2`` projected onto the essential manifold (singular values ``(1, 1, 0)``).

Exactness: for general noise-free scenes the true ``E`` is ``F2`` for ``n > 7`` (rank 8) and a
member of the pencil for ``n = 7``; it is rank 2, so it is one of the roots. Degeneracy: planar
scenes (3-D null space: the pencil is an arbitrary 2-D slice of it).
"""

from __future__ import annotations

import numpy as np

from .common import det_cubic_tensor, epipolar_rows, prepare, project_essential, right_singular, vec_to_mat

__all__ = ["sevenpt", "sevenpt_batch"]

MIN_POINTS = 7
REAL_TOL = 1e-8


def _binary_cubic_roots(c: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Roots ``(a, b)`` of ``c0 a^3 + c1 a^2 b + c2 a b^2 + c3 b^3`` for stacked ``c (h, 4)``.

    Returns real parts ``a, b (h, 3)`` and ``is_real (h, 3)``. Solved in ``t = a / b`` when
    ``|c0| >= |c3|`` (candidates ``(t, 1)``), else in ``s = b / a`` (candidates ``(1, s)``).
    """
    h = len(c)
    use_t = np.abs(c[:, 0]) >= np.abs(c[:, 3])
    lead = np.where(use_t, c[:, 0], c[:, 3])
    p = np.where(use_t[:, None], c[:, 1:], c[:, 2::-1])  # monic coefficients after division by lead
    lead = np.where(lead == 0, 1e-300, lead)
    C = np.zeros((h, 3, 3))
    C[:, 0, :] = -p / lead[:, None]
    C[:, 1, 0] = 1.0
    C[:, 2, 1] = 1.0
    r = np.linalg.eigvals(C)
    is_real = np.abs(r.imag) <= REAL_TOL * (1.0 + np.abs(r))
    rr = r.real
    a = np.where(use_t[:, None], rr, 1.0)
    b = np.where(use_t[:, None], 1.0, rr)
    return a, b, is_real


def sevenpt_batch(f1: np.ndarray, f2: np.ndarray, w: np.ndarray | None = None) -> dict:
    """Seven-point on stacked problems ``f1, f2 (h, n, 3)``; no validation.

    Returns ``E (h, 3, 3, 3)`` (three root slots, real parts, each projected to the essential
    manifold), ``mask (h, 3)`` (real roots), ``ab (h, 3, 2)`` (the root ``(a, b)``), ``cubic (h, 4)``
    (coefficients of ``a^3, a^2 b, a b^2, b^3``) and ``singular_values (h, 9)``.
    """
    s, Vt = right_singular(epipolar_rows(f1, f2, w))
    q = Vt[:, 7:9]  # F1 (second smallest), F2 (smallest)
    D = det_cubic_tensor(vec_to_mat(q))  # (h, 2, 2, 2)
    c = np.stack(
        [D[:, 0, 0, 0], D[:, 0, 0, 1] + D[:, 0, 1, 0] + D[:, 1, 0, 0], D[:, 0, 1, 1] + D[:, 1, 0, 1] + D[:, 1, 1, 0], D[:, 1, 1, 1]],
        axis=-1,
    )
    a, b, is_real = _binary_cubic_roots(c)
    F = a[..., None] * q[:, None, 0] + b[..., None] * q[:, None, 1]  # (h, 3, 9)
    E = project_essential(vec_to_mat(F))
    return {"E": E, "mask": is_real, "ab": np.stack([a, b], axis=-1), "cubic": c, "singular_values": s}


def sevenpt(f1: np.ndarray, f2: np.ndarray, w: np.ndarray | None = None, return_info: bool = False):
    """Seven-point solver for ``n >= 7`` bearings: ``E (k, 3, 3)`` with ``k`` = number of real roots (1-3).

    ``f1, f2``: ``(n, 3)`` bearings (or ``(n, 2)`` normalized coordinates); ``w``: optional
    non-negative weights ``(n,)``. Candidates have singular values ``(1, 1, 0) / sqrt(2)``. With
    ``return_info`` also returns a dict (``ab``, ``cubic``, ``singular_values``, ``n_real``).
    Raises :class:`poseonly.geometry.InputError` (``ValueError``) for fewer than 7 points.
    """
    b1, b2, ww = prepare(f1, f2, w, MIN_POINTS)
    out = sevenpt_batch(b1, b2, ww)
    m = out["mask"][0]
    E = out["E"][0][m]
    if not return_info:
        return E
    return E, {"ab": out["ab"][0][m], "cubic": out["cubic"][0], "singular_values": out["singular_values"][0], "n_real": int(m.sum())}
