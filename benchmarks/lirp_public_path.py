"""Where the public ``poseonly.lirp`` spends its time: the core alone, the public call and the checked path.

In one process, alternating on the same synthetic scenes (n = ``--points``, 0.5 px noise), so the
machine's drift cancels out of the ratios:

* ``core``: ``_core.lirp_one`` on unit bearings, every candidate's cost (the solver and its binding);
* ``public``: ``poseonly.lirp(f1, f2)``, which for plain float64 ``(n, 3)`` input is one core call
  (``poseonly.solvers.lirp.lirp_plain``: the checks in the core, the result bit for bit the checked
  path's);
* ``checked``: the path every other input takes, ``check_correspondences`` in Python, then
  ``lirp_checked`` (what the public call cost before the twenty-second session, less the numpy
  ``E = [t]x R`` it then computed: ~5 us).

Prints the median time per call of each (over ``--rounds`` rounds of ``--calls`` calls per scene) and
the medians of the per-round ratios public / core and checked / public.

    python benchmarks/lirp_public_path.py --points 30
"""

from __future__ import annotations

import argparse
import importlib
import time
from collections.abc import Callable

import numpy as np

from poseonly import _core, lirp, sim
from poseonly.geometry import check_correspondences

NOISE_PX = 0.5
RANK_TOL = 1e-9


def _per_call(fn: Callable[[], object], calls: int) -> float:
    t0 = time.perf_counter()
    for _ in range(calls):
        fn()
    return (time.perf_counter() - t0) / calls


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--points", type=int, default=30)
    ap.add_argument("--scenes", type=int, default=5)
    ap.add_argument("--rounds", type=int, default=15)
    ap.add_argument("--calls", type=int, default=300)
    a = ap.parse_args(argv)
    checked = importlib.import_module("poseonly.solvers.lirp").lirp_checked
    scenes = [sim.make_scene(a.points, noise_px=NOISE_PX, seed=s) for s in range(a.scenes)]
    ways: dict[str, Callable[[sim.Scene], Callable[[], object]]] = {
        "core": lambda sc: lambda: _core.lirp_one(sc.f1, sc.f2, None, True, RANK_TOL),
        "public": lambda sc: lambda: lirp(sc.f1, sc.f2),
        "checked": lambda sc: lambda: checked(*check_correspondences(sc.f1, sc.f2, None, min_positive=0), RANK_TOL),
    }
    times: dict[str, list[float]] = {k: [] for k in ways}
    for r in range(a.rounds):
        order = list(ways) if r % 2 == 0 else list(reversed(ways))
        for k in order:
            times[k].append(float(np.mean([_per_call(ways[k](sc), a.calls) for sc in scenes])))
    med = {k: float(np.median(v)) for k, v in times.items()}
    pub_core = np.median(np.array(times["public"]) / np.array(times["core"]))
    chk_pub = np.median(np.array(times["checked"]) / np.array(times["public"]))
    print(f"n = {a.points}, {a.scenes} scenes, {a.rounds} alternating rounds of {a.calls} calls a scene")
    for k, v in med.items():
        print(f"  {k:8s} {v * 1e6:7.1f} us a call")
    print(f"  public / core {pub_core:.2f}, checked / public {chk_pub:.2f}")
    return 0


if __name__ == "__main__":
    from poseonly.experiments.report import provenance

    print(provenance(), flush=True)
    raise SystemExit(main())
