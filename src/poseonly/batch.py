"""Many pairs: :func:`estimate_relative_poses` over an iterable of pairs, serially, on a local
process or thread pool or on a Dask cluster, yielding each pair's result as its chunk finishes.

Threads (``backend="threads"``) work because the compiled core releases the GIL for its numeric work,
which is about 90 % of a pair (``benchmarks/stage_times.py --core-share``): no worker processes to
start, no pickling, and it runs where processes cannot be forked (notebooks, Windows). The default
``backend="auto"`` takes threads for a batch of known size below :data:`AUTO_THREADS_MAX_PAIRS` pairs
(a process pool's start-up costs more than such a batch can gain from escaping the GIL) and
processes otherwise (the GIL's ~10 % share bounds threads on many cores: 4.7x on 8 by Amdahl's law).

Determinism: the seed of a pair is derived from the base ``seed`` option and the pair's key
(:func:`pair_seed`, a BLAKE2b hash), never from its position in the schedule, so the result of a
pair is the same serially, on any number of processes and on any cluster (each estimate runs
single-threaded BLAS, see :mod:`poseonly.api`). Keys that compare equal get one seed whatever types
built them (:func:`canonical_key`); keys must be hashable and unique in a batch (:class:`InputError`
at the offending pair).

Work is sent in chunks (``chunk_size`` pairs per task; default :data:`POOL_CHUNK` on a process
pool, :data:`DASK_CHUNK` on Dask, fewer when a sized batch would otherwise give a worker fewer than
:data:`MIN_CHUNKS_PER_WORKER` chunks) with a bounded number of chunks in flight, so an iterable of
100k pairs is streamed, not loaded at once. On Dask, a chunk lost with its worker is recomputed by
the scheduler, and a chunk whose task fails is retried ``retries`` times.

A pair whose input is invalid does not stop the batch: its :class:`PairResult` carries the error
message (``result is None``). Invalid options do: they are checked once before any work is sent.
"""

from __future__ import annotations

import hashlib
import os
import sys
from collections.abc import Generator, Hashable, Iterable, Iterator, Mapping
from dataclasses import dataclass, field
from types import FrameType
from typing import Any, Literal, get_args

import numpy as np

from ._equality import ValueEquality
from .api import RelativePoseResult, estimate_relative_pose
from .geometry import InputError
from .options import SEED_LIMIT
from .robust.cancel import CancelFlag, SearchCancelled, cancellable

__all__ = ["AUTO_THREADS_MAX_PAIRS", "BACKENDS", "DASK_CHUNK", "POOL_CHUNK", "Pair", "PairResult", "canonical_key", "estimate_relative_poses", "pair_seed"]

POOL_CHUNK = 16  # pairs per task on a local process pool (small: early results, even load)
DASK_CHUNK = 256  # pairs per task on Dask (amortises the scheduler's per-task overhead)
MIN_CHUNKS_PER_WORKER = 4  # a known-size batch is cut finer when it would give fewer chunks per worker
IN_FLIGHT_PER_WORKER = 2  # chunks queued per worker: keeps workers busy without loading everything
Backend = Literal["auto", "processes", "threads"]
BACKENDS: tuple[Backend, ...] = get_args(Backend)  # the local pool's workers (n_jobs > 1)
# backend="auto": a batch of known size below this many pairs runs on threads, a larger or unsized one on
# processes (a user's trial: 2 processes 1.29-1.43x slower than serial on 28-55 pairs, first result after
# 1.15 s against 0.07 s; PIPELINES.md, "Throughput")
AUTO_THREADS_MAX_PAIRS = 256
DASK_RETRIES = 3
_SEED_BITS = 63
_CHECK_POINTS = 100


@dataclass(eq=False)
class Pair(ValueEquality):
    """One image pair: matched points ``x1, x2`` (``(n, 2)`` pixels with ``camera1/2`` or ``K1/K2``,
    or ``(n, 3)`` bearings), a hashable ``key`` (default: the position in the iterable), the matches'
    ``scores (n,)`` and ``noise_scales (n,)`` (see :func:`poseonly.estimate_relative_pose`; ``None``:
    none) and per-pair ``options`` overriding the batch's (e.g. ``threshold_px``). ``==`` compares values
    (arrays elementwise, NaN equal to NaN), as :class:`PairResult`'s."""

    x1: np.ndarray
    x2: np.ndarray
    key: Hashable = None
    camera1: Any = None
    camera2: Any = None
    K1: np.ndarray | None = None
    K2: np.ndarray | None = None
    options: dict[str, Any] = field(default_factory=dict)
    scores: np.ndarray | None = None
    noise_scales: np.ndarray | None = None


