"""Baseline solvers wrapped as batched estimator solvers and registered by name.

Each wrapper turns a candidate-essential-matrix solver into the
:data:`poseonly.estimator.Solver` shape: every candidate of every sample is reduced to one pose
with the pose-only depth conditions on the sample's own points (:func:`identify_poses`);
candidates failing them, or coming from complex roots, are returned as NaN so the robust loops
drop them. Importing this module registers ``5pt``, ``7pt``, ``8pt``, ``6pt-philip`` and
``6pt-pizarro``.
"""

from __future__ import annotations

import numpy as np

from .estimator import register_solver
from .identify import identify_poses
from .solvers.eightpt import eightpt_batch
from .solvers.fivept import fivept_batch
from .solvers.sevenpt import sevenpt_batch
from .solvers.sixpt import sixpt_philip_batch, sixpt_pizarro_batch

__all__ = ["wrap_essential_solver"]


def wrap_essential_solver(batch_fn, real_key: str | None = None):
    """Batched ``(f1, f2, w) -> dict(E (h,k,3,3), mask (h,k))`` -> batched pose solver."""

    def solve(f1: np.ndarray, f2: np.ndarray, w: np.ndarray | None = None):
        out = batch_fn(f1, f2, w)
        E = out["E"]
        keep = out.get("mask", np.ones(E.shape[:2], bool))
        if real_key and real_key in out:
            keep = keep & out[real_key]
        E = np.where(np.isfinite(E), E, 0.0)
        R, t, valid, _ = identify_poses(E, f1, f2, w)
        keep = keep & valid
        R = np.where(keep[..., None, None], R, np.nan)
        t = np.where(keep[..., None], t, np.nan)
        return R, t

    return solve


register_solver("5pt", wrap_essential_solver(fivept_batch, "is_real"), 5)
register_solver("7pt", wrap_essential_solver(sevenpt_batch), 7)
register_solver("8pt", wrap_essential_solver(eightpt_batch), 8)
register_solver("6pt-philip", wrap_essential_solver(sixpt_philip_batch), 6)
register_solver("6pt-pizarro", wrap_essential_solver(sixpt_pizarro_batch), 6)
