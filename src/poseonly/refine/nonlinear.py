"""OpenGV-style nonlinear relative-pose optimisation (``opengv::relative_pose::optimize_nonlinear``).

Residual per correspondence (notes section 10; :func:`poseonly.residuals.v_OpenGV` with
``symmetric=True``; the paper's ``v^OpenGV`` is the view-2 half):

    ``r_i = (1 - f1_i . r1_i) + (1 - f2_i . r2_i)``,

with ``X_i`` the midpoint triangulation of the two rays (:func:`poseonly.geometry.triangulate_midpoint`),
``r1 = X / |X|`` and ``r2 = (R X + t) / |R X + t|``. OpenGV minimises ``sum_i r_i^2`` with Eigen's
Levenberg-Marquardt and forward-difference Jacobians.

Choices (stated):

* ``1 - f . r`` is evaluated as ``|f - r|^2 / 2`` (identical for unit vectors, no cancellation), so
  convergence on noise-free data is not limited by ``1 - cos`` rounding (~1e-8 rad);
* parameters: the 5-parameter chart ``R = exp([w]x) R0``, ``t = normalize(t0 + B v)``
  (:class:`~poseonly.refine._manifold.PoseChart`) instead of OpenGV's Cayley rotation plus a free
  3-vector ``t12`` (the cost is invariant to the scale of ``t``, so OpenGV's 6th parameter is a gauge
  freedom that LM's damping absorbs);
* Jacobian: numeric central differences (scipy ``"3-point"``) of the vectorized residual. The
  residual is quadratic in the pose error near an exact solution (its Jacobian vanishes there),
  so LM converges linearly (error roughly halves per iteration) on noise-free data; forward
  differences (OpenGV) would stall near ``sqrt(eps)``;
* tolerances ``ftol = xtol = 1e-15`` and ``gtol = 1e-15`` (OpenGV: ``10 eps``), ``max_nfev`` from
  ``max_iter`` (OpenGV ``maxfev = 1000``).

The cost is not invariant to ``t -> -t`` (points behind the cameras give residuals up to 4), so the
sign of ``t`` is kept as optimised; ``info["positive_depth_fraction"]`` reports the chirality.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from scipy.optimize import least_squares

from ..geometry import check_correspondences, normalize, triangulate_midpoint
from ..residuals import ligt_depths
from ._common import RefineResult, check_pose
from ._manifold import PoseChart

__all__ = ["opengv_nonlinear", "opengv_residuals"]


class _Converged(Exception):
    """Raised inside the residual function to stop MINPACK at an exact fit."""


def opengv_residuals(R: np.ndarray, t: np.ndarray, f1: np.ndarray, f2: np.ndarray) -> np.ndarray:
    """``(1 - f1 . r1) + (1 - f2 . r2)`` per point, computed as ``(|f1 - r1|^2 + |f2 - r2|^2) / 2``."""
    X1, _, _ = triangulate_midpoint(R, t, f1, f2)
    r1 = normalize(X1)
    r2 = normalize(X1 @ R.T + t)
    return 0.5 * (np.sum((f1 - r1) ** 2, axis=1) + np.sum((f2 - r2) ** 2, axis=1))


def opengv_nonlinear(
    R0: np.ndarray,
    t0: np.ndarray,
    f1: np.ndarray,
    f2: np.ndarray,
    weights: np.ndarray | None = None,
    max_iter: int = 1000,
    tol: float = 1e-15,
    cost_atol: float = 1e-38,
) -> RefineResult:
    """Refine ``(R0, t0)`` by LM on the OpenGV two-view residual (module docstring).

    ``weights`` (optional, non-negative ``(n,)``) scale each residual by ``sqrt(w_i)`` (OpenGV has no
    weights in ``optimize_nonlinear``). ``max_iter`` caps residual evaluations (scipy ``max_nfev``;
    each LM iteration costs ~11 with the central-difference Jacobian). Returns a
    :class:`RefineResult` with ``cost = sum_i w_i r_i^2``. ``cost_atol``: LM also stops when the
    cost falls below ``cost_atol * n`` (an exact fit: MINPACK's relative tests never fire on a
    zero-residual problem that converges linearly; ``1e-38`` corresponds to ~1e-9 rad).
    """
    f1, f2, w = check_correspondences(f1, f2, weights, min_points=6)
    R0, t0 = check_pose(R0, t0)
    if int(max_iter) < 1:
        raise ValueError(f"max_iter must be >= 1, got {max_iter}")
    sw = np.ones(len(f1)) if w is None else np.sqrt(w)
    chart = PoseChart(R0, t0)

    def fun(x):
        R, t = chart.retract(x)
        return sw * opengv_residuals(R, t, f1, f2)

    r0 = fun(chart.x0())
    cost0 = float(r0 @ r0)
    atol = float(cost_atol) * len(f1)
    tol = max(float(tol), 2.3e-16)
    if cost0 <= atol:
        x, nfev, status, ok, msg = chart.x0(), 1, 1, True, "exact start (zero residual)"
    else:
        state: dict[str, Any] = {"nfev": 0}

        def fun_stop(x):
            r = fun(x)
            state["nfev"] += 1
            if float(r @ r) <= atol:
                state["x"] = x.copy()
                raise _Converged
            return r

        try:
            res = least_squares(fun_stop, chart.x0(), jac="3-point", method="lm", ftol=tol, xtol=tol, gtol=tol, max_nfev=int(max_iter))
            x, nfev, status, ok, msg = res.x, state["nfev"], int(res.status), bool(res.status > 0), str(res.message)
        except _Converged:
            x, nfev, status, ok, msg = state["x"], state["nfev"], 2, True, f"cost below cost_atol * n = {atol:.1e} (exact fit)"
    R1, t1 = chart.retract(x)
    assert t1 is not None  # the chart was built with t0
    r1 = fun(x)
    cost1 = float(r1 @ r1)
    if not cost1 <= cost0:
        R1, t1, cost1, ok, msg = R0, t0, cost0, False, msg + "; cost increased, start pose returned"
    h, _, _ = ligt_depths(R1, t1, f1, f2)
    ww = np.ones(len(h)) if w is None else w
    frac = float(np.sum(ww * (h > 0)) / max(np.sum(ww), 1e-300))
    return RefineResult(
        R=R1,
        t=normalize(t1),
        cost_initial=cost0,
        cost_final=cost1,
        num_iterations=nfev,
        success=ok,
        message=msg,
        info={"nfev": nfev, "status": status, "positive_depth_fraction": frac},
    )
