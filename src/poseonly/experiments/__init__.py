"""Paper experiments, one module each, run by ``poseonly experiment <name>``.

Every module exposes ``add_arguments(parser)`` and ``run(args) -> int``; common arguments
(``--trials``, ``--quick``, ``--out``, ``--seed``) are added by the CLI. The registry below maps
names to modules, imported lazily so optional dependencies stay optional.
"""

from __future__ import annotations

import importlib
import importlib.util
from types import ModuleType

EXPERIMENTS: dict[str, str] = {
    "table2": "poseonly.experiments.table2",
    "noise": "poseonly.experiments.noise",
    "residuals": "poseonly.experiments.residuals",
    "gnc-ransac": "poseonly.experiments.gnc_ransac",
    "chirality": "poseonly.experiments.chirality",
    "strecha": "poseonly.experiments.strecha",
}


def load(name: str) -> ModuleType:
    if name not in EXPERIMENTS:
        raise ValueError(f"unknown experiment {name!r}; choose one of {sorted(EXPERIMENTS)}")
    return importlib.import_module(EXPERIMENTS[name])


def set_command_line(cmd: str) -> None:
    """Record ``cmd`` (one shell command line, e.g. ``"poseonly experiment noise --quick"``) as the
    command of the running experiment: every report written until :func:`clear_command_line` states it."""
    from . import _common

    _common.COMMAND[:] = [cmd]


def clear_command_line() -> None:
    """Forget the command line recorded by :func:`set_command_line`."""
    from . import _common

    _common.COMMAND.clear()


def available() -> list[str]:
    out = []
    for k, mod in EXPERIMENTS.items():
        if importlib.util.find_spec(mod) is not None:
            out.append(k)
    return out
