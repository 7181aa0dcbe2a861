"""The default method ``"poseonly"``: LO-RANSAC built from the paper's parts.

5-point minimal hypotheses (``solver="lirp"`` uses LiRP on 6 points), MSAC scoring of the Sampson
error against the threshold with a preemptive subset test, adaptive stopping, and local
optimisation of every new best model by warm-started TLS IRLS on LiRP (all 18 candidates, the one
minimising the weighted objective kept) with the cheirality-aware Sampson residual. The final model
is chosen among the RANSAC model, the LiRP candidates of its consensus set and its polished
homography twin by cheirality-consistent support, then refined by LiGTopt with the angular
normalisation. Each final stage is kept only if the cheirality-aware MSAC score does not drop.

Shapes: bearings ``f1, f2 (n, 3)`` (unit), poses ``R (3, 3)``, ``t (3,)``; ``tau`` in radians.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..analysis import REFINE_SOLVER, plausible_twin, polish, support
from ..estimator import get_estimator
from ..geometry import essential_from_pose
from ..identify import identify_poses
from ..options import PoseonlyOptions
from ..residuals import v_sampson, v_sampson_chiral
from ..solvers.lirp import lirp_batch
from ..twin import homography_twin
from .gnc import GNCOptions, gnc_irls_batch
from .ransac import ransac

__all__ = ["keep_better", "make_rng", "msac_chiral", "noise_threshold", "refine_ligt", "run_poseonly", "select_by_support"]

# noise-matched threshold: clip range relative to the user's threshold, steps of the fixed point
NOISE_THRESHOLD_RANGE = (0.25, 3.0)
NOISE_THRESHOLD_STEPS = 3
MAD_TO_SIGMA = 1.4826
# hypotheses counted for the a-contrario test (poseonly.analysis): every minimal sample may give up
# to 10 essential matrices (the 5-point solver's bound), each LO and final-stage candidate counts
MAX_ROOTS_PER_SAMPLE = 10
FINAL_CANDIDATES = 20


def make_rng(seed: int | np.random.Generator) -> np.random.Generator:
    """The generator of a seed (a Generator is used as is)."""
    return seed if isinstance(seed, np.random.Generator) else np.random.default_rng(int(seed))


def msac_chiral(R, t, f1, f2, tau) -> float:
    """Cheirality-aware MSAC score (larger is better)."""
    v = v_sampson_chiral(R, t, f1, f2)
    return float(np.sum(tau * tau - np.minimum(v * v, tau * tau)))


def keep_better(a, b, f1, f2, tau, tol=1.0):
    """``b`` if its cheirality-aware MSAC score reaches ``tol`` times ``a``'s, else ``a``."""
    if not (np.all(np.isfinite(b[0])) and np.all(np.isfinite(b[1]))):
        return a
    return b if msac_chiral(*b, f1, f2, tau) >= tol * msac_chiral(*a, f1, f2, tau) else a


def select_by_support(R, t, f1, f2, tau):
    """Best of ``(R, t)`` (re-identified on its Sampson inliers), its homography twin and the LiRP
    candidates of its consensus set, by cheirality-consistent support."""
    sel = np.nonzero(v_sampson(R, t, f1, f2) < tau)[0]
    if len(sel) < 6:
        return R, t
    Ri, ti, _, _ = identify_poses(essential_from_pose(R, t)[None], f1[sel], f2[sel])
    R, t = Ri[0], ti[0]
    inl = support(R[None], t[None], f1, f2, tau)[0]
    o = lirp_batch(f1[sel][None], f2[sel][None])
    cR = [R[None], o["cand_R"][0]]
    ct = [t[None], o["cand_t"][0]]
    tw = homography_twin(R, t, f1[sel], f2[sel])
    if tw is not None and plausible_twin(R, t, tw, f1, f2, tau):
        Rt, tt = polish(tw[0], tw[1], f1, f2, tau)
        cR.append(Rt[None])
        ct.append(tt[None])
    cRa, cta = np.concatenate(cR), np.concatenate(ct)
    sup = support(cRa, cta, f1, f2, tau).sum(axis=1)
    k = int(np.argmax(sup))
    return (cRa[k], cta[k]) if sup[k] > inl.sum() else (R, t)


