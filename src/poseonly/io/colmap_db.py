"""Reading matches and writing two-view geometries in a COLMAP database (pycolmap, optional).

Reads go through ``pycolmap.Database`` except the schema check and the list of matched pairs: one
read-only SQL query on the ``matches`` table before pycolmap opens the file (pycolmap only reads
all matches at once). Writes are
``pycolmap.Database.write_two_view_geometry`` (``update_two_view_geometry`` for a pair that has a row)
inside one ``pycolmap.DatabaseTransaction`` per batch of pairs, with Ctrl-C and SIGTERM held until it
has committed: SQLite's journal makes every batch all-or-nothing, so a process killed at any moment
leaves each pair its old row or its new one.

Pair convention (COLMAP's): ``pair_id = image_pair_to_pair_id(id1, id2)`` with ``id1 < id2``; match
columns are keypoint indices of ``id1`` and ``id2``; ``cam2_from_cam1`` maps camera-1 coordinates
to camera 2 (our ``X2 = R X1 + t``).
"""

from __future__ import annotations

import contextlib
import errno
import os
import signal
import sqlite3
import tempfile
import threading
import time
from collections import OrderedDict
from collections.abc import Iterable, Iterator
from contextlib import closing
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Self

import numpy as np

from .._fileutil import HOST, SQLITE_JOURNALS, TMP_SUFFIX, sweep_stale_temps
from .._pycolmap import import_pycolmap
from ..cameras import Camera, as_camera
from ..geometry import InputError
from .colmap_geometry import TwoViewFields, pycolmap_geometry_kwargs
from .pair_list import parse_pair_names

__all__ = [
    "KEYPOINT_CACHE_IMAGES",
    "ColmapDatabase",
    "DatabaseUnavailableError",
    "GeometryRow",
    "reading_snapshot",
    "check_writable",
    "guessed_focal",
    "keypoint_scales",
    "matched_pair_ids",
    "refuse_guessed_focal",
]

KEYPOINT_CACHE_IMAGES = 512  # images whose keypoints (and bearings) are kept in memory (LRU)


# pycolmap's Database.open is retried this long (pausing between tries) before a failure is final
OPEN_RETRY_S = 2.0
OPEN_RETRY_PAUSE_S = 0.05
# a batch that finds the database locked by another process is written again for up to this long (seconds)
WRITE_RETRY_S = 10.0
WRITE_RETRY_PAUSE_S = 0.05


class DatabaseUnavailableError(OSError):
    """A COLMAP database that exists but cannot be used now: locked by another process, or read-only
    (the file, its directory or the file system) where poseonly must write. An ``OSError``, not an
    :class:`InputError`: the file is right, its circumstances are not (``poseonly``'s commands print it
    as one line and exit with 2)."""


def database_unavailable(path: str | Path, exc: BaseException, doing: str) -> DatabaseUnavailableError:
    """The :class:`DatabaseUnavailableError` of an SQLite or pycolmap error ``exc`` while ``doing``."""
    text = str(exc)
    low = text.lower()
    if "locked" in low or "busy" in low:
        why = "it is locked by another process (a COLMAP or poseonly run on it?); try again when that one has finished"
    elif "readonly" in low or "read-only" in low or "unable to open" in low or "no registered database factory" in low:
        why = "SQLite cannot open it as needed (a read-only file, directory or file system; no permission; or a lock held by another process)"
    else:
        why = "the database refused it"
    return DatabaseUnavailableError(f"cannot use the COLMAP database {path} ({doing}): {why} [{text.strip().splitlines()[-1] if text.strip() else type(exc).__name__}]")


def keypoint_scales(raw: np.ndarray) -> np.ndarray | None:
    """Scales ``(k,)`` of COLMAP keypoint rows ``(k, c)``: ``x, y, scale, orientation`` (c = 4) or
    ``x, y, a11, a12, a21, a22`` (c = 6, the affine shape: ``sqrt(|det A|)``); ``None`` for
    positions only (c = 2) or when a scale is not finite and positive (the noise scales of
    :func:`poseonly.estimate_relative_pose` need every one)."""
    if raw.ndim != 2 or raw.shape[1] not in (4, 6) or len(raw) == 0:
        return None
    s = raw[:, 2].copy() if raw.shape[1] == 4 else np.sqrt(np.abs(raw[:, 2] * raw[:, 5] - raw[:, 3] * raw[:, 4]))
    return s if bool(np.all(np.isfinite(s) & (s > 0))) else None


