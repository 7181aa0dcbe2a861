"""The global pipeline on a view graph: rotation averaging -> LiGT -> reconstruction, with a
track filter between two LiGT solves.

LiGT is a linear least-squares solve, so wrong track observations (matches that passed a two-view
check by chance) bias it. After the first solve every point is reconstructed analytically; the
observations whose reprojection error exceeds ``max_error_px`` (or that are behind the camera) are
removed and LiGT is solved again (``filter_rounds`` times). Translation-untrusted edges
(``pure_rotation``) still give rotations; their tracks' parallax decides if they join LiGT.
"""

from __future__ import annotations

import numbers
import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from ..geometry import InputError
from .choices import LIGT_NORMALIZATIONS, LIGT_REWEIGHT, ROTATION_WEIGHTS, checked_sigma_deg
from .edge_information import edge_informations
from .inputs import checked_count, checked_positive
from .ligt_global import MIN_PARALLAX_DEG, LiGTResult, TranslationUndetermined, ligt_positions
from .reconstruct import MAX_ERROR_PX, Reconstruction, reconstruct_points
from .rotation_averaging import RotationAveragingResult, average_rotations, checked_error_bounds
from .tracks import CONFLICT_POLICIES, Tracks, build_tracks
from .viewgraph import ViewGraph, largest_component, view_components

BearingsFn = Callable[[Tracks], np.ndarray]

__all__ = ["ROTATION_WEIGHTS", "STAGES", "BearingsFn", "GlobalOptions", "GlobalResult", "filter_observations", "MIN_MODEL_VIEWS", "num_stages", "run_global", "run_global_models"]

# the stages of run_global in order; each filter round runs "filter", "LiGT" and "points" again
STAGES = ("rotation averaging", "tracks", "LiGT", "points", "filter")


@dataclass(frozen=True)
class GlobalOptions:
    """``min_track_length``, track ``conflicts`` policy, rotation averaging outlier thresholds,
    LiGT ``min_parallax_deg``, ``ligt_reweight`` iterations (default :data:`LIGT_REWEIGHT`, one:
    the angular weighting decided on real images; 0 is the paper's LiGT) and ``ligt_normalization``
    (:func:`poseonly.sfm.ligt_global.ligt_positions`), reconstruction ``max_error_px`` and ``filter_rounds``;
    ``rotation_weights``: how rotation averaging weighs the edges, ``"inliers"`` (the two-view inlier
    counts) or ``"information"`` (each relative rotation's inverse covariance from its inlier matches,
    :mod:`poseonly.sfm.edge_information`; an edge without one, too few matches or no scatter, gets its
    inlier count times the median information per inlier, isotropic)."""

    min_track_length: int = 2
    conflicts: str = "split"
    max_rotation_error_deg: float = 5.0
    min_rotation_error_deg: float = 1.0
    min_parallax_deg: float = MIN_PARALLAX_DEG
    max_error_px: float = MAX_ERROR_PX
    filter_rounds: int = 2
    ligt_reweight: int = LIGT_REWEIGHT
    # "noise" (Taubin's: the expected noise part of L^T L) or "unit" (the paper's / openMVG's unit
    # norm, which bends long graphs: 4.8 % of the extent on a 5000-view ring against 0.16 %)
    ligt_normalization: str = LIGT_NORMALIZATIONS[0]
    # the inlier counts (measured with the fixed 5 deg Geman-McClure scale; with the data's the 20 deg
    # synthetic gain stands, 0.732x: `python benchmarks/ra_information.py --seeds 10 --half-fov 20`): on
    # the Strecha scenes the information weighed no better (mean rotation error after rotation-only alignment 0.0163 / 0.0234 / 0.0274 deg against 0.0143 / 0.0237 / 0.0261,
    # P8 / P10 / P11; docs/SFM.md); on synthetic graphs of cameras with a 20 deg half field of view
    # it cuts the error by a quarter (30 views) to 60 % (12 views), at 30-50 deg it changes nothing
    rotation_weights: str = ROTATION_WEIGHTS[0]
    # the Geman-McClure scale of rotation averaging's IRLS (deg); None: from the data, 5x the median
    # edge residual of a least-squares-like fit over sqrt(1 - (N - 1) / E), at most 5 deg; 5 deg on graphs
    # with E < 3 (N - 1) (poseonly.sfm.rotation_averaging, step 4)
    rotation_sigma_deg: float | None = None

    def __post_init__(self) -> None:
        if self.rotation_weights not in ROTATION_WEIGHTS:
            raise InputError(f"rotation_weights must be one of {ROTATION_WEIGHTS}, got {self.rotation_weights!r}")
        checked_sigma_deg(self.rotation_sigma_deg, "rotation_sigma_deg")
        if self.ligt_normalization not in LIGT_NORMALIZATIONS:
            raise InputError(f"ligt_normalization must be one of {LIGT_NORMALIZATIONS}, got {self.ligt_normalization!r}")
        for name, least in (("ligt_reweight", 0), ("min_track_length", 2), ("filter_rounds", 0)):
            object.__setattr__(self, name, checked_count(getattr(self, name), name, least))  # the checked int
        object.__setattr__(self, "max_error_px", checked_positive(self.max_error_px, "max_error_px"))
        checked_error_bounds(self.min_rotation_error_deg, self.max_rotation_error_deg, "min_rotation_error_deg", "max_rotation_error_deg")
        if not (isinstance(self.min_parallax_deg, numbers.Real) and not isinstance(self.min_parallax_deg, bool) and 0.0 <= float(self.min_parallax_deg) < 90.0):
            raise InputError(f"min_parallax_deg must be a number of degrees in [0, 90), got {self.min_parallax_deg!r}")
        if self.conflicts not in CONFLICT_POLICIES:
            raise InputError(f"conflicts must be one of {CONFLICT_POLICIES}, got {self.conflicts!r}")


