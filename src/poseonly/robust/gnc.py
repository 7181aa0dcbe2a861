"""GNC-IRLS (Algorithm 2) with Peng et al.'s MS-TLS weights or Yang et al.'s classic GNC-TLS.

The loop runs in the core (``src/core/gnc.cpp``, one problem at a time, GIL released); this module
holds its options and result types. Algorithm 2, per iteration ``k`` (notes section 7):

1. ``R, t`` = weighted LiRP with ``w^(k)`` (its PPO-best candidate; ``lirp-all``: the valid candidate
   minimising ``sum_i w_i v_i``);
2. ``v`` = residuals of all points (``v_LiGT`` by default);
3. ``sigma = 1.4826 * median(|v|)`` (``scale="median"``, Alg. 2 as printed) or
   ``1.4826 * median(|v - median(v)|)`` (``scale="mad"``, the paper's text) or a fixed number;
   ``c = 5.54 sigma`` (``c_factor``). A fixed ``noise_bound`` replaces ``c`` entirely.
4. weights: MS-TLS (Peng 2023): ``w = 1`` for ``v <= c``, ``0`` for ``v >= (mu+1)/mu c``, else
   ``(mu+1) c / v - mu``; classic GNC-TLS (Yang 2020): ``w = 1`` for ``v^2 <= mu/(mu+1) c^2``, ``0`` for
   ``v^2 >= (mu+1)/mu c^2``, else ``sqrt(c^2 mu (mu+1) / v^2) - mu``.
5. ``eps = sum_i w_i v_i`` (unsquared, as Alg. 2); stop when ``|eps^(k+1) - eps^(k)| < eps0 |eps|``.
6. ``mu``: initial ``max(1 / (5 max v^2 / c^2 - 1), 1e-6)`` (MS) or ``1 / (2 max v^2 / c^2 - 1)``
   (classic); update ``mu <- 1.4 sqrt(mu)`` while ``mu < 1`` then ``1.4 mu`` (MS), or ``1.4 mu``.

Open choices, decided: ``eps0`` is relative (default 1e-9, ``v_LiGT`` has no fixed unit); 100
iterations (Peng); ``sigma`` floored at ``sigma_floor`` (1e-12) so exact data cannot make ``c = 0``;
weights that leave fewer than 6 points end the problem with the previous weights; the returned pose
is the last weighted solve (as Alg. 2). With an adaptive bound the binary weight vectors often enter
a limit cycle (periods 2-5 measured); the core detects it and ends where the full loop would, with
the same outputs (``detect_cycles=False`` runs every iteration; a test compares the two and the
numpy reference loop in ``tests/reference/gnc.py``).
"""

from __future__ import annotations

import threading
from dataclasses import dataclass

import numpy as np

from .. import _core
from .._equality import ValueEquality
from ..estimator import Estimator, lirp_estimator

__all__ = ["GNCOptions", "gnc_irls_batch", "GNCBatchResult", "GNCResult", "CYCLE_MAX_PERIOD", "MAD_TO_SIGMA"]

MAD_TO_SIGMA = 1.4826
CYCLE_MAX_PERIOD = 8  # longest limit cycle of binary weights the loop detects
_SCHEDULES = {"ms-tls": 0, "gnc-tls": 1}
_SCALES = {"median": 0, "mad": 1}


def _is_number(x: object) -> bool:
    return isinstance(x, (int, float, np.integer, np.floating)) and not isinstance(x, (bool, np.bool_))


