"""numba GNC-IRLS with LiRP + v_LiGT, one problem after another (behind :func:`poseonly._kernels.gnc_lirp`).

The twin of :func:`poseonly.robust.gnc.gnc_irls_batch` for the paper's estimator: the same
iterations, in the same floating-point order, without the lockstep's Python overhead per iteration
(docs/speed_notes.md section 8: at 30 % outliers GNC-RANSAC's lockstep spent ~9 of 17 ms in
per-iteration overhead, most of it while one or two problems were still running). Every numerical
step is the one the lockstep path executes with the kernels enabled:

* the weighted rows ``kron(f1_i, f2_i) w_i``, the QR of the rows (``n > 9``; zero-padded rows for
  ``n < 9``) and the SVD of the ``9 x 9`` factor through numba's LAPACK bindings (the same LAPACK
  routines as ``numpy.linalg``; bit-identical outputs measured, and compared in the tests);
* the compiled LiRP stages of :mod:`poseonly._kernels_nb` (action matrices, 6x6 eigen-
  decompositions, candidate assembly, identification and PPO ranking) and ``v_LiGT``;
* the noise bound (median by sorting: the same order statistics as ``np.partition``), Peng's or
  Yang's weights and ``mu`` schedule, ``eps = sum w v`` with numpy's pairwise summation
  (:func:`_np_sum`), the relative stopping test, the starving rule and the exact limit-cycle exit.

Problems that reach one of the rare numpy fallbacks of the lockstep path (an exactly rank-deficient
Demazure block, nearly coincident action-matrix eigenvalues, a vanishing case-2 cubic) are flagged
in ``status`` and redone by the caller with the lockstep loop.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ._kernels_nb import eig6_nb, lirp_action_nb, lirp_post_nb, rank_candidates_nb, residual_nb

MAD_TO_SIGMA = 1.4826


@njit(cache=True, error_model="numpy")
def _block_sum(a, lo, n):
    """numpy's ``pairwise_sum_DOUBLE`` on ``a[lo:lo + n]`` for ``n <= 128`` (8 accumulators)."""
    if n < 8:
        res = 0.0
        for i in range(n):
            res += a[lo + i]
        return res
    r0 = a[lo]
    r1 = a[lo + 1]
    r2 = a[lo + 2]
    r3 = a[lo + 3]
    r4 = a[lo + 4]
    r5 = a[lo + 5]
    r6 = a[lo + 6]
    r7 = a[lo + 7]
    i = 8
    m = n - (n % 8)
    while i < m:
        r0 += a[lo + i]
        r1 += a[lo + i + 1]
        r2 += a[lo + i + 2]
        r3 += a[lo + i + 3]
        r4 += a[lo + i + 4]
        r5 += a[lo + i + 5]
        r6 += a[lo + i + 6]
        r7 += a[lo + i + 7]
        i += 8
    res = ((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7))
    while i < n:
        res += a[lo + i]
        i += 1
    return res


@njit(cache=True, error_model="numpy")
def _pairwise(a, n):
    """numpy's pairwise summation of ``a[:n]``: blocks of <= 128 summed by :func:`_block_sum`,
    larger ranges split at ``n2 = n // 2 - (n // 2) % 8`` and the halves added. The recursion is
    run on an explicit stack (numba's cache cannot hold self-recursive functions: a cached
    recursive kernel called a null pointer when loaded)."""
    if n <= 128:
        return _block_sum(a, 0, n)
    slo = np.empty(128, np.int64)
    sn = np.empty(128, np.int64)
    sst = np.zeros(128, np.int64)
    vals = np.empty(128)
    top = 1
    slo[0] = 0
    sn[0] = n
    sst[0] = 0
    vt = 0
    while top > 0:
        lo = slo[top - 1]
        m = sn[top - 1]
        if m <= 128:
            vals[vt] = _block_sum(a, lo, m)
            vt += 1
            top -= 1
            continue
        m2 = m // 2
        m2 -= m2 % 8
        st = sst[top - 1]
        if st == 0:
            sst[top - 1] = 1
            slo[top], sn[top], sst[top] = lo, m2, 0
            top += 1
        elif st == 1:
            sst[top - 1] = 2
            slo[top], sn[top], sst[top] = lo + m2, m - m2, 0
            top += 1
        else:
            vals[vt - 2] = vals[vt - 2] + vals[vt - 1]
            vt -= 1
            top -= 1
    return vals[0]


@njit(cache=True, error_model="numpy")
def _np_sum(a, n):
    """``np.sum`` of a contiguous float64 row (``0.0 +`` the pairwise sum, as numpy's add.reduce)."""
    return 0.0 + _pairwise(a, n)


@njit(cache=True, error_model="numpy")
def _median(a, n, buf):
    """``np.median`` of ``a[:n]`` (finite values): the middle order statistic(s)."""
    for i in range(n):
        buf[i] = a[i]
    s = np.sort(buf[:n])
    k = n // 2
    if n % 2:
        return s[k]
    return (s[k - 1] + s[k]) / 2.0


