"""The status decision: what a method's final model says about the matches, and whether to trust it.

:func:`finish` takes a method's final model, computes its inlier mask and residuals, runs the
analysis of :mod:`poseonly.analysis` (chance, pure rotation, planar twin, rivals, covariance) and
decides the status of the :class:`~poseonly.result.RelativePoseResult` (``ok`` means "trust this
pose"); :func:`degenerate_result` is the result of input that determines no pose.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from . import _core
from .analysis import (
    AMBIGUITY_LEVEL,
    NFA_MAX,
    POSE_DOF,
    ROTATION_THRESHOLD_FACTOR,
    TWIN_SPREAD_CHI2,
    chance_rate,
    equally_supported_twin,
    great_circle_spread,
    log10_nfa,
    parallax_deg,
    planar_twin,
    pose_uncertainty,
    pure_rotation_test,
    rival_test,
    rotation_explains_most,
)
from .geometry import essential_from_pose, rotation_error_deg, valid_pose
from .options import MAX_ROTATION_STD_DEG
from .residuals import CHIRAL_PENALTY, v_sampson, v_sampson_chiral
from .result import RelativePoseResult, Status

__all__ = ["MIN_DISTINCT_MATCHES", "NEAR_DUPLICATE_MAX_RAD", "NEAR_DUPLICATE_PX", "degenerate_result", "distinct_rows", "finish"]

# two matches within this many pixels of each other in both views are one observation for the status
# (finish): the same keypoint detected twice has correlated errors; distinct features are further apart.
# The angle is capped (0.5 px at a focal of 500 px): a focal of a few pixels, valid input, would otherwise
# make every match a copy of every other
NEAR_DUPLICATE_PX = 0.5
NEAR_DUPLICATE_MAX_RAD = 1e-3


# the rotation-only alternative to the pose is fitted and judged at the decision
# threshold only up to this many noise scales of the Gaussian mixture at the ML pose (a 1-D Sampson
# error: 99.7 % of the inliers within 3 sigma) or the search's threshold, whichever is larger
ALTERNATIVES_SIGMAS = 3.0


def alternatives_cap(tau_search: float, sigma_gauss: float | None) -> float:
    """The largest threshold (radians) the rotation-only alternative is judged at: the search's, or
    :data:`ALTERNATIVES_SIGMAS` noise scales ``sigma_gauss`` where that is larger. With no outlier near
    the band the ML stage's p = 1/2 decision moves to the band's edge (``ml_range`` times the search's
    threshold), where an alternative absorbs a real parallax: at 0.5 px noise and 1 px a rotation
    absorbed up to ~6 px of a 0.3 baseline's parallax, and clean pairs of 40 matches were called
    ``pure_rotation``, their rotation-only fit 1.4-1.6 deg off against the pose's 0.1-0.4 (a migrating
    user's trial). Below the cap nothing changes."""
    if sigma_gauss is None or not (np.isfinite(sigma_gauss) and sigma_gauss > 0):
        return float("inf")
    return max(tau_search, ALTERNATIVES_SIGMAS * float(sigma_gauss))


def _unit(t: np.ndarray) -> np.ndarray:
    t = np.asarray(t, float)
    t = t / np.max(np.abs(t))
    return t / np.linalg.norm(t)


def _rotation_angles(R, f1, f2) -> np.ndarray:
    c = np.clip(np.sum((f1 @ R.T) * f2, axis=1), -1.0, 1.0)
    return np.arccos(c)


def distinct_rows(f1: np.ndarray, f2: np.ndarray, tol: float = 0.0) -> np.ndarray | None:
    """Indices (ascending) of the first match of each group of repeated matches, or ``None`` where every
    match is distinct. ``f1, f2 (n, 3)`` unit bearings; two matches repeat each other when their rows are
    identical or, with ``tol > 0`` (radians), within ``tol`` of each other in both views (chord
    distance); groups are the connected components of that relation. One core call (a sort for the
    identical rows, a sweep along a fixed direction of the two bearings' 6-D space for the near ones,
    union-find; numpy reference: tests/reference/neighbours.py)."""
    return _core.distinct_matches(np.ascontiguousarray(f1, dtype=float), np.ascontiguousarray(f2, dtype=float), float(tol))


