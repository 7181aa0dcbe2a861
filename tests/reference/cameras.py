"""numpy reference of the undistortion (``poseonly.cameras.Camera.unproject``) as it was before the
core's ``undistort_brown`` / ``undistort_fisheye``: Newton's method vectorised over the points, with
the fold checks (radial factor and Jacobian determinant) evaluated at the root, as the core does. The
core must give the same roots and verdicts (tests/test_cameras.py). Where Newton's method from the
distorted point fails, the fallback of the core (a bracketed radial root as the start, damped Newton;
a bracketed root for the fisheye), in scalar Python."""

from __future__ import annotations

import math

import numpy as np

from poseonly.cameras import NEWTON_MAX_ITER, NEWTON_TOL


def distort_brown(u, v, k):
    k1, k2, p1, p2, k3, k4, k5, k6 = k
    r2 = u * u + v * v
    num = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3))
    den = 1.0 + r2 * (k4 + r2 * (k5 + r2 * k6))
    rad = num / den
    uv = u * v
    return u * rad + 2.0 * p1 * uv + p2 * (r2 + 2.0 * u * u), v * rad + 2.0 * p2 * uv + p1 * (r2 + 2.0 * v * v)


def fold_terms(u, v, k):
    """The radial factor and the Jacobian's determinant of the distortion at ``(u, v)``."""
    k1, k2, p1, p2, k3, k4, k5, k6 = k
    r2 = u * u + v * v
    num = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3))
    den = 1.0 + r2 * (k4 + r2 * (k5 + r2 * k6))
    dnum = k1 + r2 * (2.0 * k2 + 3.0 * k3 * r2)
    dden = k4 + r2 * (2.0 * k5 + 3.0 * k6 * r2)
    rad = num / den
    drad = (dnum * den - num * dden) / (den * den)
    j11 = rad + 2.0 * u * u * drad + 2.0 * p1 * v + 6.0 * p2 * u
    j12 = 2.0 * u * v * drad + 2.0 * p1 * u + 2.0 * p2 * v
    j21 = 2.0 * u * v * drad + 2.0 * p2 * v + 2.0 * p1 * u
    j22 = rad + 2.0 * v * v * drad + 2.0 * p2 * u + 6.0 * p1 * v
    return rad, j11 * j22 - j12 * j21


def undistort_brown(xd, yd, k):
    """``(u, v, ok)`` of ``distort(u, v) = (xd, yd)``, ``k = (k1, k2, p1, p2, k3, k4, k5, k6)``."""
    k1, k2, p1, p2, k3, k4, k5, k6 = k
    u, v = xd.copy(), yd.copy()
    done = np.zeros(len(u), bool)
    for _ in range(NEWTON_MAX_ITER):
        r2 = u * u + v * v
        num = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3))
        den = 1.0 + r2 * (k4 + r2 * (k5 + r2 * k6))
        dnum = k1 + r2 * (2.0 * k2 + 3.0 * k3 * r2)
        dden = k4 + r2 * (2.0 * k5 + 3.0 * k6 * r2)
        rad = num / den
        drad = (dnum * den - num * dden) / (den * den)
        uv = u * v
        fu = u * rad + 2.0 * p1 * uv + p2 * (r2 + 2.0 * u * u) - xd
        fv = v * rad + 2.0 * p2 * uv + p1 * (r2 + 2.0 * v * v) - yd
        j11 = rad + 2.0 * u * u * drad + 2.0 * p1 * v + 6.0 * p2 * u
        j12 = 2.0 * u * v * drad + 2.0 * p1 * u + 2.0 * p2 * v
        j21 = 2.0 * u * v * drad + 2.0 * p2 * v + 2.0 * p1 * u
        j22 = rad + 2.0 * v * v * drad + 2.0 * p2 * u + 6.0 * p1 * v
        det = j11 * j22 - j12 * j21
        with np.errstate(divide="ignore", invalid="ignore"):
            du = (j22 * fu - j12 * fv) / det
            dv = (j11 * fv - j21 * fu) / det
        du = np.where(done, 0.0, du)
        dv = np.where(done, 0.0, dv)
        u, v = u - du, v - dv
        step = np.hypot(du, dv)
        done |= step <= NEWTON_TOL * np.maximum(1.0, np.hypot(u, v))
        if done.all():
            break
    ok = done & np.isfinite(u) & np.isfinite(v)
    rad, det = fold_terms(u, v, k)  # at the root (the loop's last values are at the last step's start)
    ok &= (rad > 0) & (det > 0)
    r_fold = brown_fold(k)
    ok &= (r_fold >= BROWN_FOLD_MAX_RADIUS) | (np.hypot(u, v) < r_fold)
    ru, rv = distort_brown(u, v, k)
    ok &= np.hypot(ru - xd, rv - yd) <= 1e-9 * np.maximum(1.0, np.hypot(xd, yd))
    for i in np.flatnonzero(~ok):  # the fallback where Newton from the distorted point failed
        root = brown_fallback(float(xd[i]), float(yd[i]), k, r_fold)
        if root is None:
            continue
        a, b = np.array([root[0]]), np.array([root[1]])
        rad, det = fold_terms(a, b, k)
        ra, rb = distort_brown(a, b, k)
        good = (rad > 0) & (det > 0) & ((r_fold >= BROWN_FOLD_MAX_RADIUS) | (np.hypot(a, b) < r_fold))
        good &= np.hypot(ra - xd[i], rb - yd[i]) <= 1e-9 * max(1.0, np.hypot(xd[i], yd[i]))
        u[i], v[i], ok[i] = root[0], root[1], bool(good[0])
    return u, v, ok


