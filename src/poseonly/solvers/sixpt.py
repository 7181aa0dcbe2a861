"""Six-point essential-matrix solvers: Philip's linear method and Pizarro et al.'s variant.

Both start from the 3-D (least-squares for ``n > 6``) null space of the epipolar system ``A``
(rows ``w_i kron(f1_i, f2_i)``): ``q1, q2, q3`` = right singular vectors of the three smallest
singular values (``q3`` smallest), ``E = a Q1 + b Q2 + c Q3``, and the nine Demazure cubics
``2 E E^T E - tr(E E^T) E = 0`` written as a 9 x 10 linear system ``B y = 0`` in the ten cubic
monomials ``y`` of the coefficients (:func:`poseonly.solvers.common.demazure_cubic_tensor`).

:func:`sixpt_philip` -- Philip (1996), the "linear 6-point" method (notes sec. 12; also Stewenius et
al. 2006, whose MATLAB ``sixplin.m`` in the public code index does the same with ``E0 + l1 E1 +
l2 E2``): ``y`` = right singular vector of the smallest singular value of ``B`` (for general points
the essential matrices in the 3-D space are a single point, so ``B`` has a 1-D null space) and
``(a : b : c)`` is read out linearly. Decision: of the three read-outs ``a^2 (a, b, c)``,
``b^2 (a, b, c)``, ``c^2 (a, b, c)`` (the entries ``(a^3, a^2 b, a^2 c)``, ``(a b^2, b^3, b^2 c)``,
``(a c^2, b c^2, c^3)`` of ``y``) the one with the largest norm is used. ``sixplin.m`` always uses
the last one with the coefficient of the *largest*-singular-value vector fixed to 1, which divides by
~0 when the true ``E`` is ``q3`` (noise-free general scenes with ``n >= 9``); the max-norm read-out
is exact in both cases. One candidate, projected onto the essential manifold. Degeneracy: in a
planar scene the 3-D null space holds two essential matrices (the homography twin), ``B`` has a
2-D null space and the read-out mixes them (Stewenius et al. 2006; Pizarro et al. 2003).

:func:`sixpt_pizarro` -- Pizarro, Eustice, Singh (DICTA 2003). The paper text was not available
to us and the authors publish no implementation alongside it (the research notes, sec. 12, found none).
What is implemented follows a public MATLAB file found later in the code index, ``estim_E_6p.m``
(header: "Calculate E based upon 6 point algorithm. Similar to Hofmann-Wellenhof Method but using
four of the nine Demazure constraints", history "12-2002 op Created and written", "09/15/2003 rme
ryanized oscar's code"; a RANSAC caller in the same collection says "estimate the Essential matrix
using Oscar's 6-point algorithm (2, 4, or 6 solutions)"). The initials match O. Pizarro and R. M.
Eustice, so this is very likely the authors' own code, but the hosting repository could not be
identified and the file's correspondence to the published paper cannot be checked. Steps, reproduced
from that file (our own vectorized code):

1. ``Ea, Eb, Ec`` = ``q1, q2, q3``; ``E = alpha (Ea - Ec) + beta Eb + Ec``;
2. Triggs' 9 x 10 Demazure system ``N`` in the monomials of ``(x, y, z) = (alpha, beta, 1)`` in the
   order ``x^3, x^2 y, x^2 z, x y^2, x y z, x z^2, y^3, y^2 z, y z^2, z^3``;
3. "SVD 4 most relevant equations": the four right singular vectors of the *largest* singular
   values of ``N`` replace the nine equations (``cond4 = s4 / s1`` is reported);
4. reduced row echelon form on the first four columns, then the file's hand-made elimination
   (multiplying rows by ``beta`` = shifting coefficient vectors) down to a sextic in ``beta`` and a
   quintic expression ``alpha = -p(beta)``;
5. real roots only (imaginary part exactly 0, as MATLAB's ``imag(roots) == 0``), and no output when
   fewer than two roots are real (the file's ``num_of_solns > 1`` test); candidates are not projected
   (the projection is commented out in the file), only scaled to unit Frobenius norm.

In the file the candidate is then chosen by Sampson distance inside RANSAC; here, like every
baseline, by :func:`poseonly.solvers.common.pose_from_essentials`. The reduced row echelon forms are
computed with the generic pivot columns (``x^3, x^2 y, x^2, x y^2``; then ``x y^2, x y``; then
``x y, x``) that the file's hard-coded column indices presuppose. Because only four combinations of
the nine cubics are kept, the true solutions (two in a planar scene) are among the up to six roots
together with spurious ones -- the planar case works, at the price of the instability the LiRP
paper mentions.
"""

from __future__ import annotations

import numpy as np

from .common import (
    demazure_cubic_tensor,
    epipolar_rows,
    monomial_tensor,
    normalize_frobenius,
    prepare,
    project_essential,
    right_singular,
    vec_to_mat,
)

__all__ = ["sixpt_philip", "sixpt_pizarro", "sixpt_philip_batch", "sixpt_pizarro_batch"]

