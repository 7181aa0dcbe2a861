"""Throughput of poseonly.estimate_relative_poses: 1 process, N processes, a local Dask cluster.

    POSEONLY_NUMBA=0 PYTHONPATH=src python benchmarks/batch_throughput.py [--pairs 1000] [--points 200]
        [--jobs 2] [--out DIR]

Pairs: synthetic pinhole scenes (poseonly.sim, 640x480, f = 800) seen through an OPENCV camera,
``--points`` matches with 30 % outliers and 0.5 px noise. Wall time includes starting the pool /
cluster (what a user waits for). Prints a table and writes batch_throughput.json to ``--out``
(default: a new folder ./batch_throughput_<time>). The load average is printed: on a shared
machine, label the numbers "measured under load".
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import time
from pathlib import Path

import numpy as np

import poseonly
from poseonly.batch import Pair
from poseonly.cameras import Camera
from poseonly.sim import make_scene

CAM = Camera("OPENCV", 640, 480, (800.0, 800.0, 320.0, 240.0, -0.1, 0.01, 0.0, 0.0))


def make_pairs(m: int, n: int) -> list[Pair]:
    out = []
    for s in range(m):
        sc = make_scene(n, camera="pinhole", noise_px=0.5, outlier_fraction=0.3, seed=s)
        out.append(Pair(CAM.project(sc.f1), CAM.project(sc.f2), key=s, camera1=CAM))
    return out


def cpu_s() -> float:
    """CPU seconds of this process and of its reaped children (pool workers, Dask workers)."""
    a, b = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return a.ru_utime + a.ru_stime + b.ru_utime + b.ru_stime


def run(pairs, **kw) -> tuple[float, dict]:
    t0 = time.perf_counter()
    res = {r.key: r for r in poseonly.estimate_relative_poses(pairs, progress=False, **kw)}
    return time.perf_counter() - t0, res


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--pairs", type=int, default=1000, help="number of pairs")
    ap.add_argument("--points", type=int, default=200, help="matches per pair")
    ap.add_argument("--jobs", type=int, default=2, help="processes of the pool and workers of the Dask cluster")
    ap.add_argument("--out", default=None, help="output folder (default: a new ./batch_throughput_<time>)")
    a = ap.parse_args(argv)
    pairs = make_pairs(a.pairs, a.points)
    rows = []
    c0 = cpu_s()
    t1, base = run(pairs, n_jobs=1)
    c1 = cpu_s()
    rows.append(("1 process", t1, c1 - c0))
    tp, pooled = run(pairs, n_jobs=a.jobs)
    c2 = cpu_s()
    rows.append((f"{a.jobs} processes", tp, c2 - c1))
    same = all(np.array_equal(base[k].result.R, pooled[k].result.R) for k in base)
    try:
        from dask.distributed import Client, LocalCluster
    except ImportError:
        td = float("nan")
    else:
        t0 = time.perf_counter()
        with LocalCluster(n_workers=a.jobs, threads_per_worker=1, dashboard_address=None) as lc, Client(lc) as cl:
            _, on_dask = run(pairs, client=cl)
        td = time.perf_counter() - t0
        same &= all(np.array_equal(base[k].result.R, on_dask[k].result.R) for k in base)
        rows.append((f"Dask LocalCluster, {a.jobs} workers (incl. start-up)", td, cpu_s() - c2))
    load = os.getloadavg()
    print(f"{a.pairs} pairs x {a.points} matches; load average {load[0]:.2f} {load[1]:.2f} {load[2]:.2f} on {os.cpu_count()} cores; results identical across schedules: {same}")
    print(f"{'schedule':<48} {'wall s':>8} {'pairs/s':>8} {'speed-up':>8} {'CPU s':>8}")
    for name, t, c in rows:
        print(f"{name:<48} {t:8.2f} {a.pairs / t:8.1f} {t1 / t:8.2f} {c:8.2f}")
    print("CPU s: user + system time of all processes (the parallel overhead, independent of other load)")
    out = Path(a.out or f"batch_throughput_{time.strftime('%Y%m%d-%H%M%S')}")
    out.mkdir(parents=True, exist_ok=True)
    (out / "batch_throughput.json").write_text(
        json.dumps(
            {
                "pairs": a.pairs,
                "points": a.points,
                "jobs": a.jobs,
                "loadavg": load,
                "identical": bool(same),
                "rows": [{"schedule": n, "wall_s": t, "cpu_s": c, "pairs_per_s": a.pairs / t, "speedup": t1 / t} for n, t, c in rows],
            },
            indent=2,
        )
    )
    print(f"wrote {out / 'batch_throughput.json'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
