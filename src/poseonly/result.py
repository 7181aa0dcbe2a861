"""The result type of :func:`poseonly.estimate_relative_pose`: :class:`RelativePoseResult`, its
statuses (:data:`Status`) and its exact records (``to_dict`` / ``from_dict``). The status decision
lives in :mod:`poseonly.status`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any, Literal, get_args

import numpy as np
from numpy.typing import NDArray

from ._equality import ValueEquality
from ._json import json_array, json_float
from .geometry import InputError

__all__ = ["RESULT_SCHEMA_VERSION", "STATUSES", "NoPoseError", "RelativePoseResult", "Status"]

Status = Literal["ok", "planar_ambiguous", "ambiguous", "uncertain", "pure_rotation", "too_few_inliers", "degenerate"]
"""The statuses of :class:`RelativePoseResult` (see there); ``"ok"`` means "trust this pose"."""
STATUSES: tuple[Status, ...] = get_args(Status)

# the layout of RelativePoseResult.to_dict (from_dict reads this version and dicts without the key)
RESULT_SCHEMA_VERSION = 1


class NoPoseError(ValueError):
    """:meth:`RelativePoseResult.pose` of a ``degenerate`` result, which holds no pose."""


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
      within ``poseonly.status.NEAR_DUPLICATE_PX`` (0.5 px) in both views, counts once:
      ``diagnostics["distinct_inliers"]``), far more than
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
    noise it estimates on the matches, and ``threshold_px`` is then that decision threshold: below the
    option's where the matches are more precise than it assumes and outliers lie close, above it (up to
    ``ml_range`` times it) where few outliers lie near the epipolar lines (the search's threshold is
    ``diagnostics["search_threshold_px"]``; a migrating user's trial at 0.5 px noise and 0.5-1 px: 1.15-2.6
    px). Inlier counts therefore differ from OpenCV's and PoseLib's at the same threshold. The matches within another
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
        is undefined; ``None`` would not tell them apart). Every record holds ``time_s``, the one field
        that differs between two runs of the same pair (drop it to compare logs byte for byte)."""
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


# names that lived here until the status decision moved to poseonly.status
_MOVED_TO_STATUS = frozenset({"finish", "degenerate_result", "distinct_rows", "NEAR_DUPLICATE_PX", "NEAR_DUPLICATE_MAX_RAD", "MIN_DISTINCT_MATCHES"})


def __getattr__(name: str) -> Any:
    if name in _MOVED_TO_STATUS:
        import warnings

        from . import status

        warnings.warn(f"poseonly.result.{name} moved to poseonly.status.{name}", DeprecationWarning, stacklevel=2)
        return getattr(status, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