def _with_model_spread(unc: dict[str, Any], delta: float, delta_t: float = 0.0, t: np.ndarray | None = None) -> dict[str, Any]:
    """``unc`` (:func:`poseonly.analysis.pose_uncertainty`'s) with ``delta**2`` (radians^2) added to the
    rotation covariance on every axis and to the reported deviation, and ``delta_t**2`` to the unit
    translation's on its tangent plane at ``t``: the spread between two models of the same data that
    the matches do not tell apart."""
    if unc["rotation_covariance"] is None or not np.isfinite(delta):
        return unc
    C = unc["rotation_covariance"] + delta**2 * np.eye(3)
    out = {**unc, "rotation_covariance": C, "rotation_std_deg": float(np.degrees(np.sqrt(max(float(np.linalg.eigvalsh(C)[-1]), 0.0))))}
    if delta_t > 0 and t is not None and unc["translation_covariance"] is not None and np.isfinite(delta_t):
        u = _unit(t)
        Ct = unc["translation_covariance"] + delta_t**2 * (np.eye(3) - np.outer(u, u))
        out.update(translation_covariance=Ct, translation_std_deg=float(np.degrees(np.sqrt(max(float(np.linalg.eigvalsh(Ct)[-1]), 0.0)))))
    return out


def _with_estimator_spread(unc: dict[str, Any], R: np.ndarray, t: np.ndarray, f1: np.ndarray, f2: np.ndarray, inl: np.ndarray, diag: dict[str, Any]) -> dict[str, Any]:
    """``unc`` with the distance from ``(R, t)`` to the least-squares Sampson fit of its inliers ``inl (n,)``
    (from ``(R, t)``) added as a model spread (:func:`_with_model_spread`; ``diag["estimator_spread_deg"]``).

    The first-order covariance is that of the least-squares pose on these inliers; a pose that another
    objective chose (the paper's LiGTopt, an algebraic solve) is that pose plus its offset from it, which
    the covariance does not see (a user's trial: GNC-RANSAC with LiGTopt on noise-free-outlier pinhole
    scenes at 0.5 px, 0.73 deg median error against deviations of 0.06-0.11 deg, 15 of 20 beyond three
    deviations). Applied to every method whose last stage is not a Sampson fit (the default's ML and
    Cauchy finals are)."""
    if unc["rotation_covariance"] is None or np.count_nonzero(inl) < 6:
        return unc
    c = np.ascontiguousarray
    Rl, tl, _ = _core.refine_sampson(c(R, dtype=float), c(t, dtype=float), c(f1[inl]), c(f2[inl]), None, loss="linear", max_iterations=100, tol=1e-12)
    if not (np.all(np.isfinite(Rl)) and np.all(np.isfinite(tl))):
        return unc
    d = float(np.radians(rotation_error_deg(R, Rl)))
    # the Sampson errors do not see t's sign, and the refit takes the sign most inliers put in front:
    # the distance between the two directions is sign-free
    ct = float(np.clip(abs(np.dot(_unit(t), _unit(tl))), 0.0, 1.0))
    dt = float(np.arccos(ct))
    diag.update(estimator_spread_deg=float(np.degrees(d)), estimator_translation_spread_deg=float(np.degrees(dt)))
    return _with_model_spread(unc, d, dt, t)


# fewer distinct matches than a pose's minimal problem plus one cannot single out a pose (the paper's
# LiRP needs 6); below this the status analysis's tests do not run
MIN_DISTINCT_MATCHES = 6


@dataclass
class _Matches:
    """The matches a status is decided on: bearings ``f1, f2 (n, 3)``, their distinct rows ``g1, g2``
    (``once``: the indices of :func:`distinct_rows`, None where all are distinct), the focal length and
    the thresholds (radians): ``tau`` the decision's, ``tau_search`` the search's, ``tau_rot`` the
    pose's covariance's, ``tau_alt_rot`` the rotation-only fit's (:func:`alternatives_cap`)."""

    f1: np.ndarray
    f2: np.ndarray
    once: np.ndarray | None
    focal: float
    tau: float
    tau_search: float
    tau_rot: float = 0.0
    tau_alt_rot: float = 0.0
    g1: np.ndarray = field(init=False)
    g2: np.ndarray = field(init=False)

    def __post_init__(self) -> None:
        self.g1, self.g2 = self.distinct(self.f1), self.distinct(self.f2)

    def distinct(self, x: np.ndarray) -> np.ndarray:
        return x if self.once is None else x[self.once]