@njit(cache=True, error_model="numpy")
def gnc_lirp_nb(f1, f2, w0, ms_tls, scale_kind, scale_value, c_factor, noise_bound, max_it, eps0, sigma_floor,
                mu_factor, mu0, P, min_sample, mono, R_out, t_out, w_out, v_out, c_out, it_out, conv_out, status):
    """GNC-IRLS (Alg. 2) with LiRP and ``v_LiGT`` on ``f1, f2 (h, n, 3)`` from weights ``w0 (h, n)``.

    ``scale_kind``: 0 median, 1 MAD, 2 fixed ``scale_value``; ``noise_bound > 0`` fixes ``c``;
    ``mu0 > 0`` fixes the initial ``mu``; ``P`` the longest limit-cycle period detected (0: none).
    Outputs as :class:`poseonly.robust.gnc.GNCBatchResult`; ``status[h] = 1`` where the problem needs
    the lockstep path (a numpy fallback of LiRP), its outputs are then undefined.
    """
    h, n = f1.shape[0], f1.shape[1]
    S = P + 1
    A = np.empty((n, 9))
    Aw = np.empty((n, 9))
    Ap = np.zeros((9, 9))
    q = np.empty((1, 3, 9))
    C = np.empty((1, 2, 6, 6))
    ok = np.empty(1, np.bool_)
    lam = np.empty((1, 2, 6), np.complex128)
    G = np.empty((1, 2, 6, 6), np.complex128)
    fail = np.empty(1, np.bool_)
    cand = np.empty((1, 18, 9))
    dmin = np.empty((1, 2))
    need = np.empty(1, np.bool_)
    E = np.empty((1, 18, 3, 3))
    F1 = np.empty((1, n, 3))
    F2 = np.empty((1, n, 3))
    W = np.empty((1, n))
    Rc = np.empty((1, 18, 3, 3))
    tc = np.empty((1, 18, 3))
    valid = np.empty((1, 18), np.bool_)
    M1 = np.empty((1, 18))
    cost = np.empty((1, 18))
    best = np.empty(1, np.int64)
    Rk = np.empty((1, 3, 3))
    tk = np.empty((1, 3))
    vout = np.empty((1, n))
    v = np.empty(n)
    vf = np.empty(n)
    wn = np.empty(n)
    prod = np.empty(n)
    buf = np.empty(n)
    HW = np.empty((max(S, 1), n))
    HR = np.empty((max(S, 1), 3, 3))
    Ht = np.empty((max(S, 1), 3))
    Hv = np.empty((max(S, 1), n))
    Hc = np.empty(max(S, 1))
    He = np.empty(max(S, 1))
    K = max_it - 1
    for hh in range(h):
        status[hh] = 0
        for i in range(n):
            for d in range(3):
                F1[0, i, d] = f1[hh, i, d]
                F2[0, i, d] = f2[hh, i, d]
            for a in range(3):
                x = f1[hh, i, a]
                for b in range(3):
                    A[i, 3 * a + b] = x * f2[hh, i, b]
            W[0, i] = w0[hh, i]
        if P > 0:
            for i in range(n):
                HW[0, i] = W[0, i]
        mu = 0.0
        eps_prev = np.inf
        nb_last = -1
        for k in range(max_it):
            # ---- LiRP (Alg. 1) on the weighted rows
            for i in range(n):
                wi = W[0, i]
                for j in range(9):
                    Aw[i, j] = A[i, j] * wi
            if n < 9:
                for i in range(9):
                    for j in range(9):
                        Ap[i, j] = Aw[i, j] if i < n else 0.0
                _, _, Vt = np.linalg.svd(Ap)
            elif n > 9:
                Rq = np.linalg.qr(Aw)[1]
                _, _, Vt = np.linalg.svd(Rq)
            else:
                _, _, Vt = np.linalg.svd(Aw)
            for r in range(3):
                for j in range(9):
                    q[0, r, j] = Vt[6 + r, j]
            lirp_action_nb(q, mono, C, ok)
            if not ok[0]:
                status[hh] = 1
                break
            eig6_nb(C, lam, G, fail, 1e-6)
            if fail[0]:
                status[hh] = 1
                break
            lirp_post_nb(q, lam, G, cand, dmin, need)
            if need[0]:
                status[hh] = 1
                break
            for c in range(18):
                for i in range(3):
                    for j in range(3):
                        E[0, c, i, j] = cand[0, c, 3 * j + i]
            rank_candidates_nb(E, F1, F2, W, True, True, Rc, tc, valid, M1, cost, best)
            bk = best[0]
            for i in range(3):
                tk[0, i] = tc[0, bk, i]
                for j in range(3):
                    Rk[0, i, j] = Rc[0, bk, i, j]
            # ---- residuals, bound, weights (gnc_irls_batch, step by step)
            residual_nb(Rk, tk, F1, F2, 0, vout)
            for i in range(n):
                x = vout[0, i]
                if math.isfinite(x):
                    v[i] = x
                    vf[i] = x
                else:
                    v[i] = np.inf
                    vf[i] = 0.0
            if noise_bound > 0.0:
                c_k = noise_bound
            else:
                if scale_kind == 2:
                    s = scale_value
                else:
                    for i in range(n):
                        prod[i] = abs(vf[i])
                    med = _median(prod, n, buf)
                    if scale_kind == 0:
                        s = MAD_TO_SIGMA * med
                    else:
                        for i in range(n):
                            prod[i] = abs(prod[i] - med)
                        s = MAD_TO_SIGMA * _median(prod, n, buf)
                c_k = c_factor * max(s, sigma_floor)
            mu_a = mu
            if k == 0:
                if mu0 > 0.0:
                    mu_a = mu0
                else:
                    mx = -np.inf
                    for i in range(n):
                        x = vf[i] * vf[i]
                        if x > mx:
                            mx = x
                    r = mx / max(c_k * c_k, 1e-300)
                    if ms_tls:
                        m_ = 1.0 / (5.0 * r - 1.0)
                        mu_a = m_ if (math.isfinite(m_) and m_ > 1e-6) else 1e-6
                    else:
                        m_ = 1.0 / (2.0 * r - 1.0)
                        mu_a = m_ if (math.isfinite(m_) and m_ > 0.0) else 1e16
            npos = 0
            nonbin = False
            if ms_tls:
                ub = (mu_a + 1.0) / mu_a * c_k
                for i in range(n):
                    x = abs(v[i])
                    if x <= c_k:
                        y = 1.0
                    elif x >= ub:
                        y = 0.0
                    else:
                        y = (mu_a + 1.0) * c_k / max(x, 1e-300) - mu_a
                    wn[i] = y
            else:
                c2 = c_k * c_k
                lb = mu_a / (mu_a + 1.0) * c2
                ub = (mu_a + 1.0) / mu_a * c2
                for i in range(n):
                    x = abs(v[i])
                    x2 = x * x
                    if x2 <= lb:
                        y = 1.0
                    elif x2 >= ub:
                        y = 0.0
                    else:
                        y = math.sqrt(c2 * mu_a * (mu_a + 1.0) / max(x2, 1e-300)) - mu_a
                    wn[i] = y
            for i in range(n):
                y = wn[i]
                if y > 0.0:
                    npos += 1
                if not (y == 0.0 or y == 1.0):
                    nonbin = True
                prod[i] = y * vf[i]
            eps = _np_sum(prod, n)
            done = abs(eps - eps_prev) <= eps0 * max(abs(eps), 1e-300)
            starving = npos < min_sample
            if not starving:
                for i in range(n):
                    W[0, i] = wn[i]
            # outputs of this iteration
            for i in range(3):
                t_out[hh, i] = tk[0, i]
                for j in range(3):
                    R_out[hh, i, j] = Rk[0, i, j]
            for i in range(n):
                v_out[hh, i] = v[i]
            c_out[hh] = c_k
            it_out[hh] = k + 1
            conv_out[hh] = done
            eps_prev = eps
            if ms_tls:
                mu_n = mu_factor * math.sqrt(mu_a) if mu_a < 1.0 else mu_factor * mu_a
            else:
                mu_n = mu_factor * mu_a
            mu = min(mu_n, 1e16)
            if done or starving:
                break
            if P > 0:
                sl = k % S
                for i in range(3):
                    Ht[sl, i] = tk[0, i]
                    for j in range(3):
                        HR[sl, i, j] = Rk[0, i, j]
                for i in range(n):
                    Hv[sl, i] = v[i]
                    HW[(k + 1) % S, i] = W[0, i]
                Hc[sl] = c_k
                He[sl] = eps
                if nonbin:
                    nb_last = k
                if nb_last < k and mu >= mu_a and k < K:
                    # _cycle_exit: the smallest period p with W_{k+1} = W_{k+1-p}, all binary since
                    period = 0
                    for p in range(1, min(P, k + 1) + 1):
                        if not nb_last < k + 1 - p:
                            continue
                        same = True
                        slp = (k + 1 - p) % S
                        sln = (k + 1) % S
                        for i in range(n):
                            if HW[slp, i] != HW[sln, i]:
                                same = False
                                break
                        if same:
                            period = p
                            break
                    if period > 0:
                        base = k + 1 - period
                        jf = K
                        conv = False
                        for m in range(1, P + 1):
                            j = k + m
                            if not (m <= period and j <= K):
                                break
                            e_cur = He[(base + (j - base) % period) % S]
                            e_prev = He[(base + (j - 1 - base) % period) % S]
                            if abs(e_cur - e_prev) <= eps0 * max(abs(e_cur), 1e-300):
                                jf = j
                                conv = True
                                break
                        jm = base + (jf - base) % period
                        sl = jm % S
                        for i in range(3):
                            t_out[hh, i] = Ht[sl, i]
                            for j in range(3):
                                R_out[hh, i, j] = HR[sl, i, j]
                        for i in range(n):
                            v_out[hh, i] = Hv[sl, i]
                            W[0, i] = HW[(jm + 1) % S, i]
                        c_out[hh] = Hc[sl]
                        it_out[hh] = jf + 1
                        conv_out[hh] = conv
                        break
        for i in range(n):
            w_out[hh, i] = W[0, i]
