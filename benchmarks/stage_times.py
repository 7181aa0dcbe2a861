"""Wall time per stage of the default method on synthetic pairs (where a pair's time goes).

Wraps the stages of ``estimate_relative_pose`` (input conversion, the core's search, the pose-only
choice, the ML stage, the status analysis and its parts) with timers and prints their mean per pair.
Nested stages are included in their parents' times. Synthetic scenes of :func:`poseonly.sim.make_scene`.

    python benchmarks/stage_times.py --outliers 0.5 --camera pinhole
"""

from __future__ import annotations

import argparse
import collections
import functools
import time
from typing import Any


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--outliers", type=float, default=0.5)
    ap.add_argument("--camera", default="pinhole", choices=("pinhole", "wide"))
    ap.add_argument("--points", type=int, default=300)
    ap.add_argument("--pairs", type=int, default=8)
    ap.add_argument("--repeats", type=int, default=3)
    a = ap.parse_args(argv)
    import poseonly.analysis as A
    import poseonly.api as API
    import poseonly.result as RS
    import poseonly.robust.default as D
    from poseonly import estimate_relative_pose, sim

    acc: dict[str, float] = collections.defaultdict(float)

    def wrap(mod: Any, name: str) -> None:
        f = getattr(mod, name)

        @functools.wraps(f)
        def g(*args: Any, **kw: Any) -> Any:
            t0 = time.perf_counter()
            try:
                return f(*args, **kw)
            finally:
                acc[f"{mod.__name__.split('.')[-1]}.{name}"] += time.perf_counter() - t0

        setattr(mod, name, g)

    stages = {
        API: ["run_poseonly", "finish", "as_bearings", "_epipolar_rank", "check_intrinsics", "parse_options"],
        D: ["_search", "local_optimization", "select_by_support", "_ml_stage"],
        RS: ["chance_rate", "pure_rotation_test", "parallax_deg", "planar_twin", "rival_test", "valid_pose", "log10_nfa"],
        A: ["robust_rotation", "rotation_chance_rate", "homography_twin", "polish", "support"],
    }
    for mod, names in stages.items():
        for n in names:
            if hasattr(mod, n):
                wrap(mod, n)
    scs = [sim.make_scene(a.points, camera=a.camera, noise_px=0.5, outlier_fraction=a.outliers, seed=300 + s) for s in range(a.pairs)]
    for sc in scs:  # warm-up
        estimate_relative_pose(sc.u1, sc.u2, sc.K, sc.K)
    acc.clear()
    t0 = time.perf_counter()
    for _ in range(a.repeats):
        for sc in scs:
            estimate_relative_pose(sc.u1, sc.u2, sc.K, sc.K)
    n = a.repeats * a.pairs
    print(f"{a.camera}, {a.points} points, {100 * a.outliers:.0f} % outliers: {1e3 * (time.perf_counter() - t0) / n:.2f} ms per pair")
    for k, v in sorted(acc.items(), key=lambda kv: -kv[1]):
        print(f"  {k:32s} {1e3 * v / n:7.3f} ms")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
