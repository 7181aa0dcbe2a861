"""Rotation averaging's Geman-McClure scale: fixed at 5 deg (Chatterjee-Govindu, openMVG, COLMAP)
against the data's (``sigma_deg=None``: 5x the noise-corrected median edge residual of a least-squares-like fit; see
:mod:`poseonly.sfm.rotation_averaging`, step 4).

Synthetic: per seed a 30-view ring of :func:`poseonly.sfm.synthetic.make_scene` at 1 px whose edges
are two-view Sampson-LM poses (``benchmarks/ra_information.py``), averaged clean, with 5 % of the
edges given an extra 0.6 deg rotation error (a moderately bad edge, like fountain-P11's widest pair)
and with 10 % outlier edges (random rotations of 0.2-3 rad); the mean rotation error after the
rotation-only alignment. Real: the shared Strecha scenes' cached view graphs (``poseonly experiment
global``'s cache, skipped where absent), openMVG's protocol, the rotation-only alignment, positions
and all pairs' relative rotations.

    python benchmarks/ra_gm_scale.py --seeds 8
    python benchmarks/ra_gm_scale.py --seeds 8 --strecha /work/shared/data/strecha --cache /tmp/sfm_cache
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

SCALES: tuple[tuple[str, float | None], ...] = (("5 deg", 5.0), ("data", None))


def _unit(rng: np.random.Generator) -> np.ndarray:
    v = rng.normal(size=3)
    return v / np.linalg.norm(v)


def synthetic(seeds: int) -> None:
    from ra_information import edge_graph  # type: ignore[import-not-found]

    from poseonly.sfm.align import evaluate_poses
    from poseonly.sfm.rotation_averaging import average_rotations
    from poseonly.sfm.so3 import exp_so3
    from poseonly.sfm.synthetic import make_scene

    cases = ("clean", "5 % edges 0.6 deg off", "10 % outlier edges")
    err = {(c, k): [] for c in cases for k, _ in SCALES}  # type: dict[tuple[str, str], list[float]]
    for seed in range(seeds):
        sc = make_scene(30, 3000, noise_px=1.0, seed=seed)
        g = edge_graph(sc)
        pairs, Rr, w = g.pairs(), g.rotations(), g.weights()
        rng = np.random.default_rng(seed)
        E = len(pairs)

        Rb = Rr.copy()
        for e in rng.choice(E, max(1, E // 20), replace=False):
            Rb[e] = exp_so3((np.radians(0.6) * _unit(rng))[None])[0] @ Rb[e]
        Ro = Rr.copy()
        for e in rng.choice(E, max(1, E // 10), replace=False):
            Ro[e] = exp_so3((rng.uniform(0.2, 3.0) * _unit(rng))[None])[0]
        for c, RR in zip(cases, (Rr, Rb, Ro), strict=True):
            for k, s in SCALES:
                ra = average_rotations(g.num_views, pairs, RR, w, sigma_deg=s)
                err[c, k].append(float(evaluate_poses(ra.rotations, sc.centres, sc.rotations, sc.centres)["rot_mean_deg_rotalign"]))
    print(f"Synthetic 30-view rings, 1 px, two-view ML edges, {seeds} seeds: mean rotation error (deg, rotation-only alignment)\n")
    print("| graph | GM scale 5 deg | GM scale from the data | ratio (mean of per-seed ratios) |")
    print("|---|---|---|---|")
    for c in cases:
        a, b = np.array(err[c, "5 deg"]), np.array(err[c, "data"])
        print(f"| {c} | {a.mean():.5f} | {b.mean():.5f} | {np.mean(b / a):.3f} |")


def sparse(seeds: int) -> None:
    """Sparse rings (each view linked to its 1 or 2 neighbours on each side: E / N = 2 or 4) of
    :func:`poseonly.sfm.synthetic.make_scene` with isotropic 0.3 deg relative-rotation noise, clean and
    with 5 % of the edges 3 deg off; 40 views."""
    from poseonly.sfm.align import evaluate_poses
    from poseonly.sfm.rotation_averaging import average_rotations
    from poseonly.sfm.so3 import exp_so3
    from poseonly.sfm.synthetic import make_scene

    print(f"\nSparse 40-view rings, 0.3 deg isotropic edge noise, {seeds} seeds: mean rotation error (deg, rotation-only alignment)\n")
    print("| graph | GM scale 5 deg | GM scale from the data (median scale used) | ratio (mean of per-seed ratios) |")
    print("|---|---|---|---|")
    for window in (1, 2):
        for bad in (False, True):
            a, b, used = [], [], []
            for seed in range(seeds):
                sc = make_scene(40, 2400, window=window, rotation_noise_deg=0.3, seed=seed)
                Rr = sc.R_rel.copy()
                if bad:
                    rng = np.random.default_rng(seed)
                    for e in rng.choice(len(Rr), max(1, len(Rr) // 20), replace=False):
                        Rr[e] = exp_so3((np.radians(3.0) * _unit(rng))[None])[0] @ Rr[e]
                for k, s in SCALES:
                    ra = average_rotations(40, sc.pairs, Rr, sc.weights, sigma_deg=s)
                    e = float(evaluate_poses(ra.rotations, sc.centres, sc.rotations, sc.centres)["rot_mean_deg_rotalign"])
                    (a if s is not None else b).append(e)
                    if s is None:
                        used.append(float(ra.info["sigma_deg"]))
            name = f"E / N = {2 * window}{', 5 % of the edges 3 deg off' if bad else ', clean'}"
            print(f"| {name} | {np.mean(a):.4f} | {np.mean(b):.4f} ({np.median(used):.2f} deg) | {np.mean(np.array(b) / np.array(a)):.3f} |")


def strecha(path: str, cache: str) -> None:
    from poseonly.experiments.global_sfm import _gt, _scores
    from poseonly.io.strecha import load_scene
    from poseonly.sfm.pairwise import PairwiseOptions, image_view_graph
    from poseonly.sfm.pipeline import GlobalOptions, run_global

    print("\nStrecha (cached view graphs of `poseonly experiment global`): openMVG protocol / rotation-only alignment / all pairs' relative rotations (deg), positions (mm)\n")
    print("| scene | GM scale | scale used (deg) | openMVG protocol | rotation-only | all pairs | positions |")
    print("|---|---|---|---|---|---|---|")
    for name in ("Herz-Jesus-P8", "entry-P10", "fountain-P11"):
        folder = Path(path) / name
        if not folder.is_dir():
            print(f"| {name} | not found under {path} | | | | | |")
            continue
        sc = load_scene(folder)
        R_gt, C_gt = _gt(sc)
        ig = image_view_graph(sc.image_paths, sc.K, options=PairwiseOptions(max_features=8000, seed=0), cache_dir=cache)
        for k, s in SCALES:
            res = run_global(ig.graph, ig.bearings, float(sc.K[0, 0]), GlobalOptions(rotation_sigma_deg=s))
            ev = _scores(res.rotations, res.centres, R_gt, C_gt)
            print(
                f"| {name} | {k} | {res.info['rotation_sigma_deg']:.4f} | {ev['rot_mean_deg']:.4f} | {ev['rot_mean_deg_rotalign']:.4f}"
                f" | {ev['rel_rot_mean_deg']:.4f} | {1000 * ev['pos_mean']:.2f} |",
                flush=True,
            )


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seeds", type=int, default=8)
    ap.add_argument("--strecha", default=None, help="folder of the Strecha scenes (skipped if not given)")
    ap.add_argument("--cache", default="/tmp/sfm_cache")
    a = ap.parse_args(argv)
    synthetic(a.seeds)
    sparse(a.seeds)
    if a.strecha:
        strecha(a.strecha, a.cache)
    return 0


if __name__ == "__main__":
    from poseonly.experiments.report import provenance

    print(provenance(), flush=True)
    raise SystemExit(main())
