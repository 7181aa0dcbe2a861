"""Multi-view tracks from the inlier matches of the view graph (union-find over observations).

Observations are ``(view, keypoint)`` nodes; every inlier match of every edge joins two of them.
Components are found by ``scipy.sparse.csgraph.connected_components`` (linear in the matches).
A component with two different keypoints of one view is a *conflicting* track (a wrong match or a
repeated structure). ``conflicts="split"`` (default) rebuilds such a component with a union-find
that takes its matches in order of decreasing edge weight and refuses every union that would put
two keypoints of one view in the same track (so each resulting track is consistent and the matches
of the strongest pairs win); ``conflicts="drop"`` discards the component (openMVG's choice).
Tracks shorter than ``min_length`` views are dropped.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from ..geometry import InputError, as_real_array
from .inputs import checked_count, checked_indices
from .viewgraph import ViewGraph

__all__ = ["Tracks", "build_tracks", "tracks_from_arrays"]

CONFLICT_POLICIES = ("split", "drop")


@dataclass(frozen=True)
class Tracks:
    """Tracks in CSR layout: track ``t`` has observations ``ptr[t]:ptr[t+1]`` of ``views (M,)`` and
    ``keypoints (M,)`` (sorted by view within a track). ``num_conflicting`` components were
    split or dropped; ``num_short`` tracks were dropped for ``min_length``."""

    ptr: np.ndarray
    views: np.ndarray
    keypoints: np.ndarray
    num_conflicting: int = 0
    num_short: int = 0

    def __post_init__(self) -> None:
        """The CSR layout checked: integer arrays, ``ptr`` from 0 non-decreasing to ``M``, ``views`` and
        ``keypoints`` of length ``M`` and non-negative (:class:`InputError` otherwise)."""
        arrays = {}
        for name in ("ptr", "views", "keypoints"):
            a = getattr(self, name)
            if isinstance(a, (list, tuple)):  # a list of ints is taken as the array it spells
                a = np.asarray(a, dtype=np.int64) if all(isinstance(x, (int, np.integer)) and not isinstance(x, bool) for x in a) else a
                object.__setattr__(self, name, a)
            if not isinstance(a, np.ndarray) or a.ndim != 1 or a.dtype.kind not in "iu":
                raise InputError(f"Tracks.{name} must be a 1-D integer array, got {type(a).__name__}{getattr(a, 'shape', '')} {getattr(a, 'dtype', '')}")
            arrays[name] = a
        ptr, views, kps = arrays["ptr"], arrays["views"], arrays["keypoints"]
        if len(ptr) == 0 or ptr[0] != 0 or np.any(np.diff(ptr) < 0) or ptr[-1] != len(views) or len(kps) != len(views):
            raise InputError("Tracks: ptr must run from 0, non-decreasing, to len(views) == len(keypoints)")
        if len(views) and (views.min() < 0 or kps.min() < 0):
            raise InputError("Tracks: views and keypoints must be >= 0")

    def __len__(self) -> int:
        return len(self.ptr) - 1

    @property
    def num_observations(self) -> int:
        return int(self.ptr[-1])

    @property
    def lengths(self) -> np.ndarray:
        """``(T,)`` number of views per track."""
        return np.diff(self.ptr)

    @property
    def track_of_observation(self) -> np.ndarray:
        """``(M,)`` track index of every observation."""
        return np.repeat(np.arange(len(self), dtype=np.int64), self.lengths)

    def track(self, t: int) -> tuple[np.ndarray, np.ndarray]:
        """``(views, keypoints)`` of track ``t``."""
        s = slice(self.ptr[t], self.ptr[t + 1])
        return self.views[s], self.keypoints[s]

    def subset(self, keep: np.ndarray) -> Tracks:
        """The tracks where ``keep (T,)`` is True."""
        keep = np.asarray(keep, dtype=bool)
        obs = np.repeat(keep, self.lengths)
        ptr = np.concatenate([[0], np.cumsum(self.lengths[keep])]).astype(np.int64)
        return Tracks(ptr, self.views[obs], self.keypoints[obs], self.num_conflicting, self.num_short)


def _find(parent: list[int], a: int) -> int:
    root = a
    while parent[root] != root:
        root = parent[root]
    while parent[a] != root:  # path compression
        parent[a], a = root, parent[a]
    return root


def _split_component(nodes: np.ndarray, node_view: np.ndarray, ea: np.ndarray, eb: np.ndarray) -> np.ndarray:
    """Greedy conflict-free union-find over one component; ``ea, eb`` local node indices in
    priority order. Returns a local label per node."""
    n = len(nodes)
    parent = list(range(n))
    views: list[set[int]] = [{int(v)} for v in node_view]
    for a, b in zip(ea.tolist(), eb.tolist()):
        ra, rb = _find(parent, a), _find(parent, b)
        if ra == rb or views[ra] & views[rb]:
            continue
        if len(views[ra]) < len(views[rb]):
            ra, rb = rb, ra
        parent[rb] = ra
        views[ra] |= views[rb]
        views[rb] = set()
    return np.array([_find(parent, a) for a in range(n)], dtype=np.int64)


def tracks_from_arrays(
    view_a: np.ndarray,
    kp_a: np.ndarray,
    view_b: np.ndarray,
    kp_b: np.ndarray,
    priority: np.ndarray | None = None,
    min_length: int = 2,
    conflicts: str = "split",
) -> Tracks:
    """Tracks from ``K`` matches ``(view_a[k], kp_a[k]) <-> (view_b[k], kp_b[k])`` (all ``(K,)``
    int arrays); ``priority (K,)`` (higher first) orders the unions when splitting conflicts."""
    if conflicts not in CONFLICT_POLICIES:
        raise InputError(f"conflicts must be one of {CONFLICT_POLICIES}, got {conflicts!r}")
    min_length = checked_count(min_length, "min_length", 2)
    arrs = [checked_indices(a, name).ravel() for a, name in ((view_a, "view_a"), (kp_a, "kp_a"), (view_b, "view_b"), (kp_b, "kp_b"))]
    k = len(arrs[0])
    if any(len(a) != k for a in arrs):
        raise InputError("view_a, kp_a, view_b, kp_b must have the same length")
    if k and (min(a.min() for a in arrs) < 0):
        raise InputError("view and keypoint indices must be non-negative")
    va, ka, vb, kb = arrs
    if np.any(va == vb):
        raise InputError("a match joins two keypoints of the same view")
    pr = np.zeros(k) if priority is None else as_real_array(priority, "priority").ravel()
    if len(pr) != k or not np.all(np.isfinite(pr)):
        raise InputError(f"priority must have {k} finite entries, got {len(pr)}")
    empty = Tracks(np.zeros(1, np.int64), np.zeros(0, np.int64), np.zeros(0, np.int64))
    if k == 0:
        return empty
    kmax = int(max(ka.max(), kb.max())) + 1
    keys, inv = np.unique(np.concatenate([va * kmax + ka, vb * kmax + kb]), return_inverse=True)
    node_view, node_kp = keys // kmax, keys % kmax
    na, nb = inv[:k], inv[k:]
    nn = len(keys)
    g = coo_matrix((np.ones(k), (na, nb)), shape=(nn, nn))
    ncomp, label = connected_components(g, directed=False)
    # conflict: a component holding two nodes of one view (nodes are unique (view, kp) pairs)
    comp_view = np.unique(label * (node_view.max() + 1) + node_view)
    nodes_per_comp = np.bincount(label, minlength=ncomp)
    views_per_comp = np.bincount(comp_view // (node_view.max() + 1), minlength=ncomp)
    bad = np.flatnonzero(nodes_per_comp != views_per_comp)
    if len(bad):
        if conflicts == "drop":
            label = np.where(np.isin(label, bad), -1, label)
        else:
            order = np.argsort(-pr, kind="stable")
            edge_comp = label[na[order]]
            next_label = ncomp
            bad_set = np.isin(edge_comp, bad)
            eo = order[bad_set]
            ec = edge_comp[bad_set]
            srt = np.argsort(ec, kind="stable")
            eo, ec = eo[srt], ec[srt]
            bounds = np.flatnonzero(np.diff(ec)) + 1
            for chunk in np.split(np.arange(len(eo)), bounds):
                c = int(ec[chunk[0]])
                nodes = np.flatnonzero(label == c)
                local = np.full(nn, -1, dtype=np.int64)
                local[nodes] = np.arange(len(nodes))
                sub = _split_component(nodes, node_view[nodes], local[na[eo[chunk]]], local[nb[eo[chunk]]])
                _, sub = np.unique(sub, return_inverse=True)
                label[nodes] = next_label + sub
                next_label += int(sub.max()) + 1
    valid = label >= 0
    lab = label[valid]
    nv, nk = node_view[valid], node_kp[valid]
    _, lab = np.unique(lab, return_inverse=True)
    order = np.lexsort((nv, lab))
    lab, nv, nk = lab[order], nv[order], nk[order]
    lengths = np.bincount(lab)
    keep = lengths >= int(min_length)
    obs = keep[lab]
    ptr = np.concatenate([[0], np.cumsum(lengths[keep])]).astype(np.int64)
    return Tracks(ptr, nv[obs], nk[obs], num_conflicting=len(bad), num_short=int(np.sum(~keep)))


def build_tracks(graph: ViewGraph, min_length: int = 2, conflicts: str = "split", edge_mask: np.ndarray | None = None) -> Tracks:
    """Tracks from the inlier matches of the (masked) edges of ``graph``; conflicts are resolved
    in favour of the heavier edges (see the module docstring)."""
    if not isinstance(graph, ViewGraph):
        raise InputError(f"graph must be a poseonly.sfm.viewgraph.ViewGraph, got {type(graph).__name__}")
    if edge_mask is not None:
        edge_mask = np.asarray(edge_mask)
        if edge_mask.shape != (len(graph.edges),):
            raise InputError(f"edge_mask must have one entry per edge ({len(graph.edges)},), got {edge_mask.shape}")
    edges = graph.edges if edge_mask is None else [e for e, k in zip(graph.edges, edge_mask) if k]
    if not edges:
        return tracks_from_arrays(*(np.zeros(0, np.int64),) * 4, min_length=min_length, conflicts=conflicts)
    va = np.concatenate([np.full(len(e.matches), e.i) for e in edges])
    vb = np.concatenate([np.full(len(e.matches), e.j) for e in edges])
    ka = np.concatenate([e.matches[:, 0] for e in edges])
    kb = np.concatenate([e.matches[:, 1] for e in edges])
    pr = np.concatenate([np.full(len(e.matches), e.weight) for e in edges])
    return tracks_from_arrays(va, ka, vb, kb, pr, min_length=min_length, conflicts=conflicts)
