"""Calibration files of the command lines: a 3x3 ``K`` as text (``--K K.txt``)."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np

from ..geometry import InputError, check_intrinsics

__all__ = ["read_K"]


def read_K(path: str | Path, name: str = "--K") -> np.ndarray:
    """The checked 3x3 calibration matrix in the text file ``path`` (whitespace-separated rows, as
    ``numpy.loadtxt`` reads them); :class:`InputError` naming the file and ``name`` otherwise (missing,
    unreadable, empty, not 3x3, a last row other than ``0 0 1``, not a calibration matrix:
    :func:`poseonly.geometry.check_intrinsics`)."""
    p = Path(path)
    if p.is_dir():
        raise InputError(f"{name}: {path} is a folder; give the calibration's text file")
    if not p.is_file():
        raise InputError(f"{name}: calibration file not found: {path}")
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)  # numpy's "input contained no data": reported below
            K = np.loadtxt(p, dtype=float, ndmin=2)
    except (ValueError, UnicodeDecodeError) as exc:
        raise InputError(f"{name}: could not read a 3x3 matrix from {path}: {exc}") from None
    if K.shape != (3, 3):
        raise InputError(f"{name}: {path} must contain a 3x3 matrix, found {'no numbers' if K.size == 0 else f'shape {K.shape}'}")
    if K[2, 2] != 1.0 and np.all(np.isfinite(K)):
        # the library divides a scaled K by K[2, 2], but in a file (COLMAP's, OpenCV's, a dataset's) a last
        # row other than 0 0 1 is a typo: an SfM user's trial wrote "0 0 2" and got every focal halved
        raise InputError(f"{name}: {path}: the last row must be 0 0 1, got {' '.join(f'{v:g}' for v in K[2])}")
    return check_intrinsics(K, f"{name} ({path})")