MIN_POINTS = 6

# Triggs' order of the cubic monomials of three coefficients (a, b, c) / (x, y, z)
_MONO3 = [(3, 0, 0), (2, 1, 0), (2, 0, 1), (1, 2, 0), (1, 1, 1), (1, 0, 2), (0, 3, 0), (0, 2, 1), (0, 1, 2), (0, 0, 3)]
_G10 = monomial_tensor(3, _MONO3)
_READOUT = np.array([[0, 1, 2], [3, 6, 7], [5, 8, 9]])  # a^2 (a,b,c), b^2 (a,b,c), c^2 (a,b,c)


def demazure_system(basis: np.ndarray) -> np.ndarray:
    """``B (h, 9, 10)``: the nine Demazure cubics of ``E = sum_i c_i basis_i`` (``basis (h, 3, 3, 3)``)
    over the monomials ``c0^3, c0^2 c1, c0^2 c2, c0 c1^2, c0 c1 c2, c0 c2^2, c1^3, c1^2 c2, c1 c2^2, c2^3``."""
    h = basis.shape[0]
    T = demazure_cubic_tensor(basis)
    return np.einsum("hijkab,ijkm->hbam", T, _G10).reshape(h, 9, 10)


# ------------------------------------------------------------------------------------------------
# Philip's linear six-point method


def sixpt_philip_batch(f1: np.ndarray, f2: np.ndarray, w: np.ndarray | None = None) -> dict:
    """Linear six-point (Philip 1996) on stacked problems ``f1, f2 (h, n, 3)``; no validation.

    Returns ``E (h, 1, 3, 3)`` (projected, unit norm), ``mask (h, 1)``, ``abc (h, 3)``,
    ``B_singular_values (h, 9)`` (the ratio ``s[8] / s[0]`` near 0 signals the planar rank loss,
    ``s[7] / s[0]`` near 0 a 2-D null space) and ``singular_values (h, 9)`` of ``A``.
    """
    s, Vt = right_singular(epipolar_rows(f1, f2, w))
    q = Vt[:, 6:9]
    B = demazure_system(vec_to_mat(q))
    _, sb, Vb = np.linalg.svd(B)  # full: Vb (h, 10, 10)
    y = Vb[:, 9]
    trip = y[:, _READOUT]  # (h, 3, 3)
    pick = np.argmax(np.linalg.norm(trip, axis=-1), axis=-1)
    abc = trip[np.arange(len(y)), pick]
    E = project_essential(vec_to_mat(np.einsum("hk,hkn->hn", abc, q)))
    h = len(E)
    return {"E": E[:, None], "mask": np.ones((h, 1), bool), "abc": abc, "B_singular_values": sb, "singular_values": s}


def sixpt_philip(f1: np.ndarray, f2: np.ndarray, w: np.ndarray | None = None, return_info: bool = False):
    """Philip's linear six-point solver for ``n >= 6`` bearings: one candidate ``E (1, 3, 3)``.

    ``f1, f2``: ``(n, 3)`` bearings (or ``(n, 2)`` normalized coordinates); ``w``: optional
    non-negative weights. With ``return_info`` also returns ``abc``, ``B_singular_values`` and
    ``singular_values``. Raises :class:`poseonly.geometry.InputError` for fewer than 6 points.
    """
    b1, b2, ww = prepare(f1, f2, w, MIN_POINTS)
    out = sixpt_philip_batch(b1, b2, ww)
    E = out["E"][0]
    if not return_info:
        return E
    return E, {k: out[k][0] for k in ("abc", "B_singular_values", "singular_values")}


# ------------------------------------------------------------------------------------------------
# Pizarro et al. (2003) six-point method, as in the public MATLAB estim_E_6p.m


def _rref_fixed(M: np.ndarray, cols: slice) -> np.ndarray:
    """Reduced row echelon form of stacked ``M (h, r, m)`` with pivots on the columns ``cols`` (``r`` of them)."""
    P = M[:, :, cols]
    try:
        return np.linalg.solve(P, M)
    except np.linalg.LinAlgError:
        return np.linalg.pinv(P) @ M


def _shift(row: np.ndarray) -> np.ndarray:
    """``[row(2:end) 0]`` of the MATLAB file: multiply a coefficient row by ``beta``."""
    return np.concatenate([row[:, 1:], np.zeros((len(row), 1))], axis=1)


