"""numpy reference of the undistortion (``poseonly.cameras.Camera.unproject``) as it was before the
core's ``undistort_brown`` / ``undistort_fisheye``: Newton's method vectorised over the points, with
the fold checks (radial factor and Jacobian determinant) evaluated at the root, as the core does. The
core must give the same roots and verdicts (tests/test_cameras.py)."""

from __future__ import annotations

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
    return theta, ok