@dataclass(eq=False)
class PairResult(ValueEquality):
    """The outcome of one pair: ``result`` (or ``None`` and ``error`` when the input was invalid),
    the pair's ``key``, its ``index`` in the input iterable and the ``seed`` it was run with."""

    index: int
    key: Hashable
    seed: int
    result: RelativePoseResult | None
    error: str | None = None

    @property
    def ok(self) -> bool:
        return self.result is not None and self.result.ok

    def to_dict(self, *, exact: bool = False) -> dict[str, Any]:
        """JSON-safe record (one line of a JSON Lines log; a batch trial): ``index``, ``key`` (its
        :func:`canonical_key`, tuples as lists, other non-JSON keys as their ``repr``), ``seed``,
        ``error`` and ``result`` (:meth:`poseonly.RelativePoseResult.to_dict` with ``exact``, or
        ``None``)."""
        result = None if self.result is None else self.result.to_dict(exact=exact)
        return {"index": int(self.index), "key": _json_key(canonical_key(self.key)), "seed": int(self.seed), "error": self.error, "result": result}

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> PairResult:
        """The pair result a :meth:`to_dict` record describes: the key's lists as tuples (a key written
        as its ``repr`` stays that string), the result by :meth:`poseonly.RelativePoseResult.from_dict`
        (equal to the original from ``to_dict(exact=True)``). Raises :class:`poseonly.InputError` on a
        malformed record."""
        if not isinstance(d, Mapping) or not all(k in d for k in ("index", "key", "seed", "result")):
            raise InputError("PairResult.from_dict needs a mapping with 'index', 'key', 'seed' and 'result'")
        for k in ("index", "seed"):
            if isinstance(d[k], bool) or not isinstance(d[k], int):
                raise InputError(f"PairResult.from_dict: {k!r} must be an integer, got {d[k]!r}")
        error = d.get("error")
        if error is not None and not isinstance(error, str):
            raise InputError(f"PairResult.from_dict: 'error' must be a string or None, got {error!r}")
        result = None if d["result"] is None else RelativePoseResult.from_dict(d["result"])
        return cls(index=d["index"], key=_key_from_json(d["key"]), seed=d["seed"], result=result, error=error)


def _key_from_json(key: Any) -> Hashable:
    if isinstance(key, list):
        return tuple(_key_from_json(k) for k in key)
    if isinstance(key, dict):
        raise InputError("PairResult.from_dict: a key cannot be a mapping")
    return key


def _json_key(key: Any) -> Any:
    if key is None or isinstance(key, (str, int, bool)):
        return key
    if isinstance(key, float):
        return key if np.isfinite(key) else repr(key)
    if isinstance(key, tuple):
        return [_json_key(k) for k in key]
    return repr(key)


def canonical_key(key: Hashable) -> Hashable:
    """``key`` with numpy scalars as the Python ones they equal (``np.int64(7)``, ``np.float32(7.0)`` and
    ``np.True_`` -> ``7``, ``7`` and ``1``; a whole float -> its int; ``np.str_`` -> ``str``), tuples
    element by element and a frozenset as the sorted tuple of its elements' canonical ``repr``: keys that
    compare equal (one dict entry) get one seed, whatever types built them (a user's trial: ``(0, 7)``
    and ``(np.int64(0), np.int64(7))`` gave different seeds and statuses)."""
    if isinstance(key, (bool, np.bool_)):
        return int(key)
    if isinstance(key, np.integer):
        return int(key)
    if isinstance(key, (float, np.floating)):
        x = float(key)
        return int(x) if x.is_integer() else x
    if isinstance(key, np.str_):
        return str(key)
    if isinstance(key, np.bytes_):
        return bytes(key)
    if isinstance(key, tuple):
        return tuple(canonical_key(k) for k in key)
    if isinstance(key, frozenset):  # its iteration order (and repr) depends on the process's hash seed
        return _SortedSet(tuple(sorted(repr(canonical_key(k)) for k in key)))
    return key


