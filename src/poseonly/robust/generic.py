"""RANSAC over an estimator written in Python: the core's one robust loop with your model.

The loop is the core's ``ransac<>`` (``src/core/ransac.h``: sampling, uniform or PROSAC, MSAC /
multi-scale MSAC / inlier-count scoring with the exact bail-out, local optimisation on each new best,
challengers, adaptive stopping), the same template the default method and GNC-RANSAC run; here its
estimator is a Python object (``PyEstimator`` in ``src/core/bind_robust.cpp``), so models can be any
Python objects and the loop holds the GIL. The estimator contract is PoseLib's (``sample_sz /
generate_models / score_model / refine_model``) and COLMAP's (``Estimate / Residuals``), in the
spirit of scikit-image's ``RansacModelProtocol``:

* ``sample_size: int`` and ``num_data: int`` (attributes);
* ``generate(sample) -> Sequence[model]``: the minimal solver on the data rows ``sample (s,)``
  (int64 indices), zero or more candidate models;
* ``residuals(model) -> (num_data,)``: non-negative residuals in the threshold's units (NaN counts
  as an outlier);
* optional ``refine(model, inliers) -> model | None``: local optimisation on the inlier indices
  ``(k,)`` (None: keep the model);
* optional ``distance(a, b) -> float``: how far apart two models are (needed for ``challengers``).

``tests/test_generic_ransac.py`` runs it on a 2-D line and on a homography estimator written in
numpy. The two-view estimators stay in the core (their Python calls would cost ~10x).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any, Protocol, runtime_checkable

import numpy as np

from .. import _core
from ..geometry import InputError
from .ransac import core_seed

__all__ = ["GenericRansacResult", "RansacEstimator", "SCORINGS", "ransac"]

SCORINGS = {"msac": 0, "multi-msac": 1, "count": 2}  # the core's Scoring


@runtime_checkable
class RansacEstimator(Protocol):
    """The estimator contract of :func:`ransac` (``refine`` and ``distance`` are optional)."""

    sample_size: int
    num_data: int

    def generate(self, sample: np.ndarray) -> Sequence[Any]: ...

    def residuals(self, model: Any) -> np.ndarray: ...


@dataclass(eq=False)
class GenericRansacResult:
    """``model`` (None where no sample gave one), ``inliers (num_data,)`` bool (residual <= threshold),
    ``residuals (num_data,)`` of the model (None without one), ``num_iterations`` (samples drawn) and
    the core's ``stats`` (``cost``, ``num_lo``, ``needed``, ...)."""

    model: Any
    inliers: np.ndarray
    residuals: np.ndarray | None
    num_iterations: int
    stats: dict[str, Any] = field(default_factory=dict)


class _Checked:
    """The user's estimator with each answer checked: the core sees lists of models and float64
    ``(num_data,)`` residuals, and a wrong shape or type is an :class:`InputError` naming the method."""

    def __init__(self, est: Any, n: int) -> None:
        self.est, self.n = est, n

    def generate(self, sample: np.ndarray) -> list[Any]:
        out = self.est.generate(sample)
        if out is None:
            return []
        if isinstance(out, (str, bytes)) or not isinstance(out, Sequence):
            raise InputError(f"estimator.generate must return a sequence of models (a list, possibly empty), got {type(out).__name__}")
        return list(out)

    def residuals(self, model: Any) -> np.ndarray:
        try:
            r = np.asarray(self.est.residuals(model), dtype=np.float64)
        except (TypeError, ValueError) as exc:
            raise InputError(f"estimator.residuals must return numbers: {exc}") from None
        if r.shape != (self.n,):
            raise InputError(f"estimator.residuals must return shape ({self.n},) (num_data), got {r.shape}")
        if np.any(r < 0):
            raise InputError("estimator.residuals must be non-negative (distances, not signed errors)")
        return np.ascontiguousarray(np.where(np.isnan(r), np.inf, r))

    def refine(self, model: Any, inliers: np.ndarray) -> Any:
        return self.est.refine(model, inliers)

    def distance(self, a: Any, b: Any) -> float:
        return float(self.est.distance(a, b))


