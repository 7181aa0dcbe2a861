"""The ML stage's collapse check by the decision threshold, on and off, on the robust benchmark's scenes.

``poseonly.robust.default._decision_inside_noise`` (twenty-second session): an EM whose decision
threshold lies below the noise scale of the matches around its pose counts as a collapse and is run
again from the band's refit. For each cell (camera x scene kind) at ``--outliers``, ``--scenes``
seeded scenes (n = 300, 1 px noise, ``sim.make_scene(..., seed=5000 + s)``, estimate seed ``s``) are
estimated with the check off (``_decision_inside_noise`` returning False: the default before) and on;
printed: the median rotation error (for planar scenes the nearer of the pose and its twin), how many
scenes changed, how many of those improved, the geometric mean of the changed scenes' error ratios,
the `ok` counts and the `ok` poses more than 5 deg off.

    python benchmarks/collapse_ab.py --scenes 200 --outliers 0.8
"""

from __future__ import annotations

import argparse

import numpy as np

import poseonly
from poseonly import sim
from poseonly.robust import default as D

CELLS = (("wide", "normal"), ("wide", "planar"), ("pinhole", "normal"), ("pinhole", "planar"))
WRONG_DEG = 5.0


def _error(r: poseonly.RelativePoseResult, sc: sim.Scene, planar: bool) -> float:
    if r.R is None:
        return 180.0
    e = float(poseonly.rotation_error_deg(r.R, sc.R))
    if planar and r.R_twin is not None:
        e = min(e, float(poseonly.rotation_error_deg(r.R_twin, sc.R)))
    return e


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenes", type=int, default=200)
    ap.add_argument("--outliers", type=float, default=0.8)
    a = ap.parse_args(argv)
    check = D._decision_inside_noise
    for camera, kind in CELLS:
        e0, e1, ok, wrong = [], [], [0, 0], [0, 0]
        for s in range(a.scenes):
            sc = sim.make_scene(300, kind=kind, camera=camera, noise_px=1.0, outlier_fraction=a.outliers, seed=5000 + s)
            for k in (0, 1):
                D._decision_inside_noise = check if k else (lambda *args, **kw: False)  # type: ignore[assignment]
                try:
                    r = poseonly.estimate_relative_pose(sc.u1, sc.u2, sc.K, sc.K, seed=s)
                finally:
                    D._decision_inside_noise = check  # type: ignore[assignment]
                e = _error(r, sc, kind == "planar")
                (e1 if k else e0).append(e)
                ok[k] += r.status == "ok"
                wrong[k] += r.status == "ok" and e > WRONG_DEG
        x, y = np.array(e0), np.array(e1)
        ch = x != y
        gm = float(np.exp(np.mean(np.log(y[ch] / x[ch])))) if ch.any() else 1.0
        print(
            f"{camera} {kind} {100 * a.outliers:.0f} %: median {np.median(x):.4f} -> {np.median(y):.4f} deg; changed {int(ch.sum())}, "
            f"better {int(np.sum(y[ch] < x[ch]))}, geometric mean ratio {gm:.3f}; ok {ok[0]} -> {ok[1]}; ok > {WRONG_DEG:g} deg {wrong[0]} -> {wrong[1]}",
            flush=True,
        )
    return 0


if __name__ == "__main__":
    from poseonly.experiments.report import provenance

    print(provenance(), flush=True)
    raise SystemExit(main())
