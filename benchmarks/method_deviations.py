"""Do the reported deviations cover the errors of every method? Rotation error against
``diagnostics["rotation_std_deg"]`` on synthetic pinhole scenes (200 matches, 0.5 px noise, no
outliers), for the paper's methods (whose last stage, LiGTopt or an algebraic solve, is not a
least-squares fit: their covariance carries the pose's offset from the least-squares Sampson fit of
its inliers, ``diagnostics["estimator_spread_deg"]``) and the default.

    python benchmarks/method_deviations.py --seeds 20
    python benchmarks/method_deviations.py --seeds 20 --without-spread   # the covariance as before
"""

from __future__ import annotations

import argparse

import numpy as np

import poseonly
from poseonly.geometry import rotation_error_deg
from poseonly.sim import make_scene

METHODS = [("gnc-ransac", {}), ("gnc-irls", {}), ("lirp", {}), ("poseonly", {"final": "ligt"}), ("poseonly", {})]


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seeds", type=int, default=20)
    ap.add_argument("--points", type=int, default=200)
    ap.add_argument("--noise", type=float, default=0.5)
    ap.add_argument("--without-spread", action="store_true", help="the covariance without the estimator's offset (before the fourteenth session)")
    a = ap.parse_args(argv)
    if a.without_spread:
        import poseonly.result as RS

        RS._with_estimator_spread = lambda unc, *args: unc  # type: ignore[assignment]
    print("| method | options | median error (deg) | median deviation (deg) | errors beyond 3 deviations | statuses |")
    print("|---|---|---|---|---|---|")
    for method, kw in METHODS:
        errs, stds, statuses = [], [], []
        for seed in range(a.seeds):
            sc = make_scene(a.points, camera="pinhole", noise_px=a.noise, seed=seed)
            r = poseonly.estimate_relative_pose(sc.u1, sc.u2, sc.K, sc.K, method=method, **kw)
            errs.append(float(rotation_error_deg(sc.R, r.R)))
            stds.append(float(r.diagnostics.get("rotation_std_deg", np.nan)))
            statuses.append(r.status)
        e, s = np.array(errs), np.array(stds)
        counts = ", ".join(f"{k} {statuses.count(k)}" for k in sorted(set(statuses)))
        print(f"| {method} | {kw or ''} | {np.median(e):.3f} | {np.median(s):.3f} | {int(np.sum(e > 3.0 * s))} of {len(e)} | {counts} |")
    return 0


if __name__ == "__main__":
    from poseonly.experiments.report import provenance

    print(provenance(), flush=True)
    raise SystemExit(main())
