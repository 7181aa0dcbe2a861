"""Batch API (issue 13 item 2): per-pair results identical serially, on a process pool, on a thread
pool and on a Dask LocalCluster; seeds from keys; bad pairs reported, bad options rejected."""

import numpy as np
import pytest

import poseonly
from poseonly.batch import Pair, canonical_key, pair_seed
from poseonly.cameras import Camera
from poseonly.sim import make_scene

CAM = Camera("OPENCV", 640, 480, (800.0, 800.0, 320.0, 240.0, -0.1, 0.01, 0.0, 0.0))


def _pairs(m=6):
    out = []
    for s in range(m):
        sc = make_scene(80, camera="pinhole", noise_px=0.5, outlier_fraction=0.2, seed=s)
        out.append(Pair(CAM.project(sc.f1), CAM.project(sc.f2), key=f"img{s}-img{s + 1}", camera1=CAM))
    return out


def _summary(results):
    d = {}
    for r in results:
        assert r.error is None, r.error
        d[r.key] = (r.index, r.seed, r.result.R.copy(), r.result.inliers.copy(), r.result.status)
    return d


def _same(a, b):
    assert a.keys() == b.keys()
    for k in a:
        assert a[k][:2] == b[k][:2]
        assert np.array_equal(a[k][2], b[k][2]) and np.array_equal(a[k][3], b[k][3]) and a[k][4] == b[k][4]


def test_serial_pool_dask_identical():
    pairs = _pairs()
    serial = _summary(poseonly.estimate_relative_poses(pairs, progress=False, seed=7))
    assert len(serial) == 6
    pooled = _summary(poseonly.estimate_relative_poses(pairs, n_jobs=2, backend="processes", chunk_size=2, progress=False, seed=7))
    _same(serial, pooled)
    auto = _summary(poseonly.estimate_relative_poses(pairs, n_jobs=2, chunk_size=2, progress=False, seed=7))  # threads: a small batch
    _same(serial, auto)
    threaded = _summary(poseonly.estimate_relative_poses(pairs, n_jobs=2, backend="threads", chunk_size=1, progress=False, seed=7))
    _same(serial, threaded)
    distributed = pytest.importorskip("dask.distributed")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as lc, distributed.Client(lc) as client:
        on_dask = _summary(poseonly.estimate_relative_poses(iter(pairs), client=client, chunk_size=2, progress=False, seed=7))
    _same(serial, on_dask)


def test_seed_from_key_not_position():
    pairs = _pairs(3)
    fwd = _summary(poseonly.estimate_relative_poses(pairs, progress=False))
    rev = _summary(poseonly.estimate_relative_poses(pairs[::-1], progress=False))
    for k in fwd:
        assert fwd[k][1] == rev[k][1] == pair_seed(0, k)
        assert np.array_equal(fwd[k][2], rev[k][2])
    assert pair_seed(0, "a") != pair_seed(1, "a") and pair_seed(0, "a") != pair_seed(0, "b")
    # the same as a single call with the derived seed
    p = pairs[0]
    r = poseonly.estimate_relative_pose(p.x1, p.x2, camera1=CAM, seed=pair_seed(0, p.key))
    assert np.array_equal(r.R, fwd[p.key][2])


def test_bad_pair_reported_bad_options_raise():
    pairs = [{"x1": np.zeros((3, 2)), "x2": np.zeros((3, 2)), "K1": np.eye(3)}, *_pairs(1)]
    res = sorted(poseonly.estimate_relative_poses(pairs, progress=False), key=lambda r: r.index)
    assert res[0].result is None and "at least 6" in res[0].error and res[0].key == 0
    assert res[1].result is not None
    with pytest.raises(ValueError, match="unknown option"):
        poseonly.estimate_relative_poses(pairs, bogus=1)
    with pytest.raises(ValueError, match="n_jobs"):
        poseonly.estimate_relative_poses(pairs, n_jobs=0)
    with pytest.raises(ValueError, match="backend"):
        poseonly.estimate_relative_poses(pairs, n_jobs=2, backend="fibers")
    with pytest.raises(ValueError, match="unknown keys"):
        list(poseonly.estimate_relative_poses([{"x1": 1, "x2": 2, "foo": 3}], progress=False))


