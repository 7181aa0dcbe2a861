"""Global structure from motion on top of the two-view API (issue 15; the paper's last figure).

Pipeline: pairwise :func:`poseonly.estimate_relative_pose` results -> :class:`ViewGraph`
(:mod:`.viewgraph`) -> multi-view tracks (:mod:`.tracks`) -> Chatterjee-Govindu rotation averaging
(:mod:`.rotation_averaging`) -> LiGT global translation (:mod:`.ligt_global`) -> pose-only analytical
reconstruction of the points (:mod:`.reconstruct`). No bundle adjustment.

Global convention (as the notes and openMVG): ``R_k`` maps world to camera ``k``, ``c_k`` is its
centre, ``X_k = R_k (X - c_k)``. A pair ``(i, j)`` in poseonly's two-view convention
``X_j = R_ij X_i + t_ij`` then has ``R_ij = R_j R_i^T`` and ``t_ij ~ R_j (c_i - c_j)``.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

# names -> submodule, loaded on first use: importing poseonly.sfm (the command line's parsers do) must
# not pull in scipy (PEP 562)
_EXPORTS = {
    "Similarity": "align",
    "align_similarity": "align",
    "evaluate_poses": "align",
    "LiGTResult": "ligt_global",
    "ligt_positions": "ligt_global",
    "Reconstruction": "reconstruct",
    "reconstruct_points": "reconstruct",
    "RotationAveragingResult": "rotation_averaging",
    "average_rotations": "rotation_averaging",
    "Tracks": "tracks",
    "build_tracks": "tracks",
    "Edge": "viewgraph",
    "ViewGraph": "viewgraph",
    "edge_from_result": "viewgraph",
}

if TYPE_CHECKING:
    from .align import Similarity, align_similarity, evaluate_poses
    from .ligt_global import LiGTResult, ligt_positions
    from .reconstruct import Reconstruction, reconstruct_points
    from .rotation_averaging import RotationAveragingResult, average_rotations
    from .tracks import Tracks, build_tracks
    from .viewgraph import Edge, ViewGraph, edge_from_result

__all__ = [
    "Edge",
    "LiGTResult",
    "Reconstruction",
    "RotationAveragingResult",
    "Similarity",
    "Tracks",
    "ViewGraph",
    "align_similarity",
    "average_rotations",
    "build_tracks",
    "edge_from_result",
    "evaluate_poses",
    "ligt_positions",
    "reconstruct_points",
]


if not TYPE_CHECKING:  # type checkers see the imports above, and an unknown name stays an error

    def __getattr__(name: str) -> Any:
        mod = _EXPORTS.get(name)
        if mod is None:
            raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
        value = getattr(importlib.import_module(f".{mod}", __name__), name)
        globals()[name] = value
        return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_EXPORTS))
