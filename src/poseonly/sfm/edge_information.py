"""Information (inverse covariance) of each two-view relative rotation, for rotation averaging.

First-order covariance of a least-squares two-view pose (Hartley and Zisserman, section 5.2; used for
rotation averaging by Zhang, Larsson and Kahl, "Revisiting Rotation Averaging: Uncertainties and
Robust Losses", CVPR 2023): with the edge's inliers' signed Sampson errors ``r_k`` (radians on the
sphere) independent with scale ``sigma``, the Gauss-Newton information of the five pose parameters is
``J^T J / sigma^2``, ``J (m, 5)`` the Jacobian of ``r`` in ``R exp([d]x)`` (``d`` in view i's frame)
and the translation direction on the sphere. The rotation's information is the Schur complement of the
translation block (the direction marginalised): a rotation about an axis that trades against the
translation (narrow fields of view, forward motion) is known less well than one about the baseline,
which an inlier count cannot say. A ``pure_rotation`` edge (translation not trusted) has the
information of its rotation-only fit, the chord residuals ``R f1 - f2`` in the tangent plane of ``f2``.
The computation is the core's ``pose_covariance`` (which the status analysis also uses, there with the
search threshold's truncation undone; here on the edge's inlier matches, no threshold).

``sigma`` is the edge's own robust scale, ``1.4826 median |r|`` over its inliers (the chords: median
norm / sqrt(2 ln 2), a Rayleigh's median) (pairs of one scene differ in blur, scale change and viewing
angle), so a pair with noisier matches weighs less.

Shapes: bearings ``f1, f2 (m, 3)`` (unit, the edge's inliers), ``R (3, 3)``, ``t (3,)``; information
``(3, 3)`` symmetric positive semi-definite, in view i's frame (``d`` above).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from .. import _core
from ..geometry import skew
from .tracks import Tracks
from .viewgraph import ViewGraph

__all__ = ["MIN_EDGE_MATCHES", "edge_informations", "rotation_information", "signed_sampson"]

# below this many inliers an edge's information is not estimated (None): 5 parameters and a scale
MIN_EDGE_MATCHES = 8
# the smallest eigenvalue of an information is raised to this fraction of its largest (a direction the
# edge does not constrain still gets a finite weight, so every averaging solve stays well posed)
MIN_EIGEN_RATIO = 1e-6


def signed_sampson(R: np.ndarray, t: np.ndarray, f1: np.ndarray, f2: np.ndarray) -> np.ndarray:
    """``(m,)`` signed Sampson errors on the sphere (radians; ``poseonly.residuals.v_sampson`` is their
    absolute value): ``f2^T E f1 / sqrt(|P_f2 E f1|^2 + |P_f1 E^T f2|^2)``, ``E = [t]x R``, unit ``t``."""
    E = skew(t / np.linalg.norm(t)) @ R
    Ef1 = f1 @ E.T
    Etf2 = f2 @ E
    num = np.einsum("ij,ij->i", Ef1, f2)
    den = np.einsum("ij,ij->i", Ef1, Ef1) + np.einsum("ij,ij->i", Etf2, Etf2) - 2.0 * num * num
    return num / np.sqrt(np.maximum(den, 1e-300))


def _floor(info: np.ndarray) -> np.ndarray | None:
    """``info`` symmetrised with its eigenvalues raised to :data:`MIN_EIGEN_RATIO` of the largest;
    None when it has no positive eigenvalue or is not finite."""
    if not np.all(np.isfinite(info)):
        return None
    w, V = np.linalg.eigh(0.5 * (info + info.T))
    if not w[-1] > 0:
        return None
    w = np.maximum(w, MIN_EIGEN_RATIO * float(w[-1]))
    return (V * w) @ V.T


def rotation_information(R: np.ndarray, t: np.ndarray | None, f1: np.ndarray, f2: np.ndarray) -> np.ndarray | None:
    """Information ``(3, 3)`` of the rotation of the pose ``X2 = R X1 + t`` estimated from the inlier
    bearings ``f1, f2 (m, 3)``, in the right perturbation ``R exp([d]x)``; ``t = None``: a rotation
    without translation (``X2 ~ R X1``). The inverse of the core's first-order covariance
    (:func:`poseonly.analysis.pose_uncertainty`, left perturbation ``exp([w]x) R``, ``w = R d``: the
    information in ``d`` is ``R^T I_w R``). None with fewer than :data:`MIN_EDGE_MATCHES` matches, a
    noise scale of exactly zero or a pose the matches do not determine. numpy reference (central
    differences): tests/reference/pose_covariance.py."""
    R = np.ascontiguousarray(R, dtype=np.float64)
    if len(f1) < MIN_EDGE_MATCHES:
        return None
    tt = None if t is None else np.ascontiguousarray(t, dtype=np.float64)
    Cw, _, _, _, ok = _core.pose_covariance(R, tt, np.ascontiguousarray(f1, dtype=np.float64), np.ascontiguousarray(f2, dtype=np.float64))
    if not ok:
        return None
    try:
        info_w = np.linalg.inv(0.5 * (Cw + Cw.T))
    except np.linalg.LinAlgError:
        return None
    return _floor(R.T @ info_w @ R)


def edge_informations(graph: ViewGraph, bearings_of: Callable[[Tracks], np.ndarray]) -> tuple[np.ndarray | None, np.ndarray]:
    """``(information (E, 3, 3), fallback (E,))``: the rotation information of every edge of ``graph``
    (in view i's frame) from its inlier matches, whose bearings ``bearings_of`` gives (as for
    :func:`poseonly.sfm.pipeline.run_global`: the matches are passed as two-observation tracks).

    An edge without one (fewer than :data:`MIN_EDGE_MATCHES` matches, no scatter, a translation its
    matches do not determine; ``fallback`` True) gets its weight (the inlier count) times the median
    information per unit weight of the others, isotropic. ``information`` is None when no edge has one."""
    E = len(graph.edges)
    fallback = np.ones(E, dtype=bool)
    out = np.zeros((E, 3, 3))
    m = [len(e.matches) for e in graph.edges]
    use = [k for k in range(E) if m[k] >= MIN_EDGE_MATCHES]
    if use:
        views = np.concatenate([np.repeat(np.array([[graph.edges[k].i, graph.edges[k].j]]), m[k], axis=0) for k in use]).ravel()
        kps = np.concatenate([graph.edges[k].matches for k in use]).ravel()
        total = int(sum(m[k] for k in use))
        tr = Tracks(np.arange(0, 2 * total + 1, 2, dtype=np.int64), views.astype(np.int64), kps.astype(np.int64))
        f = bearings_of(tr).reshape(total, 2, 3)
        start = 0
        for k in use:
            e = graph.edges[k]
            fe = f[start : start + m[k]]
            start += m[k]
            info = rotation_information(e.R, e.t if e.use_translation else None, fe[:, 0], fe[:, 1])
            if info is not None:
                out[k] = info
                fallback[k] = False
    if fallback.all():
        return None, fallback
    w = np.array([e.weight for e in graph.edges])
    per_weight = float(np.median(np.trace(out[~fallback], axis1=1, axis2=2) / 3.0 / w[~fallback]))
    out[fallback] = (w[fallback] * per_weight)[:, None, None] * np.eye(3)
    return out, fallback
