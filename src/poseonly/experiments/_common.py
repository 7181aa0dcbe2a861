"""Shared helpers of the experiments: progress bars, atomic table/JSON/figure writers."""

from __future__ import annotations

import functools
import json
import os
import platform
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import Any

import numpy as np

from .._fileutil import atomic_savefig, atomic_write_text

__all__ = ["atomic_write_text", "savefig", "write_json", "write_outputs", "finish_run"]


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


def figure_writer(draw: Callable[[Any, Any], Any]) -> Callable[[Any, Path], None]:
    """The figure function that :func:`finish_run` / :func:`write_outputs` call, from ``draw(plt, res)``
    that makes the figure and returns it: pyplot on the Agg backend (no figure without matplotlib),
    the figure saved atomically (:func:`savefig`) and closed."""

    @functools.wraps(draw)
    def write(res: Any, path: Path) -> None:
        plt = pyplot()
        if plt is None:  # pragma: no cover - matplotlib is an optional dependency
            return
        fig = draw(plt, res)
        savefig(fig, path)
        plt.close(fig)

    return write


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
    """``git describe --always --dirty`` of the source tree (``None`` outside a git checkout)."""
    import subprocess

    try:
        r = subprocess.run(["git", "describe", "--always", "--dirty"], cwd=Path(__file__).parent, capture_output=True, text=True, timeout=10)
    except (OSError, subprocess.SubprocessError):
        return None
    return (r.stdout.strip() or None) if r.returncode == 0 else None


def stamp(res: dict, t0: float) -> dict:
    """Record the wall time since ``t0`` (``time.perf_counter``), the machine and the code version."""
    import time

    res["wall_s"] = time.perf_counter() - t0
    res["machine"] = machine()
    res["code_version"] = code_version()
    return res


def finish_run(out: str | Path, name: str, header: str, res: dict, table: str, figure=None) -> None:
    """Write a stamped experiment (:func:`stamp`): ``header`` + ``table`` + a machine/code line."""
    md = header + "\n\n" + table + f"\nMachine: {res['machine']}; code `{res['code_version']}`.\n"
    write_outputs(out, name, md, res, figure)


# the command line of the running ``poseonly experiment`` (set by the CLI): recorded in every report
COMMAND: list[str] = []


def write_outputs(out: str | Path, name: str, md: str, res: Any, figure=None) -> None:
    """Write ``<name>.md``, ``<name>.json`` and (with ``figure(res, path)``) ``<name>.png``
    atomically into ``out`` and print the table; the command line that ran (:data:`COMMAND`, when the
    CLI set it) goes into both reports."""
    if COMMAND:
        cmd = COMMAND[-1]
        if isinstance(res, dict):
            res = {**res, "command": res.get("command", cmd)}
        if cmd not in md:
            md = md.rstrip("\n") + f"\n\nCommand: `{cmd}`\n"
    out = Path(out)
    atomic_write_text(out / f"{name}.md", md)
    write_json(out / f"{name}.json", res)
    if figure is not None:
        figure(res, out / f"{name}.png")
    print(md)
