"""numpy reference of the homography twin (the core's ``src/core/analysis.cpp``; tests compare).

Points on a plane ``n^T X1 = d`` satisfy ``X2 = (R + t n^T / d) X1 = H X1``. A homography has (up
to sign) two decompositions ``(R, t, n)`` with all points in front of both cameras; both explain the
plane's correspondences exactly, so no two-view residual can tell them apart. Given a pose and its
inliers, :func:`homography_twin` fits the dominant plane to the triangulated inliers, forms ``H``
and returns the other decomposition. Decomposition: Ma, Soatto, Kosecka, Sastry, *An Invitation to
3-D Vision*, Sec. 5.3.3 (the SVD method of Faugeras & Lustman 1988).
"""

from __future__ import annotations

import numpy as np

from poseonly.geometry import cross, normalize, project_to_so3, rotation_error_deg, triangulate_midpoint

__all__ = ["decompose_homography", "homography_twin", "homography_twin_dlt", "fit_plane"]


def decompose_homography(H: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The four ``(R, t/d, n)`` of a calibrated homography ``H ~ R + t n^T / d``.

    Returns ``R (4, 3, 3)``, ``T (4, 3)`` (``t / d``) and unit normals ``N (4, 3)``; the sign of
    ``H`` is fixed so that the middle singular value is ``+1``.
    """
    H = np.asarray(H, float)
    s = np.linalg.svd(H, compute_uv=False)
    H = H / s[1]
    _, S2, Vt = np.linalg.svd(H.T @ H)
    V = Vt.T
    if np.linalg.det(V) < 0:
        V = -V
    s1, s3 = S2[0], S2[2]
    v1, v2, v3 = V[:, 0], V[:, 1], V[:, 2]
    den = np.sqrt(max(s1 - s3, 1e-300))
    a = np.sqrt(max(1.0 - s3, 0.0))
    b = np.sqrt(max(s1 - 1.0, 0.0))
    # both decompositions at once (stacked over the two choices of u)
    u = np.stack([(a * v1 + b * v3) / den, (a * v1 - b * v3) / den])  # (2, 3)
    v2s = np.broadcast_to(v2, u.shape)
    N = cross(v2s, u)
    Hv2 = np.broadcast_to(H @ v2, u.shape)
    Hu = u @ H.T
    U = np.stack([v2s, u, N], axis=-1)  # columns v2, u, v2 x u
    W = np.stack([Hv2, Hu, cross(Hv2, Hu)], axis=-1)
    R = project_to_so3(W @ np.swapaxes(U, -1, -2))  # exact for an exact homography; noise leaves it slightly off SO(3)
    T = np.einsum("kij,kj->ki", H - R, N)
    return np.repeat(R, 2, axis=0), np.stack([T[0], -T[0], T[1], -T[1]]), np.stack([N[0], -N[0], N[1], -N[1]])


def fit_plane(X: np.ndarray) -> tuple[np.ndarray, float, float]:
    """Least-squares plane ``n^T X = d`` through points ``X (m, 3)``; returns ``n, d, rms / spread``."""
    c = X.mean(axis=0)
    _, s, Vt = np.linalg.svd(X - c, full_matrices=False)
    n = Vt[2]
    d = float(n @ c)
    if d < 0:
        n, d = -n, -d
    return n, d, float(s[2] / max(s[1], 1e-300))


def homography_twin(R: np.ndarray, t: np.ndarray, f1: np.ndarray, f2: np.ndarray) -> tuple[np.ndarray, np.ndarray, float] | None:
    """The other physically valid decomposition of the homography induced by the dominant plane.

    ``f1, f2`` are the inlier bearings of ``(R, t)``. Returns ``(R_twin, t_twin (unit), planarity)``
    where planarity is the ratio of the smallest to the middle singular value of the centred points
    (0 for an exact plane), or ``None`` when fewer than 4 points triangulate in front of the cameras
    or the plane fit / decomposition is numerically degenerate.
    """
    t = normalize(np.asarray(t, float))
    X1, z1, z2 = triangulate_midpoint(R, t, f1, f2)
    ok = (z1 > 0) & (z2 > 0)
    if ok.sum() < 4:
        return None
    if not np.all(np.isfinite(X1[ok])):
        return None
    try:
        n, d, planarity = fit_plane(X1[ok])
        if not (d > 0 and np.isfinite(d)):
            return None
        H = R + np.outer(t, n) / d
        if not np.all(np.isfinite(H)):
            return None
        Rs, Ts, Ns = decompose_homography(H)
    except np.linalg.LinAlgError:  # numerically degenerate inliers (e.g. bearings near 90 deg off-axis)
        return None
    tw = _twin_of(R, t, Rs, Ts, Ns, f1)
    return None if tw is None else (*tw, planarity)


def _twin_of(R, t, Rs, Ts, Ns, f1) -> tuple[np.ndarray, np.ndarray] | None:
    """Of a homography's decompositions, the valid one next closest to ``(R, unit t)``."""
    # physically valid: the inliers lie in front of camera 1 on the plane side (n . f1 > 0)
    front = np.mean(f1 @ Ns.T > 0, axis=0)
    cand = np.nonzero((front > 0.5) & (np.linalg.norm(Ts, axis=1) > 1e-12))[0]
    if len(cand) < 2:
        return None
    Tn = normalize(Ts[cand])
    errs = rotation_error_deg(R, Rs[cand]) + np.degrees(np.arccos(np.clip(Tn @ t, -1, 1)))
    # the decomposition closest to (R, t) is the pose itself; the other valid one is the twin
    k = int(np.argsort(errs, kind="stable")[1])
    return Rs[cand[k]], Tn[k]


def homography_twin_dlt(R: np.ndarray, t: np.ndarray, f1: np.ndarray, f2: np.ndarray, max_transfer: float = np.inf) -> tuple[np.ndarray, np.ndarray] | None:
    """The same from the homography fitted to the matches directly: the unit ``H`` minimising
    ``sum |f2 x H f1|^2`` (the right singular vector of the stacked cross-product rows), signed so that
    ``H f1`` points along ``f2`` for most matches, if it carries 90 % of them to within ``max_transfer``."""
    t = normalize(np.asarray(t, float))
    if len(f1) < 4:
        return None
    # (f2 x H f1)_k = sum_r [f2]x[k, r] (H f1)_r: the row for h = vec(H) (row-major) is [f2]x[k, r] f1^T
    B = np.zeros((len(f1), 3, 3))
    B[:, 0, 1], B[:, 0, 2], B[:, 1, 0], B[:, 1, 2], B[:, 2, 0], B[:, 2, 1] = -f2[:, 2], f2[:, 1], f2[:, 2], -f2[:, 0], -f2[:, 1], f2[:, 0]
    A = np.einsum("ikr,ij->ikrj", B, f1).reshape(-1, 9)
    _, s, Vt = np.linalg.svd(A)
    if not s[-2] > 1e-6 * s[0]:  # H undetermined (collinear matches): the core's kHomographyRankRtol
        return None
    H = Vt[-1].reshape(3, 3)
    if 2 * np.count_nonzero(np.einsum("ij,ij->i", f1 @ H.T, f2) > 0) < len(f1):
        H = -H
    h = f1 @ H.T
    near = np.arctan2(np.linalg.norm(np.cross(h, f2), axis=1), np.einsum("ij,ij->i", h, f2)) < max_transfer
    if not np.count_nonzero(near) >= 0.9 * len(f1):
        return None
    try:
        Rs, Ts, Ns = decompose_homography(H)
    except np.linalg.LinAlgError:
        return None
    return _twin_of(R, t, Rs, Ts, Ns, f1)
