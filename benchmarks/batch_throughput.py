"""Throughput of poseonly.estimate_relative_poses: 1 process, N processes, N threads, a local Dask cluster.

    python benchmarks/batch_throughput.py [--pairs 1000] [--points 200] [--jobs 2] [--repeats 3] [--out DIR]

Pairs: synthetic pinhole scenes (poseonly.sim, 640x480, f = 800) seen through an OPENCV camera,
``--points`` matches with 30 % outliers and 0.5 px noise. Wall time includes starting the pool /
cluster (what a user waits for). Serial, process-pool and thread-pool runs rotate ``--repeats`` times (medians), and
PoseLib runs the same pairs on 1 and N forked processes: the scaling this machine allows. Prints a table and writes batch_throughput.json to ``--out``
(default: a new folder ./batch_throughput_<time>). The load average is printed: on a shared
machine, label the numbers "measured under load".
"""

from __future__ import annotations

import argparse
import json
import os
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


def run(pairs, **kw) -> tuple[float, dict]:
    t0 = time.perf_counter()
    res = {r.key: r for r in poseonly.estimate_relative_poses(pairs, progress=False, **kw)}
    return time.perf_counter() - t0, res


def _poselib_chunk(chunk: list[Pair]) -> int:
    import poselib

    c = {"model": CAM.model, "width": CAM.width, "height": CAM.height, "params": list(CAM.params)}
    for p in chunk:
        poselib.estimate_relative_pose(p.x1, p.x2, c, c, {}, {})
    return len(chunk)


def run_poselib(pairs: list[Pair], jobs: int) -> float:
    """The anchor's scaling on the same machine: PoseLib on the same pairs (its OPENCV camera model),
    in this process or on ``jobs`` forked processes with chunks of 16 pairs."""
    import multiprocessing as mp

    chunks = [pairs[i : i + 16] for i in range(0, len(pairs), 16)]
    t0 = time.perf_counter()
    if jobs == 1:
        for c in chunks:
            _poselib_chunk(c)
    else:
        with mp.get_context("fork").Pool(jobs) as pool:
            pool.map(_poselib_chunk, chunks, chunksize=1)
    return time.perf_counter() - t0


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--pairs", type=int, default=1000, help="number of pairs")
    ap.add_argument("--points", type=int, default=200, help="matches per pair")
    ap.add_argument("--jobs", type=int, default=2, help="processes of the pool and workers of the Dask cluster")
    ap.add_argument("--repeats", type=int, default=3, help="rounds of the serial, process-pool and thread-pool runs (their order rotates); medians are reported (default 3)")
    ap.add_argument("--out", default=None, help="output folder (default: a new ./batch_throughput_<time>)")
    a = ap.parse_args(argv)
    pairs = make_pairs(a.pairs, a.points)
    schedules = {"1 process": {"n_jobs": 1}, f"{a.jobs} processes": {"n_jobs": a.jobs, "backend": "processes"}, f"{a.jobs} threads": {"n_jobs": a.jobs, "backend": "threads"}}
    walls: dict[str, list[float]] = {name: [] for name in schedules}
    speedups: dict[str, list[float]] = {name: [] for name in list(schedules)[1:]}
    same = True
    base: dict = {}
    names = list(schedules)
    for rep in range(a.repeats):  # rotate the order, so that drifts of the machine do not favour one
        order = names[rep % len(names) :] + names[: rep % len(names)]
        got = {}
        for name in order:
            t, res = run(pairs, **schedules[name])
            got[name] = t
            walls[name].append(t)
            if not base:
                base = res
            same &= all(np.array_equal(base[k].result.R, res[k].result.R) for k in base)
        for name in speedups:
            speedups[name].append(got["1 process"] / got[name])
    pl1 = [run_poselib(pairs, 1) for _ in range(a.repeats)]
    plj = [run_poselib(pairs, a.jobs) for _ in range(a.repeats)]
    est_s = sum(r.result.time_s for r in base.values() if r.result is not None)
    rows = [(name, float(np.median(ts))) for name, ts in walls.items()]
    t1 = rows[0][1]
    try:
        from dask.distributed import Client, LocalCluster
    except ImportError:
        pass
    else:
        t0 = time.perf_counter()
        with LocalCluster(n_workers=a.jobs, threads_per_worker=1, dashboard_address=None) as lc, Client(lc) as cl:
            _, on_dask = run(pairs, client=cl)
        rows.append((f"Dask LocalCluster, {a.jobs} workers (incl. start-up, 1 run)", time.perf_counter() - t0))
        same &= all(np.array_equal(base[k].result.R, on_dask[k].result.R) for k in base)
    load = os.getloadavg()
    sp = {name: float(np.median(v)) for name, v in speedups.items()}
    plsp = float(np.median(pl1) / np.median(plj))
    print(f"{a.pairs} pairs x {a.points} matches, {a.repeats} repeats; load average {load[0]:.2f} {load[1]:.2f} {load[2]:.2f} on {os.cpu_count()} cores")
    print(f"results identical across schedules: {same}")
    print(f"{'schedule':<56} {'wall s':>8} {'pairs/s':>8} {'speed-up':>8}")
    for name, t in rows:
        print(f"{name:<56} {t:8.2f} {a.pairs / t:8.1f} {t1 / t:8.2f}")
    for name, v in speedups.items():
        print(f"median of the per-repeat speed-ups, {name} / 1: {sp[name]:.2f}x (runs: {', '.join(f'{x:.2f}' for x in v)})")
    print(f"PoseLib on the same pairs, {a.jobs} processes / 1: {plsp:.2f}x (median wall {np.median(pl1):.2f} s / {np.median(plj):.2f} s): the machine's scaling")
    print(f"sum of the per-pair estimation times (serial run): {est_s:.2f} s of {walls['1 process'][0]:.2f} s wall")
    out = Path(a.out or f"batch_throughput_{time.strftime('%Y%m%d-%H%M%S')}")
    out.mkdir(parents=True, exist_ok=True)
    (out / "batch_throughput.json").write_text(
        json.dumps(
            {
                "pairs": a.pairs,
                "points": a.points,
                "jobs": a.jobs,
                "repeats": a.repeats,
                "loadavg": load,
                "identical": bool(same),
                "rows": [{"schedule": n, "wall_s": t, "pairs_per_s": a.pairs / t, "speedup": t1 / t} for n, t in rows],
                "walls": walls,
                "speedups": speedups,
                "median_speedup": sp,
                "poselib_wall_s": {"1": pl1, str(a.jobs): plj},
                "poselib_speedup": plsp,
                "sum_estimate_s": est_s,
            },
            indent=2,
        )
    )
    print(f"wrote {out / 'batch_throughput.json'}")
    return 0


if __name__ == "__main__":
    from poseonly.experiments.report import provenance

    print(provenance(), flush=True)
    raise SystemExit(main())