def test_dask_lost_worker():
    """A worker is SIGKILLed mid-run: its chunk is recomputed elsewhere, nothing lost."""
    import os
    import signal

    distributed = pytest.importorskip("dask.distributed")
    pairs = _pairs(24)
    serial = _summary(poseonly.estimate_relative_poses(pairs, progress=False))
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as lc, distributed.Client(lc) as client:
        out = []
        killed = None
        for r in poseonly.estimate_relative_poses(pairs, client=client, chunk_size=1, progress=False):
            out.append(r)
            if killed is None:
                # the first moment a worker holds a task (between two results both may be idle)
                busy = [w for w, ts in client.processing().items() if ts]
                if busy:
                    pid = client.run(os.getpid, workers=busy[:1])[busy[0]]
                    os.kill(pid, signal.SIGKILL)  # a worker process of this test's own cluster
                    killed = busy[0]
        assert killed is not None, "no worker was busy while results arrived"
        assert killed not in client.scheduler_info()["workers"]  # the worker was really lost
    _same(serial, _summary(out))


def test_other_methods_accepted():
    pairs = _pairs(1)
    for method in ("gnc-ransac", "lirp"):
        (r,) = poseonly.estimate_relative_poses(pairs, method=method, progress=False)
        assert r.error is None and r.result.method == method


@pytest.mark.parametrize("backend", ["processes", "threads"])
def test_early_stop_pool(backend):
    gen = poseonly.estimate_relative_poses(_pairs(6), n_jobs=2, backend=backend, chunk_size=1, progress=False)
    first = next(gen)
    gen.close()  # the pool shuts down without running the queued chunks
    assert first.error is None


def test_blas_limit_shared_by_concurrent_estimates(monkeypatch):
    """The one-thread BLAS limit is process-wide: overlapping estimates (a caller's threads, the batch's
    thread backend) set it once and the last to leave restores the original limits; a per-call limit
    would be restored by the first estimate to finish while the other still runs."""
    import threading

    from poseonly import api

    calls = []

    class Limiter:
        def restore_original_limits(self):
            calls.append("restore")

    class Lib:
        num_threads = 1  # what the limit set, unchanged by the caller

    class Controller:
        lib_controllers = [Lib()]

        def limit(self, limits, user_api):
            assert (limits, user_api) == (1, "blas")
            calls.append("limit")
            return Limiter()

        def select(self, user_api):
            assert user_api == "blas"
            return self

    monkeypatch.setitem(api._BLAS_STATE, "controller", Controller())
    inside, leave_first = threading.Event(), threading.Event()

    def first():
        with api._blas_single_thread():
            inside.set()
            leave_first.wait(5)

    t = threading.Thread(target=first)
    t.start()
    assert inside.wait(5)
    with api._blas_single_thread():
        leave_first.set()
        t.join(5)
        assert calls == ["limit"] and api._BLAS_STATE["users"] == 1  # the first has left: still limited
    assert calls == ["limit", "restore"] and api._BLAS_STATE["users"] == 0 and api._BLAS_STATE["limiter"] is None
    # and an exception inside an estimate releases it too
    with pytest.raises(RuntimeError), api._blas_single_thread():
        raise RuntimeError
    assert calls == ["limit", "restore", "limit", "restore"] and api._BLAS_STATE["users"] == 0


def test_a_blas_limit_the_application_sets_during_an_estimate_is_kept():
    """The estimate restores the limits of before only if BLAS is still at its one thread: an application
    that set its own meanwhile (threadpool_limits from another thread) keeps it (a SLAM user's trial:
    it was overwritten when the estimate ended)."""
    threadpoolctl = pytest.importorskip("threadpoolctl")
    from poseonly import api

    blas = threadpoolctl.ThreadpoolController().select(user_api="blas").lib_controllers
    if not blas:
        pytest.skip("no BLAS that threadpoolctl controls")
    before = [lib.num_threads for lib in blas]
    try:
        with api._blas_single_thread():
            assert all(lib.num_threads == 1 for lib in blas)
            threadpoolctl.threadpool_limits(limits=3, user_api="blas")  # the application's own setting
        assert all(lib.num_threads == 3 for lib in blas)
        with api._blas_single_thread():
            pass
        assert all(lib.num_threads == 3 for lib in blas)  # untouched: restored to what it was before
    finally:
        for lib, n in zip(blas, before):
            lib.set_num_threads(n)


