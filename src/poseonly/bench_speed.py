"""Speed benchmark: poseonly against PoseLib and OpenCV, side by side in one process, ratios reported.

Usage::

    poseonly bench speed [--quick] [--scenes S] [--repeats R] [--out DIR]

Everything runs single-threaded (BLAS and OpenCV limited to one thread) except the thread-scaling
row. Timings are medians per call over ``scenes x repeats`` calls after a warm-up call per method;
the machine may be shared, so the ratios measured in the same run are the robust numbers.

Rows (issue 11's "Must show"):

* **fresh process**: a new interpreter imports the library and estimates the demo pair's matches
  (the SIFT matches of ``poseonly demo``, computed once and passed as an ``.npz``); the time from
  before the import to after the first pose, and the whole process's wall time, for poseonly,
  PoseLib and OpenCV;
* **LiRP** (:func:`poseonly.lirp`, the public call with validation, and the core's batched solve
  per problem) at n = 30 and 300;
* **the default method** (``estimate_relative_pose``) at n = 300 with 0 / 50 / 80 % outliers on the
  wide and the pinhole camera of :func:`poseonly.sim.make_scene` (0.5 px noise), against PoseLib
  (its 1 px default) and OpenCV USAC_MAGSAC / RANSAC at 1 px;
* **GNC-RANSAC** with its 50 samples (``method="gnc-ransac"``, ``refine=False``) at 30 % outliers;
* **threads**: 8 pairs on 2 threads (a ``ThreadPoolExecutor``) against serial; the core releases
  the GIL, the Python orchestration does not (the core's search alone on the same pairs is the
  ceiling, reported beside it).

Writes ``speed.md`` and ``speed.json`` to ``--out`` (default: a new folder under the working
directory).
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any, Callable

import numpy as np

from ._fileutil import atomic_write_text, new_results_dir
from .experiments.report import code_version, machine, markdown_table, single_thread

THRESHOLD_PX = 1.0  # the anchors' default; the default method gets its own default (noise-matched)
NOISE_PX = 0.5
N_POINTS = 300
OUTLIER_RATES = (0.0, 0.5, 0.8)
FRESH_RUNS = 5

_FRESH = {
    "poseonly": "import poseonly; r = poseonly.estimate_relative_pose(d['u1'], d['u2'], d['K'], d['K'])",
    "poselib": (
        "import poselib; K = d['K']; c = {'model': 'PINHOLE', 'width': 960, 'height': 640, "
        "'params': [K[0,0], K[1,1], K[0,2], K[1,2]]}; poselib.estimate_relative_pose(d['u1'], d['u2'], c, c, {}, {})"
    ),
    "opencv": "import cv2; E, m = cv2.findEssentialMat(d['u1'], d['u2'], d['K'], cv2.USAC_MAGSAC, 0.999, 1.0); cv2.recoverPose(E, d['u1'], d['u2'], d['K'], mask=m)",
}


def _median_time(fn: Callable[[Any], Any], calls: list) -> float:
    fn(calls[0])  # warm-up
    ts = []
    for c in calls:
        t0 = time.perf_counter()
        fn(c)
        ts.append(time.perf_counter() - t0)
    return float(np.median(ts))


def fresh_process(runs: int) -> dict:
    """Import + first estimate in a new interpreter (seconds), per library; median over ``runs``."""
    from .demo_data import load_demo_pair
    from .features import match_images

    d = load_demo_pair()
    m = match_images(d.image1, d.image2)
    out: dict[str, Any] = {"num_matches": int(len(m.u1))}
    with tempfile.TemporaryDirectory() as tmp:
        f = Path(tmp) / "demo.npz"
        np.savez(f, u1=np.ascontiguousarray(m.u1, float), u2=np.ascontiguousarray(m.u2, float), K=np.asarray(d.K1, float))
        for name, stmt in _FRESH.items():
            code = ("import time, numpy as np; d = dict(np.load(%r)); t0 = time.perf_counter(); %s; print(time.perf_counter() - t0)") % (str(f), stmt)
            firsts, walls = [], []
            for _ in range(runs):
                t0 = time.perf_counter()
                p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=False)
                walls.append(time.perf_counter() - t0)
                if p.returncode != 0:
                    out[name] = {"error": p.stderr.strip().splitlines()[-1] if p.stderr.strip() else "failed"}
                    break
                firsts.append(float(p.stdout.strip().splitlines()[-1]))
            else:
                out[name] = {"import_first_estimate_s": float(np.median(firsts)), "process_wall_s": float(np.median(walls))}
    return out


def lirp_rows(scenes: int, repeats: int) -> dict:
    from . import lirp, sim
    from .solvers.lirp import lirp_batch

    out = {}
    for n in (30, 300):
        scs = [sim.make_scene(n, noise_px=NOISE_PX, seed=s) for s in range(scenes)] * repeats
        out[f"lirp_public_n{n}"] = _median_time(lambda sc: lirp(sc.f1, sc.f2), scs)
        F = (np.ascontiguousarray(np.stack([sc.f1 for sc in scs[:scenes]] * 20)), np.ascontiguousarray(np.stack([sc.f2 for sc in scs[:scenes]] * 20)))
        out[f"lirp_core_n{n}"] = _median_time(lambda F: lirp_batch(F[0], F[1], all_costs=False), [F] * repeats) / len(F[0])
    return out


def _methods() -> dict[str, Callable]:
    from . import estimate_relative_pose
    from .anchors import available_anchors, opencv_relpose, poselib_relpose

    m: dict[str, Callable] = {"poseonly": lambda sc: estimate_relative_pose(sc.u1, sc.u2, sc.K, sc.K)}
    av = available_anchors()
    if "poselib" in av:
        m["poselib"] = lambda sc: poselib_relpose(sc.u1, sc.u2, sc.K, sc.K, threshold_px=THRESHOLD_PX)
    if "opencv-magsac" in av:
        m["opencv-magsac"] = lambda sc: opencv_relpose(sc.u1, sc.u2, sc.K, sc.K, method="USAC_MAGSAC", threshold_px=THRESHOLD_PX)
        m["opencv-ransac"] = lambda sc: opencv_relpose(sc.u1, sc.u2, sc.K, sc.K, method="RANSAC", threshold_px=THRESHOLD_PX)
    return m


def end_to_end(scenes: int, repeats: int) -> list[dict]:
    """Median time per pair of every method, n = 300, per camera and outlier rate."""
    from . import sim

    rows = []
    meths = _methods()
    for camera in ("wide", "pinhole"):
        for rate in OUTLIER_RATES:
            scs = [sim.make_scene(N_POINTS, camera=camera, noise_px=NOISE_PX, outlier_fraction=rate, seed=100 + s) for s in range(scenes)]
            row: dict[str, Any] = {"camera": camera, "outliers": rate}
            for name, fn in meths.items():
                row[name] = _median_time(fn, scs * repeats)
            rows.append(row)
    return rows


def gnc_ransac_row(scenes: int, repeats: int) -> dict:
    from . import estimate_relative_pose, sim

    scs = [sim.make_scene(N_POINTS, camera="pinhole", noise_px=NOISE_PX, outlier_fraction=0.3, seed=200 + s) for s in range(scenes)]
    row = {"gnc_ransac": _median_time(lambda sc: estimate_relative_pose(sc.u1, sc.u2, sc.K, sc.K, method="gnc-ransac", refine=False), scs * repeats)}
    meths = _methods()
    if "opencv-magsac" in meths:
        row["opencv-magsac"] = _median_time(meths["opencv-magsac"], scs * repeats)
    return row


# alternating serial / threaded repeats of the 8 pairs (0.04-0.1 s each): on a shared 2-core VM single
# repeats ranged 1.1-3.3x and the median of 5 moved by +-0.15 between runs; 21, with their quartiles
THREAD_REPEATS = 21


def threads_row(pairs: int = 8, workers: int = 2, repeats: int = THREAD_REPEATS) -> dict:
    """``pairs`` pairs estimated serially and on ``workers`` threads, alternating ``repeats`` times;
    the median of the per-repeat speed-ups and their quartiles (a shared machine's load moves single
    repeats by tens of per cent)."""
    from . import estimate_relative_pose, sim

    scs = [sim.make_scene(N_POINTS, camera="pinhole", noise_px=NOISE_PX, outlier_fraction=0.5, seed=300 + s) for s in range(pairs)]

    def one(sc):
        return estimate_relative_pose(sc.u1, sc.u2, sc.K, sc.K)

    [one(sc) for sc in scs[:2]]  # warm-up
    t_ser, t_thr, same = [], [], True
    with ThreadPoolExecutor(workers) as ex:
        for _ in range(repeats):
            t0 = time.perf_counter()
            serial = [one(sc) for sc in scs]
            t_ser.append(time.perf_counter() - t0)
            t0 = time.perf_counter()
            threaded = list(ex.map(one, scs))
            t_thr.append(time.perf_counter() - t0)
            same &= all(np.array_equal(a.R, b.R) for a, b in zip(serial, threaded))
    ups = [a / b for a, b in zip(t_ser, t_thr)]
    search = _search_threads(scs, workers, repeats)
    return {
        "search_speedups": search,
        "search_speedup": float(np.median(search)),
        "speedup_quartiles": [float(q) for q in np.percentile(ups, [25, 75])],
        "search_speedup_quartiles": [float(q) for q in np.percentile(search, [25, 75])],
        "pairs": pairs,
        "workers": workers,
        "repeats": repeats,
        "serial_s": float(np.median(t_ser)),
        "threads_s": float(np.median(t_thr)),
        "speedups": ups,
        "speedup": float(np.median(ups)),
        "identical_results": bool(same),
    }


def _search_threads(scs: list, workers: int, repeats: int) -> list[float]:
    """Speed-ups of the core's search alone (``ransac_relpose`` with the default's options; the GIL is
    released throughout) on the same pairs: the ceiling of the whole method's."""
    from .options import PoseonlyOptions
    from .robust.ransac import ransac_relpose

    o = PoseonlyOptions()

    def one(sc):
        return ransac_relpose(
            sc.f1,
            sc.f2,
            o.threshold_px / float(sc.K[0, 0]),
            0,
            min_iterations=o.min_iterations,
            confidence=o.confidence,
            max_lo=o.max_lo,
            lo=o.lo,
            rival_distance=o.rival_distance,
            chiral=o.chiral_scoring,
            min_hits=o.min_hits,
            challengers=o.challengers,
        )

    one(scs[0])
    ups = []
    with ThreadPoolExecutor(workers) as ex:
        for _ in range(repeats):
            t0 = time.perf_counter()
            [one(sc) for sc in scs]
            t_ser = time.perf_counter() - t0
            t0 = time.perf_counter()
            list(ex.map(one, scs))
            ups.append(t_ser / (time.perf_counter() - t0))
    return ups


