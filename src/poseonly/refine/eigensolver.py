"""Kneip & Lynen (ICCV 2013) eigensolver for relative pose, written in poseonly's convention.

With ``c_i(R) = f2_i x R f1_i`` the epipolar constraint reads ``t^T c_i = -f2_i^T [t]x R f1_i = 0``,
so every correspondence asks ``t`` to be orthogonal to ``c_i`` and the rotation is found by

    ``R* = argmin_R lambda_min(M(R))``,  ``M(R) = sum_i w_i c_i c_i^T``  (3 x 3),

with ``t`` the eigenvector of the smallest eigenvalue (OpenGV's ``M`` uses ``f1 x R12 f2`` in its
convention ``X1 = R12 X2 + t12``; notes section 10).

Choices (stated, they differ from OpenGV's ``eigensolver``):

* **optimiser**: OpenGV runs Eigen's numeric-difference LM on the 3-vector gradient of
  ``lambda_min`` w.r.t. the Cayley parameters (a root-finder on the gradient, which can also stop at
  saddles). Here ``lambda_min(M(R)) = min_{|t| = 1} sum_i w_i (t^T c_i)^2`` (variable projection) is
  minimised *jointly* over ``(R, t)`` with ``scipy.optimize.least_squares`` (LM, analytic
  Jacobian) on the residuals ``sqrt(w_i) t^T c_i``, in the 5-parameter chart of
  :class:`~poseonly.refine._manifold.PoseChart` (``R = exp([w]x) R0``, ``t`` on the sphere),
  starting from ``R0`` and the smallest eigenvector of ``M(R0)``. The joint minimiser is the
  eigensolver's minimiser; at the end ``t`` is recomputed as the smallest eigenvector of
  ``M(R*)`` and ``cost = lambda_min``.
* **sign of t**: majority of the pose-only depths ``h_i^T t > 0`` (as in LiGT/OpenMVG) instead of
  OpenGV's test on the first correspondence only.
* **weights**: used as given (OpenGV divides them by their L2 norm; that does not move the argmin).
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import least_squares

from ..geometry import check_correspondences
from ._common import RefineResult, check_pose, fix_translation_sign
from ._manifold import PoseChart

__all__ = ["eigensolver", "eigensolver_matrix"]


def eigensolver_matrix(R: np.ndarray, f1: np.ndarray, f2: np.ndarray, w: np.ndarray | None = None) -> np.ndarray:
    """``M(R) = sum_i w_i (f2_i x R f1_i)(f2_i x R f1_i)^T`` (3 x 3)."""
    c = np.cross(f2, f1 @ R.T)
    if w is not None:
        return np.einsum("n,ni,nj->ij", w, c, c)
    return c.T @ c


def _smallest(R, f1, f2, w):
    lam, V = np.linalg.eigh(eigensolver_matrix(R, f1, f2, w))
    return max(float(lam[0]), 0.0), V[:, 0]


def eigensolver(
    R0: np.ndarray,
    f1: np.ndarray,
    f2: np.ndarray,
    weights: np.ndarray | None = None,
    max_iter: int = 100,
    tol: float = 1e-12,
) -> RefineResult:
    """Eigensolver refinement from an initial rotation ``R0`` (module docstring for the choices).

    ``f1, f2``: ``(n, 3)`` bearings (or ``(n, 2)`` normalized coordinates), ``n >= 6``; ``weights``
    optional non-negative ``(n,)``. ``max_iter`` caps residual evaluations (scipy ``max_nfev``,
    OpenGV uses 100); ``tol`` is ``ftol = xtol = gtol``. Returns a :class:`RefineResult` with
    ``cost_initial = lambda_min(M(R0))``, ``cost_final = lambda_min(M(R))``, unit ``t`` (smallest
    eigenvector, chirality-majority sign) and ``info["eigenvalues"]`` of ``M(R)``.
    """
    f1, f2, w = check_correspondences(f1, f2, weights, min_points=6)
    R0, _ = check_pose(R0)
    if int(max_iter) < 1:
        raise ValueError(f"max_iter must be >= 1, got {max_iter}")
    sw = np.ones(len(f1)) if w is None else np.sqrt(w)
    lam0, t0 = _smallest(R0, f1, f2, w)
    chart = PoseChart(R0, t0)

    def fun(x):
        R, t = chart.retract(x)
        return sw * (np.cross(f2, f1 @ R.T) @ t)

    def jac(x):
        R, t, Jl, Jt = chart.jacobians(x)
        a = f1 @ R.T
        c = np.cross(f2, a)
        # d(t.c) = (t x f2) . da + c . dt, da = -[a]x J_l dw = -(a x J_l[:, k])
        txf2 = np.cross(t, f2)
        Jw = -np.einsum("ni,nki->nk", txf2, np.cross(a[:, None, :], Jl.T[None, :, :]))
        Jv = c @ Jt
        return sw[:, None] * np.concatenate([Jw, Jv], axis=1)

    tol = max(float(tol), 2.3e-16)
    if lam0 == 0.0:
        R1, nfev, njev, status, ok, msg = R0, 1, 0, 1, True, "exact start (zero smallest eigenvalue)"
    else:
        res = least_squares(fun, chart.x0(), jac=jac, method="lm", ftol=tol, xtol=tol, gtol=tol, max_nfev=int(max_iter))
        R1 = chart.rotation(res.x)
        nfev, njev, status, ok, msg = int(res.nfev), int(res.njev or 0), int(res.status), bool(res.status > 0), str(res.message)
    lam1, t1 = _smallest(R1, f1, f2, w)
    if not lam1 <= lam0 * (1 + 1e-12) + 1e-300:
        R1, (lam1, t1), ok, msg = R0, (lam0, t0), False, msg + "; eigenvalue increased, start rotation returned"
    t1, frac = fix_translation_sign(R1, t1, f1, f2, w)
    ev = np.linalg.eigvalsh(eigensolver_matrix(R1, f1, f2, w))
    return RefineResult(
        R=R1,
        t=t1,
        cost_initial=lam0,
        cost_final=lam1,
        num_iterations=njev,
        success=ok,
        message=msg,
        info={"nfev": nfev, "status": status, "eigenvalues": ev, "positive_depth_fraction": frac},
    )
