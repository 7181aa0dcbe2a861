"""Where one iteration of the default's search goes: the five-point solve against the scoring.

For synthetic scenes of :func:`poseonly.sim.make_scene` (0.5 px noise) at several sizes and outlier
rates, runs the core's search with the default's options (``poseonly.robust.default._search``) and
prints per iteration (one minimal sample): the time, the models that reached the scorer
(``stats["num_models"]`` over the iterations: the five-point solver keeps only poses with all five
sample points in front of both cameras) and, beside it, the time of the solver alone on the same
number of random five-point samples of the scene (``_core.fivept_batch``). What is left of an
iteration after the solve is the scoring, the LO and the loop. A test that drops bad models earlier
during scoring (Wald's SPRT, Matas and Chum 2005) can only save from that remainder.

    python benchmarks/search_profile.py
    python benchmarks/search_profile.py --points 1000 --outliers 0.9 --iterations 20000
"""

from __future__ import annotations

import argparse
import time

import numpy as np


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--points", type=int, nargs="+", default=[300, 1000])
    ap.add_argument("--outliers", type=float, nargs="+", default=[0.0, 0.5, 0.8, 0.9])
    ap.add_argument("--camera", default="pinhole", choices=("pinhole", "wide"))
    ap.add_argument("--iterations", type=int, default=5000, help="max_iterations of the search (the default's is 100000)")
    ap.add_argument("--scenes", type=int, default=3)
    a = ap.parse_args(argv)
    from poseonly import _core, sim
    from poseonly.options import PoseonlyOptions
    from poseonly.robust.default import _search

    o = PoseonlyOptions(max_iterations=a.iterations)
    print("| n | outliers | iterations | models scored per iteration | us per iteration | five-point solve alone, us per sample | rest, us |")
    print("|---|---|---|---|---|---|---|")
    rng = np.random.default_rng(0)
    for n in a.points:
        for rate in a.outliers:
            its, mods, t_it, t_solve = [], [], [], []
            for s in range(a.scenes):
                sc = sim.make_scene(n, camera=a.camera, noise_px=0.5, outlier_fraction=rate, seed=700 + s)
                tau = 1.0 / float(sc.K[0, 0])
                t0 = time.perf_counter()
                r = _search(sc.f1, sc.f2, tau, o, None)
                dt = time.perf_counter() - t0
                k = r.num_iterations
                idx = np.stack([rng.choice(n, 5, replace=False) for _ in range(k)])
                F1, F2 = np.ascontiguousarray(sc.f1[idx]), np.ascontiguousarray(sc.f2[idx])
                t0 = time.perf_counter()
                _core.fivept_batch(F1, F2)
                ds = time.perf_counter() - t0
                its.append(k)
                mods.append(r.num_scored / k)
                t_it.append(1e6 * dt / k)
                t_solve.append(1e6 * ds / k)
            m_it, m_s = float(np.median(t_it)), float(np.median(t_solve))
            print(f"| {n} | {100 * rate:.0f} % | {int(np.median(its))} | {np.median(mods):.2f} | {m_it:.1f} | {m_s:.1f} | {m_it - m_s:.1f} |")
    return 0


if __name__ == "__main__":
    from poseonly.experiments.report import provenance

    print(provenance(), flush=True)
    raise SystemExit(main())
