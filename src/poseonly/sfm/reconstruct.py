"""Pose-only analytical reconstruction of every track point (no triangulation, no optimisation).

With the base views ``l, r`` of a track (:mod:`.posegeom`): signed depth
``d_l = g^T (c_l - c_r) / theta^2`` (whose magnitude is the paper's
``||[x_r]x t_lr|| / ||[x_r]x R_lr x_l||``) and ``X = c_l + d_l R_l^T x_l``; exact for exact poses.

Filters: cheirality (``d_l > 0`` and a positive depth ``(X - c_i)^T w_i`` in every kept view) and
the reprojection error ``focal * tan(angle(x_i, R_i (X - c_i)))`` in pixels below
``max_error_px``. An observation failing either is flagged; a point is valid when both base
observations pass and at least ``min_views`` observations pass.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..geometry import InputError
from .inputs import checked_bearings, checked_centres, checked_count, checked_positive, checked_rotations
from .posegeom import base_depths, base_views, world_bearings
from .tracks import Tracks

__all__ = ["MAX_ERROR_PX", "Reconstruction", "reconstruct_points"]

MAX_ERROR_PX = 4.0


@dataclass
class Reconstruction:
    """``points (T, 3)`` (NaN where the track has a view without pose), ``valid (T,)``,
    ``obs_valid (M,)``, ``error_px (M,)`` reprojection errors (inf behind the camera),
    ``base (T, 2)`` base observation indices."""

    points: np.ndarray
    valid: np.ndarray
    obs_valid: np.ndarray
    error_px: np.ndarray
    base: np.ndarray

    @property
    def num_valid(self) -> int:
        return int(np.sum(self.valid))


def reconstruct_points(
    rotations: np.ndarray,
    centres: np.ndarray,
    tracks: Tracks,
    bearings: np.ndarray,
    *,
    focal: float,
    max_error_px: float = MAX_ERROR_PX,
    min_views: int = 2,
) -> Reconstruction:
    """Points of all ``T`` tracks from ``rotations (N, 3, 3)`` (world -> camera), ``centres (N, 3)``
    (NaN rows: view not posed; its observations are ignored), camera-frame unit ``bearings (M, 3)``
    and ``focal`` (pixels, converts angles to reprojection pixels)."""
    Rg = checked_rotations(rotations, "rotations", missing=True)
    C = checked_centres(centres, "centres", len(Rg))
    if not isinstance(tracks, Tracks):
        raise InputError(f"tracks must be a poseonly.sfm.tracks.Tracks, got {type(tracks).__name__}")
    f = checked_bearings(bearings, "bearings", tracks.num_observations)
    if len(tracks) and tracks.views.max() >= len(Rg):
        raise InputError(f"tracks reference view {tracks.views.max()} but only {len(Rg)} rotations are given")
    focal = checked_positive(focal, "focal")
    max_error_px = checked_positive(max_error_px, "max_error_px")
    min_views = checked_count(min_views, "min_views", 2)
    posed = np.all(np.isfinite(Rg), axis=(1, 2)) & np.all(np.isfinite(C), axis=1)
    obs_posed = posed[tracks.views]
    cnt = np.bincount(tracks.track_of_observation[obs_posed], minlength=len(tracks))
    T, M = len(tracks), tracks.num_observations
    points = np.full((T, 3), np.nan)
    base = np.full((T, 2), -1, dtype=np.int64)
    err = np.full(M, np.inf)
    # reconstruct tracks restricted to their posed observations
    sub = Tracks(np.concatenate([[0], np.cumsum(cnt)]).astype(np.int64), tracks.views[obs_posed], tracks.keypoints[obs_posed])
    obs_idx = np.flatnonzero(obs_posed)
    Rs = np.where(posed[:, None, None], Rg, np.eye(3))
    Cs = np.where(posed[:, None], C, 0.0)
    ok_t = cnt >= 2
    if np.any(ok_t):
        s2 = sub.subset(ok_t)
        keep = np.repeat(ok_t, cnt)
        oi2 = obs_idx[keep]
        wb = world_bearings(Rs, s2.views, f[oi2])
        lo, ro, _th = base_views(s2, wb)
        vl, vr = s2.views[lo], s2.views[ro]
        with np.errstate(divide="ignore", invalid="ignore"):
            d = base_depths(wb[lo], wb[ro], Cs[vl], Cs[vr])
        X = Cs[vl] + d[:, None] * wb[lo]
        ids = np.flatnonzero(ok_t)
        points[ids] = X
        base[ids, 0], base[ids, 1] = oi2[lo], oi2[ro]
        tr = s2.track_of_observation
        v = X[tr] - Cs[s2.views]
        along = np.sum(v * wb, axis=1)
        perp = np.linalg.norm(np.cross(v, wb), axis=1)
        with np.errstate(divide="ignore", invalid="ignore"):
            e = np.where(along > 0, focal * perp / along, np.inf)
        e[~np.isfinite(e)] = np.inf
        e[(d <= 0)[tr] | ~np.isfinite(d)[tr]] = np.inf
        err[oi2] = e
    obs_valid = err <= max_error_px
    n_ok = np.bincount(tracks.track_of_observation[obs_valid], minlength=T)
    valid = (base[:, 0] >= 0) & (n_ok >= int(min_views))
    valid[valid] &= obs_valid[base[valid, 0]] & obs_valid[base[valid, 1]]
    return Reconstruction(points, valid, obs_valid, err, base)
