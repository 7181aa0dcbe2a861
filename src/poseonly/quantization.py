"""The rounding noise of quantised pixel coordinates: the least noise any fit of them can have.

Detectors without sub-pixel refinement (FAST, ORB's finest level, ``goodFeaturesToTrack``) give
integer pixels. Rounded coordinates carry a uniform error of at least ``step / sqrt(12)`` per
coordinate, and a wrong model can fit a large share of them *exactly*: under a small pure rotation
most matches keep their row, and a sideways translation then explains them with zero error. The
robust noise scales (EM's, the covariance's, the pure-rotation test's), which are medians of the
errors, then collapse to ~1e-8 px and make that pose look infinitely precise (a VO trial: a pure
0.3 deg yaw on integer keypoints came back ``ok`` with ``R = I``, the translation sideways, "1565 inliers
within 0.000342 px"). The noise scales are floored at the rounding noise of the input's grid
(:func:`rounding_sigma_px`), which :func:`grid_step` detects. SuperPoint and DISK keypoints are pixel
centres of the (possibly resized) image; FAST, ``goodFeaturesToTrack`` and ORB without sub-pixel
refinement round too.
"""

from __future__ import annotations

import math

import numpy as np

from .geometry import InputError, opencv_points

__all__ = ["GRID_MIN_SHARE", "TIE_MIN_SHARE", "axis_step", "check_coordinate_step", "grid_step", "image_grid_step", "pair_grid_step", "rounding_sigma_px"]

# a view's coordinate axis is on a grid (offset + step * integer) when at least this share of its
# values is (sub-pixel coordinates land on one by chance at a rate ~2e-3 px / step)
GRID_MIN_SHARE = 0.5
GRID_MIN_VALUES = 8  # distinct values an axis needs for its grid to be estimated
GRID_MIN_STEP_PX = 0.1  # finer grids round by < 0.03 px: no floor worth applying
GRID_TOL_PX = 2e-3  # |x - grid| below this (plus GRID_TOL_REL |x|: float32 storage) is on the grid
GRID_STEP_PER_TOL = 20.0  # a grid is at least this many tolerances wide (coordinates of 5e5 px: 2 px)
GRID_TOL_REL = 2e-7  # float32's relative rounding is 6e-8 (1e-6 put sub-pixel values at 2e5 px on a grid: a trial)
GRID_DIVISORS = (1, 2, 3, 4)  # the step is the least gap between distinct values, or it over these
GRID_SHARE_KEEP = 0.9  # ... the coarsest of them holding this share of the values the best one holds
COMMON_STEPS_PX = (1.0, 0.5)  # tried as well: sparse values' least gap can be many steps
# where no grid holds (ORB: each pyramid level on its own grid), exact ties x1 == x2 or y1 == y2 in at
# least this share of the matches say the coordinates are rounded all the same (a sub-pixel coordinate
# equals another by chance almost never); their grid is then taken as the pixel
TIE_MIN_SHARE = 0.2
TIE_STEP_PX = 1.0


def _on_grid(v: np.ndarray, offset: float, step: float) -> np.ndarray:
    return np.abs(v - offset - step * np.round((v - offset) / step)) <= GRID_TOL_PX + GRID_TOL_REL * np.abs(v)


