"""Synthetic view graphs of any size (tests, the scale benchmark).

Layout: ``N`` cameras on a ring (radius ``max(N * spacing / 2 pi, 5)``), each looking towards the
ring's centre with a random tilt; every point is placed in front of a random "home" camera
(depth 3-8, within 30 deg of its axis) and observed by the home camera and up to ``max_track - 1``
of its ring neighbours (within ``window`` positions) that see it in front within a 50 deg half
field of view. Edges: every camera pair at most ``window`` ring positions apart that shares at
least one point, weighted by the number of shared points (the stand-in of the two-view inliers).
Noise: Gaussian pixel noise of the bearings, Gaussian relative-rotation noise; outlier edges get a
uniformly random rotation and translation direction. Memory and time are linear in the number of
observations (vectorised, no per-track Python loop).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.spatial.transform import Rotation

from ..geometry import InputError
from .so3 import exp_so3
from .tracks import Tracks
from .viewgraph import Edge, ViewGraph

__all__ = ["SyntheticScene", "make_scene", "scene_view_graph"]

HALF_FOV_DEG = 50.0
HOME_CONE_DEG = 30.0
DEPTH_RANGE = (3.0, 8.0)
TILT_DEG = 10.0


@dataclass(frozen=True)
class SyntheticScene:
    """Ground truth ``rotations (N, 3, 3)`` (world -> camera) and ``centres (N, 3)``,
    ``points (T, 3)`` of the ``tracks`` (CSR, :class:`Tracks`), ``bearings (M, 3)`` unit
    (camera frame, noisy) per observation, ``pairs (E, 2)``, relative ``R_rel (E, 3, 3)`` and unit
    ``t_rel (E, 3)`` (poseonly convention, noisy / outliers), ``weights (E,)``,
    ``outlier (E,)`` mask, ``focal`` (px)."""

    rotations: np.ndarray
    centres: np.ndarray
    points: np.ndarray
    tracks: Tracks
    bearings: np.ndarray
    pairs: np.ndarray
    R_rel: np.ndarray
    t_rel: np.ndarray
    weights: np.ndarray
    outlier: np.ndarray
    focal: float


def _look_at(c: np.ndarray, target: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """World -> camera rotations ``(N, 3, 3)`` with the optical axis towards ``target``, tilted."""
    z = target - c
    z /= np.linalg.norm(z, axis=1, keepdims=True)
    up = np.array([0.0, 0.0, 1.0])
    x = np.cross(up, z)
    x /= np.linalg.norm(x, axis=1, keepdims=True)
    y = np.cross(z, x)
    R = np.stack([x, y, z], axis=1)  # rows = camera axes in world
    tilt = exp_so3(rng.normal(scale=np.radians(TILT_DEG) / np.sqrt(3), size=(len(c), 3)))
    return tilt @ R


def make_scene(
    num_views: int,
    num_points: int,
    *,
    window: int = 5,
    max_track: int = 6,
    noise_px: float = 0.0,
    rotation_noise_deg: float = 0.0,
    outlier_fraction: float = 0.0,
    focal: float = 1000.0,
    spacing: float = 1.0,
    seed: int = 0,
) -> SyntheticScene:
    """A synthetic scene (see the module docstring); ``num_points`` is the number of points drawn,
    the tracks kept are those seen by at least two cameras."""
    n = int(num_views)
    if n < 3:
        raise InputError(f"num_views must be >= 3, got {num_views}")
    if int(num_points) < 1 or int(window) < 1 or int(max_track) < 2:
        raise InputError("num_points >= 1, window >= 1 and max_track >= 2 are required")
    if not 0.0 <= outlier_fraction < 1.0:
        raise InputError(f"outlier_fraction must be in [0, 1), got {outlier_fraction}")
    w = min(int(window), (n - 1) // 2)
    rng = np.random.default_rng(seed)
    radius = max(n * spacing / (2 * np.pi), 5.0)
    ang = 2 * np.pi * np.arange(n) / n
    C = np.stack([radius * np.cos(ang), radius * np.sin(ang), rng.normal(scale=0.1, size=n)], axis=1)
    Rw = _look_at(C, np.zeros((n, 3)), rng)

    # points in front of a home camera
    p = int(num_points)
    home = rng.integers(0, n, size=p)
    cone = np.radians(HOME_CONE_DEG)
    theta = np.arccos(1 - rng.random(p) * (1 - np.cos(cone)))
    phi = rng.random(p) * 2 * np.pi
    dcam = np.stack([np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), np.cos(theta)], axis=1)
    depth = rng.uniform(*DEPTH_RANGE, size=p)
    X = C[home] + np.einsum("pji,pj->pi", Rw[home], dcam * depth[:, None])

    # observers: the home camera and random ring neighbours
    offs = np.concatenate([np.arange(1, w + 1), -np.arange(1, w + 1)])
    k = min(int(max_track) - 1, len(offs))
    pick = np.argsort(rng.random((p, len(offs))), axis=1)[:, :k]
    cams = np.concatenate([home[:, None], (home[:, None] + offs[pick]) % n], axis=1)  # (p, k+1)
    lengths = rng.integers(2, k + 2, size=p)
    use = np.arange(k + 1)[None, :] < lengths[:, None]
    Xc = np.einsum("pkij,pkj->pki", Rw[cams], X[:, None, :] - C[cams])
    cosang = Xc[..., 2] / np.linalg.norm(Xc, axis=2)
    use &= cosang > np.cos(np.radians(HALF_FOV_DEG))
    keep = use.sum(axis=1) >= 2
    cams, use, Xc, X = cams[keep], use[keep], Xc[keep], X[keep]
    # sort observations by view within a track
    key = np.where(use, cams, n + 1)
    o = np.argsort(key, axis=1, kind="stable")
    cams = np.take_along_axis(cams, o, axis=1)
    use = np.take_along_axis(use, o, axis=1)
    Xc = np.take_along_axis(Xc, o[..., None], axis=1)
    lens = use.sum(axis=1)
    ptr = np.concatenate([[0], np.cumsum(lens)]).astype(np.int64)
    views = cams[use].astype(np.int64)
    xc = Xc[use]
    uv = xc[:, :2] / xc[:, 2:3] + rng.normal(scale=noise_px / focal, size=(len(xc), 2))
    f = np.concatenate([uv, np.ones((len(uv), 1))], axis=1)
    f /= np.linalg.norm(f, axis=1, keepdims=True)
    kps = np.arange(len(views), dtype=np.int64)  # one keypoint per observation
    tracks = Tracks(ptr, views, kps)

    # edges: co-visible ring neighbours, weight = shared points
    tr = np.repeat(np.arange(len(lens)), lens)
    V = sp.csr_matrix((np.ones(len(views)), (tr, views)), shape=(len(lens), n))
    co = (V.T @ V).tocoo()
    sel = co.row < co.col
    pi, pj, cnt = co.row[sel].astype(np.int64), co.col[sel].astype(np.int64), co.data[sel]
    order = np.lexsort((pj, pi))
    pairs = np.stack([pi[order], pj[order]], axis=1)
    cnt = cnt[order].astype(np.float64)
    Ri, Rj = Rw[pairs[:, 0]], Rw[pairs[:, 1]]
    R_rel = Rj @ np.transpose(Ri, (0, 2, 1))
    t_rel = np.einsum("eij,ej->ei", Rj, C[pairs[:, 0]] - C[pairs[:, 1]])
    t_rel /= np.linalg.norm(t_rel, axis=1, keepdims=True)
    if rotation_noise_deg > 0:
        R_rel = exp_so3(rng.normal(scale=np.radians(rotation_noise_deg) / np.sqrt(3), size=(len(pairs), 3))) @ R_rel
    n_out = round(outlier_fraction * len(pairs))
    outlier = np.zeros(len(pairs), dtype=bool)
    if n_out:
        idx = rng.choice(len(pairs), size=n_out, replace=False)
        outlier[idx] = True
        R_rel[idx] = Rotation.random(n_out, random_state=rng.integers(2**31)).as_matrix()
        t = rng.normal(size=(n_out, 3))
        t_rel[idx] = t / np.linalg.norm(t, axis=1, keepdims=True)
    return SyntheticScene(Rw, C, X, tracks, f, pairs, R_rel, t_rel, cnt, outlier, float(focal))


def scene_view_graph(scene: SyntheticScene) -> ViewGraph:
    """The view graph of ``scene``: one edge per co-visible pair ``(i, j)`` of ``scene.pairs``, with
    its relative pose (``R_rel``, ``t_rel``, outliers included), the keypoint pairs of the tracks
    that see both views as its matches (in track order) and their number as its weight. Vectorised:
    linear in the observations (the scale benchmark's 10000-view graphs)."""
    tr = scene.tracks
    n = len(scene.rotations)
    lengths = tr.lengths
    cols: list[tuple[np.ndarray, ...]] = []
    for a in range(int(lengths.max()) if len(lengths) else 0):
        for b in range(a + 1, int(lengths.max())):
            t = np.flatnonzero(lengths > b)
            oa, ob = tr.ptr[t] + a, tr.ptr[t] + b
            cols.append((t, np.full(len(t), a), np.full(len(t), b), tr.views[oa], tr.views[ob], tr.keypoints[oa], tr.keypoints[ob]))
    g = ViewGraph(n)
    if not cols:
        return g
    tt, pa, pb, va, vb, ka, kb = (np.concatenate(c) for c in zip(*cols, strict=True))
    order = np.lexsort((pb, pa, tt))  # track order, then position pairs
    key = (va * n + vb)[order]
    order = order[np.argsort(key, kind="stable")]
    key = (va * n + vb)[order]
    m = np.stack([ka[order], kb[order]], axis=1).astype(np.int64)
    starts = np.flatnonzero(np.r_[True, key[1:] != key[:-1]])
    ends = np.r_[starts[1:], len(key)]
    pkey = scene.pairs[:, 0].astype(np.int64) * n + scene.pairs[:, 1]
    sorter = np.argsort(pkey)
    for s0, s1 in zip(starts.tolist(), ends.tolist(), strict=True):
        i, j = divmod(int(key[s0]), n)
        k = int(sorter[np.searchsorted(pkey, key[s0], sorter=sorter)])
        if pkey[k] != key[s0]:
            raise InputError(f"scene pair ({i}, {j}) has no relative pose")
        g.add_edge(Edge(i, j, scene.R_rel[k], scene.t_rel[k], m[s0:s1], "ok", float(s1 - s0)))
    return g
