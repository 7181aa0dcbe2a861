"""Pose-only geometry of one track, vectorised over all tracks (shared by LiGT and the
reconstruction).

World-frame bearings ``w = R_k^T x`` make every formula frame-free: for a track with base views
``l, r`` (the observation pair of largest ``theta = ||w_l x w_r||``, openMVG's rule) and
``g = (w_l x w_r) x w_r`` (so that ``g^T = a_lr^T R_r`` of the notes), the signed base depth is
``d_l = g^T (c_l - c_r) / theta^2`` (the notes' depth row; its magnitude is the paper's
``||[x_r]x t_lr|| / ||[x_r]x R_lr x_l||``) and the point is ``X = c_l + d_l w_l``.
"""

from __future__ import annotations

import numpy as np

from .tracks import Tracks

__all__ = ["base_depths", "base_views", "g_vectors", "world_bearings"]


def world_bearings(rotations: np.ndarray, views: np.ndarray, bearings: np.ndarray) -> np.ndarray:
    """``(M, 3)`` world-frame bearings ``R_v^T x`` of observations in ``views (M,)`` with camera
    bearings ``(M, 3)``; ``rotations (N, 3, 3)`` world -> camera."""
    return np.einsum("mji,mj->mi", rotations[views], bearings)


def base_views(tracks: Tracks, wb: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Base observations per track: ``(l, r, theta)``, each ``(T,)``; ``l, r`` are global
    observation indices (``l < r``) maximising ``theta = ||w_l x w_r||`` over the track's pairs.
    Vectorised per track length."""
    T = len(tracks)
    lengths = tracks.lengths
    L = np.zeros(T, dtype=np.int64)
    Rr = np.zeros(T, dtype=np.int64)
    th = np.zeros(T)
    for m in np.unique(lengths):
        ts = np.flatnonzero(lengths == m)
        idx = tracks.ptr[ts][:, None] + np.arange(m)[None, :]  # (t, m)
        a, b = np.triu_indices(int(m), 1)
        cr = np.cross(wb[idx[:, a]], wb[idx[:, b]])  # (t, P, 3)
        s = np.linalg.norm(cr, axis=2)
        k = np.argmax(s, axis=1)
        L[ts] = idx[np.arange(len(ts)), a[k]]
        Rr[ts] = idx[np.arange(len(ts)), b[k]]
        th[ts] = s[np.arange(len(ts)), k]
    return L, Rr, th


def g_vectors(wl: np.ndarray, wr: np.ndarray) -> np.ndarray:
    """``(T, 3)`` ``g = (w_l x w_r) x w_r`` (the world-frame ``a_lr^T R_r``)."""
    return np.cross(np.cross(wl, wr), wr)


def base_depths(wl: np.ndarray, wr: np.ndarray, cl: np.ndarray, cr: np.ndarray) -> np.ndarray:
    """``(T,)`` signed depth of the point along ``w_l`` from ``c_l``: ``g^T (c_l - c_r) / theta^2``."""
    g = g_vectors(wl, wr)
    th2 = np.sum(np.cross(wl, wr) ** 2, axis=1)
    return np.sum(g * (cl - cr), axis=1) / th2