def num_stages(options: GlobalOptions | None = None) -> int:
    """The most ``on_stage`` calls :func:`run_global` makes with ``options`` (fewer when a filter round finds
    nothing to drop)."""
    return 4 + 3 * (options or GlobalOptions()).filter_rounds


@dataclass
class GlobalResult:
    """``rotations (N, 3, 3)``, ``centres (N, 3)`` (NaN: not estimated), the ``tracks`` with their
    ``bearings (M, 3)``, the final ``reconstruction``, the stage results and ``times_s``."""

    rotations: np.ndarray
    centres: np.ndarray
    tracks: Tracks
    bearings: np.ndarray
    reconstruction: Reconstruction
    rotation: RotationAveragingResult
    ligt: LiGTResult
    times_s: dict[str, float] = field(default_factory=dict)
    info: dict[str, object] = field(default_factory=dict)


def filter_observations(tracks: Tracks, bearings: np.ndarray, keep_obs: np.ndarray, min_length: int = 2) -> tuple[Tracks, np.ndarray, np.ndarray]:
    """Drop observations (``keep_obs (M,)`` False) and then tracks shorter than ``min_length``;
    returns the new tracks, their bearings and the kept old-track indices."""
    tr = tracks.track_of_observation
    cnt = np.bincount(tr[keep_obs], minlength=len(tracks))
    ok = cnt >= min_length
    obs = keep_obs & ok[tr]
    ptr = np.concatenate([[0], np.cumsum(cnt[ok])]).astype(np.int64)
    return Tracks(ptr, tracks.views[obs], tracks.keypoints[obs]), bearings[obs], np.flatnonzero(ok)


def _no_centres(num_views: int, num_tracks: int, reason: str) -> LiGTResult:
    """LiGT's result where the tracks determine no centre: every centre NaN, nothing estimated."""
    return LiGTResult(np.full((num_views, 3), np.nan), np.zeros(num_views, dtype=bool), np.zeros(num_tracks, dtype=bool), -1, {}, {"undetermined": reason})


