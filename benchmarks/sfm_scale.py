"""Scale of the global stages: time and peak memory of rotation averaging and LiGT as the view
graph grows (issue 15, "10k cameras and 1M observations").

    PYTHONPATH=src python benchmarks/sfm_scale.py [--views 1000 2000 5000 10000] [--obs-per-view 100]
        [--outliers 0.1] [--stages rotation_averaging ligt ligt_averaged pipeline] [--normalization noise|unit] [--reweight N]
        [--seed 0] [--out docs/results/sfm_scale.json]

``ligt`` runs LiGT from the true rotations (its own error), ``ligt_averaged`` from rotation averaging's
(run before the timer: the pipeline's error); ``pipeline`` runs the whole of
:func:`poseonly.sfm.pipeline.run_global` (rotation averaging, tracks, LiGT, points, the filter rounds) on
the scene's view graph (:func:`poseonly.sfm.synthetic.scene_view_graph`, built before the timer).

Each (size, stage) runs in a fresh subprocess: the synthetic scene (:func:`poseonly.sfm.synthetic.make_scene`,
ring of cameras, window 5, 0.5 px bearing noise, 0.3 deg relative-rotation noise, 10 % outlier
edges) is generated first, then the peak RSS is reset (``/proc/self/clear_refs``, Linux) and the
stage is timed; the reported memory is the peak RSS during the stage (``VmHWM``), which includes
the scene held in memory. Growth exponents are least-squares slopes of log(time) and log(memory)
against log(observations). The machine is shared: label the numbers as measured under load unless
it was idle.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from poseonly.sfm.choices import LIGT_REWEIGHT

TRACK_LENGTH_MEAN = 3.2  # measured mean track length of make_scene(window=5, max_track=6)


def _vm(key: str) -> float:
    with open("/proc/self/status") as fh:
        for line in fh:
            if line.startswith(key):
                return float(line.split()[1]) / 1024.0  # MiB
    return float("nan")


def _child(stage: str, n: int, obs_per_view: int, outliers: float, seed: int, normalization: str, reweight: int = LIGT_REWEIGHT) -> dict:
    from poseonly.sfm import average_rotations, ligt_positions
    from poseonly.sfm.align import evaluate_poses
    from poseonly.sfm.pipeline import GlobalOptions, run_global
    from poseonly.sfm.synthetic import make_scene, scene_view_graph

    s = make_scene(n, int(n * obs_per_view / TRACK_LENGTH_MEAN), noise_px=0.5, rotation_noise_deg=0.3, outlier_fraction=outliers, seed=seed)
    # "ligt" runs from the true rotations, "ligt_averaged" from rotation averaging's (untimed)
    R_ligt = average_rotations(n, s.pairs, s.R_rel, s.weights).rotations if stage == "ligt_averaged" else s.rotations
    # "pipeline": run_global on the scene's view graph (built before the timer) and its bearings
    graph = scene_view_graph(s) if stage == "pipeline" else None
    rss_before = _vm("VmRSS")
    try:
        with open("/proc/self/clear_refs", "w") as fh:
            fh.write("5")
    except OSError:
        pass
    t0 = time.perf_counter()
    if stage == "rotation_averaging":
        ra = average_rotations(n, s.pairs, s.R_rel, s.weights)
        extra = {"outliers_found": len(ra.outlier_edges), "outliers_true": int(s.outlier.sum()), "times_s": ra.times_s}
        extra.update(sigma_deg=ra.info["sigma_deg"], irls_iterations=ra.info["irls_iterations"])
    elif stage == "pipeline":
        assert graph is not None
        res = run_global(graph, lambda tr: s.bearings[tr.keypoints], s.focal, GlobalOptions(ligt_reweight=reweight, ligt_normalization=normalization))
        extra = {"times_s": res.times_s, "points_valid": res.reconstruction.num_valid, "outliers_found": len(res.rotation.outlier_edges), "outliers_true": int(s.outlier.sum())}
    else:
        lg = ligt_positions(R_ligt, s.tracks, s.bearings, normalization=normalization, reweight_iterations=reweight)
        extra = {"normalization": normalization, "reweight": reweight, "times_s": lg.times_s, "rows": lg.info["rows"], "nnz_H": lg.info["nnz_H"], "eig_ratio": lg.info["eig_ratio"]}
    dt = time.perf_counter() - t0
    if stage == "rotation_averaging":
        # the accuracy too: the mean rotation error after the rotation-only alignment (a wrong start
        # once left this graph's 10000-view ring 89 deg off in the mean, in the same time and memory)
        extra["rot_mean_deg_rotalign"] = float(evaluate_poses(ra.rotations, s.centres, s.rotations, s.centres)["rot_mean_deg_rotalign"])
    elif stage == "pipeline":
        ev = evaluate_poses(res.rotations, res.centres, s.rotations, s.centres)
        extra.update(rot_mean_deg_rotalign=float(ev["rot_mean_deg_rotalign"]), pos_mean_frac=float(ev["pos_mean_frac"]), views_posed=int(ev["num_estimated"]))
    else:
        # LiGT from the true rotations: the mean position error after the similarity alignment, over the
        # largest distance of a true centre from their mean
        extent = float(np.max(np.linalg.norm(s.centres - s.centres.mean(axis=0), axis=1)))
        extra["pos_mean_frac"] = float(evaluate_poses(R_ligt, lg.centres, s.rotations, s.centres)["pos_mean"]) / extent
    return {
        "stage": stage,
        "views": n,
        "edges": len(s.pairs),
        "tracks": len(s.tracks),
        "observations": s.tracks.num_observations,
        "time_s": dt,
        "rss_before_mib": rss_before,
        "peak_rss_mib": _vm("VmHWM"),
        **extra,
    }


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--views", type=int, nargs="+", default=[1000, 2000, 5000, 10000])
    p.add_argument("--obs-per-view", type=int, default=100)
    p.add_argument("--outliers", type=float, default=0.1)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--stages", nargs="+", default=["rotation_averaging", "ligt"], choices=("rotation_averaging", "ligt", "ligt_averaged", "pipeline"))
    p.add_argument("--normalization", default="noise", choices=("noise", "unit"), help="LiGT's scale normalisation (ligt_positions)")
    p.add_argument("--reweight", type=int, default=LIGT_REWEIGHT, help="LiGT's reweighting rounds (ligt_positions' reweight_iterations; GlobalOptions.ligt_reweight)")
    p.add_argument("--out", default="sfm_scale.json", help="JSON report (default sfm_scale.json in the working directory; the committed ones are under docs/results/)")
    p.add_argument("--child", nargs=2, metavar=("STAGE", "VIEWS"), help=argparse.SUPPRESS)
    a = p.parse_args(argv)
    if a.child:
        print(json.dumps(_child(a.child[0], int(a.child[1]), a.obs_per_view, a.outliers, a.seed, a.normalization, a.reweight)))
        return 0
    rows = []
    env = {**os.environ, "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}
    for n in a.views:
        for st in a.stages:
            r = subprocess.run(
                [sys.executable, __file__, "--child", st, str(n), "--obs-per-view", str(a.obs_per_view), "--outliers", str(a.outliers)]
                + ["--seed", str(a.seed), "--normalization", a.normalization, "--reweight", str(a.reweight)],
                capture_output=True,
                text=True,
                env=env,
                check=False,
            )
            if r.returncode != 0:
                print(r.stderr[-2000:], file=sys.stderr)
                return 1
            row = json.loads(r.stdout.strip().splitlines()[-1])
            rows.append(row)
            print(
                f"{st:20s} views {n:6d} obs {row['observations']:8d} edges {row['edges']:7d}: "
                f"{row['time_s']:8.2f} s, peak RSS {row['peak_rss_mib']:8.1f} MiB (scene {row['rss_before_mib']:.0f} MiB)"
                + (
                    f", rotation error {row['rot_mean_deg_rotalign']:.3f} deg, outliers {row['outliers_found']} / {row['outliers_true']}"
                    if st == "rotation_averaging"
                    else f", {row['views_posed']} views posed, rotation error {row['rot_mean_deg_rotalign']:.3f} deg, position error "
                    f"{100 * row['pos_mean_frac']:.2f} % of the extent, {row['points_valid']} points; stages " + ", ".join(f"{k} {v:.1f} s" for k, v in row["times_s"].items())
                    if st == "pipeline"
                    else f", position error {100 * row['pos_mean_frac']:.2f} % of the extent, smallest / second eigenvalue {row['eig_ratio']:.3f}"
                ),
                flush=True,
            )
    growth = {}
    for st in a.stages:
        rr = [r for r in rows if r["stage"] == st]
        if len(rr) >= 2:
            x = np.log([r["observations"] for r in rr])
            growth[st] = {
                "time_exponent": float(np.polyfit(x, np.log([r["time_s"] for r in rr]), 1)[0]),
                "memory_exponent": float(np.polyfit(x, np.log([r["peak_rss_mib"] for r in rr]), 1)[0]),
            }
    for st, g in growth.items():
        print(f"{st}: time ~ obs^{g['time_exponent']:.2f}, peak memory ~ obs^{g['memory_exponent']:.2f}")
    Path(a.out).parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(a.out).with_suffix(".tmp")
    tmp.write_text(json.dumps({"rows": rows, "growth": growth, "argv": sys.argv[1:], "load_average": os.getloadavg()}, indent=1))
    tmp.replace(a.out)
    return 0


if __name__ == "__main__":
    from poseonly.experiments.report import provenance

    print(provenance(), flush=True)
    sys.exit(main())
