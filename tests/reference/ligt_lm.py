"""numpy reference (oracle for tests) of LiGTopt's compact Levenberg-Marquardt (the core's refine_ligt).

The LM rules and the chart are those of ``src/core/refine.h``; :func:`ligt_refine_numpy_lm` wraps them
as :func:`poseonly.refine.ligt.ligt_refine` does (same validation, default scale and sign fix).
"""

from __future__ import annotations

import numpy as np

from poseonly.geometry import check_correspondences, normalize
from poseonly.refine._common import LOSSES, RefineResult, check_pose, fix_translation_sign
from poseonly.refine._manifold import PoseChart
from poseonly.refine.ligt import _objective, _residual_and_jacobian


def _normal_equations_numpy(chart, x, f1, f2, sw, norm, loss, scale, want):
    """Robust cost ``scale^2 sum rho(|r_i|^2 / scale^2)`` and, when ``want``, the Gauss-Newton normal
    equations ``H = sum rho'_i J_i^T J_i``, ``g = sum rho'_i J_i^T r_i`` (IRLS form of the robust
    loss: no second-order ``rho''`` term, so ``H`` stays positive semi-definite)."""
    r, J = _residual_and_jacobian(chart, x, f1, f2, sw, want, norm)
    r = r.reshape(-1, 3)
    s2 = scale * scale
    rho, drho, _ = LOSSES[loss](np.einsum("ij,ij->i", r, r) / s2)
    cost = float(s2 * np.sum(rho))
    if not want:
        return cost, None, None
    J = J.reshape(-1, 3, 5)
    Jw = J * drho[:, None, None]
    return cost, np.einsum("nip,niq->pq", Jw, J), np.einsum("nip,ni->p", Jw, r)


def _normal_equations(chart, x, f1, f2, sw, norm, loss, scale, want=True):
    return _normal_equations_numpy(chart, x, f1, f2, sw, norm, loss, scale, want)


def _lm(chart, f1, f2, sw, norm, loss, scale, max_iter, tol):
    """Levenberg-Marquardt on the chart with IRLS-weighted robust normal equations.

    Step ``(H + lam diag(H)) dx = -g``; a step is taken only when the robust cost decreases
    (``lam / 3``), else ``lam * 10``. Stops when the relative cost decrease or the step falls below
    ``tol``, the gradient vanishes, ``lam`` explodes, or after ``max_iter`` cost evaluations.
    Returns ``(x, nfev, njev, status, message)`` with scipy's status codes (1 gtol, 2 ftol, 3 xtol,
    0 max evaluations, -1 no decreasing step).
    """
    x = chart.x0()
    F, H, g = _normal_equations(chart, x, f1, f2, sw, norm, loss, scale)
    nfev = njev = 1
    d = np.maximum(np.diag(H), 1e-300)
    lam = 1e-3
    status, msg = 0, "maximum number of cost evaluations reached"
    while nfev < max_iter:
        if not np.all(np.isfinite(g)) or np.max(np.abs(g)) <= tol * max(F, 1e-300):
            status, msg = 1, "gradient vanished (gtol)"
            break
        try:
            dx = np.linalg.solve(H + lam * np.diag(d), -g)
        except np.linalg.LinAlgError:
            lam *= 10.0
            continue
        xn = x + dx
        Fn, Hn, gn = _normal_equations(chart, xn, f1, f2, sw, norm, loss, scale)
        nfev += 1
        if np.isfinite(Fn) and Fn < F:
            dF = F - Fn
            x, F, H, g = xn, Fn, Hn, gn
            njev += 1
            d = np.maximum(d, np.diag(H))  # Marquardt scaling by the largest diagonal seen (as MINPACK)
            lam = max(lam / 3.0, 1e-15)
            if dF <= tol * F:
                status, msg = 2, "relative cost decrease below tol (ftol)"
                break
            if np.linalg.norm(dx) <= tol * (tol + np.linalg.norm(x)):
                status, msg = 3, "step below tol (xtol)"
                break
        else:
            lam *= 10.0
            if lam > 1e16:
                status, msg = -1, "no decreasing step"
                break
    return x, nfev, njev, status, msg


def ligt_refine_numpy_lm(R, t, f1, f2, weights=None, *, loss="linear", loss_scale=None, max_iter=50, tol=1e-12, normalization="none") -> RefineResult:
    """:func:`poseonly.refine.ligt.ligt_refine` with ``solver="lm"``, computed by the numpy LM above."""
    f1, f2, w = check_correspondences(f1, f2, weights, min_points=6)
    R0, t0 = check_pose(R, t)
    key, norm = loss, normalization
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
    cost0 = _objective(r0, key, scale)
    tol = max(float(tol), 2.3e-16)
    if cost0 == 0.0:
        x, nfev, njev, status, msg = x0, 1, 0, 1, "exact start"
    else:
        x, nfev, njev, status, msg = _lm(chart, f1, f2, sw, norm, key, scale, int(max_iter), tol)
    R1, t1 = chart.retract(x)
    r1, _ = _residual_and_jacobian(chart, x, f1, f2, sw, False, norm)
    cost1 = _objective(r1, key, scale)
    if not cost1 <= cost0:
        R1, t1, cost1 = R0, t0, cost0
    t1, frac = fix_translation_sign(R1, normalize(t1), f1, f2, w)
    return RefineResult(
        R=R1,
        t=t1,
        cost_initial=cost0,
        cost_final=cost1,
        num_iterations=njev,
        success=status > 0,
        message=str(msg),
        info={"nfev": nfev, "status": status, "loss": key, "normalization": norm, "loss_scale": scale, "positive_depth_fraction": frac},
    )
