"""The global pipeline's option values and their checks, importable without scipy (the command
line builds its parsers from them before any work; :mod:`poseonly.sfm.pipeline` and the stages
check the same values)."""

from __future__ import annotations

import numbers

import numpy as np

from ..geometry import InputError

__all__ = ["LIGT_NORMALIZATIONS", "LIGT_REWEIGHT", "ROTATION_WEIGHTS", "checked_sigma_deg"]

# rotation averaging's edge weights (GlobalOptions.rotation_weights), the default first
ROTATION_WEIGHTS = ("inliers", "information")
# LiGT's scale normalisation (poseonly.sfm.ligt_global.ligt_positions), the default first
LIGT_NORMALIZATIONS = ("noise", "unit")
# LiGT's reweighting rounds in the pipeline (GlobalOptions.ligt_reweight; 0 is the paper's / openMVG's
# LiGT): one round divides every row triple by theta^2 ||X - c_i|| of the first solution, so it weighs
# the observations' angular errors instead of their algebraic ones, which grow with the track's parallax
# and distance. Decided on real images (docs/SFM.md, "LiGT reweighted by default"): the three Strecha
# scenes' centres 3.32 / 5.44 / 3.70 -> 3.28 / 4.80 / 3.47 mm, entry-P10 and fountain-P11 as one
# model 11.2 / 43.1 -> 9.4 / 5.4 mm; synthetic rings from the true rotations at 1000-2000 views: 3 of 4
# better (0.072-0.107 -> 0.048-0.060 % of the extent), one alike (0.014 -> 0.017 %); from averaged
# rotations mixed (there the rotations' error sets the centres'); LiGT 1.7-1.9x the time
LIGT_REWEIGHT = 1


# the Geman-McClure scale a caller may set (degrees): below, its square underflows the IRLS weights'
# arithmetic to nothing; above 180 deg no rotation error is down-weighted any more (the upper bound
# only keeps the weights' arithmetic finite)
SIGMA_RANGE_DEG = (1e-6, 1e6)


def checked_sigma_deg(value: object, name: str = "sigma_deg") -> float | None:
    """A Geman-McClure scale option: None (from the data) or a finite real number > 0 (degrees; not a
    bool); anything else is an :class:`InputError` naming ``name``."""
    if value is None:
        return None
    bad = InputError(f"{name} must be a number of degrees in [{SIGMA_RANGE_DEG[0]:g}, {SIGMA_RANGE_DEG[1]:g}], got {value!r} (the default, None, takes the scale from the data)")
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Real):
        raise bad
    try:
        v = float(value)
    except (OverflowError, ValueError):
        raise bad from None
    if not (np.isfinite(v) and SIGMA_RANGE_DEG[0] <= v <= SIGMA_RANGE_DEG[1]):
        raise bad
    return v