def test_pair_scores_and_noise_scales_reach_the_estimator():
    from poseonly import estimate_relative_pose

    sc = make_scene(120, "normal", "pinhole", 0.5, 0.3, 7)
    c = np.linspace(1.0, 6.0, sc.n)
    q = np.linspace(0.0, 1.0, sc.n)
    [pr] = list(poseonly.estimate_relative_poses([Pair(sc.u1, sc.u2, key="p", K1=sc.K, K2=sc.K, scores=q, noise_scales=c)]))
    ref = estimate_relative_pose(sc.u1, sc.u2, sc.K, sc.K, seed=pr.seed, scores=q, noise_scales=c)
    np.testing.assert_array_equal(pr.result.R, ref.R)
    [bad] = list(poseonly.estimate_relative_poses([{"x1": sc.u1, "x2": sc.u2, "K1": sc.K, "noise_scales": -c}]))
    assert bad.result is None and "noise_scales" in bad.error


SCRIPT = """
import poseonly
from poseonly import sim
print("top", flush=True)
pairs = []
for s in range(4):
    sc = sim.make_scene(60, camera="pinhole", noise_px=0.5, seed=s)
    pairs.append({"x1": sc.u1, "x2": sc.u2, "K1": sc.K, "K2": sc.K})
res = list(poseonly.estimate_relative_poses(pairs, n_jobs=2, backend="processes", progress=False))
print("done", len(res), flush=True)
"""


def test_unguarded_script_gets_the_reason(tmp_path):
    """A script that calls the process pool at its top level (no ``if __name__ == "__main__":``): the
    workers import it and would run it again. The workers refuse at once and the caller's error says
    why and what to do (before: BrokenProcessPool and every worker's traceback); guarded, it runs."""
    import subprocess
    import sys
    from pathlib import Path

    env = {**__import__("os").environ, "PYTHONPATH": str(Path(poseonly.__file__).resolve().parents[1])}  # the same poseonly (editable or wheel)
    script = tmp_path / "script.py"
    script.write_text(SCRIPT)
    r = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, timeout=300, env=env, cwd=tmp_path)
    assert r.returncode == 1 and "done" not in r.stdout
    assert 'if __name__ == "__main__":' in r.stderr.splitlines()[-1] and "RuntimeError" in r.stderr.splitlines()[-1]
    # the default backend ("auto") runs a small sized batch on threads: no worker imports the script
    script.write_text(SCRIPT.replace(', backend="processes"', ""))
    r = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, timeout=300, env=env, cwd=tmp_path)
    assert r.returncode == 0 and "done 4" in r.stdout, r.stderr
    lines = SCRIPT.strip().splitlines()
    guarded = "\n".join(lines[:-2] + ['if __name__ == "__main__":'] + ["    " + x for x in lines[-2:]])
    script.write_text(guarded)
    r = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, timeout=300, env=env, cwd=tmp_path)
    assert r.returncode == 0 and "done 4" in r.stdout, r.stderr
    # a guarded script's own worker (its function, in its module __mp_main__) may call the batch
    script.write_text(OWN_POOL)
    r = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, timeout=300, env=env, cwd=tmp_path)
    assert r.returncode == 0 and "['ok', 'ok']" in r.stdout, r.stderr


OWN_POOL = """
import multiprocessing as mp
import poseonly
from poseonly import sim

def work(seed):
    sc = sim.make_scene(60, camera="pinhole", noise_px=0.5, seed=seed)
    pairs = [{"x1": sc.u1, "x2": sc.u2, "K1": sc.K, "K2": sc.K}]
    return [r.result.status for r in poseonly.estimate_relative_poses(pairs, progress=False)][0]

if __name__ == "__main__":
    with mp.get_context("spawn").Pool(1) as p:
        print(p.map(work, [0, 1]))
"""