def run_global(
    graph: ViewGraph,
    bearings_of: BearingsFn,
    focal: float,
    options: GlobalOptions | None = None,
    on_stage: Callable[[str], None] | None = None,
) -> GlobalResult:
    """Global poses and points of ``graph``. ``bearings_of(tracks) -> (M, 3)`` gives the unit
    camera-frame bearings of the tracks' observations; ``focal`` (px) scales reprojection errors.
    ``on_stage(name)``, if given, is called as each stage starts (one of :data:`STAGES`; the
    filter rounds repeat the last three), e.g. to drive a progress bar.

    Where the tracks determine no camera centre (every track without parallax: a pure rotation or a
    panorama; :class:`~poseonly.sfm.ligt_global.TranslationUndetermined`) the result holds the averaged
    rotations, NaN centres, no valid point and ``info["translation_undetermined"]`` saying why."""
    if options is not None and not isinstance(options, GlobalOptions):
        raise InputError(f"options must be a GlobalOptions, got {type(options).__name__}")
    if not isinstance(graph, ViewGraph):
        raise InputError(f"graph must be a ViewGraph, got {type(graph).__name__}")
    opt = options or GlobalOptions()
    if len(graph) == 0:
        raise InputError("the view graph has no edges")
    stage = on_stage or (lambda name: None)
    times: dict[str, float] = {}
    stage("rotation averaging")
    t0 = time.perf_counter()
    info_R, fallback = edge_informations(graph, bearings_of) if opt.rotation_weights == "information" else (None, None)
    ra = average_rotations(
        graph.num_views,
        graph.pairs(),
        graph.rotations(),
        graph.weights(),
        information=info_R,
        max_error_deg=opt.max_rotation_error_deg,
        min_error_deg=opt.min_rotation_error_deg,
        sigma_deg=opt.rotation_sigma_deg,
    )
    times["rotation_averaging"] = time.perf_counter() - t0
    stage("tracks")
    t0 = time.perf_counter()
    tracks = build_tracks(graph, min_length=opt.min_track_length, conflicts=opt.conflicts, edge_mask=ra.inlier_edges)
    f = bearings_of(tracks)
    times["tracks"] = time.perf_counter() - t0
    info: dict[str, object] = {
        "rotation_weights": "inliers" if info_R is None else "information",
        "rotation_sigma_deg": ra.info["sigma_deg"],
        "rotation_information_fallback_edges": None if fallback is None else int(fallback.sum()),
        "tracks_built": len(tracks),
        "observations_built": tracks.num_observations,
        "tracks_conflicting": tracks.num_conflicting,
    }
    stage("LiGT")
    t0 = time.perf_counter()
    try:
        lg = ligt_positions(ra.rotations, tracks, f, min_parallax_deg=opt.min_parallax_deg, reweight_iterations=opt.ligt_reweight, normalization=opt.ligt_normalization)
    except TranslationUndetermined as exc:
        # valid input whose tracks fix no centre (a pure rotation, a panorama): the rotations, no centres
        info["translation_undetermined"] = str(exc)
        times["ligt"] = time.perf_counter() - t0
        lg = _no_centres(graph.num_views, len(tracks), str(exc))
        rec = reconstruct_points(ra.rotations, lg.centres, tracks, f, focal=focal, max_error_px=opt.max_error_px)
        info["points_valid"] = rec.num_valid
        return GlobalResult(ra.rotations.copy(), lg.centres, tracks, f, rec, ra, lg, times, info)
    times["ligt"] = time.perf_counter() - t0
    stage("points")
    t0 = time.perf_counter()
    rec = reconstruct_points(ra.rotations, lg.centres, tracks, f, focal=focal, max_error_px=opt.max_error_px)
    times["reconstruction"] = time.perf_counter() - t0
    for rnd in range(opt.filter_rounds):
        keep = rec.obs_valid
        if np.all(keep[np.isfinite(rec.error_px)]):
            break
        stage("filter")
        t0 = time.perf_counter()
        prev_tracks, prev_f = tracks, f
        tracks, f, _ = filter_observations(tracks, f, keep, opt.min_track_length)
        stage("LiGT")
        try:
            lg = ligt_positions(ra.rotations, tracks, f, min_parallax_deg=opt.min_parallax_deg, reweight_iterations=opt.ligt_reweight, normalization=opt.ligt_normalization)
        except TranslationUndetermined as exc:  # the filter left too little: keep the previous round's result
            info[f"filter_round_{rnd + 1}_undetermined"] = str(exc)
            tracks, f = prev_tracks, prev_f
            break
        times["ligt"] += time.perf_counter() - t0
        stage("points")
        t0 = time.perf_counter()
        rec = reconstruct_points(ra.rotations, lg.centres, tracks, f, focal=focal, max_error_px=opt.max_error_px)
        times["reconstruction"] += time.perf_counter() - t0
        info[f"filter_round_{rnd + 1}_observations"] = tracks.num_observations
    R = ra.rotations.copy()
    R[~lg.estimated] = np.nan
    info["points_valid"] = rec.num_valid
    return GlobalResult(R, lg.centres, tracks, f, rec, ra, lg, times, info)


