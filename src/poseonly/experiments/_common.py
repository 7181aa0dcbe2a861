"""Shared helpers of the experiments: progress bars, atomic table/JSON/figure writers.

The generic helpers live in the public :mod:`poseonly.experiments.report` (the benchmarks use them
too) and are re-exported here."""

from __future__ import annotations

import functools
from collections.abc import Callable
from pathlib import Path
from typing import Any

from .._fileutil import atomic_write_text
from .report import (
    code_version,
    fmt,
    machine,
    markdown_table,
    progress,
    pyplot,
    savefig,
    single_thread,
    strict_json,
    write_json,
)

__all__ = [
    "atomic_write_text",
    "code_version",
    "figure_writer",
    "finish_run",
    "fmt",
    "machine",
    "markdown_table",
    "progress",
    "pyplot",
    "savefig",
    "single_thread",
    "stamp",
    "strict_json",
    "write_json",
    "write_outputs",
]


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


# the command line of the running ``poseonly experiment`` (set by the CLI through
# :func:`poseonly.experiments.set_command_line`): recorded in every report
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
