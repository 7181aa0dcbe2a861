"""The default method ``"poseonly"``: LO-RANSAC in the core, the pose-only choice, the ML pose.

See :func:`run_poseonly` for the stages; the search runs in ``src/core`` (``ransac.h``,
``estimators.h``), the ML refinement in ``src/core/ml_refine.cpp``.

Shapes: bearings ``f1, f2 (n, 3)`` (unit), poses ``R (3, 3)``, ``t (3,)``; ``tau`` in radians.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np

from .. import _core
from ..analysis import AMBIGUITY_LEVEL, MAX_SUPPORT_THRESHOLD, REFINE_SOLVER, sign_test, support
from ..geometry import InputError, rotvec_from_rotation, valid_pose
from ..median import median
from ..options import PoseonlyOptions
from ..residuals import get_residual, v_sampson, v_sampson_chiral
from .consistency import consistency_order_scores
from .ransac import LO_CODES, RansacResult, core_seed, ransac_relpose, search_cost

__all__ = ["keep_better", "local_optimization", "make_rng", "msac_chiral", "noise_threshold", "refine_ligt", "rival_support_ratio", "run_poseonly", "select_by_support"]

# noise-matched threshold: clip range relative to the user's threshold, steps of the fixed point
NOISE_THRESHOLD_RANGE = (0.25, 3.0)
NOISE_THRESHOLD_STEPS = 3
# fewer Sampson errors below the threshold than this: too few for the noise estimate, keep tau
NOISE_THRESHOLD_MIN_ERRORS = 15
MAD_TO_SIGMA = 1.4826
# hypotheses counted for the a-contrario test (poseonly.analysis): every minimal sample may give up
# to 10 essential matrices (the 5-point solver's bound), each LO and final-stage candidate counts
MAX_ROOTS_PER_SAMPLE = 10
FINAL_CANDIDATES = 20
# the scales of the "msac-multi" score (tau, tau / 2, tau / 4, each normalised to at most 1 a match):
# must match the core's multi-scale MSAC (src/core/ransac.h), whose best possible cost is this times n
MSAC_MULTI_SCALES = 3
# the ML refinement is kept unless it loses more than 2 % of the cheirality-aware MSAC score at tau
ML_KEEP_TOLERANCE = 0.98
# the angular LiGT refinement after LO is kept unless it loses more than 2 % of that score at the noise threshold
LIGT_KEEP_TOLERANCE = 0.98
# EM rounds at most, and the pose change (radians / unit-t distance; 1e-6 rad = 6e-5 deg, far below any
# pose error) that ends them: 7-8 rounds on real pairs
ML_ROUNDS = 50
ML_POSE_TOL = 1e-6
ML_LM_ITERATIONS = 10  # LM cost evaluations per M-step (the core's default, MlOptions::lm_iterations)
# EM has collapsed when the Gaussian mixture's sigma at its pose is below this fraction of the robust
# scale of that pose's errors (1.4826 median of those below T / 2, as EM's start): the posteriors
# concentrated on a few matches that the pose's five degrees of freedom fit almost exactly (an
# unbounded maximum of the mixture likelihood, not the ML pose), while the pose's other inliers keep
# their errors. Measured on the synthetic scenes at 80 % outliers (60 per cell, 1 px noise): 2-4 per
# cell at 0.03-0.17 of that scale, the others at 0.24-1.65 (median ~1); the pair that showed it, at
# 1e-4 (sigma at its floor on 9 matches, `tests/test_ml_collapse.py`)
ML_COLLAPSE = 0.2
# ... or when its decision threshold is below the noise scale of the matches within this fraction of its
# range (2 / 3: the status's noise check, NOISE_CHECK_BAND = 2 search thresholds of the ML_RANGE = 3),
# measured on at least this many of them (analysis.NOISE_CHECK_MIN)
COLLAPSE_BAND = 2.0 / 3.0
COLLAPSE_BAND_MIN = 30
ML_MIN_NEAR = 6  # the core's kMinInliers
# the repeated search scores at this many noise scales (MSAC's truncation near 3 sigma keeps ~99 % of
# Gaussian inliers; the first search's tau is the user's, meant for real matches' ~0.3 px noise)
RESEARCH_SIGMAS = 3.0
# the cross-fit (see _cross_fit; matches i with i % ml_folds == j form fold j) is used when at least
# this many of the ML pose's inliers are also inliers of the pose of the other folds
CROSS_FIT_MIN = 15
# the folds' EMs: the ML stage's inlier model (nu, alpha) instead of their own choice, and stopping
# when a round moves the pose by at most 1e-5 rad (0.01 px at f = 1000, far below the noise the held-out
# decision resolves) with 4 LM evaluations per M-step (a generalised EM: each round raises the
# likelihood, the fixed point is the same); measured on fountain-P11: the same classification as full
# EMs, 11.4 -> ~4.5 ms per pair
CF_POSE_TOL = 1e-5
# ... and run to the ML stage's limit of rounds: capping them at 3-10 rounds changed the vetoed set on
# 4-34 of 153 entry-P10 / temple pairs (one pose by 1.5 deg), for 10-25 % of the cross-fit's time
CF_ROUNDS = ML_ROUNDS
CF_LM_ITERATIONS = 4


def make_rng(seed: int | np.random.Generator) -> np.random.Generator:
    """The generator of a seed (a Generator is used as is)."""
    return seed if isinstance(seed, np.random.Generator) else np.random.default_rng(int(seed))


def msac_chiral(R: np.ndarray, t: np.ndarray, f1: np.ndarray, f2: np.ndarray, tau: float) -> float:
    """Cheirality-aware MSAC score (larger is better) of a pose on validated bearings ``f1, f2 (n, 3)``
    (NaN for a non-finite pose)."""
    v = v_sampson_chiral.unchecked(R, t, f1, f2)
    return float(np.sum(tau * tau - np.minimum(v * v, tau * tau)))


def keep_better(a: tuple[np.ndarray, np.ndarray], b: tuple[np.ndarray, np.ndarray], f1: np.ndarray, f2: np.ndarray, tau: float, tol: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    """``b`` if its cheirality-aware MSAC score reaches ``tol`` times ``a``'s, else ``a``."""
    if not (np.all(np.isfinite(b[0])) and np.all(np.isfinite(b[1]))):
        return a
    return b if msac_chiral(*b, f1, f2, tau) >= tol * msac_chiral(*a, f1, f2, tau) else a


def select_by_support(R: np.ndarray, t: np.ndarray, f1: np.ndarray, f2: np.ndarray, tau: float) -> tuple[np.ndarray, np.ndarray]:
    """Best of ``(R, t)`` (re-identified on its Sampson inliers), its homography twin and the LiRP
    candidates of its consensus set, by cheirality-consistent support (the core's
    ``src/core/analysis.cpp``, GIL released; numpy reference: ``tests/reference/select.py``)."""
    c = np.ascontiguousarray
    return _core.select_by_support(c(R, dtype=float), c(t, dtype=float), c(f1, dtype=float), c(f2, dtype=float), float(tau))


