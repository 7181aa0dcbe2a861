"""Value equality of the result dataclasses, which hold numpy arrays.

A dataclass's generated ``__eq__`` compares its fields as a tuple, and numpy arrays answer ``==``
elementwise, so two results with arrays raised "The truth value of an array ... is ambiguous" unless
they were the same object. :class:`ValueEquality` compares field by field instead: arrays by shape
and values (as numpy compares them: ``[True, False]`` equals ``[1, 0]``; NaN equal to NaN in float
arrays, as a repeated run's result is equal to itself), dicts, lists and tuples recursively, floats with
NaN equal to NaN.
"""

from __future__ import annotations

import math
from dataclasses import fields
from typing import Any

import numpy as np

__all__ = ["ValueEquality", "values_equal"]


def values_equal(a: Any, b: Any) -> bool:
    """``a`` and ``b`` equal as values: arrays (shape and values; NaN equals NaN), mappings, sequences
    (recursively), floats (NaN equals NaN), anything else by ``==``."""
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        if not (isinstance(a, np.ndarray) and isinstance(b, np.ndarray)) or a.shape != b.shape:
            return False
        nan_ok = a.dtype.kind in "fc" and b.dtype.kind in "fc"
        return bool(np.array_equal(a, b, equal_nan=nan_ok))
    if isinstance(a, dict) and isinstance(b, dict):
        return a.keys() == b.keys() and all(values_equal(a[k], b[k]) for k in a)
    if isinstance(a, (list, tuple)) and isinstance(b, (list, tuple)):
        return type(a) is type(b) and len(a) == len(b) and all(values_equal(x, y) for x, y in zip(a, b))
    if isinstance(a, float) and isinstance(b, float) and math.isnan(a) and math.isnan(b):
        return True
    try:
        return bool(a == b)
    except (TypeError, ValueError):
        return False


class ValueEquality:
    """Mixin for dataclasses (declared with ``eq=False``): ``==`` compares every field declared with
    ``compare=True`` (the default; a run's duration is declared ``compare=False``) with
    :func:`values_equal`; instances are unhashable (mutable values)."""

    def __eq__(self, other: object) -> bool:
        if other.__class__ is not self.__class__:
            return NotImplemented
        return all(values_equal(getattr(self, f.name), getattr(other, f.name)) for f in fields(self) if f.compare)  # type: ignore[arg-type]

    __hash__ = None  # type: ignore[assignment]
