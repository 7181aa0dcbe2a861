"""Measured, not adopted (docs/SFM.md): global rotations refined on the tracks' Sampson errors with the
LiGT centres fixed, then LiGT again, on the three shared Strecha scenes' cached view graphs.

    python benchmarks/rotation_refine_study.py
"""
import sys
from pathlib import Path
from poseonly.experiments.global_sfm import _gt, _scores
from poseonly.io.strecha import load_scene
from poseonly.sfm.pairwise import PairwiseOptions, image_view_graph
from poseonly.sfm.pipeline import GlobalOptions, run_global
V = [{}, {"rotation_refine_rounds": 1}, {"rotation_refine_rounds": 2}, {"rotation_refine_rounds": 4}, {"rotation_refine_rounds": 1, "rotation_refine_pairs": "tracks"}, {"rotation_refine_rounds": 3, "rotation_refine_pairs": "tracks"}]
for name in ("Herz-Jesus-P8", "entry-P10", "fountain-P11"):
    sc = load_scene(Path("/work/shared/data/strecha") / name)
    R_gt, C_gt = _gt(sc)
    ig = image_view_graph(sc.image_paths, sc.K, options=PairwiseOptions(max_features=8000, seed=0), cache_dir="/tmp/sfm_cache")
    for kw in V:
        res = run_global(ig.graph, ig.bearings, float(sc.K[0, 0]), GlobalOptions(**kw))
        ev = _scores(res.rotations, res.centres, R_gt, C_gt)
        print(name, kw, " ".join(f"{k}={ev[k]:.4f}" for k in ("rot_mean_deg", "rot_mean_deg_rotalign", "pos_mean", "rel_rot_mean_deg")), {k: v for k, v in res.info.items() if k.startswith("rotation_refine")}.get("rotation_refine_1"), f"{res.times_s.get('rotation_refine', 0):.2f}s", flush=True)
