"""A study of the global pipeline (docs/SFM.md, "Not done"): refit every edge's two-view rotation with
its translation direction fixed to the one the global solution gives (``R_j (C_i - C_j)``), then
average the rotations and solve LiGT again, for a few rounds. The idea: the two-view rotation's worst
direction trades against its translation direction, which the global solution might pin down better.

On each shared Strecha scene's cached view graph (``poseonly experiment global``'s cache) prints the
openMVG-protocol rotation error, the rotation-only-aligned one, the mean position error (m) and the
mean relative rotation error of all pairs, before and after each round.

    python benchmarks/global_fixed_direction_study.py [/work/shared/data/strecha] [--cache /tmp/sfm_cache] [--rounds 3]
"""

from __future__ import annotations

import argparse
import dataclasses
from pathlib import Path

import numpy as np

SCENES = ("Herz-Jesus-P8", "entry-P10", "fountain-P11")
GN_STEPS = 10


def refit_rotation(R: np.ndarray, t: np.ndarray, f1: np.ndarray, f2: np.ndarray) -> np.ndarray:
    """Gauss-Newton on the Sampson errors over the rotation alone (the core's left chart), ``t`` fixed;
    a step is kept only if it lowers the sum of squares."""
    from poseonly import _core
    from poseonly.sfm.so3 import exp_so3

    c = np.ascontiguousarray
    f1, f2 = c(f1), c(f2)
    r, J = _core._refine_residuals(0, c(R), c(t), f1, f2, np.zeros(5))
    for _ in range(GN_STEPS):
        dx = np.linalg.lstsq(J.reshape(-1, 5)[:, :3], -r, rcond=None)[0]
        Rn = exp_so3(dx[None])[0] @ R
        rn, Jn = _core._refine_residuals(0, c(Rn), c(t), f1, f2, np.zeros(5))
        if not float(rn @ rn) < float(r @ r):
            break
        R, r, J = Rn, rn, Jn
    return R


def main(argv: list[str] | None = None) -> int:
    from poseonly.experiments.global_sfm import _gt, _scores
    from poseonly.geometry import bearings_from_pixels
    from poseonly.io.strecha import load_scene
    from poseonly.sfm.pairwise import PairwiseOptions, image_view_graph
    from poseonly.sfm.pipeline import GlobalOptions, run_global

    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("path", nargs="?", default="/work/shared/data/strecha")
    p.add_argument("--cache", default="/tmp/sfm_cache")
    p.add_argument("--rounds", type=int, default=3)
    a = p.parse_args(argv)

    def short(ev: dict) -> str:
        return " ".join(f"{k}={ev[k]:.4f}" for k in ("rot_mean_deg", "rot_mean_deg_rotalign", "pos_mean", "rel_rot_mean_deg"))

    for name in SCENES:
        folder = Path(a.path) / name
        if not folder.is_dir():
            print(f"{name}: not found under {a.path}, skipped")
            continue
        sc = load_scene(folder)
        R_gt, C_gt = _gt(sc)
        ig = image_view_graph(sc.image_paths, sc.K, options=PairwiseOptions(max_features=8000, seed=0), cache_dir=a.cache)
        g = ig.graph
        res = run_global(g, ig.bearings, float(sc.K[0, 0]), GlobalOptions())
        print(name, "pipeline", short(_scores(res.rotations, res.centres, R_gt, C_gt)), flush=True)
        for rnd in range(a.rounds):
            Rg, C = res.rotations, res.centres
            edges = []
            for e in g.edges:
                known = np.all(np.isfinite(Rg[[e.i, e.j]])) and np.all(np.isfinite(C[[e.i, e.j]]))
                if not (known and e.use_translation):
                    edges.append(e)
                    continue
                t = Rg[e.j] @ (C[e.i] - C[e.j])
                f1 = bearings_from_pixels(ig.features[e.i].keypoints[e.matches[:, 0]], ig.K[e.i])
                f2 = bearings_from_pixels(ig.features[e.j].keypoints[e.matches[:, 1]], ig.K[e.j])
                edges.append(dataclasses.replace(e, R=refit_rotation(e.R, t / np.linalg.norm(t), f1, f2)))
            res = run_global(dataclasses.replace(g, edges=edges, _index={}), ig.bearings, float(sc.K[0, 0]), GlobalOptions())
            print(name, f"round {rnd + 1}", short(_scores(res.rotations, res.centres, R_gt, C_gt)), flush=True)
    return 0


if __name__ == "__main__":
    from poseonly.experiments.report import provenance

    print(provenance(), flush=True)
    raise SystemExit(main())