def refine_ligt(R: np.ndarray, t: np.ndarray, f1: np.ndarray, f2: np.ndarray, inl: np.ndarray, tau: float, normalization: str = "none") -> tuple[np.ndarray, np.ndarray]:
    """LiGTopt on the inliers ``inl (n,)`` with a robust Cauchy loss at the threshold scale.

    ``normalization="none"`` is the paper's LiGTopt (Eq. 9 residual ``||L~_i t||``);
    ``"angular"`` divides each residual by ``theta_i^2 ||z_i R f1_i + t||`` (the sine of the view-2
    reprojection angle), which measured as accurate as Sampson/ML refinement while the paper's
    weighting is not better than LiRP itself (docs/RESULTS.md).
    """
    from ..refine._common import check_pose
    from ..refine.ligt import ligt_refine

    if inl.sum() < 6:
        return R, t
    try:
        check_pose(R, t)
    except InputError:
        # the method's own pose is not one (a GNC solve on matches that repeat a few points: a user would
        # read "R must be a rotation matrix" as a fault of an R they never passed): it stays unrefined,
        # and the status analysis reports it (degenerate)
        return R, t
    r = ligt_refine(R, t, f1[inl], f2[inl], loss="cauchy", loss_scale=tau, normalization=normalization, solver=REFINE_SOLVER)
    if np.all(np.isfinite(r.R)) and np.all(np.isfinite(r.t)):
        return r.R, r.t
    return R, t


def noise_threshold(R: np.ndarray, t: np.ndarray, f1: np.ndarray, f2: np.ndarray, tau: float, o: PoseonlyOptions) -> float:
    """Inlier threshold matched to the measured noise, for the final stages and the returned mask.

    Fixed-point iteration ``thr <- clip(k sigma(thr), tau / 4, 3 tau)`` (3 steps from ``thr = tau``)
    with ``sigma(thr) = 1.4826 median |v|`` over the Sampson errors below ``thr`` and ``k =
    noise_factor`` (2.5 keeps ~99 % of Gaussian inliers; the truncation at ``thr`` biases sigma low,
    which the iteration undoes). Real images (~0.3 px) get a tighter threshold than the 1 px default,
    1 px synthetic noise a wider one. ``adaptive_threshold=False`` keeps ``tau``.
    """
    if not o.adaptive_threshold:
        return tau
    v_all = v_sampson.unchecked(R, t, f1, f2)
    thr = tau
    lo, hi = NOISE_THRESHOLD_RANGE
    for _ in range(NOISE_THRESHOLD_STEPS):
        v = v_all[v_all < thr]
        if len(v) < NOISE_THRESHOLD_MIN_ERRORS:
            return tau
        thr = float(np.clip(o.noise_factor * MAD_TO_SIGMA * median(v), lo * tau, hi * tau))
    return thr


def local_optimization(R: np.ndarray, t: np.ndarray, f1: np.ndarray, f2: np.ndarray, thr: float, o: PoseonlyOptions) -> tuple[np.ndarray, np.ndarray]:
    """The core's LO step at ``thr`` from the pose's cheirality-consistent inliers, on the points within
    4 thresholds: warm-started TLS IRLS on all-candidate LiRP (``lo="lirp"``) or Sampson LM with a loss
    at ``thr``: Cauchy's (``"sampson"``), MSAC's truncated quadratic (``"sampson-truncated"``), the
    truncated quadratics of ``scoring="msac-multi"`` (``"sampson-multi"``; without the cheirality of
    ``chiral_scoring``), or Cauchy's then one of those (``"sampson-cauchy-truncated"``,
    ``"sampson-cauchy-multi"``; ``"sampson-cauchy-auto"``: the second stage only where the matches within
    ``thr`` have a median error below 0.3 ``thr``). Of a two-stage LO's two poses the one of the better
    cheirality-aware MSAC score at ``thr`` (the later on a tie), as the search keeps the better by its own
    score. ``(R, t)`` unchanged where the LO fails."""
    Rs, ts = _core.relpose_lo(R, t, f1, f2, thr, float(o.lo_mu0), int(o.lo_iterations), get_residual(o.lo_residual).code, LO_CODES[o.lo], int(o.lo_max_points))
    if len(Rs) == 0:
        return R, t
    best = len(Rs) - 1
    for k in range(len(Rs) - 1):
        best = k if msac_chiral(Rs[k], ts[k], f1, f2, thr) > msac_chiral(Rs[best], ts[best], f1, f2, thr) else best
    return Rs[best], ts[best]


def rival_support_ratio(r: RansacResult, n: int, tau: float, scoring: str) -> float:
    """Support of the best rival model (``rival_distance`` degrees or more from the result) relative to
    the result's: the scorer's maximum minus its cost, so 1 means an equally supported rival and 0 no
    rival. Diagnostic of the uniqueness of the pose."""
    full = {"msac-multi": float(MSAC_MULTI_SCALES * n), "msac": n * tau * tau, "count": float(n)}[scoring]
    rc = float(r.stats.get("rival_cost", np.inf))
    if not np.isfinite(rc):
        return 0.0
    return max(full - rc, 0.0) / max(full - r.score, 1e-300)


def _search(f1: np.ndarray, f2: np.ndarray, tau: float, o: PoseonlyOptions, scores: np.ndarray | None, consistent: bool = False, max_iterations: int | None = None) -> RansacResult:
    """One LO-RANSAC search of :func:`run_poseonly` at ``tau`` (radians); ``consistent``: ``scores`` is
    the neighbour-consistency order (PROSAC's rule then waits for ``consistency_min_draws``);
    ``max_iterations``: a stage of the search (PROSAC keeps the schedule of ``o.max_iterations``). The
    search in the consistency order stops by ``o.consistency_rule``, the others by ``o.progressive_rule``."""
    return ransac_relpose(
        f1,
        f2,
        tau,
        core_seed(o.seed),
        solver=o.solver,
        scoring=o.scoring,
        max_iterations=o.max_iterations if max_iterations is None else max_iterations,
        min_iterations=o.min_iterations,
        confidence=o.confidence,
        max_lo=o.max_lo,
        lo_mu0=o.lo_mu0,
        lo_iterations=o.lo_iterations,
        lo_residual=o.lo_residual,
        scores=scores,
        lo=o.lo,
        rival_distance=o.rival_distance,
        chiral=o.chiral_scoring,
        min_hits=o.min_hits,
        challengers=o.challengers,
        lo_max_points=o.lo_max_points,
        keypoint_once=o.keypoint_once,
        progressive_stop=o.progressive_stop,
        floor_parallax_deg=o.floor_parallax_deg,
        min_iterations_parallax=o.min_iterations_parallax,
        progressive_rule=o.consistency_rule if consistent else o.progressive_rule,
        progressive_min_draws=o.consistency_min_draws if consistent else 0,
        prosac_trials=o.max_iterations,
        min_inlier_ratio=min(1.0, o.min_inliers / len(f1)) if o.stop_at_min_inliers else 0.0,
    )


def _pose_distance_deg(R1: np.ndarray, t1: np.ndarray, R2: np.ndarray, t2: np.ndarray) -> float:
    """The core's model distance (``estimators.h`` ``pose_distance_deg``): the larger of the rotation
    angle and the translation directions' angle, in degrees."""
    c = float(np.clip(0.5 * (np.trace(R1.T @ R2) - 1.0), -1.0, 1.0))
    ct = float(np.clip(t1 @ t2 / max(float(np.linalg.norm(t1) * np.linalg.norm(t2)), 1e-300), -1.0, 1.0))
    return float(np.degrees(max(np.arccos(c), np.arccos(ct))))


