"""Parameterisation helpers for two-view refinement on SO(3) x S^2 (5 degrees of freedom).

All refiners in :mod:`poseonly.refine` optimise a *local* parameter vector around the start
``(R0, t0)`` so that the Levenberg-Marquardt iterations work in an unconstrained R^5:

* rotation: ``R(w) = exp([w]x) R0`` (left perturbation, :func:`poseonly.geometry.rotation_from_rotvec`),
  ``w in R^3``, ``w = 0`` at the start;
* unit translation: ``t(v) = normalize(t0 + B v)`` with ``B (3, 2)`` an orthonormal basis of the
  tangent plane of the sphere at ``t0``, ``v in R^2``. The map is a chart of the open hemisphere
  around ``t0`` (it cannot represent ``-t0``), which is all a local refinement needs.

The Jacobians are exact at any parameter value (not only at 0), so the LM iterations of
``scipy.optimize.least_squares`` see a consistent model: for the rotation,
``d(R(w) p)/dw = -[R(w) p]x J_l(w)`` with the SO(3) left Jacobian ``J_l``; for the translation,
``dt/dv = (I - t t^T) B / ||t0 + B v||``.
"""

from __future__ import annotations

import math

import numpy as np

from ..geometry import normalize, skew

__all__ = ["tangent_basis", "left_jacobian_so3", "PoseChart"]


def tangent_basis(t0: np.ndarray) -> np.ndarray:
    """Orthonormal ``(3, 2)`` basis of the plane orthogonal to ``t0`` (any non-zero 3-vector)."""
    t0 = normalize(np.asarray(t0, dtype=float))
    e = np.zeros(3)
    e[int(np.argmin(np.abs(t0)))] = 1.0  # the axis least aligned with t0
    b1 = normalize(np.cross(t0, e))
    b2 = np.cross(t0, b1)
    return np.stack([b1, b2], axis=1)


def left_jacobian_so3(w: np.ndarray) -> np.ndarray:
    """Left Jacobian ``J_l(w)`` of SO(3): ``exp([w + e]x) ~= exp([J_l(w) e]x) exp([w]x)``.

    ``J_l = I + (1 - cos th) / th^2 [w]x + (th - sin th) / th^3 [w]x^2`` (series below 1e-6 rad).
    """
    w = np.asarray(w, dtype=float)
    th2 = float(w @ w)
    K = skew(w)
    if th2 < 1e-12:
        a, b = 0.5 - th2 / 24.0, 1.0 / 6.0 - th2 / 120.0
    else:
        th = np.sqrt(th2)
        a = (1.0 - np.cos(th)) / th2
        b = (th - np.sin(th)) / (th2 * th)
    return np.eye(3) + a * K + b * (K @ K)


def _rodrigues_and_jl(x: np.ndarray, want_jl: bool) -> tuple[np.ndarray, np.ndarray | None]:
    """``exp([w]x)`` and (optionally) ``J_l(w)`` for ``w = x[:3]`` in scalar arithmetic (the array
    forms :func:`~poseonly.geometry.rotation_from_rotvec` / :func:`left_jacobian_so3` cost ~50 us of
    numpy overhead per call, paid every LM iteration; same formulas and series thresholds)."""
    w0, w1, w2 = float(x[0]), float(x[1]), float(x[2])
    th2 = w0 * w0 + w1 * w1 + w2 * w2
    K = np.array([[0.0, -w2, w1], [w2, 0.0, -w0], [-w1, w0, 0.0]])
    K2 = K @ K
    th = math.sqrt(th2)
    if th < 1e-8:
        a, b = 1.0 - th2 / 6.0, 0.5 - th2 / 24.0
    else:
        a, b = math.sin(th) / th, (1.0 - math.cos(th)) / th2
    E = np.eye(3) + a * K + b * K2
    if not want_jl:
        return E, None
    if th2 < 1e-12:
        c, d = 0.5 - th2 / 24.0, 1.0 / 6.0 - th2 / 120.0
    else:
        c, d = (1.0 - math.cos(th)) / th2, (th - math.sin(th)) / (th2 * th)
    return E, np.eye(3) + c * K + d * K2


class PoseChart:
    """Local chart ``x = (w (3), v (2)) -> (R, t)`` of SO(3) x S^2 around ``(R0, t0)``.

    ``retract(x)`` gives the pose; ``jacobians(x)`` gives ``(R, t, J_l (3, 3), Jt (3, 2))`` with
    ``d(R p)/dw = -[R p]x J_l`` and ``dt/dv = Jt``. With ``with_translation=False`` the chart is
    SO(3) only (``x = w``) and ``t`` stays ``t0``.
    """

    def __init__(self, R0: np.ndarray, t0: np.ndarray | None = None, with_translation: bool = True):
        self.R0 = np.asarray(R0, dtype=float)
        self.with_translation = with_translation and t0 is not None
        self.t0 = normalize(np.asarray(t0, dtype=float)) if t0 is not None else None
        self.B: np.ndarray | None = tangent_basis(self.t0) if self.with_translation and self.t0 is not None else None
        self.size = 5 if self.with_translation else 3

    def x0(self) -> np.ndarray:
        return np.zeros(self.size)

    def rotation(self, x: np.ndarray) -> np.ndarray:
        return _rodrigues_and_jl(x, False)[0] @ self.R0

    def translation(self, x: np.ndarray) -> np.ndarray | None:
        if not self.with_translation:
            return self.t0
        return normalize(self.t0 + self.B @ x[3:5])

    def retract(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray | None]:
        return self.rotation(x), self.translation(x)

    def jacobians(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray | None, np.ndarray, np.ndarray | None]:
        E, Jl = _rodrigues_and_jl(x, True)
        assert Jl is not None  # want_jl=True always returns J_l
        R = E @ self.R0
        if not self.with_translation:
            return R, self.t0, Jl, None
        u = self.t0 + self.B @ x[3:5]
        nu = np.linalg.norm(u)
        t = u / nu
        Jt = (self.B - np.outer(t, t @ self.B)) / nu
        return R, t, Jl, Jt