# the fewest views a model of run_global_models may have (two views are a two-view result, not a model)
MIN_MODEL_VIEWS = 3


def run_global_models(
    graph: ViewGraph,
    bearings_of: BearingsFn,
    focal: float,
    options: GlobalOptions | None = None,
    on_model: Callable[[int, int], Callable[[str], None] | None] | None = None,
    min_views: int = MIN_MODEL_VIEWS,
) -> list[GlobalResult]:
    """Every model ``graph`` holds, largest first: :func:`run_global` on the edges among the views no
    model has claimed yet, until the largest connected component left has fewer than ``min_views``
    views (a run that poses fewer than ``min_views`` gives no model; its views are set aside and the
    search goes on). A run claims the views its rotation averaging
    solved (``rotation.estimated``: its component after the outlier edges are removed), posed or not,
    so the views of one scene do not come back as a model of their own; an image set of several scenes
    (or one scene whose pairs split into parts that no trusted pair joins) gives one model per part, as
    COLMAP's mappers write ``sparse/0``, ``sparse/1``, ... Each result is indexed like ``graph`` (NaN
    for the views of other models). ``on_model(k, views)`` is called as model ``k`` starts (its
    component's view count) and may return an ``on_stage`` callback for that run."""
    if isinstance(min_views, bool) or not isinstance(min_views, (int, np.integer)) or min_views < 2:
        raise InputError(f"min_views must be an int >= 2, got {min_views!r}")
    if options is not None and not isinstance(options, GlobalOptions):
        raise InputError(f"options must be a GlobalOptions, got {type(options).__name__}")
    if not isinstance(graph, ViewGraph):
        raise InputError(f"graph must be a ViewGraph, got {type(graph).__name__}")
    if len(graph) == 0:
        raise InputError("the view graph has no edges")
    pairs = graph.pairs()
    free = np.ones(graph.num_views, dtype=bool)
    models: list[GlobalResult] = []
    while True:
        emask = free[pairs[:, 0]] & free[pairs[:, 1]]
        if not emask.any():
            break
        views = int(largest_component(view_components(graph.num_views, pairs[emask])).sum())
        if views < min_views:
            break
        stage = on_model(len(models), views) if on_model is not None else None
        res = run_global(graph.subgraph(emask), bearings_of, focal, options, on_stage=stage)
        claimed = res.rotation.estimated & free
        if not claimed.any():
            break
        free &= ~claimed
        if int(np.sum(np.all(np.isfinite(res.rotations), axis=(1, 2)))) >= min_views:
            models.append(res)
    return models