def _model_distance_deg(R1: np.ndarray, t1: np.ndarray, R2: np.ndarray, t2: np.ndarray) -> float:
    """:func:`_pose_distance_deg` with the translations compared up to sign (``t`` and ``-t`` are one
    epipolar model, which a re-identification may flip)."""
    return _pose_distance_deg(R1, t1, R2, t2) if float(t1 @ t2) >= 0 else _pose_distance_deg(R1, t1, R2, -t2)


RIVAL_COST_FACTOR = 1.5  # ransac.h kRivalCostFactor: a rival is scored up to this times the best cost
SAME_BASIN_DEG = 1.0  # ransac.h challenger_distance: two models this close are one basin


def rival_candidates(r: RansacResult, rival_distance: float) -> list[tuple[np.ndarray, np.ndarray]]:
    """The models the uniqueness test compares the result with, best first: the search's rival
    (``stats["rival_R"]``, its best model at least ``rival_distance`` from the result), then the
    challengers it optimised and that lost (``stats["others_R"]``: the best models of other basins)
    as far from the result and within ``RIVAL_COST_FACTOR`` of its cost, one per basin. Why more
    than one: refined, the best rival can fall back into the result's basin (a broad wrong basin
    holds several of the search's models), while a costlier basin the search also kept is the
    truth's (ORB on KITTI: docs/RESULTS_real.md, "Every basin the search kept")."""
    if not (rival_distance > 0 and np.isfinite(float(r.stats.get("rival_cost", np.inf)))):
        return []
    out = [(np.asarray(r.stats["rival_R"]), np.asarray(r.stats["rival_t"]))]
    costs = np.asarray(r.stats.get("others_cost", np.empty(0)), float)
    Rs, ts = np.asarray(r.stats.get("others_R", np.empty((0, 3, 3)))), np.asarray(r.stats.get("others_t", np.empty((0, 3))))
    for k in np.argsort(costs, kind="stable"):
        Rv, tv = Rs[k], ts[k]
        if not (costs[k] <= RIVAL_COST_FACTOR * r.score and _pose_distance_deg(r.R, r.t, Rv, tv) > rival_distance):
            continue
        if all(_pose_distance_deg(Ru, tu, Rv, tv) > SAME_BASIN_DEG for Ru, tu in out):
            out.append((Rv, tv))
    return out


def _combined(a: RansacResult, b: RansacResult, rival_distance: float) -> RansacResult:
    """The better of two searches' results (the lower cost; ``a`` on ties) with both searches' counts
    (iterations, LO runs, scored models, challenger LO runs). Every model either search kept outside
    its result (rivals, optimised challengers, the loser's best) is one of the merged ``others``; the
    rival (the uniqueness test's best model at least ``rival_distance`` from the result, within
    ``RIVAL_COST_FACTOR`` of its cost) is the cheapest of them, as one search would have kept it
    (the winner's own rival on ties)."""
    r, other = (b, a) if b.score < a.score else (a, b)
    stats = dict(r.stats)
    stats["num_challenger_lo"] = int(a.stats.get("num_challenger_lo", 0)) + int(b.stats.get("num_challenger_lo", 0))
    if rival_distance > 0:
        pool: list[tuple[np.ndarray, np.ndarray, float]] = []  # (R, t, cost) on the same matches
        for x in (r, other):
            if np.isfinite(float(x.stats.get("rival_cost", np.inf))):
                pool.append((np.asarray(x.stats["rival_R"], float), np.asarray(x.stats["rival_t"], float), float(x.stats["rival_cost"])))
            Rs = np.asarray(x.stats.get("others_R", np.empty((0, 3, 3))), float)
            ts = np.asarray(x.stats.get("others_t", np.empty((0, 3))), float)
            pool += [(Rs[k], ts[k], float(c)) for k, c in enumerate(np.asarray(x.stats.get("others_cost", np.empty(0)), float))]
        pool.append((np.asarray(other.R, float), np.asarray(other.t, float), float(other.score)))
        far = [m for m in pool if m[2] <= RIVAL_COST_FACTOR * r.score and _pose_distance_deg(r.R, r.t, m[0], m[1]) > rival_distance]
        if far:
            Rv, tv, cost = min(far, key=lambda m: m[2])
            stats.update(rival_R=Rv, rival_t=tv, rival_cost=cost)
        else:
            stats["rival_cost"] = np.inf
        stats.update(
            others_R=np.array([m[0] for m in pool]).reshape(-1, 3, 3),
            others_t=np.array([m[1] for m in pool]).reshape(-1, 3),
            others_cost=np.array([m[2] for m in pool], float),
        )
    return dataclasses.replace(r, num_iterations=a.num_iterations + b.num_iterations, num_lo=a.num_lo + b.num_lo, num_scored=a.num_scored + b.num_scored, stats=stats)


def _with_remainder(
    r: RansacResult, budget: int, f1: np.ndarray, f2: np.ndarray, tau: float, o: PoseonlyOptions, scores: np.ndarray | None, by_scores: bool = False
) -> RansacResult:
    """``o.consistency_remainder``: a search ``r`` in the consistency order that its progressive rule
    ended (before its ``budget``, and before the classical rule on its inlier share would have: the
    core's ``stats["classical_needed"]``) is followed by a second one in the consistency order of the matches
    outside ``r``'s band (Sampson error at least ``tau``), for as many draws as ``r`` took (at least
    ``consistency_min_draws``, at most what is left of ``budget``). ``by_scores`` (``o.prosac_remainder``):
    the same after a search in the order of ``scores`` (PROSAC), the second one in the ``scores`` order of
    the remainder, for as many draws as ``r`` took (scores that rank a repeated structure first end
    PROSAC on its geometry; the truth's matches are then first in the remainder). Its model, scored on all the matches
    by the search's objective (:func:`search_cost`, cheirality-aware: with ``chiral_scoring`` off the
    two costs would differ, and the step is skipped), replaces ``r`` if it costs less and is offered as
    the uniqueness test's rival otherwise (:func:`_combined`). Why: a compact second motion (a moving
    object) has the most consistent neighbourhoods and tops the order; a rule that trusts the order ends
    on it, and the scene's own matches are left in the remainder, where they come first."""
    left = budget - r.num_iterations
    if not ((o.prosac_remainder if by_scores else o.consistency_remainder) and o.chiral_scoring and left > 0):
        return r
    if r.num_iterations >= float(r.stats.get("classical_needed", np.inf)):
        return r
    rest = np.flatnonzero(~r.inliers)
    if by_scores:
        if scores is None or len(rest) < 5:
            return r
        g1, g2 = f1[rest], f2[rest]
        s = _search(g1, g2, tau, o, scores[rest], False, min(left, r.num_iterations))
    else:
        if len(rest) < o.consistency_min_matches * o.consistency_k:
            return r
        g1, g2 = f1[rest], f2[rest]
        order = consistency_order_scores(g1, g2, None if scores is None else scores[rest], o.consistency_k)
        s = _search(g1, g2, tau, o, order, True, min(left, max(o.consistency_min_draws, r.num_iterations)))
    if not s.num_scored or not (np.all(np.isfinite(s.R)) and np.all(np.isfinite(s.t))):  # no model (the core's (I, 0))
        return r
    cost, inl = search_cost(s.R, s.t, f1, f2, tau, scoring=o.scoring, keypoint_once=o.keypoint_once)
    v = v_sampson.unchecked(s.R, s.t, f1, f2)
    # its counts on all the matches (the first search's keypoint groups; no rival of its own)
    stats = {k: x for k, x in r.stats.items() if not k.startswith(("rival_", "others_"))}
    stats.update(cost=float(cost), num_inliers=len(inl), rival_cost=np.inf, needed=np.inf)
    stats.update(num_challenger_lo=s.stats.get("num_challenger_lo", 0), challenger_won=s.stats.get("challenger_won", 0))
    whole = dataclasses.replace(s, inliers=v < tau, residuals=v, score=float(cost), stats=stats)
    return _combined(r, whole, o.rival_distance)


