"""RANSAC loops generic over :class:`poseonly.estimator.Estimator`.

* :func:`ransac` -- hypothesise-and-verify with batched hypotheses: ``batch`` samples are drawn at
  once, solved as stacked arrays, and every candidate is scored against every point in one residual
  call. Inlier-count or MSAC (truncated quadratic) scoring, adaptive stopping
  ``N = log(1 - p) / log(1 - w^m)``, optional local optimisation (LO) on each new best model.
* :func:`gnc_ransac` -- the paper's Algorithm 3: samples of ``n_s = 30`` fitted by GNC-IRLS
  (Alg. 2) in lockstep, scored by inlier count of ``v_LiGT < theta`` on all points, best inlier set
  refit by GNC-IRLS.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from .. import _kernels
from ..estimator import Estimator, lirp_estimator
from ..residuals import v_LiGT, v_sampson, v_sampson_chiral
from .gnc import GNCOptions, gnc_irls_batch

__all__ = ["RansacResult", "ransac", "gnc_ransac", "sample_indices", "adaptive_iterations"]


@dataclass
class RansacResult:
    R: np.ndarray
    t: np.ndarray
    inliers: np.ndarray
    residuals: np.ndarray
    score: float
    num_iterations: int
    num_lo: int = 0
    num_scored: int = 0
    weights: np.ndarray | None = None


# residuals whose RANSAC score has a fused compiled kernel (_kernels.ransac_score)
_FUSED = {v_sampson: "sampson", v_LiGT: "ligt", v_sampson_chiral: "sampson-chiral"}


def sample_indices(rng: np.random.Generator, n: int, m: int, b: int) -> np.ndarray:
    """``b`` samples of ``m`` distinct indices from ``range(n)``: ``(b, m)``.

    Vectorized: the ``m`` smallest of ``n`` uniform keys per row (``O(b n)``, no rejection loop).
    """
    if m >= n:
        return np.tile(np.arange(n), (b, 1))
    return np.argpartition(rng.random((b, n)), m - 1, axis=1)[:, :m]


def adaptive_iterations(inlier_ratio: float, m: int, confidence: float) -> float:
    """Number of samples needed to draw one all-inlier sample of size ``m`` with ``confidence``."""
    if inlier_ratio <= 0:
        return np.inf
    p = inlier_ratio**m
    if p >= 1:
        return 1.0
    return np.log(1.0 - confidence) / np.log1p(-p)


def _score(v: np.ndarray, thr: float, scoring: str) -> tuple[np.ndarray, np.ndarray]:
    inl = v < thr
    if scoring == "count":
        return inl.sum(axis=-1).astype(float), inl
    if scoring == "msac-multi":
        # MSAC averaged over the thresholds thr, thr/2, thr/4 (a coarse marginalisation over the noise
        # scale in the spirit of MAGSAC): a model whose inliers fit tightly beats one that collects
        # more points near the threshold
        v2 = v * v
        s = np.zeros(v.shape[:-1])
        for k in (1.0, 0.5, 0.25):
            tk2 = (k * thr) ** 2
            s = s + np.sum(1.0 - np.minimum(v2, tk2) / tk2, axis=-1)
        return s, inl
    # MSAC: maximise sum(thr^2 - min(v^2, thr^2)) (higher is better)
    return np.sum(thr * thr - np.minimum(v * v, thr * thr), axis=-1), inl


def ransac(
    f1: np.ndarray,
    f2: np.ndarray,
    estimator: Estimator,
    threshold: float,
    rng: np.random.Generator,
    *,
    max_iterations: int = 10000,
    min_iterations: int = 0,
    confidence: float = 0.999,
    adaptive: bool = True,
    batch: int = 64,
    scoring: str = "msac",
    score_residual: Callable | None = None,
    local_optimization: Callable | None = None,
    max_lo: int = 10,
    preemptive: int = 0,
) -> RansacResult:
    """Generic batched RANSAC / MSAC with optional LO (see the module docstring).

    ``score_residual`` (default ``estimator.residual``) and ``threshold`` define inliers.
    ``local_optimization(R, t, inliers) -> (R, t)`` is called on every new best model (at most
    ``max_lo`` times); its result replaces the best model when it scores at least as well.
    ``preemptive > 0`` first scores each hypothesis on that many random points and fully scores only
    those reaching half the inlier count the current best model implies (saves most of the scoring
    at high outlier ratios; a good hypothesis is rejected with probability ``P(Bin(d, w) < d w / 2)``).
    """
    res = score_residual or estimator.residual
    fused = _FUSED.get(res) if (_kernels.enabled() and f1.ndim == 2) else None
    n = len(f1)
    m = estimator.sample_size
    best = (-np.inf, np.eye(3), np.zeros(3))
    best_ratio = 0.0
    it = 0
    num_lo = 0
    num_scored = 0
    needed = float(max_iterations)
    pre = min(int(preemptive), n) if preemptive else 0
    while it < max_iterations and (it < needed or it < min_iterations):
        # the first batch draws min_iterations samples (when smaller than batch): at low outlier
        # ratios the adaptive bound is met by then and a full batch would be wasted
        b = int(min(batch if it or min_iterations <= 0 else min(batch, min_iterations), max_iterations - it))
        idx = sample_indices(rng, n, m, b)
        R, t = estimator.solve(f1[idx], f2[idx], None)
        R = R.reshape(-1, 3, 3)
        t = t.reshape(-1, 3)
        ok = np.all(np.isfinite(R), axis=(1, 2)) & np.all(np.isfinite(t), axis=1)
        R, t = R[ok], t[ok]
        it += b
        if len(R) == 0:
            continue
        if pre and pre < n and best_ratio > 0:
            # preemptive test (in the spirit of the T(d,d) test): score a random subset first and keep
            # hypotheses whose subset inlier count reaches half of what the best model would give
            sub = rng.choice(n, size=pre, replace=False)
            cnt = np.count_nonzero(res(R, t, f1[sub], f2[sub]) < threshold, axis=1)
            keep = cnt >= max(1.0, 0.5 * best_ratio * pre)
            R, t = R[keep], t[keep]
            if len(R) == 0:
                continue
        num_scored += len(R)
        if fused is not None:  # compiled residual + score in one pass, no (k, n) array (same bits)
            s = _kernels.ransac_score(fused, R, t, f1, f2, threshold, scoring)
        else:
            v = res(R, t, f1, f2)
            s, _ = _score(v, threshold, scoring)
        k = int(np.argmax(s))
        if s[k] > best[0]:
            best = (float(s[k]), R[k], t[k])
            if local_optimization is not None and num_lo < max_lo:
                inl = (res(R[k], t[k], f1, f2) if fused is not None else v[k]) < threshold
                R_lo, t_lo = local_optimization(R[k], t[k], inl)
                num_lo += 1
                s_lo, _ = _score(res(R_lo, t_lo, f1, f2), threshold, scoring)
                if s_lo >= best[0]:
                    best = (float(s_lo), R_lo, t_lo)
            best_ratio = np.count_nonzero(res(best[1], best[2], f1, f2) < threshold) / n
            if adaptive:
                needed = adaptive_iterations(best_ratio, m, confidence)
    _, R, t = best
    v = res(R, t, f1, f2)
    return RansacResult(R=R, t=t, inliers=v < threshold, residuals=v, score=best[0], num_iterations=it, num_lo=num_lo, num_scored=num_scored)


def gnc_ransac(
    f1: np.ndarray,
    f2: np.ndarray,
    theta: float,
    rng: np.random.Generator,
    *,
    estimator: Estimator | None = None,
    sample_size: int = 30,
    max_iterations: int = 50,
    gnc_options: GNCOptions | None = None,
    adaptive: bool = False,
    confidence: float = 0.99,
) -> RansacResult:
    """GNC-RANSAC, Algorithm 3 of the paper.

    ``max_iterations`` samples of ``sample_size`` (n_s = 30) points are each fitted by GNC-IRLS
    (Alg. 2, all samples in lockstep as stacked arrays), every fit is scored on all points by the
    count of ``v_LiGT < theta`` and the best inlier set is refit by GNC-IRLS. ``adaptive=True`` stops
    early with the RANSAC rule applied to the paper's rationale (a sample only needs a majority of
    inliers, taken as ``>= 60 %``; hypergeometric approximation by a binomial). Open choices (notes
    section 8): ``theta`` is given by the caller (:func:`poseonly.api.estimate_relative_pose`
    derives it from a pixel threshold); samples start from uniform weights.
    """
    est = estimator or lirp_estimator()
    n = len(f1)
    ns = min(sample_size, n)
    iters = max_iterations
    if adaptive:
        # draw in chunks and stop once a good sample is likely enough
        chunk = 10
    else:
        chunk = max_iterations
    best_count, best_R, best_t, best_inl = -1, np.eye(3), np.zeros(3), np.zeros(n, bool)
    done = 0
    while done < iters:
        b = min(chunk, iters - done)
        idx = sample_indices(rng, n, ns, b)
        g = gnc_irls_batch(f1[idx], f2[idx], est, gnc_options)
        v = v_LiGT(g.R, g.t, f1, f2)
        inl = v < theta
        cnt = inl.sum(axis=1)
        k = int(np.argmax(cnt))
        if cnt[k] > best_count:
            best_count, best_R, best_t, best_inl = int(cnt[k]), g.R[k], g.t[k], inl[k]
        done += b
        if adaptive:
            from scipy.stats import binom

            w = best_count / n
            p_good = binom.sf(int(np.ceil(0.6 * ns)) - 1, ns, w)
            if p_good > 0:
                need = np.log(1 - confidence) / np.log1p(-min(p_good, 1 - 1e-12))
                iters = int(min(max_iterations, max(done, np.ceil(need))))
    R, t = best_R, best_t
    weights = np.zeros(n)
    if best_inl.sum() >= est.sample_size:
        sel = np.nonzero(best_inl)[0]
        g = gnc_irls_batch(f1[sel][None], f2[sel][None], est, gnc_options)
        R, t = g.R[0], g.t[0]
        weights[sel] = g.weights[0]
    v = v_LiGT(R, t, f1, f2)
    return RansacResult(R=R, t=t, inliers=v < theta, residuals=v, score=float(best_count), num_iterations=done, weights=weights)