@dataclass
class _Model:
    """The model the status speaks for and its reading of the matches: inlier mask, weights and
    residuals (pixels) per match, median parallax (degrees), covariance (:func:`pose_uncertainty`'s)."""

    R: np.ndarray
    t: np.ndarray
    inl: np.ndarray
    weights: np.ndarray
    residuals: np.ndarray
    par: float
    unc: dict[str, Any]

    @property
    def n_in(self) -> int:
        return int(self.inl.sum())


def finish(
    method: str,
    R: np.ndarray,
    t: np.ndarray,
    f1: np.ndarray,
    f2: np.ndarray,
    w: np.ndarray | None,
    tau: float,
    focal: float,
    thr_px: float,
    iters: int,
    t0: float,
    diag: dict[str, Any],
    min_inliers: int = 15,
    max_rotation_std_deg: float = MAX_ROTATION_STD_DEG,
    max_translation_std_deg: float = float("inf"),
    noise_floor: float = 0.0,
) -> RelativePoseResult:
    """Inliers, residuals, analysis and status of a method's final model ``(R, t)``.

    ``R (3, 3)``, ``t (3,)`` (any length; non-finite when the method found no model), unit bearings
    ``f1, f2 (n, 3)``, the method's weights ``w (n,)`` or None, the angular threshold ``tau``
    (radians; ``thr_px`` at ``focal`` pixels), ``iters`` the method's iterations, ``t0`` its start
    (``time.perf_counter``) and ``diag`` its diagnostics (updated in place); ``noise_floor``
    (radians): the least noise scale of the analysis (the coordinates' rounding, :mod:`poseonly.quantization`).

    Order of the decision: no valid model -> ``degenerate``; a significant rotation-only model
    and no significant translation -> ``pure_rotation`` (``too_few_inliers`` where that rotation is
    more than ``max_rotation_std_deg`` from the pose's R, or its deviation exceeds it); too few inliers or an NFA above
    :data:`poseonly.analysis.NFA_MAX` -> ``too_few_inliers``; inliers on a great circle of one view ->
    ``degenerate``; a planar twin -> ``planar_ambiguous``;
    a rival pose (``diag["rivals"]``, the default method's uniqueness test: the refined models the
    search kept in other basins, best first; or ``diag["rival_R"]``) that explains as many matches of
    its own -> ``ambiguous``; a rotation standard deviation above
    ``max_rotation_std_deg``, or of the translation direction above ``max_translation_std_deg``, or an
    iterative method that did not converge (``diag["converged"]`` False: GNC-IRLS) -> ``uncertain``;
    else ``ok``.
    """
    tau_search = tau
    diag["search_threshold_px"] = float(tau_search * focal)
    sampson_final = bool(diag.pop("sampson_final", False))
    # the uniqueness test's refined rivals, best first (the default method's; diag["rival_R"] alone
    # from a caller that gives one)
    rivals = diag.pop("rivals", None)
    if rivals is None:
        rivals = [] if diag.get("rival_R") is None else [(diag["rival_R"], diag["rival_t"])]
    if "tau_effective" in diag:  # the default method's noise-matched threshold (the ML stage's decision)
        tau = diag["tau_effective"]
        thr_px = tau * focal
    n = len(f1)
    if not valid_pose(R, t):
        return degenerate_result(n, diag.get("rank", -1), method, thr_px, focal, t0, reason=f"the {method!r} method found no valid pose (no hypothesis scored)", diag=diag)
    t = _unit(t)
    v = v_sampson.unchecked(R, t, f1, f2)
    inl = v < tau
    weights = inl.astype(float) if w is None else np.asarray(w, float)
    num_tests = float(diag.get("num_hypotheses", 1))
    p_pose = chance_rate(R, t, f1, f2, tau)
    # a match given twice (the same coordinates in both views: SIFT's orientation duplicates, 6-10 % of
    # the real benchmark's matches; a matcher's repeated rows), or again within NEAR_DUPLICATE_PX in both
    # views (one keypoint detected twice, e.g. at two scales: a review made random matches repeated with
    # 0.05-0.3 px of jitter `ok`), is one observation, not two: the significance, the inlier count the
    # status needs, the support counts of the pure-rotation, twin and uniqueness tests and the covariance
    # count it once
    once = distinct_rows(f1, f2, min(NEAR_DUPLICATE_PX / focal, NEAR_DUPLICATE_MAX_RAD) if focal > 0 else 0.0)
    # the rotation-only alternative is fitted at the search threshold at least: at a decision threshold
    # the pose itself shrank (an ML fit to a tight subset) a rotation would miss its own noisy inliers
    cap = alternatives_cap(tau_search, diag.get("sigma_gauss"))
    m = _Matches(f1, f2, once, focal, tau, tau_search, max(tau, tau_search), min(max(tau, tau_search), cap))
    n_in_once = int(np.count_nonzero(m.distinct(inl)))
    lnfa = log10_nfa(n_in_once, len(m.g1), p_pose, num_tests, POSE_DOF)
    diag.update(chance_inliers=n * p_pose, chance_rate=p_pose, log10_nfa=lnfa, distinct_inliers=n_in_once)

    def result(model: _Model, status: Status, message: str, twin: tuple[np.ndarray, np.ndarray, int] | None = None) -> RelativePoseResult:
        R_twin, t_twin, twin_n = twin if twin is not None else (None, None, 0)
        return RelativePoseResult(
            R=model.R,
            t=model.t,
            E=essential_from_pose(model.R, model.t),
            inliers=model.inl,
            weights=model.weights,
            residuals_px=model.residuals,
            num_inliers=model.n_in,
            num_iterations=int(iters),
            status=status,
            message=message,
            method=method,
            threshold_px=float(thr_px),
            focal_px=focal,
            parallax_deg=model.par,
            R_twin=R_twin,
            t_twin=t_twin,
            twin_inliers=twin_n,
            time_s=time.perf_counter() - t0,
            diagnostics=diag,
            rotation_covariance=model.unc["rotation_covariance"],
            translation_covariance=model.unc["translation_covariance"],
        )

    if len(m.g1) < MIN_DISTINCT_MATCHES:
        # matches that all repeat a few (e.g. normalized coordinates passed with a K: every pixel within a
        # pixel of the principal point) are too few observations for any of the tests below (a trial: the
        # rotation search raised "at least 2 points are needed" on 1022 such matches)
        diag.update(rotation_std_deg=np.inf, translation_std_deg=np.inf, noise_sigma_px=float("nan"))
        few = _Model(R, t, inl, weights, v * focal, parallax_deg(R, f1, f2, inl), {"rotation_covariance": None, "translation_covariance": None})
        message = (
            f"{n} matches, but only {len(m.g1)} distinct (matches within {NEAR_DUPLICATE_PX:g} px of each other in both views "
            f"count once; {MIN_DISTINCT_MATCHES} needed): they do not determine a pose (pixels passed as normalized "
            "coordinates, or normalized coordinates with a K?)"
        )
        return result(few, "too_few_inliers", message)

    def in_front() -> np.ndarray:
        # in front of both cameras with the sign of t that most of the pose's inliers take (the sign a
        # method returned may rest on a few matches: t and -t give the same Sampson errors); computed
        # only where the pure-rotation test's count decides, by two core calls (the core's cheirality of
        # sampson-chiral: both pose-only depths positive; exact on the inliers, whose errors are below
        # the penalty), not numpy's 0.15-0.45 ms a pair holding the GIL
        front = v_sampson_chiral.unchecked(R, t, f1, f2) < CHIRAL_PENALTY
        behind = v_sampson_chiral.unchecked(R, -t, f1, f2) < CHIRAL_PENALTY
        return m.distinct(behind if np.count_nonzero(behind & inl) > np.count_nonzero(front & inl) else front)

    rot = pure_rotation_test(
        m.g1, m.g2, m.tau_alt_rot, m.distinct(inl), p_pose, num_tests, v_pose=m.distinct(v), noise_floor=noise_floor, in_front=in_front, tau_precision=m.tau_rot
    )
    R_rot = rot.pop("R_rotation_only")
    diag.update(rot)
    rot_inl = _rotation_inliers_mask(R_rot, f1, f2, m.tau_alt_rot) if rot["pure_rotation"] else None
    unc = _covariance(m, R, t, v, rot_inl, R_rot, rot, diag, sampson_final, noise_floor)
    model = _Model(R, t, inl, weights, v * focal, parallax_deg(R, f1, f2, inl), unc)
    twin = None
    status: Status
    if rot_inl is not None:
        model, status, msg = _pure_rotation_decision(m, model, R_rot, rot_inl, diag, max_rotation_std_deg)
    elif n_in_once < max(6, min_inliers) or lnfa >= np.log10(NFA_MAX):
        status, msg = "too_few_inliers", _too_few_message(model.n_in, n_in_once, thr_px, max(6, min_inliers), n * p_pose, num_tests, lnfa)
    else:
        # inliers whose bearings in one view lie on a great circle within the threshold do not determine the
        # pose (an adversarial trial: points on one 3-D line gave `ok` poses 172-178 deg off with the paper's
        # methods; the rank test of the epipolar system sees the noise as a sixth dimension)
        ins = m.distinct(inl)
        circle = [great_circle_spread(m.g1[ins]), great_circle_spread(m.g2[ins])]
        diag["great_circle_spread_px"] = min(circle) * focal
        if min(circle) <= tau:
            view = 1 + int(np.argmin(circle))
            reason = (
                f"the {model.n_in} inliers' bearings in view {view} lie within {min(circle) * focal:.3g} px (RMS) of one plane through "
                f"the camera's centre, inside the threshold ({thr_px:g} px): every scene point on a plane through that centre "
                "(e.g. on one 3-D line) leaves the pose undetermined"
            )
            for key in _SPREAD_KEYS:
                diag.pop(key, None)  # of a pose not returned
            diag.update(rotation_std_deg=np.inf, translation_std_deg=np.inf, great_circle_view=view)
            return degenerate_result(n, diag.get("rank", -1), method, thr_px, focal, t0, reason=reason, diag=diag)
        status, msg, twin = _pose_decision(m, model, rivals, rot, lnfa, thr_px, diag, max_rotation_std_deg, max_translation_std_deg)
    if status == "too_few_inliers":
        for key in _SPREAD_KEYS:  # of a covariance not reported
            diag.pop(key, None)
        # inliers that chance explains, or too few to estimate their noise from, do not determine the pose
        # (a handful fitted exactly gave deviations of 1e-14 deg to a pose 160 deg off): no covariance
        model.unc = {**model.unc, "rotation_covariance": None, "translation_covariance": None, "rotation_std_deg": np.inf, "translation_std_deg": np.inf}
        diag.update(rotation_std_deg=np.inf, translation_std_deg=np.inf)
    return result(model, status, msg, twin)


