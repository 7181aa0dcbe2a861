"""RANSAC-family loops of the core, bound to their estimators.

* :func:`ransac_relpose` -- LO-RANSAC of minimal relative-pose hypotheses (5-point, or LiRP on 6
  points) scored by (multi-scale) MSAC on the Sampson error, with the exact early bail-out of the
  support measurer, adaptive stopping ``N = log(1 - p) / log(1 - w^m)``, local optimisation of each
  new best model by warm-started TLS IRLS on all-candidate LiRP, and PROSAC sampling when a match
  quality order is given (``scores``).
* :func:`gnc_ransac` -- the paper's Algorithm 3: samples of ``n_s = 30`` fitted by GNC-IRLS (Alg. 2),
  scored by the inlier count of the estimator's residual (``v_LiGT`` in the paper) on all points, the
  best inlier set refit by GNC-IRLS.

Both are the one generic loop of ``src/core/ransac.h`` with different estimators and scorers.
Seeds: an ``int`` is used as the core's 64-bit seed; a ``numpy.random.Generator`` gives one draw.
"""

from __future__ import annotations

import threading
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .. import _core
from .._equality import ValueEquality
from ..estimator import Estimator, lirp_estimator
from ..residuals import Residual, get_residual
from . import cancel
from .gnc import GNCOptions

__all__ = ["RansacResult", "ransac_relpose", "search_cost", "gnc_ransac", "sample_indices", "core_seed", "SCORINGS", "prosac_order"]

SCORINGS = {"msac": 0, "msac-multi": 1, "count": 2}
_MINIMAL = {"5pt": 0, "lirp": 1}
LO_CODES = {"lirp": 0, "sampson": 1, "sampson-truncated": 2, "sampson-multi": 3, "sampson-cauchy-multi": 4, "sampson-cauchy-truncated": 5, "sampson-cauchy-auto": 6}
# the progressive sampler's stopping rules (src/core/ransac.h): PROSAC's per-top-n rule, or the expected
# all-inlier draws of the sampler's schedule
PROGRESSIVE_RULES = ("prosac", "expected")
_SEED_MASK = (1 << 64) - 1


@dataclass(eq=False)
class RansacResult(ValueEquality):
    """``R (3, 3)``, unit ``t (3,)``, ``inliers (n,)`` and ``residuals (n,)`` against the returned
    model, the loop's ``score`` (its cost: lower is better; GNC-RANSAC: the best sample's inlier
    count), iteration counts and, for GNC-RANSAC, the final GNC ``weights (n,)``. Compared by value
    (``==``), as the other result types (a trial: the dataclass ``==`` raised on its arrays)."""

    R: np.ndarray
    t: np.ndarray
    inliers: np.ndarray
    residuals: np.ndarray
    score: float
    num_iterations: int
    num_lo: int = 0
    num_scored: int = 0
    weights: np.ndarray | None = None
    stats: dict[str, Any] = field(default_factory=dict)


def core_seed(seed: int | np.integer | np.random.Generator) -> int:
    """The core's 64-bit seed: an ``int`` in ``[0, 2**64)`` as is, one draw of a ``Generator``."""
    if isinstance(seed, np.random.Generator):
        return int(seed.integers(0, 2**63))
    if isinstance(seed, (bool, np.bool_)) or not isinstance(seed, (int, np.integer)) or not 0 <= int(seed) <= _SEED_MASK:
        raise ValueError(f"seed must be an integer in [0, 2**64) or a numpy.random.Generator, got {seed!r}")
    return int(seed)


def prosac_order(scores: np.ndarray) -> np.ndarray:
    """Match indices by decreasing quality (stable: ties keep their input order): PROSAC's order."""
    return np.argsort(-np.asarray(scores, dtype=float), kind="stable").astype(np.int64)


def sample_indices(rng: np.random.Generator, n: int, m: int, b: int) -> np.ndarray:
    """``b`` samples of ``m`` distinct indices from ``range(n)``: ``(b, m)`` (numpy loops of the
    experiments; the core's loops draw their own). The ``m`` smallest of ``n`` uniform keys per row."""
    if m >= n:
        return np.tile(np.arange(n), (b, 1))
    return np.argpartition(rng.random((b, n)), m - 1, axis=1)[:, :m]


def _c(a: np.ndarray) -> np.ndarray:
    return np.ascontiguousarray(a, dtype=float)