# the free space a batch of rows needs (ColmapDatabase._check_free_space): a row's fixed part (pair id,
# config, F, E, H, qvec, tvec, index entries: ~300 bytes) plus 8 bytes an inlier match, counted this many
# times (the write-ahead log, the database file after the checkpoint, a journal), plus a margin
ROW_BYTES = 512
FREE_SPACE_FACTOR = 3
FREE_SPACE_MARGIN = 4 << 20


@dataclass
class GeometryRow:
    """One ``two_view_geometries`` row: the pair's image ids and its ``geometry``
    (:class:`poseonly.io.colmap_geometry.TwoViewFields`: configuration, inlier matches, E, F, H, R, t)."""

    image_id1: int
    image_id2: int
    geometry: TwoViewFields

    @classmethod
    def empty(cls, image_id1: int, image_id2: int, config: str) -> GeometryRow:
        """A row without inlier matches or matrices (an error, a degenerate pair)."""
        return cls(image_id1, image_id2, TwoViewFields(config, np.zeros((0, 2), dtype=np.int64)))


def _pycolmap():
    try:
        pycolmap = import_pycolmap()
    except ImportError:
        raise ImportError("reading a COLMAP database needs pycolmap (pip install pycolmap)") from None
    return pycolmap


def guessed_focal(camera: Any) -> str | None:
    """A description of ``camera`` (a ``pycolmap.Camera``) if COLMAP guessed its focal length (no
    ``has_prior_focal_length``: no calibration was given and no EXIF focal length was found, so COLMAP
    took ~1.2 times the larger image side), else ``None``."""
    if bool(getattr(camera, "has_prior_focal_length", True)):
        return None
    K = np.asarray(camera.calibration_matrix(), dtype=float)
    return f"camera {int(camera.camera_id)} ({camera.model_name}, {int(camera.width)}x{int(camera.height)}, f = {0.5 * (K[0, 0] + K[1, 1]):.1f} px)"


def refuse_guessed_focal(path: str | Path, guessed: Iterable[str], override: str) -> None:
    """:class:`InputError` naming the cameras of the database ``path`` whose focal length COLMAP
    guessed (``guessed``: :func:`guessed_focal`'s descriptions; nothing happens if empty). A calibrated
    relative pose from a guessed focal length can be degrees off while it looks right, so such a
    database is refused unless the caller gives a calibration or says to use the guess (``override``:
    how, in the caller's terms)."""
    names = sorted(set(guessed))
    if names:
        shown = "; ".join(names[:5]) + (f"; and {len(names) - 5} more" if len(names) > 5 else "")
        raise InputError(
            f"{path}: COLMAP guessed the focal length of {len(names)} camera(s) used by the pairs (no prior focal length: no calibration"
            f" or EXIF focal length was given when the images were imported): {shown}. A calibrated relative pose needs the real"
            f" focal length; with a guess its rotation can be degrees off. {override}"
        )


def _sqlite_uri(path: Path, mode: str) -> str:
    """An SQLite URI of the existing file ``path`` opened in ``mode`` (``ro`` / ``rw``: never created): the
    path percent-encoded (a review: ``#`` or ``?`` in a name cut the URI, and ``mode`` was dropped, so
    SQLite created another, empty file)."""
    return f"{path.resolve().as_uri()}?mode={mode}"