@dataclass(frozen=True)
class _SortedSet:
    """A frozenset key's canonical form: its elements' canonical reprs, sorted (equal only to another
    set's, never to a tuple's; its repr is stable across processes)."""

    reprs: tuple[str, ...]

    def __repr__(self) -> str:
        return "frozenset({" + ", ".join(self.reprs) + "})"


def pair_seed(base_seed: int, key: Hashable) -> int:
    """Seed of the pair ``key``: the first 63 bits of ``BLAKE2b(repr((base_seed, canonical_key(key))))``
    (:func:`canonical_key`: keys that compare equal get one seed). Keys should be ints, strings or
    tuples of them (their ``repr`` is stable across processes and runs; an object's default ``repr``
    holds its address, which is not)."""
    h = hashlib.blake2b(repr((int(base_seed), canonical_key(key))).encode(), digest_size=8).digest()
    return int.from_bytes(h, "little") >> (64 - _SEED_BITS)


def _as_pair(p: Any, index: int) -> Pair:
    if isinstance(p, Pair):
        pair = p
    elif isinstance(p, Mapping):
        extra = set(p) - set(Pair.__dataclass_fields__)
        if extra:
            raise InputError(f"pair {index}: unknown keys {sorted(extra)}; valid: {sorted(Pair.__dataclass_fields__)}")
        if "x1" not in p or "x2" not in p:
            raise InputError(f"pair {index}: needs x1 and x2")
        pair = Pair(**p)
    else:
        raise InputError(f"pair {index} must be a poseonly.batch.Pair or a dict with x1, x2, ...; got {type(p).__name__}")
    if pair.key is None:
        pair = Pair(**{**pair.__dict__, "key": index})
    try:
        hash(pair.key)
    except TypeError:
        raise InputError(f"pair {index}: its key must be hashable (results are collected by key), got {type(pair.key).__name__} {pair.key!r}") from None
    return pair


# a pair's own options may not name its points or cameras (the Pair's fields carry them; ``scores`` and
# ``noise_scales`` there override the Pair's fields)
_PAIR_FIELDS_IN_OPTIONS = ("x1", "x2", "K1", "K2", "camera1", "camera2")
# per-match arrays: a pair's (its fields, or its own options), never the batch's (a batch trial: batch-level
# scores overrode every pair's own silently)
_PER_MATCH = ("scores", "noise_scales")


def _pair_options(pair: Pair, options: dict[str, Any]) -> tuple[dict[str, Any], int]:
    """The batch's options with the pair's own, and the pair's base seed; :class:`InputError` for a
    pair whose ``options`` are not a dict of option names, name its points or cameras, or hold a seed
    that is not a whole number in ``[0, 2**64)`` (as the single-pair API; :func:`pair_seed` hashes it)."""
    own = pair.options
    if not isinstance(own, Mapping) or not all(isinstance(k, str) for k in own):
        raise InputError(f"the pair's options must be a dict of option names, got {own!r}")
    clash = sorted(set(own) & set(_PAIR_FIELDS_IN_OPTIONS))
    if clash:
        raise InputError(f"the pair's options name its data {clash}: pass them as the Pair's fields")
    twice = [k for k in _PER_MATCH if k in own and getattr(pair, k) is not None]
    if twice:
        raise InputError(f"the pair gives {twice} both as its fields and in its options: give them once")
    opts = {**options, **own}
    seed = opts.pop("seed", 0)
    whole = isinstance(seed, (int, np.integer)) or (isinstance(seed, (float, np.floating)) and np.isfinite(seed) and seed == round(seed))
    if isinstance(seed, (bool, np.bool_)) or not whole or not 0 <= int(seed) < SEED_LIMIT:
        raise InputError(f"a pair's seed must be a whole number in [0, 2**64) (the base of its pair_seed), got {seed!r}")
    return opts, int(seed)


