"""argparse types shared by the command lines (:mod:`poseonly.cli`, :mod:`poseonly.sfm.cli`): a bad
value is an argument error before any work starts."""

from __future__ import annotations

import argparse

__all__ = ["jobs_int", "non_negative_int", "positive_int", "positive_float"]


def positive_int(text: str) -> int:
    """An integer >= 1."""
    try:
        v = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a positive integer, got {text!r}") from None
    if v < 1:
        raise argparse.ArgumentTypeError(f"must be >= 1, got {v}")
    return v


def non_negative_int(text: str) -> int:
    """An integer >= 0 (seeds, counts where 0 means "all")."""
    try:
        v = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected an integer >= 0, got {text!r}") from None
    if v < 0:
        raise argparse.ArgumentTypeError(f"must be >= 0, got {v}")
    return v


def jobs_int(text: str) -> int:
    """A worker count: an integer >= 1, or -1 for one per core."""
    try:
        v = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected an integer >= 1 or -1 (one per core), got {text!r}") from None
    if v < 1 and v != -1:
        raise argparse.ArgumentTypeError(f"must be >= 1 or -1 (one per core), got {v}")
    return v


def positive_float(text: str) -> float:
    """A finite number > 0 (thresholds in pixels)."""
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number > 0, got {text!r}") from None
    if not (v > 0 and v != float("inf")):
        raise argparse.ArgumentTypeError(f"must be a finite number > 0, got {text}")
    return v