def matched_pair_ids(path: str | Path) -> list[int]:
    """The pair ids of ``path``'s matches (pairs with at least one match, ascending), after checking
    that ``path`` is an existing COLMAP database: :class:`InputError` otherwise, and the file is never
    created or changed (pycolmap's ``Database.open`` creates the tables in any SQLite file, or in a
    new one). Read with a read-only SQL connection, closed on return: Python's sqlite3 is a different
    SQLite library from pycolmap's, and both must never have the file open in one process (closing
    one connection drops the other's POSIX locks, which corrupts the database:
    sqlite.org/howtocorrupt.html 2.2.1)."""
    p = Path(path)
    if not p.is_file():
        raise InputError(f"COLMAP database not found: {path}")
    try:
        with closing(sqlite3.connect(_sqlite_uri(p, "ro"), uri=True)) as con:
            tables = {r[0] for r in con.execute("SELECT name FROM sqlite_master WHERE type='table'")}
            missing = {"cameras", "images", "keypoints", "matches", "two_view_geometries"} - tables
            if missing:
                raise InputError(f"{path} is not a COLMAP database (missing tables {sorted(missing)})")
            return [int(r[0]) for r in con.execute("SELECT pair_id FROM matches WHERE rows > 0 ORDER BY pair_id")]
    except sqlite3.OperationalError as exc:  # an SQLite file it cannot read now (not a wrong file)
        if "not a database" in str(exc):
            raise InputError(f"{path} is not an SQLite database: {exc}") from None
        raise database_unavailable(path, exc, "reading its matched pairs") from None
    except sqlite3.DatabaseError as exc:
        raise InputError(f"{path} is not an SQLite database: {exc}") from None


# tables whose rows a reading snapshot leaves out (what the readers never use: the descriptors are most of
# a database's size)
SNAPSHOT_SKIPPED_ROWS = ("descriptors",)


@contextlib.contextmanager
def reading_snapshot(path: str | os.PathLike, directory: str | os.PathLike | None = None) -> Iterator[Path]:
    """A copy of the COLMAP database ``path`` to open with pycolmap for reading, removed when the block
    ends. pycolmap opens a database read-write (it creates its tables if they are missing): a read-only
    file or directory, or another process's write transaction, stopped the reading, and SQLite updated
    the file's header although no table changed (a COLMAP user's trial). The copy is made through one
    read-only SQL connection, closed before pycolmap opens the copy (never both on one file:
    :func:`matched_pair_ids`): every table and index as its schema has it, the rows of every table but
    :data:`SNAPSHOT_SKIPPED_ROWS`. It is written in ``directory`` (default: the system's temporary
    folder) under an atomic writer's temporary name, so a killed run's copy is swept by the next
    (:mod:`poseonly._fileutil`). The source is never written."""
    p = Path(path)
    d = Path(directory) if directory is not None else Path(tempfile.gettempdir())
    d.mkdir(parents=True, exist_ok=True)
    sweep_stale_temps(d)  # a killed run's copy
    fd, name = tempfile.mkstemp(prefix=f".{p.name}.{HOST}-{os.getpid()}.", suffix=TMP_SUFFIX, dir=d)
    os.close(fd)
    snap = Path(name)
    try:
        try:
            with closing(sqlite3.connect(snap)) as dst:
                dst.execute("ATTACH DATABASE ? AS src", (_sqlite_uri(p, "ro"),))
                schema = dst.execute("SELECT type, name, sql FROM src.sqlite_master WHERE sql IS NOT NULL ORDER BY type = 'index', rowid").fetchall()
                for kind, table, sql in schema:
                    if table.startswith("sqlite_"):
                        continue
                    dst.execute(sql)
                    if kind == "table" and table not in SNAPSHOT_SKIPPED_ROWS:
                        dst.execute(f'INSERT INTO main."{table}" SELECT * FROM src."{table}"')
                dst.commit()
                dst.execute("DETACH DATABASE src")
        except sqlite3.DatabaseError as exc:
            raise database_unavailable(p, exc, "reading it (a copy to open with pycolmap)") from None
        yield snap
    finally:
        for f in (snap, *(snap.with_name(snap.name + x) for x in SQLITE_JOURNALS)):
            with contextlib.suppress(FileNotFoundError):
                f.unlink()


