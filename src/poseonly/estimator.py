"""The small protocol the robust loops need (in the spirit of PoseLib and COLMAP estimators).

An :class:`Estimator` binds

* a **solver** ``solve(f1 (h, m, 3), f2 (h, m, 3), w (h, m) | None) -> (R (h, k, 3, 3), t (h, k, 3))``
  returning ``k`` identified candidate poses for each of ``h`` stacked problems (LiRP returns its
  best candidate, ``k = 1``; a minimal solver returns all its roots);
* a **residual** ``(R (..., 3, 3), t (..., 3), f1, f2) -> (..., n)`` from :mod:`poseonly.residuals`;
* the solver's ``sample_size`` (minimal number of points).

RANSAC, GNC-IRLS and GNC-RANSAC in :mod:`poseonly.robust` only talk to this interface, so a new
solver or residual plugs in without touching them.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from .residuals import Residual, get_residual
from .solvers.lirp import lirp_batch

__all__ = ["Estimator", "Solver", "lirp_solver", "lirp_all_solver", "lirp_estimator", "get_estimator", "register_solver", "SOLVERS"]

Solver = Callable[[np.ndarray, np.ndarray, "np.ndarray | None"], tuple[np.ndarray, np.ndarray]]


def lirp_solver(f1: np.ndarray, f2: np.ndarray, w: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Weighted LiRP (Alg. 1) as a batched solver: one identified pose per problem."""
    o = lirp_batch(f1, f2, w)
    return o["R"][:, None], o["t"][:, None]


def lirp_all_solver(f1: np.ndarray, f2: np.ndarray, w: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Weighted LiRP returning all 18 identified candidates (NaN where the pose-only depth
    conditions fail), so a robust loop can choose the one minimising its own objective."""
    o = lirp_batch(f1, f2, w)
    ok = o["cand_valid"]
    none = ~np.any(ok, axis=1)
    ok = ok | none[:, None]  # no valid candidate: keep all rather than none
    return np.where(ok[..., None, None], o["cand_R"], np.nan), np.where(ok[..., None], o["cand_t"], np.nan)


@dataclass(frozen=True)
class Estimator:
    """Solver + residual + minimal sample size (see the module docstring)."""

    name: str
    solve: Solver
    sample_size: int
    residual: Residual

    def with_residual(self, residual: str | Residual) -> "Estimator":
        return Estimator(self.name, self.solve, self.sample_size, get_residual(residual))


SOLVERS: dict[str, tuple[Solver, int]] = {"lirp": (lirp_solver, 6), "lirp-all": (lirp_all_solver, 6)}


def register_solver(name: str, solver: Solver, sample_size: int) -> None:
    """Make a batched solver available to :func:`get_estimator` by name."""
    SOLVERS[name] = (solver, sample_size)


def lirp_estimator(residual: str | Residual = "ligt") -> Estimator:
    """LiRP with the LiGT residual: the paper's estimator."""
    return Estimator("lirp", lirp_solver, 6, get_residual(residual))


def get_estimator(solver: str = "lirp", residual: str | Residual = "ligt") -> Estimator:
    """Estimator by solver name (``lirp`` and any registered solver, e.g. ``5pt``)."""
    if solver not in SOLVERS:
        try:  # baseline solvers register themselves on import
            from . import baselines  # noqa: F401
        except ImportError:
            pass
    if solver not in SOLVERS:
        raise ValueError(f"unknown solver {solver!r}; choose one of {sorted(SOLVERS)}")
    fn, m = SOLVERS[solver]
    return Estimator(solver, fn, m, get_residual(residual))
