"""Generic report helpers shared by the experiments and the benchmarks (``poseonly bench``):
progress bars, strict JSON, markdown tables, figures, and the machine / code-version stamp."""

from __future__ import annotations

import json
import os
import platform
from collections.abc import Iterable
from pathlib import Path
from typing import Any

import numpy as np

from .._fileutil import atomic_savefig, atomic_write_text

__all__ = [
    "code_version",
    "fmt",
    "machine",
    "markdown_table",
    "progress",
    "provenance",
    "pyplot",
    "savefig",
    "single_thread",
    "strict_json",
    "write_json",
]


def progress(it: Iterable, total: int | None = None, desc: str = "", disable: bool | None = None):
    """tqdm progress bar when available (disabled when not a terminal unless forced)."""
    try:
        from tqdm import tqdm
    except ImportError:  # pragma: no cover
        return it
    return tqdm(it, total=total, desc=desc, disable=disable, leave=False, dynamic_ncols=True)


def _jsonable(o: Any):
    if isinstance(o, np.ndarray):
        return o.tolist()
    if isinstance(o, (np.floating, np.integer)):
        return o.item()
    if isinstance(o, np.bool_):
        return bool(o)
    raise TypeError(type(o))


def strict_json(o: Any) -> Any:
    """``o`` with every NaN / inf float (in nested dicts, lists and tuples) replaced by ``None``, so
    that the JSON written is strict (readable by any JSON parser, not only Python's)."""
    if isinstance(o, dict):
        return {k: strict_json(v) for k, v in o.items()}
    if isinstance(o, (list, tuple)):
        return [strict_json(v) for v in o]
    if isinstance(o, (float, np.floating)):
        return float(o) if np.isfinite(o) else None
    return o


def write_json(path: str | Path, data: Any) -> Path:
    """``data`` as strict JSON (NaN / inf as ``null``: :func:`strict_json`, after numpy values are
    converted), written atomically."""
    return atomic_write_text(path, json.dumps(strict_json(json.loads(json.dumps(data, default=_jsonable))), indent=2, allow_nan=False))


def fmt(x: float | np.floating[Any] | None) -> str:
    if x is None or (isinstance(x, float) and np.isnan(x)):
        return "-"
    if x == 0:
        return "0"
    ax = abs(float(x))
    if ax >= 1000 or ax < 1e-3:
        return f"{x:.2e}"
    return f"{x:.4g}"


def markdown_table(header: list[str], rows: list[list[Any]]) -> str:
    lines = ["| " + " | ".join(header) + " |", "|" + "|".join("---" for _ in header) + "|"]
    for r in rows:
        lines.append("| " + " | ".join(fmt(c) if isinstance(c, (float, np.floating)) else str(c) for c in r) + " |")
    return "\n".join(lines) + "\n"


def savefig(fig, path: str | Path) -> Path:
    """Write a figure atomically (format from the suffix; see :func:`poseonly._fileutil.atomic_savefig`)."""
    return atomic_savefig(fig, path, dpi=110, bbox_inches="tight")


def machine() -> str:
    import scipy

    return f"{platform.machine()}, {os.cpu_count()} cores, Python {platform.python_version()}, numpy {np.__version__}, scipy {scipy.__version__}"


def single_thread() -> None:
    """Pin BLAS and OpenCV to one thread (for timings)."""
    try:
        from threadpoolctl import threadpool_limits

        threadpool_limits(1)
    except ImportError:
        for v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
            os.environ.setdefault(v, "1")
    try:
        import cv2

        cv2.setNumThreads(1)
    except ImportError:
        pass


def pyplot():
    """``matplotlib.pyplot`` on the Agg backend, or ``None`` when matplotlib is not installed."""
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:  # pragma: no cover
        return None
    return plt


def code_version() -> str | None:
    """``git describe --always --dirty`` of poseonly's source tree: ``None`` unless the package runs from
    the ``src/poseonly`` of a git checkout (an installed package inside a user's own repository reported
    the user's commit: a packaging trial)."""
    import subprocess

    pkg = Path(__file__).resolve().parents[1]
    try:
        top = subprocess.run(["git", "rev-parse", "--show-toplevel"], cwd=pkg, capture_output=True, text=True, timeout=10)
        if top.returncode != 0 or (Path(top.stdout.strip()) / "src" / "poseonly").resolve() != pkg:
            return None
        r = subprocess.run(["git", "describe", "--always", "--dirty"], cwd=pkg, capture_output=True, text=True, timeout=10)
    except (OSError, subprocess.SubprocessError):
        return None
    return (r.stdout.strip() or None) if r.returncode == 0 else None


def provenance() -> str:
    """One comment line naming what printed the figures below it: the command (``sys.argv``), poseonly's
    version and code (:func:`code_version`, ``None`` outside a checkout), the UTC time and the machine.
    Every script under benchmarks/ prints it first (a docs audit found figures no output tied to a
    commit)."""
    import shlex
    import sys
    import time

    from .. import __version__

    cmd = " ".join(shlex.quote(a) for a in ["python", *sys.argv])
    when = time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime())
    return f"# {cmd}\n# poseonly {__version__}, code {code_version()}, {when}, {machine()}"