def search(f1: np.ndarray, f2: np.ndarray, tau: float, o: PoseonlyOptions, scores: np.ndarray | None) -> tuple[RansacResult, dict[str, Any]]:
    """The search of :func:`run_poseonly` in the sampling order ``o.consistency`` asks for: the
    ``scores`` order (PROSAC; uniform without scores), the neighbour-consistency order
    (``"always"``), or the ``scores`` order for ``consistency_after`` samples and, if that search has
    not converged, a second search in the consistency order for the rest of the budget (at most the
    draws the first search's stopping rule still asked for, at least ``consistency_min_draws``), the
    better of the two kept (``"fallback"``: a search that ends within the first stage is the plain search's, draw
    for draw). A search in the ``scores`` order that PROSAC's rule ended early is followed by one in the
    remainder (:func:`_with_remainder`, ``o.prosac_remainder``). Returns the result (iterations, LO runs
    and scored models of all stages) and diagnostics (``consistency``: the order that produced the result)."""
    usable = o.consistency != "off" and len(f1) >= o.consistency_min_matches * o.consistency_k
    if usable and o.consistency == "always":
        r = _search(f1, f2, tau, o, consistency_order_scores(f1, f2, scores, o.consistency_k), True)
        return _with_remainder(r, o.max_iterations, f1, f2, tau, o, scores), {"consistency": "always"}
    # (a first stage shorter than the sample floor would not be the plain search's prefix)
    if not (usable and o.consistency == "fallback" and o.min_iterations <= o.consistency_after < o.max_iterations):
        return _with_remainder(_search(f1, f2, tau, o, scores), o.max_iterations, f1, f2, tau, o, scores, by_scores=True), {}
    first = _search(f1, f2, tau, o, scores, max_iterations=o.consistency_after)
    needed = float(first.stats.get("needed", np.inf))
    if first.num_iterations < o.consistency_after or needed <= o.consistency_after:  # converged in the first stage
        return _with_remainder(first, o.max_iterations, f1, f2, tau, o, scores, by_scores=True), {}
    # the second search's budget: the rest of max_iterations, but not past the draws the first search's
    # stopping rule asked for (the plain search would have ended there unless it found a better model)
    budget = o.max_iterations - o.consistency_after
    if np.isfinite(needed):
        budget = min(budget, max(o.consistency_min_draws, int(np.ceil(needed)) - o.consistency_after))
    second = _search(f1, f2, tau, o, consistency_order_scores(f1, f2, scores, o.consistency_k), True, budget)
    second = _with_remainder(second, budget, f1, f2, tau, o, scores)
    r = _combined(first, second, o.rival_distance)
    return r, {"consistency": "fallback" if r.score < first.score else "fallback-unused"}


def _better_rival(R: np.ndarray, t: np.ndarray, f1: np.ndarray, f2: np.ndarray, tau: float, diag: dict[str, Any]) -> tuple[np.ndarray, np.ndarray]:
    """The search's pose, or a rival that beats it: a better cheirality-aware MSAC score at ``tau`` and
    significantly more matches of its own (the uniqueness test's sign test the other way round, at
    :data:`poseonly.analysis.AMBIGUITY_LEVEL`).

    The rivals (``diag["rivals"]``) are refined after the search, which ranked them unrefined: a refined
    rival can be the better model by the search's own objective (a VO trial with ``challengers=0``: the
    pose 5.2 deg off returned `ambiguous`, the rival 0.1 deg off explaining 165 matches the pose did not
    against 96). The score alone swapped too often on the temple's few, narrow matches (AUC@10 88.35 ->
    88.11 over three seeds), where the two are about equal. The better one is returned and the other
    takes its place among the rivals, for the uniqueness test of :func:`poseonly.status.finish`
    (``diag["rival_swapped"]``; the rivals are then ordered by that score, best first, and
    ``diag["rival_support_ratio"]`` is the best rival's score over the returned pose's;
    ``diag["ransac_score"]`` stays the search's own)."""
    rivals = list(diag["rivals"])
    best = msac_chiral(R, t, f1, f2, tau)
    support = [msac_chiral(Rv, tv, f1, f2, tau) if valid_pose(Rv, tv) else -np.inf for Rv, tv in rivals]
    swapped = False
    c = np.ascontiguousarray
    for k, (Rv, tv) in enumerate(rivals):
        s = support[k]
        if not (np.isfinite(best) and s > best):
            continue
        _, _, only_pose, only_rival = _core.compare_support(c(R), c(t), c(Rv), c(tv), c(f1), c(f2), min(float(tau), MAX_SUPPORT_THRESHOLD), far_neutral=True)
        if sign_test(only_rival, only_pose) < np.log10(AMBIGUITY_LEVEL):
            rivals[k], (R, t), support[k], best, swapped = (R, t), (Rv, tv), best, s, True
    if swapped:
        # the rivals best first again, and the support ratio of the best one to the returned pose
        # (the search's ratio compared its own, unrefined models)
        order = sorted(range(len(rivals)), key=lambda k: -support[k])
        rivals = [rivals[k] for k in order]
        ratio = support[order[0]] / best if best > 0 and np.isfinite(support[order[0]]) else 0.0
        diag.update(rivals=rivals, rival_R=rivals[0][0], rival_t=rivals[0][1], rival_swapped=True, rival_support_ratio=float(max(ratio, 0.0)))
    return R, t


FULL_RANGE = 0.1  # radians: the outlier range of the full-range likelihood that compares EM fixed points


def full_range_log_likelihood(R: np.ndarray, t: np.ndarray, f1: np.ndarray, f2: np.ndarray, T: float, steps: int = 200) -> float:
    """max over (sigma, g) of sum_i log(g N+(r_i; sigma) + (1 - g) / FULL_RANGE), r_i the Sampson errors
    of every match clipped at FULL_RANGE (EM from the MAD and the share of the errors below T): one
    likelihood for every pose, unlike the ML stage's, whose mixture lives on the errors below its range."""
    r = np.minimum(v_sampson.unchecked(R, t, f1, f2), FULL_RANGE)
    near = r < T
    if np.count_nonzero(near) < ML_MIN_NEAR:
        return -np.inf
    s = max(MAD_TO_SIGMA * median(r[near]), 1e-12)
    g = min(max(float(np.mean(near)), 1e-9), 1 - 1e-9)
    for _ in range(steps):
        fin = np.sqrt(2 / np.pi) / s * np.exp(-0.5 * (r / s) ** 2)
        p = g * fin / (g * fin + (1 - g) / FULL_RANGE)
        sp = float(np.sum(p))
        if not sp > 0:
            break
        s = max(float(np.sqrt(np.sum(p * r * r) / sp)), 1e-12)
        g = min(max(sp / len(r), 1e-9), 1 - 1e-9)
    fin = np.sqrt(2 / np.pi) / s * np.exp(-0.5 * (r / s) ** 2)
    return float(np.sum(np.log(g * fin + (1 - g) / FULL_RANGE)))