@dataclass(frozen=True)
class GNCOptions:
    """Options of :func:`gnc_irls_batch` (see the module docstring)."""

    schedule: str = "ms-tls"  # "ms-tls" (Peng 2023, the paper) or "gnc-tls" (Yang 2020)
    scale: str | float = "median"  # "median" (Alg. 2), "mad" (paper text) or a fixed sigma
    c_factor: float = 5.54
    noise_bound: float | None = None  # fixed c (overrides scale / c_factor)
    max_iterations: int = 100
    eps0: float = 1e-9
    sigma_floor: float = 1e-12
    mu_factor: float = 1.4
    mu0: float | None = None  # initial mu; None = Peng's rule. A large value (e.g. 1e3) starts at
    # (near) hard TLS: a warm start for local optimisation from a good model's inliers

    def __post_init__(self) -> None:
        if self.schedule not in _SCHEDULES:
            raise ValueError(f"schedule must be 'ms-tls' or 'gnc-tls', got {self.schedule!r}")
        if isinstance(self.scale, str):
            if self.scale not in _SCALES:
                raise ValueError(f"scale must be 'median', 'mad' or a positive number, got {self.scale!r}")
        elif not (_is_number(self.scale) and np.isfinite(self.scale) and self.scale > 0):
            raise ValueError(f"scale must be 'median', 'mad' or a positive number, got {self.scale!r}")
        if self.noise_bound is not None and not (_is_number(self.noise_bound) and np.isfinite(self.noise_bound) and self.noise_bound > 0):
            raise ValueError(f"noise_bound must be a finite number > 0 or None, got {self.noise_bound!r}")
        if not (isinstance(self.max_iterations, (int, np.integer)) and not isinstance(self.max_iterations, bool) and self.max_iterations >= 1):
            raise ValueError(f"max_iterations must be a positive integer, got {self.max_iterations!r}")
        if self.mu0 is not None and not (_is_number(self.mu0) and np.isfinite(self.mu0) and self.mu0 > 0):
            raise ValueError(f"mu0 must be a finite number > 0 or None, got {self.mu0!r}")
        for name, ok in (("c_factor", lambda v: v > 0), ("eps0", lambda v: v >= 0), ("sigma_floor", lambda v: v > 0), ("mu_factor", lambda v: v > 1)):
            val = getattr(self, name)
            if not (_is_number(val) and np.isfinite(val) and ok(val)):
                raise ValueError(f"{name} has an invalid value {val!r}")

    def core_options(self, estimator: Estimator, detect_cycles: bool = True) -> dict:
        """The options dict of ``poseonly._core.gnc_irls_batch`` for ``estimator``."""
        if estimator.solver not in ("lirp", "lirp-all"):
            raise ValueError(f"GNC-IRLS (Algorithm 2) solves with LiRP; got solver {estimator.solver!r}")
        fixed = not isinstance(self.scale, str)
        return {
            "schedule": _SCHEDULES[self.schedule],
            "scale": 2 if fixed else _SCALES[str(self.scale)],
            "scale_value": float(self.scale) if fixed else 0.0,
            "c_factor": float(self.c_factor),
            "noise_bound": 0.0 if self.noise_bound is None else float(self.noise_bound),
            "max_iterations": int(self.max_iterations),
            "eps0": float(self.eps0),
            "sigma_floor": float(self.sigma_floor),
            "mu_factor": float(self.mu_factor),
            "mu0": 0.0 if self.mu0 is None else float(self.mu0),
            "residual": estimator.residual.code,
            "all_candidates": estimator.solver == "lirp-all",
            "min_sample": estimator.sample_size,
            "cycle_period": CYCLE_MAX_PERIOD if detect_cycles else 0,
        }


@dataclass
class GNCBatchResult:
    """Stacked GNC-IRLS output: ``R (h,3,3)``, ``t (h,3)``, final ``weights (h,n)``, ``residuals (h,n)``
    of the returned pose, ``c (h,)`` final noise bound, ``num_iterations (h,)``, ``converged (h,)``."""

    R: np.ndarray
    t: np.ndarray
    weights: np.ndarray
    residuals: np.ndarray
    c: np.ndarray
    num_iterations: np.ndarray
    converged: np.ndarray


@dataclass(eq=False)
class GNCResult(ValueEquality):
    """GNC-IRLS output for one problem (:func:`poseonly.gnc_irls`): the pose ``R (3, 3)``, ``t (3,)``
    (``X2 = R X1 + t``, unit), the final ``weights (n,)`` and ``residuals (n,)`` of that pose, the
    final noise bound ``c`` (in the residual's units: radians for the Sampson error; ``v_LiGT`` is not an
    angle, see :func:`poseonly.gnc_ransac`), ``num_iterations`` and whether the loop ``converged``."""

    R: np.ndarray
    t: np.ndarray
    weights: np.ndarray
    residuals: np.ndarray
    c: float
    num_iterations: int
    converged: bool


def gnc_irls_batch(
    f1: np.ndarray,
    f2: np.ndarray,
    estimator: Estimator | None = None,
    options: GNCOptions | None = None,
    w0: np.ndarray | None = None,
    *,
    detect_cycles: bool = True,
) -> GNCBatchResult:
    """GNC-IRLS (Alg. 2) on ``h`` stacked problems ``f1, f2 (h, n, 3)`` (no validation).

    ``estimator`` defaults to LiRP + v_LiGT; ``w0 (h, n)`` optional initial weights (default ones).
    ``detect_cycles`` (default) ends a problem at a limit cycle with the outputs of the full loop
    (module docstring).
    """
    est = estimator or lirp_estimator()
    opts = options or GNCOptions()
    o = _core.gnc_irls_batch(
        np.ascontiguousarray(f1, dtype=float),
        np.ascontiguousarray(f2, dtype=float),
        None if w0 is None else np.ascontiguousarray(w0, dtype=float),
        opts.core_options(est, detect_cycles),
        check_signals=threading.current_thread() is threading.main_thread(),  # Ctrl-C between iterations
    )
    return GNCBatchResult(R=o["R"], t=o["t"], weights=o["weights"], residuals=o["residuals"], c=o["c"], num_iterations=o["num_iterations"], converged=o["converged"].astype(bool))
