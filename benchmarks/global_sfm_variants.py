"""Where the global pipeline's error comes from (docs/SFM.md "Not done"): on each shared Strecha
scene's cached view graph (the `poseonly experiment global` cache), the global stages with a few
option variants, rotation averaging with the edges weighted by the inverse trace of their two-view
rotation covariance (Sampson least squares on the edge's inliers at its pose, sigma^2 (J^T J)^-1)
instead of their inlier counts, and LiGT on the same tracks with the ground-truth rotations.

    python benchmarks/global_sfm_variants.py [/work/shared/data/strecha] [--cache /tmp/sfm_cache]

Prints the openMVG-protocol rotation error, the rotation-only-aligned rotation error, the mean
position error (m) and the mean relative rotation error of all pairs per variant.
"""

from __future__ import annotations

import argparse
import dataclasses
from pathlib import Path

import numpy as np

from poseonly import _core
from poseonly.experiments.global_sfm import _gt, _scores
from poseonly.geometry import bearings_from_pixels
from poseonly.io.strecha import load_scene
from poseonly.sfm.ligt_global import ligt_positions
from poseonly.sfm.pairwise import PairwiseOptions, image_view_graph
from poseonly.sfm.pipeline import GlobalOptions, run_global

SCENES = ("Herz-Jesus-P8", "entry-P10", "fountain-P11")
VARIANTS: tuple[dict, ...] = ({}, {"ligt_reweight": 3}, {"max_error_px": 2.0}, {"max_error_px": 1.0, "filter_rounds": 4}, {"min_track_length": 3})


def covariance_weights(ig) -> list[float]:
    """Per edge of ``ig.graph``: 1 / trace of the rotation block of ``sigma^2 (J^T J)^-1``, J the
    Sampson residuals' Jacobian on the edge's inliers at its pose (the core's chart), sigma^2 their
    mean square (5 parameters)."""
    out = []
    for e in ig.graph.edges:
        f1 = bearings_from_pixels(ig.features[e.i].keypoints[e.matches[:, 0]], ig.K[e.i])
        f2 = bearings_from_pixels(ig.features[e.j].keypoints[e.matches[:, 1]], ig.K[e.j])
        r, J = _core._refine_residuals(0, e.R, e.t, np.ascontiguousarray(f1), np.ascontiguousarray(f2), np.zeros(5))
        J = J.reshape(-1, 5)
        s2 = float(np.sum(r**2)) / max(len(r) - 5, 1)
        cov = s2 * np.linalg.inv(J.T @ J)
        out.append(1.0 / float(np.trace(cov[:3, :3])))
    return out


def _short(ev: dict) -> str:
    return " ".join(f"{k}={ev[k]:.4f}" for k in ("rot_mean_deg", "rot_mean_deg_rotalign", "pos_mean", "rel_rot_mean_deg"))


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("path", nargs="?", default="/work/shared/data/strecha")
    p.add_argument("--cache", default="/tmp/sfm_cache")
    a = p.parse_args(argv)
    for name in SCENES:
        folder = Path(a.path) / name
        if not folder.is_dir():
            print(f"{name}: not found under {a.path}, skipped")
            continue
        sc = load_scene(folder)
        R_gt, C_gt = _gt(sc)
        ig = image_view_graph(sc.image_paths, sc.K, options=PairwiseOptions(max_features=8000, seed=0), cache_dir=a.cache)
        res = None
        for kw in VARIANTS:
            res = run_global(ig.graph, ig.bearings, float(sc.K[0, 0]), GlobalOptions(**kw))
            print(name, kw, _short(_scores(res.rotations, res.centres, R_gt, C_gt)), flush=True)
        assert res is not None
        edges = [dataclasses.replace(e, weight=w) for e, w in zip(ig.graph.edges, covariance_weights(ig), strict=True)]
        res_cov = run_global(dataclasses.replace(ig.graph, edges=edges, _index={}), ig.bearings, float(sc.K[0, 0]), GlobalOptions())
        print(name, "rotation averaging weighted by 1 / trace(two-view rotation covariance)", _short(_scores(res_cov.rotations, res_cov.centres, R_gt, C_gt)), flush=True)
        lg = ligt_positions(R_gt, res.tracks, res.bearings)
        print(name, "LiGT with the ground-truth rotations", _short(_scores(R_gt, lg.centres, R_gt, C_gt)), flush=True)
    return 0


if __name__ == "__main__":
    from poseonly.experiments.report import provenance

    print(provenance(), flush=True)
    raise SystemExit(main())
