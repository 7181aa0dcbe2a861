"""Synthetic two-view scenes for tests, benchmarks and the paper's experiments.

Two camera models:

* ``camera="wide"`` (default): OpenGV-style (notes section 9). Camera 2 at a position drawn
  uniformly in the box ``[-2, 2]^3`` and rotated by yaw/pitch/roll each uniform in ``+-0.5`` rad;
  points from OpenGV's ``generateRandomPoint(8, 4)`` (all around, 4 to ~10.9 units). Only points in
  front of both cameras (positive ``z`` in both frames, the paper's chirality filter, Fig. 1) are
  kept; draws repeat until ``n`` are found.
* ``camera="pinhole"``: a 640x480 image with ``f = 800``; camera 2 looks at the scene centre from a
  baseline of 0.5-2 units; points must project into both images (the narrow field of view makes the
  planar homography twin far more frequent).

Scene types: ``"normal"`` (3-D points), ``"planar"`` (all points on one plane seen from the same
side by both cameras), ``"rotation"`` (pure rotation, ``t = 0``). Noise is Gaussian with ``noise_px``
pixels per image axis at focal 800 (``noise_model="opengv"`` reproduces OpenGV's uniform noise).
Outliers: ``floor(outlier_fraction * n)`` randomly chosen correspondences get the view-2 bearing of
a fresh random point (OpenGV's model). Everything is seeded by ``seed`` or a ``numpy`` Generator.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .geometry import normalize, rotation_from_rotvec, skew

__all__ = ["Scene", "make_scene", "motion", "opengv_points", "add_noise", "FOCAL", "WIDTH", "HEIGHT", "default_K"]

FOCAL = 800.0
WIDTH, HEIGHT = 640, 480


def default_K() -> np.ndarray:
    """The 640x480, f = 800 pinhole calibration used by all synthetic scenes."""
    return np.array([[FOCAL, 0.0, WIDTH / 2], [0.0, FOCAL, HEIGHT / 2], [0.0, 0.0, 1.0]])


@dataclass
class Scene:
    """A synthetic correspondence set. ``X2 = R X1 + t``; ``t`` has unit norm (``baseline`` = true length)."""

    f1: np.ndarray  # (n, 3) unit bearings, view 1 (noisy)
    f2: np.ndarray  # (n, 3) unit bearings, view 2 (noisy, outliers replaced)
    u1: np.ndarray  # (n, 2) pixels under K (meaningful for points with z > 0)
    u2: np.ndarray
    K: np.ndarray
    R: np.ndarray
    t: np.ndarray  # unit (zero for pure rotation)
    baseline: float
    inliers: np.ndarray  # (n,) bool
    X: np.ndarray  # (n, 3) true points in camera 1's frame (inlier geometry)
    kind: str
    camera: str
    noise_px: float
    plane: np.ndarray | None = None  # (n, d): n^T X = d in camera 1 for planar scenes

    @property
    def n(self) -> int:
        return len(self.f1)

    @property
    def E(self) -> np.ndarray:
        return skew(self.t) @ self.R


def _rng(seed: int | np.random.Generator | None) -> np.random.Generator:
    return seed if isinstance(seed, np.random.Generator) else np.random.default_rng(seed)


def _opengv_rotation(rng: np.random.Generator, max_angle: float = 0.5) -> np.ndarray:
    """OpenGV ``generateRandomRotation``: R3(yaw) R2(pitch) R1(roll), angles U(-max, max) rad."""
    a = rng.uniform(-max_angle, max_angle, 3)
    return rotation_from_rotvec(np.array([0, 0, a[0]])) @ rotation_from_rotvec(np.array([0, a[1], 0])) @ rotation_from_rotvec(np.array([a[2], 0, 0]))


def opengv_points(rng: np.random.Generator, m: int, max_depth: float = 8.0, min_depth: float = 4.0) -> np.ndarray:
    """``m`` random 3-D points, ``(m, 3)``, at least ``min_depth`` from the origin (OpenGV
    ``generateRandomPoint``: a uniform cube of half-width ``max_depth - min_depth`` pushed out by ``min_depth``)."""
    c = rng.uniform(-1.0, 1.0, (m, 3))
    return (max_depth - min_depth) * c + min_depth * normalize(c)


def add_noise(f: np.ndarray, noise_px: float, rng: np.random.Generator, model: str) -> np.ndarray:
    """Perturb unit bearings ``f (n, 3)`` on their tangent plane by ``noise_px`` pixels at focal 800;
    returns unit bearings ``(n, 3)`` (``f`` itself when ``noise_px <= 0``). ``model``: ``"gaussian"``
    or ``"opengv"`` (uniform, as OpenGV ``addNoise``)."""
    if noise_px <= 0:
        return f
    # tangent basis: n1 orthogonal to f built from the largest |component| (OpenGV addNoise)
    idx = np.argmax(np.abs(f), axis=1)
    other = (idx + 1) % 3
    n1 = np.zeros_like(f)
    rows = np.arange(len(f))
    n1[rows, other] = f[rows, idx]
    n1[rows, idx] = -f[rows, other]
    n1 = normalize(n1)
    n2 = np.cross(f, n1)
    if model == "opengv":
        nx, ny = noise_px * rng.uniform(-1, 1, (2, len(f))) / np.sqrt(2.0)
    elif model == "gaussian":
        nx, ny = noise_px * rng.standard_normal((2, len(f)))
    else:
        raise ValueError(f"unknown noise_model {model!r}; use 'gaussian' or 'opengv'")
    return normalize(FOCAL * f + nx[:, None] * n1 + ny[:, None] * n2)


def _project(K: np.ndarray, P: np.ndarray) -> np.ndarray:
    p = P @ K.T
    with np.errstate(divide="ignore", invalid="ignore"):
        return p[:, :2] / p[:, 2:3]


def _in_image(u: np.ndarray) -> np.ndarray:
    return (u[:, 0] >= 0) & (u[:, 0] < WIDTH) & (u[:, 1] >= 0) & (u[:, 1] < HEIGHT)


def _look_at(C: np.ndarray, target: np.ndarray, rng: np.random.Generator, jitter: float) -> np.ndarray:
    """World(=camera 1)->camera rotation of a camera at ``C`` looking at ``target`` with random roll."""
    z = normalize(target - C)
    up = normalize(rng.standard_normal(3) * 0.2 + np.array([0.0, -1.0, 0.0]))
    x = normalize(np.cross(up, z))
    y = np.cross(z, x)
    Rwc = np.stack([x, y, z], axis=1)  # columns = camera axes in world
    Rj = rotation_from_rotvec(rng.normal(0.0, jitter, 3))
    return (Rwc @ Rj).T


def motion(rng: np.random.Generator, kind: str, camera: str) -> tuple[np.ndarray, np.ndarray]:
    """Camera-2 pose ``(R (3, 3), C (3,))``: rotation world->camera 2 and centre in camera-1 coordinates."""
    if camera == "wide":
        R2 = _opengv_rotation(rng)  # body 2 -> world (OpenGV)
        C = np.zeros(3) if kind == "rotation" else rng.uniform(-2.0, 2.0, 3)
        return R2.T, C
    if kind == "rotation":
        return rotation_from_rotvec(normalize(rng.standard_normal(3)) * np.radians(rng.uniform(3, 15))), np.zeros(3)
    d = normalize(rng.standard_normal(3) * np.array([1.0, 1.0, 0.3]))
    C = d * rng.uniform(0.5, 2.0)
    return _look_at(C, np.array([0.0, 0.0, 8.0]), rng, jitter=np.radians(3.0)), C


def _sample_points(rng, kind, camera, R, C, m, plane):
    """Candidate 3-D points in camera 1's frame (before visibility filtering)."""
    if kind == "planar":
        nrm, d = plane
        if camera == "wide":
            dirs = normalize(rng.standard_normal((m, 3)))
            dirs[:, 2] = np.abs(dirs[:, 2])
        else:
            u = np.column_stack([rng.uniform(0, WIDTH, m), rng.uniform(0, HEIGHT, m)])
            dirs = normalize(np.column_stack([(u - [WIDTH / 2, HEIGHT / 2]) / FOCAL, np.ones(m)]))
        den = dirs @ nrm
        with np.errstate(divide="ignore", invalid="ignore"):
            z = d / den
        P = dirs * z[:, None]
        ok = np.isfinite(z) & (z > 0) & (np.linalg.norm(P, axis=1) < 25.0)
        return P[ok]
    if camera == "wide":
        return opengv_points(rng, m)
    u = np.column_stack([rng.uniform(0, WIDTH, m), rng.uniform(0, HEIGHT, m)])
    depth = rng.uniform(4.0, 12.0, m)
    return np.column_stack([(u - [WIDTH / 2, HEIGHT / 2]) / FOCAL, np.ones(m)]) * depth[:, None]