def _collapsed(m: dict[str, Any], f1: np.ndarray, f2: np.ndarray, T: float) -> bool:
    """EM ran and its Gaussian sigma is below ``ML_COLLAPSE`` times the robust scale of its pose's
    errors (see there; fewer than 6 errors below T / 2 count as a collapse)."""
    if not m["rounds"] > 0:
        return False
    if not np.all(np.isfinite(m["R"])) or not np.all(np.isfinite(m["t"])):
        return True
    r = v_sampson.unchecked(m["R"], m["t"], f1, f2)
    near = r[r < 0.5 * T]
    if near.size < ML_MIN_NEAR:
        return True
    return not m["sigma_gauss"] >= ML_COLLAPSE * MAD_TO_SIGMA * median(near)


def _settled_on_a_subset(m: dict[str, Any], f1: np.ndarray, f2: np.ndarray, T: float) -> bool:
    """EM ran (to a finite pose) and its decision threshold lies inside the noise around its pose
    (:func:`_decision_inside_noise`)."""
    if not (m["rounds"] > 0 and np.all(np.isfinite(m["R"])) and np.all(np.isfinite(m["t"]))):
        return False
    return _decision_inside_noise(m, v_sampson.unchecked(m["R"], m["t"], f1, f2), f1, f2, T)


def _decision_inside_noise(m: dict[str, Any], r: np.ndarray, f1: np.ndarray, f2: np.ndarray, T: float) -> bool:
    """The Gaussian mixture's decision threshold (its p = 1/2 point) is below the noise scale of the
    matches within ``COLLAPSE_BAND * T`` of the pose (the truncated-median scale of the status's noise
    check, :func:`poseonly.analysis.pose_uncertainty`; at least ``COLLAPSE_BAND_MIN`` matches): EM fitted
    a tight subset and calls most of the pose's own inliers outliers. A healthy fit's decision lies 1.4-5
    noise scales out (the real benchmark's 401 `ok` pairs, seed 0: 1.37 at least); at 80 % outliers
    (synthetic, 1 px noise, 150 scenes) 14 wide-camera poses fell inside, their median rotation error
    0.231 deg against 0.075 for the others and 4.4 deviations (1.7), and EM from the band's refit
    (``ml_start="band"``, what a collapse runs) took them to 0.095 deg (a COLMAP user's trial: a small
    pair `ok` 0.62 deg off with 24 inliers within 0.41 px where the band's noise was 0.68 px)."""
    band = r < COLLAPSE_BAND * T
    if np.count_nonzero(band) < COLLAPSE_BAND_MIN:
        return False
    c = np.ascontiguousarray
    try:
        R, t = c(m["R"], dtype=float), c(m["t"], dtype=float)
        scale = _core.pose_covariance(R, t, c(f1, dtype=float), c(f2, dtype=float), band.astype(float), threshold=float(COLLAPSE_BAND * T))[2]
    except ValueError:  # a pose the core does not take as one (R not a rotation to its tolerance, t zero): no scale
        return False
    return bool(np.isfinite(scale) and m["decision_gauss"] < scale)


def _ml_from(
    R: np.ndarray, t: np.ndarray, f1: np.ndarray, f2: np.ndarray, T: float, student: bool, scales: np.ndarray | None, start: str, noise_floor: float = 0.0
) -> dict[str, Any]:
    """``_core.ml_refine`` from the chosen pose (``start="search"``), from the band's least-squares refit
    (``"band"``, ``MlOptions::band_start``) or from both with the larger :func:`full_range_log_likelihood`
    kept (``"both"``; the last two are studies, not the default). A collapsed EM is not an estimate: it
    is run once more from the band's refit, and if that collapses too it is marked not run (``rounds = 0``:
    the caller keeps the chosen pose). An EM that settled on a subset (:func:`_settled_on_a_subset`) is
    run once more from the band's refit too, and the band's fit replaces it where it did not; where both
    settled so, the first is kept as before that check (dropping the stage put back the search's pose
    at the user's threshold, which the status's noise check then passed, 11 deg off, at 4 px noise under
    the 1 px threshold: `tests/test_pose_uncertainty.py::test_noise_above_the_threshold_is_not_ok`)."""

    def run(band: bool) -> dict[str, Any]:
        return _core.ml_refine(R, t, f1, f2, T, rounds=ML_ROUNDS, pose_tol=ML_POSE_TOL, student=student, scales=scales, band_start=band, noise_floor=noise_floor)

    ms = run(False) if start != "band" else None
    cs = ms is not None and _collapsed(ms, f1, f2, T)
    ss = ms is not None and not cs and _settled_on_a_subset(ms, f1, f2, T)
    mb = run(True) if ms is None or start == "both" or cs or ss else None
    cb = mb is not None and _collapsed(mb, f1, f2, T)
    sb = mb is not None and not cb and _settled_on_a_subset(mb, f1, f2, T)
    ok = [m for m, c, sub in ((ms, cs, ss), (mb, cb, sb)) if m is not None and m["rounds"] > 0 and not c and not sub]
    if not ok:  # no fit free of both: the first that did not collapse, as before the subset check
        ok = [m for m, c in ((ms, cs), (mb, cb)) if m is not None and m["rounds"] > 0 and not c][:1]
    if not ok:
        m = ms if ms is not None else mb
        assert m is not None
        m["rounds"] = 0
        return m
    if len(ok) == 1 or start == "search":
        return ok[0]
    return max(ok, key=lambda m: full_range_log_likelihood(m["R"], m["t"], f1, f2, T))


def _ml_stage(
    R: np.ndarray,
    t: np.ndarray,
    f1: np.ndarray,
    f2: np.ndarray,
    tau: float,
    T: float,
    student: bool = True,
    scales: np.ndarray | None = None,
    start: str = "search",
    info: dict[str, Any] | None = None,
    noise_floor: float = 0.0,
) -> tuple[np.ndarray, np.ndarray, dict[str, Any]] | None:
    """The ML pose from the search's ``(R, t)`` (outlier range ``T``), or None when EM did not run
    (``info["sigma_start"]``, if given, gets EM's start scale either way)
    or its pose loses more than ``1 - ML_KEEP_TOLERANCE`` of the cheirality-aware MSAC score at the
    larger of ``tau`` and the mixture's decision threshold (the truncated score at a tight tau
    favours the pose fitted to that truncation)."""
    m = _ml_from(R, t, f1, f2, T, student, scales, start, noise_floor)
    if info is not None:
        info["sigma_start"] = float(m["sigma_start"])
    if not (m["rounds"] > 0 and m["decision_gauss"] > 0 and np.all(np.isfinite(m["R"]))):
        return None
    thr = max(tau, float(m["decision_gauss"]))
    if msac_chiral(m["R"], m["t"], f1, f2, thr) < ML_KEEP_TOLERANCE * msac_chiral(R, t, f1, f2, thr):
        return None
    return m["R"], m["t"], m


