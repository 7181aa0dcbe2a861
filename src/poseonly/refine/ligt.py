"""Two-view LiGT refinement (the paper's LiGTopt, Section 4 after Eq. 8) and the LiGT translation.

The LiGT constraint (Eq. 8) is ``L_i t = ([x'_i]x R x_i h_i^T + theta_i^2 [x'_i]x) t = 0`` with
``h_i^T t = ([R x_i]x x'_i)^T [x'_i]x t`` and ``theta_i = ||x'_i x R x_i||``, built from unit
bearings (``L~_i``). With ``c_i = f2_i x R f1_i`` and ``s_i = f2_i x t`` it collapses to

    ``L_i t = |c_i|^2 s_i - c_i (c_i . s_i) = theta_i^2 (I - c^_i c^_i^T) s_i``,

(``h_i^T t = -c_i . s_i``; :func:`poseonly.residuals.v_LiGT` evaluates the same vector), a
parallax-weighted reprojection error ``theta_i^2 f2_i x (z_i R f1_i + t)`` (notes section 3).

**Objective (decision).** The paper writes LiGTopt as ``argmin_(R, t) sum_i ||L~_i t||``
(un-squared norms). :func:`ligt_refine` minimises the least-squares version
``sum_i w_i ||L~_i t||^2`` over ``R in SO(3)`` and unit ``t`` (the natural Gauss-Newton/LM target,
notes section 6). Robust variants: ``loss="soft_l1"``, ``"huber"``, ``"cauchy"`` or ``"arctan"``
apply the corresponding ``scipy.optimize.least_squares`` loss to each point's squared norm
``||sqrt(w_i) L~_i t||^2 / loss_scale^2`` (grouped per point, not per component, see
:func:`poseonly.refine._common.grouped_loss`). ``loss="soft_l1"`` with a small ``loss_scale`` tends to
``2 loss_scale sum_i sqrt(w_i) ||L~_i t||``, i.e. the paper's un-squared sum.

**Normalisation (extension, not in the paper).** ``L~_i t = theta_i^2 f2_i x P_i`` with
``P_i = z_i R f1_i + t`` the LiGT point in camera 2's frame, so the paper's residual weights each
point's view-2 reprojection error by ``theta_i^2 |P_i|`` (parallax squared times distance). Measured
on the wide-angle synthetic scenes (1 px, LiRP start), the least-squares LiGTopt is on average
*slightly less* accurate in rotation than its LiRP start (mean ratio ~1.04-1.10 at n = 30, ~1.15-1.3
at n = 300; the optimiser does find the minimum: BFGS from the ground truth lands on the same pose).
``normalization="theta2"`` divides by ``theta_i^2`` (residual ``f2_i x P_i``) and
``normalization="angular"`` by ``theta_i^2 |P_i|`` (the sine of the view-2 reprojection angle); both
keep the zero set (exactness on noise-free data) and are more accurate than LiRP under noise.
Robust losses with ``"none"`` let outliers shrink their residual through ``theta_i^2`` (a rotation
that aligns an outlier's rays): in a 20 %-outlier scene (n = 100) ``soft_l1``/``huber`` ended at
~17 deg with ``"none"`` and at ~0.06 deg with ``"theta2"`` (``cauchy``/``arctan``: < 0.1 deg with
every normalisation).

**Local minima.** In planar scenes the homography twin is an exact second zero of the cost and can be
closer than 1 degree to the truth; from 5-degree starts the normalised forms occasionally stop at a
non-zero local minimum in planar scenes (``"none"`` did not in our runs).
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import least_squares

from .. import _core
from ..geometry import check_correspondences, cross, normalize
from ._common import LOSSES, RefineResult, check_pose, fix_translation_sign, grouped_loss
from ._manifold import PoseChart

__all__ = ["ligt_refine", "ligt_translation", "ligt_residual_vectors", "ligt_matrices"]


def ligt_residual_vectors(R: np.ndarray, t: np.ndarray, f1: np.ndarray, f2: np.ndarray) -> np.ndarray:
    """``L~_i t`` for every point, ``(n, 3)`` (``t`` used as given, not normalised)."""
    a = f1 @ R.T
    c = np.cross(f2, a)
    s = np.cross(f2, t)
    return np.sum(c * c, axis=1)[:, None] * s - c * np.sum(c * s, axis=1)[:, None]


def ligt_matrices(R: np.ndarray, f1: np.ndarray, f2: np.ndarray) -> np.ndarray:
    """The ``(n, 3, 3)`` LiGT matrices ``L~_i = (theta_i^2 I - c_i c_i^T) [f2_i]x`` of Eq. (8)."""
    c = np.cross(f2, f1 @ R.T)
    P = np.sum(c * c, axis=1)[:, None, None] * np.eye(3) - c[:, :, None] * c[:, None, :]
    # P [f2]x: column k of [f2]x is f2 x e_k
    F = np.cross(f2[:, None, :], np.eye(3)[None, :, :])  # (n, k, 3): row k = f2 x e_k
    return np.einsum("nij,nkj->nik", P, F)


def ligt_translation(R: np.ndarray, f1: np.ndarray, f2: np.ndarray, weights: np.ndarray | None = None) -> np.ndarray:
    """Least-squares LiGT translation for a fixed rotation (notes section 3, OpenMVG ``SolveLiGT``).

    ``t`` = unit eigenvector of ``sum_i w_i L~_i^T L~_i`` with the smallest eigenvalue, sign fixed by
    the (weighted) majority of ``h_i^T t > 0`` (OpenMVG ``IdentifySign``). Raises ``ValueError`` on
    bad input.
    """
    f1, f2, w = check_correspondences(f1, f2, weights, min_points=2)
    R, _ = check_pose(R)
    L = ligt_matrices(R, f1, f2)
    ww = np.ones(len(f1)) if w is None else w
    M = np.einsum("n,nki,nkj->ij", ww, L, L)
    _, V = np.linalg.eigh(M)
    t, _ = fix_translation_sign(R, V[:, 0], f1, f2, w)
    return t


NORMALIZATIONS = ("none", "theta2", "angular")
_CC_FLOOR = 1e-30  # theta^4 floor for the normalised residuals (zero-parallax points)


def _ligt_terms(R, t, f1, f2, normalization):
    """Per-point residual vectors of the chosen normalisation, plus the intermediates."""
    a = f1 @ R.T
    c = cross(f2, a)
    s = cross(f2, t)
    cc = np.einsum("ij,ij->i", c, c)
    cs = np.einsum("ij,ij->i", c, s)
    if normalization == "none":
        return cc[:, None] * s - c * cs[:, None], (a, c, s, cc, cs, None, None, None)
    ccf = np.maximum(cc, _CC_FLOOR)
    z = -cs / ccf  # pose-only depth h^T t / theta^2 (view 1)
    q = s + z[:, None] * c  # f2 x (z R f1 + t) = L~ t / theta^2
    if normalization == "theta2":
        return q, (a, c, s, ccf, cs, z, None, None)
    P = z[:, None] * a + t  # the LiGT point in camera 2's frame
    nP = np.maximum(np.sqrt(np.einsum("ij,ij->i", P, P)), 1e-300)
    return q / nP[:, None], (a, c, s, ccf, cs, z, P, nP)


def _residual_and_jacobian(chart: PoseChart, x: np.ndarray, f1: np.ndarray, f2: np.ndarray, sw: np.ndarray, want_jac: bool, normalization: str = "none"):
    """Stacked residuals ``(3n,)`` and their Jacobian ``(3n, 5)`` w.r.t. the chart's ``x = (w, v)``.

    Derivatives are formed per parameter block, ``[n, k, i]`` = d(component i)/d(x_k): the rotation
    block (``k < 3``) moves ``a = R f1`` (``da = -[a]x J_l dw``) and with it ``c = f2 x a``; the
    translation block (``k >= 3``) moves ``t`` (``dt = Jt dv``) and with it ``s = f2 x t``.
    """
    if not want_jac:
        R, t = chart.retract(x)
        r, _ = _ligt_terms(R, t, f1, f2, normalization)
        return (sw[:, None] * r).ravel(), None
    R, t, Jl, Jt = chart.jacobians(x)
    assert Jt is not None  # the LiGT chart always has the translation block
    r, (a, c, s, cc, cs, z, P, nP) = _ligt_terms(R, t, f1, f2, normalization)
    dA = cross(Jl.T[None, :, :], a[:, None, :])  # (n, 3, 3): -[a]x J_l, column k as row k
    dC = cross(f2[:, None, :], dA)
    dT = Jt.T  # (2, 3)
    dS = cross(f2[:, None, :], dT[None, :, :])  # (n, 2, 3)
    dcc_r = 2.0 * np.einsum("nki,ni->nk", dC, c)
    dcs_r = np.einsum("nki,ni->nk", dC, s)
    dcs_t = np.einsum("nki,ni->nk", dS, c)
    if normalization == "none":
        Jr = s[:, None, :] * dcc_r[:, :, None] - c[:, None, :] * dcs_r[:, :, None] - cs[:, None, None] * dC
        Jtr = cc[:, None, None] * dS - c[:, None, :] * dcs_t[:, :, None]
    else:
        dz_r = -dcs_r / cc[:, None] + (cs / cc**2)[:, None] * dcc_r
        dz_t = -dcs_t / cc[:, None]
        Jr = c[:, None, :] * dz_r[:, :, None] + z[:, None, None] * dC
        Jtr = dS + c[:, None, :] * dz_t[:, :, None]
        if normalization == "angular":
            dP_r = a[:, None, :] * dz_r[:, :, None] + z[:, None, None] * dA
            dP_t = a[:, None, :] * dz_t[:, :, None] + dT[None, :, :]
            q = r * nP[:, None]
            inv = 1.0 / nP
            g = inv**3
            Jr = Jr * inv[:, None, None] - q[:, None, :] * (np.einsum("nki,ni->nk", dP_r, P) * g[:, None])[:, :, None]
            Jtr = Jtr * inv[:, None, None] - q[:, None, :] * (np.einsum("nki,ni->nk", dP_t, P) * g[:, None])[:, :, None]
    J = np.concatenate([Jr, Jtr], axis=1) * sw[:, None, None]  # (n, 5, 3)
    return (sw[:, None] * r).ravel(), J.transpose(0, 2, 1).reshape(-1, 5)


_LOSS_CODE = {"linear": 0, "soft_l1": 1, "huber": 2, "cauchy": 3, "arctan": 4}
_NORM_CODE = {"none": 0, "theta2": 1, "angular": 2}


def _objective(r: np.ndarray, loss: str, scale: float) -> float:
    s = np.sum(r.reshape(-1, 3) ** 2, axis=1)
    if loss == "linear":
        return float(np.sum(s))
    return float(scale**2 * np.sum(LOSSES[loss](s / scale**2)[0]))


def ligt_refine(
    R: np.ndarray,
    t: np.ndarray,
    f1: np.ndarray,
    f2: np.ndarray,
    weights: np.ndarray | None = None,
    loss: str = "linear",
    loss_scale: float | None = None,
    max_iter: int = 50,
    tol: float = 1e-12,
    normalization: str = "none",
    solver: str = "scipy",
) -> RefineResult:
    """LiGTopt: refine ``(R, t)`` by minimising ``sum_i w_i rho(||L~_i t||^2)`` on SO(3) x S^2.

    Parameters
    ----------
    R, t : initial pose (``X2 = R X1 + t``; ``t`` any non-zero length, normalised here).
    f1, f2 : ``(n, 3)`` bearings or ``(n, 2)`` normalized image coordinates (``n >= 6``).
    weights : optional non-negative ``(n,)``; each point's residual vector is scaled by ``sqrt(w_i)``
        (so the LS cost is ``sum w_i ||L~_i t||^2``; Alg. 1 of the paper scales rows by ``w_i``,
        decision: IRLS convention here because this is a least-squares objective).
    loss : ``"linear"`` (LS, Levenberg-Marquardt ``method="lm"``) or a robust loss ``"soft_l1"``,
        ``"huber"``, ``"cauchy"``, ``"arctan"`` (``method="trf"``), applied per point (module doc).
    loss_scale : inlier scale of ``||sqrt(w_i) L~_i t||`` for robust losses (scipy ``f_scale``).
        Default (decision): ``1.4826 * median_i ||sqrt(w_i) L~_i t||`` at the start pose over the
        points with positive weight (a zero-centred MAD), at least ``1e-12``. Ignored for ``linear``.
    max_iter : cap on residual evaluations (scipy ``max_nfev``); one LM iteration costs about one.
    tol : ``ftol = xtol = gtol`` of ``least_squares`` (tight by default so an exact start stays
        exact and a perturbed start on noise-free data converges to machine precision).
    normalization : ``"none"`` (default, the paper's ``L~_i t``), ``"theta2"`` (``L~_i t / theta_i^2
        = f2_i x (z_i R f1_i + t)``) or ``"angular"`` (``L~_i t / (theta_i^2 ||z_i R f1_i + t||)``, the
        sine of the view-2 reprojection angle of the LiGT point). Not in the paper (extension, see
        the module docstring): the paper's residual weights each point by ``theta_i^2`` times its
        distance from camera 2, which measurably costs accuracy under noise; all three share the
        same zero set, so exactness on noise-free data is unchanged.
    solver : ``"scipy"`` (default: ``scipy.optimize.least_squares``, ``method="lm"`` for the linear
        loss, ``"trf"`` with the grouped robust loss otherwise) or ``"lm"``: a compact
        Levenberg-Marquardt on IRLS-weighted 5x5 normal equations (:func:`_lm`; no ``rho''`` term),
        run by the compiled core (``src/core/refine.cpp``). Same
        objective; from starts near the optimum the same minimum (tests/test_refine.py compares
        them); ~1 ms instead of ~4-6 ms per call at n ~ 200 (docs/results/speed.md), which is why
        the robust methods use it (``poseonly.api.REFINE_SOLVER``). ``max_iter`` counts cost
        evaluations for both.

    Returns
    -------
    :class:`RefineResult` with ``cost_initial`` / ``cost_final`` = ``sum_i w_i ||L~_i t||^2`` for the
    linear loss, ``loss_scale^2 sum_i rho(w_i ||L~_i t||^2 / loss_scale^2)`` otherwise; ``t`` unit with
    its sign re-fixed after the refinement by the majority of ``h_i^T t > 0`` (the objective is
    invariant to ``t -> -t``); ``info`` holds ``nfev``, ``status``, ``loss``, ``loss_scale`` and
    ``positive_depth_fraction``.

    Parameterisation: ``R = exp([w]x) R0``, ``t = normalize(t0 + B v)`` (5 parameters,
    :class:`~poseonly.refine._manifold.PoseChart`); the Jacobian is analytic and vectorized.
    """
    f1, f2, w = check_correspondences(f1, f2, weights, min_points=6)
    R0, t0 = check_pose(R, t)
    key = str(loss).lower()
    if key not in LOSSES:
        raise ValueError(f"unknown loss {loss!r}; choose one of {sorted(LOSSES)}")
    norm = str(normalization).lower()
    if norm not in NORMALIZATIONS:
        raise ValueError(f"unknown normalization {normalization!r}; choose one of {NORMALIZATIONS}")
    if int(max_iter) < 1:
        raise ValueError(f"max_iter must be >= 1, got {max_iter}")
    sw = np.ones(len(f1)) if w is None else np.sqrt(w)
    chart = PoseChart(R0, t0)
    x0 = chart.x0()
    r0, _ = _residual_and_jacobian(chart, x0, f1, f2, sw, False, norm)

    scale = 1.0
    if key != "linear":
        if loss_scale is None:
            nr = np.linalg.norm(r0.reshape(-1, 3), axis=1)
            pos = nr[sw > 0] if np.any(sw > 0) else nr
            scale = max(1.4826 * float(np.median(pos)), 1e-12)
        else:
            scale = float(loss_scale)
            if not np.isfinite(scale) or scale <= 0:
                raise ValueError(f"loss_scale must be positive, got {loss_scale}")
    cost0 = _objective(r0, key, scale)

    fun = lambda x: _residual_and_jacobian(chart, x, f1, f2, sw, False, norm)[0]  # noqa: E731
    jac = lambda x: _residual_and_jacobian(chart, x, f1, f2, sw, True, norm)[1]  # noqa: E731
    tol = max(float(tol), 2.3e-16)
    if solver not in ("scipy", "lm"):
        raise ValueError(f"unknown solver {solver!r}; choose 'scipy' or 'lm'")
    if cost0 == 0.0:
        x, nfev, njev, status, ok, msg = x0, 1, 0, 1, True, "exact start (zero residual)"
    elif solver == "lm":
        # the core's LM (src/core/refine.cpp): the same chart, losses and rules as the numpy LM kept in
        # tests/reference/ligt_lm.py (the tests compare the two)
        Rc, tc, st = _core.refine_ligt(
            R0,
            t0,
            np.ascontiguousarray(f1),
            np.ascontiguousarray(f2),
            None if w is None else np.ascontiguousarray(w, dtype=float),
            normalization=norm,
            loss=key,
            loss_scale=scale if key != "linear" else None,
            max_iterations=int(max_iter),
            tol=tol,
        )
        x = None
        nfev, njev, status = int(st["evaluations"]), int(st["iterations"]), int(st["status"])
        msg, ok = f"core LM status {status}", status > 0
    else:
        res = least_squares(
            fun,
            x0,
            jac=jac,
            method="lm" if key == "linear" else "trf",
            loss=grouped_loss(key, 3),
            f_scale=scale,
            ftol=tol,
            xtol=tol,
            gtol=tol,
            max_nfev=int(max_iter),
        )
        x, nfev, njev, status, ok, msg = res.x, int(res.nfev), int(res.njev or 0), int(res.status), bool(res.status > 0), res.message
    if x is None:  # the core's LM returned the pose itself
        R1, t1 = Rc, tc
    else:
        R1, t1_chart = chart.retract(x)
        assert t1_chart is not None  # the chart was built with t0
        t1 = t1_chart
    r1 = (sw[:, None] * _ligt_terms(R1, t1, f1, f2, norm)[0]).ravel()
    cost1 = _objective(r1, key, scale)
    if not cost1 <= cost0:  # never return a worse pose (LM/TRF only accept decreasing steps; guard)
        R1, t1, cost1, msg = R0, t0, cost0, msg + "; cost increased, start pose returned"
        ok = False
    t1, frac = fix_translation_sign(R1, normalize(t1), f1, f2, w)
    return RefineResult(
        R=R1,
        t=t1,
        cost_initial=cost0,
        cost_final=cost1,
        num_iterations=njev,
        success=ok,
        message=str(msg),
        info={"nfev": nfev, "status": status, "loss": key, "normalization": norm, "loss_scale": scale if key != "linear" else None, "positive_depth_fraction": frac},
    )
