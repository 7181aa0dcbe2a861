"""Shared pieces of the refiners: the result type, grouped robust losses and the chirality sign."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Callable, overload

import numpy as np

from ..geometry import InputError, normalize
from ..residuals import ligt_depths

__all__ = ["RefineResult", "grouped_loss", "LOSSES", "fix_translation_sign", "check_pose"]


@dataclass
class RefineResult:
    """Result of a refinement.

    ``R, t``: refined pose (``X2 = R X1 + t``, unit ``t``); ``cost_initial`` / ``cost_final``: the
    method's objective at the start and at the end (each refiner documents its objective);
    ``num_iterations``: Jacobian evaluations of the optimiser (= accepted LM iterations + 1 for
    ``lm``; see each function); ``success``: the optimiser converged (and, where checked, the cost
    did not increase); ``message``: optimiser message plus notes; ``points``: refined 3-D points in
    camera 1's frame (bundle adjustment only, else ``None``); ``info``: method-specific extras
    (``nfev``, ``status``, ``loss_scale``, ...).
    """

    R: np.ndarray
    t: np.ndarray
    cost_initial: float
    cost_final: float
    num_iterations: int
    success: bool
    message: str
    points: np.ndarray | None = None
    info: dict[str, Any] = field(default_factory=dict)


# ---------------------------------------------------------------------------------------------
# robust losses rho(s) of a per-point squared norm s (value, first and second derivative)


def _linear(s):
    return s, np.ones_like(s), np.zeros_like(s)


def _soft_l1(s):
    q = 1.0 + s
    r = np.sqrt(q)
    return 2.0 * (r - 1.0), 1.0 / r, -0.5 / (q * r)


def _huber(s):
    big = s > 1.0
    r = np.sqrt(np.where(big, s, 1.0))
    return (np.where(big, 2.0 * r - 1.0, s), np.where(big, 1.0 / r, 1.0), np.where(big, -0.5 / (r * r * r), 0.0))


def _cauchy(s):
    q = 1.0 + s
    return np.log1p(s), 1.0 / q, -1.0 / (q * q)


def _arctan(s):
    q = 1.0 + s * s
    return np.arctan(s), 1.0 / q, -2.0 * s / (q * q)


LOSSES: dict[str, Callable] = {"linear": _linear, "soft_l1": _soft_l1, "huber": _huber, "cauchy": _cauchy, "arctan": _arctan}


def grouped_loss(name: str, group: int) -> Callable[[np.ndarray], np.ndarray] | str:
    """A scipy ``least_squares`` loss callable that applies ``rho`` to each *point's* squared norm.

    scipy applies its built-in losses to every scalar residual; our residual vectors have ``group``
    components per point (3 for LiGT), so ``rho`` is applied to ``s_i = sum_k (f_ik / f_scale)^2``
    instead (the cost is ``f_scale^2 sum_i rho(s_i)``, the gradient is exact). The second-derivative
    (Triggs) correction that scipy applies per component uses ``rho''(s_i)`` for every component
    of the point: an approximation of the Gauss-Newton Hessian only, it does not move the optimum.
    ``"linear"`` is returned as the string so that ``method="lm"`` can be used.
    """
    key = str(name).lower()
    if key not in LOSSES:
        raise InputError(f"unknown loss {name!r}; choose one of {sorted(LOSSES)}")
    if key == "linear":
        return "linear"
    rho_fn = LOSSES[key]

    def loss(z: np.ndarray) -> np.ndarray:
        s = z.reshape(-1, group).sum(axis=1)
        r0, r1, r2 = rho_fn(s)
        out = np.empty((3, z.size))
        out[0] = np.repeat(r0 / group, group)
        out[1] = np.repeat(r1, group)
        out[2] = np.repeat(r2, group)
        return out

    return loss


# ---------------------------------------------------------------------------------------------
# pose helpers


@overload
def check_pose(R: np.ndarray, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]: ...
@overload
def check_pose(R: np.ndarray, t: None = None) -> tuple[np.ndarray, None]: ...
@overload
def check_pose(R: np.ndarray, t: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray | None]: ...


def check_pose(R: np.ndarray, t: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray | None]:
    """Validate an initial pose: finite ``(3, 3)`` rotation (det ~ +1) and non-zero ``(3,)`` ``t``."""
    try:
        R = np.asarray(R, dtype=float)
    except (TypeError, ValueError):
        raise InputError("R must be a numeric 3x3 matrix") from None
    if R.shape != (3, 3) or not np.all(np.isfinite(R)):
        raise InputError(f"R must be a finite 3x3 matrix, got shape {R.shape}")
    if np.abs(R.T @ R - np.eye(3)).max() > 1e-6 or np.linalg.det(R) < 0:
        raise InputError("R must be a rotation matrix (R^T R = I, det R = +1)")
    if t is None:
        return R, None
    try:
        t = np.asarray(t, dtype=float)
    except (TypeError, ValueError):
        raise InputError("t must be a numeric 3-vector") from None
    if t.shape != (3,) or not np.all(np.isfinite(t)):
        raise InputError(f"t must be a finite 3-vector, got shape {t.shape}")
    if np.linalg.norm(t) < 1e-12:
        raise InputError("t must be non-zero (pure rotation has no translation direction to refine)")
    return R, normalize(t)


def fix_translation_sign(R: np.ndarray, t: np.ndarray, f1: np.ndarray, f2: np.ndarray, w: np.ndarray | None = None) -> tuple[np.ndarray, float]:
    """Flip ``t`` so that the (weighted) majority of the pose-only depths ``h_i^T t`` is positive.

    The same rule as OpenMVG's LiGT ``IdentifySign`` and :func:`poseonly.identify.identify_poses`
    (``M2``). Returns the signed unit ``t`` and the weighted fraction of positive depths after the
    flip, in [0, 1].
    """
    h, _, _ = ligt_depths(R, t, f1, f2)
    ww = np.ones(len(h)) if w is None else w
    m2 = float(np.sum(ww * np.sign(h)))
    if m2 < 0:
        t = -t
        h = -h
    frac = float(np.sum(ww * (h > 0)) / max(np.sum(ww), 1e-300))
    return normalize(t), frac