def ransac_relpose(
    f1: np.ndarray,
    f2: np.ndarray,
    threshold: float,
    seed: int | np.random.Generator = 0,
    *,
    solver: str = "5pt",
    scoring: str = "msac",
    max_iterations: int = 100000,
    min_iterations: int = 50,
    confidence: float = 0.999,
    max_lo: int = 8,
    lo_mu0: float = 1e3,
    lo_iterations: int = 10,
    lo_residual: str | Residual = "sampson-chiral",
    scores: np.ndarray | None = None,
    lo: str = "lirp",
    rival_distance: float = 0.0,
    chiral: bool = False,
    min_hits: int = 1,
    challengers: int = 0,
    challenger_distance: float = 1.0,
    lo_max_points: int = 0,
    keypoint_once: bool = False,
    progressive_stop: bool = False,
    floor_parallax_deg: float = 0.0,
    min_iterations_parallax: int = 0,
    progressive_rule: str = "prosac",
    progressive_min_draws: int = 0,
    prosac_trials: int = 0,
    min_inlier_ratio: float = 0.0,
) -> RansacResult:
    """LO-RANSAC on bearings ``f1, f2 (n, 3)`` with the Sampson error against ``threshold`` (radians).

    ``scoring``: ``"msac"`` (truncated quadratic at ``threshold``), ``"msac-multi"`` (its sum at
    ``threshold``, ``/2`` and ``/4``) or ``"count"`` (inlier count).
    ``scores (n,)`` (higher is better) switch to PROSAC sampling in that order. Returns a
    :class:`RansacResult` whose inliers are the Sampson inliers of the returned model. ``lo``: the
    local optimisation, ``"lirp"`` (warm-started TLS IRLS on all-candidate LiRP with ``lo_residual``)
    or Levenberg-Marquardt on the Sampson error with a loss at the threshold: ``"sampson"`` Cauchy's,
    ``"sampson-truncated"`` MSAC's truncated quadratic (PoseLib's LO), ``"sampson-multi"`` the
    truncated quadratics of ``"msac-multi"`` (the default search's score, without cheirality),
    ``"sampson-cauchy-truncated"`` / ``"sampson-cauchy-multi"`` Cauchy's, then MSAC's / those from
    its result.
    ``rival_distance > 0`` (degrees) also keeps the best-scoring model at least that far from the
    result in rotation or translation direction: ``stats["rival_cost"]`` (``inf`` if none),
    ``stats["rival_R"]``, ``stats["rival_t"]`` (a uniqueness test of the result). ``chiral``: a match
    whose point the hypothesis puts behind either camera scores as an outlier (exact: the plain cost
    bails out first, the cheirality-aware pass runs only for models that survive it). ``min_hits``:
    adaptive stopping waits until, at ``confidence``, that many all-inlier samples of the best
    model's consensus have been drawn (1: the classical rule; exact binomial tail). ``challengers``:
    the best models of that many other basins (``challenger_distance`` degrees from the best and
    from each other, scored up to 1.5x the best cost) are kept during the search and locally
    optimised after it until their cost stops improving; one that beats the best replaces it
    (``stats["challenger_won"]``), those that lost are ``stats["others_R"] (k, 3, 3)``,
    ``["others_t"] (k, 3)`` and ``["others_cost"] (k,)``: LO runs only on new bests, and a raw minimal model of the right
    basin can score worse than a locally optimised model of a wrong one. A challenger is kept only
    while the largest support gain of an LO step in this search could make it the best, so with
    ``max_lo=0`` (or no LO that improved a model) none is kept. ``challenger_distance`` must be finite
    and > 0 (degrees: the larger of the rotation angle and the translation directions' angle).
    ``lo_max_points > 0``: each LO step runs on an evenly strided subset of at most that many of the
    points in its window (0: all). ``keypoint_once`` (with ``chiral``): of the matches that share a
    keypoint (an identical bearing in one view), only those of the correspondence that fits the
    hypothesis best keep their score and count as its inliers, the others score as outliers
    (``stats["keypoint_groups"]``: the number of shared keypoints; ``src/core/conflicts.h``).
    ``progressive_stop`` (with ``scores``): the search also ends by PROSAC's stopping rule (Chum and
    Matas 2005): when, for some top-n set of the score order (n >= min(N / 2, 100)) whose inlier count
    is non-random, the draws made within it reach the count at its inlier ratio (bounded for sampling
    without replacement); the draws are the ones the search makes anyway, so it only ends earlier
    (``src/core/ransac.h`` ``progressive_needed``); with ``progressive_rule="expected"`` instead when the
    expected number of all-inlier draws of the best model's inliers, summed over the sampler's actual
    schedule, reaches the classical rule's ``-ln(1 - confidence)`` (``expected_needed``: the classical
    criterion for the draws PROSAC makes); either rule ends the search only after
    ``progressive_min_draws`` draws (the classical rule is not affected). ``prosac_trials > 0``: PROSAC's
    growth schedule is that of this many trials instead of ``max_iterations`` (a search run in stages
    draws as the whole would). ``floor_parallax_deg > 0``: while the best model's
    inliers have a median parallax (angle between ``R f1`` and ``f2``) of at least that, the sample
    floor is ``min(min_iterations, min_iterations_parallax)`` instead of ``min_iterations``.
    ``min_inlier_ratio`` in ``[0, 1]``: the classical rule assumes at least that inlier share, so the
    search ends once a model supported by that share would have been drawn at ``confidence`` (a caller
    that refuses models with less support need not search longer for them).
    """
    if lo not in LO_CODES:
        raise ValueError(f"unknown local optimisation {lo!r}; choose one of {sorted(LO_CODES)}")
    if solver not in _MINIMAL:
        raise ValueError(f"unknown minimal solver {solver!r}; choose one of {sorted(_MINIMAL)}")
    if scoring not in SCORINGS:
        raise ValueError(f"unknown scoring {scoring!r}; choose one of {sorted(SCORINGS)}")
    if progressive_rule not in PROGRESSIVE_RULES:
        raise ValueError(f"unknown progressive_rule {progressive_rule!r}; choose one of {list(PROGRESSIVE_RULES)}")
    f1, f2 = _c(f1), _c(f2)
    order = None if scores is None else prosac_order(scores)
    R, t, st = _core.ransac_relpose(
        f1,
        f2,
        float(threshold),
        core_seed(seed),
        _MINIMAL[solver],
        SCORINGS[scoring],
        int(max_iterations),
        int(min_iterations),
        float(confidence),
        int(max_lo),
        float(lo_mu0),
        int(lo_iterations),
        get_residual(lo_residual).code,
        order,
        LO_CODES[lo],
        float(rival_distance),
        bool(chiral),
        int(min_hits),
        int(challengers),
        float(challenger_distance),
        int(lo_max_points),
        bool(keypoint_once),
        bool(progressive_stop),
        float(np.radians(floor_parallax_deg)),
        int(min_iterations_parallax),
        progressive_rule == "expected",
        int(progressive_min_draws),
        int(prosac_trials),
        float(min_inlier_ratio),
        threading.current_thread() is threading.main_thread(),  # Ctrl-C during the search (main thread only)
        cancel.current(),  # a batch's worker threads: the batch's flag (SearchCancelled once it is set)
    )
    v = get_residual("sampson").unchecked(R, t, f1, f2)
    return RansacResult(
        R=R,
        t=t,
        inliers=v < threshold,
        residuals=v,
        score=float(st["cost"]),
        num_iterations=int(st["iterations"]),
        num_lo=int(st["num_lo"]),
        num_scored=int(st["num_models"]),
        stats=dict(st),
    )


