"""Atomic writers: a file is either absent, its old version or its complete new version.

Every writer writes to a temp file in the target's directory (``.NAME.HOST-PID.RANDOM.poseonly-tmp``),
flushes and fsyncs it, gives it the mode a plain ``open`` would have created and renames it onto the
target (``os.replace``, atomic on POSIX). A process killed mid-write leaves its temp file behind; a
process's first write into a directory removes the temp files there of this host's processes that no
longer run (a folder shared with other hosts keeps theirs: their PIDs mean nothing here), so killed
runs do not accumulate hidden files (and earlier writers' ``.NAME.RANDOM.tmp`` files older than an
hour next to their target).
The sweep lists the directory once per process, not once per write: a cache of 100000 entries costs
one listing, where a listing per write made filling it quadratic in its size.
"""

from __future__ import annotations

import contextlib
import os
import tempfile
import threading
import time
import warnings
import zipfile
import zlib
from collections.abc import Iterator
from pathlib import Path
from typing import IO, Any

__all__ = [
    "CACHE_READ_ERRORS",
    "TMP_SUFFIX",
    "atomic_open",
    "atomic_savefig",
    "atomic_savez",
    "atomic_write_bytes",
    "atomic_write_text",
    "cache_savez",
    "clean_stale_temps",
    "staging_dir",
    "sweep_stale_temps",
    "new_results_dir",
    "remove_empty_results_dirs",
    "publish",
]

TMP_SUFFIX = ".poseonly-tmp"
# the files SQLite keeps beside a database: a temporary database's are temporary too
SQLITE_JOURNALS = ("-wal", "-shm", "-journal")
# what reading a missing, truncated, garbage or inconsistent ``.npz`` cache entry raises (``np.load``
# with ``allow_pickle=False``, a missing key, a field of the wrong type; zipfile on a corrupt header byte:
# NotImplementedError for an unknown version or compression, RuntimeError for the "encrypted" flag, a
# review's fuzzing: 55 of ~7000 single-byte corruptions; zlib.error for corrupt deflate data): such an
# entry is recomputed
CACHE_READ_ERRORS: tuple[type[Exception], ...] = (OSError, ValueError, KeyError, TypeError, EOFError, zipfile.BadZipFile, NotImplementedError, RuntimeError, zlib.error)
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


def _host_tag() -> str:
    """This machine's name as it goes into temp names (letters, digits and ``-`` only, at most 32)."""
    import socket

    return "".join(c if c.isalnum() else "-" for c in socket.gethostname())[:32] or "host"


HOST = _host_tag()


def _stale(f: Path, now: float) -> bool:
    """``f`` is a temp file of a writer that no longer runs: ``.NAME.HOST-PID.RANDOM.poseonly-tmp`` of
    this host and a dead PID (a writer on another host sharing the folder is never judged by this
    host's PIDs), ``.NAME.PID.RANDOM.poseonly-tmp`` (earlier versions) of a dead PID, or an earlier
    writer's ``.NAME.RANDOM.tmp`` older than :data:`LEGACY_TMP_AGE_S` whose target ``NAME`` exists
    (other programs' hidden ``.tmp`` files are left alone)."""
    name = f.name
    if not name.startswith("."):
        return False
    for journal in SQLITE_JOURNALS:  # an SQLite copy's journal beside it (io.colmap_db.reading_snapshot)
        if name.endswith(TMP_SUFFIX + journal):
            name = name[: -len(journal)]
    if name.endswith(TMP_SUFFIX):
        parts = name.rsplit(".", 3)  # [".NAME", HOST-PID, RANDOM, "poseonly-tmp"] (mkstemp's RANDOM has no dot)
        if len(parts) != 4:
            return False
        host, _, pid = parts[1].rpartition("-")
        if host and host != HOST:
            return False
        return pid.isdigit() and not _pid_alive(int(pid))
    if name.endswith(".tmp"):  # an earlier writer's .TARGET.RANDOM.tmp, next to its (existing) target
        inner = name[1:-4]
        target = inner.rpartition(".")[0]
        try:
            return bool(target) and f.with_name(target).is_file() and now - f.stat().st_mtime > LEGACY_TMP_AGE_S
        except OSError:
            return False
    return False


def clean_stale_temps(path: str | os.PathLike) -> int:
    """Remove the temp files of ``path`` left by killed writers; returns how many were removed."""
    path = Path(path)
    if not path.parent.is_dir():
        return 0
    prefix = f".{path.name}."
    now = time.time()
    removed = 0
    for f in path.parent.iterdir():
        if f.name.startswith(prefix) and _stale(f, now):
            with contextlib.suppress(OSError):
                f.unlink()
                removed += 1
    return removed


def sweep_stale_temps(directory: str | os.PathLike) -> int:
    """Remove the temp files of this host's killed writers anywhere in ``directory`` (not recursive;
    other programs' hidden files are left alone, :func:`_stale`); returns how many were removed."""
    d = Path(directory)
    if not d.is_dir():
        return 0
    now = time.time()
    removed = 0
    for f in d.iterdir():
        if _stale(f, now):
            with contextlib.suppress(OSError):
                f.unlink()
                removed += 1
    return removed


