"""The view graph: one edge per image pair with its relative pose, inlier matches and weight.

An edge ``(i, j)`` (``i < j``) holds poseonly's two-view result ``X_j = R X_i + t`` (unit ``t``),
the inlier matches as keypoint index pairs ``(k_i, k_j)``, the two-view ``status`` and a weight
(by default the number of inliers, the information of the two-view estimate grows with it).

Edge use by status (the two-view API's meaning of each status):

* ``"ok"`` -- rotation and translation trusted;
* ``"pure_rotation"`` -- rotation trusted, translation direction not (``use_translation`` False);
  its inlier matches still join tracks (LiGT drops low-parallax tracks itself);
* anything else (``planar_ambiguous``, ``ambiguous``, ``too_few_inliers``, ``degenerate``) -- not added; the caller
  gets the reason from :meth:`ViewGraph.add_result`.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from ..geometry import InputError, as_real_array
from .inputs import checked_count, checked_indices, checked_positive, checked_rotation

__all__ = ["ROTATION_STATUSES", "TRANSLATION_STATUSES", "Edge", "ViewGraph", "edge_from_result"]

ROTATION_STATUSES = ("ok", "pure_rotation")
TRANSLATION_STATUSES = ("ok",)


@dataclass
class Edge:
    """One view pair ``i < j``: ``R (3, 3)``, ``t (3,)`` with ``X_j = R X_i + t``, ``matches (k, 2)``
    inlier keypoint indices ``(k_i, k_j)``, ``status``, ``weight > 0``."""

    i: int
    j: int
    R: np.ndarray
    t: np.ndarray
    matches: np.ndarray
    status: str = "ok"
    weight: float = 1.0

    @property
    def use_translation(self) -> bool:
        return self.status in TRANSLATION_STATUSES


def edge_from_result(i: int, j: int, result: Any, matches: np.ndarray, weight: float | None = None) -> Edge:
    """Edge from a :class:`poseonly.RelativePoseResult` of views ``i -> j`` and the ``(n, 2)``
    keypoint indices of the ``n`` putative matches it was estimated from (only its ``inliers`` are
    kept). ``i > j`` is accepted and inverted. Weight: ``num_inliers`` unless given."""
    i, j = checked_count(i, "view index i"), checked_count(j, "view index j")
    m = _checked_matches(matches, f"matches of pair ({i}, {j})")
    if getattr(result, "inliers", None) is None:
        raise InputError(f"pair ({i}, {j}): the result has no inlier flags")
    inl = as_real_array(result.inliers, f"inliers of pair ({i}, {j})")
    if inl.shape != (len(m),) or not np.all((inl == 0) | (inl == 1)):
        raise InputError(f"pair ({i}, {j}): the inlier flags must be {len(m)} booleans, one per match, got shape {inl.shape}")
    R = checked_rotation(result.R, f"R of pair ({i}, {j})")
    t = _checked_t(result.t, f"t of pair ({i}, {j})")
    mm = m[inl.astype(bool)]
    w = checked_positive(result.num_inliers if weight is None else weight, f"weight of pair ({i}, {j})")
    if i > j:  # X_i = R^T X_j - R^T t
        i, j, R, t, mm = j, i, R.T, -R.T @ t, mm[:, ::-1]
    return Edge(i, j, R, t, np.ascontiguousarray(mm), str(result.status), w)


def _checked_matches(matches: object, name: str) -> np.ndarray:
    m = checked_indices(matches, name)
    if m.ndim != 2 or m.shape[1] != 2:
        raise InputError(f"{name} must have shape (n, 2), got {m.shape}")
    return m


def _checked_t(t: object, name: str) -> np.ndarray:
    a = as_real_array(t, name)
    if a.size != 3 or not np.all(np.isfinite(a)):
        raise InputError(f"{name} must be 3 finite numbers, got {t!r}")
    return a.reshape(3)


@dataclass
class ViewGraph:
    """Views ``0..num_views-1`` and their pairwise edges (at most one per unordered pair).

    ``rejected`` lists ``(i, j, reason)`` of pairs not added (any status but ``ok`` and ``pure_rotation``:
    ``ambiguous``, ``planar_ambiguous``, ``uncertain``, ``too_few_inliers``, ``degenerate``).
    """

    num_views: int
    edges: list[Edge] = field(default_factory=list)
    rejected: list[tuple[int, int, str]] = field(default_factory=list)
    _index: dict[tuple[int, int], int] = field(default_factory=dict, repr=False)

    def __post_init__(self) -> None:
        self.num_views = checked_count(self.num_views, "num_views", 1)
        if isinstance(self.edges, (str, bytes, dict)) or not isinstance(self.edges, Iterable):
            raise InputError(f"edges must be an iterable of Edge, got {type(self.edges).__name__}")
        given, self.edges = list(self.edges), []
        for e in given:
            self.add_edge(e)

    def add_edge(self, e: Edge) -> None:
        """Add an edge, its fields checked and converted (an :class:`InputError` on indices that are not
        whole numbers or outside the views, a self loop, a duplicate, a weight that is not a positive
        number, a matrix that is not a rotation, a translation that is not 3 finite numbers, matches that
        are not ``(k, 2)`` whole indices)."""
        if not isinstance(e, Edge):
            raise InputError(f"an edge must be a poseonly.sfm.viewgraph.Edge, got {type(e).__name__}")
        i, j = checked_count(e.i, "edge index i"), checked_count(e.j, "edge index j")
        if not (i < self.num_views and j < self.num_views):
            raise InputError(f"edge ({i}, {j}) outside the {self.num_views} views")
        if i >= j:
            raise InputError(f"edge ({i}, {j}) must have i < j (use edge_from_result to invert)")
        if (i, j) in self._index:
            raise InputError(f"duplicate edge ({i}, {j})")
        w = checked_positive(e.weight, f"weight of edge ({i}, {j})")
        R = checked_rotation(e.R, f"R of edge ({i}, {j})")
        t = _checked_t(e.t, f"t of edge ({i}, {j})")
        m = _checked_matches(e.matches, f"matches of edge ({i}, {j})")
        self._index[(i, j)] = len(self.edges)
        self.edges.append(Edge(i, j, R, t, m, str(e.status), w))

    def add_result(self, i: int, j: int, result: Any, matches: np.ndarray, weight: float | None = None) -> bool:
        """Add the two-view ``result`` of pair ``(i, j)`` if its status allows; False (and recorded in
        ``rejected``) otherwise."""
        if result.status not in ROTATION_STATUSES:
            self.rejected.append((min(i, j), max(i, j), f"status {result.status}"))
            return False
        self.add_edge(edge_from_result(i, j, result, matches, weight))
        return True

    def __len__(self) -> int:
        return len(self.edges)

    def edge(self, i: int, j: int) -> Edge | None:
        k = self._index.get((min(i, j), max(i, j)))
        return None if k is None else self.edges[k]

    # array views ---------------------------------------------------------------------------
    def pairs(self) -> np.ndarray:
        """``(E, 2)`` int array of ``(i, j)``."""
        return np.array([(e.i, e.j) for e in self.edges], dtype=np.int64).reshape(-1, 2)

    def rotations(self) -> np.ndarray:
        """``(E, 3, 3)`` relative rotations ``R_ij = R_j R_i^T``."""
        return np.array([e.R for e in self.edges], dtype=np.float64).reshape(-1, 3, 3)

    def translations(self) -> np.ndarray:
        """``(E, 3)`` unit relative translations."""
        return np.array([e.t for e in self.edges], dtype=np.float64).reshape(-1, 3)

    def weights(self) -> np.ndarray:
        """``(E,)`` edge weights."""
        return np.array([e.weight for e in self.edges], dtype=np.float64)

    def components(self, edge_mask: np.ndarray | None = None) -> np.ndarray:
        """``(num_views,)`` connected-component label per view (over the masked edges)."""
        p = self.pairs()
        if edge_mask is not None:
            p = p[np.asarray(edge_mask, dtype=bool)]
        return view_components(self.num_views, p)

    def subgraph(self, edge_mask: Iterable[bool]) -> ViewGraph:
        """The same views with only the masked edges."""
        mask = np.asarray(list(edge_mask), dtype=bool)
        if mask.shape != (len(self.edges),):
            raise InputError(f"edge mask must have {len(self.edges)} entries, got {mask.shape}")
        return ViewGraph(self.num_views, [e for e, k in zip(self.edges, mask) if k], list(self.rejected))


def view_components(num_views: int, pairs: np.ndarray) -> np.ndarray:
    """Connected-component labels ``(num_views,)`` of the graph with edges ``pairs (E, 2)``."""
    p = np.asarray(pairs, dtype=np.int64).reshape(-1, 2)
    g = coo_matrix((np.ones(len(p)), (p[:, 0], p[:, 1])), shape=(num_views, num_views))
    return connected_components(g, directed=False)[1]


def largest_component(labels: np.ndarray) -> np.ndarray:
    """Boolean mask ``(n,)`` of the views in the largest component (ties: lowest label)."""
    counts = np.bincount(labels)
    return labels == int(np.argmax(counts))
