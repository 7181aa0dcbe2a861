"""Analysis of a final model: cheirality-consistent support, planar twin, pure rotation, chance inliers.

Everything the status decision (:mod:`poseonly.result`) needs to know about a pose besides its own
inliers: whether the homography twin (the core's ``analyse_twin``) explains the data about as well
(planar scene), whether a rotation without translation does (pure rotation), and how many inliers
the pose would collect by chance. Shapes: bearings ``f1, f2 (n, 3)`` (unit), ``R (3, 3)`` or
stacked ``(h, 3, 3)``, ``t (3,)`` or ``(h, 3)``; ``tau`` is an angle (radians).
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from typing import Any

import numpy as np

from . import _core
from .geometry import rotation_error_deg
from .median import median
from .residuals import v_sampson, v_sampson_chiral

__all__ = [
    "NFA_MAX",
    "POSE_DOF",
    "REFINE_SOLVER",
    "chance_inliers",
    "chance_rate",
    "log10_nfa",
    "log_binom_sf",
    "far_angle",
    "parallax_deg",
    "parallax_ratio",
    "planar_twin",
    "pose_uncertainty",
    "pure_rotation_test",
    "rival_test",
    "sign_test",
    "robust_rotation",
    "support",
]

# LiGTopt's optimiser inside the robust methods: the compact LM of poseonly.refine.ligt (same
# objective as scipy's least_squares, ~10-20x less time per call; docs/RESULTS.md section 2)
REFINE_SOLVER = "lm"
# the pose's degrees of freedom: the a-contrario test discounts this many inliers (a pose fits any
# 5 matches exactly), and a pose fitted to k matches leaves k - POSE_DOF for their noise variance
POSE_DOF = 5
# a second pose (the planar twin, the search's rival) makes the pose ambiguous unless the pose explains
# significantly more matches of its own: McNemar's sign test on the matches only one of the two
# explains, one-sided at this level. At NFA_MAX instead, 3 of the 51 fountain-P11 pairs on which
# PoseLib is right (0.2-0.5 deg) would lose `ok` (docs/RESULTS_real.md)
AMBIGUITY_LEVEL = 0.05
# the twin is reported when its support reaches this fraction of the pose's, the sign test does not
# prefer the pose and it is more than TWIN_MIN_SEPARATION_DEG from the pose
TWIN_SUPPORT_RATIO = 0.9
# a twin this close to the pose does not make the pose ambiguous (whichever is right, the rotation is
# known to this accuracy); measured on temple's ring pairs 24-27: twins 0.3-2.1 deg off, poses 0.01-0.4
TWIN_MIN_SEPARATION_DEG = 1.0
# a twin as well supported whose summed squared errors exceed the pose's by at most this many noise
# variances (twin_cost_excess; chi-square with 5 degrees of freedom at 95 %) fits as well: its distance
# is part of the pose's uncertainty (poseonly.status.finish)
TWIN_SPREAD_CHI2 = 11.07
CHANCE_SEED = 20240611
# support counts cap the threshold here (radians; v_sampson_chiral is 1 where a depth is not positive)
MAX_SUPPORT_THRESHOLD = 0.5


def _c(a: np.ndarray) -> np.ndarray:
    return np.ascontiguousarray(a, dtype=float)


def support(R: np.ndarray, t: np.ndarray, f1: np.ndarray, f2: np.ndarray, tau: float) -> np.ndarray:
    """Inliers ``(h, n)`` of stacked poses ``(h,3,3), (h,3)``: Sampson error below ``tau`` and
    positive depths (``v_sampson_chiral`` is 1 where a depth is not positive, and ``tau`` is far
    below 1)."""
    return v_sampson_chiral.unchecked(R, t, f1, f2) < min(tau, MAX_SUPPORT_THRESHOLD)


def parallax_deg(R: np.ndarray, f1: np.ndarray, f2: np.ndarray, inl: np.ndarray) -> float:
    """Median angle (degrees) between ``R f1`` and ``f2`` over the inliers ``inl (n,)`` (NaN without
    any). One core call (numpy reference: tests/reference/status.py)."""
    return float(np.degrees(_core.median_rotation_angle(_c(R), _c(f1), _c(f2), np.ascontiguousarray(inl, dtype=bool))))


# the noise check of pose_uncertainty: the errors' scale over this many thresholds (truncation undone) must
# not exceed the threshold. Where the noise is above the threshold a robust pose fitted to a tight band
# pulls the errors inside it in (their median over the threshold 0.2-0.35 at the returned pose against
# 0.45-0.57 at the truth), so the band's own truncation test seldom fires; over twice the band the pull
# is weaker (docs/RESULTS_real.md, "Pose uncertainty")
NOISE_CHECK_BAND = 2.0
# ... on at least this many matches in the wide band (the truncated median's root is noisy on fewer: one
# right pose of 19 inliers at 1 px noise was flagged on the synthetic scenes)
NOISE_CHECK_MIN = 30


def pose_uncertainty(R: np.ndarray, t: np.ndarray | None, f1: np.ndarray, f2: np.ndarray, inl: np.ndarray, threshold: float = 0.0, noise_floor: float = 0.0) -> dict[str, Any]:
    """First-order covariance of the pose fitted to its inliers ``inl (n,)`` (Hartley and Zisserman,
    section 5.2.3): ``sigma^2 (J^T J)^-1``, ``J`` the Jacobian of the inliers' Sampson errors in the
    pose's five parameters (the core's ``pose_covariance``). The rotation's block has the translation
    direction marginalised: a rotation that trades against the translation (a narrow field of view, a
    small object turning in front of the camera) is known less well than the inlier count says.
    ``t = None``: a rotation without translation (the chord residuals ``R f1 - f2``).

    ``sigma`` comes from the median inlier error; ``threshold`` (radians; chords for ``t = None``) is the
    one that selected the inliers: their errors are a truncated sample, and sigma solves the truncated
    distribution's median (a tight threshold hides most of the noise: without this a threshold at the
    noise level gives 0.66x sigma), and the covariance has the factor ``k / (k - p)`` for the fit's ``p``
    parameters. Where the noise exceeds the threshold the robust pose is fitted to a tight band that
    pulls its errors in and the band's truncation test seldom fires: the errors' scale over
    ``NOISE_CHECK_BAND`` thresholds (>= ``NOISE_CHECK_MIN`` matches) must not exceed the threshold, else
    the noise is not resolved (inf deviations); that catches about half such poses, and the deviation of
    the others stays several times too small (docs/RESULTS_real.md, "Pose uncertainty"). Where it
    passes, that wider scale is a floor of ``sigma`` (the inliers' own is pulled in by the fit). The
    covariance describes a least-squares pose on these inliers at their noise; the calibration and the
    ground truth's own errors (0.01-0.05 deg on Strecha and KITTI) are not in it.

    Returns ``rotation_covariance (3, 3)`` (radians^2, the left perturbation ``exp([d]x) R``),
    ``translation_covariance (3, 3)`` (of the unit ``t``; rank 2, tangent to ``t``; None without ``t``),
    ``rotation_std_deg`` / ``translation_std_deg`` (the standard deviation along the least constrained
    axis, square root of the largest eigenvalue, in degrees) and ``noise_sigma`` (radians). ``inf``
    deviations (covariances None) where the inliers do not determine the pose (fewer than 6, 3 without
    ``t``, a singular information) or the threshold does not resolve their noise (``noise_sigma`` inf).
    ``noise_floor`` (radians): a finite ``sigma`` is at least this (the coordinates' rounding,
    :mod:`poseonly.quantization`)."""
    tt = None if t is None else _c(t)
    if threshold > 0:
        # is the noise within the threshold at all? its scale over twice the band (errors measured at the
        # pose itself: for a rotation-only fit, the chord |R f1 - f2|)
        e = v_sampson.unchecked(R, t, f1, f2) if t is not None else np.linalg.norm(f1 @ np.asarray(R).T - f2, axis=1)
        wide = NOISE_CHECK_BAND * threshold
        band = e < wide
        s_wide = _core.pose_covariance(_c(R), tt, _c(f1), _c(f2), band.astype(float), threshold=float(wide), noise_floor=noise_floor)[2]
        if np.count_nonzero(band) >= NOISE_CHECK_MIN:
            if not s_wide <= threshold:
                return {"rotation_covariance": None, "translation_covariance": None, "rotation_std_deg": np.inf, "translation_std_deg": np.inf, "noise_sigma": np.inf}
            # both estimate the noise where the threshold resolves it; the inliers' is pulled in by a pose
            # fitted to them (more so where the noise nears the threshold), the wide band's less: the
            # larger one is the noise scale (synthetic: median error / deviation 1.67 -> 1.44 with < 40
            # inliers, 5.8 -> 4.2 at noise above the threshold; docs/RESULTS_real.md, "Pose uncertainty").
            # Wrong matches inside the wide band raise it (conservative: at most the threshold, as the
            # check above bounds it). For chords s_wide is already the chord scale, which the core's floor
            # would multiply by sqrt(2) again (a review: pure rotations' sigma was sqrt(2) too large)
            noise_floor = max(noise_floor, float(s_wide) if t is not None else float(s_wide) / np.sqrt(2.0))
    Cr, Ct, sigma, _, ok = _core.pose_covariance(_c(R), tt, _c(f1), _c(f2), np.ascontiguousarray(inl, dtype=float), threshold=float(threshold), noise_floor=noise_floor)
    if not ok:
        return {"rotation_covariance": None, "translation_covariance": None, "rotation_std_deg": np.inf, "translation_std_deg": np.inf, "noise_sigma": float(sigma)}
    std_r = float(np.degrees(np.sqrt(max(float(np.linalg.eigvalsh(Cr)[-1]), 0.0))))
    std_t = float(np.degrees(np.sqrt(max(float(np.linalg.eigvalsh(Ct)[-1]), 0.0)))) if t is not None else float("nan")
    return {
        "rotation_covariance": Cr,
        "translation_covariance": Ct if t is not None else None,
        "rotation_std_deg": std_r,
        "translation_std_deg": std_t,
        "noise_sigma": float(sigma),
    }


def planar_twin(R: np.ndarray, t: np.ndarray, f1: np.ndarray, f2: np.ndarray, tau: float, inl: np.ndarray) -> tuple[tuple[np.ndarray, np.ndarray, int] | None, dict[str, Any]]:
    """The homography twin of ``(R, t)`` when it explains the data about as well (planar scene).

    The core (``_core.analyse_twin``; numpy reference: tests/reference/status.py) decomposes the
    homography of the dominant plane through the inliers ``inl (n,)`` (at least 6), screens the twin as
    the pose-only choice does (its support at 1.5 ``tau`` at least 30 % of the pose's: the twin of a
    non-planar scene keeps a few per cent, an unpolished planar twin 40-65 %), polishes it (angular
    LiGTopt, Cauchy loss at ``tau``, on its cheirality-consistent inliers at 1.5 ``tau``) and counts both
    poses' cheirality-consistent support at ``min(tau, 0.5)``. The twin is reported when its support reaches
    :data:`TWIN_SUPPORT_RATIO` of the pose's, the sign test does not prefer the pose at
    :data:`AMBIGUITY_LEVEL` and it is more than :data:`TWIN_MIN_SEPARATION_DEG` away.

    Returns ``(twin, info)``: ``twin = (R_twin, t_twin, support)`` or ``None``; ``info`` holds
    ``planarity`` and ``support``/``twin_support`` when a twin was polished.
    """
    info: dict[str, Any] = {}
    r = _core.analyse_twin(_c(R), _c(t), _c(f1), _c(f2), np.ascontiguousarray(inl, dtype=bool), float(tau))
    if r is None:
        return None, info
    if r[0] is not None:
        info["planarity"] = float(r[0])
    if r[1] is None:
        return None, info
    Rt, tt, (sup_pose, sup_twin, only_pose, only_twin) = r[1]
    lp = sign_test(only_pose, only_twin)
    sep = rotation_error_deg(R, Rt)
    info.update(support=int(sup_pose), twin_support=int(sup_twin), twin_log10_p=lp, twin_separation_deg=sep)
    ct = float(np.dot(tt, t)) / max(float(np.linalg.norm(tt) * np.linalg.norm(t)), 1e-300)
    info["twin_translation_separation_deg"] = float(np.degrees(np.arccos(np.clip(ct, -1.0, 1.0))))
    info["twin_cost_excess"] = twin_cost_excess(R, t, Rt, tt, f1[inl], f2[inl])
    if equally_supported_twin(info) and sep > TWIN_MIN_SEPARATION_DEG:
        return (Rt, tt, int(sup_twin)), info
    return None, info


def twin_cost_excess(R: np.ndarray, t: np.ndarray, R_twin: np.ndarray, t_twin: np.ndarray, f1: np.ndarray, f2: np.ndarray) -> float:
    """How much worse the twin fits the pose's inliers ``f1, f2 (k, 3)``: the difference of their summed
    squared Sampson errors over the noise variance the pose's own errors give (``k - POSE_DOF`` degrees of
    freedom), a likelihood-ratio statistic (about chi-square with a few degrees of freedom where the two
    models fit equally; inf below 6 inliers or without noise)."""
    k = len(f1)
    if k < 6:
        return float("inf")
    sp = float(np.sum(v_sampson.unchecked(R, t, f1, f2) ** 2))
    st = float(np.sum(v_sampson.unchecked(R_twin, t_twin, f1, f2) ** 2))
    if not sp > 0:
        return float("inf")
    return (st - sp) * (k - POSE_DOF) / sp


def equally_supported_twin(info: dict[str, Any]) -> bool:
    """Did :func:`planar_twin` (``info``) find a twin that explains the matches as well as the pose: its
    support at least :data:`TWIN_SUPPORT_RATIO` of the pose's and the sign test not preferring the pose
    at :data:`AMBIGUITY_LEVEL`, whatever its separation?"""
    if "twin_support" not in info:
        return False
    return bool(info["twin_support"] >= TWIN_SUPPORT_RATIO * info["support"] and info["twin_log10_p"] >= np.log10(AMBIGUITY_LEVEL))


def rival_test(R: np.ndarray, t: np.ndarray, R_rival: np.ndarray, t_rival: np.ndarray, f1: np.ndarray, f2: np.ndarray, tau: float, min_separation_deg: float) -> dict[str, Any]:
    """Does a second pose explain the matches as well as ``(R, t)`` (the uniqueness test)?

    ``(R_rival, t_rival)``: the best model the search scored at least ``min_separation_deg`` from
    its result, refined. Both poses' cheirality-consistent inliers at ``tau`` are compared on the
    matches only one of them explains: the pose is *ambiguous* when the rival is still more than
    ``min_separation_deg`` away in rotation after refinement and the sign test (:func:`sign_test`)
    does not prefer the pose at :data:`AMBIGUITY_LEVEL` (on temple's small narrow-view pairs two
    poses 45-150 deg apart share 13-16 of 18-22 inliers; refined rivals of sound poses mostly fall
    back into the pose's basin). A match whose rays are parallel to within the threshold under a pose
    (``|R f1 x f2|`` below it: a point at infinity within the noise) counts for that pose by its Sampson
    error alone: the signs of its depths are the noise's, and a forward-moving camera's far points
    triangulate behind the true pose about half the time while a rival of another rotation keeps its
    own (``far_neutral``; a SLAM trial's KITTI ORB pairs, 0.02 deg off, were called ambiguous).
    Returns ``rival_support``, ``rival_only``, ``pose_only``, ``rival_separation_deg``,
    ``rival_log10_p`` and ``ambiguous`` (bool)."""
    _, rival_support, only_pose, only_rival = _core.compare_support(
        _c(R), _c(t), _c(R_rival), _c(t_rival), _c(f1), _c(f2), min(float(tau), MAX_SUPPORT_THRESHOLD), far_neutral=True
    )
    sep = rotation_error_deg(R, R_rival)
    lp = sign_test(only_pose, only_rival)
    return {
        "rival_support": int(rival_support),
        "rival_only": only_rival,
        "pose_only": only_pose,
        "rival_separation_deg": sep,
        "rival_log10_p": lp,
        "ambiguous": bool(sep > min_separation_deg and lp >= np.log10(AMBIGUITY_LEVEL)),
    }


def sign_test(only_pose: int, only_other: int) -> float:
    """``log10`` p-value of McNemar's exact sign test that the pose explains more matches than another
    pose: among the ``only_pose + only_other`` matches exactly one of them explains, the chance that
    a fair coin gives the pose ``only_pose`` or more (``0`` when neither has any of its own)."""
    m = only_pose + only_other
    if m == 0:
        return 0.0
    return log_binom_sf(only_pose, m, 0.5) / float(np.log(10.0))


# ------------------------------------------------------------------------------------------------
# a-contrario significance (Moisan & Stival 2004; Moisan, Moulon, Monasse 2012 "AC-RANSAC")
#
# Under the random-match model a correspondence is an inlier of a fixed model with probability p,
# the model's chance rate, measured on randomly re-paired matches. Among N tested hypotheses, the
# expected number that collect k or more inliers of n by chance is at most N * P(Bin(n - s, p) >=
# k - s) (Bonferroni; s = minimal sample size, whose points are inliers by construction). A model
# is trusted only when this number of false alarms (NFA) is below NFA_MAX.

NFA_MAX = 1e-3
# re-paired matches used to measure a chance rate (at least CHANCE_MIN_REPEATS permutations)
CHANCE_PAIRS = 20000
CHANCE_MIN_REPEATS = 3
CHANCE_MAX_REPEATS = 200


@functools.lru_cache(maxsize=64)
def _permutations(n: int) -> np.ndarray:
    """The fixed re-pairings ``(reps, n)`` of ``n`` matches (seeded, so cached; read-only)."""
    rng = np.random.default_rng(CHANCE_SEED)
    reps = int(np.clip(np.ceil(CHANCE_PAIRS / max(n, 1)), CHANCE_MIN_REPEATS, CHANCE_MAX_REPEATS))
    # one call for all rows (a list of per-row permutations cost ~1 ms at n ~ 150, paid per new n)
    p = np.ascontiguousarray(rng.permuted(np.tile(np.arange(n, dtype=np.int64), (reps, 1)), axis=1))
    p.setflags(write=False)
    return p


def chance_rate(R: np.ndarray, t: np.ndarray, f1: np.ndarray, f2: np.ndarray, tau: float) -> float:
    """Probability that a randomly re-paired match is a Sampson inlier (``< tau``) of ``(R, t)``,
    with add-one smoothing (never 0). One core call over the cached re-pairings."""
    perms = _permutations(len(f1))
    t = np.asarray(t, dtype=float)
    t = t / max(float(np.linalg.norm(t)), 1e-300)
    hits = _core.chance_count(_c(R), _c(t), _c(f1), _c(f2), perms, float(tau))
    return float((hits + 1) / (perms.size + 2))


def chance_inliers(R: np.ndarray, t: np.ndarray, f1: np.ndarray, f2: np.ndarray, tau: float) -> float:
    """Expected inlier count of ``(R, t)`` on randomly re-paired matches (``n * chance_rate``)."""
    return len(f1) * chance_rate(R, t, f1, f2, tau)


def log_binom_sf(k: int, n: int, p: float) -> float:
    """``log P(Bin(n, p) >= k)`` by the core (log-sum-exp of the terms over a table of ``log j!``;
    exact to rounding, no underflow; scipy.stats is not imported because its import costs seconds;
    numpy reference: tests/reference/nfa.py). 0 for ``k <= 0`` or ``p >= 1``, ``-inf`` for ``k > n`` or
    ``p <= 0``."""
    return float(_core.log_binom_sf(int(k), int(n), float(p)))


def log10_nfa(k: int, n: int, p: float, num_tests: float, sample_size: int) -> float:
    """``log10`` of the number of false alarms of a model with ``k`` inliers of ``n`` (see above)."""
    kk, nn = k - sample_size, n - sample_size
    lt = float(np.log10(max(num_tests, 1.0)))
    if kk <= 0 or nn <= 0:
        return lt
    return lt + log_binom_sf(kk, nn, p) / float(np.log(10.0))


# ------------------------------------------------------------------------------------------------
# pure rotation: a robust rotation-only fit on all matches (2-point RANSAC + Kabsch)

ROTATION_SAMPLE = 2
ROTATION_MAX_ITERATIONS = 1000
ROTATION_CONFIDENCE = 0.9999
ROTATION_SEED = 20240612
# rotation hypotheses are scored on a seeded subset of at most this many matches (the samples needed
# depend on the inlier ratio only; the Kabsch refinement and the significance test use every match):
# the test's cost stops growing with n (26 ms -> ~3 ms on a 4266-match Strecha pair)
ROTATION_SCORE_POINTS = 500
# the test needs to know whether a rotation explains most of the pose's inliers, not the best rotation:
# its RANSAC stops once a rotation supported by this share of the pose's inliers would have been drawn
# with ROTATION_CONFIDENCE (2-point samples: 32 where every match is a pose inlier, 143 where half are) instead of running to
# ROTATION_MAX_ITERATIONS wherever no rotation fits (every pair with a translation). The decision
# cannot change for the worse: under a pure rotation the rotation explains ~all the pose's inliers (a
# far larger share, drawn earlier with the same confidence), and a rotation with less support only
# adds translation support; the diagnostics of a pair with a translation describe the rotation found
ROTATION_MIN_SHARE = 0.5
# a match fits a rotation when angle(R f1, f2) < ROTATION_THRESHOLD_FACTOR * tau (the full angular
# error of a match is larger than its Sampson error, which only measures one direction)
ROTATION_THRESHOLD_FACTOR = 2.0


def great_circle_spread(f: np.ndarray) -> float:
    """RMS distance (radians: the sine of the angle) of unit bearings ``f (k, 3)`` from the plane through
    the camera's centre that fits them best, the square root of the least eigenvalue of ``f^T f / k``
    (inf for fewer than 3). Bearings on one great circle (every scene point on a plane through the
    centre, e.g. on one 3-D line) leave the epipolar constraint blind to the circle's normal: ``E``'s
    action on it, three of its parameters, is free, and the pose is not determined."""
    if len(f) < 3:
        return float("inf")
    w = np.linalg.eigvalsh(f.T @ f / len(f))
    return float(np.sqrt(max(float(w[0]), 0.0)))


# a pose inlier supports a translation only when it is this many rotation thresholds off the rotation
EXTRA_FACTOR = 2.0
# the precision test of a rotation-only model (pure_rotation_test): on the pose's matches within
# PRECISION_BAND thresholds, the median of the residual component the rotation leaves along the
# epipolar lines (chord^2 / 2 - e^2: the parallax) over the median of the pose's squared Sampson
# error e^2. Both are sigma^2 chi^2(1) under a pure rotation, so the ratio is ~1 (measured 0.5-2.5 at
# 0-50 % outliers, at most 6.6 at 80 %, on synthetic pure rotations with 0.3-1 px noise); a translation
# adds the parallax (low-parallax scenes at 0.3 px noise: 8-55 at 0.5 deg, 98-260 at 1.5 deg).
PRECISION_BAND = 3.0
# the ratio above which the parallax is significant (about twice the largest measured under a pure
# rotation, 6.6 at 80 % outliers; low-parallax scenes at 0.3 px noise: 20-98 at 0.75 deg)
PRECISION_RATIO = 12.0
PRECISION_IRLS = 5  # Cauchy-weighted Kabsch rounds of the test's rotation refit
# ... on at least this many matches (medians of fewer, a third of them outliers, reached 20-32 on pure
# rotations of 60 matches at 50 % outliers)
PRECISION_MIN_MATCHES = 50
# a median parallax below this fraction of the threshold is rounding, not geometry (noise-free data:
# the ratio of two rounding errors means nothing)
PRECISION_MIN_PARALLAX = 1e-4
# a pose inlier is evidence of a translation only beyond this many noise sigmas of the rotation's
# 2-D residual as well (far_angle: P(chi^2_2 > 5.3^2) ~ 1e-6)
FAR_SIGMAS = 5.3
CAUCHY_C = 2.385  # the Cauchy loss's scale in noise sigmas (95 % efficiency at the Gaussian)
# ... and only where the noise is resolved: the pose's robust noise scale at most the threshold (beyond
# it the threshold truncates the inliers' own errors). It was 0.35 of the threshold: the test was then
# off wherever the threshold had been matched to the noise (2.5 sigma, noise / threshold 0.4: every
# pair at 1 px noise), and a small object turning in front of a narrow camera (fixated: the rotation
# cancels most of the translation's image motion) was called a pure rotation, its rotation-only fit
# 8 deg off (tests/test_pose_uncertainty.py). A partial fix: at 1 px noise 9 -> 6 of 30 such scenes at
# f = 1000 px, 1 -> 0 at f = 1500; at 2 px noise (beyond this bound) 27 and 15 of 30 remain. On
# synthetic pure rotations (0.1-3 px noise, 0-80 % outliers, 30-2000 matches, both cameras; 1400
# scenes) every status is the same at 0.35 and 1, the ratio at most 7.3 (pinhole, 3 px, 20 % outliers)
PRECISION_NOISE = 1.0
CHI2_1_MEDIAN = 0.45493642311957283  # median of chi^2 with one degree of freedom


def _rotation_inliers(Rs, f1, f2, thr) -> np.ndarray:
    """``(h, n)`` mask of ``|R f1 - f2| < 2 sin(thr / 2)`` (chord form: exact for tiny angles)."""
    d = np.einsum("hij,nj->hni", Rs, f1) - f2[None]
    return np.einsum("hni,hni->hn", d, d) < (2.0 * np.sin(0.5 * thr)) ** 2


def robust_rotation(f1: np.ndarray, f2: np.ndarray, tau: float, min_inlier_ratio: float = 0.0) -> tuple[np.ndarray, np.ndarray, int]:
    """Best rotation-only model ``X2 ~ R X1`` over all matches ``f1, f2 (n, 3)``: 2-point RANSAC with
    adaptive stopping in the core (the generic loop with its rotation estimator; hypotheses scored on
    at most :data:`ROTATION_SCORE_POINTS` matches), then Kabsch on the inliers among all matches
    (twice, each kept if the inliers do not drop). ``min_inlier_ratio`` > 0: the stopping rule assumes
    at least this inlier ratio (a decision: is there a rotation with this support?), so the model is the
    best found, not necessarily the best, where no rotation has it. Returns ``(R (3, 3), inliers (n,),
    hypotheses tested)``."""
    chord = 2.0 * np.sin(0.5 * ROTATION_THRESHOLD_FACTOR * tau)
    R, mask, tests = _core.robust_rotation(
        np.ascontiguousarray(f1, dtype=float),
        np.ascontiguousarray(f2, dtype=float),
        float(chord),
        ROTATION_SEED,
        ROTATION_MAX_ITERATIONS,
        ROTATION_CONFIDENCE,
        ROTATION_SCORE_POINTS,
        float(min_inlier_ratio),
    )
    return R, mask.astype(bool), int(tests)


def rotation_chance_rate(R: np.ndarray, f1: np.ndarray, f2: np.ndarray, tau: float) -> float:
    """Probability that a re-paired match fits the rotation ``R`` (add-one smoothing)."""
    perms = _permutations(len(f1))
    chord2 = (2.0 * np.sin(0.5 * ROTATION_THRESHOLD_FACTOR * tau)) ** 2
    hits = _core.rotation_chance_count(_c(R), _c(f1), _c(f2), perms, float(chord2))
    return float((hits + 1) / (perms.size + 2))


def far_angle(v_pose: np.ndarray | None, tau: float, noise_floor: float = 0.0) -> float:
    """The angle from a rotation-only model beyond which a pose inlier is evidence of a translation:
    ``EXTRA_FACTOR`` rotation thresholds, or, where the matches are noisier than the threshold
    assumes, :data:`FAR_SIGMAS` noise sigmas of the rotation's residual (``sqrt(2)`` times the pose's
    robust Sampson scale on its band, ``v_pose (n,)``; the noise tail beyond that holds ~1e-6 of the
    inliers). At 1 px noise and the 1 px default the noise tail beyond 4 tau is ~2 % of the inliers,
    which the count test took for a translation (pure rotations of 1500 matches, 22-35 of 40 `ok`).
    The scale is at least ``noise_floor`` (radians)."""
    far = EXTRA_FACTOR * ROTATION_THRESHOLD_FACTOR * tau
    if v_pose is None:
        return far
    band = v_pose < PRECISION_BAND * tau
    if np.count_nonzero(band) < PRECISION_MIN_MATCHES:
        return far
    sigma = max(float(np.sqrt(median(v_pose[band] ** 2) / CHI2_1_MEDIAN)), noise_floor)
    return max(far, FAR_SIGMAS * np.sqrt(2.0) * sigma)


def parallax_ratio(R_rot: np.ndarray, f1: np.ndarray, f2: np.ndarray, v_pose: np.ndarray, tau: float, noise_floor: float = 0.0) -> tuple[float, float, np.ndarray | None]:
    """Precision test of a rotation-only model against a pose with Sampson errors ``v_pose (n,)``:
    ``(ratio, noise, R)``, the median parallax component over the median squared Sampson error on the
    matches with ``v_pose < PRECISION_BAND * tau`` that the rotation does not put clearly off (within
    ``EXTRA_FACTOR`` rotation thresholds), the pose's robust noise scale there over ``tau`` (both NaN
    with fewer than :data:`PRECISION_MIN_MATCHES` such matches; the ratio is 0 where the median
    parallax is below :data:`PRECISION_MIN_PARALLAX` ``* tau``, i.e. rounding, and inf where there is
    parallax but no noise) and the refitted rotation (``None`` with too few matches).

    A nested-model comparison with the noise scale cancelled: the rotation explains a match with the
    2-D residual ``r = R f1 - f2`` (geometric distance ``|r|^2 / 2`` with equal noise in both images),
    the pose with its 1-D Sampson error ``e``; ``|r|^2 / 2 - e^2`` is the component along the
    epipolar line, where a translation's parallax lies. The rotation is refitted on those matches
    from ``R_rot`` by Cauchy-weighted Kabsch at the pose's noise scale (:data:`PRECISION_IRLS` rounds):
    the robust fit on all matches is least squares within its threshold, and at 80 % outliers the few
    outliers inside it bias it by about a pixel (measured: ratio 15 on a pure rotation, 6.6 at most
    after the refit). ``noise_floor`` (radians): the noise scale is at least this (the median squared
    Sampson error at least ``CHI2_1_MEDIAN noise_floor^2``; the coordinates' rounding, under which a
    pose can fit most matches exactly)."""
    # the band, without the matches the rotation puts clearly off (beyond EXTRA_FACTOR rotation
    # thresholds: the count test's evidence; here they would be outliers that the pose's band admits);
    # computed by the core (numpy reference: tests/reference/parallax.py)
    chord = 2.0 * np.sin(0.5 * EXTRA_FACTOR * ROTATION_THRESHOLD_FACTOR * tau)
    ratio, noise, R = _core.parallax_ratio(
        np.ascontiguousarray(R_rot, dtype=float),
        np.ascontiguousarray(f1, dtype=float),
        np.ascontiguousarray(f2, dtype=float),
        np.ascontiguousarray(v_pose, dtype=float),
        float(tau),
        PRECISION_BAND,
        float(chord**2),
        PRECISION_MIN_MATCHES,
        PRECISION_IRLS,
        CAUCHY_C,
        CHI2_1_MEDIAN,
        PRECISION_MIN_PARALLAX,
        float(noise_floor),
    )
    return float(ratio), float(noise), R


# the translation's support counts an extra inlier (a pose inlier clearly off the rotation) only where at
# least LOCAL_SUPPORT_MIN of its LOCAL_SUPPORT_K nearest matches in view 1 are extra inliers too: a
# surface near enough to show parallax shows it over a neighbourhood (depth is piecewise smooth), while
# a repeated structure's wrong matches, displaced by its period along one direction that a translation's
# epipole at infinity collects, sit alone among matches the rotation explains
LOCAL_SUPPORT_K = 10
LOCAL_SUPPORT_MIN = 2


def _locally_supported(f1: np.ndarray, extra: np.ndarray, explained: np.ndarray) -> np.ndarray:
    """``extra (n,)`` bool restricted to the matches with at least :data:`LOCAL_SUPPORT_MIN` of their
    :data:`LOCAL_SUPPORT_K` nearest ``explained`` matches in view 1 (chord distance on the bearings; the
    matches the pose or the rotation explains: outliers of both say nothing about depth) in ``extra``.
    A neighbour at the same view-1 bearing is the same keypoint matched again (a non-mutual matcher,
    several orientations of one SIFT keypoint), not a second point of the surface. One core call
    (numpy reference: tests/reference/neighbours.py)."""
    m = _core.locally_supported(_c(f1), np.ascontiguousarray(extra, dtype=bool), np.ascontiguousarray(explained, dtype=bool), LOCAL_SUPPORT_K, LOCAL_SUPPORT_MIN)
    return m.view(bool)


# a significant rotation-only model that explains at least this share of the pose's inliers, without
# resolvable parallax on them, leaves the translation to the minority (rotation_explains_most)
ROTATION_MAJORITY = 0.5


def rotation_explains_most(rot: dict[str, Any]) -> bool:
    """From :func:`pure_rotation_test`'s result: a significant rotation without translation explains at
    least :data:`ROTATION_MAJORITY` of the pose's inliers and leaves no precise parallax on them, while
    the translation is supported (not a pure rotation). Then the pose's translation rests on the
    minority: a near surface before a distant background, or objects that moved before a still camera
    (from two views the same geometry), and the rotation-only fit is the other reading of the data."""
    precise = rot["parallax_ratio"] > PRECISION_RATIO and rot["parallax_noise"] <= PRECISION_NOISE
    return bool(not rot["pure_rotation"] and rot["log10_nfa_rotation"] < np.log10(NFA_MAX) and rot["rotation_only_fraction"] >= ROTATION_MAJORITY and not precise)


def _shares_keypoint_with(f1: np.ndarray, f2: np.ndarray, other: np.ndarray) -> np.ndarray:
    """``(n,)`` bool: the match shares its view-1 or view-2 keypoint (an identical bearing) with a
    different correspondence in ``other (n,)`` bool (the core's keypoint groups, ``conflicts.h``: at most
    one correspondence of a keypoint can be right)."""
    start, members, corr = (np.asarray(a) for a in _core.keypoint_groups(_c(f1), _c(f2)))
    out = np.zeros(len(f1), bool)
    if members.size == 0:
        return out
    g = np.repeat(np.arange(len(start) - 1, dtype=np.int64), np.diff(start))  # each member's group
    o = np.asarray(other, bool)[members].astype(float)
    in_group = np.bincount(g, weights=o, minlength=len(start) - 1)
    c = corr[members].astype(np.int64)
    _, gc = np.unique(g * (int(c.max()) + 1) + c, return_inverse=True)  # each member's (group, correspondence)
    in_corr = np.bincount(gc, weights=o)
    out[members[in_group[g] - in_corr[gc] > 0]] = True
    return out


def pure_rotation_test(
    f1: np.ndarray,
    f2: np.ndarray,
    tau: float,
    inl: np.ndarray,
    p_pose: float,
    num_pose_tests: float,
    v_pose: np.ndarray | None = None,
    noise_floor: float = 0.0,
    in_front: np.ndarray | Callable[[], np.ndarray] | None = None,
    tau_precision: float | None = None,
) -> dict[str, Any]:
    """Does a rotation without translation explain the data as well as the pose?

    The rotation is fitted robustly on all matches (:func:`robust_rotation`). It is *significant*
    when its own NFA (2-point samples, its measured chance rate) is below :data:`NFA_MAX`; the pose's
    translation is *supported* when the pose's inliers that the rotation does not explain are more
    than chance allows among the rotation's outliers (NFA with the pose's chance rate ``p_pose`` and
    ``num_pose_tests`` hypotheses), or, given the pose's Sampson errors ``v_pose (n,)``, when the
    rotation leaves a parallax far above the noise on the matches both explain (:func:`parallax_ratio`
    above :data:`PRECISION_RATIO` where the noise is resolved, :data:`PRECISION_NOISE`: a small
    baseline whose parallax stays within the rotation's threshold). ``pure_rotation`` = significant
    rotation and unsupported translation. The rotation search stops once a rotation explaining
    :data:`ROTATION_MIN_SHARE` of the pose's inliers would have been found. Returns a dict with
    ``R_rotation_only`` (the robust fit,
    refitted by :func:`parallax_ratio`'s Cauchy-weighted Kabsch where it ran),
    ``rotation_inliers``, ``rotation_tests`` (the rotation hypotheses tested), ``rotation_only_fraction``
    (of the pose's inliers), ``translation_support``
    (pose inliers more than ``EXTRA_FACTOR`` rotation thresholds off the rotation; where the rotation is
    significant, the support significant and the parallax not precise, only those in front of both
    cameras under the pose (``in_front (n,)`` bool or a function returning it, called only there; where given: a match behind a camera contradicts the
    translation it is to support), whose keypoints no other correspondence the rotation explains uses
    (:func:`_shares_keypoint_with`: a non-mutual matcher pairs a keypoint the rotation already explains
    with the repeated structure's next period, or with its copy where the rotation carries the point out
    of view 2) and with local support (:func:`_locally_supported`: a repeated structure's isolated wrong
    matches are no translation)),
    ``log10_nfa_rotation``, ``log10_nfa_translation``, ``parallax_ratio``, ``parallax_noise`` and
    ``pure_rotation`` (bool). ``noise_floor`` (radians): the least noise scale of :func:`far_angle` and
    :func:`parallax_ratio` (the coordinates' rounding). ``tau_precision``: the threshold of
    :func:`parallax_ratio`'s band and noise scale where it differs from the rotation's ``tau`` (the
    status judges the rotation at a threshold capped by the noise, :func:`poseonly.status.alternatives_cap`,
    and keeps the precision test's band at the pose's own).
    """
    n = len(f1)
    Rr, rin, tests = robust_rotation(f1, f2, tau, min(1.0, ROTATION_MIN_SHARE * int(np.count_nonzero(inl)) / n))
    k_rot = int(rin.sum())
    p_rot = rotation_chance_rate(Rr, f1, f2, tau)
    nfa_rot = log10_nfa(k_rot, n, p_rot, tests, ROTATION_SAMPLE)
    # the pose's extra inliers: those clearly off the rotation (beyond EXTRA_FACTOR times its
    # threshold: matches in the noise tail of the rotation are not evidence of a translation),
    # among the matches that far off (s = 0: they are in no sample)
    far = ~_rotation_inliers(Rr[None], f1, f2, far_angle(v_pose, tau, noise_floor))[0]
    ext = inl & far
    extra = int(np.count_nonzero(ext))
    nfa_tr = log10_nfa(extra, int(far.sum()), p_pose, num_pose_tests, 0)
    frac = float(np.count_nonzero(inl & rin) / max(int(inl.sum()), 1))
    tp = tau if tau_precision is None else tau_precision
    ratio, noise, R_fit = parallax_ratio(Rr, f1, f2, v_pose, tp, noise_floor) if v_pose is not None else (float("nan"), float("nan"), None)
    precise = bool(ratio > PRECISION_RATIO and noise <= PRECISION_NOISE)  # NaN (too few matches): False
    if nfa_rot < np.log10(NFA_MAX) and nfa_tr < np.log10(NFA_MAX) and not precise:
        # only where it decides the status (it can only lower the support): the extra inliers in front
        # of both cameras, on keypoints the rotation does not already pair otherwise, with local support
        # (a nearest-neighbour search, ~0.1-0.3 ms a pair). On real images warped by pure rotations the
        # translations that reached `ok` (3 of 200, entry-P10's facade) rested on such matches: 10 of 12,
        # 8 of 9 and 44 of 54 took a view-2 keypoint that a match the rotation explains uses
        ext = ext & ~_shares_keypoint_with(f1, f2, rin)
        if in_front is not None:
            ext = ext & np.asarray(in_front() if callable(in_front) else in_front, bool)
        extra = int(np.count_nonzero(_locally_supported(f1, ext, inl | rin)))
        nfa_tr = log10_nfa(extra, int(far.sum()), p_pose, num_pose_tests, 0)
    return {
        # the robust refit where there is one (5-25 % closer on synthetic pure rotations, 0-80 % outliers)
        "R_rotation_only": Rr if R_fit is None else R_fit,
        "rotation_inliers": k_rot,
        "rotation_tests": tests,
        "rotation_only_fraction": frac,
        "translation_support": extra,
        "log10_nfa_rotation": nfa_rot,
        "log10_nfa_translation": nfa_tr,
        "parallax_ratio": ratio,
        "parallax_noise": noise,
        "pure_rotation": bool(nfa_rot < np.log10(NFA_MAX) and nfa_tr >= np.log10(NFA_MAX) and not precise),
    }