FOLD_STEPS, FOLD_BISECTIONS, BROWN_FOLD_MAX_RADIUS = 1024, 60, 573.0


def first_fold(dh, hi: float) -> float:
    """The first x in (0, hi] where the increasing map with derivative ``dh`` stops increasing (a
    quadratically spaced grid, then bisection to the last increasing x); ``hi`` without a fold."""
    x = hi * (np.arange(1, FOLD_STEPS + 1) / FOLD_STEPS) ** 2
    with np.errstate(all="ignore"):
        bad = np.flatnonzero(~(dh(x) > 0))
    if not len(bad):
        return hi
    s = int(bad[0]) + 1
    a, b = hi * ((s - 1) / FOLD_STEPS) ** 2, float(x[s - 1])
    for _ in range(FOLD_BISECTIONS):
        m = 0.5 * (a + b)
        with np.errstate(all="ignore"):
            up = float(dh(np.array([m]))[0]) > 0
        a, b = (m, b) if up else (a, m)
    return a


def brown_fold(k) -> float:
    """The first fold of the radial map ``r -> r rad(r^2)`` (up to BROWN_FOLD_MAX_RADIUS)."""
    k1, k2, _, _, k3, k4, k5, k6 = k

    def dh(r):
        r2 = r * r
        num = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3))
        den = 1.0 + r2 * (k4 + r2 * (k5 + r2 * k6))
        dnum = k1 + r2 * (2.0 * k2 + 3.0 * k3 * r2)
        dden = k4 + r2 * (2.0 * k5 + 3.0 * k6 * r2)
        return np.where(den > 0, num / den + 2.0 * r2 * (dnum * den - num * dden) / (den * den), -1.0)  # the pole ends the branch

    return first_fold(dh, BROWN_FOLD_MAX_RADIUS)


def fisheye_poly(theta, k):
    k1, k2, k3, k4 = k
    t2 = theta * theta
    poly = 1.0 + t2 * (k1 + t2 * (k2 + t2 * (k3 + t2 * k4)))
    dpoly = 1.0 + t2 * (3.0 * k1 + t2 * (5.0 * k2 + t2 * (7.0 * k3 + t2 * 9.0 * k4)))
    return theta * poly, dpoly


def undistort_fisheye(rd, k):
    """``(theta, ok)`` of ``theta_d(theta) = rd``."""
    theta = rd.copy()
    done = np.zeros(len(rd), bool)
    for _ in range(NEWTON_MAX_ITER):
        g, dg = fisheye_poly(theta, k)
        with np.errstate(divide="ignore", invalid="ignore"):
            step = np.where(done, 0.0, (g - rd) / dg)
        theta = theta - step
        done |= np.abs(step) <= NEWTON_TOL * np.maximum(1.0, theta)
        if done.all():
            break
    g, dg = fisheye_poly(theta, k)
    th_max = first_fold(lambda th: fisheye_poly(th, k)[1], np.pi)
    ok = done & np.isfinite(theta) & (theta >= 0) & (theta < th_max) & (dg > 0) & (np.abs(g - rd) <= 1e-9 * np.maximum(1.0, rd))
    for i in np.flatnonzero(~ok & (rd >= 0) & np.isfinite(rd)):  # the fallback: the polynomial increases on [0, th_max]
        th = bracketed_root(lambda t: tuple(float(x) for x in fisheye_poly(t, k)), float(rd[i]), th_max)
        g1, dg1 = fisheye_poly(th, k)
        theta[i] = th
        ok[i] = math.isfinite(th) and 0 <= th < th_max and dg1 > 0 and abs(g1 - rd[i]) <= 1e-9 * max(1.0, float(rd[i]))
    return theta, ok


# --- the fallback where Newton's method from the distorted point fails (src/core/cameras.cpp) -------------
BRACKET_ITERATIONS, DAMPED_HALVINGS = 200, 40


ROOT_VALUE_TOL = 1e-9  # a tiny Newton step with the value farther than this from the target is a stall: bisect


