"""The estimator contract of the robust loops, and the typed candidates every solver returns.

The loops themselves are C++ templates (``src/core/ransac.h``: ``ransac<Estimator, Scorer,
Sampler>``, in the spirit of PoseLib's ``ransac<>`` and COLMAP's ``LORANSAC<Estimator,
SupportMeasurer, Sampler>``): an estimator provides ``sample_size``, ``generate`` (the solver),
``terms``/``residual`` (one row of the residual table), ``refine`` (the local optimisation step) and
``success_probability`` (the adaptive stopping rule); a scorer (MSAC, multi-scale MSAC, inlier
count) measures support with an exact early bail-out; a sampler is uniform or PROSAC. The estimators
compiled in are the default method's (5-point or 6-point LiRP hypotheses, LO by weighted LiRP), the
paper's GNC-RANSAC (GNC-IRLS fits of 30-point samples) and a 2-D line estimator that the tests run
through the same loop.

This module is the Python face: :class:`Estimator` names the solver and the residual a loop binds,
and :class:`Candidates` is the one shape every solver's output takes.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .residuals import Residual, get_residual

__all__ = ["Candidates", "Estimator", "SOLVERS", "lirp_estimator", "get_estimator"]

# solver name -> minimal sample size; these are the solvers compiled into the core's loops
SOLVERS: dict[str, int] = {"lirp": 6, "lirp-all": 6, "5pt": 5}


@dataclass(frozen=True)
class Candidates:
    """Identified candidate poses of ``h`` stacked problems: ``R (h, k, 3, 3)``, unit ``t (h, k, 3)``
    and ``valid (h, k)`` (the slot holds a pose that passed the solver's checks: a real root, positive
    pose-only depths). Invalid slots hold NaN poses."""

    R: np.ndarray
    t: np.ndarray
    valid: np.ndarray

    def __post_init__(self) -> None:
        if self.R.shape[:-2] != self.valid.shape or self.t.shape[:-1] != self.valid.shape:
            raise ValueError(f"inconsistent candidate shapes R {self.R.shape}, t {self.t.shape}, valid {self.valid.shape}")

    @property
    def num_problems(self) -> int:
        return int(self.valid.shape[0])


@dataclass(frozen=True)
class Estimator:
    """A solver of the core (``lirp``: LiRP's identified pose; ``lirp-all``: the LiRP candidate that
    minimises the loop's weighted residual; ``5pt``: five-point hypotheses) bound to a residual."""

    solver: str
    residual: Residual

    def __post_init__(self) -> None:
        if self.solver not in SOLVERS:
            raise ValueError(f"unknown solver {self.solver!r}; choose one of {sorted(SOLVERS)}")

    @property
    def name(self) -> str:
        return self.solver

    @property
    def sample_size(self) -> int:
        return SOLVERS[self.solver]

    def with_residual(self, residual: str | Residual) -> Estimator:
        return Estimator(self.solver, get_residual(residual))


def lirp_estimator(residual: str | Residual = "ligt") -> Estimator:
    """LiRP with the LiGT residual: the paper's estimator."""
    return Estimator("lirp", get_residual(residual))


def get_estimator(solver: str = "lirp", residual: str | Residual = "ligt") -> Estimator:
    """Estimator by solver name (:data:`SOLVERS`) and residual name."""
    if not isinstance(solver, str) or solver not in SOLVERS:
        raise ValueError(f"unknown solver {solver!r}; choose one of {sorted(SOLVERS)}")
    return Estimator(solver, get_residual(residual))
