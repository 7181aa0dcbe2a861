"""GNC-IRLS (Algorithm 2) with Peng et al.'s MS-TLS weights, and Yang et al.'s classic GNC-TLS.

Algorithm 2, per iteration ``k`` (notes section 7 for Peng's constants):

1. ``R, t`` = weighted solve with ``w^(k)`` (LiRP by default);
2. ``v`` = residuals of all points (``v_LiGT`` by default);
3. ``sigma = 1.4826 * median(|v|)`` (``scale="median"``, Alg. 2 as printed) or
   ``1.4826 * median(|v - median(v)|)`` (``scale="mad"``, the paper's text) or a fixed number;
   ``c = 5.54 sigma`` (``c_factor``). A fixed ``noise_bound`` replaces ``c`` entirely.
4. weights: MS-TLS (majorized, Peng 2023): ``w = 1`` for ``v <= c``, ``0`` for
   ``v >= (mu+1)/mu c``, else ``(mu+1) c / v - mu``; classic GNC-TLS (Yang 2020):
   ``w = 1`` for ``v^2 <= mu/(mu+1) c^2``, ``0`` for ``v^2 >= (mu+1)/mu c^2``, else
   ``sqrt(c^2 mu (mu+1) / v^2) - mu``.
5. ``eps = sum_i w_i v_i`` (Alg. 2: unsquared); stop when ``|eps^(k+1) - eps^(k)| < eps0``.
6. ``mu``: initial ``max(1 / (5 max v^2 / c^2 - 1), 1e-6)`` (Peng; MS) or ``1 / (2 max v^2 / c^2 - 1)``
   (Yang; classic); superlinear update ``mu <- 1.4 sqrt(mu)`` while ``mu < 1`` then ``1.4 mu``
   (MS), or ``mu <- 1.4 mu`` (classic).

Open choices, decided: ``eps0`` is relative (``|d eps| < eps0 * max(eps, tiny)``, default 1e-9,
because ``v_LiGT`` has no fixed unit); ``n_iter = 100`` (Peng); ``sigma`` is floored at
``sigma_floor`` (default 1e-12) so exact data cannot make ``c = 0``; the returned pose is the last
weighted solve (as in Alg. 2).

Everything runs in lockstep over ``h`` stacked problems (GNC-RANSAC fits all its samples at once);
problems that converge drop out of the active set. Speed (docs/speed_notes.md): the Kronecker rows
of LiRP are built once and reweighted per iteration, no gathers while every problem is active, the
median by partition, residuals and identification by the compiled kernels when numba is present;
the iterates are those of the straightforward loop (tests/test_speed_equivalence.py).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .. import _kernels
from ..estimator import Estimator, lirp_all_solver, lirp_estimator, lirp_solver
from ..residuals import v_LiGT, v_sampson, v_sampson_chiral

_COMPILED_RESIDUALS = (v_LiGT, v_sampson, v_sampson_chiral)
from ..solvers.lirp import _kron_rows, lirp_batch

__all__ = ["GNCOptions", "gnc_irls_batch", "GNCBatchResult", "tls_weights"]

MAD_TO_SIGMA = 1.4826


@dataclass(frozen=True)
class GNCOptions:
    """Options of :func:`gnc_irls_batch` (see the module docstring)."""

    schedule: str = "ms-tls"  # "ms-tls" (Peng 2023, the paper) or "gnc-tls" (Yang 2020)
    scale: str | float = "median"  # "median" (Alg. 2), "mad" (paper text) or a fixed sigma
    c_factor: float = 5.54
    noise_bound: float | None = None  # fixed c (overrides scale / c_factor)
    max_iterations: int = 100
    eps0: float = 1e-9
    sigma_floor: float = 1e-12
    mu_factor: float = 1.4
    mu0: float | None = None  # initial mu; None = Peng's rule. A large value (e.g. 1e3) starts at
    # (near) hard TLS: a warm start for local optimisation from a good model's inliers

    def __post_init__(self) -> None:
        if self.schedule not in ("ms-tls", "gnc-tls"):
            raise ValueError(f"schedule must be 'ms-tls' or 'gnc-tls', got {self.schedule!r}")
        if isinstance(self.scale, str):
            if self.scale not in ("median", "mad"):
                raise ValueError(f"scale must be 'median', 'mad' or a positive number, got {self.scale!r}")
        elif not (isinstance(self.scale, (int, float)) and self.scale > 0):
            raise ValueError(f"scale must be 'median', 'mad' or a positive number, got {self.scale!r}")
        if self.noise_bound is not None and not self.noise_bound > 0:
            raise ValueError(f"noise_bound must be > 0, got {self.noise_bound}")
        if not (isinstance(self.max_iterations, (int, np.integer)) and self.max_iterations >= 1):
            raise ValueError(f"max_iterations must be a positive integer, got {self.max_iterations!r}")
        if self.mu0 is not None and not self.mu0 > 0:
            raise ValueError(f"mu0 must be > 0, got {self.mu0}")
        if not self.c_factor > 0 or not self.eps0 >= 0 or not self.mu_factor > 1:
            raise ValueError("c_factor > 0, eps0 >= 0 and mu_factor > 1 are required")


def tls_weights(v: np.ndarray, c: np.ndarray, mu: np.ndarray, schedule: str = "ms-tls") -> np.ndarray:
    """TLS GNC weights for residuals ``v (h, n)``, bounds ``c (h,)`` and ``mu (h,)``."""
    c = c[:, None]
    mu = mu[:, None]
    v = np.abs(v)
    # (the divisors are >= 1e-300, so no errstate context is needed: it cost more than the weights)
    if schedule == "ms-tls":
        ub = (mu + 1.0) / mu * c
        mid = (mu + 1.0) * c / np.maximum(v, 1e-300) - mu
        return np.where(v <= c, 1.0, np.where(v >= ub, 0.0, mid))
    v2 = v * v
    c2 = c * c
    lb = mu / (mu + 1.0) * c2
    ub = (mu + 1.0) / mu * c2
    mid = np.sqrt(c2 * mu * (mu + 1.0) / np.maximum(v2, 1e-300)) - mu
    return np.where(v2 <= lb, 1.0, np.where(v2 >= ub, 0.0, mid))


def _median_rows(a: np.ndarray) -> np.ndarray:
    """``np.median(a, axis=1)`` bit for bit (finite input), without its generic machinery."""
    n = a.shape[1]
    k = n // 2
    if n % 2:
        return np.partition(a, k, axis=1)[:, k]
    p = np.partition(a, (k - 1, k), axis=1)
    return (p[:, k - 1] + p[:, k]) / 2.0


def _scale(v: np.ndarray, opts: GNCOptions) -> np.ndarray:
    if opts.noise_bound is not None:
        return np.full(len(v), opts.noise_bound)
    if isinstance(opts.scale, str):
        a = np.abs(v)
        if opts.scale == "median":
            s = MAD_TO_SIGMA * _median_rows(a)
        else:
            s = MAD_TO_SIGMA * _median_rows(np.abs(a - _median_rows(a)[:, None]))
    else:
        s = np.full(len(v), float(opts.scale))
    return opts.c_factor * np.maximum(s, opts.sigma_floor)


def _initial_mu(v: np.ndarray, c: np.ndarray, schedule: str) -> np.ndarray:
    r = np.max(v * v, axis=1) / np.maximum(c * c, 1e-300)
    with np.errstate(divide="ignore", invalid="ignore"):
        if schedule == "ms-tls":
            mu = 1.0 / (5.0 * r - 1.0)
            return np.where(np.isfinite(mu) & (mu > 1e-6), mu, 1e-6)
        mu = 1.0 / (2.0 * r - 1.0)
        # all residuals inside the bound: TLS = LS, start already convex-free (large mu)
        return np.where(np.isfinite(mu) & (mu > 0), mu, 1e16)


def _update_mu(mu: np.ndarray, opts: GNCOptions) -> np.ndarray:
    if opts.schedule == "ms-tls":
        new = np.where(mu < 1.0, opts.mu_factor * np.sqrt(mu), opts.mu_factor * mu)
    else:
        new = opts.mu_factor * mu
    return np.minimum(new, 1e16)


CYCLE_MAX_PERIOD = 8


def _cycle_exit(k, active, cand, wnew, nb_last, HW, He, opts, P):
    """Problems whose iteration ``k`` closed a limit cycle, and where the full loop would end.

    With the adaptive bound ``c`` re-estimated every iteration, GNC-IRLS often ends in a cycle of
    binary weight vectors (period 2-5 measured; the relative eps test never fires, so Alg. 2 runs to
    its iteration cap). Let ``W_j`` be the input weights of iteration ``j`` (``W_{j+1}`` = its new
    weights). The solve and the residuals depend on ``W_j`` only, and the new weights on them and on
    ``mu``; a binary ``W_{j+1}`` means no residual lies in the TLS transition band, which only narrows
    as ``mu`` grows (both schedules), so ``W_{j+1}`` is what every later iteration maps ``W_j`` to.
    Hence if ``W_{k+1} = W_{k+1-p}`` and ``W_{k+2-p}, ..., W_{k+1}`` are binary, the iterations from
    ``k+1-p`` on repeat with period ``p`` exactly. The future stopping tests (consecutive eps values)
    take only ``p`` distinct forms, checked here; the loop ends at the first that fires (converged) or
    at ``max_iterations - 1``. Returns ``(indices into active, cycle iteration whose outputs are returned,
    final iteration, converged)`` or None.
    """
    K = opts.max_iterations - 1
    if k >= K:
        return None
    S = P + 1
    sel = np.nonzero(cand)[0]
    a = active[sel]
    ps = np.arange(1, min(P, k + 1) + 1)  # candidate periods; the smallest that matches wins
    ok = np.all(HW[a][:, (k + 1 - ps) % S] == wnew[sel][:, None, :], axis=2) & (nb_last[a][:, None] < k + 1 - ps)
    hit = ok.any(axis=1)
    if not hit.any():
        return None
    sel, a, period = sel[hit], a[hit], ps[np.argmax(ok[hit], axis=1)]
    base = k + 1 - period  # first iteration of the cycle
    jf = np.full(len(sel), K)
    conv = np.zeros(len(sel), bool)
    for m in range(1, P + 1):  # future iteration k + m, for every position of the period
        j = k + m
        live = (m <= period) & (j <= K) & ~conv
        if not live.any():
            break
        e_cur = He[a, (base + (j - base) % period) % S]
        e_prev = He[a, (base + (j - 1 - base) % period) % S]
        d = live & (np.abs(e_cur - e_prev) <= opts.eps0 * np.maximum(np.abs(e_cur), 1e-300))
        jf = np.where(d, j, jf)
        conv |= d
    # the iteration whose outputs the loop returns: the cycle position of jf
    jmap = base + (jf - base) % period
    return sel, jmap, jf, conv


@dataclass
class GNCBatchResult:
    """Stacked GNC-IRLS output: ``R (h,3,3)``, ``t (h,3)``, final ``weights (h,n)``, ``residuals (h,n)``
    of the returned pose, ``c (h,)`` final noise bound, ``num_iterations (h,)``, ``converged (h,)``."""

    R: np.ndarray
    t: np.ndarray
    weights: np.ndarray
    residuals: np.ndarray
    c: np.ndarray
    num_iterations: np.ndarray
    converged: np.ndarray
    history: list = field(default_factory=list)


def gnc_irls_batch(
    f1: np.ndarray,
    f2: np.ndarray,
    estimator: Estimator | None = None,
    options: GNCOptions | None = None,
    w0: np.ndarray | None = None,
    *,
    detect_cycles: bool = True,
    compiled: bool = True,
) -> GNCBatchResult:
    """GNC-IRLS (Alg. 2) on ``h`` stacked problems ``f1, f2 (h, n, 3)`` in lockstep (no validation).

    ``estimator`` defaults to LiRP + v_LiGT; ``w0`` optional initial weights (default all ones).
    ``detect_cycles`` (default) ends a problem as soon as its iteration has entered a limit cycle
    (see :func:`_cycle_exit`) and returns what the full loop would have returned after
    ``max_iterations`` (or at its first convergence inside the cycle): the same pose, weights,
    residuals, bound, iteration count and convergence flag, without running the remaining iterations.
    ``detect_cycles=False`` runs every iteration (the equality is a test).
    ``compiled`` (default): with LiRP (the identified pose, or all candidates: ``lirp-all``) and
    ``v_LiGT``, ``v_sampson`` or ``v_sampson_chiral``, and the numba kernels available, each problem
    runs its whole loop in one compiled call (``poseonly._kernels.gnc_lirp``: the
    same iterations in the same floating-point order, bit-identical results, a test); ``False``
    forces the lockstep loop below.
    """
    est = estimator or lirp_estimator()
    opts = options or GNCOptions()
    h, n, _ = f1.shape
    w = np.ones((h, n)) if w0 is None else np.array(w0, dtype=float)
    if compiled and est.solve in (lirp_solver, lirp_all_solver) and est.residual in _COMPILED_RESIDUALS and _kernels.enabled():
        R, t, wo, v, c, it, conv, redo = _kernels.gnc_lirp(f1, f2, w, opts, CYCLE_MAX_PERIOD if detect_cycles else 0,
                                                          est.sample_size, est.solve is lirp_all_solver,
                                                          est.residual.__name__)
        if redo.any():  # a rare numpy fallback inside LiRP: those problems run the lockstep loop
            g = gnc_irls_batch(f1[redo], f2[redo], est, opts, w[redo], detect_cycles=detect_cycles, compiled=False)
            R[redo], t[redo], wo[redo], v[redo], c[redo] = g.R, g.t, g.weights, g.residuals, g.c
            it[redo], conv[redo] = g.num_iterations, g.converged
        return GNCBatchResult(R=R, t=t, weights=wo, residuals=v, c=c, num_iterations=it, converged=conv)
    R = np.tile(np.eye(3), (h, 1, 1))
    t = np.zeros((h, 3))
    v_all = np.zeros((h, n))
    c_all = np.zeros(h)
    mu = np.zeros(h)
    eps_prev = np.full(h, np.inf)
    iters = np.zeros(h, int)
    converged = np.zeros(h, bool)
    active = np.arange(h)
    # per-point precomputation reused by every iteration: the Kronecker rows of LiRP (the weighted
    # system is A * w); while no problem has dropped out, whole arrays are used without gathers
    P = CYCLE_MAX_PERIOD if detect_cycles else 0
    if P:
        S = P + 1  # ring buffers: slot j % S holds iteration j's outputs and input weights W_j
        HW = np.empty((h, S, n))
        HW[:, 0] = w
        HR, Ht, Hv = np.empty((h, S, 3, 3)), np.empty((h, S, 3)), np.empty((h, S, n))
        Hc, He = np.empty((h, S)), np.empty((h, S))
        nb_last = np.full(h, -1)  # last iteration whose new weights were not all 0 or 1
    fast_lirp = est.solve is lirp_solver
    A_all = _kron_rows(f1, f2) if fast_lirp else None
    full = True
    for k in range(opts.max_iterations):
        if active.size == 0:
            break
        if full:
            a1, a2, aw = f1, f2, w
        else:
            a1, a2, aw = f1[active], f2[active], w[active]
        if fast_lirp:
            o = lirp_batch(a1, a2, aw, A=A_all if full else A_all[active])
            Rk, tk = o["R"], o["t"]
        else:
            Rk, tk = est.solve(a1, a2, aw)
            if Rk.shape[1] > 1:
                # several candidates per problem: keep the one minimising the weighted objective
                # sum_i w_i v_i being optimised (candidates that failed their own checks are NaN)
                vk = est.residual(Rk, tk, a1[:, None], a2[:, None])
                cost = np.sum(aw[:, None, :] * vk, axis=-1)
                cost = np.where(np.isfinite(cost), cost, np.inf)
                pick = np.argmin(cost, axis=1)
                Rk, tk = Rk[np.arange(len(pick)), pick], tk[np.arange(len(pick)), pick]
            else:
                Rk, tk = Rk[:, 0], tk[:, 0]
        v = est.residual(Rk, tk, a1, a2)
        fin = np.isfinite(v)
        if fin.all():
            vf = v
        else:
            vf = np.where(fin, v, 0.0)
            v = np.where(fin, v, np.inf)
        c = _scale(vf, opts)
        mu_a = mu if full else mu[active]
        if k == 0:
            mu_a = _initial_mu(vf, c, opts.schedule) if opts.mu0 is None else np.full(len(vf), float(opts.mu0))
        wn = tls_weights(v, c, mu_a, opts.schedule)
        eps = np.sum(wn * vf, axis=1)
        done = np.abs(eps - (eps_prev if full else eps_prev[active])) <= opts.eps0 * np.maximum(np.abs(eps), 1e-300)
        # a problem whose weights leave fewer than the minimal sample cannot be solved further
        starving = np.count_nonzero(wn > 0, axis=1) < est.sample_size
        wnew = np.where(starving[:, None], aw, wn)
        if full:
            R, t, v_all, c_all = Rk, tk, v, c
            iters[:] = k + 1
            w = wnew
            eps_prev = eps
            converged |= done
            mu = _update_mu(mu_a, opts)
        else:
            R[active], t[active], v_all[active], c_all[active] = Rk, tk, v, c
            iters[active] = k + 1
            w[active] = wnew
            eps_prev[active] = eps
            converged[active[done]] = True
            mu[active] = _update_mu(mu_a, opts)
        stop = done | starving
        cyc = None
        if P:
            sl = k % S
            HR[active, sl], Ht[active, sl], Hv[active, sl], Hc[active, sl], He[active, sl] = Rk, tk, v, c, eps
            HW[active, (k + 1) % S] = wnew
            nonbin = ~np.all((wn == 0.0) | (wn == 1.0), axis=1)
            if nonbin.any():
                nb_last[active[nonbin]] = k
            cand = ~stop & (nb_last[active] < k) & (mu[active] >= mu_a)
            if cand.any():
                cyc = _cycle_exit(k, active, cand, wnew, nb_last, HW, He, opts, P)
        if stop.any() or cyc is not None:
            if full:  # from now on the arrays are written through the active indices
                R, t, v_all, c_all = R.copy(), t.copy(), np.array(v_all, dtype=float), np.array(c_all, dtype=float)
                full = False
            if cyc is not None:
                idx, jmap, jf, conv = cyc
                a = active[idx]
                sl = jmap % S
                R[a], t[a], v_all[a], c_all[a] = HR[a, sl], Ht[a, sl], Hv[a, sl], Hc[a, sl]
                w[a] = HW[a, (jmap + 1) % S]
                iters[a] = jf + 1
                converged[a] = conv
                stop = stop.copy()
                stop[idx] = True
            active = active[~stop]
    return GNCBatchResult(R=R, t=t, weights=w, residuals=v_all, c=c_all, num_iterations=iters, converged=converged)
