"""The result type of :func:`poseonly.estimate_relative_pose` and the status decision.

:func:`finish` takes a method's final model, computes its inlier mask and residuals, runs the
analysis of :mod:`poseonly.analysis` and decides the status (``ok`` means "trust this pose").
:func:`degenerate_result` is the result of input that determines no pose.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .analysis import ROTATION_ONLY_FRACTION, analyse, chance_inliers
from .geometry import essential_from_pose, rotation_error_deg
from .residuals import v_sampson

__all__ = ["STATUSES", "RelativePoseResult", "degenerate_result", "finish"]

STATUSES = ("ok", "planar_ambiguous", "pure_rotation", "too_few_inliers", "degenerate")


@dataclass
class RelativePoseResult:
    """Relative pose ``X2 = R X1 + t`` (unit ``t``) with inliers and an honest status.

    ``status`` is one of

    * ``"ok"`` -- a confident calibrated pose;
    * ``"planar_ambiguous"`` -- the inliers are (near) planar and the homography twin (``R_twin``,
      ``t_twin``) explains them about as well; the caller must decide (e.g. with a third view);
    * ``"pure_rotation"`` -- rotation-only motion explains the inliers: ``R`` is reliable, the
      translation direction is not (``parallax_deg`` says how much parallax there is);
    * ``"too_few_inliers"`` -- fewer than 6 inliers (or fewer than ``min_inliers``); ``R, t`` are the
      best guess and should not be trusted;
    * ``"degenerate"`` -- the correspondences do not determine a pose (e.g. all points identical).
    """

    R: np.ndarray
    t: np.ndarray
    E: np.ndarray
    inliers: np.ndarray
    weights: np.ndarray
    residuals_px: np.ndarray
    num_inliers: int
    num_iterations: int
    status: str
    message: str
    method: str
    threshold_px: float
    focal_px: float
    parallax_deg: float = float("nan")
    R_twin: np.ndarray | None = None
    t_twin: np.ndarray | None = None
    twin_inliers: int = 0
    time_s: float = 0.0
    diagnostics: dict[str, Any] = field(default_factory=dict)

    @property
    def ok(self) -> bool:
        return self.status == "ok"

    @property
    def inlier_ratio(self) -> float:
        return self.num_inliers / max(len(self.inliers), 1)

    def to_dict(self) -> dict[str, Any]:
        """JSON-friendly summary."""
        d = {
            "R": self.R.tolist(),
            "t": self.t.tolist(),
            "num_inliers": self.num_inliers,
            "num_points": len(self.inliers),
            "inlier_ratio": self.inlier_ratio,
            "num_iterations": self.num_iterations,
            "status": self.status,
            "message": self.message,
            "method": self.method,
            "threshold_px": self.threshold_px,
            "focal_px": self.focal_px,
            "parallax_deg": self.parallax_deg,
            "time_s": self.time_s,
        }
        if self.R_twin is not None:
            d["R_twin"] = self.R_twin.tolist()
            d["t_twin"] = self.t_twin.tolist()
            d["twin_inliers"] = self.twin_inliers
        return d


def finish(method, R, t, f1, f2, w, tau, focal, thr_px, iters, t0, diag, min_inliers=15) -> RelativePoseResult:
    """Inliers, residuals, analysis and status of a method's final model ``(R, t)``."""
    if "tau_effective" in diag:  # the default method's noise-matched threshold (<= the user's)
        tau = diag["tau_effective"]
        thr_px = tau * focal
    v = v_sampson(R, t, f1, f2)
    inl = v < tau
    n_in = int(inl.sum())
    weights = inl.astype(float) if w is None else w
    twin, par, info = (None, float("nan"), {})
    if n_in >= 6:
        twin, par, info = analyse(R, t, f1, f2, tau, inl)
    R_twin = t_twin = None
    twin_n = 0
    chance = chance_inliers(R, t, f1, f2, tau) if n_in >= 6 else 0.0
    diag["chance_inliers"] = chance
    needed = max(6, min_inliers, int(np.ceil(chance + 4.0 * np.sqrt(chance) + 4.0)))
    if n_in < needed:
        status, msg = "too_few_inliers", (f"only {n_in} inliers within {thr_px:g} px (needed {needed}; the same "
                                          f"model keeps {chance:.1f} of randomly re-paired matches): the pose is not reliable")
    elif info.get("rotation_only_fraction", 0.0) > ROTATION_ONLY_FRACTION:
        status = "pure_rotation"
        R = info.pop("R_rotation_only")  # the rotation-only fit is the better estimate of R here
        msg = (f"{100 * info['rotation_only_fraction']:.0f}% of the inliers fit a pure rotation within "
               f"{2 * thr_px:g} px (median parallax {par:.3f} deg): R is reliable, the translation direction is not")
    elif twin is not None:
        status = "planar_ambiguous"
        R_twin, t_twin, twin_n = twin
        msg = (f"the inliers are explained by two poses {rotation_error_deg(R, R_twin):.2f} deg apart "
               f"(planar scene: the homography twin keeps {twin_n} inliers in front of both cameras); see R_twin, t_twin")
    else:
        status, msg = "ok", f"{n_in} inliers within {thr_px:g} px"
    info.pop("R_rotation_only", None)
    diag.update(info)
    return RelativePoseResult(
        R=R, t=t, E=essential_from_pose(R, t), inliers=inl, weights=np.asarray(weights, float), residuals_px=v * focal,
        num_inliers=n_in, num_iterations=int(iters), status=status, message=msg, method=method, threshold_px=float(thr_px),
        focal_px=focal, parallax_deg=par, R_twin=R_twin, t_twin=t_twin, twin_inliers=twin_n,
        time_s=time.perf_counter() - t0, diagnostics=diag,
    )


def degenerate_result(n: int, rank: int, method: str, thr_px: float, focal: float, t0: float) -> RelativePoseResult:
    """Result of ``n`` correspondences whose epipolar system has rank ``rank < 6``."""
    R, t = np.eye(3), np.zeros(3)
    return RelativePoseResult(
        R=R, t=t, E=np.zeros((3, 3)), inliers=np.zeros(n, bool), weights=np.zeros(n), residuals_px=np.full(n, np.nan),
        num_inliers=0, num_iterations=0, status="degenerate",
        message=f"the correspondences span a rank-{rank} epipolar system (< 6): the pose is not determined",
        method=method, threshold_px=thr_px, focal_px=focal, time_s=time.perf_counter() - t0, diagnostics={"rank": rank},
    )
