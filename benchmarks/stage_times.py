"""Wall time per stage of the default method on synthetic pairs (where a pair's time goes).

Wraps the stages of ``estimate_relative_pose`` (input conversion, the core's search, the pose-only
choice, the ML stage, the status analysis and its parts) with timers and prints their mean per pair.
Nested stages are included in their parents' times. Synthetic scenes of :func:`poseonly.sim.make_scene`,
or with ``--real DIR`` the first ``--pairs`` pairs of a ``poseonly bench real`` dataset folder (its
cached SIFT matches, ``1 - ratio`` as scores and the keypoints' sizes as noise scales, as the bench
calls the default; ``--ml-tails`` picks the ML stage's inlier model, ``--no-scales`` leaves the noise
scales out).

    python benchmarks/stage_times.py --outliers 0.5 --camera pinhole
    python benchmarks/stage_times.py --real /work/shared/data/realpairs/kitti_seq1 --pairs 20 --ml-tails gauss
    python benchmarks/stage_times.py --real /work/shared/data/realpairs/kitti_seq1 --pairs 20 --no-scales

``--core-share`` also times every call into the compiled core (each module's ``_core`` attribute
replaced by a timing proxy) and prints the time of a pair spent outside it: the Python that holds the
GIL and so caps what threads can gain (Amdahl: two threads at most ``2 / (1 + share)``).
``--reference-pure-rotation`` runs the pure-rotation test as it was before the nineteenth session (its
rotation search without a support floor, ``ROTATION_MIN_SHARE = 0``, and the numpy precision check of
tests/reference/parallax.py), for before / after figures from one build.
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
    ap.add_argument("--real", default=None, help="a realpairs or Strecha folder instead of synthetic scenes")
    ap.add_argument("--cache", default="/tmp/realbench_cache", help="the real benchmark's match cache")
    ap.add_argument("--ml-tails", default="student", choices=("student", "gauss"))
    ap.add_argument("--no-scales", action="store_true", help="real pairs: no noise scales")
    ap.add_argument("--core-share", action="store_true", help="also time the calls into the compiled core")
    ap.add_argument("--reference-pure-rotation", action="store_true", help="the pure-rotation test as before the nineteenth session")
    a = ap.parse_args(argv)
    import poseonly.analysis as A
    import poseonly.api as API
    import poseonly.result as RS
    import poseonly.robust.default as D
    from poseonly import estimate_relative_pose, sim

    if a.reference_pure_rotation:
        import sys
        from pathlib import Path

        sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
        from reference.parallax import parallax_ratio

        A.parallax_ratio = parallax_ratio
        A.ROTATION_MIN_SHARE = 0.0

    acc: dict[str, float] = collections.defaultdict(float)
    py: dict[str, float] = collections.defaultdict(float)  # --core-share: each stage's time outside the core

    def wrap(mod: Any, name: str) -> None:
        f = getattr(mod, name)

        @functools.wraps(f)
        def g(*args: Any, **kw: Any) -> Any:
            t0, c0 = time.perf_counter(), acc["(core calls)"]
            try:
                return f(*args, **kw)
            finally:
                key = f"{mod.__name__.split('.')[-1]}.{name}"
                dt = time.perf_counter() - t0
                acc[key] += dt
                py[key] += dt - (acc["(core calls)"] - c0)

        setattr(mod, name, g)

    stages = {
        API: ["run_poseonly", "finish", "as_bearings", "_epipolar_rank", "check_intrinsics", "parse_options"],
        D: ["_search", "local_optimization", "select_by_support", "_ml_stage", "_cross_fit"],
        RS: ["chance_rate", "pure_rotation_test", "parallax_deg", "planar_twin", "rival_test", "valid_pose", "log10_nfa"],
        A: ["robust_rotation", "rotation_chance_rate", "homography_twin", "polish", "support"],
    }
    for mod, names in stages.items():
        for n in names:
            if hasattr(mod, n):
                wrap(mod, n)
    if a.core_share:
        import sys
        from types import ModuleType

        class TimedCore:
            """The core module with every function call timed into ``acc["(core calls)"]``."""

            def __init__(self, m: ModuleType) -> None:
                self._m = m

            def __getattr__(self, name: str) -> Any:
                f = getattr(self._m, name)
                if not callable(f) or isinstance(f, type):
                    return f

                def g(*args: Any, **kw: Any) -> Any:
                    t0 = time.perf_counter()
                    try:
                        return f(*args, **kw)
                    finally:
                        acc["(core calls)"] += time.perf_counter() - t0

                setattr(self, name, g)
                return g

        for name, mod in list(sys.modules.items()):
            core = getattr(mod, "_core", None)
            if name.startswith("poseonly") and isinstance(core, ModuleType):
                mod._core = TimedCore(core)  # type: ignore[attr-defined]
    calls: list[tuple[tuple[Any, ...], dict[str, Any]]] = []
    if a.real is None:
        for s in range(a.pairs):
            sc = sim.make_scene(a.points, camera=a.camera, noise_px=0.5, outlier_fraction=a.outliers, seed=300 + s)
            calls.append(((sc.u1, sc.u2, sc.K, sc.K), {"ml_tails": a.ml_tails}))
        what = f"{a.camera}, {a.points} points, {100 * a.outliers:.0f} % outliers"
    else:
        from pathlib import Path

        from poseonly.experiments import real_bench as rb

        for name, pairs in rb.load_datasets([a.real]).items():
            for p in pairs[: a.pairs]:
                u1, u2, ratio, scales = rb.pair_match_data(p, Path(a.cache))
                kw: dict[str, Any] = {"scores": 1.0 - ratio, "ml_tails": a.ml_tails}
                if not a.no_scales:
                    kw["noise_scales"] = scales
                calls.append(((u1, u2, p.K1, p.K2), kw))
            what = f"{name}, first {len(calls)} pairs, ml_tails={a.ml_tails}, noise scales {'no' if a.no_scales else 'yes'}"
    for args, kw in calls:  # warm-up
        estimate_relative_pose(*args, **kw)
    acc.clear()
    py.clear()
    t0 = time.perf_counter()
    for _ in range(a.repeats):
        for args, kw in calls:
            estimate_relative_pose(*args, **kw)
    n = a.repeats * len(calls)
    total = time.perf_counter() - t0
    print(f"{what}: {1e3 * total / n:.2f} ms per pair")
    if a.core_share:
        out = total - acc["(core calls)"]
        print(f"  outside the core: {1e3 * out / n:.3f} ms per pair ({100 * out / total:.1f} %; two threads at most {2 / (1 + out / total):.2f}x)")
    for k, v in sorted(acc.items(), key=lambda kv: -kv[1]):
        extra = f"  (outside the core {1e3 * py[k] / n:6.3f} ms)" if a.core_share and k in py else ""
        print(f"  {k:32s} {1e3 * v / n:7.3f} ms{extra}")
    return 0


if __name__ == "__main__":
    from poseonly.experiments.report import provenance

    print(provenance(), flush=True)
    raise SystemExit(main())
