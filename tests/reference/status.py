"""Reference of the status analysis's twin, rival and parallax steps (``poseonly.analysis.planar_twin``,
``rival_test``, ``parallax_deg``) as they were written in numpy before the core's ``analyse_twin``,
``compare_support`` and ``median_rotation_angle``: the support masks of stacked poses, the twin's
screen and polish (LiGTopt by ``poseonly._core.refine_ligt``) and numpy's median. The core must give
the same counts and the same twin to rounding (tests/test_status_core.py)."""

from __future__ import annotations

from typing import Any

import numpy as np

from poseonly import _core
from poseonly.analysis import AMBIGUITY_LEVEL, MAX_SUPPORT_THRESHOLD, TWIN_MIN_SEPARATION_DEG, TWIN_SUPPORT_RATIO, sign_test, support, twin_cost_excess
from poseonly.geometry import rotation_error_deg
from poseonly.median import median
from poseonly.residuals import v_sampson
from poseonly.twin import homography_twin, homography_twin_dlt

POLISH_ITERATIONS = 20
POLISH_TOL = 1e-12


def _c(a: np.ndarray) -> np.ndarray:
    return np.ascontiguousarray(a, dtype=float)


def plausible_twin(R, t, tw, f1, f2, tau) -> bool:
    """The twin's raw support at 1.5 tau reaches 30 % of the pose's."""
    sup = support(np.stack([R, tw[0]]), np.stack([t, tw[1]]), f1, f2, tau * 1.5).sum(axis=1)
    return bool(sup[1] >= 0.3 * max(sup[0], 1))


def polish(R, t, f1, f2, tau):
    """Angular LiGTopt of a candidate on its cheirality-consistent inliers at 1.5 tau (Cauchy loss at tau)."""
    inl = support(R[None], t[None], f1, f2, tau * 1.5)[0]
    if inl.sum() < 6:
        inl = v_sampson(R, t, f1, f2) < tau * 1.5
        if inl.sum() < 6:
            return R, t
    try:
        Rr, tr, _ = _core.refine_ligt(
            _c(R), _c(t), _c(f1[inl]), _c(f2[inl]), None, normalization="angular", loss="cauchy", loss_scale=float(tau), max_iterations=POLISH_ITERATIONS, tol=POLISH_TOL
        )
    except ValueError:
        return R, t
    if np.all(np.isfinite(Rr)) and np.all(np.isfinite(tr)):
        return Rr, tr
    return R, t


def planar_twin(R, t, f1, f2, tau, inl) -> tuple[tuple[np.ndarray, np.ndarray, int] | None, dict[str, Any]]:
    """``(twin, info)`` as :func:`poseonly.analysis.planar_twin` documents them."""
    info: dict[str, Any] = {}
    twin = None
    sel = np.nonzero(inl)[0]
    tw = homography_twin(R, t, f1[sel], f2[sel]) if len(sel) >= 6 else None
    if tw is not None:
        info["planarity"] = tw[2]
    if (tw is None or not plausible_twin(R, t, tw, f1, f2, tau)) and len(sel) >= 6:
        # the core's fallback: the twin of the homography fitted to the inliers directly
        dlt = homography_twin_dlt(R, t, f1[sel], f2[sel], 2.0 * tau)
        tw = None if dlt is None else (*dlt, None)
    if tw is not None and plausible_twin(R, t, tw, f1, f2, tau):
        Rt, tt = polish(tw[0], tw[1], f1, f2, tau)
        S = support(np.stack([R, Rt]), np.stack([t, tt]), f1, f2, tau)
        sup = S.sum(axis=1)
        only_pose, only_twin = int(np.count_nonzero(S[0] & ~S[1])), int(np.count_nonzero(S[1] & ~S[0]))
        lp = sign_test(only_pose, only_twin)
        sep = rotation_error_deg(R, Rt)
        info.update(support=int(sup[0]), twin_support=int(sup[1]), twin_log10_p=lp, twin_separation_deg=sep)
        info["twin_cost_excess"] = twin_cost_excess(R, t, Rt, tt, f1[sel], f2[sel])
        ct = float(np.dot(tt, t)) / (np.linalg.norm(tt) * np.linalg.norm(t))
        info["twin_translation_separation_deg"] = float(np.degrees(np.arccos(np.clip(ct, -1.0, 1.0))))
        if sup[1] >= TWIN_SUPPORT_RATIO * sup[0] and lp >= np.log10(AMBIGUITY_LEVEL) and sep > TWIN_MIN_SEPARATION_DEG:
            twin = (Rt, tt, int(sup[1]))
    return twin, info


def rival_test(R, t, R_rival, t_rival, f1, f2, tau, min_separation_deg) -> dict[str, Any]:
    """The uniqueness test's counts and decision as :func:`poseonly.analysis.rival_test` documents them:
    cheirality-consistent inliers, and the Sampson inliers whose rays are parallel to within the
    threshold under the pose (far points: their depths' signs are the noise's)."""
    thr = min(tau, MAX_SUPPORT_THRESHOLD)
    Rs, ts = np.stack([R, R_rival]), np.stack([t, t_rival])
    far = np.stack([np.linalg.norm(np.cross(f1 @ Rk.T, f2), axis=1) < thr for Rk in Rs])
    S = support(Rs, ts, f1, f2, tau) | (far & (v_sampson.unchecked(Rs, ts, f1, f2) < thr))
    only_pose, only_rival = int(np.count_nonzero(S[0] & ~S[1])), int(np.count_nonzero(S[1] & ~S[0]))
    sep = rotation_error_deg(R, R_rival)
    lp = sign_test(only_pose, only_rival)
    return {
        "rival_support": int(S[1].sum()),
        "rival_only": only_rival,
        "pose_only": only_pose,
        "rival_separation_deg": sep,
        "rival_log10_p": lp,
        "ambiguous": bool(sep > min_separation_deg and lp >= np.log10(AMBIGUITY_LEVEL)),
    }


def parallax_deg(R, f1, f2, inl) -> float:
    """Median angle (degrees) between ``R f1`` and ``f2`` over the inliers (NaN without any)."""
    if not np.any(inl):
        return float("nan")
    Rf1 = f1[inl] @ R.T
    c = np.clip(np.sum(Rf1 * f2[inl], axis=1), -1.0, 1.0)
    return float(np.degrees(median(np.arccos(c))))
