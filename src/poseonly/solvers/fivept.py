"""Stewenius five-point solver (Stewenius, Engels, Nister, ISPRS J. 2006), minimal and n-point.

Construction, following OpenGV's ``relative_pose::fivept_stewenius`` (``src/relative_pose/methods.cpp``)
and ``modules::fivept_stewenius_main`` (``src/relative_pose/modules/main.cpp``), written from scratch
and vectorized over stacked problems:

1. ``A`` (rows ``w_i kron(f1_i, f2_i)``); ``X, Y, Z, W`` = right singular vectors of the four
   smallest singular values (OpenGV: columns 5..8 of ``V``; ``W`` belongs to the smallest). For
   ``n = 5`` this is the exact null space ("5pt (5)"), for ``n > 5`` the least-squares 4-D subspace
   ("5pt (m)" of the paper's Table 2; notes sec. 12). OpenGV swaps the two views because it
   estimates the inverse transformation; with our convention the rows are the same numbers.
2. ``E = x X + y Y + z Z + W``. The nine Demazure cubics ``2 E E^T E - tr(E E^T) E = 0`` and
   ``det E = 0`` form the 10 x 20 template over the cubic monomials in the order

       x^3, x^2 y, x y^2, y^3, x^2 z, x y z, y^2 z, x z^2, y z^2, z^3 | x^2, x y, y^2, x z, y z, z^2, x, y, z, 1

   (this is the order that OpenGV's action matrix rows imply). The coefficients are obtained by
   polarisation (:func:`poseonly.solvers.common.demazure_cubic_tensor`, ``det_cubic_tensor``)
   rather than OpenGV's hand-expanded ``composeA``.
3. Elimination: ``G = A[:, :10]^{-1} A[:, 10:]`` (LU solve; pseudo-inverse only if a block is
   exactly singular), expressing the ten cubic monomials in the basis
   ``b = (x^2, xy, y^2, xz, yz, z^2, x, y, z, 1)``.
4. Action matrix of multiplication by ``x`` (10 x 10): rows ``-G[0, 1, 2, 4, 5, 7]`` (``x b_0..b_5``
   = ``x^3, x^2 y, x y^2, x^2 z, x y z, x z^2``) and unit rows picking ``b_0, b_1, b_3, b_6``
   (``x b_6..b_9 = x^2, xy, xz, x``) -- identical to OpenGV's ``M``. Its eigenvalues are the ``x``
   of the ten solutions; eigenvectors ``v ~ b`` give ``(x, y, z) = v[6:9] / v[9]``.
5. ``E ~ v6 X + v7 Y + v8 Z + v9 W`` (homogeneous, no division by ``v9``), normalised by the complex
   ``sqrt(sum E_ij^2)`` as OpenGV does; candidates are the real parts (OpenGV's SAC problem takes the
   real part of all ten), rescaled to unit Frobenius norm, with the sign that makes the largest
   entry positive (the complex square root's branch otherwise decides it).

``d_min = min_{i != j} |lambda_i - lambda_j|`` over the ten action-matrix eigenvalues is the
paper's Table 2 indicator (same definition as LiRP's). For noise-free planar scenes and ``n > 5`` the
true null space is 3-D, ``X`` is a spurious direction and several solutions share ``x = 0``: the
eigenvalue 0 is repeated (``d_min ~ 1e-15``) and the eigenvectors of the repeated eigenvalue mix
solutions, which degrades the pose.
"""

from __future__ import annotations

import numpy as np

from .common import (
    cubic_template,
    det_cubic_tensor,
    epipolar_rows,
    monomial_tensor,
    normalize_frobenius,
    pairwise_min_gap,
    prepare,
    right_singular,
    vec_to_mat,
)

__all__ = ["fivept", "fivept_batch", "MONOMIALS"]

MIN_POINTS = 5
REAL_TOL = 1e-8

# exponents of (x, y, z, w=1) for the 20 template columns (see the module docstring)
MONOMIALS = [
    (3, 0, 0),
    (2, 1, 0),
    (1, 2, 0),
    (0, 3, 0),
    (2, 0, 1),
    (1, 1, 1),
    (0, 2, 1),
    (1, 0, 2),
    (0, 1, 2),
    (0, 0, 3),
    (2, 0, 0),
    (1, 1, 0),
    (0, 2, 0),
    (1, 0, 1),
    (0, 1, 1),
    (0, 0, 2),
    (1, 0, 0),
    (0, 1, 0),
    (0, 0, 1),
    (0, 0, 0),
]
_G20 = monomial_tensor(4, [(a, b, c, 3 - a - b - c) for a, b, c in MONOMIALS])
_ACTION_ROWS = [0, 1, 2, 4, 5, 7]  # template rows of x * b_0 .. x * b_5
_UNIT = np.zeros((4, 10))
_UNIT[[0, 1, 2, 3], [0, 1, 3, 6]] = 1.0  # x * (x, y, z, 1) = (x^2, xy, xz, x) = b_0, b_1, b_3, b_6


