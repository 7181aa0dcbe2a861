"""argparse types shared by the command lines (:mod:`poseonly.cli`, :mod:`poseonly.sfm.cli`): a bad
value is an argument error before any work starts."""

from __future__ import annotations

import argparse
from collections.abc import Callable

from .geometry import InputError
from .options import SEED_LIMIT
from .sfm.choices import checked_sigma_deg

__all__ = ["jobs_int", "non_negative_float", "non_negative_int", "positive_degrees", "positive_float", "positive_int", "seed_int"]


def _int_in(text: str, ok: Callable[[int], bool], what: str) -> int:
    """``text`` as an integer for which ``ok`` holds; otherwise an argument error saying ``what``."""
    try:
        v = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected {what}, got {text!r}") from None
    if not ok(v):
        raise argparse.ArgumentTypeError(f"must be {what}, got {v}")
    return v


def positive_int(text: str) -> int:
    """An integer >= 1."""
    return _int_in(text, lambda v: v >= 1, "an integer >= 1")


def points_int(minimum: int, why: str) -> Callable[[str], int]:
    """An argparse type: a point count >= ``minimum`` (``why``: the solver that needs them), so that an
    experiment refuses a count its solvers cannot use before it writes anything (a researcher's trial:
    ``table2 --n 5`` printed a LiRP row)."""

    def parse(text: str) -> int:
        return _int_in(text, lambda v: v >= minimum, f"an integer >= {minimum} ({why})")

    parse.__name__ = f"points_int_{minimum}"
    return parse


def non_negative_int(text: str) -> int:
    """An integer >= 0 (seeds, counts where 0 means "all")."""
    return _int_in(text, lambda v: v >= 0, "an integer >= 0")


def seed_int(text: str) -> int:
    """A seed: an integer in ``[0, 2**64)`` (the core's seeds are 64-bit; the Python API's range)."""
    return _int_in(text, lambda v: 0 <= v < SEED_LIMIT, "an integer in [0, 2**64)")


def jobs_int(text: str) -> int:
    """A worker count: an integer >= 1, or -1 for one per core."""
    return _int_in(text, lambda v: v >= 1 or v == -1, "an integer >= 1 or -1 (one per core)")


def positive_float(text: str) -> float:
    """A finite number > 0 (thresholds in pixels)."""
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number > 0, got {text!r}") from None
    if not (v > 0 and v != float("inf")):
        raise argparse.ArgumentTypeError(f"must be a finite number > 0, got {text}")
    return v


def non_negative_float(text: str) -> float:
    """A finite number >= 0 (noise levels)."""
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a finite number >= 0, got {text!r}") from None
    if not (v >= 0 and v != float("inf")):
        raise argparse.ArgumentTypeError(f"must be a finite number >= 0, got {text}")
    return v


def positive_degrees(text: str) -> float:
    """A Geman-McClure scale in degrees within :data:`poseonly.sfm.choices.SIGMA_RANGE_DEG` (``--rotation-sigma``
    of ``poseonly sfm`` and ``poseonly experiment global``; checked before any image is read)."""
    try:
        v = checked_sigma_deg(float(text), "--rotation-sigma")
    except (ValueError, InputError) as e:
        raise argparse.ArgumentTypeError(str(e)) from None
    assert v is not None
    return v
