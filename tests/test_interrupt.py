"""Ctrl-C during the core's search: Python's signal handlers run inside the loop (every 64 draws), so a
KeyboardInterrupt ends a long estimate at once (a reliability trial waited 8 s on 30k random matches
and a minute on 200k for the search to return)."""

from __future__ import annotations

import signal
import subprocess
import sys
import time

import pytest

CODE = """
import sys, time, numpy as np, poseonly
rng = np.random.default_rng(0)
u1, u2 = rng.uniform(0, 1000, (60000, 2)), rng.uniform(0, 1000, (60000, 2))
K = np.array([[800.0, 0.0, 500.0], [0.0, 800.0, 500.0], [0.0, 0.0, 1.0]])
print("start", flush=True)
t0 = time.perf_counter()
try:
    poseonly.estimate_relative_pose(u1, u2, K, max_iterations=100000, min_iterations=100000)
    print("finished", time.perf_counter() - t0, flush=True)
except KeyboardInterrupt:
    print("interrupted", time.perf_counter() - t0, flush=True)
"""


@pytest.mark.skipif(sys.platform == "win32", reason="POSIX signals")
def test_ctrl_c_ends_the_search_at_once():
    p = subprocess.Popen([sys.executable, "-c", CODE], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        assert p.stdout is not None
        assert p.stdout.readline().strip() == "start"
        time.sleep(1.5)  # into the search (100000 draws on 60000 random matches: tens of seconds)
        sent = time.perf_counter()
        p.send_signal(signal.SIGINT)
        out, err = p.communicate(timeout=60)
        waited = time.perf_counter() - sent
    finally:
        p.kill()
    assert out.startswith("interrupted"), (out, err[-2000:])
    assert waited < 5.0, waited  # the handler ran inside the loop, not after it


THREAD_CODE = """
import threading, numpy as np, poseonly
rng = np.random.default_rng(0)
u1, u2 = rng.uniform(0, 1000, (60000, 2)), rng.uniform(0, 1000, (60000, 2))
K = np.array([[800.0, 0.0, 500.0], [0.0, 800.0, 500.0], [0.0, 0.0, 1.0]])
threading.Thread(target=poseonly.estimate_relative_pose, args=(u1, u2, K), kwargs={"max_iterations": 100000, "min_iterations": 100000}, daemon=True).start()
import time; time.sleep(1.5)
print("exit", flush=True)
"""


@pytest.mark.skipif(sys.platform == "win32", reason="POSIX signals")
def test_a_search_in_a_daemon_thread_does_not_abort_interpreter_exit():
    """Only the main thread's search checks for signals: a worker thread taking the GIL during interpreter
    shutdown aborted the process ("terminate called without an active exception", a review)."""
    r = subprocess.run([sys.executable, "-c", THREAD_CODE], capture_output=True, text=True, timeout=120)
    assert r.returncode == 0 and r.stdout.strip() == "exit", (r.returncode, r.stderr[-2000:])
