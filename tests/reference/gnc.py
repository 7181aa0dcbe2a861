"""numpy reference (oracle for tests) of GNC-IRLS, Algorithm 2, written as the paper's loop.

One problem at a time, every iteration run (no limit-cycle exit), LiRP and the residuals from the
numpy references; the options are :class:`poseonly.robust.gnc.GNCOptions`.
"""

from __future__ import annotations

import numpy as np

from poseonly.robust.gnc import MAD_TO_SIGMA, GNCOptions

from . import residuals as ref_res
from .lirp import lirp_batch

RESIDUALS = {
    "ligt": ref_res.v_LiGT,
    "sampson": ref_res.v_sampson,
    "sampson-chiral": ref_res.v_sampson_chiral,
    "coplanar": ref_res.v_E,
    "ppo": ref_res.v_PPO,
    "ba": ref_res.v_BA,
    "opengv": ref_res.v_OpenGV,
}


def tls_weights(v: np.ndarray, c: float, mu: float, schedule: str) -> np.ndarray:
    v = np.abs(v)
    if schedule == "ms-tls":
        return np.where(v <= c, 1.0, np.where(v >= (mu + 1.0) / mu * c, 0.0, (mu + 1.0) * c / np.maximum(v, 1e-300) - mu))
    v2, c2 = v * v, c * c
    return np.where(v2 <= mu / (mu + 1.0) * c2, 1.0, np.where(v2 >= (mu + 1.0) / mu * c2, 0.0, np.sqrt(c2 * mu * (mu + 1.0) / np.maximum(v2, 1e-300)) - mu))


def gnc_irls(f1, f2, opts: GNCOptions, residual: str = "ligt", all_candidates: bool = False, w0=None, min_sample: int = 6):
    """Returns ``(R, t, weights, residuals, c, iterations, converged)`` of Algorithm 2 on ``(n, 3)`` bearings."""
    res = RESIDUALS[residual]
    n = len(f1)
    w = np.ones(n) if w0 is None else np.array(w0, float)
    mu, eps_prev, converged = 0.0, np.inf, False
    for k in range(opts.max_iterations):
        o = lirp_batch(f1[None], f2[None], w[None])
        if all_candidates:
            valid = o["cand_valid"][0]
            keep = valid if valid.any() else np.ones_like(valid)
            cost = np.array([np.sum(w * res(o["cand_R"][0, j], o["cand_t"][0, j], f1, f2)) if keep[j] else np.inf for j in range(len(valid))])
            cost = np.where(np.isfinite(cost), cost, np.inf)
            j = int(np.argmin(cost)) if np.isfinite(cost).any() else int(o["best"][0])
            R, t = o["cand_R"][0, j], o["cand_t"][0, j]
        else:
            R, t = o["R"][0], o["t"][0]
        v = res(R, t, f1, f2)
        fin = np.isfinite(v)
        vf = np.where(fin, v, 0.0)
        v = np.where(fin, v, np.inf)
        if opts.noise_bound is not None:
            c = float(opts.noise_bound)
        else:
            if opts.scale == "median":
                s = MAD_TO_SIGMA * np.median(np.abs(vf))
            elif opts.scale == "mad":
                a = np.abs(vf)
                s = MAD_TO_SIGMA * np.median(np.abs(a - np.median(a)))
            else:
                s = float(opts.scale)
            c = opts.c_factor * max(s, opts.sigma_floor)
        if k == 0:
            if opts.mu0 is not None:
                mu = float(opts.mu0)
            else:
                r = np.max(vf * vf) / max(c * c, 1e-300)
                with np.errstate(divide="ignore"):
                    m = 1.0 / (5.0 * r - 1.0) if opts.schedule == "ms-tls" else 1.0 / (2.0 * r - 1.0)
                mu = (m if np.isfinite(m) and m > 1e-6 else 1e-6) if opts.schedule == "ms-tls" else (m if np.isfinite(m) and m > 0 else 1e16)
        wn = tls_weights(v, c, mu, opts.schedule)
        eps = float(np.sum(wn * vf))
        done = abs(eps - eps_prev) <= opts.eps0 * max(abs(eps), 1e-300)
        starving = np.count_nonzero(wn > 0) < min_sample
        if not starving:
            w = wn
        converged |= done
        eps_prev = eps
        mu = min(opts.mu_factor * np.sqrt(mu) if (opts.schedule == "ms-tls" and mu < 1.0) else opts.mu_factor * mu, 1e16)
        if done or starving:
            break
    return R, t, w, v, c, k + 1, converged