def template(basis: np.ndarray) -> np.ndarray:
    """The 10 x 20 coefficient matrix of ``E = x X + y Y + z Z + W`` for ``basis (h, 4, 3, 3)`` = ``(X, Y, Z, W)``.

    Rows 0-8: the Demazure cubics (entry ``(a, b)`` -> row ``3 b + a``), row 9: ``det E``.
    """
    h = basis.shape[0]
    out = np.empty((h, 10, 20))
    out[:, :9] = cubic_template(basis, _G20)
    out[:, 9] = np.matmul(det_cubic_tensor(basis).reshape(h, 1, 64), _G20.reshape(64, 20))[:, 0]  # stacked: same rounding for any h
    return out


def fivept_batch(f1: np.ndarray, f2: np.ndarray, w: np.ndarray | None = None) -> dict:
    """Stewenius five-point on stacked problems ``f1, f2 (h, n, 3)``, ``w (h, n)``; no validation.

    Returns ``E (h, 10, 3, 3)`` (real parts, unit Frobenius norm), ``mask (h, 10)`` (all True: every
    slot holds a candidate, OpenGV style), ``is_real (h, 10)`` (eigenvalue imaginary part
    ``<= 1e-8 (1 + |lambda|)``), ``eigenvalues (h, 10)`` (complex, the ``x`` of each solution),
    ``xyz (h, 10, 3)`` (complex solutions, NaN where ``v9 = 0``), ``d_min (h,)`` and
    ``singular_values (h, 9)``.
    """
    s, Vt = right_singular(epipolar_rows(f1, f2, w))
    q = Vt[:, 5:9]  # X, Y, Z, W as rows (W smallest)
    A = template(vec_to_mat(q))
    A1, A2 = A[:, :, :10], A[:, :, 10:]
    try:
        G = np.linalg.solve(A1, A2)
    except np.linalg.LinAlgError:  # an exactly singular block somewhere in the batch
        G = np.linalg.pinv(A1) @ A2
    h = len(A)
    M = np.concatenate([-G[:, _ACTION_ROWS], np.broadcast_to(_UNIT, (h, 4, 10))], axis=1)
    lam, V = np.linalg.eig(M)  # V[:, :, j] eigenvector of lam[:, j]
    v = np.swapaxes(V, -1, -2)  # (h, 10 solutions, 10 monomials)
    Ec = np.einsum("hsk,hkn->hsn", v[..., 6:10], q.astype(complex))  # v6 X + v7 Y + v8 Z + v9 W
    nrm = np.sqrt(np.sum(Ec * Ec, axis=-1, keepdims=True))  # OpenGV's complex normalisation
    nrm = np.where(np.abs(nrm) > 1e-300, nrm, 1.0)
    E = normalize_frobenius(vec_to_mat(np.real(Ec / nrm)))
    # canonical sign (largest entry positive): OpenGV's complex normalisation leaves the sign of a
    # real solution to the branch of a complex square root, which rounding can flip
    Ef = E.reshape(h, 10, 9)
    big = np.take_along_axis(Ef, np.argmax(np.abs(Ef), axis=-1)[..., None], axis=-1)
    E = E * np.where(big < 0, -1.0, 1.0)[..., None]
    with np.errstate(divide="ignore", invalid="ignore"):
        xyz = v[..., 6:9] / v[..., 9:10]
    xyz = np.where(np.isfinite(xyz), xyz, np.nan)
    return {
        "E": E,
        "mask": np.ones((h, 10), bool),
        "is_real": np.abs(lam.imag) <= REAL_TOL * (1.0 + np.abs(lam)),
        "eigenvalues": lam,
        "xyz": xyz,
        "d_min": pairwise_min_gap(lam),
        "singular_values": s,
    }


def fivept(f1: np.ndarray, f2: np.ndarray, w: np.ndarray | None = None, return_info: bool = False, *, real_only: bool = False):
    """Stewenius five-point solver for ``n >= 5`` bearings: ``E (k, 3, 3)``, ``k <= 10``.

    ``n = 5`` is the minimal solver ("5pt (5)"); ``n > 5`` uses the least-squares 4-D subspace
    ("5pt (m)"). By default all ten candidates are returned (real parts of the complex solutions,
    unit Frobenius norm), as OpenGV's RANSAC uses them; ``real_only=True`` keeps the solutions with
    a real action-matrix eigenvalue. With ``return_info`` also returns a dict with ``d_min``
    (``min_{i != j} |lambda_i - lambda_j|`` over the action-matrix eigenvalues, the paper's Table 2
    indicator), ``eigenvalues``, ``is_real`` (of the returned candidates) and ``singular_values``.
    Raises :class:`poseonly.geometry.InputError` (``ValueError``) for fewer than 5 points.
    """
    b1, b2, ww = prepare(f1, f2, w, MIN_POINTS)
    out = fivept_batch(b1, b2, ww)
    keep = out["is_real"][0] if real_only else out["mask"][0]
    E = out["E"][0][keep]
    if not return_info:
        return E
    info = {
        "d_min": float(out["d_min"][0]),
        "eigenvalues": out["eigenvalues"][0],
        "is_real": out["is_real"][0][keep],
        "xyz": out["xyz"][0][keep],
        "singular_values": out["singular_values"][0],
    }
    return E, info