def _visible(P1, P2, camera, K):
    ok = (P1[:, 2] > 0) & (P2[:, 2] > 0)
    if camera == "pinhole":
        ok &= _in_image(_project(K, P1)) & _in_image(_project(K, P2))
    return ok


def make_scene(
    n: int = 100,
    kind: str = "normal",
    camera: str = "wide",
    noise_px: float = 0.0,
    outlier_fraction: float = 0.0,
    seed: int | np.random.Generator | None = 0,
    noise_model: str = "gaussian",
) -> Scene:
    """Generate a seeded two-view scene (see the module docstring for the geometry)."""
    if kind not in ("normal", "planar", "rotation"):
        raise ValueError(f"unknown scene kind {kind!r}; use 'normal', 'planar' or 'rotation'")
    if camera not in ("wide", "pinhole"):
        raise ValueError(f"unknown camera {camera!r}; use 'wide' or 'pinhole'")
    if not isinstance(n, (int, np.integer)) or n < 1:
        raise ValueError(f"n must be a positive integer, got {n!r}")
    if not 0.0 <= outlier_fraction <= 1.0:
        raise ValueError(f"outlier_fraction must be in [0, 1], got {outlier_fraction}")
    if noise_px < 0:
        raise ValueError(f"noise_px must be >= 0, got {noise_px}")
    rng = _rng(seed)
    K = default_K()
    for _attempt in range(200):
        R, C = motion(rng, kind, camera)
        plane = None
        if kind == "planar":
            # plane nrm^T X = dd in camera 1, crossing the optical axis at depth z0, tilted up to ~60 deg
            nrm = normalize(np.array([*rng.normal(0, 0.6, 2), 1.0]))
            z0 = rng.uniform(4.0, 8.0) if camera == "wide" else rng.uniform(5.0, 10.0)
            dd = z0 * nrm[2]
            plane = (nrm, dd)
            # both camera centres on the same side of the plane (camera 1 at origin: n.0 - d < 0)
            if nrm @ C - dd >= -0.5:
                continue
        pts = []
        count = 0
        for _ in range(200):
            P1 = _sample_points(rng, kind, camera, R, C, max(4 * n, 64), plane)
            P2 = (P1 - C) @ R.T
            P1 = P1[_visible(P1, P2, camera, K)]
            pts.append(P1)
            count += len(P1)
            if count >= n:
                break
        if count >= n:
            break
    else:  # pragma: no cover - the geometry always admits points
        raise RuntimeError("could not generate a scene with enough visible points")
    X = np.concatenate(pts)[:n]
    t = -R @ C
    baseline = float(np.linalg.norm(t))
    t_unit = t / baseline if baseline > 0 else np.zeros(3)
    X2 = X @ R.T + t
    f1 = add_noise(normalize(X), noise_px, rng, noise_model)
    f2 = add_noise(normalize(X2), noise_px, rng, noise_model)
    inliers = np.ones(n, bool)
    k = int(np.floor(outlier_fraction * n))
    if k > 0:
        idx = rng.choice(n, size=k, replace=False)
        inliers[idx] = False
        if camera == "wide":
            Q: list[np.ndarray] = []
            while sum(len(q) for q in Q) < k:
                Pq = opengv_points(rng, 4 * k)
                Q.append(Pq[Pq[:, 2] > 0])  # a random point seen by camera 2, in camera 2's frame
            f2[idx] = normalize(np.concatenate(Q)[:k])
        else:
            u = np.column_stack([rng.uniform(0, WIDTH, k), rng.uniform(0, HEIGHT, k)])
            f2[idx] = normalize(np.column_stack([(u - [WIDTH / 2, HEIGHT / 2]) / FOCAL, np.ones(k)]))
    u1 = _project(K, f1)
    u2 = _project(K, f2)
    return Scene(
        f1=f1,
        f2=f2,
        u1=u1,
        u2=u2,
        K=K,
        R=R,
        t=t_unit,
        baseline=baseline,
        inliers=inliers,
        X=X,
        kind=kind,
        camera=camera,
        noise_px=float(noise_px),
        plane=None if plane is None else np.append(plane[0], plane[1]),
    )