# the model spreads a covariance took in (diagnostics), dropped with a covariance not reported
_SPREAD_KEYS = ("estimator_spread_deg", "estimator_translation_spread_deg", "leverage_spread_deg", "leverage_translation_spread_deg")


def _covariance(
    m: _Matches,
    R: np.ndarray,
    t: np.ndarray,
    v: np.ndarray,
    rot_inl: np.ndarray | None,
    R_rot: np.ndarray,
    rot: dict[str, Any],
    diag: dict[str, Any],
    sampson_final: bool,
    noise_floor: float,
) -> dict[str, Any]:
    """The covariance of the model the status speaks for (:func:`pose_uncertainty`'s dict, with the
    spreads to the other fits of the matches): the rotation-only fit's on its inliers ``rot_inl``, or
    the pose's on the matches within the search threshold (a decision threshold shrunk by the ML stage
    would truncate the inliers' noise and leave the pose's precision to a few matches)."""
    if rot_inl is None:
        near = m.distinct(v < m.tau_rot)
        unc = pose_uncertainty(R, t, m.g1, m.g2, near, m.tau_rot, noise_floor)
        if not sampson_final:
            unc = _with_estimator_spread(unc, R, t, m.g1, m.g2, near, diag)
        if diag.get("leverage_spread_deg", 0.0) > 0 or diag.get("leverage_translation_spread_deg", 0.0) > 0:
            # the pose's significant distance from its other inliers' fit (poseonly.robust.default.leverage_test)
            unc = _with_model_spread(unc, float(np.radians(diag["leverage_spread_deg"])), float(np.radians(diag["leverage_translation_spread_deg"])), t)
    else:
        unc = pose_uncertainty(R_rot, None, m.g1, m.g2, m.distinct(rot_inl), _rotation_chord(m.tau_alt_rot), noise_floor)
        diag["distinct_inliers"] = int(np.count_nonzero(m.distinct(rot_inl)))
    if rotation_explains_most(rot):
        # the rotation-only fit is the other reading (a still camera, objects moving): its distance from the
        # pose's R is part of R's uncertainty (a SLAM user's trial: R 0.18 deg off the still camera's
        # identity against a first-order deviation of 0.03)
        spread_rot = float(np.radians(rotation_error_deg(R, R_rot)))
        unc = _with_model_spread(unc, spread_rot)
        diag["rotation_model_spread_deg"] = float(np.degrees(spread_rot))
    diag.update(rotation_std_deg=unc["rotation_std_deg"], translation_std_deg=unc["translation_std_deg"], noise_sigma_px=unc["noise_sigma"] * m.focal)
    return unc