def _cross_fit(
    R: np.ndarray,
    t: np.ndarray,
    f1: np.ndarray,
    f2: np.ndarray,
    T: float,
    decision: float,
    student: bool,
    scales: np.ndarray | None,
    folds: int,
    tails: tuple[float, float] | None = None,
    start: tuple[float, float] | None = None,
    noise_floor: float = 0.0,
) -> tuple[np.ndarray, np.ndarray, int, np.ndarray] | None:
    """The ML pose without the inliers the cross-fit vetoes, from the ML pose ``(R, t)``; or None.

    Returns ``(R, t, vetoed, veto)``: the pose, the number of the ML pose's inliers the cross-fit removed
    (``(R, t, 0, ...)`` unchanged when it removes none) and their mask ``(n,)``.

    The ML pose decides its own inliers: a pose free to move along a weakly constrained direction (low
    parallax, a narrow field of points) can pick up a few outliers that happen to lie near its epipolar
    lines, and every such match raises the mixture likelihood more than the inliers' small loss of fit
    costs (the maximum of the likelihood, not the truth). Cross-fitting decides each match without its
    own influence: the matches are split into ``folds`` interleaved folds (``i % folds``); EM on all the
    other folds (from ``(R, t)``) gives the pose that classifies fold j, a match being an inlier when its
    Sampson error there is below ``decision`` (the Gaussian mixture's p = 1/2 point at the ML pose); an
    outlier joins only by chance, at the rate of a pose that was not fitted to it. The cross-fit is a
    veto: a match is removed when the ML pose calls it an inlier and the held-out pose does not, and the
    returned pose is EM from ``(R, t)`` on every other match. The mixture keeps modelling the outliers
    and the inliers' tail (EM on the cross-fitted inliers alone fits the mixture to truncated errors:
    at 0 % outliers 1.065 / 1.053x the synthetic floor against 1.032 / 1.018x with the veto, wide /
    pinhole; docs/history/RESULTS_real_sessions.md, thirteenth session). Measured on the synthetic hard cases
    (0.3 px noise, 40 scenes each, ``benchmarks/hard_cases.py``): the ML pose's inliers held 2.7 / 2.3 /
    1.7 / 5.4 outliers (low parallax 0.75 / 1.5 deg, repetitive texture, second motion) against PoseLib's
    1.1 / 1.0 / 1.2 / 5.2, and least squares on the true inliers from the ML pose reaches the noise floor
    (the objective, not the optimiser, chose the wrong pose). Five folds (the default) were decided on
    the real pairs and the seeded low-parallax test (docs/history/RESULTS_real_sessions.md, twelfth session);
    two leave too few matches per fold on small pairs.

    ``start = (sigma, g)``: the ML stage's noise scale and inlier share on all matches, where each
    fold's EM starts (the same fixed point as from its own robust start, to ~1e-8 in the pose, in a
    third fewer E-steps); only the folds' poses are computed (``pose_only``). One core call
    (``_core.ml_cross_fit``, GIL released; the Python version it replaced is tests/reference/cross_fit.py,
    the same pose bit for bit)."""
    nu, alpha = tails if tails is not None else (None, None)
    s0, g0 = start if start is not None and np.isfinite(start[0]) and start[0] > 0.0 and 0.0 < start[1] < 1.0 else (None, None)
    c = np.ascontiguousarray
    Rc, tc, vetoed, ok, veto = _core.ml_cross_fit(
        c(R),
        c(t),
        c(f1),
        c(f2),
        T,
        decision,
        folds=folds,
        min_agree=CROSS_FIT_MIN,
        student=student,
        scales=None if scales is None else c(scales),
        nu=nu,
        alpha=alpha,
        sigma_init=s0,
        g_init=g0,
        fold_rounds=CF_ROUNDS,
        fold_lm_iterations=CF_LM_ITERATIONS,
        fold_pose_tol=CF_POSE_TOL,
        final_rounds=ML_ROUNDS,
        final_lm_iterations=ML_LM_ITERATIONS,
        final_pose_tol=ML_POSE_TOL,
        noise_floor=noise_floor,
    )
    if not ok:
        return None
    if vetoed == 0:
        return R, t, 0, veto.astype(bool)
    return Rc, tc, int(vetoed), veto.astype(bool)


def leverage_test(
    R: np.ndarray,
    t: np.ndarray,
    f1: np.ndarray,
    f2: np.ndarray,
    m: dict[str, Any],
    T: float,
    student: bool,
    scales: np.ndarray | None,
    max_leverage: float,
    diag: dict[str, Any],
    excluded: np.ndarray | None = None,
    noise_floor: float = 0.0,
) -> tuple[np.ndarray, np.ndarray, int] | None:
    """The ML pose without the inliers it cannot vouch for, from the ML (or cross-fitted) pose ``(R, t)``
    whose EM result is ``m``; None where nothing is vetoed or the refit fails.

    An inlier of high leverage (``_core.leverage_veto``: the least-squares fit of the inliers absorbs
    more than ``max_leverage`` of its residual) is judged by the fit of the other inliers, as a
    prediction: the Gaussian decision threshold widened by that fit's uncertainty at the match
    (``decision sqrt(1 + J H^-1 J^T)``). Its own residual cannot show that it is wrong: where the
    translation is weakly constrained (a short baseline), two or three wrong matches of large parallax
    lying near the epipolar lines of some direction pull the translation onto it and fit it exactly (a
    SLAM user's trial: leverages 0.96 and 0.98, the translation 5 deg off with a deviation of 0.04
    deg); the cross-fit's folds split them, and each fold's pose is still held by the others. The
    refit is EM from ``(R, t)`` on every other match (less those the cross-fit removed, ``excluded``,
    which the pose's own EM did not see either) with ``m``'s inlier model, kept unless it loses
    more than ``1 - ML_KEEP_TOLERANCE`` of the cheirality-aware MSAC score at the decision threshold
    against ``(R, t)`` (the cross-fit compares with the search's pose at the larger of the search
    threshold and the decision; here both poses are ML fits of the same mixture). Returns ``(R, t,
    vetoed)``; ``diag`` gets the group's size and the others' fit (``leverage_others_R``, ``_t``), whose
    distance from the returned pose :func:`poseonly.status.finish` adds to the covariance."""
    c = np.ascontiguousarray
    decision = float(m["decision_gauss"])
    if not decision > 0 or not valid_pose(R, t):  # (a search that scored no hypothesis leaves a placeholder R; the fuzz)
        return None
    inl = v_sampson.unchecked(R, t, f1, f2) < decision
    out = np.zeros(len(f1), bool) if excluded is None else np.asarray(excluded, bool)
    inl &= ~out
    _, veto, group, tested, R_others, t_others = _core.leverage_veto(c(R), c(t), c(f1), c(f2), inl, decision, float(max_leverage))
    if not tested:
        return None
    diag["leverage_group"] = int(np.count_nonzero(group))
    others = (R_others, t_others, (inl & (group == 0)).astype(float), decision)
    if not veto.any():
        diag.update(_leverage_spread(R, t, f1, f2, others, noise_floor))
        return None
    keep = (veto == 0) & ~out  # the refit sees what the pose's own EM saw, less the vetoed matches
    r = _core.ml_refine(
        c(R),
        c(t),
        c(f1[keep]),
        c(f2[keep]),
        T,
        rounds=ML_ROUNDS,
        pose_tol=ML_POSE_TOL,
        student=student,
        scales=None if scales is None else c(scales[keep]),
        nu=float(m["nu"]),
        alpha=float(m["alpha"]),
        noise_floor=noise_floor,
    )
    if not (r["rounds"] > 0 and np.all(np.isfinite(r["R"])) and np.all(np.isfinite(r["t"]))):
        return None
    thr = decision
    if msac_chiral(r["R"], r["t"], f1, f2, thr) < ML_KEEP_TOLERANCE * msac_chiral(R, t, f1, f2, thr):
        diag.update(_leverage_spread(R, t, f1, f2, others, noise_floor))
        return None
    diag.update(_leverage_spread(r["R"], r["t"], f1, f2, others, noise_floor))
    return r["R"], r["t"], int(np.count_nonzero(veto))