def bracketed_root(g, target: float, hi: float, tol: float = NEWTON_TOL) -> float:
    """The root of an increasing ``g`` (value, derivative) on ``[0, hi]``: Newton inside a shrinking
    bracket, bisection where a step leaves it; NaN where ``g(hi) < target``."""
    val, _ = g(hi)
    if not val >= target:
        return float("nan")
    a, b, x = 0.0, hi, min(target, hi)
    for _ in range(BRACKET_ITERATIONS):
        val, d = g(x)
        if val == target:
            return x
        if val < target:
            a = x
        else:
            b = x
        nx = x - (val - target) / d
        stalled = abs(nx - x) <= tol * max(1.0, nx) and not abs(val - target) <= ROOT_VALUE_TOL * max(1.0, target)
        if not (a < nx < b) or stalled:
            nx = 0.5 * (a + b)
        if abs(nx - x) <= tol * max(1.0, nx) or b - a <= tol * max(1.0, b):
            return nx
        x = nx
    return x


def _brown_residual(u: float, v: float, x: float, y: float, k) -> tuple[float, float, tuple[float, float, float, float]]:
    k1, k2, p1, p2, k3, k4, k5, k6 = (float(c) for c in k)
    r2 = u * u + v * v
    num = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3))
    den = 1.0 + r2 * (k4 + r2 * (k5 + r2 * k6))
    dnum = k1 + r2 * (2.0 * k2 + 3.0 * k3 * r2)
    dden = k4 + r2 * (2.0 * k5 + 3.0 * k6 * r2)
    rad = num / den
    drad = (dnum * den - num * dden) / (den * den)
    uv = u * v
    fu = u * rad + 2.0 * p1 * uv + p2 * (r2 + 2.0 * u * u) - x
    fv = v * rad + 2.0 * p2 * uv + p1 * (r2 + 2.0 * v * v) - y
    J = (
        rad + 2.0 * u * u * drad + 2.0 * p1 * v + 6.0 * p2 * u,
        2.0 * u * v * drad + 2.0 * p1 * u + 2.0 * p2 * v,
        2.0 * u * v * drad + 2.0 * p2 * v + 2.0 * p1 * u,
        rad + 2.0 * v * v * drad + 2.0 * p2 * u + 6.0 * p1 * v,
    )
    return fu, fv, J


def brown_fallback(x: float, y: float, k, r_fold: float) -> tuple[float, float] | None:
    """The radial root (tangential terms left out) as the start, then Newton steps halved until the
    residual decreases; None where it does not apply."""
    k1, k2, _, _, k3, k4, k5, k6 = (float(c) for c in k)
    rd = np.hypot(x, y)
    if not (rd > 0.0 and math.isfinite(rd)):
        return None

    def h(r):
        r2 = r * r
        num = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3))
        den = 1.0 + r2 * (k4 + r2 * (k5 + r2 * k6))
        dnum = k1 + r2 * (2.0 * k2 + 3.0 * k3 * r2)
        dden = k4 + r2 * (2.0 * k5 + 3.0 * k6 * r2)
        return r * num / den, num / den + 2.0 * r2 * (dnum * den - num * dden) / (den * den)

    ru = bracketed_root(h, rd, min(r_fold, BROWN_FOLD_MAX_RADIUS))
    if not math.isfinite(ru) and r_fold < BROWN_FOLD_MAX_RADIUS:  # past the radial map's largest value: start at the fold
        ru = r_fold
    if not math.isfinite(ru):
        return None
    cu, cv = x * (ru / rd), y * (ru / rd)
    fu, fv, J = _brown_residual(cu, cv, x, y, k)
    norm = np.hypot(fu, fv)
    for _ in range(NEWTON_MAX_ITER):
        det = J[0] * J[3] - J[1] * J[2]
        du, dv = (J[3] * fu - J[1] * fv) / det, (J[0] * fv - J[2] * fu) / det
        if not (math.isfinite(du) and math.isfinite(dv)):
            return None
        s, better = 1.0, False
        for _ in range(DAMPED_HALVINGS + 1):
            nu, nv = cu - s * du, cv - s * dv
            nfu, nfv, nJ = _brown_residual(nu, nv, x, y, k)
            if np.hypot(nfu, nfv) < norm:
                better = True
                break
            s *= 0.5
        if not better:  # no halving decreases the residual: the point stays where it is
            break
        step = np.hypot(nu - cu, nv - cv)
        cu, cv = nu, nv
        fu, fv, J, norm = nfu, nfv, nJ, np.hypot(nfu, nfv)
        if step <= NEWTON_TOL * max(1.0, np.hypot(cu, cv)):
            break
    return (cu, cv) if math.isfinite(cu) and math.isfinite(cv) else None
