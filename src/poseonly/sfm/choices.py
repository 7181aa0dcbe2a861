"""The global pipeline's option values and their checks, importable without scipy (the command
line builds its parsers from them before any work; :mod:`poseonly.sfm.pipeline` and the stages
check the same values)."""

from __future__ import annotations

import numbers

import numpy as np

from ..geometry import InputError

__all__ = ["LIGT_NORMALIZATIONS", "ROTATION_WEIGHTS", "checked_sigma_deg"]

# rotation averaging's edge weights (GlobalOptions.rotation_weights), the default first
ROTATION_WEIGHTS = ("inliers", "information")
# LiGT's scale normalisation (poseonly.sfm.ligt_global.ligt_positions), the default first
LIGT_NORMALIZATIONS = ("noise", "unit")


def checked_sigma_deg(value: object, name: str = "sigma_deg") -> float | None:
    """A Geman-McClure scale option: None (from the data) or a finite real number > 0 (degrees; not a
    bool); anything else is an :class:`InputError` naming ``name``."""
    if value is None:
        return None
    bad = InputError(f"{name} must be a finite number of degrees > 0, got {value!r} (the default, None, takes the scale from the data)")
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Real):
        raise bad
    try:
        v = float(value)
    except (OverflowError, ValueError):
        raise bad from None
    if not (np.isfinite(v) and v > 0):
        raise bad
    return v