# the leverage spread's gate on the rotation: chi-square at 95 % with 3 degrees of freedom
LEVERAGE_SPREAD_CHI2_R = 7.81


def _leverage_spread(
    R: np.ndarray, t: np.ndarray, f1: np.ndarray, f2: np.ndarray, others: tuple[np.ndarray, np.ndarray, np.ndarray, float], noise_floor: float = 0.0
) -> dict[str, float]:
    """The distances (degrees) of the returned pose ``(R, t)`` from the least-squares fit of the inliers
    without the high-leverage group (``others``: its ``R, t``, the mask of its matches and the decision
    threshold that selected them), which :func:`poseonly.status.finish` adds to the covariance: the group's
    matches, whose residuals cannot vouch for them, may be wrong. The translation direction's always; the
    rotation's where significant, beyond the chi-square gate of the others' fit's own first-order
    covariance (``poseonly.analysis.pose_uncertainty``'s), else 0: the rotation decides the status, and
    where the group is right its pull lies within that precision (ungated, five well-posed temple pairs,
    0.2-2.4 deg off, became `uncertain`)."""
    Ro, to, mask, decision = others
    out = {"leverage_spread_deg": 0.0, "leverage_translation_spread_deg": 0.0}
    if not (np.all(np.isfinite(Ro)) and np.all(np.isfinite(to))):
        return out
    u, uo = t / np.linalg.norm(t), to / np.linalg.norm(to)
    # the translation direction's always (sign-free, as the Sampson errors): it is what a short baseline
    # leaves to a few matches (the trial's 46 % of `ok` poses beyond three deviations at a 0.05 baseline
    # fall to 8 % with it, stay at 31 % with the gate; benchmarks/leverage_study.py), and the status does
    # not read it
    out["leverage_translation_spread_deg"] = float(np.degrees(np.arccos(np.clip(abs(np.dot(u, uo)), 0.0, 1.0))))
    c = np.ascontiguousarray
    Cr, _, _, _, ok = _core.pose_covariance(c(Ro), c(to), c(f1), c(f2), mask, threshold=float(decision), noise_floor=noise_floor)
    w = rotvec_from_rotation(R @ Ro.T)  # the left perturbation exp([w]x) Ro = R, as the covariance's
    if ok and float(w @ np.linalg.pinv(Cr) @ w) > LEVERAGE_SPREAD_CHI2_R:
        out["leverage_spread_deg"] = float(np.degrees(np.linalg.norm(w)))
    return out