def _pizarro_weights(N: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``weights_6p`` of ``estim_E_6p.m``: roots ``beta (h, 6)`` (complex), ``alpha (h, 6)`` and ``cond4 (h,)``.

    Column layouts (``x = alpha``, ``y = beta``, ``z = 1``) at each stage, as in the file's comments:
    ``As``: x^3 x^2y x^2 xy^2 xy x y^3 y^2 y 1; ``C``: x^2y x^2 xy^2 xy x y^6 .. y 1;
    ``D, E, F``: xy^2 xy x y^6 .. y 1.
    """
    h = N.shape[0]
    _, sn, Vn = np.linalg.svd(N)
    cond4 = sn[:, 3] / sn[:, 0]
    As = Vn[:, :4]  # right singular vectors of the 4 largest singular values, as rows
    Ar = _rref_fixed(As, slice(0, 4))  # pivots x^3, x^2 y, x^2, x y^2
    B = Ar[:, 1:4, 1:10]  # rows x^2y, x^2, xy^2 equations; cols x^2y x^2 xy^2 xy x y^3 y^2 y 1
    C = np.concatenate([B[..., :5], np.zeros((h, 3, 3)), B[..., 5:9]], axis=-1)  # (h, 3, 12)
    c0 = C[:, 0] - _shift(C[:, 1])  # eliminate x^2 y with beta * (x^2 equation)
    D = np.stack([c0[:, 2:12], C[:, 2, 2:12]], axis=1)  # (h, 2, 10): xy^2 xy x y^6 .. 1
    Dr = _rref_fixed(D, slice(0, 2))  # pivots xy^2, xy
    E = np.stack([Dr[:, 0] - _shift(Dr[:, 1]), Dr[:, 1]], axis=1)
    E[:, :, 0] = 0.0  # the xy^2 column is eliminated (rref zeroes negligible columns)
    Er = _rref_fixed(E, slice(1, 3))  # pivots xy, x
    F0 = Er[:, 0] - _shift(Er[:, 1])
    ypoly = F0[:, 3:10]  # y^6 .. 1
    xpoly = Er[:, 1, 4:10]  # y^5 .. 1, alpha = -xpoly(beta)
    lead = ypoly[:, 0]
    lead = np.where(lead == 0, 1e-300, lead)
    comp = np.zeros((h, 6, 6))
    comp[:, 0, :] = -ypoly[:, 1:] / lead[:, None]
    comp[:, np.arange(1, 6), np.arange(5)] = 1.0
    comp = np.where(np.isfinite(comp), comp, 0.0)
    beta = np.linalg.eigvals(comp)
    powers = beta[..., None] ** np.arange(5, -1, -1)  # (h, 6, 6)
    alpha = -np.einsum("hrk,hk->hr", powers, xpoly.astype(complex))
    return beta, alpha, cond4


def sixpt_pizarro_batch(f1: np.ndarray, f2: np.ndarray, w: np.ndarray | None = None) -> dict:
    """Pizarro et al.'s six-point (``estim_E_6p.m``) on stacked problems ``f1, f2 (h, n, 3)``; no validation.

    Returns ``E (h, 6, 3, 3)`` (six root slots, real parts, unit Frobenius norm), ``mask (h, 6)``
    (real roots, and only when at least two are real, as in the file), ``alpha_beta (h, 6, 2)``
    (complex), ``cond4 (h,)`` and ``singular_values (h, 9)`` of ``A``.
    """
    s, Vt = right_singular(epipolar_rows(f1, f2, w))
    q = Vt[:, 6:9]  # ea, eb, ec (ec smallest)
    Ea, Eb, Ec = vec_to_mat(q[:, 0]), vec_to_mat(q[:, 1]), vec_to_mat(q[:, 2])
    N = demazure_system(np.stack([Ea - Ec, Eb, Ec], axis=1))
    beta, alpha, cond4 = _pizarro_weights(N)
    real = (beta.imag == 0) & np.isfinite(beta.real) & np.isfinite(alpha.real)
    real &= (np.sum(real, axis=-1) > 1)[:, None]
    a, b = np.real(alpha), np.real(beta)
    a = np.where(np.isfinite(a), a, 0.0)
    b = np.where(np.isfinite(b), b, 0.0)
    E = a[..., None, None] * (Ea - Ec)[:, None] + b[..., None, None] * Eb[:, None] + Ec[:, None]
    return {
        "E": normalize_frobenius(E),
        "mask": real,
        "alpha_beta": np.stack([alpha, beta], axis=-1),
        "cond4": cond4,
        "singular_values": s,
    }


def sixpt_pizarro(f1: np.ndarray, f2: np.ndarray, w: np.ndarray | None = None, return_info: bool = False):
    """Pizarro et al.'s six-point solver (as in the public ``estim_E_6p.m``) for ``n >= 6`` bearings.

    Returns the candidates ``E (k, 3, 3)``, ``k`` in {0, 2, 4, 6} (real roots of the sextic), unit
    Frobenius norm. With ``return_info`` also returns ``alpha_beta`` (of the returned candidates),
    ``cond4`` and ``singular_values``. Raises :class:`poseonly.geometry.InputError` for fewer than 6
    points.
    """
    b1, b2, ww = prepare(f1, f2, w, MIN_POINTS)
    out = sixpt_pizarro_batch(b1, b2, ww)
    m = out["mask"][0]
    E = out["E"][0][m]
    if not return_info:
        return E
    return E, {"alpha_beta": out["alpha_beta"][0][m], "cond4": float(out["cond4"][0]), "singular_values": out["singular_values"][0]}
