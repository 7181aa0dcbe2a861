"""The result type of :func:`poseonly.estimate_relative_pose` and the status decision.

:func:`finish` takes a method's final model, computes its inlier mask and residuals, runs the
analysis of :mod:`poseonly.analysis` and decides the status (``ok`` means "trust this pose").
:func:`degenerate_result` is the result of input that determines no pose.
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any, Literal, get_args

import numpy as np
from numpy.typing import NDArray

from . import _core
from ._equality import ValueEquality
from ._json import json_array, json_float
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
from .geometry import InputError, essential_from_pose, rotation_error_deg, valid_pose
from .options import MAX_ROTATION_STD_DEG
from .residuals import v_sampson

__all__ = ["RESULT_SCHEMA_VERSION", "STATUSES", "NoPoseError", "RelativePoseResult", "Status", "degenerate_result", "finish", "valid_pose"]

Status = Literal["ok", "planar_ambiguous", "ambiguous", "uncertain", "pure_rotation", "too_few_inliers", "degenerate"]
"""The statuses of :class:`RelativePoseResult` (see there); ``"ok"`` means "trust this pose"."""
STATUSES: tuple[Status, ...] = get_args(Status)

# the layout of RelativePoseResult.to_dict (from_dict reads this version and dicts without the key)
RESULT_SCHEMA_VERSION = 1


class NoPoseError(ValueError):
    """:meth:`RelativePoseResult.pose` of a ``degenerate`` result, which holds no pose."""


# two matches within this many pixels of each other in both views are one observation for the status
# (finish): the same keypoint detected twice has correlated errors; distinct features are further apart.
# The angle is capped (0.5 px at a focal of 500 px): a focal of a few pixels, valid input, would otherwise
# make every match a copy of every other
NEAR_DUPLICATE_PX = 0.5
NEAR_DUPLICATE_MAX_RAD = 1e-3


_json_float = json_float
_json_array = json_array


def _json_value(v: Any, exact: bool = False) -> Any:
    """A JSON-safe version of a diagnostic value: arrays -> lists, non-finite floats -> ``None`` or, with
    ``exact``, the strings ``"nan"``, ``"inf"``, ``"-inf"`` (which :meth:`RelativePoseResult.from_dict`
    reads back)."""
    if isinstance(v, (bool, np.bool_)):
        return bool(v)
    if isinstance(v, (int, np.integer)):
        return int(v)
    if isinstance(v, (float, np.floating)):
        return _exact_float(v) if exact else _json_float(v)
    if isinstance(v, np.ndarray):
        if v.dtype.kind == "f":
            return _exact_array(v) if exact else _json_array(v)
        return v.tolist()
    if isinstance(v, str) or v is None:
        return v
    return str(v)


_NONFINITE = {"nan": math.nan, "inf": math.inf, "-inf": -math.inf}


def _exact_float(x: Any) -> float | str:
    """``float(x)``, or ``"nan"`` / ``"inf"`` / ``"-inf"`` (strict JSON has no non-finite numbers)."""
    x = float(x)
    return x if math.isfinite(x) else ("nan" if math.isnan(x) else ("inf" if x > 0 else "-inf"))


def _exact_array(a: np.ndarray | None) -> list[Any] | None:
    if a is None:
        return None
    a = np.asarray(a, float)
    obj = a.astype(object)
    bad = ~np.isfinite(a)
    obj[bad] = [_exact_float(x) for x in a[bad]]
    return obj.tolist()


# the most matches a record may describe (its inlier mask and per-match arrays are allocated)
MAX_RECORD_POINTS = 10**8


def _read_float(x: Any, key: str) -> float:
    """A float of a result dict: a number, ``None`` (NaN) or ``"nan"`` / ``"inf"`` / ``"-inf"``."""
    if x is None:
        return math.nan
    if isinstance(x, str) and x in _NONFINITE:
        return _NONFINITE[x]
    if isinstance(x, bool) or not isinstance(x, (int, float)):
        raise InputError(f"RelativePoseResult.from_dict: {key!r} must be a number, got {x!r}")
    try:
        return float(x)
    except OverflowError:
        raise InputError(f"RelativePoseResult.from_dict: {key!r} is beyond a float's range") from None


def _read_array(x: Any, key: str, shape: tuple[int, ...] | None = None) -> NDArray[np.float64]:
    def conv(v: Any) -> Any:
        return [conv(u) for u in v] if isinstance(v, list) else _read_float(v, key)

    if not isinstance(x, list):
        raise InputError(f"RelativePoseResult.from_dict: {key!r} must be a list, got {type(x).__name__}")
    try:
        a = np.array(conv(x), dtype=float)
    except ValueError as exc:
        raise InputError(f"RelativePoseResult.from_dict: {key!r} is not a regular array ({exc})") from None
    if shape is not None and a.shape != shape:
        raise InputError(f"RelativePoseResult.from_dict: {key!r} must have shape {shape}, got {a.shape}")
    return a


def _iterations(v: Any) -> int:
    if isinstance(v, bool) or not isinstance(v, int) or not 0 <= v < 2**63:
        raise InputError(f"RelativePoseResult.from_dict: 'num_iterations' must be a non-negative integer, got {v!r}")
    return v


def _read_diagnostic(v: Any, key: str, exact: bool) -> Any:
    """A diagnostic as :meth:`RelativePoseResult.to_dict` wrote it: lists -> arrays (bool or float),
    ``"nan"`` / ``"inf"`` / ``"-inf"`` -> floats, anything else as is."""
    if v is None:  # a non-finite number of the default record (null); None itself in an exact one
        return None if exact else math.nan
    if isinstance(v, list):
        flat = np.ravel(np.array(v, dtype=object)) if v else np.empty(0, object)
        if flat.size and all(isinstance(u, bool) for u in flat):
            return np.array(v, dtype=bool)
        if flat.size and all(isinstance(u, int) and not isinstance(u, bool) and abs(u) < 2**63 for u in flat):
            return np.array(v, dtype=np.int64)
        return _read_array(v, f"diagnostics[{key!r}]")
    if isinstance(v, str) and v in _NONFINITE:
        return _NONFINITE[v]
    if isinstance(v, float) or (isinstance(v, int) and not isinstance(v, bool) and abs(v) >= 2**63):
        return _read_float(v, f"diagnostics[{key!r}]")
    if not isinstance(v, (bool, int, str)):
        raise InputError(f"RelativePoseResult.from_dict: diagnostics[{key!r}] must be a number, string, bool, list or null, got {type(v).__name__}")
    return v


@dataclass(eq=False, repr=False)
class RelativePoseResult(ValueEquality):
    """Relative pose ``X2 = R X1 + t`` (unit ``t``) with inliers and an honest status.

    ``status`` is one of

    * ``"ok"`` -- a confident calibrated pose: enough inliers (``min_inliers``; a match given twice,
      the same coordinates in both views, counts once: ``diagnostics["distinct_inliers"]``), far more than
      chance allows (a-contrario test, ``diagnostics["log10_nfa"] < -3``), no pure rotation, no
      planar twin;
    * ``"planar_ambiguous"`` -- the inliers are (near) planar and the homography twin (``R_twin``,
      ``t_twin``) explains them about as well; the caller must decide (e.g. with a third view);
    * ``"ambiguous"`` -- a second pose far from this one (``diagnostics["rival_R"]``,
      ``["rival_t"]``, at least ``rival_distance`` degrees of rotation away: one of the models the
      search kept in other basins, ``diagnostics["rivals_tested"]`` of them compared) explains at
      least as many matches of its own: the two views do not single out the pose;
    * ``"uncertain"`` -- the inliers single out the pose but do not pin its rotation down: its
      first-order standard deviation (``diagnostics["rotation_std_deg"]``, the least constrained
      axis, translation direction marginalised) exceeds ``max_rotation_std_deg`` (5/3 deg by default;
      typical of a small object or a narrow field of view with few matches, where the rotation trades
      against the translation), or is not known (the threshold does not resolve the matches' noise:
      ``diagnostics["noise_sigma_px"]`` inf); or, for GNC-IRLS, its iterations did not converge
      (``diagnostics["converged"]`` False); the pose is the best estimate, ``rotation_covariance``
      says how good;
    * ``"pure_rotation"`` -- a rotation without translation explains the matches, the pose's
      extra inliers are no more than chance and the rotation leaves no parallax above the noise on
      the matches both explain (``diagnostics["parallax_ratio"]``, see
      :func:`poseonly.analysis.parallax_ratio`): ``R`` is the robust rotation-only fit and reliable
      to ``diagnostics["rotation_std_deg"]`` (which includes its distance from the pose's R,
      ``diagnostics["rotation_model_spread_deg"]``), ``t`` (a unit vector, the epipolar fit's) is not;
      ``inliers`` are the rotation's; the epipolar pose is ``diagnostics["pose_R"]``, ``["pose_t"]``;
    * ``"too_few_inliers"`` -- fewer than ``min_inliers`` inliers, or not significantly more than
      randomly re-paired matches give the same model over all hypotheses tried, or a rotation that
      would be a pure rotation but whose fit is more than ``max_rotation_std_deg`` from the pose's R
      (neither is determined); ``R, t`` are the best guess and must not be trusted;
    * ``"degenerate"`` -- the correspondences do not determine a pose (e.g. all points identical)
      or the method found no valid model: ``R``, ``t`` and ``E`` are ``None``.

    ``rotation_covariance`` and ``translation_covariance`` are the pose's first-order covariance
    from the matches within the search threshold (:func:`poseonly.analysis.pose_uncertainty`: radians^2, the rotation's in the
    perturbation ``exp([d]x) R``, the unit translation's tangent to ``t``), ``None`` where no pose or
    no finite covariance exists and for ``too_few_inliers`` (whose inliers do not determine the pose;
    ``diagnostics["rotation_std_deg"]`` inf); for ``pure_rotation`` the rotation-only fit's, no translation's.

    ``inliers``, ``num_inliers`` and ``threshold_px`` are the final classification's, which need not be
    the option ``threshold_px`` (the search's threshold): the default method's ML stage decides by the
    noise it estimates on the matches, and ``threshold_px`` is then that decision threshold, often below
    the option's (the search's is ``diagnostics["search_threshold_px"]``). The matches within another
    distance ``d`` of the pose are ``residuals_px < d``: the Sampson error on the unit sphere (radians)
    times the focal length (``focal_px``), the pixel Sampson error near the image centre and 0.8-0.96x it
    toward a pinhole image's borders (a trial's real pairs), where the same angle is more pixels.

    Shapes: ``R (3, 3)``, ``t (3,)`` (unit), ``E (3, 3)``, ``inliers (n,)`` bool, ``weights (n,)``,
    ``residuals_px (n,)`` (NaN when undefined), ``rotation_covariance (3, 3)``,
    ``translation_covariance (3, 3)``.
    """

    R: np.ndarray | None
    t: np.ndarray | None
    E: np.ndarray | None
    inliers: np.ndarray
    weights: np.ndarray
    residuals_px: np.ndarray
    num_inliers: int
    num_iterations: int
    status: Status
    message: str
    method: str
    threshold_px: float
    focal_px: float
    parallax_deg: float = float("nan")
    R_twin: np.ndarray | None = None
    t_twin: np.ndarray | None = None
    twin_inliers: int = 0
    time_s: float = field(default=0.0, compare=False)  # a run's duration: not part of its value (==)
    diagnostics: dict[str, Any] = field(default_factory=dict)
    rotation_covariance: np.ndarray | None = None
    translation_covariance: np.ndarray | None = None

    @property
    def ok(self) -> bool:
        return self.status == "ok"

    @property
    def inlier_ratio(self) -> float:
        return self.num_inliers / max(len(self.inliers), 1)

    @property
    def rotation_std_deg(self) -> float:
        """The rotation's first-order standard deviation in degrees (``diagnostics["rotation_std_deg"]``,
        the least constrained axis); ``inf`` where not known (``too_few_inliers``, ``degenerate``)."""
        return float(self.diagnostics.get("rotation_std_deg", math.inf))

    @property
    def translation_std_deg(self) -> float:
        """The translation direction's first-order standard deviation in degrees; ``inf`` where not known,
        NaN for ``pure_rotation`` (no translation)."""
        return float(self.diagnostics.get("translation_std_deg", math.inf))

    def pose(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """``(R (3, 3), t (3,))`` with ``X2 = R X1 + t`` (unit ``t``); raises :class:`NoPoseError` (a
        ``ValueError``) for a ``degenerate`` result, which holds none. Whether to trust the pose is
        :attr:`status`'s to say."""
        if self.R is None or self.t is None:
            raise NoPoseError(f"a {self.status!r} result holds no pose: {self.message}")
        return self.R, self.t

    def __repr__(self) -> str:
        """One line: status, inliers, the deviations, the method and the message (the arrays are fields)."""
        return (
            f"RelativePoseResult(status={self.status!r}, inliers={self.num_inliers}/{len(self.inliers)}, "
            f"rotation_std_deg={self.rotation_std_deg:.3g}, translation_std_deg={self.translation_std_deg:.3g}, "
            f"threshold_px={self.threshold_px:.3g}, method={self.method!r}, message={self.message!r})"
        )

    def to_dict(self, *, exact: bool = False) -> dict[str, Any]:
        """JSON-safe summary (``json.dumps(..., allow_nan=False)`` works): arrays as lists, ``None`` (null)
        for undefined values (no pose, NaN parallax, no twin, no covariance: every key is always there);
        ``inliers`` as indices; ``schema_version`` :data:`RESULT_SCHEMA_VERSION`.

        ``exact=True`` is the record :meth:`from_dict` turns back into an equal result (``==``): it adds
        ``weights`` and ``residuals_px`` (per match) and writes non-finite numbers as the strings
        ``"nan"``, ``"inf"``, ``"-inf"`` (``rotation_std_deg`` is inf where it is not known, NaN where it
        is undefined; ``None`` would not tell them apart)."""
        num = _exact_float if exact else _json_float
        arr = _exact_array if exact else _json_array
        d: dict[str, Any] = {
            "schema_version": RESULT_SCHEMA_VERSION,
            "R": arr(self.R),
            "t": arr(self.t),
            "E": arr(self.E),
            "num_inliers": int(self.num_inliers),
            "num_points": len(self.inliers),
            "inlier_ratio": num(self.inlier_ratio),
            "inliers": np.nonzero(self.inliers)[0].tolist(),
            "num_iterations": int(self.num_iterations),
            "status": self.status,
            "message": self.message,
            "method": self.method,
            "threshold_px": num(self.threshold_px),
            "focal_px": num(self.focal_px),
            "parallax_deg": num(self.parallax_deg),
            "time_s": num(self.time_s),
            "diagnostics": {k: _json_value(v, exact) for k, v in self.diagnostics.items()},
        }
        # every key always present (null where undefined: no twin, no covariance), so a reader can index
        # any result the same way
        twin = self.R_twin is not None
        d["R_twin"] = arr(self.R_twin) if twin else None
        d["t_twin"] = arr(self.t_twin) if twin else None
        d["twin_inliers"] = int(self.twin_inliers)
        d["rotation_covariance"] = None if self.rotation_covariance is None else arr(self.rotation_covariance)
        d["translation_covariance"] = None if self.translation_covariance is None else arr(self.translation_covariance)
        if exact:
            d["weights"] = arr(self.weights)
            d["residuals_px"] = arr(self.residuals_px)
        return d

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> RelativePoseResult:
        """The result a :meth:`to_dict` record describes (e.g. read back from JSON). From a record of
        ``to_dict(exact=True)`` the result equals the original (``==``); from the default record,
        ``weights`` are the inlier mask and ``residuals_px`` NaN (not written), and non-finite numbers
        written as ``None`` read as NaN. Raises :class:`poseonly.InputError` (a ``ValueError``) naming a
        missing or malformed key, or an unknown ``schema_version``."""
        if not isinstance(d, Mapping):
            raise InputError(f"RelativePoseResult.from_dict needs a mapping, got {type(d).__name__}")
        version = d.get("schema_version", RESULT_SCHEMA_VERSION)
        if type(version) is not int or version != RESULT_SCHEMA_VERSION:
            raise InputError(f"RelativePoseResult.from_dict reads schema_version {RESULT_SCHEMA_VERSION}, got {version!r}")
        for key in ("R", "t", "E", "num_inliers", "num_points", "inliers", "num_iterations", "status", "message", "method", "threshold_px", "focal_px"):
            if key not in d:
                raise InputError(f"RelativePoseResult.from_dict: the record has no {key!r}")
        status = d["status"]
        if status not in STATUSES:
            raise InputError(f"RelativePoseResult.from_dict: status must be one of {STATUSES}, got {status!r}")

        def count(key: str, default: int | None = None) -> int:
            v = d.get(key, default)
            if isinstance(v, bool) or not isinstance(v, int) or not 0 <= v <= MAX_RECORD_POINTS:
                raise InputError(f"RelativePoseResult.from_dict: {key!r} must be an integer in [0, {MAX_RECORD_POINTS}], got {v!r}")
            return v

        def text(key: str) -> str:
            v = d[key]
            if not isinstance(v, str):
                raise InputError(f"RelativePoseResult.from_dict: {key!r} must be a string, got {v!r}")
            return v

        n = count("num_points")
        idx = d["inliers"]
        if not isinstance(idx, list) or not all(isinstance(i, int) and not isinstance(i, bool) and 0 <= i < n for i in idx):
            raise InputError(f"RelativePoseResult.from_dict: 'inliers' must be a list of indices below num_points = {n}")
        inliers = np.zeros(n, dtype=bool)
        inliers[idx] = True
        num_inliers = count("num_inliers")
        if num_inliers != len(idx) or num_inliers != int(inliers.sum()):
            raise InputError(f"RelativePoseResult.from_dict: num_inliers = {num_inliers} but 'inliers' holds {len(idx)} indices ({int(inliers.sum())} distinct)")
        if (d["R"] is None or d["t"] is None or d["E"] is None) != (status == "degenerate") or not (d["R"] is None) == (d["t"] is None) == (d["E"] is None):
            raise InputError(f"RelativePoseResult.from_dict: R, t and E must be null exactly for status 'degenerate' (status {status!r})")

        def opt(key: str, shape: tuple[int, ...]) -> NDArray[np.float64] | None:
            v = d.get(key)
            return None if v is None else _read_array(v, key, shape)

        def per_match(key: str, default: NDArray[np.float64]) -> NDArray[np.float64]:
            v = d.get(key)
            return default if v is None else _read_array(v, key, (n,))

        exact = "residuals_px" in d  # to_dict(exact=True)'s record: non-finite numbers are strings there
        diag = d.get("diagnostics", {})
        if not isinstance(diag, Mapping):
            raise InputError("RelativePoseResult.from_dict: 'diagnostics' must be a mapping")
        return cls(
            R=opt("R", (3, 3)),
            t=opt("t", (3,)),
            E=opt("E", (3, 3)),
            inliers=inliers,
            weights=per_match("weights", inliers.astype(float)),
            residuals_px=per_match("residuals_px", np.full(n, np.nan)),
            num_inliers=num_inliers,
            num_iterations=_iterations(d["num_iterations"]),
            status=status,
            message=text("message"),
            method=text("method"),
            threshold_px=_read_float(d["threshold_px"], "threshold_px"),
            focal_px=_read_float(d["focal_px"], "focal_px"),
            parallax_deg=_read_float(d.get("parallax_deg"), "parallax_deg"),
            R_twin=opt("R_twin", (3, 3)),
            t_twin=opt("t_twin", (3,)),
            twin_inliers=count("twin_inliers", 0),
            time_s=_read_float(d.get("time_s", 0.0), "time_s"),
            diagnostics={str(k): _read_diagnostic(v, str(k), exact) for k, v in diag.items()},
            rotation_covariance=opt("rotation_covariance", (3, 3)),
            translation_covariance=opt("translation_covariance", (3, 3)),
        )


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
    :data:`poseonly.analysis.NFA_MAX` -> ``too_few_inliers``; a planar twin -> ``planar_ambiguous``;
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
    if "tau_effective" in diag:  # the default method's noise-matched threshold (<= the user's)
        tau = diag["tau_effective"]
        thr_px = tau * focal
    n = len(f1)
    if not valid_pose(R, t):
        return degenerate_result(n, diag.get("rank", -1), method, thr_px, focal, t0, reason=f"the {method!r} method found no valid pose (no hypothesis scored)", diag=diag)
    t = _unit(t)
    v = v_sampson.unchecked(R, t, f1, f2)
    inl = v < tau
    n_in = int(inl.sum())
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

    def distinct(x: np.ndarray) -> np.ndarray:
        return x if once is None else x[once]

    g1, g2 = distinct(f1), distinct(f2)
    n_once, n_in_once = len(g1), int(np.count_nonzero(distinct(inl)))
    lnfa = log10_nfa(n_in_once, n_once, p_pose, num_tests, POSE_DOF)
    diag.update(chance_inliers=n * p_pose, chance_rate=p_pose, log10_nfa=lnfa, distinct_inliers=n_in_once)
    if n_once < MIN_DISTINCT_MATCHES:
        # matches that all repeat a few (e.g. normalized coordinates passed with a K: every pixel within a
        # pixel of the principal point) are too few observations for any of the tests below (a trial: the
        # rotation search raised "at least 2 points are needed" on 1022 such matches)
        diag.update(rotation_std_deg=np.inf, translation_std_deg=np.inf, noise_sigma_px=float("nan"))
        return RelativePoseResult(
            R=R,
            t=t,
            E=essential_from_pose(R, t),
            inliers=inl,
            weights=weights,
            residuals_px=v * focal,
            num_inliers=n_in,
            num_iterations=int(iters),
            status="too_few_inliers",
            message=(
                f"{n} matches, but only {n_once} distinct (matches within {NEAR_DUPLICATE_PX:g} px of each other in both views "
                f"count once; {MIN_DISTINCT_MATCHES} needed): they do not determine a pose (pixels passed as normalized "
                "coordinates, or normalized coordinates with a K?)"
            ),
            method=method,
            threshold_px=float(thr_px),
            focal_px=focal,
            parallax_deg=parallax_deg(R, f1, f2, inl),
            time_s=time.perf_counter() - t0,
            diagnostics=diag,
        )
    # the rotation-only alternative is fitted at the search threshold at least: at a decision threshold
    # the pose itself shrank (an ML fit to a tight subset) a rotation would miss its own noisy inliers
    tau_rot = max(tau, tau_search)
    rot = pure_rotation_test(g1, g2, tau_rot, distinct(inl), p_pose, num_tests, v_pose=distinct(v), noise_floor=noise_floor)
    R_rot = rot.pop("R_rotation_only")
    diag.update(rot)
    R_twin = t_twin = None
    twin_n = 0
    par = parallax_deg(R, f1, f2, inl)
    residuals = v * focal
    needed = max(6, min_inliers)
    # the covariance of the model the status speaks for: the rotation-only fit's on its inliers, or the pose's
    # on the matches within the search threshold (a decision threshold shrunk by the ML stage would truncate
    # the inliers' noise and leave the pose's precision to a few matches)
    rot_inl = _rotation_inliers_mask(R_rot, f1, f2, tau_rot) if rot["pure_rotation"] else None
    if rot_inl is None:
        unc = pose_uncertainty(R, t, g1, g2, distinct(v < tau_rot), tau_rot, noise_floor)
        if not sampson_final:
            unc = _with_estimator_spread(unc, R, t, g1, g2, distinct(v < tau_rot), diag)
        if diag.get("leverage_spread_deg", 0.0) > 0 or diag.get("leverage_translation_spread_deg", 0.0) > 0:
            # the pose's significant distance from its other inliers' fit (poseonly.robust.default.leverage_test)
            unc = _with_model_spread(unc, float(np.radians(diag["leverage_spread_deg"])), float(np.radians(diag["leverage_translation_spread_deg"])), t)
    else:
        unc = pose_uncertainty(R_rot, None, g1, g2, distinct(rot_inl), _rotation_chord(tau_rot), noise_floor)
        diag["distinct_inliers"] = int(np.count_nonzero(distinct(rot_inl)))
    minority = rotation_explains_most(rot)
    if minority:
        # the rotation-only fit is the other reading (a still camera, objects moving): its distance from the
        # pose's R is part of R's uncertainty (a SLAM user's trial: R 0.18 deg off the still camera's
        # identity against a first-order deviation of 0.03)
        spread_rot = float(np.radians(rotation_error_deg(R, R_rot)))
        unc = _with_model_spread(unc, spread_rot)
        diag["rotation_model_spread_deg"] = float(np.degrees(spread_rot))
    diag.update(rotation_std_deg=unc["rotation_std_deg"], translation_std_deg=unc["translation_std_deg"], noise_sigma_px=unc["noise_sigma"] * focal)
    status: Status
    if rot_inl is not None:
        status = "pure_rotation"
        # the rotation-only fit absorbs whatever parallax the matches cannot resolve, and the pose's R
        # absorbs it differently: their difference is part of R's uncertainty (a 0.03 baseline at depths
        # 4-10: the fit 0.2 deg off, its noise-only deviation 0.02 deg, the difference 0.39 deg)
        delta = float(np.radians(rotation_error_deg(R, R_rot)))
        # the robust rotation-only fit is the estimate of R here; the epipolar pose stays in the diagnostics
        # (a caller that knows the camera moved may prefer it: 10 cm sideways at 10-50 m is a pure rotation
        # to the matches, and its translation direction was within a few degrees in a user's trial)
        diag.update(pose_R=R, pose_t=t)
        R = R_rot
        unc = _with_model_spread(unc, delta)
        diag.update(rotation_std_deg=unc["rotation_std_deg"], rotation_model_spread_deg=float(np.degrees(delta)))
        ang = _rotation_angles(R, f1, f2)
        inl = rot_inl
        n_in = int(inl.sum())
        weights = inl.astype(float)
        residuals = ang * focal
        par = parallax_deg(R, f1, f2, inl)
        spread = float(np.degrees(delta))
        if spread > max_rotation_std_deg or (np.isfinite(unc["rotation_std_deg"]) and unc["rotation_std_deg"] > max_rotation_std_deg):
            # the pose's translation has no support beyond chance and the rotation-only fit is not
            # determined either (a poor pose of the paper's methods: 125-150 deg off, the fit 5 deg off):
            # nothing here is reliable, and E = [t]x R would mix the two models
            status = "too_few_inliers"
            msg = (
                f"a rotation without translation explains {n_in} matches within {2 * tau_rot * focal:g} px and the pose's other "
                f"inliers are no more than chance, but the rotation-only fit is {spread:.2f} deg from the pose's R (max_rotation_std_deg = "
                f"{max_rotation_std_deg:g}): neither R nor the translation direction is reliable"
            )
        else:
            msg = (
                f"a rotation without translation explains {n_in} matches within {2 * tau_rot * focal:g} px and the pose's "
                f"other inliers are no more than chance (median parallax {par:.3f} deg): R is reliable"
                + (f" to {unc['rotation_std_deg']:.3g} deg (one standard deviation)" if np.isfinite(unc["rotation_std_deg"]) else "")
                + ", the translation direction is not"
            )
    elif n_in_once < needed or lnfa >= np.log10(NFA_MAX):
        status = "too_few_inliers"
        counted = f"{n_in} inliers" + ("" if n_in_once == n_in else f" ({n_in_once} distinct)") + f" within {thr_px:g} px"
        if n_in_once < needed:
            msg = f"{counted}, {needed} needed (min_inliers): the pose is not reliable"
        else:
            msg = (
                f"{counted}; randomly re-paired matches give the same model {n * p_pose:.1f} inliers, and over the "
                f"{num_tests:.3g} hypotheses tried chance explains this support (expected false alarms 10^{lnfa:.1f} >= "
                f"{NFA_MAX:g}): the pose is not reliable"
            )
    else:
        # inliers whose bearings in one view lie on a great circle within the threshold do not determine the
        # pose (an adversarial trial: points on one 3-D line gave `ok` poses 172-178 deg off with the paper's
        # methods; the rank test of the epipolar system sees the noise as a sixth dimension)
        ins = distinct(inl)
        circle = [great_circle_spread(g1[ins]), great_circle_spread(g2[ins])]
        diag["great_circle_spread_px"] = min(circle) * focal
        if min(circle) <= tau:
            view = 1 + int(np.argmin(circle))
            reason = (
                f"the {n_in} inliers' bearings in view {view} lie within {min(circle) * focal:.3g} px (RMS) of one plane through "
                f"the camera's centre, inside the threshold ({thr_px:g} px): every scene point on a plane through that centre "
                "(e.g. on one 3-D line) leaves the pose undetermined"
            )
            for key in ("estimator_spread_deg", "estimator_translation_spread_deg", "leverage_spread_deg", "leverage_translation_spread_deg"):
                diag.pop(key, None)  # of a pose not returned
            diag.update(rotation_std_deg=np.inf, translation_std_deg=np.inf, great_circle_view=view)
            return degenerate_result(n, diag.get("rank", -1), method, thr_px, focal, t0, reason=reason, diag=diag)
        twin, info = planar_twin(R, t, g1, g2, tau, distinct(inl))
        diag.update(info)
        if equally_supported_twin(info) and info["twin_cost_excess"] <= TWIN_SPREAD_CHI2:
            # a planar scene's twin that explains the matches as well as the pose: the matches do not tell
            # the two apart, so their distance is part of the pose's uncertainty. Forward motion towards a
            # plane merges the twins into a flat valley the first-order covariance does not see (twins 0.9
            # deg apart, the pose 0.7 deg off, its first-order deviation 0.08 deg)
            unc = _with_model_spread(unc, float(np.radians(info["twin_separation_deg"])), float(np.radians(info["twin_translation_separation_deg"])), t)
            diag.update(rotation_std_deg=unc["rotation_std_deg"], translation_std_deg=unc["translation_std_deg"], twin_spread_deg=float(info["twin_separation_deg"]))
        if twin is not None:
            status = "planar_ambiguous"
            R_twin, t_twin, twin_n = twin
            msg = (
                f"the inliers are explained by two poses {rotation_error_deg(R, R_twin):.2f} deg apart "
                f"(the homography twin keeps {twin_n} inliers in front of both cameras: a planar scene, or one whose depth "
                "the parallax does not resolve); see R_twin, t_twin"
            )
        else:
            amb = None
            for k, (Rv, tv) in enumerate(rivals):
                # compared at the search threshold, as the search scored both; the first rival that
                # the pose does not beat decides (reported as rival_R, rival_t), else the best one
                test = rival_test(R, t, Rv, _unit(tv), g1, g2, tau_search, diag["rival_distance"])
                diag["rivals_tested"] = k + 1
                if amb is None or test["ambiguous"]:
                    amb = test
                    diag.update(test, rival_R=Rv, rival_t=tv)
                if test["ambiguous"]:
                    break
            if amb is not None and amb["ambiguous"]:
                status = "ambiguous"
                msg = (
                    f"a second pose {amb['rival_separation_deg']:.1f} deg away (diagnostics rival_R, rival_t) explains "
                    f"{amb['rival_only']} matches the pose does not, against the pose's {amb['pose_only']} it does not, "
                    f"too few to prefer the pose (sign test p = {10 ** amb['rival_log10_p']:.2g} >= {AMBIGUITY_LEVEL:g}): "
                    "the matches do not single out the pose"
                )
            elif max_rotation_std_deg < np.inf and not unc["rotation_std_deg"] <= max_rotation_std_deg:
                status = "uncertain"
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
            elif max_translation_std_deg < np.inf and not unc["translation_std_deg"] <= max_translation_std_deg:
                status = "uncertain"
                msg = (
                    f"{n_in} inliers within {thr_px:g} px single out the pose, but they determine its translation direction only to "
                    f"{unc['translation_std_deg']:.2f} deg (one standard deviation, with the spread to other fits of the matches: "
                    f"diagnostics leverage_translation_spread_deg, twin_spread_deg; max_translation_std_deg = {max_translation_std_deg:g}): see "
                    "translation_covariance"
                )
            elif diag.get("converged") is False:
                # GNC-IRLS's pose is defined where its weights settle; one still moving can sit on a few inliers
                # far from the pose the matches give (a researcher's trial: 4.4 deg off, 19 deviations, as ok)
                status = "uncertain"
                msg = (
                    f"{n_in} inliers within {thr_px:g} px, but the method's iterations did not converge (max_iterations): "
                    "its weights had not settled, so the pose is not vouched for"
                )
            else:
                status, msg = "ok", f"{n_in} inliers within {thr_px:g} px (expected false alarms 10^{lnfa:.0f})"
                if minority:
                    msg += (
                        f"; {100 * rot['rotation_only_fraction']:.0f} % of them fit a rotation alone: the translation rests on "
                        "the rest (a near surface, or objects that moved; two views cannot tell)"
                    )
    if status == "too_few_inliers":
        for key in ("estimator_spread_deg", "estimator_translation_spread_deg", "leverage_spread_deg", "leverage_translation_spread_deg"):  # of a covariance not reported
            diag.pop(key, None)
        # inliers that chance explains, or too few to estimate their noise from, do not determine the pose
        # (a handful fitted exactly gave deviations of 1e-14 deg to a pose 160 deg off): no covariance
        unc = {**unc, "rotation_covariance": None, "translation_covariance": None, "rotation_std_deg": np.inf, "translation_std_deg": np.inf}
        diag.update(rotation_std_deg=np.inf, translation_std_deg=np.inf)
    return RelativePoseResult(
        R=R,
        t=t,
        E=essential_from_pose(R, t),
        inliers=inl,
        weights=weights,
        residuals_px=residuals,
        num_inliers=n_in,
        num_iterations=int(iters),
        status=status,
        message=msg,
        method=method,
        threshold_px=float(thr_px),
        focal_px=focal,
        parallax_deg=par,
        R_twin=R_twin,
        t_twin=t_twin,
        twin_inliers=twin_n,
        time_s=time.perf_counter() - t0,
        diagnostics=diag,
        rotation_covariance=unc["rotation_covariance"],
        translation_covariance=unc["translation_covariance"],
    )


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