def _run_one(index: int, pair: Pair, options: dict[str, Any]) -> PairResult:
    try:
        opts, base = _pair_options(pair, options)
    except InputError as exc:
        return PairResult(index, pair.key, 0, None, str(exc))
    seed = pair_seed(base, pair.key)
    try:
        sc = pair.scores if pair.scores is not None else opts.pop("scores", None)
        ns = pair.noise_scales if pair.noise_scales is not None else opts.pop("noise_scales", None)
        r = estimate_relative_pose(pair.x1, pair.x2, pair.K1, pair.K2, camera1=pair.camera1, camera2=pair.camera2, scores=sc, noise_scales=ns, seed=seed, **opts)
    except ValueError as exc:  # invalid input of this pair (InputError is a ValueError)
        return PairResult(index, pair.key, seed, None, str(exc))
    return PairResult(index, pair.key, seed, r)


# a process-pool worker's flag, set when the batch sets the pool's shared stop event (_worker_init)
_WORKER_FLAG: CancelFlag | None = None


def _worker_init(stop: Any) -> None:
    """A process-pool worker's start: a local :class:`CancelFlag` that a daemon thread sets once the
    batch sets ``stop`` (a ``multiprocessing`` Event), so that a stopped batch's searches in flight end
    within 64 draws, as on threads (a concurrency trial: breaking out of a process batch waited 18.6 s
    for three 50k-match pairs, 0.01 s on threads)."""
    import threading

    global _WORKER_FLAG
    flag = CancelFlag()
    _WORKER_FLAG = flag

    def watch() -> None:
        stop.wait()
        flag.set()

    threading.Thread(target=watch, name="poseonly-stop", daemon=True).start()


def _run_chunk(chunk: list[tuple[int, Pair]], options: dict[str, Any], flag: CancelFlag | None = None) -> list[PairResult]:
    """Worker task: the pairs of one chunk, in order; with ``flag`` (a worker thread) or in a process
    pool's worker (its flag from :func:`_worker_init`), its searches end with
    :class:`~poseonly.robust.cancel.SearchCancelled` once the batch sets it."""
    if flag is None:
        flag = _WORKER_FLAG
    if flag is None:
        return [_run_one(i, p, options) for i, p in chunk]
    out = []
    with cancellable(flag):
        for i, p in chunk:
            if flag.is_set():  # the batch stopped: the rest of the chunk is not run (other methods do not read the flag)
                raise SearchCancelled("the batch was stopped")
            out.append(_run_one(i, p, options))
    return out


def _chunks(pairs: Iterable[Any], size: int) -> Iterator[list[tuple[int, Pair]]]:
    """The pairs in chunks of ``size``; :class:`InputError` at a pair whose key (its canonical form, the
    one its seed is derived from) an earlier pair has: two results under one key, one of them lost to a
    caller collecting by key (a user's trial)."""
    buf: list[tuple[int, Pair]] = []
    seen: dict[Hashable, int] = {}
    source = enumerate(pairs)
    while True:
        try:
            i, p = next(source)
        except StopIteration:
            break
        except Exception:
            # the caller's iterable failed (a file that could not be read): the pairs it gave before are
            # run and yielded first, as for a malformed pair (a batch trial: threads and processes lost
            # the pairs in flight, Dask all of them)
            if buf:
                yield buf
            raise
        try:
            pair = _as_pair(p, i)
            first = seen.setdefault(canonical_key(pair.key), i)
            if first != i:
                raise InputError(f"pair {i}: its key {pair.key!r} is pair {first}'s too (an unkeyed pair's key is its position): keys must be unique")
        except InputError:
            # the pairs before a malformed one are run, whatever the chunking and scheduling (a reliability
            # trial: with two workers the results of pairs already done were dropped, depending on timing)
            if buf:
                yield buf
            raise
        buf.append((i, pair))
        if len(buf) >= size:
            yield buf
            buf = []
    if buf:
        yield buf