def _pure_rotation_decision(m: _Matches, pose: _Model, R_rot: np.ndarray, rot_inl: np.ndarray, diag: dict[str, Any], max_rotation_std_deg: float) -> tuple[_Model, Status, str]:
    """``pure_rotation`` with the rotation-only fit ``R_rot`` as the model (its inliers ``rot_inl (n,)``),
    or ``too_few_inliers`` where that fit is not determined either."""
    # the rotation-only fit absorbs whatever parallax the matches cannot resolve, and the pose's R
    # absorbs it differently: their difference is part of R's uncertainty (a 0.03 baseline at depths
    # 4-10: the fit 0.2 deg off, its noise-only deviation 0.02 deg, the difference 0.39 deg)
    delta = float(np.radians(rotation_error_deg(pose.R, R_rot)))
    # the robust rotation-only fit is the estimate of R here; the epipolar pose stays in the diagnostics
    # (a caller that knows the camera moved may prefer it: 10 cm sideways at 10-50 m is a pure rotation
    # to the matches, and its translation direction was within a few degrees in a user's trial)
    diag.update(pose_R=pose.R, pose_t=pose.t)
    unc = _with_model_spread(pose.unc, delta)
    diag.update(rotation_std_deg=unc["rotation_std_deg"], rotation_model_spread_deg=float(np.degrees(delta)))
    model = _Model(R_rot, pose.t, rot_inl, rot_inl.astype(float), _rotation_angles(R_rot, m.f1, m.f2) * m.focal, parallax_deg(R_rot, m.f1, m.f2, rot_inl), unc)
    n_in, within = model.n_in, 2 * m.tau_alt_rot * m.focal
    spread = float(np.degrees(delta))
    if spread > max_rotation_std_deg or (np.isfinite(unc["rotation_std_deg"]) and unc["rotation_std_deg"] > max_rotation_std_deg):
        # the pose's translation has no support beyond chance and the rotation-only fit is not
        # determined either (a poor pose of the paper's methods: 125-150 deg off, the fit 5 deg off):
        # nothing here is reliable, and E = [t]x R would mix the two models
        return (
            model,
            "too_few_inliers",
            (
                f"a rotation without translation explains {n_in} matches within {within:g} px and the pose's other "
                f"inliers are no more than chance, but the rotation-only fit is {spread:.2f} deg from the pose's R (max_rotation_std_deg = "
                f"{max_rotation_std_deg:g}): neither R nor the translation direction is reliable"
            ),
        )
    return (
        model,
        "pure_rotation",
        (
            f"a rotation without translation explains {n_in} matches within {within:g} px and the pose's "
            f"other inliers are no more than chance (median parallax {model.par:.3f} deg): R is reliable"
            + (f" to {unc['rotation_std_deg']:.3g} deg (one standard deviation)" if np.isfinite(unc["rotation_std_deg"]) else "")
            + ", the translation direction is not"
        ),
    )