def search_cost(
    R: np.ndarray, t: np.ndarray, f1: np.ndarray, f2: np.ndarray, threshold: float, *, scoring: str = "msac-multi", keypoint_once: bool = True
) -> tuple[float, np.ndarray]:
    """The cheirality-aware search objective of :func:`ransac_relpose` at one pose ``R (3, 3)``, ``t (3,)``
    on bearings ``f1, f2 (n, 3)`` at ``threshold`` (radians): ``(cost, inlier indices)``, lower cost
    better, as the loop measures them (with ``keypoint_once`` the matches of a shared keypoint
    scored once). A diagnostic: which of two poses does the search prefer, and why."""
    if scoring not in SCORINGS:
        raise ValueError(f"unknown scoring {scoring!r}; choose one of {sorted(SCORINGS)}")
    c, inl = _core.search_cost(_c(R), _c(t), _c(f1), _c(f2), float(threshold), SCORINGS[scoring], bool(keypoint_once))
    return float(c), inl


def gnc_ransac(
    f1: np.ndarray,
    f2: np.ndarray,
    theta: float,
    seed: int | np.random.Generator = 0,
    *,
    estimator: Estimator | None = None,
    sample_size: int = 30,
    max_iterations: int = 50,
    gnc_options: GNCOptions | None = None,
    adaptive: bool = False,
    confidence: float = 0.99,
) -> RansacResult:
    """GNC-RANSAC, Algorithm 3 of the paper, on bearings ``(n, 3)``.

    ``max_iterations`` samples of ``sample_size`` (n_s = 30) points are each fitted by GNC-IRLS (Alg. 2
    from uniform weights), every fit is scored on all points by the count of ``residual < theta``
    (the estimator's residual; ``v_LiGT`` for the paper's estimator), and the best inlier set is refit
    by GNC-IRLS. ``adaptive=True`` stops early with the RANSAC rule applied to the paper's rationale (a
    sample only needs a majority of inliers, taken as ``>= 60 %``; binomial tail). ``theta`` is given by
    the caller (:func:`poseonly.api.estimate_relative_pose` derives it from a pixel threshold).
    With fewer than ``sample_size`` points every sample is all of them (the same fit each time); the
    public :func:`poseonly.gnc_ransac` refuses such input.
    """
    est = estimator or lirp_estimator()
    opts = gnc_options or GNCOptions()
    f1, f2 = _c(f1), _c(f2)
    R, t, w, st = _core.gnc_ransac(
        f1,
        f2,
        float(theta),
        core_seed(seed),
        int(min(sample_size, len(f1))),
        int(max_iterations),
        bool(adaptive),
        float(confidence),
        opts.core_options(est),
        threading.current_thread() is threading.main_thread(),  # Ctrl-C within 64 samples (main thread only)
        cancel.current(),  # a batch's worker threads: the batch's flag
    )
    v = est.residual.unchecked(R, t, f1, f2)
    return RansacResult(R=R, t=t, inliers=v < theta, residuals=v, score=float(len(f1) - st["cost"]), num_iterations=int(st["iterations"]), weights=w, stats=dict(st))
