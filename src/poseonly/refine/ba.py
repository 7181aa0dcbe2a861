"""Two-view bundle adjustment (the gold-standard reference for the residual ``v^BA`` of Section 4).

Unknowns: the relative pose on SO(3) x S^2 (5 parameters, :class:`~poseonly.refine._manifold.PoseChart`:
``R = exp([w]x) R0``, ``t = normalize(t0 + B v)``, which also fixes the scale gauge ``|t| = 1``) and a
full 3-D point per correspondence in camera 1's frame, parameterised (decision) as

    ``X_i = (f1_i + B1_i u_i) / rho_i``   (inverse depth ``rho_i`` along ``f1_i``, tangent offset ``u_i``),

3 parameters per point. A pure inverse depth along ``f1`` would keep the point on the view-1 ray
(view-1 residual identically zero, not a two-view BA); the tangent offset restores the 3rd degree
of freedom, and with it the view-1 residual is exactly ``u_i``. This is far better conditioned
than raw ``(x, y, z)`` points (with those, LSMR-based TRF needed 100+ evaluations from a 5-degree
start; with this chart ~6-30), and it represents points at infinity (``rho -> 0``).

Residuals (2 per view and point, decision): tangent-plane reprojection errors

    ``r1_i = B1_i^T X_i / (f1_i . X_i) = u_i``,   ``r2_i = B2_i^T P_i / (f2_i . P_i)``,  ``P_i = R X_i + t``,

with ``B_i (3, 2)`` an orthonormal tangent basis at the observed bearing: ``P / (f . P) - f``
expressed in that basis, i.e. the paper's ``||eps / (e3^T eps) - x'||`` of ``v^BA`` measured on the
plane tangent to the observed bearing instead of the ``z = 1`` image plane (equal for rays on the
optical axis and defined for wide-angle bearings; the same choice as :func:`poseonly.residuals.v_BA`).
Units are those of normalized image coordinates (multiply by the focal length for pixels).

Solver: ``scipy.optimize.least_squares(method="trf", tr_solver="lsmr")`` with an analytic sparse
(CSR) Jacobian of the ``(4n) x (5 + 3n)`` block structure (view-1 rows of a point touch its ``u``
columns, view-2 rows its 3 columns and the 5 pose columns), LSMR tolerances ``1e-14``; points start
at the midpoint triangulation of the initial pose (:func:`poseonly.geometry.triangulate_midpoint`).
Robust losses are applied per observation (the 2 residuals of one view of one point, like COLMAP's
residual blocks).

Known limitation: the projection ``P / (f . P)`` is blind to the sign of the depth, so a point can
converge onto camera 1's centre or behind a camera; from 5-degree perturbations this produced a
spurious local minimum in ~2 of 30 noise-free scenes (points within a few degrees of the epipole).
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import least_squares
from scipy.sparse import csr_matrix

from ..geometry import check_correspondences, normalize, triangulate_midpoint
from ._common import LOSSES, RefineResult, check_pose, fix_translation_sign, grouped_loss
from ._manifold import PoseChart

__all__ = ["bundle_adjust", "tangent_bases"]

_DEN_FLOOR = 1e-12


def tangent_bases(f: np.ndarray) -> np.ndarray:
    """Orthonormal tangent bases ``(n, 3, 2)`` at unit bearings ``f (n, 3)`` (vectorized)."""
    idx = np.argmin(np.abs(f), axis=1)
    e = np.zeros_like(f)
    e[np.arange(len(f)), idx] = 1.0
    b1 = normalize(np.cross(f, e))
    b2 = np.cross(f, b1)
    return np.stack([b1, b2], axis=2)


def _safe_den(d: np.ndarray) -> np.ndarray:
    return np.where(np.abs(d) < _DEN_FLOOR, np.where(d < 0, -_DEN_FLOOR, _DEN_FLOOR), d)


def bundle_adjust(
    R0: np.ndarray,
    t0: np.ndarray,
    f1: np.ndarray,
    f2: np.ndarray,
    loss: str = "linear",
    weights: np.ndarray | None = None,
    loss_scale: float | None = None,
    points0: np.ndarray | None = None,
    max_iter: int = 100,
    tol: float = 1e-12,
) -> RefineResult:
    """Two-view bundle adjustment of ``(R0, t0)`` and the points (module docstring).

    Parameters
    ----------
    R0, t0 : initial pose (``X2 = R X1 + t``; ``t0`` normalised here, ``|t| = 1`` fixes the scale).
    f1, f2 : ``(n, 3)`` bearings or ``(n, 2)`` normalized image coordinates, ``n >= 6``.
    loss : ``"linear"``, ``"soft_l1"``, ``"huber"``, ``"cauchy"`` or ``"arctan"`` (per observation).
    weights : optional non-negative ``(n,)``, residuals scaled by ``sqrt(w_i)``.
    loss_scale : inlier scale of an observation's reprojection error (scipy ``f_scale``). Default
        (decision): ``1.4826 * median`` of the initial per-observation errors, at least ``1e-12``.
    points0 : optional initial points ``(n, 3)`` in camera 1's frame. Default: midpoint triangulation,
        except that points with a non-positive depth in either view (decision) restart on their
        view-1 ray at the median distance of the other points: the tangent-plane projection
        ``P / (f . P)`` cannot tell a point from its mirror image behind the camera, and such a
        point otherwise traps the pose in a spurious local minimum (seen from 5-degree
        perturbations for points within ~10 degrees of the epipole).
    max_iter : scipy ``max_nfev``; ``tol``: ``ftol = xtol = gtol``.

    Returns
    -------
    :class:`RefineResult` with ``cost = sum_i w_i (|r1_i|^2 + |r2_i|^2)`` (linear loss; otherwise
    ``loss_scale^2 sum rho(...)``), the refined ``points (n, 3)`` in camera 1's frame (scale
    ``|t| = 1``), ``t`` sign-checked by the majority of positive pose-only depths (``info`` holds
    ``positive_depth_fraction``, ``rms_initial`` and ``rms_final`` of the per-observation errors).
    """
    f1, f2, w = check_correspondences(f1, f2, weights, min_points=6)
    R0, t0 = check_pose(R0, t0)
    key = str(loss).lower()
    if key not in LOSSES:
        raise ValueError(f"unknown loss {loss!r}; choose one of {sorted(LOSSES)}")
    if int(max_iter) < 1:
        raise ValueError(f"max_iter must be >= 1, got {max_iter}")
    n = len(f1)
    reinit = 0
    if points0 is None:
        X0, z1, z2 = triangulate_midpoint(R0, t0, f1, f2)
        # a point reconstructed behind a camera (typically near the epipole under a perturbed pose)
        # would sit in the mirror basin of the sign-blind projection P / (f . P); restart it on its
        # view-1 ray at the median positive depth
        bad = (z1 <= 0) | (z2 <= 0)
        reinit = int(np.count_nonzero(bad))
        if reinit:
            good = np.linalg.norm(X0[~bad], axis=1)
            depth = float(np.median(good)) if good.size else 1.0
            X0[bad] = depth * f1[bad]
    else:
        X0 = np.asarray(points0, dtype=float)
        if X0.shape != (n, 3) or not np.all(np.isfinite(X0)):
            raise ValueError(f"points0 must be a finite ({n}, 3) array")
    sw = np.ones(n) if w is None else np.sqrt(w)
    B1 = tangent_bases(f1)
    B2 = tangent_bases(f2)
    chart = PoseChart(R0, t0)
    # point parameters (u_i (2), rho_i): X_i = (f1_i + B1_i u_i) / rho_i
    d0 = np.sum(f1 * X0, axis=1)
    d0 = _safe_den(d0)
    rho0 = 1.0 / d0
    u0 = np.einsum("nik,ni->nk", B1, X0) * rho0[:, None]
    x0 = np.concatenate([chart.x0(), np.column_stack([u0, rho0]).ravel()])

    def unpack(x):
        p = x[5:].reshape(n, 3)
        return p[:, :2], p[:, 2]

    def residuals(x):
        R, t = chart.retract(x)
        u, rho = unpack(x)
        Q = (f1 + np.einsum("nik,nk->ni", B1, u)) @ R.T + rho[:, None] * t  # rho * (R X + t)
        d2 = _safe_den(np.sum(f2 * Q, axis=1))
        r2 = np.einsum("nik,ni->nk", B2, Q) / d2[:, None]
        return np.concatenate([u, r2], axis=1) * sw[:, None]  # (n, 4): view 1 is exactly u

    # sparsity: rows 4i, 4i+1 (view 1) -> u_i columns; rows 4i+2, 4i+3 (view 2) -> 5 pose columns
    # and the 3 point columns
    pc = 5 + 3 * np.arange(n)[:, None] + np.arange(3)[None, :]  # (n, 3)
    rows1 = 4 * np.arange(n)[:, None] + np.arange(2)[None, :]  # (n, 2)
    cols1 = pc[:, :2]
    rows2 = np.repeat(4 * np.arange(n)[:, None] + 2 + np.arange(2)[None, :], 8, axis=1)  # (n, 16)
    cols2 = np.tile(np.concatenate([np.broadcast_to(np.arange(5), (n, 5)), pc], axis=1), (1, 2))
    rows = np.concatenate([rows1.ravel(), rows2.ravel()])
    cols = np.concatenate([cols1.ravel(), cols2.ravel()])
    shape = (4 * n, 5 + 3 * n)

    def jacobian(x):
        R, t, Jl, Jt = chart.jacobians(x)
        u, rho = unpack(x)
        RY = (f1 + np.einsum("nik,nk->ni", B1, u)) @ R.T
        Q = RY + rho[:, None] * t
        d2 = _safe_den(np.sum(f2 * Q, axis=1))
        r2 = np.einsum("nik,ni->nk", B2, Q) / d2[:, None]
        G2 = (np.swapaxes(B2, 1, 2) - r2[:, :, None] * f2[:, None, :]) / d2[:, None, None]  # dr2/dQ (n, 2, 3)
        dQw = -np.cross(RY[:, None, :], Jl.T[None, :, :]).transpose(0, 2, 1)  # -[R Y]x J_l (n, 3, 3)
        dQv = rho[:, None, None] * Jt[None]  # (n, 3, 2)
        dQu = np.einsum("ij,njk->nik", R, B1)  # R B1 (n, 3, 2)
        dQr = np.broadcast_to(t, (n, 3))[:, :, None]  # (n, 3, 1)
        Jv2 = G2 @ np.concatenate([dQw, dQv, dQu, dQr], axis=2) * sw[:, None, None]  # (n, 2, 8)
        data = np.concatenate([np.repeat(sw, 2), Jv2.reshape(n, 16).ravel()])
        return csr_matrix((data, (rows, cols)), shape=shape)

    def points(x):
        u, rho = unpack(x)
        return (f1 + np.einsum("nik,nk->ni", B1, u)) / _safe_den(rho)[:, None]

    r0 = residuals(x0)
    e0 = np.sum(r0.reshape(n, 2, 2) ** 2, axis=2).ravel()  # per-observation squared errors
    scale = 1.0
    if key != "linear":
        if loss_scale is None:
            pos = np.sqrt(e0[np.repeat(sw > 0, 2)])
            scale = max(1.4826 * float(np.median(pos)), 1e-12)
        else:
            scale = float(loss_scale)
            if not np.isfinite(scale) or scale <= 0:
                raise ValueError(f"loss_scale must be positive, got {loss_scale}")

    def objective(r):
        e = np.sum(r.reshape(n, 2, 2) ** 2, axis=2).ravel()
        if key == "linear":
            return float(np.sum(e))
        return float(scale**2 * np.sum(LOSSES[key](e / scale**2)[0]))

    cost0 = objective(r0)
    tol = max(float(tol), 2.3e-16)
    if cost0 == 0.0:
        x, nfev, njev, status, ok, msg = x0, 1, 0, 1, True, "exact start (zero residual)"
    else:
        res = least_squares(
            lambda x: residuals(x).ravel(),
            x0,
            jac=jacobian,
            method="trf",
            tr_solver="lsmr",
            loss=grouped_loss(key, 2),
            f_scale=scale,
            x_scale="jac",
            ftol=tol,
            xtol=tol,
            gtol=tol,
            tr_options={"atol": 1e-14, "btol": 1e-14},
            max_nfev=int(max_iter),
        )
        x, nfev, njev, status, ok, msg = res.x, int(res.nfev), int(res.njev or 0), int(res.status), bool(res.status > 0), str(res.message)
    r1 = residuals(x)
    cost1 = objective(r1)
    R1, t1 = chart.retract(x)
    assert t1 is not None  # the chart was built with t0
    X1 = points(x)
    if not cost1 <= cost0:
        R1, t1, X1, cost1, ok, msg = R0, t0, X0, cost0, False, msg + "; cost increased, start returned"
        r1 = r0
    t1s, frac = fix_translation_sign(R1, t1, f1, f2, w)
    if t1s @ t1 < 0:  # the flipped pose mirrors the points through camera 1
        X1 = -X1
    rms = lambda r: float(np.sqrt(np.mean(np.sum(r.reshape(n, 2, 2) ** 2, axis=2))))  # noqa: E731
    return RefineResult(
        R=R1,
        t=t1s,
        cost_initial=cost0,
        cost_final=cost1,
        num_iterations=njev,
        success=ok,
        message=msg,
        points=X1,
        info={
            "nfev": nfev,
            "status": status,
            "loss": key,
            "loss_scale": scale if key != "linear" else None,
            "positive_depth_fraction": frac,
            "rms_initial": rms(r0),
            "rms_final": rms(r1),
            "points_reinitialised": reinit,
        },
    )
