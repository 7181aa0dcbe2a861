"""numba implementations behind :mod:`poseonly._kernels` (imported only when numba is present).

IEEE semantics (``error_model="numpy"``: a division by zero gives inf/nan instead of raising, which
also lets LLVM vectorise the point loops); ``fastmath`` is limited to ``reassoc`` in the point
loops (sums may be reordered). The numpy twins give the same numbers to rounding.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, types
from numba.np.linalg import _LAPACK, ensure_lapack  # numba's LAPACK bindings (those of numpy.linalg's overloads)

# ------------------------------------------------------------------------------------------------
# pose identification + PPO ranking (twin: poseonly.identify._rank_numpy)


@njit(cache=True, error_model="numpy")
def _jacobi3(M, V):
    """Eigen-decomposition of the symmetric 3x3 ``M`` (overwritten by its diagonal form) by cyclic
    Jacobi rotations; eigenvectors in the columns of ``V`` (a proper rotation)."""
    for i in range(3):
        for j in range(3):
            V[i, j] = 1.0 if i == j else 0.0
    for _sweep in range(30):
        off = M[0, 1] * M[0, 1] + M[0, 2] * M[0, 2] + M[1, 2] * M[1, 2]
        dia = M[0, 0] * M[0, 0] + M[1, 1] * M[1, 1] + M[2, 2] * M[2, 2]
        if off <= 1e-40 * dia or off == 0.0:
            break
        for pq in range(3):
            p = 0 if pq < 2 else 1
            q = 1 if pq == 0 else 2
            apq = M[p, q]
            if apq == 0.0:
                continue
            theta = (M[q, q] - M[p, p]) / (2.0 * apq)
            if abs(theta) > 1e150:
                tt = 0.5 / theta
            else:
                tt = 1.0 / (abs(theta) + math.sqrt(theta * theta + 1.0))
                if theta < 0.0:
                    tt = -tt
            c = 1.0 / math.sqrt(tt * tt + 1.0)
            s = tt * c
            # M <- J^T M J with J the rotation in the (p, q) plane
            for r in range(3):
                mrp = M[r, p]
                mrq = M[r, q]
                M[r, p] = c * mrp - s * mrq
                M[r, q] = s * mrp + c * mrq
            for r in range(3):
                mpr = M[p, r]
                mqr = M[q, r]
                M[p, r] = c * mpr - s * mqr
                M[q, r] = s * mpr + c * mqr
            M[p, q] = 0.0
            M[q, p] = 0.0
            for r in range(3):
                vrp = V[r, p]
                vrq = V[r, q]
                V[r, p] = c * vrp - s * vrq
                V[r, q] = s * vrp + c * vrq


@njit(cache=True, error_model="numpy")
def _smallest_eigvec3(M, v):
    """Unit eigenvector ``v`` of the smallest eigenvalue of the symmetric PSD 3x3 ``M``.

    The smallest root of the characteristic polynomial by Newton's method from 0 (monotone: all
    roots are real and >= 0), then the largest cross product of two rows of ``M - lambda I``
    (error ~ eps |M| / (lambda_2 - lambda_3), like an SVD of ``E`` for the gaps that occur)."""
    m00, m01, m02 = M[0, 0], M[0, 1], M[0, 2]
    m11, m12, m22 = M[1, 1], M[1, 2], M[2, 2]
    c2 = m00 + m11 + m22
    c1 = m00 * m11 - m01 * m01 + m00 * m22 - m02 * m02 + m11 * m22 - m12 * m12
    c0 = m00 * (m11 * m22 - m12 * m12) - m01 * (m01 * m22 - m12 * m02) + m02 * (m01 * m12 - m11 * m02)
    lam = 0.0
    for _ in range(60):
        pv = ((lam - c2) * lam + c1) * lam - c0
        dp = (3.0 * lam - 2.0 * c2) * lam + c1
        if dp == 0.0:
            break
        step = pv / dp
        lam -= step
        if abs(step) <= 1e-17 * c2:
            break
    a00, a11, a22 = m00 - lam, m11 - lam, m22 - lam
    # cross products of the rows (a00 m01 m02), (m01 a11 m12), (m02 m12 a22)
    x0 = m01 * m12 - m02 * a11
    x1 = m02 * m01 - a00 * m12
    x2 = a00 * a11 - m01 * m01
    y0 = m01 * a22 - m02 * m12
    y1 = m02 * m02 - a00 * a22
    y2 = a00 * m12 - m01 * m02
    z0 = a11 * a22 - m12 * m12
    z1 = m12 * m02 - m01 * a22
    z2 = m01 * m12 - a11 * m02
    nx = x0 * x0 + x1 * x1 + x2 * x2
    ny = y0 * y0 + y1 * y1 + y2 * y2
    nz = z0 * z0 + z1 * z1 + z2 * z2
    if nx >= ny and nx >= nz:
        v[0], v[1], v[2], nn = x0, x1, x2, nx
    elif ny >= nz:
        v[0], v[1], v[2], nn = y0, y1, y2, ny
    else:
        v[0], v[1], v[2], nn = z0, z1, z2, nz
    if nn > 0.0:
        nn = math.sqrt(nn)
        v[0] /= nn
        v[1] /= nn
        v[2] /= nn
        return True
    return False


@njit(cache=True, error_model="numpy")
def _frames(E, u3, v3, F, Ep, M, V):
    """Twin of :func:`poseonly.geometry.essential_frames` for one 3x3 ``E`` (outputs in place)."""
    for i in range(3):
        for j in range(3):
            s = 0.0
            for r in range(3):
                s += E[r, i] * E[r, j]
            M[i, j] = s
    if not _smallest_eigvec3(M, v3):  # a multiple smallest eigenvalue (e.g. E ~ identity): Jacobi
        _jacobi3(M, V)
        i0 = 0
        if M[1, 1] < M[i0, i0]:
            i0 = 1
        if M[2, 2] < M[i0, i0]:
            i0 = 2
        for i in range(3):
            v3[i] = V[i, i0]
    # u = cof(E) v3: columns of cof(E) are the cross products of the columns of E
    e00, e01, e02 = E[0, 0], E[0, 1], E[0, 2]
    e10, e11, e12 = E[1, 0], E[1, 1], E[1, 2]
    e20, e21, e22 = E[2, 0], E[2, 1], E[2, 2]
    u0 = v3[0] * (e11 * e22 - e21 * e12) + v3[1] * (e12 * e20 - e22 * e10) + v3[2] * (e10 * e21 - e20 * e11)
    u1 = v3[0] * (e21 * e02 - e01 * e22) + v3[1] * (e22 * e00 - e02 * e20) + v3[2] * (e20 * e01 - e00 * e21)
    u2 = v3[0] * (e01 * e12 - e11 * e02) + v3[1] * (e02 * e10 - e12 * e00) + v3[2] * (e00 * e11 - e10 * e01)
    s12 = math.sqrt(u0 * u0 + u1 * u1 + u2 * u2)
    if s12 > 0.0:
        u3[0], u3[1], u3[2] = u0 / s12, u1 / s12, u2 / s12
    else:
        u3[0], u3[1], u3[2] = v3[0], v3[1], v3[2]
    s3 = 0.0
    fro2 = 0.0
    for i in range(3):
        s3 += u3[i] * (E[i, 0] * v3[0] + E[i, 1] * v3[1] + E[i, 2] * v3[2])
        for j in range(3):
            fro2 += E[i, j] * E[i, j]
    sp = math.sqrt(max(fro2 - s3 * s3 + 2.0 * s12, 0.0))
    if not sp > 0.0:
        sp = 1.0
    # rows of E [v3]x are E_i x v3 (stored in M), then [u3]x applied to its columns
    for i in range(3):
        M[i, 0] = E[i, 1] * v3[2] - E[i, 2] * v3[1]
        M[i, 1] = E[i, 2] * v3[0] - E[i, 0] * v3[2]
        M[i, 2] = E[i, 0] * v3[1] - E[i, 1] * v3[0]
    for j in range(3):
        c0 = u3[1] * M[2, j] - u3[2] * M[1, j]
        c1 = u3[2] * M[0, j] - u3[0] * M[2, j]
        c2 = u3[0] * M[1, j] - u3[1] * M[0, j]
        Ep[0, j] = (E[0, j] - c0 - s3 * u3[0] * v3[j]) / sp
        Ep[1, j] = (E[1, j] - c1 - s3 * u3[1] * v3[j]) / sp
        Ep[2, j] = (E[2, j] - c2 - s3 * u3[2] * v3[j]) / sp
    for j in range(3):
        F[0, j] = u3[1] * Ep[2, j] - u3[2] * Ep[1, j]
        F[1, j] = u3[2] * Ep[0, j] - u3[0] * Ep[2, j]
        F[2, j] = u3[0] * Ep[1, j] - u3[1] * Ep[0, j]


@njit(cache=True, error_model="numpy")
def _sgn(x):
    if x > 0.0:
        return 1.0
    if x < 0.0:
        return -1.0
    return 0.0


@njit(cache=True, fastmath={"reassoc"}, error_model="numpy")
def _sign_pass(P, G, Fm, u3, v3, wv, n, out):
    """Weighted sums over the points of sign(h h'), h h' and sign(h) for both rotations ``u3 v3^T +- F``.

    Written as a flat loop over contiguous coordinate rows so that LLVM vectorises it
    (``reassoc`` only lets the sums be reordered)."""
    sa = 0.0
    sb = 0.0
    ra = 0.0
    rb = 0.0
    ma = 0.0
    mb = 0.0
    f00, f01, f02, f10, f11, f12, f20, f21, f22 = Fm[0, 0], Fm[0, 1], Fm[0, 2], Fm[1, 0], Fm[1, 1], Fm[1, 2], Fm[2, 0], Fm[2, 1], Fm[2, 2]
    for i in range(n):
        p0 = P[0, i]
        p1 = P[1, i]
        p2 = P[2, i]
        g0 = G[0, i]
        g1 = G[1, i]
        g2 = G[2, i]
        x = g0 * (f00 * p0 + f01 * p1 + f02 * p2) + g1 * (f10 * p0 + f11 * p1 + f12 * p2) + g2 * (f20 * p0 + f21 * p1 + f22 * p2)
        at = v3[0] * p0 + v3[1] * p1 + v3[2] * p2
        bt = u3[0] * g0 + u3[1] * g1 + u3[2] * g2
        base = bt * at
        aba = base + x
        abb = base - x
        ha = aba * bt - at
        hb = abb * bt - at
        pa = ha * (bt - at * aba)
        pb = hb * (bt - at * abb)
        wi = wv[i]
        sa += wi * ((1.0 if pa > 0.0 else 0.0) - (1.0 if pa < 0.0 else 0.0))
        sb += wi * ((1.0 if pb > 0.0 else 0.0) - (1.0 if pb < 0.0 else 0.0))
        ra += wi * pa
        rb += wi * pb
        ma += wi * ((1.0 if ha > 0.0 else 0.0) - (1.0 if ha < 0.0 else 0.0))
        mb += wi * ((1.0 if hb > 0.0 else 0.0) - (1.0 if hb < 0.0 else 0.0))
    out[0] = sa
    out[1] = sb
    out[2] = ra
    out[3] = rb
    out[4] = ma
    out[5] = mb


@njit(cache=True, fastmath={"reassoc"}, error_model="numpy")
def _ppo_pass(P, G, Fm, Em, u3, v3, sf, sg, wv, n):
    """Weighted sum of v_PPO over the points for the pose ``(u3 v3^T + sf F, sg u3)``
    (vectorisable twin of :func:`poseonly.identify.ppo_from_forms`)."""
    acc = 0.0
    f00, f01, f02, f10, f11, f12, f20, f21, f22 = Fm[0, 0], Fm[0, 1], Fm[0, 2], Fm[1, 0], Fm[1, 1], Fm[1, 2], Fm[2, 0], Fm[2, 1], Fm[2, 2]
    e00, e01, e02, e10, e11, e12, e20, e21, e22 = Em[0, 0], Em[0, 1], Em[0, 2], Em[1, 0], Em[1, 1], Em[1, 2], Em[2, 0], Em[2, 1], Em[2, 2]
    for i in range(n):
        p0 = P[0, i]
        p1 = P[1, i]
        p2 = P[2, i]
        g0 = G[0, i]
        g1 = G[1, i]
        g2 = G[2, i]
        x = g0 * (f00 * p0 + f01 * p1 + f02 * p2) + g1 * (f10 * p0 + f11 * p1 + f12 * p2) + g2 * (f20 * p0 + f21 * p1 + f22 * p2)
        e = g0 * (e00 * p0 + e01 * p1 + e02 * p2) + g1 * (e10 * p0 + e11 * p1 + e12 * p2) + g2 * (e20 * p0 + e21 * p1 + e22 * p2)
        at = v3[0] * p0 + v3[1] * p1 + v3[2] * p2
        bt0 = u3[0] * g0 + u3[1] * g1 + u3[2] * g2
        ab = bt0 * at + sf * x
        h = sg * (ab * bt0 - at)
        bt = sg * bt0
        e2 = e * e
        a2 = (1.0 - bt) * (1.0 + bt)
        b2 = (1.0 - ab) * (1.0 + ab)
        alpha = math.sqrt(a2 if a2 > 0.0 else 0.0)
        beta = math.sqrt(b2 if b2 > 0.0 else 0.0)
        p = alpha * ab + beta * bt
        rho = alpha * beta
        rho1 = rho if rho > 0.0 else 1.0
        pos = h > 0.0
        omc = (e2 if pos else rho1 - h) / (rho1 * (rho1 + h) if pos else rho1)
        q2 = 2.0 * rho * rho * (omc if rho > 0.0 else 0.0)
        r = math.sqrt(p * p + q2)
        r1 = r if r > 0.0 else 1.0
        ppos = p > 0.0
        omc2 = (q2 if ppos else r1 - p) / (r1 * (r1 + p) if ppos else r1)
        v = math.sqrt(2.0 * omc2) if r > 0.0 else 1.0
        acc += wv[i] * v
    return acc


@njit(cache=True, error_model="numpy")
def _rank_core(E, f1, f2, w, weighted, with_cost, R, t, valid, M1, cost, best, lazy, u3, v3, F, Ep, M, V, P, G, wv, sums, sfs, sgs):
    H, k = E.shape[0], E.shape[1]
    n = f1.shape[1]
    for hh in range(H):
        # points of zero weight add nothing to the weighted sums: they are left out of the passes
        # (GNC-IRLS zeroes its outliers, a third of the points at 30 % outliers)
        m = 0
        for i in range(n):
            wi = w[hh, i] if weighted else 1.0
            if wi != 0.0:
                for c in range(3):
                    P[c, m] = f1[hh, i, c]
                    G[c, m] = f2[hh, i, c]
                wv[m] = wi
                m += 1
        wsum = 0.0
        if weighted:
            for i in range(m):
                wsum += wv[i]
            wsum = max(wsum, 1e-300)
        else:
            wsum = float(n)
        for c in range(k):
            dup = -1
            for c2 in range(c):  # exact duplicates (complex-conjugate eigenvectors give identical candidates)
                same = True
                for i in range(3):
                    for j in range(3):
                        if E[hh, c, i, j] != E[hh, c2, i, j]:
                            same = False
                if same:
                    dup = c2
                    break
            if dup >= 0:
                M1[hh, c] = M1[hh, dup]
                valid[hh, c] = valid[hh, dup]
                cost[hh, c] = cost[hh, dup]
                sfs[c] = sfs[dup]
                sgs[c] = sgs[dup]
                for i in range(3):
                    t[hh, c, i] = t[hh, dup, i]
                    for j in range(3):
                        R[hh, c, i, j] = R[hh, dup, i, j]
                continue
            _frames(E[hh, c], u3, v3, F, Ep, M, V)
            _sign_pass(P, G, F, u3, v3, wv, m, sums)
            m1a = sums[0] / wsum
            m1b = sums[1] / wsum
            pick_b = (m1b > m1a) or (m1b == m1a and sums[3] / wsum > sums[2] / wsum)
            m1 = m1b if pick_b else m1a
            m2 = (sums[5] if pick_b else sums[4]) / wsum
            sg = -1.0 if m2 < 0.0 else 1.0
            sf = -1.0 if pick_b else 1.0
            M1[hh, c] = m1
            valid[hh, c] = (m1 > 0.0) and (abs(m2) > 0.0)
            sfs[c] = sf
            sgs[c] = sg
            for i in range(3):
                t[hh, c, i] = sg * u3[i]
                for j in range(3):
                    R[hh, c, i, j] = u3[i] * v3[j] + sf * F[i, j]
            if with_cost and not (lazy and not valid[hh, c]):
                cv = _ppo_pass(P, G, F, Ep, u3, v3, sf, sg, wv, m) / wsum
                cost[hh, c] = cv if math.isfinite(cv) else np.inf
            else:
                cost[hh, c] = np.nan if with_cost else 0.0
        if lazy and with_cost:
            # ``best`` only (GNC-IRLS): invalid candidates rank after every valid one of finite cost
            # (their key is cost + 10, PPO costs are <= 2), so their PPO pass is needed only when no
            # valid candidate has a finite cost; their ``cost`` entries stay NaN otherwise
            need = True
            for c in range(k):
                if valid[hh, c] and cost[hh, c] < np.inf:
                    need = False
                    break
            if need:
                for c in range(k):
                    if cost[hh, c] != cost[hh, c]:
                        _frames(E[hh, c], u3, v3, F, Ep, M, V)
                        cv = _ppo_pass(P, G, F, Ep, u3, v3, sfs[c], sgs[c], wv, m) / wsum
                        cost[hh, c] = cv if math.isfinite(cv) else np.inf
        # best: the first minimum of cost (+10 for invalid candidates: PPO residuals are <= 2)
        bk = 0
        bkey = np.inf
        for c in range(k):
            if cost[hh, c] != cost[hh, c]:  # deferred (lazy): ranks after the valid ones
                continue
            key = cost[hh, c] if valid[hh, c] else cost[hh, c] + 10.0
            if key < bkey:
                bkey = key
                bk = c
        best[hh] = bk


@njit(cache=True, error_model="numpy")
def rank_candidates_nb(E, f1, f2, w, weighted, with_cost, R, t, valid, M1, cost, best, lazy=False):
    """Allocating wrapper of :func:`_rank_core` (the compiled GNC loop passes its own scratch)."""
    k = E.shape[1]
    n = f1.shape[1]
    _rank_core(E, f1, f2, w, weighted, with_cost, R, t, valid, M1, cost, best, lazy, np.empty(3), np.empty(3),
               np.empty((3, 3)), np.empty((3, 3)), np.empty((3, 3)), np.empty((3, 3)), np.empty((3, n)), np.empty((3, n)),
               np.empty(n), np.empty(6), np.empty(k), np.empty(k))


# ------------------------------------------------------------------------------------------------
# LiRP around LAPACK's eig (twins: poseonly.solvers.lirp._demazure_rows / lirp_candidates)


@njit(cache=True, error_model="numpy")
def _householder_ls(A, Bm, X, m, p, r):
    """Least squares ``A (m x p) X = Bm (m x r)`` by Householder QR (``A``, ``Bm`` overwritten).
    Returns False when ``A`` is (numerically exactly) rank deficient."""
    for j in range(p):
        nrm = 0.0
        for i in range(j, m):
            nrm += A[i, j] * A[i, j]
        nrm = math.sqrt(nrm)
        if nrm == 0.0:
            return False
        alpha = -nrm if A[j, j] > 0 else nrm
        v0 = A[j, j] - alpha
        # v = (v0, A[j+1:, j]); H = I - 2 v v^T / (v^T v)
        vtv = v0 * v0
        for i in range(j + 1, m):
            vtv += A[i, j] * A[i, j]
        if vtv == 0.0:
            A[j, j] = alpha
            continue
        for c in range(j + 1, p):
            s = v0 * A[j, c]
            for i in range(j + 1, m):
                s += A[i, j] * A[i, c]
            f = 2.0 * s / vtv
            A[j, c] -= f * v0
            for i in range(j + 1, m):
                A[i, c] -= f * A[i, j]
        for c in range(r):
            s = v0 * Bm[j, c]
            for i in range(j + 1, m):
                s += A[i, j] * Bm[i, c]
            f = 2.0 * s / vtv
            Bm[j, c] -= f * v0
            for i in range(j + 1, m):
                Bm[i, c] -= f * A[i, j]
        A[j, j] = alpha
    for c in range(r):
        for j in range(p - 1, -1, -1):
            s = Bm[j, c]
            for l in range(j + 1, p):
                s -= A[j, l] * X[l, c]
            X[j, c] = s / A[j, j]
    return True


@njit(cache=True, error_model="numpy")
def _action_core(q, mono, C, ok, Q, P, tr, B, B4, B6, X):
    """Action matrices ``C (h, 2, 6, 6)`` of the Demazure system of ``a Q1 + b Q2 + Q3`` (``q (h, 3, 9)``
    column-major vecs; ``mono (27,)`` monomial index of ``Q_i Q_j Q_k``); ``ok[h] = False`` when the
    4-column block is rank deficient (the caller falls back to numpy's pinv)."""
    h = q.shape[0]
    for hh in range(h):
        for i in range(3):
            for a in range(3):
                for b in range(3):
                    Q[i, a, b] = q[hh, i, 3 * b + a]
        for i in range(3):
            for j in range(3):
                s = 0.0
                for a in range(3):
                    for c in range(3):
                        acc = 0.0
                        for b in range(3):
                            acc += Q[i, a, b] * Q[j, c, b]
                        P[i, j, a, c] = acc
                    s += P[i, j, a, a]
                tr[i, j] = s
        for r in range(9):
            for m in range(10):
                B[r, m] = 0.0
        for i in range(3):
            for j in range(3):
                for k in range(3):
                    m = mono[9 * i + 3 * j + k]
                    for a in range(3):
                        for d in range(3):
                            acc = 0.0
                            for c in range(3):
                                acc += P[i, j, a, c] * Q[k, c, d]
                            B[3 * a + d, m] += 2.0 * acc - tr[i, j] * Q[k, a, d]
        for r in range(9):
            for m in range(4):
                B4[r, m] = B[r, m]
            for m in range(6):
                B6[r, m] = B[r, 4 + m]
        ok[hh] = _householder_ls(B4, B6, X, 9, 4, 6)
        for c in range(2):
            for r in range(6):
                for m in range(6):
                    C[hh, c, r, m] = 0.0
        for r in range(3):
            for m in range(6):
                C[hh, 0, r, m] = -X[r, m]
                C[hh, 1, r, m] = -X[r + 1, m]
        C[hh, 0, 3, 0] = 1.0
        C[hh, 0, 4, 1] = 1.0
        C[hh, 0, 5, 3] = 1.0
        C[hh, 1, 3, 1] = 1.0
        C[hh, 1, 4, 2] = 1.0
        C[hh, 1, 5, 4] = 1.0


@njit(cache=True, error_model="numpy")
def lirp_action_nb(q, mono, C, ok):
    """Allocating wrapper of :func:`_action_core`."""
    _action_core(q, mono, C, ok, np.empty((3, 3, 3)), np.empty((3, 3, 3, 3)), np.empty((3, 3)), np.empty((9, 10)),
                 np.empty((9, 4)), np.empty((9, 6)), np.empty((4, 6)))


@njit(cache=True, error_model="numpy")
def _det3(M):
    return (M[0, 0] * (M[1, 1] * M[2, 2] - M[1, 2] * M[2, 1]) - M[0, 1] * (M[1, 0] * M[2, 2] - M[1, 2] * M[2, 0])
            + M[0, 2] * (M[1, 0] * M[2, 1] - M[1, 1] * M[2, 0]))


@njit(cache=True, error_model="numpy")
def _cubic_real_parts(c3, c2, c1, c0, out):
    """Real parts of the three roots of ``c3 x^3 + c2 x^2 + c1 x + c0`` (closed form, Numerical
    Recipes 5.6), polished by two Newton steps on the real roots."""
    inv = 1.0 / (c3 if c3 != 0.0 else 1e-300)
    a = c2 * inv
    b = c1 * inv
    c = c0 * inv
    Qc = (a * a - 3.0 * b) / 9.0
    Rc = (2.0 * a * a * a - 9.0 * a * b + 27.0 * c) / 54.0
    nreal = 3
    if Rc * Rc < Qc * Qc * Qc:
        th = math.acos(Rc / math.sqrt(Qc * Qc * Qc))
        sq = -2.0 * math.sqrt(Qc)
        out[0] = sq * math.cos(th / 3.0) - a / 3.0
        out[1] = sq * math.cos((th + 2.0 * math.pi) / 3.0) - a / 3.0
        out[2] = sq * math.cos((th - 2.0 * math.pi) / 3.0) - a / 3.0
    else:
        A = -math.copysign(1.0, Rc) * (abs(Rc) + math.sqrt(Rc * Rc - Qc * Qc * Qc)) ** (1.0 / 3.0)
        Bc = Qc / A if A != 0.0 else 0.0
        out[0] = (A + Bc) - a / 3.0
        out[1] = -0.5 * (A + Bc) - a / 3.0
        out[2] = out[1]
        nreal = 1
    for i in range(nreal):
        x = out[i]
        for _ in range(2):
            f = ((x + a) * x + b) * x + c
            d = (3.0 * x + 2.0 * a) * x + b
            if d != 0.0 and math.isfinite(f / d):
                x -= f / d
        out[i] = x
    for i in range(3):
        if not math.isfinite(out[i]):
            out[i] = 0.0


@njit(cache=True, error_model="numpy")
def _post_core(q, lam, G, cand, dmin, need_numpy, coef, M, r, dets):
    """The 18 unit candidates ``cand (h, 18, 9)`` and ``dmin (h, 2)`` from ``q (h, 3, 9)`` and the
    eigen-decompositions ``lam (h, 2, 6)``, ``G (h, 2, 6, 6)`` (eigenvectors in columns).
    ``need_numpy[h]`` is set when the case-2 cubic is nearly identically zero (noise-free planar
    scenes): its roots are then rounding noise and the caller recomputes them with numpy's LAPACK
    calls (bitwise the old results)."""
    h = q.shape[0]
    for hh in range(h):
        for c in range(2):
            for j in range(6):
                g3 = G[hh, c, 3, j]
                g4 = G[hh, c, 4, j]
                g5 = G[hh, c, 5, j]
                row = 6 * c + j
                coef[row, 0] = g3.real * g5.real + g3.imag * g5.imag
                coef[row, 1] = g4.real * g5.real + g4.imag * g5.imag
                coef[row, 2] = g5.real * g5.real + g5.imag * g5.imag
            best = np.inf
            for i in range(6):
                for j in range(6):
                    if i != j:
                        d = abs(lam[hh, c, i] - lam[hh, c, j])
                        if d < best:
                            best = d
            dmin[hh, c] = best
        for sd in range(4):
            for a in range(3):
                for b in range(3):
                    x0 = q[hh, 0, 3 * b + a]
                    x1 = q[hh, 1, 3 * b + a]
                    if sd == 0:
                        M[a, b] = x0
                    elif sd == 1:
                        M[a, b] = x1
                    elif sd == 2:
                        M[a, b] = x0 + x1
                    else:
                        M[a, b] = x1 - x0
            dets[sd] = _det3(M)
        d3, d0, sp, sm = dets[0], dets[1], dets[2], dets[3]
        d2 = 0.5 * (sp + sm) - d0
        d1 = 0.5 * (sp - sm) - d3
        need_numpy[hh] = max(max(abs(d0), abs(d1)), max(abs(d2), abs(d3))) < 1e-6
        use_a = abs(d3) >= abs(d0)
        if use_a:
            _cubic_real_parts(d3, d2, d1, d0, r)
        else:
            _cubic_real_parts(d0, d1, d2, d3, r)
        for i in range(3):
            coef[12 + i, 0] = r[i] if use_a else 1.0
            coef[12 + i, 1] = 1.0 if use_a else r[i]
            coef[12 + i, 2] = 0.0
        for i in range(3):
            coef[15 + i, 0] = 1.0 if i == 0 else 0.0
            coef[15 + i, 1] = 1.0 if i == 1 else 0.0
            coef[15 + i, 2] = 1.0 if i == 2 else 0.0
        for k in range(18):
            nrm = 0.0
            for m in range(9):
                v = coef[k, 0] * q[hh, 0, m] + coef[k, 1] * q[hh, 1, m] + coef[k, 2] * q[hh, 2, m]
                cand[hh, k, m] = v
                nrm += v * v
            nrm = math.sqrt(nrm)
            if nrm > 0.0:
                for m in range(9):
                    cand[hh, k, m] /= nrm
            else:
                for m in range(9):
                    cand[hh, k, m] = q[hh, 2, m]


@njit(cache=True, error_model="numpy")
def lirp_post_nb(q, lam, G, cand, dmin, need_numpy):
    """Allocating wrapper of :func:`_post_core`."""
    _post_core(q, lam, G, cand, dmin, need_numpy, np.empty((18, 3)), np.empty((3, 3)), np.empty(3), np.empty(4))


# ------------------------------------------------------------------------------------------------
# five-point solver, real solutions (twin: poseonly.solvers.fivept.fivept_batch + is_real filter)


@njit(cache=True, error_model="numpy")
def _lu(A, piv, n):
    """In-place LU with partial pivoting of ``A[:n, :n]``; returns False on an exactly zero pivot."""
    for k in range(n):
        p = k
        big = abs(A[k, k])
        for i in range(k + 1, n):
            if abs(A[i, k]) > big:
                big = abs(A[i, k])
                p = i
        piv[k] = p
        if big == 0.0:
            return False
        if p != k:
            for j in range(n):
                tmp = A[k, j]
                A[k, j] = A[p, j]
                A[p, j] = tmp
        inv = 1.0 / A[k, k]
        for i in range(k + 1, n):
            A[i, k] *= inv
            f = A[i, k]
            if f != 0.0:
                for j in range(k + 1, n):
                    A[i, j] -= f * A[k, j]
    return True


@njit(cache=True, error_model="numpy")
def _lu_solve(LU, piv, b, n):
    for k in range(n):
        p = piv[k]
        if p != k:
            tmp = b[k]
            b[k] = b[p]
            b[p] = tmp
    for i in range(n):
        s = b[i]
        for j in range(i):
            s -= LU[i, j] * b[j]
        b[i] = s
    for i in range(n - 1, -1, -1):
        s = b[i]
        for j in range(i + 1, n):
            s -= LU[i, j] * b[j]
        b[i] = s / LU[i, i]


@njit(cache=True, error_model="numpy")
def _balance(a, n):
    """Parlett-Reinsch balancing of ``a[:n, :n]`` in place (Numerical Recipes ``balanc``)."""
    radix = 2.0
    sqrdx = radix * radix
    done = False
    while not done:
        done = True
        for i in range(n):
            r = 0.0
            c = 0.0
            for j in range(n):
                if j != i:
                    c += abs(a[j, i])
                    r += abs(a[i, j])
            if c != 0.0 and r != 0.0:
                g = r / radix
                f = 1.0
                s = c + r
                while c < g:
                    f *= radix
                    c *= sqrdx
                while c > r * radix:
                    f /= radix
                    c /= sqrdx
                if (c + r) / f < 0.95 * s:
                    done = False
                    g = 1.0 / f
                    for j in range(n):
                        a[i, j] *= g
                    for j in range(n):
                        a[j, i] *= f


@njit(cache=True, error_model="numpy")
def _hessenberg(a, n):
    """Reduction of ``a[:n, :n]`` to upper Hessenberg form by stabilised elementary similarity
    transformations (Numerical Recipes ``elmhes``); entries below the subdiagonal are zeroed."""
    for m in range(1, n - 1):
        x = 0.0
        i = m
        for j in range(m, n):
            if abs(a[j, m - 1]) > abs(x):
                x = a[j, m - 1]
                i = j
        if i != m:
            for j in range(m - 1, n):
                tmp = a[i, j]
                a[i, j] = a[m, j]
                a[m, j] = tmp
            for j in range(n):
                tmp = a[j, i]
                a[j, i] = a[j, m]
                a[j, m] = tmp
        if x != 0.0:
            for i2 in range(m + 1, n):
                y = a[i2, m - 1]
                if y != 0.0:
                    y /= x
                    a[i2, m - 1] = y
                    for j in range(m, n):
                        a[i2, j] -= y * a[m, j]
                    for j in range(n):
                        a[j, m] += y * a[j, i2]
    for i in range(2, n):
        for j in range(i - 1):
            a[i, j] = 0.0


@njit(cache=True, error_model="numpy")
def _hqr(h, n, wr, wi):
    """Eigenvalues of the upper Hessenberg ``h[1:n+1, 1:n+1]`` (1-based, destroyed) by the Francis
    double-shift QR algorithm (EISPACK ``hqr`` as in Numerical Recipes). False if it did not converge."""
    anorm = 0.0
    for i in range(1, n + 1):
        for j in range(max(i - 1, 1), n + 1):
            anorm += abs(h[i, j])
    nn = n
    t = 0.0
    x = y = z = w = p = q = r = s = 0.0
    while nn >= 1:
        its = 0
        while True:
            l = 1
            for ll in range(nn, 1, -1):
                s = abs(h[ll - 1, ll - 1]) + abs(h[ll, ll])
                if s == 0.0:
                    s = anorm
                if abs(h[ll, ll - 1]) + s == s:
                    h[ll, ll - 1] = 0.0
                    l = ll
                    break
            x = h[nn, nn]
            if l == nn:
                wr[nn] = x + t
                wi[nn] = 0.0
                nn -= 1
            else:
                y = h[nn - 1, nn - 1]
                w = h[nn, nn - 1] * h[nn - 1, nn]
                if l == nn - 1:
                    p = 0.5 * (y - x)
                    q = p * p + w
                    z = math.sqrt(abs(q))
                    x += t
                    if q >= 0.0:
                        z = p + (z if p >= 0.0 else -z)
                        wr[nn - 1] = x + z
                        wr[nn] = x + z
                        if z != 0.0:
                            wr[nn] = x - w / z
                        wi[nn - 1] = 0.0
                        wi[nn] = 0.0
                    else:
                        wr[nn - 1] = x + p
                        wr[nn] = x + p
                        wi[nn - 1] = -z
                        wi[nn] = z
                    nn -= 2
                else:
                    if its == 60:
                        return False
                    if its == 10 or its == 20 or its == 40:
                        t += x
                        for i in range(1, nn + 1):
                            h[i, i] -= x
                        s = abs(h[nn, nn - 1]) + abs(h[nn - 1, nn - 2])
                        x = 0.75 * s
                        y = x
                        w = -0.4375 * s * s
                    its += 1
                    m = nn - 2
                    while m >= l:
                        z = h[m, m]
                        r = x - z
                        s = y - z
                        p = (r * s - w) / h[m + 1, m] + h[m, m + 1]
                        q = h[m + 1, m + 1] - z - r - s
                        r = h[m + 2, m + 1]
                        s = abs(p) + abs(q) + abs(r)
                        p /= s
                        q /= s
                        r /= s
                        if m == l:
                            break
                        u = abs(h[m, m - 1]) * (abs(q) + abs(r))
                        v = abs(p) * (abs(h[m - 1, m - 1]) + abs(z) + abs(h[m + 1, m + 1]))
                        if u + v == v:
                            break
                        m -= 1
                    for i in range(m + 2, nn + 1):
                        h[i, i - 2] = 0.0
                        if i != m + 2:
                            h[i, i - 3] = 0.0
                    for k in range(m, nn):
                        if k != m:
                            p = h[k, k - 1]
                            q = h[k + 1, k - 1]
                            r = 0.0
                            if k != nn - 1:
                                r = h[k + 2, k - 1]
                            x = abs(p) + abs(q) + abs(r)
                            if x != 0.0:
                                p /= x
                                q /= x
                                r /= x
                        s = math.sqrt(p * p + q * q + r * r)
                        if p < 0.0:
                            s = -s
                        if s != 0.0:
                            if k == m:
                                if l != m:
                                    h[k, k - 1] = -h[k, k - 1]
                            else:
                                h[k, k - 1] = -s * x
                            p += s
                            x = p / s
                            y = q / s
                            z = r / s
                            q /= p
                            r /= p
                            for j in range(k, nn + 1):
                                p = h[k, j] + q * h[k + 1, j]
                                if k != nn - 1:
                                    p += r * h[k + 2, j]
                                    h[k + 2, j] -= p * z
                                h[k + 1, j] -= p * y
                                h[k, j] -= p * x
                            mmin = nn if nn < k + 3 else k + 3
                            for i in range(l, mmin + 1):
                                p = x * h[i, k] + y * h[i, k + 1]
                                if k != nn - 1:
                                    p += z * h[i, k + 2]
                                    h[i, k + 2] -= p * r
                                h[i, k + 1] -= p * q
                                h[i, k] -= p
            if l >= nn - 1:
                break
    return True


@njit(cache=True, error_model="numpy")
def fivept_real_nb(f1, f2, mono, unit_cols, action_rows, real_tol, E, mask, fail):
    """Stewenius five-point on minimal samples ``f (h, 5, 3)``: the real solutions in ``E (h, 10,
    3, 3)`` (unit Frobenius norm), ``mask (h, 10)``; ``fail[h]`` when a step broke down (the caller
    redoes those samples with numpy/LAPACK). ``mono (64,)``: monomial of ``c_i c_j c_k`` in the
    template's column order; ``action_rows``/``unit_cols``: the action matrix layout of
    :mod:`poseonly.solvers.fivept`."""
    h = f1.shape[0]
    At = np.empty((9, 5))
    Qn = np.empty((9, 9))
    hv = np.empty(9)
    basis = np.empty((4, 3, 3))
    P = np.empty((4, 4, 3, 3))
    tr = np.empty((4, 4))
    T = np.empty((10, 20))
    A1 = np.empty((10, 10))
    piv = np.empty(10, np.int64)
    b = np.empty(10)
    Mact = np.empty((10, 10))
    Hs = np.empty((11, 11))
    wr = np.empty(11)
    wi = np.empty(11)
    L = np.empty((10, 10))
    cr = np.empty(3)
    for hh in range(h):
        fail[hh] = False
        for s in range(10):
            mask[hh, s] = False
        # --- null space of the 5 x 9 epipolar rows: Householder QR of A^T (9 x 5), last 4 columns of Q
        for i in range(5):
            for c in range(3):
                for r in range(3):
                    At[3 * c + r, i] = f1[hh, i, c] * f2[hh, i, r]
        for i in range(9):
            for j in range(9):
                Qn[i, j] = 1.0 if i == j else 0.0
        ok = True
        for j in range(5):
            nrm = 0.0
            for i in range(j, 9):
                nrm += At[i, j] * At[i, j]
            nrm = math.sqrt(nrm)
            if nrm == 0.0:
                ok = False
                break
            alpha = -nrm if At[j, j] > 0 else nrm
            for i in range(9):
                hv[i] = 0.0
            hv[j] = At[j, j] - alpha
            for i in range(j + 1, 9):
                hv[i] = At[i, j]
            vtv = 0.0
            for i in range(j, 9):
                vtv += hv[i] * hv[i]
            if vtv == 0.0:
                continue
            for c in range(j, 5):
                sacc = 0.0
                for i in range(j, 9):
                    sacc += hv[i] * At[i, c]
                f = 2.0 * sacc / vtv
                for i in range(j, 9):
                    At[i, c] -= f * hv[i]
            # Q <- Q H (accumulate the reflectors)
            for r in range(9):
                sacc = 0.0
                for i in range(j, 9):
                    sacc += Qn[r, i] * hv[i]
                f = 2.0 * sacc / vtv
                for i in range(j, 9):
                    Qn[r, i] -= f * hv[i]
        if not ok:
            fail[hh] = True
            continue
        for k in range(4):
            for a in range(3):
                for c in range(3):
                    basis[k, a, c] = Qn[3 * c + a, 5 + k]
        # --- template: 9 Demazure cubics and det over the 20 monomials
        for i in range(4):
            for j in range(4):
                sacc = 0.0
                for a in range(3):
                    for c in range(3):
                        acc = 0.0
                        for d in range(3):
                            acc += basis[i, a, d] * basis[j, c, d]
                        P[i, j, a, c] = acc
                    sacc += P[i, j, a, a]
                tr[i, j] = sacc
        for r in range(10):
            for m in range(20):
                T[r, m] = 0.0
        for i in range(4):
            for j in range(4):
                for k in range(4):
                    m = mono[16 * i + 4 * j + k]
                    for a in range(3):
                        for d in range(3):
                            acc = 0.0
                            for c in range(3):
                                acc += P[i, j, a, c] * basis[k, c, d]
                            T[3 * d + a, m] += 2.0 * acc - tr[i, j] * basis[k, a, d]
                    cr[0] = basis[j, 1, 1] * basis[k, 2, 2] - basis[j, 1, 2] * basis[k, 2, 1]
                    cr[1] = basis[j, 1, 2] * basis[k, 2, 0] - basis[j, 1, 0] * basis[k, 2, 2]
                    cr[2] = basis[j, 1, 0] * basis[k, 2, 1] - basis[j, 1, 1] * basis[k, 2, 0]
                    T[9, m] += basis[i, 0, 0] * cr[0] + basis[i, 0, 1] * cr[1] + basis[i, 0, 2] * cr[2]
        # --- G = A1^{-1} A2 and the action matrix of multiplication by x
        for r in range(10):
            for c in range(10):
                A1[r, c] = T[r, c]
        if not _lu(A1, piv, 10):
            fail[hh] = True
            continue
        for r in range(10):
            for c in range(10):
                Mact[r, c] = 0.0
        for c in range(10):
            for r in range(10):
                b[r] = T[r, 10 + c]
            _lu_solve(A1, piv, b, 10)
            for rr in range(6):
                Mact[rr, c] = -b[action_rows[rr]]
        for rr in range(4):
            Mact[6 + rr, unit_cols[rr]] = 1.0
        # --- eigenvalues: balance, Hessenberg, Francis QR
        for r in range(10):
            for c in range(10):
                L[r, c] = Mact[r, c]
        _balance(L, 10)
        _hessenberg(L, 10)
        for r in range(10):
            for c in range(10):
                Hs[r + 1, c + 1] = L[r, c]
        if not _hqr(Hs, 10, wr, wi):
            fail[hh] = True
            continue
        mnorm = 0.0
        for r in range(10):
            for c in range(10):
                mnorm = max(mnorm, abs(Mact[r, c]))
        slot = 0
        for e in range(1, 11):
            lam = wr[e]
            if not abs(wi[e]) <= real_tol * (1.0 + math.sqrt(lam * lam + wi[e] * wi[e])):
                continue
            # eigenvector: two steps of inverse iteration with M - lam I
            for r in range(10):
                for c in range(10):
                    L[r, c] = Mact[r, c]
                L[r, r] -= lam
            for k in range(10):
                pk = k
                big = abs(L[k, k])
                for i in range(k + 1, 10):
                    if abs(L[i, k]) > big:
                        big = abs(L[i, k])
                        pk = i
                piv[k] = pk
                if pk != k:
                    for j in range(10):
                        tmp = L[k, j]
                        L[k, j] = L[pk, j]
                        L[pk, j] = tmp
                if L[k, k] == 0.0:
                    L[k, k] = 1e-300 + 1e-15 * mnorm
                inv = 1.0 / L[k, k]
                for i in range(k + 1, 10):
                    L[i, k] *= inv
                    fk = L[i, k]
                    if fk != 0.0:
                        for j in range(k + 1, 10):
                            L[i, j] -= fk * L[k, j]
            for r in range(10):
                b[r] = 1.0
            for _it in range(2):
                _lu_solve(L, piv, b, 10)
                nb = 0.0
                for r in range(10):
                    nb += b[r] * b[r]
                nb = math.sqrt(nb)
                if not (nb > 0.0 and math.isfinite(nb)):
                    break
                for r in range(10):
                    b[r] /= nb
            nE = 0.0
            for a in range(3):
                for c in range(3):
                    v = b[6] * basis[0, a, c] + b[7] * basis[1, a, c] + b[8] * basis[2, a, c] + b[9] * basis[3, a, c]
                    E[hh, slot, a, c] = v
                    nE += v * v
            nE = math.sqrt(nE)
            if not (nE > 0.0 and math.isfinite(nE)):
                continue
            for a in range(3):
                for c in range(3):
                    E[hh, slot, a, c] /= nE
            mask[hh, slot] = True
            slot += 1
        for s2 in range(slot, 10):
            for a in range(3):
                for c in range(3):
                    E[hh, s2, a, c] = 0.0


# ------------------------------------------------------------------------------------------------
# residuals (twins: poseonly.residuals.v_LiGT, v_sampson)


@njit(cache=True, error_model="numpy")
def _residual_core(R, t, f1, f2, kind, out, P, G):
    """``out (k, n)``: residual ``kind`` (0 = v_LiGT, 1 = v_sampson, 2 = v_sampson_chiral) of the poses ``R (k, 3, 3)``,
    ``t (k, 3)`` (normalised here) on ``f (m, n, 3)`` with ``m = 1`` (shared points) or ``m = k``."""
    k = R.shape[0]
    m = f1.shape[0]
    n = f1.shape[1]
    for c in range(k):
        if c == 0 or m > 1:
            j = c if m > 1 else 0
            for i in range(n):
                for d in range(3):
                    P[d, i] = f1[j, i, d]
                    G[d, i] = f2[j, i, d]
        _pose_row(R, t, c, P, G, kind, out[c], n)


@njit(cache=True, error_model="numpy")
def _pose_row(R, t, c, P, G, kind, o, n):
    """Residual ``kind`` of pose ``c`` of ``R, t`` on the points ``P, G (3, n)`` into ``o (n,)``."""
    tn = math.sqrt(t[c, 0] * t[c, 0] + t[c, 1] * t[c, 1] + t[c, 2] * t[c, 2])
    if not tn > 0.0:
        tn = 1.0
    t0 = t[c, 0] / tn
    t1 = t[c, 1] / tn
    t2 = t[c, 2] / tn
    r00, r01, r02 = R[c, 0, 0], R[c, 0, 1], R[c, 0, 2]
    r10, r11, r12 = R[c, 1, 0], R[c, 1, 1], R[c, 1, 2]
    r20, r21, r22 = R[c, 2, 0], R[c, 2, 1], R[c, 2, 2]
    if kind == 0:
        _ligt_row(P, G, r00, r01, r02, r10, r11, r12, r20, r21, r22, t0, t1, t2, o, n)
    else:
        # E = [t]x R
        e00 = t1 * r20 - t2 * r10
        e01 = t1 * r21 - t2 * r11
        e02 = t1 * r22 - t2 * r12
        e10 = t2 * r00 - t0 * r20
        e11 = t2 * r01 - t0 * r21
        e12 = t2 * r02 - t0 * r22
        e20 = t0 * r10 - t1 * r00
        e21 = t0 * r11 - t1 * r01
        e22 = t0 * r12 - t1 * r02
        _sampson_row(P, G, e00, e01, e02, e10, e11, e12, e20, e21, e22, o, n)
        if kind == 2:
            _chiral_row(P, G, r00, r01, r02, r10, r11, r12, r20, r21, r22, t0, t1, t2, o, n)


@njit(cache=True, error_model="numpy")
def score_nb(R, t, f1, f2, kind, mode, thr, thr2, out):
    """RANSAC scores ``out (k,)`` of the poses ``R (k, 3, 3)``, ``t (k, 3)`` on shared points ``f (n, 3)``
    without materialising the ``(k, n)`` residuals (twin: :func:`poseonly.robust.ransac._score`, same
    order of operations and numpy's pairwise sums, so the same bits). ``mode`` 0: inlier count below
    ``thr``; 1: MSAC ``sum thr^2 - min(v^2, thr^2)`` (``thr2[0] = thr^2``); 2: MSAC averaged over the
    squared thresholds ``thr2`` (``sum_k sum 1 - min(v^2, t_k^2) / t_k^2``). ``min`` propagates NaN
    as ``np.minimum`` does."""
    k = R.shape[0]
    n = f1.shape[0]
    P = np.empty((3, n))
    G = np.empty((3, n))
    row = np.empty(n)
    term = np.empty(n)
    for i in range(n):
        for d in range(3):
            P[d, i] = f1[i, d]
            G[d, i] = f2[i, d]
    for c in range(k):
        _pose_row(R, t, c, P, G, kind, row, n)
        if mode == 0:
            cnt = 0
            for i in range(n):
                if row[i] < thr:
                    cnt += 1
            out[c] = float(cnt)
        elif mode == 1:
            t2 = thr2[0]
            for i in range(n):
                v2 = row[i] * row[i]
                term[i] = t2 - (t2 if v2 > t2 else v2)
            out[c] = _np_sum(term, n)
        else:
            acc = 0.0
            for j in range(thr2.shape[0]):
                t2 = thr2[j]
                for i in range(n):
                    v2 = row[i] * row[i]
                    term[i] = 1.0 - (t2 if v2 > t2 else v2) / t2
                acc = acc + _np_sum(term, n)
            out[c] = acc


@njit(cache=True, error_model="numpy")
def residual_nb(R, t, f1, f2, kind, out):
    """Allocating wrapper of :func:`_residual_core`."""
    n = f1.shape[1]
    _residual_core(R, t, f1, f2, kind, out, np.empty((3, n)), np.empty((3, n)))


@njit(cache=True, error_model="numpy")
def _chiral_row(P, G, r00, r01, r02, r10, r11, r12, r20, r21, r22, t0, t1, t2, o, n):
    # 1 (a gross error) where a pose-only depth numerator is not positive (residuals.ligt_depths:
    # h = (R f1 x f2) . (f2 x t), h' = (R f1 x f2) . (R f1 x t))
    for i in range(n):
        p0 = P[0, i]
        p1 = P[1, i]
        p2 = P[2, i]
        a0 = r00 * p0 + r01 * p1 + r02 * p2
        a1 = r10 * p0 + r11 * p1 + r12 * p2
        a2 = r20 * p0 + r21 * p1 + r22 * p2
        g0 = G[0, i]
        g1 = G[1, i]
        g2 = G[2, i]
        c0 = a1 * g2 - a2 * g1
        c1 = a2 * g0 - a0 * g2
        c2 = a0 * g1 - a1 * g0
        h = c0 * (g1 * t2 - g2 * t1) + c1 * (g2 * t0 - g0 * t2) + c2 * (g0 * t1 - g1 * t0)
        hp = c0 * (a1 * t2 - a2 * t1) + c1 * (a2 * t0 - a0 * t2) + c2 * (a0 * t1 - a1 * t0)
        if not (h > 0.0 and hp > 0.0):
            o[i] = 1.0


@njit(cache=True, error_model="numpy")
def _ligt_row(P, G, r00, r01, r02, r10, r11, r12, r20, r21, r22, t0, t1, t2, o, n):
    # ||L t|| = |c| |c . t| with c = f2 x R f1 (Lagrange identity, residuals.v_LiGT)
    for i in range(n):
        p0 = P[0, i]
        p1 = P[1, i]
        p2 = P[2, i]
        a0 = r00 * p0 + r01 * p1 + r02 * p2
        a1 = r10 * p0 + r11 * p1 + r12 * p2
        a2 = r20 * p0 + r21 * p1 + r22 * p2
        g0 = G[0, i]
        g1 = G[1, i]
        g2 = G[2, i]
        c0 = g1 * a2 - g2 * a1
        c1 = g2 * a0 - g0 * a2
        c2 = g0 * a1 - g1 * a0
        ct = c0 * t0 + c1 * t1 + c2 * t2
        o[i] = math.sqrt(c0 * c0 + c1 * c1 + c2 * c2) * abs(ct)


@njit(cache=True, error_model="numpy")
def _sampson_row(P, G, e00, e01, e02, e10, e11, e12, e20, e21, e22, o, n):
    for i in range(n):
        p0 = P[0, i]
        p1 = P[1, i]
        p2 = P[2, i]
        g0 = G[0, i]
        g1 = G[1, i]
        g2 = G[2, i]
        x0 = e00 * p0 + e01 * p1 + e02 * p2
        x1 = e10 * p0 + e11 * p1 + e12 * p2
        x2 = e20 * p0 + e21 * p1 + e22 * p2
        y0 = e00 * g0 + e10 * g1 + e20 * g2
        y1 = e01 * g0 + e11 * g1 + e21 * g2
        y2 = e02 * g0 + e12 * g1 + e22 * g2
        num = g0 * x0 + g1 * x1 + g2 * x2
        den = x0 * x0 + x1 * x1 + x2 * x2 + (y0 * y0 + y1 * y1 + y2 * y2) - 2.0 * (num * num)
        o[i] = abs(num) / math.sqrt(den if den > 1e-300 else 1e-300)


# ------------------------------------------------------------------------------------------------
# small nonsymmetric eigenproblems (twin: numpy.linalg.eig on LiRP's 6x6 action matrices)


@njit(cache=True, error_model="numpy")
def _eigvec_inverse_iteration(A, n, lam, L, piv, b, anorm):
    """Eigenvector of ``A[:n, :n]`` for the eigenvalue ``lam`` (complex) by two steps of inverse
    iteration with ``A - lam I`` (complex LU with partial pivoting), unit 2-norm, in ``b``."""
    for r in range(n):
        for c in range(n):
            L[r, c] = A[r, c]
        L[r, r] -= lam
    tiny = 1e-15 * anorm + 1e-300
    for k in range(n):
        pk = k
        big = abs(L[k, k])
        for i in range(k + 1, n):
            if abs(L[i, k]) > big:
                big = abs(L[i, k])
                pk = i
        piv[k] = pk
        if pk != k:
            for j in range(n):
                tmp = L[k, j]
                L[k, j] = L[pk, j]
                L[pk, j] = tmp
        if abs(L[k, k]) < tiny:
            L[k, k] = tiny
        inv = 1.0 / L[k, k]
        for i in range(k + 1, n):
            L[i, k] *= inv
            f = L[i, k]
            if f != 0.0:
                for j in range(k + 1, n):
                    L[i, j] -= f * L[k, j]
    for r in range(n):
        b[r] = 1.0 + 0.0j
    for _it in range(2):
        for k in range(n):
            p = piv[k]
            if p != k:
                tmp = b[k]
                b[k] = b[p]
                b[p] = tmp
        for i in range(n):
            s = b[i]
            for j in range(i):
                s -= L[i, j] * b[j]
            b[i] = s
        for i in range(n - 1, -1, -1):
            s = b[i]
            for j in range(i + 1, n):
                s -= L[i, j] * b[j]
            b[i] = s / L[i, i]
        nb = 0.0
        for r in range(n):
            nb += b[r].real * b[r].real + b[r].imag * b[r].imag
        nb = math.sqrt(nb)
        if not (nb > 0.0 and math.isfinite(nb)):
            return False
        for r in range(n):
            b[r] /= nb
    return True


@njit(cache=True, error_model="numpy")
def _action_pattern(A):
    """1 or 2 when rows 3-5 of the 6x6 ``A`` are the unit rows of LiRP's action matrix ``C1``
    (``e0, e1, e3``: ``a g = (a^2, ab, b^2, a, b, 1) a``) or ``C2`` (``e1, e2, e4``), else 0."""
    for k in range(2):
        cols = (0, 1, 3) if k == 0 else (1, 2, 4)
        ok = True
        for r in range(3):
            for c in range(6):
                want = 1.0 if c == cols[r] else 0.0
                if A[3 + r, c] != want:
                    ok = False
        if ok:
            return k + 1
    return 0


@njit(cache=True, error_model="numpy")
def _action_eigvec(A, pattern, lam, b, K):
    """Unit eigenvector ``b`` of LiRP's action matrix ``A`` (:func:`_action_pattern`) for the
    eigenvalue ``lam``: the unit rows give ``g = B(lam) y`` with three free entries ``y``, the three
    dense rows ``K(lam) y = 0`` with ``K = (A - lam I)[:3] B(lam)``, solved by the largest cross
    product of two rows of ``K`` (no 6x6 factorisation; complex-bilinear, so it works for complex
    ``lam``). Returns False when ``K`` has no clear 1-D null space (the caller iterates instead)."""
    l2 = lam * lam
    l3 = l2 * lam
    for i in range(3):
        if pattern == 1:  # y = (g2, g4, g5): g = (l^2 g5, l g4, g2, l g5, g4, g5)
            K[i, 0] = A[i, 2] - (lam if i == 2 else 0.0)
            K[i, 1] = lam * A[i, 1] + A[i, 4] - (l2 if i == 1 else 0.0)
            K[i, 2] = l2 * A[i, 0] + lam * A[i, 3] + A[i, 5] - (l3 if i == 0 else 0.0)
        else:  # y = (g0, g3, g5): g = (g0, l g3, l^2 g5, g3, l g5, g5)
            K[i, 0] = A[i, 0] - (lam if i == 0 else 0.0)
            K[i, 1] = lam * A[i, 1] + A[i, 3] - (l2 if i == 1 else 0.0)
            K[i, 2] = l2 * A[i, 2] + lam * A[i, 4] + A[i, 5] - (l3 if i == 2 else 0.0)
    best = -1.0
    y0 = y1 = y2 = 0.0j
    kn = 0.0
    for i in range(3):
        for j in range(3):
            kn = max(kn, abs(K[i, j]))
    for a, c in ((0, 1), (0, 2), (1, 2)):
        x0 = K[a, 1] * K[c, 2] - K[a, 2] * K[c, 1]
        x1 = K[a, 2] * K[c, 0] - K[a, 0] * K[c, 2]
        x2 = K[a, 0] * K[c, 1] - K[a, 1] * K[c, 0]
        nx = (x0.real * x0.real + x0.imag * x0.imag + x1.real * x1.real + x1.imag * x1.imag
              + x2.real * x2.real + x2.imag * x2.imag)
        if nx > best:
            best = nx
            y0, y1, y2 = x0, x1, x2
    if not (best > (1e-12 * kn * kn) ** 2 and math.isfinite(best)):
        return False
    if pattern == 1:
        b[0] = l2 * y2
        b[1] = lam * y1
        b[2] = y0
        b[3] = lam * y2
        b[4] = y1
        b[5] = y2
    else:
        b[0] = y0
        b[1] = lam * y1
        b[2] = l2 * y2
        b[3] = y1
        b[4] = lam * y2
        b[5] = y2
    nb = 0.0
    for r in range(6):
        nb += b[r].real * b[r].real + b[r].imag * b[r].imag
    nb = math.sqrt(nb)
    if not (nb > 0.0 and math.isfinite(nb)):
        return False
    for r in range(6):
        b[r] /= nb
    return True


@njit(cache=True, error_model="numpy")
def _eig6_core(C, lam, G, fail, sep_tol, Hs, Lr, wr, wi, Lc, Ac, piv, b, K):
    """Eigen-decompositions of ``C (h, m, 6, 6)``: ``lam (h, m, 6)``, ``G (h, m, 6, 6)`` (unit
    eigenvectors in columns, exact conjugates for conjugate pairs). ``fail[h]`` when the Francis QR
    did not converge or two eigenvalues are closer than ``sep_tol (1 + |lambda|)`` (eigenvectors
    ill-determined: the caller uses LAPACK for those problems)."""
    h, m = C.shape[0], C.shape[1]
    n = 6
    for hh in range(h):
        fail[hh] = False
        for mm in range(m):
            anorm = 0.0
            for r in range(n):
                for c in range(n):
                    Lr[r, c] = C[hh, mm, r, c]
                    Ac[r, c] = C[hh, mm, r, c]
                    anorm = max(anorm, abs(C[hh, mm, r, c]))
            _balance(Lr, n)
            _hessenberg(Lr, n)
            for r in range(n):
                for c in range(n):
                    Hs[r + 1, c + 1] = Lr[r, c]
            if not _hqr(Hs, n, wr, wi):
                fail[hh] = True
                break
            for e in range(n):
                lam[hh, mm, e] = complex(wr[e + 1], wi[e + 1])
            for e in range(n):
                for e2 in range(e + 1, n):
                    if abs(lam[hh, mm, e] - lam[hh, mm, e2]) <= sep_tol * (1.0 + abs(lam[hh, mm, e])):
                        fail[hh] = True
            if fail[hh]:
                break
            pat = _action_pattern(C[hh, mm])
            Cm = C[hh, mm]
            e = 0
            while e < n:
                lv = lam[hh, mm, e]
                if not (pat > 0 and _action_eigvec(Cm, pat, lv, b, K)) and not _eigvec_inverse_iteration(Ac, n, lv, Lc, piv, b, anorm):
                    fail[hh] = True
                    break
                for r in range(n):
                    G[hh, mm, r, e] = b[r]
                if lv.imag != 0.0 and e + 1 < n and lam[hh, mm, e + 1] == lv.conjugate():
                    for r in range(n):
                        G[hh, mm, r, e + 1] = b[r].conjugate()
                    e += 2
                else:
                    e += 1
            if fail[hh]:
                break


@njit(cache=True, error_model="numpy")
def eig6_nb(C, lam, G, fail, sep_tol):
    """Allocating wrapper of :func:`_eig6_core`."""
    _eig6_core(C, lam, G, fail, sep_tol, np.empty((7, 7)), np.empty((6, 6)), np.empty(7), np.empty(7),
               np.empty((6, 6), np.complex128), np.empty((6, 6), np.complex128), np.empty(6, np.int64),
               np.empty(6, np.complex128), np.empty((3, 3), np.complex128))


@njit(cache=True)
def kron_rows_nb(f1, f2, A):
    """``A[h, i, 3 j + k] = f1[h, i, j] f2[h, i, k]`` (column-major vec; same products as numpy)."""
    H, n = f1.shape[0], f1.shape[1]
    for hh in range(H):
        for i in range(n):
            for j in range(3):
                a = f1[hh, i, j]
                for k in range(3):
                    A[hh, i, 3 * j + k] = a * f2[hh, i, k]


# ------------------------------------------------------------------------------------------------
# LiGTopt normal equations (twin: poseonly.refine.ligt._normal_equations_numpy)


@njit(cache=True, error_model="numpy")
def _rho(s, loss):
    """(rho(s), rho'(s)) of the grouped robust losses (codes of poseonly.refine.ligt._LOSS_CODE)."""
    if loss == 0:
        return s, 1.0
    if loss == 1:  # soft_l1
        r = math.sqrt(1.0 + s)
        return 2.0 * (r - 1.0), 1.0 / r
    if loss == 2:  # huber
        if s > 1.0:
            r = math.sqrt(s)
            return 2.0 * r - 1.0, 1.0 / r
        return s, 1.0
    if loss == 3:  # cauchy
        return math.log1p(s), 1.0 / (1.0 + s)
    q = 1.0 + s * s  # arctan
    return math.atan(s), 1.0 / q


@njit(cache=True, error_model="numpy")
def ligt_normal_nb(R, t, Jl, Jt, f1, f2, sw, norm, loss, scale, want, H, g):
    """Robust LiGT cost ``scale^2 sum rho(|r_i|^2 / scale^2)`` and, when ``want``, the Gauss-Newton
    normal equations ``H = sum rho' J_i^T J_i`` (5x5), ``g = sum rho' J_i^T r_i`` (5) of the
    residual vectors ``r_i`` (normalisation ``norm``: 0 none, 1 theta2, 2 angular) with respect to
    the pose chart ``(w, v)``; ``Jl`` the SO(3) left Jacobian, ``Jt`` (3, 2) the translation chart."""
    n = f1.shape[0]
    for p in range(5):
        g[p] = 0.0
        for q in range(5):
            H[p, q] = 0.0
    cost = 0.0
    s2 = scale * scale
    r = np.empty(3)
    J = np.empty((3, 5))
    dA = np.empty(3)
    dC = np.empty(3)
    dS = np.empty(3)
    dT = np.empty(3)
    for i in range(n):
        x0, x1, x2 = f1[i, 0], f1[i, 1], f1[i, 2]
        y0, y1, y2 = f2[i, 0], f2[i, 1], f2[i, 2]
        a0 = R[0, 0] * x0 + R[0, 1] * x1 + R[0, 2] * x2
        a1 = R[1, 0] * x0 + R[1, 1] * x1 + R[1, 2] * x2
        a2 = R[2, 0] * x0 + R[2, 1] * x1 + R[2, 2] * x2
        c0 = y1 * a2 - y2 * a1
        c1 = y2 * a0 - y0 * a2
        c2 = y0 * a1 - y1 * a0
        s0 = y1 * t[2] - y2 * t[1]
        s1 = y2 * t[0] - y0 * t[2]
        s_2 = y0 * t[1] - y1 * t[0]
        cc = c0 * c0 + c1 * c1 + c2 * c2
        cs = c0 * s0 + c1 * s1 + c2 * s_2
        z = 0.0
        q0 = q1 = q2 = 0.0
        P0 = P1 = P2 = 0.0
        nP = 1.0
        if norm == 0:
            r[0] = cc * s0 - c0 * cs
            r[1] = cc * s1 - c1 * cs
            r[2] = cc * s_2 - c2 * cs
        else:
            cc = max(cc, 1e-30)
            z = -cs / cc
            q0 = s0 + z * c0
            q1 = s1 + z * c1
            q2 = s_2 + z * c2
            if norm == 1:
                r[0], r[1], r[2] = q0, q1, q2
            else:
                P0 = z * a0 + t[0]
                P1 = z * a1 + t[1]
                P2 = z * a2 + t[2]
                nP = max(math.sqrt(P0 * P0 + P1 * P1 + P2 * P2), 1e-300)
                r[0], r[1], r[2] = q0 / nP, q1 / nP, q2 / nP
        w = sw[i]
        r[0] *= w
        r[1] *= w
        r[2] *= w
        si = (r[0] * r[0] + r[1] * r[1] + r[2] * r[2]) / s2
        rho, drho = _rho(si, loss)
        cost += s2 * rho
        if not want:
            continue
        for k in range(5):
            if k < 3:
                j0, j1, j2 = Jl[0, k], Jl[1, k], Jl[2, k]
                dA[0] = j1 * a2 - j2 * a1
                dA[1] = j2 * a0 - j0 * a2
                dA[2] = j0 * a1 - j1 * a0
                dC[0] = y1 * dA[2] - y2 * dA[1]
                dC[1] = y2 * dA[0] - y0 * dA[2]
                dC[2] = y0 * dA[1] - y1 * dA[0]
                dS[0] = dS[1] = dS[2] = 0.0
                dT[0] = dT[1] = dT[2] = 0.0
            else:
                dA[0] = dA[1] = dA[2] = 0.0
                dC[0] = dC[1] = dC[2] = 0.0
                dT[0], dT[1], dT[2] = Jt[0, k - 3], Jt[1, k - 3], Jt[2, k - 3]
                dS[0] = y1 * dT[2] - y2 * dT[1]
                dS[1] = y2 * dT[0] - y0 * dT[2]
                dS[2] = y0 * dT[1] - y1 * dT[0]
            dcc = 2.0 * (dC[0] * c0 + dC[1] * c1 + dC[2] * c2)
            dcs = dC[0] * s0 + dC[1] * s1 + dC[2] * s_2 + c0 * dS[0] + c1 * dS[1] + c2 * dS[2]
            if norm == 0:
                J[0, k] = s0 * dcc + cc * dS[0] - c0 * dcs - cs * dC[0]
                J[1, k] = s1 * dcc + cc * dS[1] - c1 * dcs - cs * dC[1]
                J[2, k] = s_2 * dcc + cc * dS[2] - c2 * dcs - cs * dC[2]
            else:
                dz = -dcs / cc + (cs / (cc * cc)) * dcc
                e0 = dS[0] + c0 * dz + z * dC[0]
                e1 = dS[1] + c1 * dz + z * dC[1]
                e2 = dS[2] + c2 * dz + z * dC[2]
                if norm == 1:
                    J[0, k], J[1, k], J[2, k] = e0, e1, e2
                else:
                    dP0 = a0 * dz + z * dA[0] + dT[0]
                    dP1 = a1 * dz + z * dA[1] + dT[1]
                    dP2 = a2 * dz + z * dA[2] + dT[2]
                    f = (P0 * dP0 + P1 * dP1 + P2 * dP2) / (nP * nP * nP)
                    J[0, k] = e0 / nP - q0 * f
                    J[1, k] = e1 / nP - q1 * f
                    J[2, k] = e2 / nP - q2 * f
        for k in range(5):
            J[0, k] *= w
            J[1, k] *= w
            J[2, k] *= w
        for p in range(5):
            g[p] += drho * (J[0, p] * r[0] + J[1, p] * r[1] + J[2, p] * r[2])
            for q in range(p, 5):
                H[p, q] += drho * (J[0, p] * J[0, q] + J[1, p] * J[1, q] + J[2, p] * J[2, q])
    for p in range(5):
        for q in range(p):
            H[p, q] = H[q, p]
    return cost


# ------------------------------------------------------------------------------------------------
# 9x9 SVD by one-sided Jacobi (LiRP's null space; replaces LAPACK's dgesdd, ~9 us per 9x9 call)


def _round_robin(m):
    """Round-robin (circle method) schedule of ``m - 1`` columns plus one idle slot: ``(m - 1,
    m // 2 - 1, 2)``, each round ``m // 2 - 1`` disjoint pairs (the idle slot's pair left out);
    every pair of columns occurs exactly once."""
    players = list(range(m))
    rounds = []
    for _ in range(m - 1):
        pr = []
        for i in range(m // 2):
            a, b = players[i], players[m - 1 - i]
            if m - 1 not in (a, b):
                pr.append((min(a, b), max(a, b)))
        rounds.append(pr)
        players = [players[0], players[-1]] + players[1:-1]
    return np.array(rounds, dtype=np.int64)


_JACOBI_ROUNDS = _round_robin(10)  # 9 columns: 9 rounds of 4 disjoint pairs (+ one idle)


@njit(cache=True, error_model="numpy", fastmath={"reassoc", "contract"})
def _jacobi9(R, s, Vt, X, V, nrm, cs, sn, act):
    """SVD of a 9x9 ``R`` by one-sided Jacobi (Hestenes): columns of ``X = R V`` are rotated pairwise
    until mutually orthogonal (``|x_p . x_q| <= 1e-15 |x_p| |x_q|``, or a sweep whose largest cosine
    was below 1e-8: the next would only confirm it); ``V`` accumulates the rotations.
    Returns the sweeps used; ``s (9,)`` descending, ``Vt (9, 9)`` rows = right singular vectors.
    Each round rotates 4 disjoint pairs, so the square roots and divisions of the four rotation
    angles overlap in the pipeline. High relative accuracy: the right singular vectors of the small
    singular values (LiRP's null space) are as accurate as LAPACK's (measured agreement 2e-15)."""
    for p in range(9):
        for i in range(9):
            X[p, i] = R[i, p]
            V[p, i] = 0.0
        V[p, p] = 1.0
    sweep = 0
    while sweep < 40:
        sweep += 1
        rotated = False
        worst = 0.0  # largest |cos| between two columns met in this sweep
        for r in range(9):
            for k in range(4):
                p = _JACOBI_ROUNDS[r, k, 0]
                q = _JACOBI_ROUNDS[r, k, 1]
                ap = 0.0
                aq = 0.0
                g = 0.0
                for i in range(9):
                    xp = X[p, i]
                    xq = X[q, i]
                    ap += xp * xp
                    aq += xq * xq
                    g += xp * xq
                nn = math.sqrt(ap * aq)
                if p == q or not abs(g) > 1e-15 * nn:
                    act[k] = False
                    continue
                act[k] = True
                if abs(g) > worst * nn:
                    worst = abs(g) / nn
                zeta = (aq - ap) / (2.0 * g)
                t = 1.0 / (abs(zeta) + math.sqrt(1.0 + zeta * zeta))
                if zeta < 0.0:
                    t = -t
                c = 1.0 / math.sqrt(1.0 + t * t)
                cs[k] = c
                sn[k] = c * t
            for k in range(4):
                if not act[k]:
                    continue
                rotated = True
                p = _JACOBI_ROUNDS[r, k, 0]
                q = _JACOBI_ROUNDS[r, k, 1]
                c = cs[k]
                s_ = sn[k]
                for i in range(9):
                    xp = X[p, i]
                    xq = X[q, i]
                    X[p, i] = c * xp - s_ * xq
                    X[q, i] = s_ * xp + c * xq
                    vp = V[p, i]
                    vq = V[q, i]
                    V[p, i] = c * vp - s_ * vq
                    V[q, i] = s_ * vp + c * vq
        # quadratic convergence: after a sweep whose largest |cos| was below 1e-8 the columns are
        # orthogonal to ~1e-16, so the confirming sweep (36 dot products, no rotation) is skipped
        if not rotated or worst < 1e-8:
            break
    for p in range(9):
        x = 0.0
        for i in range(9):
            x += X[p, i] * X[p, i]
        nrm[p] = math.sqrt(x)
    # descending order, stable (ties keep the column order); NaN norms (NaN input) sort last
    for r in range(9):
        b = -1
        bv = -1.0
        for p in range(9):
            if nrm[p] > bv:
                bv = nrm[p]
                b = p
        if b < 0:
            for p in range(9):
                if nrm[p] != -2.0:
                    b = p
                    break
        s[r] = nrm[b]
        for i in range(9):
            Vt[r, i] = V[b, i]
        nrm[b] = -2.0
    return sweep


@njit(cache=True, error_model="numpy", fastmath={"reassoc", "contract"})
def _householder_r9(AF, n, R):
    """Triangular factor ``R (9, 9)`` of the Householder QR of the ``n x 9`` matrix held column by
    column in ``AF (9, n)`` (overwritten; LAPACK's ``dgeqr2`` conventions: ``R[k, k] = beta = -sign(alpha)
    |x|``, no pivoting; equal to ``dgeqrf``'s factor to ~1e-15). Used for ``n <= QR_SMALL``, where it
    beats LAPACK's call (workspace query and allocation per call); OpenBLAS wins for larger ``n``."""
    for k in range(9):
        sig = 0.0
        for i in range(k + 1, n):
            sig += AF[k, i] * AF[k, i]
        alpha = AF[k, k]
        if sig == 0.0:
            R[k, k] = alpha
            for j in range(k + 1, 9):
                R[k, j] = AF[j, k]
            continue
        beta = math.sqrt(alpha * alpha + sig)
        if alpha > 0.0:
            beta = -beta
        tau = (beta - alpha) / beta
        scale = 1.0 / (alpha - beta)
        for i in range(k + 1, n):
            AF[k, i] *= scale
        R[k, k] = beta
        for j in range(k + 1, 9):
            d = AF[j, k]
            for i in range(k + 1, n):
                d += AF[k, i] * AF[j, i]
            d *= tau
            AF[j, k] -= d
            for i in range(k + 1, n):
                AF[j, i] -= d * AF[k, i]
            R[k, j] = AF[j, k]
    for k in range(9):
        for j in range(k):
            R[k, j] = 0.0


QR_SMALL = 64


@njit(cache=True, error_model="numpy")
def _qr_r9(AF, n, tau, R):
    """``R (9, 9)`` of the ``n x 9`` matrix held column-major in ``AF (9, n)`` (overwritten), ``n > 9``:
    :func:`_householder_r9` up to ``QR_SMALL`` rows, LAPACK's ``dgeqrf`` above (numpy's bits)."""
    if n <= QR_SMALL:
        _householder_r9(AF, n, R)
        return
    _geqrf(_KIND_D, n, 9, AF.ctypes, n, tau.ctypes)
    for i in range(9):
        for j in range(9):
            R[i, j] = AF[j, i] if i <= j else 0.0


@njit(cache=True, error_model="numpy")
def qr_r9_nb(A, R):
    """``R (h, 9, 9)`` of stacked ``A (h, n, 9)`` (``n > 9``) by :func:`_qr_r9`."""
    h, n = A.shape[0], A.shape[1]
    AF = np.empty((9, n))
    tau = np.empty(9)
    for hh in range(h):
        for i in range(n):
            for j in range(9):
                AF[j, i] = A[hh, i, j]
        _qr_r9(AF, n, tau, R[hh])


@njit(cache=True, error_model="numpy")
def svd9_nb(R, s, Vt):
    """Singular values ``s (h, 9)`` (descending) and right singular vectors ``Vt (h, 9, 9)`` (rows) of
    stacked 9x9 matrices ``R`` by :func:`_jacobi9`."""
    X = np.empty((9, 9))
    V = np.empty((9, 9))
    nrm = np.empty(9)
    cs = np.empty(4)
    sn = np.empty(4)
    act = np.empty(4, np.bool_)
    for hh in range(R.shape[0]):
        _jacobi9(R[hh], s[hh], Vt[hh], X, V, nrm, cs, sn, act)


# ------------------------------------------------------------------------------------------------
# GNC-IRLS with LiRP + v_LiGT, one problem after another (twin: poseonly.robust.gnc.gnc_irls_batch)
# (behind :func:`poseonly._kernels.gnc_lirp`; kept in this module on purpose: numba's cache is
# invalidated by the stamp of the file that holds a kernel, so a kernel in another module would keep
# running stale copies of the helpers below after they change.)
#
# The twin of :func:`poseonly.robust.gnc.gnc_irls_batch` for the paper's estimator: the same
# iterations, in the same floating-point order, without the lockstep's Python overhead per iteration
# (docs/speed_notes.md section 8: at 30 % outliers GNC-RANSAC's lockstep spent ~9 of 17 ms in
# per-iteration overhead, most of it while one or two problems were still running). Every numerical
# step is the one the lockstep path executes with the kernels enabled:
#
# * the weighted rows ``kron(f1_i, f2_i) w_i``, their QR (``n > 9``) through numba's LAPACK bindings
#   (the ``dgeqrf`` call of ``numpy.linalg.qr``; bit-identical outputs, compared in the tests) and the
#   Jacobi SVD of the ``9 x 9`` factor (LAPACK's ``dgesdd`` of the zero-padded rows for ``n < 9``);
# * the compiled LiRP stages above (action matrices, 6x6 eigen-
#   decompositions, candidate assembly, identification and PPO ranking) and ``v_LiGT``;
# * the noise bound (median by sorting: the same order statistics as ``np.partition``), Peng's or
#   Yang's weights and ``mu`` schedule, ``eps = sum w v`` with numpy's pairwise summation
#   (:func:`_np_sum`), the relative stopping test, the starving rule and the exact limit-cycle exit.
#
# Problems that reach one of the rare numpy fallbacks of the lockstep path (an exactly rank-deficient
# Demazure block, nearly coincident action-matrix eigenvalues, a vanishing case-2 cubic) are flagged
# in ``status`` and redone by the caller with the lockstep loop.

MAD_TO_SIGMA = 1.4826

ensure_lapack()
_geqrf = _LAPACK().numba_ez_geqrf(types.float64)
_gesdd = _LAPACK().numba_ez_gesdd(types.float64)
_KIND_D = ord("d")
_JOBZ_A = ord("A")


@njit(cache=True, error_model="numpy")
def _right_singular9(AF, AF2, n, tau, R9, s, U, VT, Vt, X, V, nrm, cs, sn, act):
    """Right singular vectors ``Vt (9, 9)`` (rows, descending singular values ``s``) of the ``n x 9``
    matrix stored column-major in ``AF (9, n)`` (overwritten), as :func:`poseonly.solvers.lirp._null_space3`
    computes them with the kernels: for ``n > 9`` the QR of :func:`_qr_r9` and the Jacobi SVD of the
    triangular factor,
    for ``n = 9`` the Jacobi SVD of the rows, for ``n < 9`` LAPACK's ``dgesdd('A')`` of the
    zero-padded rows (``numpy.linalg.svd``'s call), and LAPACK's QR and SVD where the null space is
    exactly 3-D (``sigma_7 <= 1e-9 sigma_1``, ``lirp.DEGENERATE_NULL``: ``numpy.linalg``'s basis).
    ``R9``, ``U``, ``VT``: ``9 x 9`` scratch."""
    if n < 9:
        for j in range(9):
            for i in range(9):
                R9[j, i] = AF[j, i] if i < n else 0.0  # column-major padded rows
        _gesdd(_KIND_D, _JOBZ_A, 9, 9, R9.ctypes, 9, s.ctypes, U.ctypes, 9, VT.ctypes, 9)
        for r in range(9):
            for c in range(9):
                Vt[r, c] = VT[c, r]
        return
    small = 9 < n <= QR_SMALL
    if small:  # the rows are needed again if the null space turns out exactly 3-D
        for j in range(9):
            for i in range(n):
                AF2[j, i] = AF[j, i]
    if n > 9:
        _qr_r9(AF, n, tau, R9)
    else:
        for i in range(9):
            for j in range(9):
                R9[i, j] = AF[j, i]
    _jacobi9(R9, s, Vt, X, V, nrm, cs, sn, act)
    if s[6] <= 1e-9 * s[0]:  # exactly 3-D null space: LAPACK's QR and SVD (lirp.DEGENERATE_NULL)
        if small:
            _geqrf(_KIND_D, n, 9, AF2.ctypes, n, tau.ctypes)
            for j in range(9):
                for i in range(9):
                    U[j, i] = AF2[j, i] if i <= j else 0.0
        else:
            for j in range(9):
                for i in range(9):
                    U[j, i] = R9[i, j]
        _gesdd(_KIND_D, _JOBZ_A, 9, 9, U.ctypes, 9, s.ctypes, X.ctypes, 9, VT.ctypes, 9)
        for r in range(9):
            for c in range(9):
                Vt[r, c] = VT[c, r]


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
    s = buf[:n]
    s.sort()  # in place: no allocation
    k = n // 2
    if n % 2:
        return s[k]
    return (s[k - 1] + s[k]) / 2.0


@njit(cache=True, error_model="numpy")
def gnc_lirp_nb(f1, f2, w0, ms_tls, scale_kind, scale_value, c_factor, noise_bound, max_it, eps0, sigma_floor,
                mu_factor, mu0, P, min_sample, mono, R_out, t_out, w_out, v_out, c_out, it_out, conv_out, status,
                multi=False, rkind=0):
    """GNC-IRLS (Alg. 2) with LiRP on ``f1, f2 (h, n, 3)`` from weights ``w0 (h, n)``.

    ``multi=False``: LiRP's identified pose (``poseonly.estimator.lirp_solver``); ``multi=True``: all
    valid candidates (``lirp_all_solver``: every candidate where none is valid), the one minimising
    ``sum w v`` kept. ``rkind``: the residual, 0 ``v_LiGT``, 1 ``v_sampson``, 2 ``v_sampson_chiral``.
    ``scale_kind``: 0 median, 1 MAD, 2 fixed ``scale_value``; ``noise_bound > 0`` fixes ``c``;
    ``mu0 > 0`` fixes the initial ``mu``; ``P`` the longest limit-cycle period detected (0: none).
    Outputs as :class:`poseonly.robust.gnc.GNCBatchResult`; ``status[h] = 1`` where the problem needs
    the lockstep path (a numpy fallback of LiRP), its outputs are then undefined.
    """
    h, n = f1.shape[0], f1.shape[1]
    S = P + 1
    A = np.empty((n, 9))
    AF = np.empty((9, max(n, 9)))
    AF2 = np.empty((9, max(n, 9)))
    tau = np.empty(9)
    RF = np.empty((9, 9))
    X9 = np.empty((9, 9))
    V9 = np.empty((9, 9))
    nrm = np.empty(9)
    cs = np.empty(4)
    sn = np.empty(4)
    act = np.empty(4, np.bool_)
    sv = np.empty(9)
    Ub = np.empty((9, 9))
    VTb = np.empty((9, 9))
    Vt = np.empty((9, 9))
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
    vall = np.empty((18, n))
    # scratch of the stages, allocated once (the allocating wrappers cost ~40 allocations per iteration)
    sQ = np.empty((3, 3, 3))
    sP4 = np.empty((3, 3, 3, 3))
    str3 = np.empty((3, 3))
    sB = np.empty((9, 10))
    sB4 = np.empty((9, 4))
    sB6 = np.empty((9, 6))
    sX = np.empty((4, 6))
    sHs = np.empty((7, 7))
    sLr = np.empty((6, 6))
    swr = np.empty(7)
    swi = np.empty(7)
    sLc = np.empty((6, 6), np.complex128)
    sAc = np.empty((6, 6), np.complex128)
    spiv = np.empty(6, np.int64)
    sb = np.empty(6, np.complex128)
    sK = np.empty((3, 3), np.complex128)
    scoef = np.empty((18, 3))
    sM3 = np.empty((3, 3))
    sr3 = np.empty(3)
    sdets = np.empty(4)
    sPr = np.empty((3, n))
    sGr = np.empty((3, n))
    rs = (np.empty(3), np.empty(3), np.empty((3, 3)), np.empty((3, 3)), np.empty((3, 3)), np.empty((3, 3)), np.empty((3, n)),
          np.empty((3, n)), np.empty(n), np.empty(6), np.empty(18), np.empty(18))
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
                    AF[j, i] = A[i, j] * wi
            _right_singular9(AF, AF2, n, tau, RF, sv, Ub, VTb, Vt, X9, V9, nrm, cs, sn, act)
            for r in range(3):
                for j in range(9):
                    q[0, r, j] = Vt[6 + r, j]
            _action_core(q, mono, C, ok, sQ, sP4, str3, sB, sB4, sB6, sX)
            if not ok[0]:
                status[hh] = 1
                break
            _eig6_core(C, lam, G, fail, 1e-6, sHs, sLr, swr, swi, sLc, sAc, spiv, sb, sK)
            if fail[0]:
                status[hh] = 1
                break
            _post_core(q, lam, G, cand, dmin, need, scoef, sM3, sr3, sdets)
            if need[0]:
                status[hh] = 1
                break
            for c in range(18):
                for i in range(3):
                    for j in range(3):
                        E[0, c, i, j] = cand[0, c, 3 * j + i]
            if not multi:
                _rank_core(E, F1, F2, W, True, True, Rc, tc, valid, M1, cost, best, True, *rs)
                bk = best[0]
                okb = True
            else:
                # lirp_all_solver + the weighted objective (gnc_irls_batch's multi-candidate branch):
                # costs sum w v of the kept candidates (NaN poses elsewhere: cost inf), first argmin
                _rank_core(E, F1, F2, W, True, False, Rc, tc, valid, M1, cost, best, False, *rs)
                anyv = False
                for c in range(18):
                    if valid[0, c]:
                        anyv = True
                _residual_core(Rc[0], tc[0], F1, F2, rkind, vall, sPr, sGr)  # all 18 poses, points shared
                bk = 0
                bc = np.inf
                for c in range(18):
                    if not (valid[0, c] or not anyv):
                        continue
                    for i in range(n):
                        prod[i] = W[0, i] * vall[c, i]
                    cc = _np_sum(prod, n)
                    if cc < bc:  # (NaN / inf costs never win; all inf: candidate 0, as np.argmin)
                        bc = cc
                        bk = c
                okb = valid[0, bk] or not anyv
            for i in range(3):
                tk[0, i] = tc[0, bk, i] if okb else np.nan
                for j in range(3):
                    Rk[0, i, j] = Rc[0, bk, i, j] if okb else np.nan
            # ---- residuals, bound, weights (gnc_irls_batch, step by step)
            _residual_core(Rk, tk, F1, F2, rkind, vout, sPr, sGr)
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