def _count(v: Any, name: str, lo: int) -> int:
    if isinstance(v, (bool, np.bool_)) or not isinstance(v, (int, np.integer)) or int(v) < lo:
        raise InputError(f"{name} must be an int >= {lo}, got {v!r}")
    return int(v)


def ransac(
    estimator: RansacEstimator,
    threshold: float,
    *,
    seed: int | np.random.Generator = 0,
    max_iterations: int = 1000,
    min_iterations: int = 0,
    confidence: float = 0.999,
    scoring: str = "msac",
    max_lo: int = 8,
    challengers: int = 0,
    challenger_distance: float = 1.0,
    order: np.ndarray | None = None,
) -> GenericRansacResult:
    """LO-RANSAC of ``estimator`` (see the module docstring for its contract) at ``threshold`` (the
    residuals' units). ``scoring``: ``"msac"`` (truncated quadratic), ``"multi-msac"`` (the default
    method's multi-scale MSAC) or ``"count"`` (inliers); ``order (num_data,)``: a permutation, best
    row first, for PROSAC sampling; ``challengers > 0`` needs ``estimator.distance``. Deterministic
    for a given ``seed`` (an int in ``[0, 2**64)`` or a ``numpy.random.Generator``)."""
    for attr in ("generate", "residuals"):
        if not callable(getattr(estimator, attr, None)):
            raise InputError(f"the estimator has no method {attr}() (poseonly.robust.generic.RansacEstimator)")
    s = _count(getattr(estimator, "sample_size", None), "estimator.sample_size", 1)
    n = _count(getattr(estimator, "num_data", None), "estimator.num_data", s)
    if isinstance(threshold, (bool, np.bool_)) or not isinstance(threshold, (int, float, np.integer, np.floating)) or not (threshold > 0 and np.isfinite(threshold)):
        raise InputError(f"threshold must be a finite number > 0, got {threshold!r}")
    if scoring not in SCORINGS:
        raise InputError(f"scoring must be one of {sorted(SCORINGS)}, got {scoring!r}")
    max_iterations = _count(max_iterations, "max_iterations", 1)
    min_iterations = _count(min_iterations, "min_iterations", 0)
    max_lo = _count(max_lo, "max_lo", 0)
    challengers = _count(challengers, "challengers", 0)
    if isinstance(confidence, (bool, np.bool_)) or not isinstance(confidence, (int, float, np.floating)) or not 0 < confidence < 1:
        raise InputError(f"confidence must be in (0, 1), got {confidence!r}")
    ordered = None
    if order is not None:
        ordered = np.asarray(order)
        if ordered.shape != (n,) or not np.issubdtype(ordered.dtype, np.integer) or not np.array_equal(np.sort(ordered), np.arange(n)):
            raise InputError(f"order must be a permutation of range({n}) (num_data)")
        ordered = np.ascontiguousarray(ordered, dtype=np.int64)
    checked = _Checked(estimator, n)
    has_refine = callable(getattr(estimator, "refine", None))
    has_distance = callable(getattr(estimator, "distance", None))
    if challengers and not has_distance:
        raise InputError("challengers > 0 need the estimator's distance(a, b) (how far apart two models are)")
    if challengers > 64 or not (challenger_distance > 0 and np.isfinite(challenger_distance)):
        raise InputError(f"challengers must be <= 64 and challenger_distance finite and > 0, got {challengers}, {challenger_distance!r}")
    model, stats = _core.ransac_python(
        checked,
        s,
        n,
        has_refine,
        has_distance,
        float(threshold),
        core_seed(seed),
        max_iterations,
        min_iterations,
        float(confidence),
        max_lo,
        SCORINGS[scoring],
        challengers,
        float(challenger_distance),
        ordered,
    )
    if model is None:
        return GenericRansacResult(None, np.zeros(n, bool), None, int(stats["iterations"]), stats)
    r = checked.residuals(model)
    return GenericRansacResult(model, r <= threshold, r, int(stats["iterations"]), stats)
