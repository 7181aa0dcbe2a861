"""Which part of the default scales on two threads? The speed benchmark's thread row (8 pinhole pairs,
300 matches, 50 % outliers, 2 threads against serial, alternating repeats) for the whole method, for
the method without its status analysis (``poseonly.api.finish`` replaced by a stub) and for the status
analysis alone (the method's stages before it cached per pair).

    OMP_NUM_THREADS=1 python benchmarks/threads_stages.py --repeats 15
"""

from __future__ import annotations

import argparse
import time
from concurrent.futures import ThreadPoolExecutor
from typing import Any

import numpy as np


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--repeats", type=int, default=15)
    a = ap.parse_args(argv)
    import poseonly.api as API
    from poseonly import estimate_relative_pose, sim
    from poseonly.experiments._common import single_thread

    single_thread()
    scs = [sim.make_scene(300, camera="pinhole", noise_px=0.5, outlier_fraction=0.5, seed=300 + s) for s in range(8)]

    def one(sc: Any) -> Any:
        return estimate_relative_pose(sc.u1, sc.u2, sc.K, sc.K)

    def measure(label: str) -> None:
        [one(sc) for sc in scs]
        ups, ser = [], []
        with ThreadPoolExecutor(2) as ex:
            for _ in range(a.repeats):
                t0 = time.perf_counter()
                [one(sc) for sc in scs]
                t1 = time.perf_counter()
                list(ex.map(one, scs))
                t2 = time.perf_counter()
                ups.append((t1 - t0) / (t2 - t1))
                ser.append((t1 - t0) / len(scs))
        q = np.percentile(ups, [25, 75])
        print(f"{label}: {np.median(ups):.2f}x (quartiles {q[0]:.2f}-{q[1]:.2f}), serial {1e3 * np.median(ser):.2f} ms a pair", flush=True)

    measure("whole method")
    finish = API.finish
    API.finish = lambda method, R, t, *args, **kw: (R, t)  # type: ignore[assignment]
    measure("without the status analysis")
    API.finish = finish
    run = API.run_poseonly
    cache: dict[bytes, Any] = {}

    def cached(f1: np.ndarray, f2: np.ndarray, *args: Any) -> Any:
        key = f1.tobytes()
        if key not in cache:
            cache[key] = run(f1, f2, *args)
        R, t, w, iters, diag = cache[key]
        return R, t, w, iters, dict(diag)

    API.run_poseonly = cached  # type: ignore[assignment]
    measure("input checks and the status analysis (the search and ML stages cached)")
    API.run_poseonly = run
    return 0


if __name__ == "__main__":
    from poseonly.experiments.report import provenance

    print(provenance(), flush=True)
    raise SystemExit(main())