def test_progress_bar_only_on_a_terminal(capsys):
    """The default progress bar is drawn only where stderr is a terminal (pytest's capture is not):
    a pipeline's logs stay clean; progress=True forces it."""
    pytest.importorskip("tqdm")
    pairs = [{"x1": s.u1, "x2": s.u2, "K1": s.K, "K2": s.K} for s in (make_scene(40, camera="pinhole", noise_px=0.5, seed=k) for k in range(2))]
    assert len(list(poseonly.estimate_relative_poses(pairs))) == 2
    assert capsys.readouterr().err == ""
    assert len(list(poseonly.estimate_relative_poses(pairs, progress=True))) == 2
    assert "poseonly pairs" in capsys.readouterr().err
    with pytest.raises(poseonly.InputError, match="progress"):
        poseonly.estimate_relative_poses(pairs, progress="yes")


def test_equal_keys_get_one_seed_whatever_their_types():
    # a user's trial: numpy ids built the keys, and (np.int64(0), np.int64(7)) got another seed than (0, 7)
    base = pair_seed(0, (0, 7))
    for k in [(np.int64(0), np.int64(7)), (np.int32(0), np.int32(7)), (0.0, 7.0), (np.float32(0), np.uint8(7)), (False, 7)]:
        assert k == (0, 7) and pair_seed(0, k) == base
    assert pair_seed(0, np.str_("a")) == pair_seed(0, "a")
    assert pair_seed(0, (0.5, 1)) != pair_seed(0, (0, 1))
    # a frozenset's repr follows the process's hash seed; its canonical form does not
    assert pair_seed(0, frozenset({"b", "a", "c"})) == pair_seed(0, frozenset({"c", "a", "b"}))
    assert canonical_key(frozenset({1})) != canonical_key(("frozenset", ("1",)))  # a set is never a tuple
    assert pair_seed(0, "a") == 0x7FFFFFFFFFFFFFFF & pair_seed(0, "a")  # the 63-bit range kept


def test_unhashable_and_duplicate_keys_are_refused():
    p = _pairs(2)
    for key in ([0, 1], {"a": 1}, np.array([0, 1]), (0, [1])):
        with pytest.raises(ValueError, match="must be hashable"):
            list(poseonly.estimate_relative_poses([Pair(p[0].x1, p[0].x2, key=key, camera1=CAM)], progress=False))
    dup = [Pair(p[0].x1, p[0].x2, key="A", camera1=CAM), Pair(p[1].x1, p[1].x2, key="A", camera1=CAM)]
    with pytest.raises(ValueError, match="pair 1: its key 'A' is pair 0's too"):
        list(poseonly.estimate_relative_poses(dup, progress=False))
    # equal keys of other types are the same key; an unkeyed pair's key is its position
    with pytest.raises(ValueError, match="keys must be unique"):
        list(poseonly.estimate_relative_poses([Pair(p[0].x1, p[0].x2, key=(0, 1), camera1=CAM), Pair(p[1].x1, p[1].x2, key=(np.int64(0), 1), camera1=CAM)], progress=False))
    with pytest.raises(ValueError, match="keys must be unique"):
        list(poseonly.estimate_relative_poses([Pair(p[0].x1, p[0].x2, camera1=CAM), Pair(p[1].x1, p[1].x2, key=0, camera1=CAM)], progress=False))


@pytest.mark.parametrize("seed", [-1, np.int64(-5), 2**64])
def test_batch_seeds_have_the_single_pair_range(seed):
    """A base seed outside [0, 2**64) is refused as the single-pair API refuses it (a reliability trial:
    the batch ran -1 and 2**64), and so is a pair's own."""
    pairs = _pairs(1)
    with pytest.raises(ValueError, match=r"\[0, 2\*\*64\)"):
        list(poseonly.estimate_relative_poses(pairs, progress=False, seed=seed))
    p = Pair(pairs[0].x1, pairs[0].x2, camera1=CAM, key="k", options={"seed": seed})
    (r,) = poseonly.estimate_relative_poses([p], progress=False)
    assert r.result is None and "[0, 2**64)" in str(r.error)