def check_writable(path: str | Path) -> None:
    """:class:`DatabaseUnavailableError` unless the existing database ``path`` can be written now: the
    file and its directory writable (SQLite writes its journal beside the file) and no other process
    holding a write lock (``BEGIN IMMEDIATE`` on a connection that is closed before pycolmap opens the
    file: :func:`matched_pair_ids` says why). Checked before any pair is estimated, so that a run does
    not end in a traceback after its work; a lock taken later still ends the run, with this error, the
    pairs written before kept (a rerun resumes)."""
    p = Path(path)
    for what, q in (("file", p), ("directory", p.resolve().parent)):
        if not os.access(q, os.W_OK):
            raise DatabaseUnavailableError(f"cannot use the COLMAP database {path}: its {what} {q} is not writable (poseonly writes two_view_geometries rows)")
    try:
        # a lock held for a moment (another connection's WAL recovery or checkpoint; a killed run's
        # database reopened at once: a CI run of test_kill_and_resume saw it once) is waited for as the
        # opening's is (OPEN_RETRY_S); a run holding the database longer still stops this one here
        with closing(sqlite3.connect(_sqlite_uri(p, "rw"), uri=True, timeout=OPEN_RETRY_S)) as con:
            con.execute("BEGIN IMMEDIATE")
            con.rollback()
    except sqlite3.DatabaseError as exc:
        raise database_unavailable(path, exc, "before writing") from None


DEFERRED_SIGNALS = tuple(getattr(signal, n) for n in ("SIGINT", "SIGTERM") if hasattr(signal, n))


