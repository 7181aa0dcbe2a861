"""The embedded demo pair: two views of Strecha's fountain-P11 with ground-truth pose.

Two 960x640 JPEGs (views 0004 and 0005, downscaled 5/16 from 3072x2048) ship inside the package
with ``demo_pair.json`` (scaled intrinsics, ground truth in the poseonly convention
``X2 = R X1 + t``, provenance). They were produced by ``benchmarks/make_demo_data.py``.

Data: C. Strecha et al., "On Benchmarking Camera Calibration and Multi-View Stereo for High
Resolution Imagery", CVPR 2008, as redistributed by openMVG/SfM_quality_evaluation; see the
``provenance`` field of :attr:`DemoPair.meta`.
"""

from __future__ import annotations

import atexit
import json
from contextlib import ExitStack
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from .geometry import InputError, check_intrinsics, project_to_so3

__all__ = ["DemoPair", "load_demo_pair"]

_stack = ExitStack()
atexit.register(_stack.close)


@dataclass(frozen=True)
class DemoPair:
    """Paths of the two demo images, their intrinsics and the ground-truth pose (``X2 = R X1 + t``)."""

    image1: Path
    image2: Path
    K1: np.ndarray
    K2: np.ndarray
    R_gt: np.ndarray
    t_gt: np.ndarray
    image_size: tuple[int, int]
    meta: dict[str, Any] = field(default_factory=dict, repr=False)


def _resource_path(name: str) -> Path:
    """A real filesystem path for a file of ``poseonly/data`` (extracted if installed zipped)."""
    res = resources.files("poseonly").joinpath("data", name)
    if isinstance(res, Path):
        if not res.is_file():
            raise InputError(f"embedded demo file missing from the installation: {res}")
        return res
    return _stack.enter_context(resources.as_file(res))  # pragma: no cover - zipped installs


def load_demo_pair() -> DemoPair:
    """Load the embedded fountain-P11 demo pair (no external data needed)."""
    meta = json.loads(_resource_path("demo_pair.json").read_text(encoding="utf-8"))
    img1, img2 = (_resource_path(n) for n in meta["images"])
    t = np.asarray(meta["t"], dtype=float)
    w, h = meta["image_size"][0]
    return DemoPair(
        image1=img1,
        image2=img2,
        K1=check_intrinsics(meta["K1"], "K1"),
        K2=check_intrinsics(meta["K2"], "K2"),
        R_gt=project_to_so3(np.asarray(meta["R"], dtype=float)),
        t_gt=t / np.linalg.norm(t),
        image_size=(int(w), int(h)),
        meta=meta,
    )