@pytest.mark.parametrize("kw", [{"n_jobs": 1, "chunk_size": 4}, {"n_jobs": 2, "backend": "threads", "chunk_size": 1}, {"n_jobs": 2, "backend": "threads", "chunk_size": 3}])
def test_a_malformed_item_ends_the_batch_after_every_pair_before_it(kw):
    """A malformed item (a dict with an unknown key) raises InputError after the results of every pair
    before it, whatever the chunking and scheduling (a reliability trial: with two workers only the
    first three of six came out, depending on timing; serially a partly filled chunk was lost)."""
    good = _pairs(6)
    items = [*good, {"x1": good[0].x1, "x2": good[0].x2, "K": np.eye(3), "key": "bad"}, *_pairs(2)]
    got = []
    with pytest.raises(ValueError, match=r"pair 6: unknown keys \['K'\]"):
        for pr in poseonly.estimate_relative_poses(items, progress=False, **kw):
            got.append(pr.key)
    assert sorted(got) == sorted(p.key for p in good)


@pytest.mark.parametrize("kw", [{"n_jobs": 1, "chunk_size": 4}, {"n_jobs": 2, "backend": "threads", "chunk_size": 3}, {"n_jobs": 2, "backend": "processes", "chunk_size": 3}])
def test_a_failing_iterable_ends_the_batch_after_every_pair_it_gave(kw):
    """The caller's iterable raising (a matches file that cannot be read) ends the batch with its error
    after the results of every pair it gave (a batch trial: threads and processes lost the pairs in
    flight, Dask all of them; only a malformed pair's InputError was handled so)."""
    good = _pairs(7)

    def source():
        yield from good
        raise OSError("cannot read pair 7")

    got = []
    with pytest.raises(OSError, match="cannot read pair 7"):
        for pr in poseonly.estimate_relative_poses(source(), progress=False, **kw):
            got.append(pr.key)
    assert sorted(got) == sorted(p.key for p in good)


def test_per_match_arrays_are_not_batch_options():
    """Batch-level scores overrode every pair's own silently (a batch trial); Pair compares by value."""
    import copy

    p = _pairs(1)[0]
    with pytest.raises(ValueError, match=r"\['scores'\] are a pair's data"):
        poseonly.estimate_relative_poses([p], scores=np.ones(len(p.x1)))
    q = Pair(p.x1, p.x2, camera1=CAM, key="q", options={"noise_scales": np.ones(len(p.x1))}, noise_scales=np.ones(len(p.x1)))
    (r,) = poseonly.estimate_relative_poses([q], progress=False)
    assert r.result is None and "both as its fields and in its options" in str(r.error)
    assert p == copy.deepcopy(p) and p != q


def test_pair_results_as_json_lines():
    """PairResult.to_dict: one JSON line per pair (a batch trial asked for it), errors included."""
    import json

    pairs = [*_pairs(2), Pair(np.zeros((3, 2)), np.zeros((3, 2)), camera1=CAM, key=("img", np.int64(9)))]
    out = sorted(poseonly.estimate_relative_poses(pairs, progress=False), key=lambda r: r.index)
    lines = [json.dumps(r.to_dict(), allow_nan=False) for r in out]
    back = [json.loads(x) for x in lines]
    assert back[0]["key"] == "img0-img1" and back[0]["result"]["R"] == out[0].result.R.tolist() and back[0]["error"] is None
    assert back[2]["key"] == ["img", 9] and back[2]["result"] is None and "at least 6" in back[2]["error"]