def _check_options(options: dict[str, Any]) -> None:
    """Fail fast on invalid options: run them once on a fixed, well-posed problem of
    :data:`_CHECK_POINTS` points (enough for the methods' sample sizes)."""
    data = sorted(set(options) & {*_PAIR_FIELDS_IN_OPTIONS, *_PER_MATCH})
    if data:
        raise InputError(f"{data} are a pair's data, not batch options: pass them as each Pair's fields")
    seed = options.get("seed", 0)
    if not isinstance(seed, (int, np.integer)) or isinstance(seed, bool) or not 0 <= int(seed) < SEED_LIMIT:
        # the single-pair API's range (a reliability trial: -1 and 2**64 ran here and were refused there)
        raise InputError(f"seed must be an int in [0, 2**64) for a batch (each pair's seed is derived from it), got {options['seed']!r}")
    rng = np.random.default_rng(0)
    X = rng.uniform(-1, 1, (_CHECK_POINTS, 3)) + [0, 0, 5]
    f1 = X / np.linalg.norm(X, axis=1)[:, None]
    X2 = X + [0.3, 0.0, 0.0]
    f2 = X2 / np.linalg.norm(X2, axis=1)[:, None]
    estimate_relative_pose(f1, f2, **{"focal_px": 800.0, **options, "seed": 0})


def _progress(total: int | None, enabled: bool | None):
    """A tqdm bar on stderr (``enabled`` None: only where stderr is a terminal, so that logs stay clean),
    or None (``False``, or tqdm not installed)."""
    if enabled is None:
        enabled = sys.stderr is not None and sys.stderr.isatty()
    if enabled:
        try:
            from tqdm.auto import tqdm
        except ImportError:  # optional dependency
            enabled = False
        else:
            return tqdm(total=total, unit="pair", desc="poseonly pairs")
    return None


def estimate_relative_poses(
    pairs: Iterable[Any],
    *,
    n_jobs: int = 1,
    backend: Backend = "auto",
    client: Any = None,
    chunk_size: int | None = None,
    progress: bool | None = None,
    retries: int = DASK_RETRIES,
    **options: Any,
) -> Iterator[PairResult]:
    """Estimate the relative pose of every pair; yields :class:`PairResult` as chunks finish (not in
    input order: sort by ``index`` or use ``key``).

    ``pairs``: an iterable of :class:`Pair` or dicts with its fields (``x1, x2`` ``(n, 2)`` or
    ``(n, 3)``, ``camera1/camera2`` or ``K1/K2``, ``key``, ``options``, ``scores``, ``noise_scales``). ``n_jobs``: local workers
    (1 = in this process, -1 = all cores), ``backend`` ``"auto"`` (threads for a sized batch below
    :data:`AUTO_THREADS_MAX_PAIRS` pairs, else processes), ``"processes"`` or ``"threads"`` for
    ``n_jobs > 1`` (the same results either way; not used with ``n_jobs = 1`` or a ``client``); ``client``: a ``dask.distributed.Client`` or a scheduler
    address (then ``n_jobs`` is ignored). ``options``: those of
    :func:`poseonly.estimate_relative_pose` (``method``, ``threshold_px``, ...); ``seed`` is the base
    seed of :func:`pair_seed`. ``progress``: a tqdm bar on stderr (if tqdm is installed; the default ``None``: only where stderr is a
    terminal, ``True`` always, ``False`` never)."""
    if not isinstance(n_jobs, (int, np.integer)) or isinstance(n_jobs, bool) or n_jobs == 0 or n_jobs < -1:
        raise InputError(f"n_jobs must be a positive int or -1 (all cores), got {n_jobs!r}")
    if chunk_size is not None and (not isinstance(chunk_size, (int, np.integer)) or isinstance(chunk_size, bool) or chunk_size < 1):
        raise InputError(f"chunk_size must be a positive int, got {chunk_size!r}")
    if not isinstance(retries, (int, np.integer)) or isinstance(retries, bool) or retries < 0:
        raise InputError(f"retries must be an int >= 0, got {retries!r}")
    if not isinstance(pairs, Iterable) or isinstance(pairs, (str, bytes, Mapping)):
        raise InputError(f"pairs must be an iterable of Pair or dicts, got {type(pairs).__name__}")
    if client is not None and not isinstance(client, str) and not hasattr(client, "submit"):
        raise InputError(f"client must be a dask.distributed.Client or a scheduler address, got {client!r}")
    if backend not in BACKENDS:
        raise InputError(f"backend must be one of {BACKENDS}, got {backend!r}")
    if progress is not None and not isinstance(progress, (bool, np.bool_)):
        raise InputError(f"progress must be True, False or None (a bar where stderr is a terminal), got {progress!r}")
    total = len(pairs) if hasattr(pairs, "__len__") else None  # type: ignore[arg-type]
    if backend == "auto":  # the same results either way: only the time differs
        backend = "threads" if total is not None and total < AUTO_THREADS_MAX_PAIRS else "processes"
    if client is None and n_jobs != 1 and backend == "processes" and _importing_main():
        # a worker process of a pool is importing the caller's script, which runs this call again
        raise RuntimeError(UNGUARDED_MAIN)
    _check_options(options)
    return _generate(pairs, int(n_jobs), backend, client, chunk_size, progress, int(retries), options, total)


