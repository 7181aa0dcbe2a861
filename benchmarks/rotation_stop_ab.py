"""In-process A/B of the pure-rotation test's stopping rule (``poseonly.analysis.ROTATION_MIN_SHARE``).

A = the rotation RANSAC stopped by its own best model only (share 0: it runs to
``ROTATION_MAX_ITERATIONS`` wherever no rotation fits), B = the library's share (the search stops once a
rotation explaining that share of the pose's inliers would have been drawn). Both alternate on the same
synthetic pairs (n = ``--points``, 0.5 px noise) in one process, so the machine's drift cancels out of
the ratio. Prints, per cell, the median time per pair of each, the median of the per-round ratios B / A
(interquartile range), the rotation hypotheses tested and whether every status and pose is the same.

    python benchmarks/rotation_stop_ab.py --camera pinhole --outliers 0 0.5 0.8
    python benchmarks/rotation_stop_ab.py --kind rotation --outliers 0 0.5
    python benchmarks/rotation_stop_ab.py --old-parallax   # A also with the numpy parallax_ratio

``--old-parallax``: A also runs the precision check as it was before it moved into the core (the numpy
reference, tests/reference/parallax.py), so B / A is the time of both changes; the poses then agree to
rounding, not bit for bit, and the same-result check compares statuses and rotations to 1e-9 deg.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--camera", default="pinhole", choices=("pinhole", "wide"))
    ap.add_argument("--kind", default="normal", choices=("normal", "planar", "rotation"))
    ap.add_argument("--outliers", type=float, nargs="+", default=[0.0, 0.5, 0.8])
    ap.add_argument("--points", type=int, default=300)
    ap.add_argument("--scenes", type=int, default=5)
    ap.add_argument("--rounds", type=int, default=10)
    ap.add_argument("--old-parallax", action="store_true", help="A: the numpy parallax_ratio as well")
    a = ap.parse_args(argv)
    import poseonly.analysis as A
    from poseonly import estimate_relative_pose
    from poseonly.geometry import rotation_error_deg
    from poseonly.sim import make_scene

    new_parallax = A.parallax_ratio
    old_parallax = new_parallax
    if a.old_parallax:
        sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
        from reference.parallax import parallax_ratio as old_parallax

    share_b = A.ROTATION_MIN_SHARE
    for out in a.outliers:
        scenes = [make_scene(a.points, kind=a.kind, camera=a.camera, noise_px=0.5, outlier_fraction=out, seed=100 + s) for s in range(a.scenes)]

        def run(share: float, sink: list, scenes: list = scenes) -> float:
            A.ROTATION_MIN_SHARE = share
            A.parallax_ratio = old_parallax if share == 0.0 else new_parallax
            t0 = time.perf_counter()
            for sc in scenes:
                sink.append(estimate_relative_pose(sc.u1, sc.u2, sc.K, sc.K))
            return (time.perf_counter() - t0) / len(scenes)

        ra, rb = [], []
        res_a: list = []
        res_b: list = []
        run(0.0, []), run(share_b, [])  # warm-up
        for _ in range(a.rounds):
            ra.append(run(0.0, res_a))
            rb.append(run(share_b, res_b))
        A.ROTATION_MIN_SHARE, A.parallax_ratio = share_b, new_parallax
        tol = 1e-9 if a.old_parallax else 0.0
        same = all(x.status == y.status and rotation_error_deg(x.R, y.R) <= tol for x, y in zip(res_a, res_b))
        tests_a = np.median([r.diagnostics["rotation_tests"] for r in res_a[: a.scenes]]) if "rotation_tests" in res_a[0].diagnostics else float("nan")
        tests_b = np.median([r.diagnostics["rotation_tests"] for r in res_b[: a.scenes]]) if "rotation_tests" in res_b[0].diagnostics else float("nan")
        q = np.array(rb) / np.array(ra)
        print(
            f"{a.kind} {a.camera} {out:.0%}, n = {a.points}: A (share 0) {np.median(ra) * 1e3:.3f} ms, B (share {share_b:g}) "
            f"{np.median(rb) * 1e3:.3f} ms per pair; B / A median {np.median(q):.3f} (IQR {np.percentile(q, 25):.3f}-{np.percentile(q, 75):.3f}); "
            f"rotation hypotheses {tests_a:g} -> {tests_b:g}; statuses {sorted({r.status for r in res_b[: a.scenes]})}, "
            f"statuses and poses {'the same' if same else 'DIFFERENT'}"
        )
    return 0


if __name__ == "__main__":
    from poseonly.experiments.report import provenance

    print(provenance(), flush=True)
    raise SystemExit(main())