def _too_few_message(n_in: int, n_in_once: int, thr_px: float, needed: int, chance_inliers: float, num_tests: float, lnfa: float) -> str:
    """Why a pose with ``n_in`` inliers (``n_in_once`` distinct) is ``too_few_inliers``: fewer than
    ``needed``, or support that chance explains (``lnfa``, the log10 of the expected false alarms)."""
    counted = f"{n_in} inliers" + ("" if n_in_once == n_in else f" ({n_in_once} distinct)") + f" within {thr_px:g} px"
    if n_in_once < needed:
        return f"{counted}, {needed} needed (min_inliers): the pose is not reliable"
    return (
        f"{counted}; randomly re-paired matches give the same model {chance_inliers:.1f} inliers, and over the "
        f"{num_tests:.3g} hypotheses tried chance explains this support (expected false alarms 10^{lnfa:.1f} >= "
        f"{NFA_MAX:g}): the pose is not reliable"
    )


def _pose_decision(
    m: _Matches,
    model: _Model,
    rivals: list[tuple[np.ndarray, np.ndarray]],
    rot: dict[str, Any],
    lnfa: float,
    thr_px: float,
    diag: dict[str, Any],
    max_rotation_std_deg: float,
    max_translation_std_deg: float,
) -> tuple[Status, str, tuple[np.ndarray, np.ndarray, int] | None]:
    """The status of a significant pose that is not a pure rotation, in the order of :func:`finish`:
    a planar twin, a rival that explains as many matches of its own, a deviation above its bound or an
    unconverged method, else ``ok``; with the twin ``(R, t, inliers)`` where there is one.
    ``model.unc`` takes the twin's spread where the matches do not tell the two apart."""
    R, t, n_in = model.R, model.t, model.n_in
    twin, info = planar_twin(R, t, m.g1, m.g2, m.tau, m.distinct(model.inl))
    diag.update(info)
    if equally_supported_twin(info) and info["twin_cost_excess"] <= TWIN_SPREAD_CHI2:
        # a planar scene's twin that explains the matches as well as the pose: the matches do not tell
        # the two apart, so their distance is part of the pose's uncertainty. Forward motion towards a
        # plane merges the twins into a flat valley the first-order covariance does not see (twins 0.9
        # deg apart, the pose 0.7 deg off, its first-order deviation 0.08 deg)
        model.unc = _with_model_spread(model.unc, float(np.radians(info["twin_separation_deg"])), float(np.radians(info["twin_translation_separation_deg"])), t)
        diag.update(rotation_std_deg=model.unc["rotation_std_deg"], translation_std_deg=model.unc["translation_std_deg"], twin_spread_deg=float(info["twin_separation_deg"]))
    unc = model.unc
    if twin is not None:
        R_twin = twin[0]
        return (
            "planar_ambiguous",
            (
                f"the inliers are explained by two poses {rotation_error_deg(R, R_twin):.2f} deg apart "
                f"(the homography twin keeps {twin[2]} inliers in front of both cameras: a planar scene, or one whose depth "
                "the parallax does not resolve); see R_twin, t_twin"
            ),
            twin,
        )
    amb = None
    for k, (Rv, tv) in enumerate(rivals):
        # compared at the search threshold, as the search scored both; the first rival that
        # the pose does not beat decides (reported as rival_R, rival_t), else the best one
        test = rival_test(R, t, Rv, _unit(tv), m.g1, m.g2, m.tau_search, diag["rival_distance"])
        diag["rivals_tested"] = k + 1
        if amb is None or test["ambiguous"]:
            amb = test
            diag.update(test, rival_R=Rv, rival_t=tv)
        if test["ambiguous"]:
            break
    if amb is not None and amb["ambiguous"]:
        return (
            "ambiguous",
            (
                f"a second pose {amb['rival_separation_deg']:.1f} deg away (diagnostics rival_R, rival_t) explains "
                f"{amb['rival_only']} matches the pose does not, against the pose's {amb['pose_only']} it does not, "
                f"too few to prefer the pose (sign test p = {10 ** amb['rival_log10_p']:.2g} >= {AMBIGUITY_LEVEL:g}): "
                "the matches do not single out the pose"
            ),
            None,
        )
    if max_rotation_std_deg < np.inf and not unc["rotation_std_deg"] <= max_rotation_std_deg:
        if not np.isfinite(unc["noise_sigma"]):
            msg = (
                f"{n_in} inliers within {thr_px:g} px single out the pose, but their errors fill the threshold "
                "as if it cut a much wider noise: the threshold does not resolve the noise, and how well the "
                "matches determine the pose is not known (a larger threshold_px tells)"
            )
        elif not np.isfinite(unc["rotation_std_deg"]):
            msg = f"{n_in} inliers within {thr_px:g} px single out the pose, but they do not determine its rotation (a singular information)"
        else:
            msg = (
                f"{n_in} inliers within {thr_px:g} px single out the pose, but they determine its rotation only to "
                f"{unc['rotation_std_deg']:.2f} deg (one standard deviation, first order, with the spread to other fits of the "
                "matches where there is one: diagnostics twin_spread_deg, rotation_model_spread_deg, estimator_spread_deg, leverage_spread_deg; max_rotation_std_deg = "
                f"{max_rotation_std_deg:g}): see rotation_covariance"
            )
        return "uncertain", msg, None
    if max_translation_std_deg < np.inf and not unc["translation_std_deg"] <= max_translation_std_deg:
        return (
            "uncertain",
            (
                f"{n_in} inliers within {thr_px:g} px single out the pose, but they determine its translation direction only to "
                f"{unc['translation_std_deg']:.2f} deg (one standard deviation, with the spread to other fits of the matches: "
                f"diagnostics leverage_translation_spread_deg, twin_spread_deg; max_translation_std_deg = {max_translation_std_deg:g}): see "
                "translation_covariance"
            ),
            None,
        )
    if diag.get("converged") is False:
        # GNC-IRLS's pose is defined where its weights settle; one still moving can sit on a few inliers
        # far from the pose the matches give (a researcher's trial: 4.4 deg off, 19 deviations, as ok)
        return (
            "uncertain",
            (f"{n_in} inliers within {thr_px:g} px, but the method's iterations did not converge (max_iterations): its weights had not settled, so the pose is not vouched for"),
            None,
        )
    msg = f"{n_in} inliers within {thr_px:g} px (expected false alarms 10^{lnfa:.0f})"
    if rotation_explains_most(rot):
        msg += (
            f"; {100 * rot['rotation_only_fraction']:.0f} % of them fit a rotation alone: the translation rests on "
            "the rest (a near surface, or objects that moved; two views cannot tell)"
        )
    return "ok", msg, None