def axis_step(v: np.ndarray) -> float:
    """The grid step of one coordinate axis ``v (n,)`` (pixels): of the least gap between its distinct
    values over :data:`GRID_DIVISORS` and :data:`COMMON_STEPS_PX` (not finer than :data:`GRID_MIN_STEP_PX`), the coarsest on which
    :data:`GRID_SHARE_KEEP` of the share of the best lie, if that is at least :data:`GRID_MIN_SHARE`
    (offsets from the smallest and the median value); 0 where there is none (sub-pixel coordinates)."""
    v = np.sort(v[np.isfinite(v)])
    if len(v) == 0:
        return 0.0
    gaps = np.diff(v)
    gaps = gaps[gaps > GRID_TOL_PX]  # between distinct values
    if len(gaps) + 1 < GRID_MIN_VALUES:
        return 0.0
    g = float(gaps.min())
    shares = {}
    tol = GRID_TOL_PX + GRID_TOL_REL * float(np.abs(v).max())
    for step in {g / k for k in GRID_DIVISORS} | set(COMMON_STEPS_PX):
        if step < max(GRID_MIN_STEP_PX, GRID_STEP_PER_TOL * tol):  # (a tolerance near the step: every value on it)
            continue
        # (an off-grid smallest value: the median's offset)
        shares[step] = max(np.count_nonzero(_on_grid(v, offset, step)) for offset in (float(v[0]), float(v[len(v) // 2]))) / len(v)
    if not shares or max(shares.values()) < GRID_MIN_SHARE:
        return 0.0
    # the coarsest step that holds (nearly) as many values as the finest: a multiple of the true step
    # holds only its share by parity (sparse integers whose least gap is 2: half of them; a review)
    top = max(shares.values())
    return max(s for s, share in shares.items() if share >= GRID_SHARE_KEEP * top)


def image_grid_step(keypoints: np.ndarray) -> float:
    """The grid of one image's keypoints ``(m, 2)`` (pixels; NaN rows ignored): the finer of its two axes'
    (:func:`axis_step`), or 0 where either has none. Where the keypoints are lifted to bearings before
    the estimate (a COLMAP database, a camera model), a pair's step is the finer of its two images'
    where both have one (:func:`pair_grid_step`), passed as ``coordinate_step_px``."""
    kp = np.asarray(keypoints, dtype=float).reshape(-1, 2)
    sx = axis_step(kp[:, 0])
    return min(sx, axis_step(kp[:, 1])) if sx > 0.0 else 0.0


def pair_grid_step(step1: float, step2: float) -> float:
    """A pair's rounding grid from its two images' (:func:`image_grid_step`): the finer, 0 unless both."""
    return min(step1, step2) if step1 > 0.0 and step2 > 0.0 else 0.0


def grid_step(x1: object, x2: object) -> float:
    """The rounding grid of pixel matches ``x1, x2 (n, 2)`` (already validated; NaN rows ignored): the
    finest of the four axes' grids (:func:`axis_step`: whole pixels, or e.g. ``1 / scale`` pixels
    offset by ``0.5 / scale - 0.5`` for keypoints detected on an image resized by ``scale``), where all
    four have one, or :data:`TIE_STEP_PX` if larger where at least :data:`TIE_MIN_SHARE` of the matches
    keep a coordinate exactly (rounded on grids that differ, such as ORB's pyramid levels, whose common
    grid is finer than any level's); else 0."""
    a = np.concatenate([opencv_points(np.asarray(x1, dtype=float)), opencv_points(np.asarray(x2, dtype=float))], axis=1)
    if a.ndim != 2 or a.shape[1] != 4 or len(a) == 0:
        return 0.0
    # exactly one coordinate kept: a match that did not move at all (a static overlay, a failed track left
    # at its start) is no evidence of rounding (a review)
    ties = (a[:, 0] == a[:, 2]) != (a[:, 1] == a[:, 3])
    tie_step = TIE_STEP_PX if np.count_nonzero(ties) >= TIE_MIN_SHARE * len(a) else 0.0
    steps = []
    for j in range(4):  # (sub-pixel input: the first axis decides, ~20 us at n = 1000)
        steps.append(axis_step(a[:, j]))
        if steps[-1] == 0.0:
            return tie_step
    return max(min(steps), tie_step)


def rounding_sigma_px(step: float) -> float:
    """The standard deviation of the rounding error of a coordinate on a grid of ``step`` pixels
    (uniform on ``[-step / 2, step / 2]``): the least noise scale of one view's coordinates, which is
    also the least scale of the Sampson error (the matches' errors in both views projected on the
    normal of the epipolar manifold)."""
    return float(step) / math.sqrt(12.0)


def check_coordinate_step(step: object) -> float | None:
    """``coordinate_step_px``: None (detect it from pixel input) or a finite number >= 0 (0: no floor)."""
    if step is None:
        return None
    if isinstance(step, (bool, np.bool_)) or not isinstance(step, (int, float, np.integer, np.floating)) or not (math.isfinite(float(step)) and float(step) >= 0.0):
        raise InputError(f"coordinate_step_px must be None (detected from pixels) or a finite number >= 0, got {step!r}")
    return float(step)
