"""Global rotations refined on the tracks' epipolar errors with the camera centres held fixed.

Rotation averaging sees each two-view rotation as one number with one weight; it cannot use that a
two-view rotation's error is coupled to its translation direction (for a narrow field of view a
rotation about the image's y axis and a sideways translation explain the matches almost equally). Once
LiGT has placed the centres from every view at once, the translation direction of every pair is far
better known than its two-view estimate, and the rotations can be re-estimated *given* it: minimise,
over the global rotations ``R_k`` only, the Sampson errors of the tracks' observation pairs

    e_ab = x_b^T [t_ab]x R_ab x_a / d_ab,   R_ab = R_b R_a^T,   t_ab = R_b (c_a - c_b) / ||c_a - c_b||,

(``x`` the unit camera-frame bearings; ``d_ab = sqrt(|P_xb E x_a|^2 + |P_xa E^T x_b|^2)`` the spherical
Sampson denominator of the core's residual table, ``E = [t_ab]x R_ab``), by Gauss-Newton with the exact
Jacobian. There is no gauge freedom: the fixed centres pin the global rotation.
No point is estimated and no reprojection error is minimised (this is not bundle adjustment); the
pipeline then solves LiGT again on the refined rotations (:func:`poseonly.sfm.pipeline.run_global`,
``GlobalOptions.rotation_refine_rounds``).

Derivatives (left perturbations ``R_k <- exp([w_k]x) R_k``): ``E -> exp([w_b]x) E`` (``R_ab`` and
``t_ab`` both turn with ``R_b``) and ``E -> E exp(-[w_a]x)``; with ``g = E x_a``, ``h = E^T x_b``, the
numerator's gradients are ``g x x_b`` and ``-(x_a x h)``, the denominator's follow (``_errors``). Robustness: Huber weights at ``HUBER_SIGMAS`` robust standard
deviations of the current errors (the tracks are already filtered by reprojection error).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.linalg import spsolve

from ..geometry import InputError
from .so3 import exp_so3
from .tracks import Tracks

__all__ = ["RotationRefineResult", "observation_pairs", "refine_rotations"]

HUBER_SIGMAS = 3.0
MAX_ITERATIONS = 10
STEP_TOL_RAD = 1e-10
# a pair whose centres are closer than this fraction of the median baseline has no usable direction
MIN_BASELINE_FRACTION = 1e-3
_TINY = 1e-300


@dataclass
class RotationRefineResult:
    """``rotations (N, 3, 3)``; ``num_pairs`` observation pairs used; ``iterations``;
    ``rms_before`` / ``rms_after`` of the Sampson errors (radians); ``max_step_deg`` of the last step."""

    rotations: np.ndarray
    num_pairs: int
    iterations: int
    rms_before: float
    rms_after: float
    max_step_deg: float


def observation_pairs(tracks: Tracks, allowed: set[tuple[int, int]] | None = None) -> tuple[np.ndarray, np.ndarray]:
    """All observation index pairs ``(a, b)`` of each track (``a < b`` within the track, so the view
    of ``a`` is the smaller: tracks are sorted by view); with ``allowed``, only pairs whose views
    ``(i, j)``, ``i < j``, are in it. Returns two ``(P,)`` int64 arrays."""
    lengths = tracks.lengths
    A, B = [], []
    for L in np.unique(lengths):
        if L < 2:
            continue
        starts = tracks.ptr[:-1][lengths == L]
        ia, ib = np.triu_indices(int(L), 1)
        A.append((starts[:, None] + ia[None, :]).ravel())
        B.append((starts[:, None] + ib[None, :]).ravel())
    if not A:
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    a = np.concatenate(A).astype(np.int64)
    b = np.concatenate(B).astype(np.int64)
    if allowed is not None:
        va, vb = tracks.views[a], tracks.views[b]
        keep = np.fromiter(((int(i), int(j)) in allowed for i, j in zip(va, vb, strict=True)), dtype=bool, count=len(a))
        a, b = a[keep], b[keep]
    return a, b


def _errors(R: np.ndarray, C: np.ndarray, va: np.ndarray, vb: np.ndarray, xa: np.ndarray, xb: np.ndarray, want_jac: bool):
    """Sampson errors ``(P,)`` and (``want_jac``) their exact derivatives ``(P, 3)`` w.r.t. ``w_a``, ``w_b``."""
    Ra, Rb = R[va], R[vb]
    Rab = np.einsum("pij,pkj->pik", Rb, Ra)
    d = C[va] - C[vb]
    t = np.einsum("pij,pj->pi", Rb, d / np.linalg.norm(d, axis=1, keepdims=True))
    g = np.cross(t, np.einsum("pij,pj->pi", Rab, xa))  # E x_a, E = [t]x R_ab
    num = np.einsum("pi,pi->p", xb, g)
    h = np.einsum("pji,pj->pi", Rab, np.cross(xb, t))  # E^T x_b = R_ab^T [t]x^T x_b = R_ab^T (x_b x t)
    den = np.einsum("pi,pi->p", g, g) + np.einsum("pi,pi->p", h, h) - 2.0 * num * num
    s = 1.0 / np.sqrt(np.maximum(den, _TINY))
    e = num * s
    if not want_jac:
        return e, None, None
    # E -> exp([w_b]x) E under w_b (|g| unchanged), E -> E exp(-[w_a]x) under w_a (|h| unchanged)
    dnum_b = np.cross(g, xb)
    dnum_a = -np.cross(xa, h)
    Eh = np.cross(t, np.einsum("pij,pj->pi", Rab, h))  # E E^T x_b
    Etg = np.einsum("pji,pj->pi", Rab, np.cross(g, t))  # E^T E x_a
    dden_b = 2.0 * np.cross(Eh, xb) - 4.0 * num[:, None] * dnum_b
    dden_a = 2.0 * np.cross(Etg, xa) - 4.0 * num[:, None] * dnum_a
    c = (0.5 * num * s**3)[:, None]
    return e, dnum_a * s[:, None] - c * dden_a, dnum_b * s[:, None] - c * dden_b


def refine_rotations(
    rotations: np.ndarray,
    centres: np.ndarray,
    tracks: Tracks,
    bearings: np.ndarray,
    *,
    allowed_pairs: set[tuple[int, int]] | None = None,
    max_iterations: int = MAX_ITERATIONS,
) -> RotationRefineResult:
    """Refine ``rotations (N, 3, 3)`` (world -> camera) given ``centres (N, 3)`` (NaN: view not
    estimated, left as it is) on the tracks' observation pairs (``bearings (M, 3)`` unit, camera
    frame; ``allowed_pairs`` restricts them to those view pairs, e.g. the graph's trusted edges).
    Returns the refined rotations; views without a usable pair keep theirs."""
    R = np.array(rotations, dtype=np.float64)
    C = np.asarray(centres, dtype=np.float64)
    N = len(R)
    if R.shape != (N, 3, 3) or C.shape != (N, 3):
        raise InputError(f"rotations must be (N, 3, 3) and centres (N, 3), got {R.shape} and {C.shape}")
    if bearings.shape != (tracks.num_observations, 3):
        raise InputError(f"bearings must be ({tracks.num_observations}, 3), got {bearings.shape}")
    a, b = observation_pairs(tracks, allowed_pairs)
    va, vb = tracks.views[a], tracks.views[b]
    ok = np.all(np.isfinite(C[va]), axis=1) & np.all(np.isfinite(C[vb]), axis=1) & np.all(np.isfinite(R[va]), axis=(1, 2)) & np.all(np.isfinite(R[vb]), axis=(1, 2))
    base = np.linalg.norm(np.where(ok[:, None], C[va] - C[vb], 0.0), axis=1)
    if np.any(ok):
        ok &= base > MIN_BASELINE_FRACTION * float(np.median(base[ok]))
    a, b, va, vb = a[ok], b[ok], va[ok], vb[ok]
    xa, xb = bearings[a], bearings[b]
    if len(a) == 0:
        return RotationRefineResult(R, 0, 0, float("nan"), float("nan"), 0.0)
    used = np.zeros(N, bool)
    used[va] = True
    used[vb] = True
    e0, _, _ = _errors(R, C, va, vb, xa, xb, False)
    rms0 = float(np.sqrt(np.mean(e0**2)))
    it, step = 0, 0.0
    cols = np.concatenate([3 * va[:, None] + np.arange(3), 3 * vb[:, None] + np.arange(3)], axis=1)  # (P, 6)
    for it in range(1, max_iterations + 1):  # noqa: B007 (the count is reported)
        e, Ja, Jb = _errors(R, C, va, vb, xa, xb, True)
        assert Ja is not None and Jb is not None
        sig = 1.4826 * float(np.median(np.abs(e)))
        k = HUBER_SIGMAS * max(sig, _TINY)
        w = np.where(np.abs(e) <= k, 1.0, k / np.maximum(np.abs(e), _TINY))
        J = np.concatenate([Ja, Jb], axis=1)  # (P, 6)
        JW = J * w[:, None]
        rows = np.repeat(cols, 6, axis=1).ravel()
        cc = np.tile(cols, (1, 6)).ravel()
        vals = np.einsum("pi,pj->pij", JW, J).ravel()
        H = coo_matrix((vals, (rows, cc)), shape=(3 * N, 3 * N)).tocsc()
        gvec = np.bincount(cols.ravel(), weights=(JW * e[:, None]).ravel(), minlength=3 * N)
        idx = np.flatnonzero(np.repeat(used, 3))
        Hs = H[idx][:, idx]
        delta = np.zeros(3 * N)
        delta[idx] = -spsolve(Hs.tocsc(), gvec[idx])
        dw = delta.reshape(N, 3)
        R = exp_so3(dw) @ R
        step = float(np.degrees(np.max(np.linalg.norm(dw, axis=1))))
        if step < np.degrees(STEP_TOL_RAD):
            break
    e1, _, _ = _errors(R, C, va, vb, xa, xb, False)
    return RotationRefineResult(R, len(a), it, rms0, float(np.sqrt(np.mean(e1**2))), step)
