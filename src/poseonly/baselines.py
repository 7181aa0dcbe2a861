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

from . import _kernels
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


def _fivept_real(f1: np.ndarray, f2: np.ndarray, w: np.ndarray | None = None) -> dict:
    """Real five-point solutions: the compiled minimal solver (:func:`poseonly._kernels.fivept_real`,
    ~10 us per sample instead of ~45 us) on unweighted minimal samples, :func:`fivept_batch` otherwise
    and for the samples where the compiled solver broke down. Same solutions to rounding (the
    equivalence test compares them with the previous code)."""
    if w is None and f1.ndim == 3 and f1.shape[1] == 5 and _kernels.enabled():
        E, mask, fail = _kernels.fivept_real(f1, f2)
        if fail.any():
            o = fivept_batch(f1[fail], f2[fail])
            E[fail] = o["E"]
            mask[fail] = o["is_real"]
        return {"E": E, "mask": mask}
    o = fivept_batch(f1, f2, w)
    return {"E": o["E"], "mask": o["is_real"]}


register_solver("5pt", wrap_essential_solver(_fivept_real), 5)
register_solver("7pt", wrap_essential_solver(sevenpt_batch), 7)
register_solver("8pt", wrap_essential_solver(eightpt_batch), 8)
register_solver("6pt-philip", wrap_essential_solver(sixpt_philip_batch), 6)
register_solver("6pt-pizarro", wrap_essential_solver(sixpt_pizarro_batch), 6)