_SWEPT: set[str] = set()  # directories this process has swept (atomic_open)
_SWEPT_LOCK = threading.Lock()


def _sweep_once(directory: Path) -> None:
    key = os.path.abspath(directory)
    with _SWEPT_LOCK:
        if key in _SWEPT:
            return
        _SWEPT.add(key)
    sweep_stale_temps(directory)


@contextlib.contextmanager
def atomic_open(path: str | os.PathLike, mode: str = "w", **kw: Any) -> Iterator[IO[Any]]:
    """``with atomic_open(path, "w" | "wb") as fh: ...`` writes ``path`` atomically (see the module
    docstring); on any exception the temp file is removed and ``path`` is untouched."""
    if mode not in ("w", "wb"):
        raise ValueError(f"atomic_open supports modes 'w' and 'wb', got {mode!r}")
    path = Path(path)
    if path.is_dir():
        raise IsADirectoryError(f"{path} is a directory")
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.{HOST}-{os.getpid()}.", suffix=TMP_SUFFIX)
    except OSError as exc:  # name the target, not the hidden temp file
        raise OSError(exc.errno, f"cannot write {path}: {exc.strerror}") from None
    try:
        if mode == "w":
            kw.setdefault("encoding", "utf-8")
        with os.fdopen(fd, mode, **kw) as fh:
            yield fh
            fh.flush()
            os.fsync(fh.fileno())
        publish(tmp, path)
    except OSError as exc:  # name the target (a bare "[Errno 27] File too large" said nothing; a reliability trial)
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        if str(path) in str(exc) or exc.errno is None:
            raise
        raise type(exc)(exc.errno, f"cannot write {path}: {exc.strerror or exc}") from exc
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise
    _sweep_once(path.parent)  # after the write: an earlier writer's .NAME.RANDOM.tmp is judged with its target in place


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


_NEW_RESULTS_DIRS: list[Path] = []  # made by new_results_dir in this process


def new_results_dir(name: str, base: str | os.PathLike | None = None) -> Path:
    """A new, empty folder ``poseonly-NAME-YYYYmmdd-HHMMSS[-k]`` under ``base`` (default: the working
    directory): where experiments and benchmarks write when no ``--out`` is given, so that a run never
    overwrites earlier results (a clone's committed docs/results included). A run that fails before
    writing anything leaves no folder behind (:func:`remove_empty_results_dirs`, called by the CLI)."""
    root = Path.cwd() if base is None else Path(base)
    stem = f"poseonly-{name}-{time.strftime('%Y%m%d-%H%M%S')}"
    for k in range(1000):
        p = root / (stem if k == 0 else f"{stem}-{k}")
        try:
            p.mkdir(parents=True)
            _NEW_RESULTS_DIRS.append(p)
            return p
        except FileExistsError:
            continue
    raise FileExistsError(f"could not create a new results folder {stem}-* under {root}")


def remove_empty_results_dirs() -> None:
    """Remove the folders :func:`new_results_dir` made in this process that are still empty (a run
    that failed before writing anything); folders with content are kept."""
    while _NEW_RESULTS_DIRS:
        with contextlib.suppress(OSError):
            _NEW_RESULTS_DIRS.pop().rmdir()  # only an empty folder can be removed


def atomic_savez(path: str | os.PathLike, **arrays: Any) -> None:
    """``np.savez`` through :func:`atomic_open` (atomic; the temp files of killed writers are removed
    by the next process that writes into the directory)."""
    import numpy as np

    with atomic_open(path, "wb") as fh:
        np.savez(fh, **arrays)


_CACHE_WARNED: set[str] = set()  # cache directories whose failed write was reported (once each)


def cache_savez(path: str | os.PathLike, **arrays: Any) -> bool:
    """:func:`atomic_savez` for an optional cache entry: a failed write (a full disk, a read-only
    folder) is a ``RuntimeWarning`` naming the folder, once per folder, and the caller goes on without
    the entry (a reliability trial: a full cache disk ended the pose estimate). False if not written."""
    try:
        atomic_savez(path, **arrays)
        return True
    except OSError as exc:
        folder = str(Path(path).parent)
        with _SWEPT_LOCK:
            first = folder not in _CACHE_WARNED
            _CACHE_WARNED.add(folder)
        if first:
            warnings.warn(f"cannot write to the cache folder {folder} ({exc.strerror or exc}); going on without caching there", RuntimeWarning, stacklevel=2)
        return False


def staging_dir(parent: str | os.PathLike) -> Path:
    """A new hidden folder in ``parent`` (``.staging.HOST-PID.RANDOM.poseonly-tmp``, on the same file system)
    where a writer of several outputs puts them all before moving them into place: a failed write leaves
    the previous set whole (a reliability trial: a full disk left one new file among old ones). The
    staging folders of this host's dead processes in ``parent`` are removed first."""
    import shutil

    d = Path(parent)
    d.mkdir(parents=True, exist_ok=True)
    now = time.time()
    for f in d.iterdir():
        if f.name.startswith(".staging.") and f.is_dir() and not f.is_symlink() and _stale(f, now):
            shutil.rmtree(f, ignore_errors=True)
    return Path(tempfile.mkdtemp(dir=d, prefix=f".staging.{HOST}-{os.getpid()}.", suffix=TMP_SUFFIX))
