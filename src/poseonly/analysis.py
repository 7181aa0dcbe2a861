"""Analysis of a final model: cheirality-consistent support, planar twin, pure rotation, chance inliers.

Everything the status decision (:mod:`poseonly.result`) needs to know about a pose besides its own
inliers: whether the homography twin (:mod:`poseonly.twin`) explains the data about as well
(planar scene), whether a rotation without translation does (pure rotation), and how many inliers
the pose would collect by chance. Shapes: bearings ``f1, f2 (n, 3)`` (unit), ``R (3, 3)`` or
stacked ``(h, 3, 3)``, ``t (3,)`` or ``(h, 3)``; ``tau`` is an angle (radians).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .geometry import rotation_error_deg
from .residuals import v_sampson, v_sampson_chiral
from .twin import homography_twin

__all__ = [
    "REFINE_SOLVER",
    "analyse",
    "chance_inliers",
    "kabsch",
    "parallax_deg",
    "plausible_twin",
    "polish",
    "support",
]

# LiGTopt's optimiser inside the robust methods: the compact LM of poseonly.refine.ligt (same
# objective as scipy's least_squares, ~10-20x less time per call; docs/RESULTS.md section 2)
REFINE_SOLVER = "lm"
# the twin is reported when its support reaches this fraction of the pose's
TWIN_SUPPORT_RATIO = 0.9
# status pure_rotation when more than this fraction of the inliers fit a rotation within 2 tau
ROTATION_ONLY_FRACTION = 0.9
CHANCE_SEED = 20240611


def support(R: np.ndarray, t: np.ndarray, f1: np.ndarray, f2: np.ndarray, tau: float) -> np.ndarray:
    """Inliers ``(h, n)`` of stacked poses ``(h,3,3), (h,3)``: Sampson error below ``tau`` and
    positive depths (``v_sampson_chiral`` is 1 where a depth is not positive, and ``tau`` is far
    below 1)."""
    return v_sampson_chiral(R, t, f1, f2) < min(tau, 0.5)


def plausible_twin(R, t, tw, f1, f2, tau) -> bool:
    """Cheap screen before polishing a twin: its raw support reaches 30 % of the pose's (the twin of
    a non-planar scene keeps a few per cent; an unpolished planar twin measured 40-65 %)."""
    sup = support(np.stack([R, tw[0]]), np.stack([t, tw[1]]), f1, f2, tau * 1.5).sum(axis=1)
    return bool(sup[1] >= 0.3 * max(sup[0], 1))


def polish(R, t, f1, f2, tau):
    """Angular LiGTopt of a candidate on its cheirality-consistent inliers (twin comparison)."""
    from .refine.ligt import ligt_refine

    inl = support(R[None], t[None], f1, f2, tau * 1.5)[0]
    if inl.sum() < 6:
        inl = v_sampson(R, t, f1, f2) < tau * 1.5
        if inl.sum() < 6:
            return R, t
    try:
        r = ligt_refine(R, t, f1[inl], f2[inl], loss="cauchy", loss_scale=tau, normalization="angular", max_iter=20,
                        solver=REFINE_SOLVER)
    except ValueError:  # a degenerate candidate: keep it unpolished
        return R, t
    if np.all(np.isfinite(r.R)) and np.all(np.isfinite(r.t)):
        return r.R, r.t
    return R, t


def parallax_deg(R, f1, f2, inl) -> float:
    """Median angle (degrees) between ``R f1`` and ``f2`` over the inliers (NaN without any)."""
    if not np.any(inl):
        return float("nan")
    Rf1 = f1[inl] @ R.T
    c = np.clip(np.sum(Rf1 * f2[inl], axis=1), -1.0, 1.0)
    return float(np.degrees(np.median(np.arccos(c))))


def kabsch(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Rotation ``R`` minimising ``sum ||b_i - R a_i||^2`` (unit bearings ``(m, 3)``)."""
    U, _, Vt = np.linalg.svd(b.T @ a)
    D = np.diag([1.0, 1.0, np.sign(np.linalg.det(U @ Vt))])
    return U @ D @ Vt


def analyse(R, t, f1, f2, tau, inl) -> tuple[tuple[np.ndarray, np.ndarray, int] | None, float, dict[str, Any]]:
    """Planar homography twin and the pure-rotation test on the inliers ``inl (n,)``.

    Returns ``(twin, parallax_deg, info)``: ``twin = (R_twin, t_twin, support)`` or ``None``;
    ``info`` holds ``planarity``, ``support``/``twin_support``, ``rotation_only_fraction`` and
    ``R_rotation_only``.
    """
    info: dict[str, Any] = {}
    twin = None
    sel = np.nonzero(inl)[0]
    tw = homography_twin(R, t, f1[sel], f2[sel]) if len(sel) >= 6 else None
    if tw is not None:
        info["planarity"] = tw[2]
    if tw is not None and plausible_twin(R, t, tw, f1, f2, tau):
        Rt, tt = polish(tw[0], tw[1], f1, f2, tau)
        sup = support(np.stack([R, Rt]), np.stack([t, tt]), f1, f2, tau).sum(axis=1)
        info["support"], info["twin_support"] = int(sup[0]), int(sup[1])
        if sup[1] >= TWIN_SUPPORT_RATIO * sup[0] and rotation_error_deg(R, Rt) > 0.1:
            twin = (Rt, tt, int(sup[1]))
    par = parallax_deg(R, f1, f2, inl)
    if len(sel) >= 3:
        # pure-rotation model X2 ~ R_rot X1 fitted to the inliers (Kabsch, one re-selection)
        Rr = kabsch(f1[sel], f2[sel])
        ang = np.arccos(np.clip(np.sum((f1[sel] @ Rr.T) * f2[sel], axis=1), -1, 1))
        if np.count_nonzero(ang < 2.0 * tau) >= 3:
            keep = sel[ang < 2.0 * tau]
            Rr = kabsch(f1[keep], f2[keep])
            ang = np.arccos(np.clip(np.sum((f1[sel] @ Rr.T) * f2[sel], axis=1), -1, 1))
        info["rotation_only_fraction"] = float(np.mean(ang < 2.0 * tau))
        info["R_rotation_only"] = Rr
        par = float(np.degrees(np.median(ang)))
    return twin, par, info


def chance_inliers(R, t, f1, f2, tau, repeats: int = 3) -> float:
    """Mean inlier count of the model on randomly re-paired matches (fixed seed): how many inliers
    the model collects by chance. A pose whose support is not well above it is not trusted."""
    rng = np.random.default_rng(CHANCE_SEED)
    n = len(f1)
    perms = np.stack([rng.permutation(n) for _ in range(repeats)])
    # one pose per re-pairing, so that the compiled residual takes the stacked points
    v = v_sampson(np.broadcast_to(R, (repeats, 3, 3)), np.broadcast_to(t, (repeats, 3)),
                  np.broadcast_to(f1, (repeats,) + f1.shape), f2[perms])  # (repeats, n)
    return float(np.mean(np.count_nonzero(v < tau, axis=1)))
