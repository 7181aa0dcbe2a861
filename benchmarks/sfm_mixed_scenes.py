"""Several scenes in one unordered image set: the models ``poseonly sfm`` builds from it.

    python benchmarks/sfm_mixed_scenes.py DIR [DIR ...] [--max-features 8000] [--cache /tmp/sfm_cache]

Takes the images of the Strecha-style folders (``DIR/images/*.jpg``, one shared ``K.txt``) as one set,
matches all pairs (:func:`poseonly.sfm.pairwise.image_view_graph`, the ``poseonly sfm`` defaults), and
runs :func:`poseonly.sfm.pipeline.run_global_models`. Prints the edges kept within and across scenes,
and for every model the scenes of its images and, per scene, the accuracy after a similarity
alignment to that scene's ground truth (openMVG's protocol, :func:`poseonly.sfm.align.evaluate_poses`),
beside ``run_global`` on the scene's own images (the ``poseonly experiment global`` row).
"""

from __future__ import annotations

import argparse
import collections
from pathlib import Path

import numpy as np


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("dirs", nargs="+")
    ap.add_argument("--max-features", type=int, default=8000)
    ap.add_argument("--cache", default="/tmp/sfm_cache")
    ap.add_argument("--joint-variants", action="store_true", help="rerun each joint model: no reprojection filter, only bridges of >= 100 inliers, LiGT not reweighted")
    a = ap.parse_args(argv)
    from poseonly.io.strecha import load_scene
    from poseonly.sfm.align import evaluate_poses
    from poseonly.sfm.pairwise import PairwiseOptions, image_view_graph
    from poseonly.sfm.pipeline import GlobalOptions, run_global, run_global_models

    scenes = [load_scene(Path(d)) for d in a.dirs]
    images: list[Path] = []
    scene_of: list[int] = []
    for k, sc in enumerate(scenes):
        images += list(sc.image_paths)
        scene_of += [k] * len(sc.image_paths)
        if not np.allclose(sc.K, scenes[0].K):
            raise SystemExit("the scenes must share one calibration")
    so = np.array(scene_of)
    R_gt = np.concatenate([np.array([c.R_cw.T for c in sc.cameras]) for sc in scenes])
    C_gt = np.concatenate([np.array([c.C for c in sc.cameras]) for sc in scenes])
    opt = PairwiseOptions(max_features=a.max_features)
    ig = image_view_graph(images, scenes[0].K, options=opt, cache_dir=a.cache)
    p = ig.graph.pairs()
    across = so[p[:, 0]] != so[p[:, 1]]
    print(f"{len(images)} images of {len(scenes)} scenes; {len(ig.graph)} edges kept ({int(across.sum())} across scenes), {len(ig.graph.rejected)} pairs rejected")
    for e in np.flatnonzero(across):
        ed = ig.graph.edges[e]
        print(f"  edge across scenes: {images[ed.i].parent.parent.name}/{images[ed.i].name} - {images[ed.j].parent.parent.name}/{images[ed.j].name}, {len(ed.matches)} inliers")
    focal = float(scenes[0].K[0, 0])
    models = run_global_models(ig.graph, ig.bearings, focal)
    print()
    print("| model | scene | images posed / in scene | rot mean (deg) | rot mean, rot-only align | pos mean (m) | the scene alone: rot mean / rot-only / pos mean |")
    print("|---|---|---|---|---|---|---|")
    for k, res in enumerate(models):
        posed = np.all(np.isfinite(res.centres), axis=1)
        counts = collections.Counter(so[posed].tolist())
        for s, cnt in sorted(counts.items()):
            sel = posed & (so == s)
            ev = evaluate_poses(res.rotations[sel], res.centres[sel], R_gt[sel], C_gt[sel]) if cnt >= 3 else None
            own = so == s
            alone = run_global(ig.graph.subgraph(own[p[:, 0]] & own[p[:, 1]]), ig.bearings, focal)
            ea = evaluate_poses(alone.rotations[own], alone.centres[own], R_gt[own], C_gt[own])
            row = [f"{ev['rot_mean_deg']:.4f}", f"{ev['rot_mean_deg_rotalign']:.4f}", f"{ev['pos_mean']:.4f}"] if ev else ["", "", ""]
            alone_row = f"{ea['rot_mean_deg']:.4f} / {ea['rot_mean_deg_rotalign']:.4f} / {ea['pos_mean']:.4f}"
            print(f"| {k} | {scenes[s].name} | {cnt} / {int(own.sum())} | " + " | ".join(row) + f" | {alone_row} |")
    if a.joint_variants:
        print()
        print("| model | variant | scene | rot mean (deg) | rot mean, rot-only align | pos mean (m) |")
        print("|---|---|---|---|---|---|")
        for k, res in enumerate(models):
            posed = np.all(np.isfinite(res.centres), axis=1)
            if len(set(so[posed].tolist())) < 2:
                continue
            em = posed[p[:, 0]] & posed[p[:, 1]]
            strong = em & (~across | np.array([len(e.matches) >= 100 for e in ig.graph.edges]))
            variants = (
                ("no reprojection filter", em, GlobalOptions(filter_rounds=0)),
                ("bridges of >= 100 inliers only", strong, GlobalOptions()),
                ("LiGT not reweighted (ligt_reweight=0, before the ninth session)", em, GlobalOptions(ligt_reweight=0)),
            )
            for name, mask, gopt in variants:
                v = run_global(ig.graph.subgraph(mask), ig.bearings, focal, gopt)
                for s in sorted(set(so[posed].tolist())):
                    sel = (so == s) & np.all(np.isfinite(v.centres), axis=1)
                    ev = evaluate_poses(v.rotations[sel], v.centres[sel], R_gt[sel], C_gt[sel])
                    print(f"| {k} | {name} | {scenes[s].name} | {ev['rot_mean_deg']:.4f} | {ev['rot_mean_deg_rotalign']:.4f} | {ev['pos_mean']:.4f} |")
    return 0


if __name__ == "__main__":
    from poseonly.experiments.report import provenance

    print(provenance(), flush=True)
    raise SystemExit(main())
