"""Zhao (TPAMI 2020) N-point essential-matrix estimation by a semidefinite relaxation (notes sec. 11).

QCQP (written in poseonly's convention ``f2^T E f1 = 0``, ``E = [t]x R``): with ``e = vec_row(E)``
(``e[3i + j] = E_ij``) and ``g_i = kron(f2_i, f1_i)`` so that ``f2^T E f1 = g^T e``,

    ``min_(e, t)  e^T C e``,  ``C = sum_i w_i g_i g_i^T``,
    ``s.t.  E E^T = [t]x [t]x^T = |t|^2 I - t t^T``  (6 equations),  ``t^T t = 1``.

The constraints characterise essential matrices with unit translation (``E E^T`` has eigenvalues
``(1, 1, 0)``). Shor's relaxation replaces ``[e; t][e; t]^T`` by a 12 x 12 PSD matrix ``Y``:

    ``min <C, Y_ee>``  s.t.  ``sum_k Y_e[3i+k, 3j+k] = delta_ij tr(Y_tt) - Y_tt[i, j]`` (i <= j),
    ``tr(Y_tt) = 1``,  ``Y >= 0``.

``E`` is the leading eigenvector of ``Y_ee`` (scaled to ``|E|_F = sqrt(2)``), decomposed and
identified with the pose-only depth conditions (:func:`poseonly.identify.identify_poses`).

Choices (stated): ``C`` is divided by the standard deviation of its 81 entries (as in
``jizhaox/npt-pose``; conditioning only); the default solver is Clarabel (interior point) with
gap/feasibility tolerances 1e-12 (on noise-free data the optimum is 0 and Clarabel stops at its
reduced tolerances with status ``optimal_inaccurate``: rotation errors ~1e-5 deg; with 1e-10 they
were ~4e-4 deg), SCS (``eps = 1e-9``, slower) as an alternative; ``n >= 8`` as in the
reference code. The relaxation is tight (``rank Y = 1``) for general noise-free scenes. In a
noise-free *planar* scene ``C`` has a 3-D null space that contains two essential matrices (the
true one and its homography twin), so the SDP optimum is any convex combination of the two
rank-1 solutions: ``Y_ee`` has rank 2 and the extracted ``E`` is generally neither (``info["rank_ratio"]``
= second / first eigenvalue of ``Y`` flags this). The robust (M-estimator) variant of Zhao's paper
is not in the public code; ``weights`` is the hook for it.
"""

from __future__ import annotations

import time
import warnings

import numpy as np

from ..geometry import check_correspondences
from ..identify import identify_poses

__all__ = ["npt", "npt_cost_matrix"]


def npt_cost_matrix(f1: np.ndarray, f2: np.ndarray, w: np.ndarray | None = None) -> np.ndarray:
    """``C = sum_i w_i kron(f2_i, f1_i) kron(f2_i, f1_i)^T`` (9 x 9, row-major ``vec(E)``)."""
    g = (f2[:, :, None] * f1[:, None, :]).reshape(-1, 9)
    if w is not None:
        return np.einsum("n,ni,nj->ij", w, g, g)
    return g.T @ g


def npt(f1: np.ndarray, f2: np.ndarray, weights: np.ndarray | None = None, solver: str = "CLARABEL", verbose: bool = False):
    """Zhao's N-point SDP. Returns ``(R, t, info)`` (``X2 = R X1 + t``, unit ``t``).

    ``f1, f2``: ``(n, 3)`` bearings or ``(n, 2)`` normalized coordinates, ``n >= 8``; ``weights``
    optional non-negative ``(n,)``; ``solver``: ``"CLARABEL"`` (default) or ``"SCS"``. Needs
    ``cvxpy`` (``pip install poseonly[sdp]``). ``info`` holds ``E`` (``|E|_F = sqrt(2)``), ``t_sdp``
    (leading eigenvector of ``Y_tt``), ``status``, ``objective`` (``<C, Y_ee>`` for the unscaled
    ``C``), ``eigenvalues`` of ``Y`` and ``eigenvalues_ee`` of ``Y_ee`` (descending), ``rank_ratio``
    (second / first eigenvalue of ``Y_ee``, ~0 when the relaxation is tight; ``Y`` itself has rank 2
    at a tight optimum because the block ``Y_et`` is unconstrained: ``(e, t)`` and ``(-e, t)`` are
    both feasible with equal cost), ``valid`` (pose-only depth conditions), ``solver`` and ``solve_time``.
    """
    try:
        import cvxpy as cp
    except ImportError as exc:  # pragma: no cover - depends on the environment
        raise ImportError("npt needs cvxpy and an SDP solver: pip install poseonly[sdp]") from exc
    f1, f2, w = check_correspondences(f1, f2, weights, min_points=8)
    key = str(solver).upper()
    if key not in ("CLARABEL", "SCS"):
        raise ValueError(f"unknown solver {solver!r}; use 'CLARABEL' or 'SCS'")
    C = npt_cost_matrix(f1, f2, w)
    sd = float(np.std(C))
    Cs = C / sd if sd > 0 else C
    Y = cp.Variable((12, 12), PSD=True)
    cons = [cp.trace(Y[9:, 9:]) == 1]
    for i in range(3):
        for j in range(i, 3):
            lhs = sum(Y[3 * i + k, 3 * j + k] for k in range(3))
            rhs = (cp.trace(Y[9:, 9:]) if i == j else 0) - Y[9 + i, 9 + j]
            cons.append(lhs == rhs)
    prob = cp.Problem(cp.Minimize(cp.trace(Cs @ Y[:9, :9])), cons)
    t0 = time.perf_counter()
    with warnings.catch_warnings():
        # "Solution may be inaccurate": expected when the optimum is 0 (noise-free data), where the
        # interior-point method stops at its reduced tolerances; the status is reported in info
        warnings.filterwarnings("ignore", message="Solution may be inaccurate")
        if key == "CLARABEL":
            prob.solve(solver=cp.CLARABEL, verbose=verbose, tol_gap_abs=1e-12, tol_gap_rel=1e-12, tol_feas=1e-12, max_iter=1000)
        else:
            prob.solve(solver=cp.SCS, verbose=verbose, eps=1e-9, max_iters=200000)
    dt = time.perf_counter() - t0
    if Y.value is None:
        raise RuntimeError(f"SDP solver {key} failed: status {prob.status}")
    Yv = 0.5 * (Y.value + Y.value.T)
    lamY = np.linalg.eigvalsh(Yv)[::-1]
    lam_e, V = np.linalg.eigh(Yv[:9, :9])
    E = V[:, -1].reshape(3, 3) * np.sqrt(2.0)
    _, Vt = np.linalg.eigh(Yv[9:, 9:])
    R, t, valid, _ = identify_poses(E[None], f1, f2, w)
    info = {
        "E": E,
        "t_sdp": Vt[:, -1],
        "status": prob.status,
        "objective": float(np.sum(C * Yv[:9, :9])),
        "eigenvalues": lamY,
        "eigenvalues_ee": lam_e[::-1],
        "rank_ratio": float(lam_e[-2] / lam_e[-1]) if lam_e[-1] > 0 else float("nan"),
        "valid": bool(valid[0]),
        "solver": key,
        "solve_time": dt,
    }
    return R[0], t[0], info
