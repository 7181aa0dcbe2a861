"""Runners of the non-default methods of :func:`poseonly.estimate_relative_pose`.

Each runner takes unit bearings ``f1, f2 (n, 3)``, the method's checked options and the angle
threshold ``tau`` and returns ``(R (3, 3), t (3,), weights (n,) | None, iterations, diagnostics)``.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from ..estimator import lirp_estimator
from ..geometry import InputError
from ..options import CommonOptions, GncIrlsOptions, GncRansacOptions
from ..solvers.lirp import lirp_batch
from .default import make_rng, refine_ligt, run_poseonly
from .gnc import GNCOptions, gnc_irls_batch
from .ransac import gnc_ransac

__all__ = ["RUNNERS", "run_gnc_irls", "run_gnc_ransac", "run_lirp"]

Runner = Callable[[np.ndarray, np.ndarray, Any, float], tuple[np.ndarray, np.ndarray, "np.ndarray | None", int, dict]]


def run_gnc_ransac(f1: np.ndarray, f2: np.ndarray, o: GncRansacOptions, tau: float):
    """The paper's Algorithm 3 (samples of ``n_s``, GNC-IRLS per sample), then LiGTopt."""
    rng = make_rng(o.seed)
    if o.sample_size > len(f1):
        raise InputError(f"sample_size n_s = {o.sample_size} is larger than the number of points {len(f1)}")
    est = lirp_estimator(o.residual)
    gopts = GNCOptions(schedule=o.schedule, scale=o.scale)
    r = gnc_ransac(f1, f2, tau, rng, estimator=est, sample_size=o.sample_size, max_iterations=o.max_iterations, gnc_options=gopts, adaptive=o.adaptive, confidence=o.confidence)
    R, t = r.R, r.t
    if o.refine:
        R, t = refine_ligt(R, t, f1, f2, r.inliers, tau)
    return R, t, r.weights, r.num_iterations, {"best_sample_inliers": int(r.score), "num_hypotheses": r.num_iterations + 1}


def run_gnc_irls(f1: np.ndarray, f2: np.ndarray, o: GncIrlsOptions, tau: float):
    """Algorithm 2 on all points (noise bound ``tau`` unless ``scale`` is given), then LiGTopt."""
    est = lirp_estimator(o.residual)
    if o.scale is None:
        gopts = GNCOptions(schedule=o.schedule, noise_bound=tau, max_iterations=o.max_iterations)
    else:
        gopts = GNCOptions(schedule=o.schedule, scale=o.scale, max_iterations=o.max_iterations)
    g = gnc_irls_batch(f1[None], f2[None], est, gopts)
    R, t, w = g.R[0], g.t[0], g.weights[0]
    if o.refine:
        R, t = refine_ligt(R, t, f1, f2, w > 0.5, tau)
    return R, t, w, int(g.num_iterations[0]), {"converged": bool(g.converged[0]), "noise_bound": float(g.c[0]), "num_hypotheses": 1}


def run_lirp(f1: np.ndarray, f2: np.ndarray, o: CommonOptions, tau: float):
    """Algorithm 1 on all points (no robustness)."""
    out = lirp_batch(f1[None], f2[None])
    return out["R"][0], out["t"][0], np.ones(len(f1)), 1, {"d_min": float(out["d_min"][0]), "num_hypotheses": 1}


RUNNERS: dict[str, Runner] = {"poseonly": run_poseonly, "gnc-ransac": run_gnc_ransac, "gnc-irls": run_gnc_irls, "lirp": run_lirp}
