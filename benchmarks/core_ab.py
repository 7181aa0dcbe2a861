"""In-process A/B timing of two builds of the compiled core on the default's search, its refinements or whole pairs.

Loads both extension modules under different names in one interpreter and alternates them on the
same synthetic pairs (n = ``--points``, 0.5 px noise), so that the machine's speed drift between runs
(up to 30 % within minutes on a shared VM) cancels out of the ratio. ``--stage``: ``search`` (the
default's search, ``poseonly.robust.default._search``), ``refine`` (``refine_sampson``, 5 LM
evaluations, from the true pose), ``ml`` (``ml_refine`` as the default's ML stage calls it, Student-t
tails, from the true pose; ``--scales`` adds random noise scales) ``pair`` (``estimate_relative_pose``
with every module's core swapped), ``lirp`` (``lirp_one``, Algorithm 1 on all the scene's points: use
``--points 30``) or ``gnc-ransac`` (``estimate_relative_pose(method="gnc-ransac", refine=False)``, every
module's core swapped). Build the two cores with plain CMake into separate folders, e.g.

    cmake -S . -B /tmp/build_new -G Ninja -DPython_EXECUTABLE=$(which python) -DCMAKE_BUILD_TYPE=Release
    ninja -C /tmp/build_new
    python benchmarks/core_ab.py /tmp/build_base/_core*.so /tmp/build_new/_core*.so --camera pinhole --outliers 0

Prints the median time per pair of each and the median of the per-round ratios B / A with its
interquartile range.
"""

from __future__ import annotations

import argparse
import importlib.util
import time
from types import ModuleType

import numpy as np

LIRP_REPEATS = 200  # lirp stage: calls per scene and round (one call is ~20 us)


def _load(path: str, tag: str) -> ModuleType:
    spec = importlib.util.spec_from_file_location(f"{tag}._core", path)
    if spec is None or spec.loader is None:
        raise SystemExit(f"cannot load {path}")
    m = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(m)
    return m


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("core_a", help="path of build A's _core extension module")
    ap.add_argument("core_b", help="path of build B's _core extension module")
    ap.add_argument("--camera", default="pinhole", choices=("pinhole", "wide"))
    ap.add_argument("--outliers", type=float, default=0.0)
    ap.add_argument("--scenes", type=int, default=5)
    ap.add_argument("--rounds", type=int, default=20)
    ap.add_argument("--points", type=int, default=300)
    ap.add_argument("--stage", default="search", choices=("search", "refine", "ml", "pair", "lirp", "gnc-ransac"))
    ap.add_argument("--scales", action="store_true", help="ml / pair: per-match noise scales (uniform 1-8)")
    a = ap.parse_args(argv)
    A, B = _load(a.core_a, "a"), _load(a.core_b, "b")
    import sys

    import poseonly.robust.ransac as RR
    from poseonly import estimate_relative_pose
    from poseonly.options import PoseonlyOptions
    from poseonly.robust import default as D
    from poseonly.sim import make_scene

    scenes = [make_scene(a.points, camera=a.camera, noise_px=0.5, outlier_fraction=a.outliers, seed=100 + s) for s in range(a.scenes)]
    scales = [np.random.default_rng(s).uniform(1.0, 8.0, a.points) if a.scales else None for s in range(a.scenes)]
    o = PoseonlyOptions()
    T = o.ml_range * o.threshold_px / 800.0
    users = [mod for name, mod in list(sys.modules.items()) if name.startswith("poseonly") and isinstance(getattr(mod, "_core", None), ModuleType)]

    def one(m: ModuleType, k: int) -> None:
        sc = scenes[k]
        if a.stage == "search":
            D._search(sc.f1, sc.f2, o.threshold_px / 800.0, o, None)
        elif a.stage == "refine":
            m.refine_sampson(sc.R, sc.t, sc.f1, sc.f2, None, loss="cauchy", loss_scale=1e-3, max_iterations=5, tol=0.0)
        elif a.stage == "ml":
            m.ml_refine(sc.R, sc.t, sc.f1, sc.f2, T, rounds=D.ML_ROUNDS, pose_tol=D.ML_POSE_TOL, student=True, scales=scales[k])
        elif a.stage == "lirp":
            for _ in range(LIRP_REPEATS):
                m.lirp_one(sc.f1, sc.f2, None, False, 1e-9)
        elif a.stage == "gnc-ransac":
            estimate_relative_pose(sc.u1, sc.u2, sc.K, sc.K, method="gnc-ransac", refine=False)
        else:
            estimate_relative_pose(sc.u1, sc.u2, sc.K, sc.K, noise_scales=scales[k])

    def run(m: ModuleType) -> float:
        RR._core = m  # the search's core calls go through this module attribute
        if a.stage in ("pair", "gnc-ransac"):
            for mod in users:  # every module's core calls
                mod._core = m  # type: ignore[attr-defined]
        t0 = time.perf_counter()
        for k in range(len(scenes)):
            one(m, k)
        return (time.perf_counter() - t0) / len(scenes) / (LIRP_REPEATS if a.stage == "lirp" else 1)

    run(A), run(B)  # warm-up
    ta, tb = [], []
    for _ in range(a.rounds):
        ta.append(run(A))
        tb.append(run(B))
    ra, rb = np.array(ta), np.array(tb)
    q = rb / ra
    print(
        f"{a.stage}, {a.camera} {a.outliers:.0%}, n = {a.points}: A {np.median(ra) * 1e3:.3f} ms, B {np.median(rb) * 1e3:.3f} ms per pair (lirp: per call); "
        f"B / A median {np.median(q):.3f} (IQR {np.percentile(q, 25):.3f}-{np.percentile(q, 75):.3f})"
    )
    return 0


if __name__ == "__main__":
    from poseonly.experiments.report import provenance

    print(provenance(), flush=True)
    raise SystemExit(main())
