"""Evaluation against ground truth: 7-DoF similarity alignment of camera centres (Umeyama) and
per-camera errors, openMVG's ``main_evalQuality`` protocol."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..geometry import InputError, as_real_array
from .inputs import MAX_COORDINATE
from .so3 import angle_deg, project_so3

__all__ = ["AUC_THRESHOLDS_DEG", "Similarity", "align_similarity", "evaluate_poses", "pose_auc", "relative_pose_errors"]


@dataclass(frozen=True)
class Similarity:
    """``x -> s R x + t``: ``s`` scale, ``R (3, 3)``, ``t (3,)``."""

    s: float
    R: np.ndarray
    t: np.ndarray

    def apply(self, x: np.ndarray) -> np.ndarray:
        """``(n, 3)`` -> ``(n, 3)``."""
        return self.s * np.asarray(x) @ self.R.T + self.t


def align_similarity(src: np.ndarray, dst: np.ndarray) -> Similarity:
    """Least-squares similarity (Umeyama 1991) with ``dst ~ s R src + t``; ``(n, 3)`` each,
    ``n >= 3`` non-collinear points."""
    a = as_real_array(src, "src")
    b = as_real_array(dst, "dst")
    if a.shape != b.shape or a.ndim != 2 or a.shape[1] != 3 or len(a) < 3:
        raise InputError(f"align_similarity needs two (n >= 3, 3) arrays, got {a.shape} and {b.shape}")
    if not (np.all(np.isfinite(a)) and np.all(np.isfinite(b))) or max(np.abs(a).max(), np.abs(b).max()) > MAX_COORDINATE:
        raise InputError(f"align_similarity needs finite points below {MAX_COORDINATE:g} in magnitude")
    ma, mb = a.mean(0), b.mean(0)
    A, B = a - ma, b - mb
    va = np.sum(A * A) / len(a)
    if va <= 0 or np.sum(B * B) <= 0:
        raise InputError(f"align_similarity: the {'source' if va <= 0 else 'destination'} points are all identical")
    S = B.T @ A / len(a)
    U, d, Vt = np.linalg.svd(S)
    D = np.eye(3)
    if np.linalg.det(U) * np.linalg.det(Vt) < 0:
        D[2, 2] = -1
    R = U @ D @ Vt
    s = float(np.trace(np.diag(d) @ D) / va)
    return Similarity(s, R, mb - s * R @ ma)


def evaluate_poses(rotations: np.ndarray, centres: np.ndarray, R_gt: np.ndarray, C_gt: np.ndarray) -> dict[str, object]:
    """Errors of estimated world -> camera ``rotations (N, 3, 3)`` and ``centres (N, 3)`` (NaN:
    not estimated) against the ground truth, over the estimated views.

    A similarity is fitted on the centres; the position error is ``||C_gt - (s R C + t)||`` (ground-
    truth units, and divided by the extent = largest distance of a ground-truth centre from their
    mean); the rotation error is the angle of ``R_gt^T (R_est R_sim^T)`` with the fitted
    similarity (openMVG's protocol) and, beside it, after the best rotation-only alignment
    (chordal L2 mean), which does not mix position errors into the rotations.
    """
    R, C = as_real_array(rotations, "rotations"), as_real_array(centres, "centres")
    R_gt, C_gt = as_real_array(R_gt, "R_gt"), as_real_array(C_gt, "C_gt")
    if R.ndim != 3:
        raise InputError(f"evaluate_poses: rotations must have shape (N, 3, 3), got {R.shape}")
    n = len(R)
    for name, a, shape in (("rotations", R, (n, 3, 3)), ("centres", C, (n, 3)), ("R_gt", R_gt, (n, 3, 3)), ("C_gt", C_gt, (n, 3))):
        if a.shape != shape:
            raise InputError(f"evaluate_poses: {name} must have shape (N, {', '.join(map(str, shape[1:]))}) with N = {n} views, got {a.shape}")
    if not (np.all(np.isfinite(R_gt)) and np.all(np.isfinite(C_gt))):
        raise InputError("evaluate_poses: the ground truth must be finite")
    est = np.all(np.isfinite(R), axis=(1, 2)) & np.all(np.isfinite(C), axis=1)
    if est.sum() < 3:
        raise InputError("evaluate_poses needs at least 3 estimated cameras")
    sim = align_similarity(C[est], C_gt[est])
    pos = np.linalg.norm(C_gt[est] - sim.apply(C[est]), axis=1)
    extent = float(np.max(np.linalg.norm(C_gt - C_gt.mean(0), axis=1)))
    # the similarity maps world_est -> world_gt: R_est_in_gt = R_est R_sim^T
    rot = angle_deg(np.einsum("nji,njk->nik", R_gt[est], R[est] @ sim.R.T))
    # rotation-only alignment: Q = argmin sum ||R_gt_k - R_k Q||, Q = proj(sum R_k^T R_gt_k)
    Q = project_so3(np.einsum("nji,njk->ik", R[est], R_gt[est])[None])[0]
    rot2 = angle_deg(np.einsum("nji,njk->nik", R_gt[est], R[est] @ Q))
    per = np.full(len(R), np.nan)
    per[est] = rot
    per_pos = np.full(len(R), np.nan)
    per_pos[est] = pos
    return {
        "num_estimated": int(est.sum()),
        "rotation_deg": per,
        "position": per_pos,
        "rot_mean_deg": float(rot.mean()),
        "rot_median_deg": float(np.median(rot)),
        "rot_max_deg": float(rot.max()),
        "rot_mean_deg_rotalign": float(rot2.mean()),
        "pos_mean": float(pos.mean()),
        "pos_median": float(np.median(pos)),
        "pos_max": float(pos.max()),
        "extent": extent,
        "pos_mean_frac": float(pos.mean() / extent),
        "scale": sim.s,
    }


AUC_THRESHOLDS_DEG = (0.5, 1.0, 5.0, 10.0)


def relative_pose_errors(rotations: np.ndarray, centres: np.ndarray, R_gt: np.ndarray, C_gt: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rotation and translation-direction errors (deg), ``(P,)`` each, of all pairs ``i < j``
    (``P = N (N - 1) / 2``); a pair with an unestimated view gets ``inf`` (COLMAP's benchmark)."""
    n = len(R_gt)
    i, j = np.triu_indices(n, 1)
    est = np.all(np.isfinite(rotations), axis=(1, 2)) & np.all(np.isfinite(centres), axis=1)
    Rs = np.where(est[:, None, None], rotations, np.eye(3))
    Cs = np.where(est[:, None], centres, 0.0)

    def rel(R, C):
        Rij = R[j] @ np.transpose(R[i], (0, 2, 1))
        t = np.einsum("pab,pb->pa", R[j], C[i] - C[j])
        return Rij, t / np.maximum(np.linalg.norm(t, axis=1, keepdims=True), 1e-300)

    Re, te = rel(Rs, Cs)
    Rg, tg = rel(R_gt, C_gt)
    dR = angle_deg(np.einsum("pji,pjk->pik", Rg, Re))
    dt = np.degrees(np.arctan2(np.linalg.norm(np.cross(te, tg), axis=1), np.sum(te * tg, axis=1)))  # accurate near 0
    bad = ~(est[i] & est[j])
    dR[bad] = np.inf
    dt[bad] = np.inf
    return dR, dt


def pose_auc(errors_deg: np.ndarray, thresholds: tuple[float, ...] = AUC_THRESHOLDS_DEG) -> dict[str, float]:
    """Area under the recall-vs-error curve up to each threshold, normalised to [0, 1]
    (the SuperGlue / COLMAP benchmark definition), of ``(P,)`` errors (inf counts as a miss)."""
    e = np.sort(np.asarray(errors_deg, dtype=np.float64))
    recall = np.arange(1, len(e) + 1) / len(e)
    e = np.concatenate([[0.0], e])
    recall = np.concatenate([[0.0], recall])
    out = {}
    for t in thresholds:
        last = int(np.searchsorted(e, t))
        x = np.concatenate([e[:last], [t]])
        y = np.concatenate([recall[:last], [recall[last - 1]]])
        out[f"auc@{t:g}"] = float(np.trapezoid(y, x) / t)
    return out