def run_poseonly(
    f1: np.ndarray, f2: np.ndarray, o: PoseonlyOptions, tau: float, scores: np.ndarray | None = None, noise_scales: np.ndarray | None = None, noise_floor: float = 0.0
):
    """The default method; returns ``(R, t, weights | None, iterations, diagnostics)``. ``noise_floor``
    (radians): the least noise scale of the ML stage, the cross-fit and the leverage test (the input's
    rounding, :mod:`poseonly.quantization`).

    1. LO-RANSAC in the core (``poseonly.robust.ransac.ransac_relpose``): minimal hypotheses, MSAC-type
       scoring of the Sampson error at ``tau`` with an exact bail-out, at least ``min_iterations``
       samples and adaptive stopping at ``confidence``, PROSAC order when ``scores`` are given, LO of
       every new best model, and at the end LO of the best models of up to ``challengers`` other
       basins, one of which replaces the best if it beats it (a raw model of the right basin can
       score worse than an optimised model of a wrong consensus, and would never be optimised);
    2. the pose-only choice among the RANSAC model (re-identified on its inliers), its homography twin
       and the LiRP candidates of its consensus set, by cheirality-consistent support
       (:func:`select_by_support`: the Sampson score cannot tell a planar scene's twin from the truth,
       depth signs can);
    3. ``final="ml"``: the ML pose under a mixture of inlier and uniform outlier Sampson errors
       (``poseonly._core.ml_refine``: EM with the noise scale estimated, outliers uniform up to
       ``ml_range * tau``; ``ml_tails="student"``: the inliers' errors Student-t with the degrees of
       freedom chosen by the profile likelihood, the Gaussian among the choices, since real match
       errors are heavy-tailed; ``"gauss"``: MLESAC's Gaussian), kept if its cheirality-aware MSAC
       score at the larger of ``tau`` and the mixture's decision threshold does not drop by more
       than 2 %; EM runs to its fixed point (at most ``ML_ROUNDS`` rounds); the returned inliers are
       those more likely inliers than not under the Gaussian mixture fitted at the ML pose (the t's
       own p = 1/2 point lies far out in its tail). With ``noise_scales`` (each match's relative
       localisation scale, e.g. ``sqrt(size1 size2)`` of its SIFT keypoints) a match's inlier scale is
       ``sigma c_i^alpha`` (``c_i`` its scale over the median), ``alpha`` in {0, 1/2, 1} chosen with
       the degrees of freedom by the profile likelihood (0: the scales explain nothing); the inliers
       and the status analysis keep the Gaussian mixture without the scales;
       then (``ml_folds > 1``) the inliers cross-fitted: each match classified by the ML pose of the
       other folds, and EM on that set (:func:`_cross_fit`; the ML pose deciding its own inliers picks
       up outliers near its epipolar lines where the pose is weakly constrained); then (``max_leverage
       < 1``) the inliers of high leverage judged by the fit of the others and the pose refitted without
       those it rejects (:func:`leverage_test`: a few wrong matches of large parallax can hold a short
       baseline's translation and fit it exactly, where the folds split them);
       ``final="ligt"`` (the earlier default): LO at a noise-matched threshold, then angular LiGTopt;
       ``final="cauchy"`` (PoseLib's final step, for comparisons): Sampson LM with a Cauchy loss at
       ``tau`` on the matches within ``tau`` of the chosen pose;
    4. (``final="ml"``, opt-in: ``research_noise > 0``) when the noise scale (EM's sigma, or its
       start where EM shrank onto a few matches) exceeds ``research_noise * tau`` (the matches are
       noisier than the threshold assumes: at 1 px on 1 px noise the search scores a third of the
       inliers out and its pose sits in the basin of the rest), steps 1-3 again at ``3 sigma`` (at
       most the mixture's range), whose result is returned. Measured (docs/RESULTS.md section 2,
       ``benchmarks/research_study.py``): better at 80 % outliers, worse at 0-50 %, neutral on real
       pairs (sigma ~0.15-0.35 px at 1 px triggers it on 6 of 424), hence off by default.
    """
    r, order_diag = search(f1, f2, tau, o, scores)
    num_hyp = r.num_iterations * MAX_ROOTS_PER_SAMPLE + r.num_lo + FINAL_CANDIDATES
    diag: dict[str, Any] = {"num_lo": r.num_lo, "ransac_score": r.score, "num_scored": r.num_scored, "num_hypotheses": num_hyp, **order_diag}
    if o.challengers:
        diag.update(num_challenger_lo=int(r.stats["num_challenger_lo"]), challenger_won=bool(r.stats["challenger_won"]))
        diag["num_hypotheses"] += int(r.stats["num_challenger_lo"])
    if o.rival_distance > 0 and np.isfinite(float(r.stats.get("rival_cost", np.inf))):
        # the uniqueness test's rivals (decided in poseonly.status.finish): the best model the search
        # scored rival_distance or more from its result and the other basins it optimised, each
        # refined as the result was
        diag["rival_support_ratio"] = rival_support_ratio(r, len(f1), tau, o.scoring)
        rivals = [local_optimization(Rv, tv, f1, f2, tau, o) for Rv, tv in rival_candidates(r, o.rival_distance)[: o.rivals]]
        diag.update(rival_R=rivals[0][0], rival_t=rivals[0][1], rival_distance=float(o.rival_distance), rivals=rivals)
    R, t = select_by_support(r.R, r.t, f1, f2, tau)
    if o.rival_distance > 0 and r.num_scored > 0 and valid_pose(r.R, r.t) and _model_distance_deg(R, t, r.R, r.t) > o.rival_distance:
        # the pose-only choice left the search's basin: the search's own result, the best model by the
        # search's objective, is a rival of the pose returned (on points near a critical surface the
        # re-solve on the consensus set can jump to the other solution, and the uniqueness test then
        # never saw the search's pose)
        own = local_optimization(r.R, r.t, f1, f2, tau, o)
        rivals = [own, *diag.get("rivals", [])]
        diag.update(rival_R=own[0], rival_t=own[1], rival_distance=float(o.rival_distance), rivals=rivals, rival_search_own=True)
        s_pose, s_own = msac_chiral(R, t, f1, f2, tau), msac_chiral(own[0], own[1], f1, f2, tau)
        ratio = s_own / s_pose if s_pose > 0 and np.isfinite(s_own) else 0.0
        diag["rival_support_ratio"] = float(max(diag.get("rival_support_ratio", 0.0), ratio, 0.0))
    if diag.get("rivals"):
        R, t = _better_rival(R, t, f1, f2, tau, diag)
    if o.final == "cauchy":
        diag["tau_effective"] = tau
        if o.refine:
            inl = v_sampson.unchecked(R, t, f1, f2) < tau
            if np.count_nonzero(inl) >= 6:
                c = np.ascontiguousarray
                Rc, tc, _ = _core.refine_sampson(c(R), c(t), c(f1[inl]), c(f2[inl]), None, loss="cauchy", loss_scale=float(tau), max_iterations=100, tol=1e-12)
                if np.all(np.isfinite(Rc)) and np.all(np.isfinite(tc)):
                    R, t = Rc, tc
                    diag["sampson_final"] = True  # the pose is a Sampson fit: no estimator spread (status.finish)
        return R, t, None, r.num_iterations, diag
    if o.final == "ml":
        diag["tau_effective"] = tau
        iterations = r.num_iterations
        if o.refine:
            T = float(o.ml_range) * tau
            student = o.ml_tails == "student"
            ml_info: dict[str, Any] = {}
            best = _ml_stage(R, t, f1, f2, tau, T, student, noise_scales, o.ml_start, ml_info, noise_floor)
            tau_used, T_used = tau, T
            # noise scale: the Gaussian mixture's sigma at the ML pose, or EM's start (the MAD at the
            # chosen pose) where EM shrank sigma onto the few matches a pose can fit exactly (or
            # collapsed and was not used)
            sig = max(best[2]["sigma_gauss"], best[2]["sigma_start"]) if best is not None else ml_info.get("sigma_start", 0.0)
            if o.research_noise > 0 and sig > o.research_noise * tau:
                # the matches are noisier than the threshold assumes: the search scored a part of the
                # inliers and its pose sits in that part's basin. Search again at 3 sigma (at most the
                # mixture's range, so outliers cannot widen it further), as if the user had set it.
                tau2 = min(RESEARCH_SIGMAS * sig, T)
                r2, order_diag2 = search(f1, f2, tau2, o, scores)
                diag.pop("consistency", None)
                diag.update(order_diag2)
                iterations += r2.num_iterations
                diag["num_hypotheses"] += r2.num_iterations * MAX_ROOTS_PER_SAMPLE + r2.num_lo + FINAL_CANDIDATES
                R2, t2 = select_by_support(r2.R, r2.t, f1, f2, tau2)
                diag.update(research_threshold=tau2, tau_effective=tau2)
                second = _ml_stage(R2, t2, f1, f2, tau2, float(o.ml_range) * tau2, student, noise_scales, o.ml_start, noise_floor=noise_floor)
                R, t, best = R2, t2, second
                tau_used, T_used = tau2, float(o.ml_range) * tau2
            if best is not None:
                R0, t0 = R, t
                R, t, m = best
                # the ML pose (or the cross-fit's EM pose below) is a Sampson fit: no estimator spread
                # (status.finish); without it the pose is the pose-only choice's, which may be algebraic
                diag["sampson_final"] = True
                excluded = None  # the matches the cross-fit removed (its pose's EM did not see them)
                if o.ml_folds > 1:
                    tails, start = (float(m["nu"]), float(m["alpha"])), (float(m["sigma"]), float(m["inlier_fraction"]))
                    cf = _cross_fit(R, t, f1, f2, T_used, float(m["decision_gauss"]), student, noise_scales, int(o.ml_folds), tails, start, noise_floor)
                    thr = max(tau_used, float(m["decision_gauss"]))
                    diag["cross_fit"] = cf is not None and msac_chiral(cf[0], cf[1], f1, f2, thr) >= ML_KEEP_TOLERANCE * msac_chiral(R0, t0, f1, f2, thr)
                    if diag["cross_fit"]:
                        assert cf is not None
                        R, t, diag["cross_fit_vetoed"], excluded = cf
                if o.max_leverage < 1.0:
                    lv = leverage_test(R, t, f1, f2, m, T_used, student, noise_scales, o.max_leverage, diag, excluded, noise_floor)
                    if lv is not None:
                        R, t, diag["leverage_vetoed"] = lv
                # the inliers: more likely inliers than not under the Gaussian mixture at the ML pose
                # (the t's heavy tail puts its own p = 1/2 point far out)
                diag.update(
                    tau_effective=float(m["decision_gauss"]),
                    ml_decision=float(m["decision"]),
                    sigma=float(m["sigma"]),
                    sigma_gauss=float(m["sigma_gauss"]),
                    ml_nu=float(m["nu"]),
                    ml_alpha=float(m["alpha"]),
                    ml_rounds=int(m["rounds"]),
                    ml_inlier_fraction=float(m["inlier_fraction"]),
                )
        return R, t, None, iterations, diag
    thr = noise_threshold(R, t, f1, f2, tau, o)
    R, t = keep_better((R, t), local_optimization(R, t, f1, f2, thr, o), f1, f2, thr)
    if o.refine:
        ref = refine_ligt(R, t, f1, f2, support(R[None], t[None], f1, f2, thr)[0], thr, normalization="angular")
        R, t = keep_better((R, t), ref, f1, f2, thr, tol=LIGT_KEEP_TOLERANCE)
    diag["tau_effective"] = thr
    return R, t, None, r.num_iterations, diag