def _generate(pairs, n_jobs, backend, client, chunk_size, progress, retries, options, total) -> Iterator[PairResult]:
    bar = _progress(total, progress)
    runner: Generator[list[PairResult], None, None] | None = None
    try:
        if client is not None:
            runner = _dask(pairs, client, chunk_size, total, retries, options)
        elif n_jobs == 1:
            runner = (_run_chunk(c, options) for c in _chunks(pairs, chunk_size or 1))
        else:
            n = (os.cpu_count() or 1) if n_jobs == -1 else n_jobs
            runner = _pool(pairs, n, chunk_size or _auto_chunk(POOL_CHUNK, total, n), options, backend)
        for results in runner:
            yield from results
            if bar is not None:
                bar.update(len(results))
    finally:
        # close the runner here, not when it is collected: a pool's runner sets its threads' cancel flag
        # and shuts its workers down in its own finally
        if runner is not None:
            runner.close()
        if bar is not None:
            bar.close()


def _auto_chunk(default: int, total: int | None, workers: int) -> int:
    """``default``, or fewer pairs per chunk when the batch is known to be too small to give every
    worker :data:`MIN_CHUNKS_PER_WORKER` chunks (load balance)."""
    if total is None:
        return default
    return max(1, min(default, -(-total // (MIN_CHUNKS_PER_WORKER * workers))))


# why a process pool's workers die at start-up when the call sits at a script's top level
UNGUARDED_MAIN = (
    "worker processes import the calling script's main module (multiprocessing's forkserver and spawn start"
    " methods), and this script calls estimate_relative_poses when imported, so every worker would run it"
    ' again: put the call under `if __name__ == "__main__":`, or pass backend="threads" (the core'
    " releases the GIL)"
)


def _importing_main() -> bool:
    """Is this process a spawned or forkserver worker still importing the parent's main module (whose
    top-level code is running this call)? multiprocessing runs that import in ``spawn.prepare``."""
    f: FrameType | None = sys._getframe(1)
    while f is not None:
        if f.f_code.co_filename.endswith(("multiprocessing/spawn.py", "multiprocessing\\spawn.py")) and f.f_code.co_name in ("_fixup_main_from_path", "_fixup_main_from_name"):
            return True
        f = f.f_back
    return False


class _Feed:
    """The chunks of a parallel batch: ``next()`` gives the next chunk or None at the end, at a malformed
    pair or where the caller's iterable raised; ``raise_error()`` raises that error once the chunks
    before it are done (so the pairs run and yielded do not depend on the scheduling)."""

    def __init__(self, chunks: Iterator[list[tuple[int, Pair]]]) -> None:
        self._chunks = chunks
        self._error: Exception | None = None

    def next(self) -> list[tuple[int, Pair]] | None:
        if self._error is not None:
            return None
        try:
            return next(self._chunks, None)
        except Exception as exc:  # a malformed pair's InputError, or the caller's iterable failing
            self._error = exc
            return None

    def raise_error(self) -> None:
        if self._error is not None:
            raise self._error


def _process_context() -> Any:
    """The process pool's start method. Workers never fork the caller (no inherited threads or locks):
    a fork server started from a clean interpreter that has imported poseonly once forks them where
    available (POSIX), else spawn (forkserver's workers are the fork server's children, so their CPU time
    is not this process's RUSAGE_CHILDREN until it exits; a batch trial). ``poseonly.batch`` is added
    to the fork server's preload list, not put in its place (the list is process-wide: an application's
    own was lost; a concurrency trial); a process forked from one whose fork server it inherited cannot
    use that server (``ChildProcessError``, a DataLoader-style worker in a trial) and gets spawn."""
    import multiprocessing as mp

    if "forkserver" not in mp.get_all_start_methods():  # pragma: no cover - Windows
        return mp.get_context("spawn")
    from multiprocessing import forkserver

    fs = mp.get_context("forkserver")
    preload = getattr(getattr(forkserver, "_forkserver", None), "_preload_modules", None)
    current = list(preload) if isinstance(preload, list) else []
    if "poseonly.batch" not in current:
        fs.set_forkserver_preload([*current, "poseonly.batch"])
    try:
        forkserver.ensure_running()
    except (ChildProcessError, OSError):
        return mp.get_context("spawn")
    return fs


def _pool(pairs, n_jobs: int, chunk_size: int, options, backend: str = "processes") -> Generator[list[PairResult], None, None]:
    from concurrent.futures import FIRST_COMPLETED, Executor, ProcessPoolExecutor, ThreadPoolExecutor, wait
    from concurrent.futures.process import BrokenProcessPool

    ex: Executor
    # set when the batch stops (Ctrl-C, an error, the caller stopped iterating), so that the searches
    # running then end within 64 draws instead of running to their end: the threads' CancelFlag, or
    # the processes' shared event that each worker's watcher turns into its own flag (_worker_init)
    flag: CancelFlag | None = None
    stop: Any = None
    if backend == "threads":
        ex = ThreadPoolExecutor(max_workers=n_jobs, thread_name_prefix="poseonly")
        flag = CancelFlag()
    else:
        ctx = _process_context()
        stop = ctx.Event()
        ex = ProcessPoolExecutor(max_workers=n_jobs, mp_context=ctx, initializer=_worker_init, initargs=(stop,))
    chunks = _Feed(_chunks(pairs, chunk_size))
    limit = IN_FLIGHT_PER_WORKER * n_jobs
    try:
        pending: set[Any] = set()
        while len(pending) < limit and (c := chunks.next()) is not None:
            pending.add(ex.submit(_run_chunk, c, options, flag))
        started = False  # a chunk finished: the workers got past their start-up
        while pending:
            done, pending = wait(pending, return_when=FIRST_COMPLETED)
            for fut in done:
                try:
                    res = fut.result()
                except BrokenProcessPool as exc:
                    main = sys.modules.get("__main__")
                    if not started and getattr(main, "__file__", None) is not None:  # a script, whose import may have killed them
                        raise RuntimeError(f"the worker processes died before any pair was done ({exc}); if at start-up: {UNGUARDED_MAIN}") from exc
                    raise
                started = True
                yield res
                nxt = chunks.next()
                if nxt is not None:
                    pending.add(ex.submit(_run_chunk, nxt, options, flag))
        chunks.raise_error()
    finally:  # also when the caller stops iterating early: queued chunks are dropped, not run
        if flag is not None:
            flag.set()
        if stop is not None:
            stop.set()
        ex.shutdown(wait=True, cancel_futures=True)


def _dask(pairs, client, chunk_size: int | None, total: int | None, retries: int, options) -> Generator[list[PairResult], None, None]:
    try:
        from dask.distributed import Client, as_completed
    except ImportError as exc:  # name the extra (a packaging trial: a bare "No module named 'dask'")
        raise ImportError(f"dask.distributed is required for client=...; install it with pip install poseonly[dask] ({exc})") from exc

    own = isinstance(client, str)
    cl = Client(client) if own else client
    try:
        nworkers = max(1, sum(int(w.get("nthreads", 1)) for w in cl.scheduler_info()["workers"].values()))
        chunks = _Feed(_chunks(pairs, chunk_size or _auto_chunk(DASK_CHUNK, total, nworkers)))
        futs: list[Any] = []
        while len(futs) < IN_FLIGHT_PER_WORKER * nworkers and (c := chunks.next()) is not None:
            futs.append(cl.submit(_run_chunk, c, options, pure=False, retries=retries))
        ac = as_completed(futs)
        for fut in ac:
            res = fut.result()
            fut.release()
            nxt = chunks.next()
            if nxt is not None:
                ac.add(cl.submit(_run_chunk, nxt, options, pure=False, retries=retries))
            yield res
        chunks.raise_error()
    finally:
        if own:
            cl.close()
