"""How often the ML stage's EM collapses (``poseonly.robust.default.ML_COLLAPSE``) on the robust
benchmark's scene generator at 80 % outliers (``poseonly.sim.make_scene``, n = 300, 1 px noise, seeds
5000 + i), and the ratio the guard thresholds: the Gaussian mixture's sigma
over the robust scale of its pose's errors (1.4826 median of those below T / 2), EM run from the
default's chosen pose without the guard.

    python benchmarks/ml_collapse_survey.py --scenes 60
"""

from __future__ import annotations

import argparse

import numpy as np

from poseonly import _core
from poseonly.options import PoseonlyOptions
from poseonly.residuals import v_sampson
from poseonly.robust import default as D
from poseonly.sim import make_scene

CELLS = [("wide", "normal"), ("wide", "planar"), ("pinhole", "normal"), ("pinhole", "planar")]


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scenes", type=int, default=60)
    ap.add_argument("--outliers", type=float, default=0.8)
    ap.add_argument("--cells", type=int, default=len(CELLS), help="the first this many of the four cells")
    a = ap.parse_args(argv)
    o = PoseonlyOptions()
    for cam, kind in CELLS[: a.cells]:
        ratios, collapsed = [], 0
        for s in range(a.scenes):
            sc = make_scene(300, kind=kind, camera=cam, noise_px=1.0, outlier_fraction=a.outliers, seed=5000 + s)
            tau = o.threshold_px / (float(sc.K[0, 0]) if sc.K is not None else 800.0)
            T = o.ml_range * tau
            r = D._search(sc.f1, sc.f2, tau, o, None)
            R, t = D.select_by_support(r.R, r.t, sc.f1, sc.f2, tau)
            m = _core.ml_refine(R, t, sc.f1, sc.f2, T, rounds=D.ML_ROUNDS, pose_tol=D.ML_POSE_TOL, student=o.ml_tails == "student")
            v = v_sampson(m["R"], m["t"], sc.f1, sc.f2)
            near = v[v < 0.5 * T]
            ratios.append(m["sigma_gauss"] / (D.MAD_TO_SIGMA * float(np.median(near))) if near.size else 0.0)
            collapsed += bool(D._collapsed(m, sc.f1, sc.f2, T))
        q = np.sort(np.asarray(ratios))
        print(
            f"{cam} {kind} {a.outliers:.0%}: collapsed {collapsed} of {a.scenes}; ratio min / 5 % / median / max "
            f"{q[0]:.3f} / {np.quantile(q, 0.05):.3f} / {np.median(q):.3f} / {q[-1]:.3f}; smallest {np.round(q[:5], 3).tolist()}"
        )
    return 0


if __name__ == "__main__":
    from poseonly.experiments.report import provenance

    print(provenance(), flush=True)
    raise SystemExit(main())