def _quartiles(q: list[float] | None) -> str:
    return f" (quartiles {q[0]:.2f}-{q[1]:.2f})" if q else ""


def _ms(s: float) -> str:
    return f"{1e3 * s:.2f} ms" if s >= 1e-3 else f"{1e6 * s:.1f} us"


def write_report(data: dict, out: Path) -> None:
    atomic_write_text(out / "speed.json", json.dumps(data, indent=1, default=float))
    lines = ["# Speed (`poseonly bench speed`)", "", f"Machine: {data['machine']}. Command: `{data['command']}`. Code: `{data.get('code_version')}`.", ""]
    fp = data.get("fresh_process")
    if fp:
        lines += [
            "## Fresh process: import + first estimate on the demo matches",
            "",
            f"{fp['num_matches']} SIFT matches of the demo pair; median of {FRESH_RUNS} new interpreters.",
            "",
        ]
        rows = [
            [k, f"{v['import_first_estimate_s']:.3f} s", f"{v['process_wall_s']:.3f} s"] if "error" not in v else [k, v["error"], ""] for k, v in fp.items() if isinstance(v, dict)
        ]
        lines += [markdown_table(["library", "import + first estimate", "whole process"], rows), ""]
    lr = data["lirp"]
    lines += [
        "## LiRP",
        "",
        markdown_table(["n", "public `poseonly.lirp`", "core, per problem in a batch"], [[n, _ms(lr[f"lirp_public_n{n}"]), _ms(lr[f"lirp_core_n{n}"])] for n in (30, 300)]),
        "",
    ]
    e2e = data["end_to_end"]
    names = [k for k in e2e[0] if k not in ("camera", "outliers")]
    rows = []
    for r in e2e:
        row = [r["camera"], f"{100 * r['outliers']:.0f} %"] + [_ms(r[k]) for k in names]
        if "poselib" in r:
            row.append(f"{r['poseonly'] / r['poselib']:.2f}")
        if "opencv-magsac" in r:
            row.append(f"{r['poseonly'] / r['opencv-magsac']:.2f}")
        rows.append(row)
    hdr = ["camera", "outliers"] + names + (["poseonly / PoseLib"] if "poselib" in names else []) + (["poseonly / MAGSAC"] if "opencv-magsac" in names else [])
    lines += [f"## Default method, n = {N_POINTS}, {NOISE_PX} px noise (anchors at {THRESHOLD_PX} px)", "", markdown_table(hdr, rows), ""]
    g = data["gnc_ransac"]
    lines += [
        "## GNC-RANSAC (Algorithm 3, 50 samples of 30), 30 % outliers",
        "",
        f"GNC-RANSAC {_ms(g['gnc_ransac'])}" + (f", OpenCV MAGSAC {_ms(g['opencv-magsac'])}: ratio {g['gnc_ransac'] / g['opencv-magsac']:.2f}" if "opencv-magsac" in g else ""),
        "",
    ]
    t = data["threads"]
    lines += [
        "## Threads",
        "",
        f"{t['pairs']} pairs: serial {t['serial_s']:.3f} s, {t['workers']} threads {t['threads_s']:.3f} s: "
        f"speed-up {t['speedup']:.2f}x, the median of {t.get('repeats', 1)} alternating repeats{_quartiles(t.get('speedup_quartiles'))} "
        f"({', '.join(f'{u:.2f}' for u in t.get('speedups', [t['speedup']]))}; identical results: {t['identical_results']}).",
        "",
    ]
    if "search_speedup" in t:
        lines += [
            f"The core's search alone (`ransac_relpose` with the default's options, GIL released) on the same pairs: "
            f"{t['search_speedup']:.2f}x{_quartiles(t.get('search_speedup_quartiles'))} ({', '.join(f'{u:.2f}' for u in t['search_speedups'])}); the rest of a pair is "
            "Python around core calls (`python benchmarks/stage_times.py`).",
            "",
        ]
    atomic_write_text(out / "speed.md", "\n".join(lines))


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="poseonly bench speed", description="speed of poseonly against PoseLib and OpenCV (ratios)")
    p.add_argument("--quick", action="store_true", help="few scenes and repeats (a smoke run)")
    p.add_argument("--scenes", type=int, default=10, help="scenes per cell (default 10)")
    p.add_argument("--repeats", type=int, default=3, help="calls per scene (default 3)")
    p.add_argument("--out", default=None, help="output folder (default: a new folder poseonly-speed-<date>-<time> under the working directory)")
    p.add_argument("--no-fresh", action="store_true", help="skip the fresh-process row (it needs OpenCV for the demo matches)")
    a = p.parse_args(argv)
    if a.scenes < 1 or a.repeats < 1:
        p.error("--scenes and --repeats must be >= 1")
    scenes, repeats = (2, 1) if a.quick else (a.scenes, a.repeats)
    out = Path(a.out) if a.out else new_results_dir("speed")
    out.mkdir(parents=True, exist_ok=True)
    single_thread()
    data: dict[str, Any] = {"machine": machine(), "code_version": code_version(), "command": "poseonly bench speed " + " ".join(argv or sys.argv[1:])}
    if not a.no_fresh:
        data["fresh_process"] = fresh_process(2 if a.quick else FRESH_RUNS)
    data["lirp"] = lirp_rows(scenes, repeats)
    data["end_to_end"] = end_to_end(scenes, repeats)
    data["gnc_ransac"] = gnc_ransac_row(scenes, repeats)
    data["threads"] = threads_row(repeats=3 if a.quick else THREAD_REPEATS)
    write_report(data, out)
    print((out / "speed.md").read_text(encoding="utf-8"))
    print(json.dumps({"out": str(out)}))
    return 0
