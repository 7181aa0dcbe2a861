"""L1RA's stop rule against all 50 rounds, from good and bad starts (docs/SFM.md, "Scale").

    python benchmarks/l1ra_stop_study.py --views 500 1000 [--weight-spread 0 0.5] [--seeds 4]

For every ring (:func:`poseonly.sfm.synthetic.make_scene`, 50 tracks per view, 0.3 deg rotation
noise, 10 / 20 / 30 % outlier edges, edge weights optionally multiplied by 10^U(-s, s)) and start --
the default spanning tree (with the triangle check), the plain maximum-weight tree (without it) and
random rotations -- rotation averaging runs with the rule (``L1_COST_RTOL``, ``L1_STALL_STEP``) and
without it (50 rounds); printed: rounds, views more than 5 deg off after the rotation-only alignment,
and whether the rule ended worse or better. The counts of the last line are what the docs quote.
"""

from __future__ import annotations

import argparse

import numpy as np
from scipy.spatial.transform import Rotation

BAD_DEG = 5.0


def _aligned_errors(R: np.ndarray, R_gt: np.ndarray) -> np.ndarray:
    from poseonly.geometry import project_to_so3
    from poseonly.sfm.so3 import angle_deg

    ok = np.all(np.isfinite(R), axis=(1, 2))
    Q = project_to_so3(np.einsum("nji,njk->ik", R[ok], R_gt[ok]))
    e = np.full(len(R), np.inf)
    e[ok] = angle_deg(np.einsum("nji,njk->nik", R_gt[ok], R[ok] @ Q))
    return e


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--views", type=int, nargs="+", default=[500, 1000])
    p.add_argument("--weight-spread", type=float, nargs="+", default=[0.0])
    p.add_argument("--outliers", type=float, nargs="+", default=[0.1, 0.2, 0.3])
    p.add_argument("--seeds", type=int, default=4)
    a = p.parse_args(argv)
    import poseonly.sfm.rotation_averaging as ra_mod
    from poseonly.sfm.synthetic import make_scene

    rule = (ra_mod.L1_COST_RTOL, ra_mod.L1_STALL_STEP)
    tally: dict[str, list[int]] = {}
    for n in a.views:
        for ws in a.weight_spread:
            for of in a.outliers:
                for seed in range(a.seeds):
                    s = make_scene(n, 50 * n, seed=seed, rotation_noise_deg=0.3, outlier_fraction=of)
                    rng = np.random.default_rng(seed + 7)
                    w = s.weights * 10.0 ** rng.uniform(-ws, ws, len(s.weights)) if ws else s.weights
                    wn = w / np.median(w)
                    root = int(np.argmax(np.bincount(s.pairs.ravel(), weights=np.repeat(wn, 2), minlength=n)))
                    saved = ra_mod.triangle_support
                    ra_mod.triangle_support = lambda nn, pp, RR, *x, **k: (np.zeros(len(pp), np.int64), np.zeros(len(pp), np.int64))
                    try:
                        plain = ra_mod.spanning_tree_rotations(n, s.pairs, s.R_rel, wn, root)
                    finally:
                        ra_mod.triangle_support = saved
                    starts = {"tree": None, "plain tree": plain, "random": Rotation.random(n, random_state=seed).as_matrix()}
                    for name, init in starts.items():
                        out = {}
                        for on in (True, False):
                            ra_mod.L1_COST_RTOL = rule[0] if on else -np.inf
                            try:
                                ra = ra_mod.average_rotations(n, s.pairs, s.R_rel, w, init=init)
                            finally:
                                ra_mod.L1_COST_RTOL = rule[0]
                            out[on] = (int(ra.info["l1_outer"]), int(np.sum(_aligned_errors(ra.rotations, s.rotations) > BAD_DEG)))
                        verdict = "worse" if out[True][1] > out[False][1] else "better" if out[True][1] < out[False][1] else "same"
                        key = f"views {n}, weight spread {ws}, {'default start' if name == 'tree' else 'bad starts'}"
                        tally.setdefault(key, [0, 0, 0])["worse better same".split().index(verdict)] += 1
                        print(
                            f"n={n} spread={ws} outliers={of} seed={seed} {name:10s} rule: {out[True][0]:2d} rounds, {out[True][1]:4d} views > {BAD_DEG:g} deg | "
                            f"50 rounds: {out[False][0]:2d} rounds, {out[False][1]:4d} views | {verdict}",
                            flush=True,
                        )
    for key, (worse, better, same) in tally.items():
        print(f"{key}: the rule worse in {worse}, better in {better}, the same in {same}")
    return 0


if __name__ == "__main__":
    from poseonly.experiments.report import provenance

    print(provenance(), flush=True)
    raise SystemExit(main())