def _rotation_chord(tau: float) -> float:
    """The chord ``|R f1 - f2|`` below which a match fits a rotation (the angle ROTATION_THRESHOLD_FACTOR tau)."""
    return float(2.0 * np.sin(0.5 * ROTATION_THRESHOLD_FACTOR * tau))


def _rotation_inliers_mask(R, f1, f2, tau) -> np.ndarray:
    d = f1 @ R.T - f2
    return np.sum(d * d, axis=1) < _rotation_chord(tau) ** 2


def degenerate_result(
    n: int, rank: int, method: str, thr_px: float, focal: float, t0: float, *, reason: str | None = None, diag: dict[str, Any] | None = None
) -> RelativePoseResult:
    """Result without a pose (``R = t = E = None``): ``n`` correspondences whose epipolar system has
    rank ``rank < 6``, or (``reason``) a method that found no valid model."""
    msg = reason or f"the correspondences span a rank-{rank} epipolar system (< 6): the pose is not determined"
    d = dict(diag or {})
    d["rank"] = rank
    return RelativePoseResult(
        R=None,
        t=None,
        E=None,
        inliers=np.zeros(n, bool),
        weights=np.zeros(n),
        residuals_px=np.full(n, np.nan),
        num_inliers=0,
        num_iterations=0,
        status="degenerate",
        message=msg,
        method=method,
        threshold_px=thr_px,
        focal_px=focal,
        time_s=time.perf_counter() - t0,
        diagnostics=d,
    )
