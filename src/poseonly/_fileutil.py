"""Atomic writers: a file is either absent, its old version or its complete new version.

Every writer writes to a temp file in the target's directory (``.NAME.PID.RANDOM.poseonly-tmp``),
flushes and fsyncs it, gives it the mode a plain ``open`` would have created and renames it onto the
target (``os.replace``, atomic on POSIX). A process killed mid-write leaves its temp file behind; the
next write to the same target removes temp files of processes that no longer run (and legacy
``.NAME.*.tmp`` files older than an hour), so killed runs do not accumulate hidden files.
"""

from __future__ import annotations

import contextlib
import os
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path
from typing import IO, Any

__all__ = [
    "TMP_SUFFIX",
    "atomic_open",
    "atomic_savefig",
    "atomic_savez",
    "atomic_write_bytes",
    "atomic_write_text",
    "clean_stale_temps",
    "new_results_dir",
    "publish",
]

TMP_SUFFIX = ".poseonly-tmp"
# temp files of the older writers (no pid in the name) are removed once they are this old (seconds)
LEGACY_TMP_AGE_S = 3600.0


def publish(tmp: str | os.PathLike, path: str | os.PathLike) -> None:
    """Give ``tmp`` (made by ``tempfile.mkstemp``, mode 0600) the mode a plain ``open`` would have
    created (``0666`` minus the umask), then move it onto ``path`` atomically."""
    mask = os.umask(0)
    os.umask(mask)
    os.chmod(tmp, 0o666 & ~mask)
    os.replace(tmp, path)


def _pid_alive(pid: int) -> bool:
    if pid == os.getpid():
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # exists, owned by someone else
        return True
    return True


def clean_stale_temps(path: str | os.PathLike) -> int:
    """Remove temp files of ``path`` left by killed writers; returns how many were removed."""
    path = Path(path)
    if not path.parent.is_dir():
        return 0
    removed = 0
    prefix = f".{path.name}."
    now = time.time()
    for f in path.parent.iterdir():
        name = f.name
        if not name.startswith(prefix):
            continue
        rest = name[len(prefix) :]
        stale = False
        if name.endswith(TMP_SUFFIX):
            pid = rest.split(".", 1)[0]
            stale = pid.isdigit() and not _pid_alive(int(pid))
        elif name.endswith(".tmp"):  # legacy temp names (no pid): only old ones
            with contextlib.suppress(OSError):
                stale = now - f.stat().st_mtime > LEGACY_TMP_AGE_S
        if stale:
            with contextlib.suppress(OSError):
                f.unlink()
                removed += 1
    return removed


@contextlib.contextmanager
def atomic_open(path: str | os.PathLike, mode: str = "w", **kw: Any) -> Iterator[IO[Any]]:
    """``with atomic_open(path, "w" | "wb") as fh: ...`` writes ``path`` atomically (see the module
    docstring); on any exception the temp file is removed and ``path`` is untouched."""
    if mode not in ("w", "wb"):
        raise ValueError(f"atomic_open supports modes 'w' and 'wb', got {mode!r}")
    path = Path(path)
    if path.is_dir():
        raise IsADirectoryError(f"{path} is a directory")
    path.parent.mkdir(parents=True, exist_ok=True)
    clean_stale_temps(path)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.{os.getpid()}.", suffix=TMP_SUFFIX)
    try:
        if mode == "w":
            kw.setdefault("encoding", "utf-8")
        with os.fdopen(fd, mode, **kw) as fh:
            yield fh
            fh.flush()
            os.fsync(fh.fileno())
        publish(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise


def atomic_write_text(path: str | os.PathLike, text: str) -> Path:
    """Write ``text`` (UTF-8) to ``path`` atomically."""
    with atomic_open(path, "w") as fh:
        fh.write(text)
    return Path(path)


def atomic_write_bytes(path: str | os.PathLike, data: bytes) -> Path:
    """Write ``data`` to ``path`` atomically."""
    with atomic_open(path, "wb") as fh:
        fh.write(data)
    return Path(path)


def atomic_savefig(fig: Any, path: str | os.PathLike, **kw: Any) -> Path:
    """``fig.savefig`` onto ``path`` atomically; the format comes from the suffix and must be one
    matplotlib writes (else :class:`ValueError` before anything is written)."""
    path = Path(path)
    fmt = path.suffix.lower().lstrip(".")
    supported = fig.canvas.get_supported_filetypes()
    if fmt not in supported:
        raise ValueError(f"cannot write a figure as {path.name!r}: the suffix must be one of {sorted('.' + k for k in supported)}")
    with atomic_open(path, "wb") as fh:
        fig.savefig(fh, format=fmt, **kw)
    return path


def new_results_dir(name: str, base: str | os.PathLike | None = None) -> Path:
    """A new, empty folder ``poseonly-NAME-YYYYmmdd-HHMMSS[-k]`` under ``base`` (default: the working
    directory): where experiments and benchmarks write when no ``--out`` is given, so that a run never
    overwrites earlier results (a clone's committed docs/results included)."""
    root = Path.cwd() if base is None else Path(base)
    stem = f"poseonly-{name}-{time.strftime('%Y%m%d-%H%M%S')}"
    for k in range(1000):
        p = root / (stem if k == 0 else f"{stem}-{k}")
        try:
            p.mkdir(parents=True)
            return p
        except FileExistsError:
            continue
    raise FileExistsError(f"could not create a new results folder {stem}-* under {root}")


def atomic_savez(path: str | os.PathLike, **arrays: Any) -> None:
    """``np.savez`` through :func:`atomic_open` (atomic; the temp files of killed writers are removed
    on the next write of the same target)."""
    import numpy as np

    with atomic_open(path, "wb") as fh:
        np.savez(fh, **arrays)