@contextlib.contextmanager
def signals_deferred() -> Iterator[None]:
    """Hold Ctrl-C and SIGTERM during the block and act on them after it (in Python's main thread, where
    their handlers run; elsewhere a no-op: no KeyboardInterrupt is raised in other threads). A signal that
    came is then handed to the handler that was installed (``SIG_DFL``: sent again, ending the process as
    it would have; ``SIG_IGN``: dropped)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    came: list[int] = []
    previous = {sig: signal.signal(sig, lambda signum, frame: came.append(signum)) for sig in DEFERRED_SIGNALS}
    try:
        yield
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)
        for sig in dict.fromkeys(came):
            handler = previous[sig]
            if callable(handler):
                handler(sig, None)
            elif handler == signal.SIG_DFL:
                os.kill(os.getpid(), sig)


class ColmapDatabase:
    """An existing COLMAP database file (never created here: a wrong path is an error)."""

    def __init__(self, path: str | Path, writable: bool = False) -> None:
        """``writable``: the caller will write (:func:`check_writable` before pycolmap opens the file)."""
        p = Path(path)
        pair_ids = matched_pair_ids(p)  # checked, read-only, before pycolmap opens the file
        if writable:
            check_writable(p)
        self.path = p
        self._pc = _pycolmap()
        deadline = time.monotonic() + OPEN_RETRY_S
        while True:
            try:
                self.db = self._pc.Database.open(str(p))
                break
            except RuntimeError as exc:  # pycolmap: "No registered database factory succeeded" (its log says why)
                # a reader's lock at the moment of opening (a COLMAP viewer, a poller: a test saw it once) is
                # transient; pycolmap's error does not say which it was, so the opening is retried briefly
                if time.monotonic() >= deadline:
                    raise database_unavailable(p, exc, "opening it with pycolmap") from None
                time.sleep(OPEN_RETRY_PAUSE_S)
        self._pairs: list[tuple[int, int, int]] = []
        for pid in pair_ids:
            i1, i2 = self._pc.pair_id_to_image_pair(pid)
            self._pairs.append((pid, int(i1), int(i2)))
        # COLMAP stores a pair under the id of (smaller image id, larger): a pair stored the other way round
        # is read and written by pycolmap as its canonical twin (a reliability trial: its row overwrote the
        # canonical pair's, or it was written DEGENERATE with its matches never read)
        twisted = [(pid, i1, i2) for pid, i1, i2 in self._pairs if i1 > i2]
        if twisted:
            self.db.close()
            pid, i1, i2 = twisted[0]
            raise InputError(
                f"{p}: {len(twisted)} pairs of the matches table have a pair id COLMAP does not write (e.g. {pid}: image ids {i1} > {i2};"
                " COLMAP's pair id is that of the smaller image id first); the database was not written through COLMAP's API"
            )
        self._kp: OrderedDict[int, tuple[np.ndarray, np.ndarray | None]] = OrderedDict()
        try:
            images = self.db.read_all_images()
            cams = {c.camera_id: c for c in self.db.read_all_cameras()}
        except (RuntimeError, ValueError) as exc:  # a malformed row ("Camera model does not exist", a params count)
            self.db.close()
            raise InputError(f"{p}: pycolmap cannot read its images or cameras: {(str(exc).strip().splitlines() or [type(exc).__name__])[-1]}") from None
        self.image_names = {int(im.image_id): str(im.name) for im in images}
        self.cameras: dict[int, Camera] = {}
        self.unsupported: dict[int, str] = {}
        # image id -> its camera's description where COLMAP guessed the focal length (guessed_focal)
        self.guessed: dict[int, str] = {}
        for im in images:
            c = cams.get(im.camera_id)
            if c is None:  # (a KeyError traceback before; a reliability trial)
                self.unsupported[int(im.image_id)] = f"image {im.name!r} (id {im.image_id}) refers to camera {im.camera_id}, which is not in the database"
                continue
            g = guessed_focal(c)
            if g is not None:
                self.guessed[int(im.image_id)] = g
            try:
                self.cameras[int(im.image_id)] = as_camera(c, f"camera {im.camera_id}")
            except InputError as exc:
                self.unsupported[int(im.image_id)] = str(exc)

    def close(self) -> None:
        self.db.close()

    def __enter__(self) -> Self:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # -- reading --------------------------------------------------------------------------------------

    def matched_pairs(self) -> list[tuple[int, int, int]]:
        """``(pair_id, image_id1, image_id2)`` of every pair with at least one match, by pair id."""
        return list(self._pairs)

    def pair_ids_from_names(self, lines: Iterable[str], source: str = "pairs file") -> set[int]:
        """Pair ids of ``name1 name2`` lines (COLMAP's match-list format; ``#`` comments)."""
        by_name = {n: i for i, n in self.image_names.items()}
        out = set()
        for a, b in parse_pair_names(lines, source, by_name, "an image of the database"):
            out.add(int(self._pc.image_pair_to_pair_id(by_name[a], by_name[b])))
        return out

    def has_geometry(self, image_id1: int, image_id2: int) -> bool:
        """Does the pair have a ``two_view_geometries`` row (of any configuration)?"""
        return bool(self.db.exists_two_view_geometry(image_id1, image_id2))

    def matches(self, image_id1: int, image_id2: int) -> np.ndarray:
        """``(m, 2)`` keypoint indices (int64)."""
        return np.asarray(self.db.read_matches(image_id1, image_id2), dtype=np.int64).reshape(-1, 2)

    def keypoints(self, image_id: int) -> np.ndarray:
        """``(k, 2)`` keypoint pixel positions (float64), LRU-cached."""
        return self._keypoint_entry(image_id)[0]

    def keypoint_scales(self, image_id: int) -> np.ndarray | None:
        """``(k,)`` keypoint scales (:func:`keypoint_scales`; ``None`` when the database stores
        positions only), LRU-cached."""
        return self._keypoint_entry(image_id)[1]

    def _keypoint_entry(self, image_id: int) -> tuple[np.ndarray, np.ndarray | None]:
        e = self._kp.get(image_id)
        if e is None:
            raw = np.asarray(self.db.read_keypoints(image_id), dtype=np.float64)
            raw = raw.reshape(len(raw), -1) if raw.size else np.zeros((0, 2))
            e = (raw[:, :2].copy(), keypoint_scales(raw))
            self._kp[image_id] = e
            if len(self._kp) > KEYPOINT_CACHE_IMAGES:
                self._kp.popitem(last=False)
        else:
            self._kp.move_to_end(image_id)
        return e

    def read_geometry(self, image_id1: int, image_id2: int) -> dict[str, Any]:
        """The stored row as a dict (``config`` as a name, arrays as numpy)."""
        g = self.db.read_two_view_geometry(image_id1, image_id2)
        d = g.todict()
        d["config"] = self._pc.TwoViewGeometryConfiguration(d["config"]).name
        return d

    # -- writing --------------------------------------------------------------------------------------

    def write_geometries(self, rows: Iterable[GeometryRow]) -> int:
        """Write (replacing) the rows in one transaction; returns how many. A lock another process holds
        is waited for up to :data:`WRITE_RETRY_S` (the batch written again: a row is replaced, so rows
        of a batch that got in before the lock are written twice, the same; a 20 ms lock ended a run:
        a COLMAP user's trial); then, or where SQLite refuses otherwise, :class:`DatabaseUnavailableError`."""
        rows = list(rows)
        deadline = time.monotonic() + WRITE_RETRY_S
        while True:
            try:
                return self._write(rows)
            except RuntimeError as exc:
                low = str(exc).lower()
                if ("locked" in low or "busy" in low) and time.monotonic() < deadline:
                    time.sleep(WRITE_RETRY_PAUSE_S)
                    continue
                raise database_unavailable(self.path, exc, "writing two-view geometries; the batches written before are kept and a rerun resumes") from None

    def _write(self, rows: Iterable[GeometryRow]) -> int:
        """The batch in one transaction. pycolmap's ``DatabaseTransaction`` commits when its block ends,
        an exception included (a COLMAP user's trial: a Ctrl-C inside a batch committed half of it and,
        between a row's delete and its insert, left a pair with no row), so: the rows are built before
        the transaction; an existing row is replaced by one ``update_two_view_geometry`` (never absent);
        and Ctrl-C / SIGTERM during the transaction are held until it has committed
        (:func:`signals_deferred`). A SIGKILL or a crash leaves SQLite's journal to roll it back."""
        pc = self._pc
        rows = list(rows)
        self._check_free_space(rows)
        built = [(r, pc.TwoViewGeometry(**pycolmap_geometry_kwargs(r.geometry, pc))) for r in rows]
        k = 0
        with signals_deferred(), pc.DatabaseTransaction(self.db):
            for r, g in built:
                if self.db.exists_two_view_geometry(r.image_id1, r.image_id2):
                    if hasattr(self.db, "update_two_view_geometry"):
                        self.db.update_two_view_geometry(r.image_id1, r.image_id2, g)
                    else:  # pragma: no cover - pycolmap before update_two_view_geometry (signals held here too)
                        self.db.delete_two_view_geometry(r.image_id1, r.image_id2)
                        self.db.write_two_view_geometry(r.image_id1, r.image_id2, g)
                else:
                    self.db.write_two_view_geometry(r.image_id1, r.image_id2, g)
                k += 1
        return k

    def _check_free_space(self, rows: list[GeometryRow]) -> None:
        """:class:`OSError` unless the database's file system has room for the batch: pycolmap commits in
        a C++ destructor, and a failed commit (a full disk) aborts the process (SIGABRT, a C++ stack
        trace; a reliability trial) where no Python code can catch it. The batch's rows, counted
        ``FREE_SPACE_FACTOR`` times (the write-ahead log, then its checkpoint into the file) plus
        ``FREE_SPACE_MARGIN`` bytes, must fit. A limit the file system does not report (``ulimit -f``, a
        quota) is not seen."""
        need = FREE_SPACE_FACTOR * sum(ROW_BYTES + 8 * len(r.geometry.inlier_matches) for r in rows) + FREE_SPACE_MARGIN
        try:
            st = os.statvfs(self.path.resolve().parent)
        except OSError:  # pragma: no cover - a file system without statvfs: nothing to check
            return
        free = st.f_bavail * st.f_frsize
        if free < need:
            raise OSError(
                errno.ENOSPC,
                f"cannot write to the COLMAP database {self.path}: {free} bytes free on its file system, a batch of {len(rows)} rows"
                f" needs about {need}; the batches written before are kept and a rerun resumes",
            )