def refine_ligt(R, t, f1, f2, inl, tau, normalization="none"):
    """LiGTopt on the inliers ``inl (n,)`` with a robust Cauchy loss at the threshold scale.

    ``normalization="none"`` is the paper's LiGTopt (Eq. 9 residual ``||L~_i t||``);
    ``"angular"`` divides each residual by ``theta_i^2 ||z_i R f1_i + t||`` (the sine of the view-2
    reprojection angle), which measured as accurate as Sampson/ML refinement while the paper's
    weighting is not better than LiRP itself (docs/RESULTS.md).
    """
    from ..refine.ligt import ligt_refine

    if inl.sum() < 6:
        return R, t
    r = ligt_refine(R, t, f1[inl], f2[inl], loss="cauchy", loss_scale=tau, normalization=normalization, solver=REFINE_SOLVER)
    if np.all(np.isfinite(r.R)) and np.all(np.isfinite(r.t)):
        return r.R, r.t
    return R, t


def noise_threshold(R, t, f1, f2, tau, o: PoseonlyOptions) -> float:
    """Inlier threshold matched to the measured noise, for the final stages and the returned mask.

    Fixed-point iteration ``thr <- clip(k sigma(thr), tau / 4, 3 tau)`` (3 steps from ``thr = tau``)
    with ``sigma(thr) = 1.4826 median |v|`` over the Sampson errors below ``thr`` and ``k =
    noise_factor`` (2.5 keeps ~99 % of Gaussian inliers; the truncation at ``thr`` biases sigma low,
    which the iteration undoes). Real images (~0.3 px) get a tighter threshold than the 1 px default,
    1 px synthetic noise a wider one. ``adaptive_threshold=False`` keeps ``tau``.
    """
    if not o.adaptive_threshold:
        return tau
    v_all = v_sampson(R, t, f1, f2)
    thr = tau
    lo, hi = NOISE_THRESHOLD_RANGE
    for _ in range(NOISE_THRESHOLD_STEPS):
        v = v_all[v_all < thr]
        if len(v) < 15:
            return tau
        thr = float(np.clip(o.noise_factor * MAD_TO_SIGMA * float(np.median(v)), lo * tau, hi * tau))
    return thr


def run_poseonly(f1: np.ndarray, f2: np.ndarray, o: PoseonlyOptions, tau: float):
    """The default method; returns ``(R, t, weights | None, iterations, diagnostics)``."""
    rng = make_rng(o.seed)
    est = get_estimator(o.solver, "sampson")
    lirp_all = get_estimator("lirp-all", o.lo_residual)

    def make_lo(thr):
        gopts = GNCOptions(noise_bound=thr, max_iterations=o.lo_iterations, mu0=o.lo_mu0)

        def lo(R, t, inl):
            # warm-started TLS IRLS on the points within 4 thresholds of the model (the rest would
            # get weight 0 at once), from the model's inliers
            cand = np.nonzero(v_sampson(R, t, f1, f2) < 4.0 * thr)[0]
            if inl.sum() < 6 or len(cand) < 6:
                return R, t
            g = gnc_irls_batch(f1[cand][None], f2[cand][None], lirp_all, gopts, w0=inl[cand][None].astype(float))
            return g.R[0], g.t[0]

        return lo

    r = ransac(
        f1, f2, est, tau, rng, max_iterations=o.max_iterations, min_iterations=o.min_iterations,
        confidence=o.confidence, batch=o.batch, scoring=o.scoring, local_optimization=make_lo(tau),
        max_lo=o.max_lo, preemptive=o.preemptive,
    )
    # final stage: the pose-only choice among the RANSAC model (re-identified on its inliers), its
    # homography twin and the LiRP candidates of its consensus set, by cheirality-consistent
    # support (the Sampson score of RANSAC cannot tell a planar scene's twin from the truth; depth
    # signs can); then, at the noise-matched threshold, IRLS from that model's support and LiGTopt,
    # each kept only if the cheirality-aware MSAC score does not drop
    R, t = select_by_support(r.R, r.t, f1, f2, tau)
    thr = noise_threshold(R, t, f1, f2, tau, o)
    lo = make_lo(thr)
    R, t = keep_better((R, t), lo(R, t, support(R[None], t[None], f1, f2, thr)[0]), f1, f2, thr)
    if o.refine:
        ref = refine_ligt(R, t, f1, f2, support(R[None], t[None], f1, f2, thr)[0], thr, normalization="angular")
        R, t = keep_better((R, t), ref, f1, f2, thr, tol=0.98)
    num_hyp = r.num_iterations * MAX_ROOTS_PER_SAMPLE + r.num_lo + FINAL_CANDIDATES
    diag: dict[str, Any] = {"num_lo": r.num_lo, "ransac_score": r.score, "num_scored": r.num_scored, "tau_effective": thr,
                            "num_hypotheses": num_hyp}
    return R, t, None, r.num_iterations, diag