def test_a_process_workers_flag_follows_the_batchs_stop_event(monkeypatch):
    """A stopped process batch ends its workers' searches in flight (a concurrency trial: breaking out of
    one waited 18.6 s for three 50k-match pairs, 0.01 s on threads): each worker's watcher turns the
    pool's shared event into its own CancelFlag, which _run_chunk uses (here in this process)."""
    import multiprocessing as mp
    import time

    from poseonly import batch
    from poseonly.robust.cancel import SearchCancelled

    monkeypatch.setattr(batch, "_WORKER_FLAG", None)
    stop = mp.get_context("spawn").Event()
    batch._worker_init(stop)
    flag = batch._WORKER_FLAG
    assert flag is not None and not flag.is_set()
    sc = make_scene(60, seed=1)
    chunk = [(0, Pair(sc.u1, sc.u2, K1=sc.K, key=0))]
    assert batch._run_chunk(chunk, {})[0].result.status == "ok"
    stop.set()
    for _ in range(1000):  # the watcher thread sets it
        if flag.is_set():
            break
        time.sleep(0.01)
    assert flag.is_set()
    with pytest.raises(SearchCancelled):
        batch._run_chunk(chunk, {})


def test_the_fork_servers_preload_list_is_added_to():
    """The fork server's preload list is process-wide: a process batch replaced an application's own."""
    import multiprocessing as mp

    if "forkserver" not in mp.get_all_start_methods():
        pytest.skip("no fork server on this platform")
    from multiprocessing import forkserver

    from poseonly import batch

    fs = mp.get_context("forkserver")
    before = getattr(getattr(forkserver, "_forkserver", None), "_preload_modules", None)
    try:
        fs.set_forkserver_preload(["json"])
        assert batch._process_context() is not None
        after = forkserver._forkserver._preload_modules  # type: ignore[attr-defined]
        assert after[:1] == ["json"] and "poseonly.batch" in after
    finally:
        fs.set_forkserver_preload(list(before) if isinstance(before, list) else [])


def _child_batch(q):
    s = make_scene(120, camera="pinhole", noise_px=0.5, outlier_fraction=0.3, seed=0)
    try:
        out = [p.result.status for p in poseonly.estimate_relative_poses([Pair(s.u1, s.u2, K1=s.K, key=i) for i in range(2)], n_jobs=2, backend="processes")]
        q.put(out)
    except Exception as exc:  # reported to the parent
        q.put(repr(exc))


def test_a_forked_child_of_a_batch_runs_a_process_batch():
    """A DataLoader-style worker forked after a process batch inherited the parent's fork server and
    failed with ChildProcessError; it now falls back to spawn."""
    import multiprocessing as mp

    if "fork" not in mp.get_all_start_methods() or "forkserver" not in mp.get_all_start_methods():
        pytest.skip("needs fork and a fork server")
    s = make_scene(120, camera="pinhole", noise_px=0.5, outlier_fraction=0.3, seed=0)
    list(poseonly.estimate_relative_poses([Pair(s.u1, s.u2, K1=s.K, key=i) for i in range(2)], n_jobs=2, backend="processes"))
    ctx = mp.get_context("fork")
    q = ctx.Queue()
    p = ctx.Process(target=_child_batch, args=(q,))
    p.start()
    got = q.get(timeout=120)
    p.join(60)
    assert got == ["ok", "ok"], got


def test_a_child_forked_during_an_estimate_gets_the_blas_limits_of_before():
    """A concurrency trial: a process forked while an estimate held BLAS at one thread kept one thread for
    good (its estimates then took one as the limit to restore)."""
    import os

    threadpoolctl = pytest.importorskip("threadpoolctl")
    if not hasattr(os, "fork"):
        pytest.skip("POSIX fork")
    from poseonly import api

    blas = threadpoolctl.ThreadpoolController().select(user_api="blas").lib_controllers
    if not blas or all(lib.num_threads == 1 for lib in blas):
        pytest.skip("no multi-threaded BLAS that threadpoolctl controls")
    before = [lib.num_threads for lib in blas]
    r, w = os.pipe()
    with api._blas_single_thread():
        pid = os.fork()
        if pid == 0:  # the child: report its BLAS threads, leave at once
            os.close(r)
            got = [lib.num_threads for lib in threadpoolctl.ThreadpoolController().select(user_api="blas").lib_controllers]
            os.write(w, repr(got).encode())
            os._exit(0)
    os.close(w)
    with os.fdopen(r) as fh:
        child = fh.read()
    os.waitpid(pid, 0)
    assert child == repr(before), (child, before)
