"""Study: rotation averaging weighted by the two-view rotations' uncertainty, on Strecha scenes.

For every edge of a scene's view graph (``poseonly experiment global``'s cached two-view stage), the
information of its relative rotation (:func:`poseonly.sfm.edge_information.edge_informations`: the
Gauss-Newton matrix of its inliers' Sampson errors at its pose, the edge's own noise scale, the
translation marginalised); Zhang et al., "Revisiting Rotation Averaging: Uncertainties and Robust
Losses" (CVPR 2023) weight rotation averaging this way. The pipeline's IRLS
(:func:`poseonly.sfm.rotation_averaging.average_rotations`, Geman-McClure at the pipeline's scale, relinearised) is
rerun from the pipeline's averaged rotations on its inlier edges, without L1RA or outlier rounds, with
four weightings: the inlier count (the pipeline's, a check that it reproduces the pipeline), the full
3x3 information, its trace / 3 and its smallest eigenvalue; the rotation error after the best
rotation-only alignment is printed per scene. ``GlobalOptions(rotation_weights="information")`` is the
second in the pipeline (docs/SFM.md).

    python benchmarks/ra_uncertainty_study.py /work/shared/data/strecha/Herz-Jesus-P8 /work/shared/data/strecha/entry-P10
"""

from __future__ import annotations

import argparse
from pathlib import Path


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("scenes", nargs="+", help="Strecha scene folders")
    ap.add_argument("--cache", default="/tmp/sfm_cache", help="experiment global's cache")
    ap.add_argument("--max-features", type=int, default=8000)
    a = ap.parse_args(argv)
    import numpy as np

    from poseonly.experiments.global_sfm import _gt
    from poseonly.io.strecha import load_scene
    from poseonly.sfm.align import evaluate_poses
    from poseonly.sfm.edge_information import edge_informations
    from poseonly.sfm.pairwise import PairwiseOptions, image_view_graph
    from poseonly.sfm.pipeline import GlobalOptions, run_global
    from poseonly.sfm.rotation_averaging import average_rotations

    print("| scene | inlier count (pipeline) | 3x3 information | trace / 3 | smallest eigenvalue | information anisotropy, median (max / min eigenvalue) |")
    print("|---|---|---|---|---|---|")
    for path in a.scenes:
        sc = load_scene(Path(path))
        R_gt, C_gt = _gt(sc)
        ig = image_view_graph(sc.image_paths, sc.K, options=PairwiseOptions(max_features=a.max_features, seed=0), cache_dir=a.cache)
        g = ig.graph
        res = run_global(g, ig.bearings, float(sc.K[0, 0]), GlobalOptions())
        info, fallback = edge_informations(g, ig.bearings)
        if info is None or fallback.any():
            raise SystemExit(f"{sc.name}: {int(fallback.sum())} edges without an information")
        inl = res.rotation.inlier_edges
        p, Rrel, w, L = g.pairs()[inl], g.rotations()[inl], g.weights()[inl], info[inl]
        ev = np.linalg.eigvalsh(L)
        variants = {
            "count": {"weights": w},
            "full": {"weights": w, "information": L},
            "trace": {"weights": np.trace(L, axis1=1, axis2=2) / 3.0},
            "min": {"weights": ev[:, 0]},
        }
        cells = []
        for kw in variants.values():
            ra = average_rotations(g.num_views, p, Rrel, init=res.rotations, l1=False, outlier_rounds=0, sigma_deg=res.info["rotation_sigma_deg"], **kw)
            cells.append(f"{evaluate_poses(ra.rotations, res.centres, R_gt, C_gt)['rot_mean_deg_rotalign']:.4f}")
        print(f"| {sc.name} | " + " | ".join(cells) + f" | {np.median(ev[:, 2] / ev[:, 0]):.0f} |")
    return 0


if __name__ == "__main__":
    from poseonly.experiments.report import provenance

    print(provenance(), flush=True)
    raise SystemExit(main())
