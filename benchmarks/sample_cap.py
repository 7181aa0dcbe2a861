"""The two-view search's sample cap on an all-pairs image set, with match scores as ``poseonly sfm``
passes them: the default ``max_iterations`` (100000, PoseLib's) against a lower cap (COLMAP's
two-view verification uses 10000).

    python benchmarks/sample_cap.py DIR [DIR ...] [--caps 100000 10000] [--max-features 8000] [--cache /tmp/sample_cap_cache] [--no-scores]

Takes the images of the Strecha-style folders as one set (``DIR/images/*.jpg``, one ``K.txt``),
matches all pairs once (features and matches cached), then runs the pairwise stage of ``poseonly
sfm`` (:func:`poseonly.sfm.pairwise.image_view_graph`: ratio scores, keypoint sizes, one thread) once
per cap with ``estimator_options=(("max_iterations", cap),)`` and an empty two-view cache. Prints per
cap the two-view stage's time, the statuses, the rotation error of the kept (``ok``) edges within one
scene against the ground truth (median, largest, count above 5 deg) and the edges kept across scenes;
then the pairs whose status differs between the caps. ``--no-scores``: the pairs estimated without the
ratio scores (uniform sampling), as ``poseonly colmap verify`` and ``poseonly sfm --database`` estimate
them (a COLMAP database stores no match scores).
"""

from __future__ import annotations

import argparse
import collections
import shutil
from pathlib import Path

import numpy as np


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("dirs", nargs="+")
    ap.add_argument("--caps", type=int, nargs="+", default=[100000, 10000])
    ap.add_argument("--max-features", type=int, default=8000)
    ap.add_argument("--cache", default="/tmp/sample_cap_cache")
    ap.add_argument("--no-scores", action="store_true", help="estimate without the ratio scores (uniform sampling)")
    a = ap.parse_args(argv)
    from poseonly.geometry import rotation_error_deg
    from poseonly.io.strecha import load_scene
    from poseonly.sfm.pairwise import PairwiseOptions, image_view_graph

    scenes = [load_scene(Path(d)) for d in a.dirs]
    images: list[Path] = []
    scene_of: list[int] = []
    R_gt: list[np.ndarray] = []
    for k, sc in enumerate(scenes):
        images += list(sc.image_paths)
        scene_of += [k] * len(sc.image_paths)
        R_gt += [c.R_cw.T for c in sc.cameras]  # world -> camera
    K = scenes[0].K
    cache = Path(a.cache)
    image_view_graph(images, K, options=PairwiseOptions(max_features=a.max_features), cache_dir=cache)  # features and matches, once
    shutil.rmtree(cache / "twoview", ignore_errors=True)
    stats: dict[int, dict[tuple[int, int], str]] = {}
    how = "without scores (uniform sampling), as colmap verify and sfm --database do" if a.no_scores else "with the ratio scores (PROSAC), as poseonly sfm does"
    print(f"{len(images)} images; every pair estimated {how}, with the keypoint sizes as noise scales")
    print()
    print("| max_iterations | two-view s | ok | ok within a scene: median / largest R err (deg), > 5 deg | too_few_inliers | other | edges across scenes |")
    print("|---|---|---|---|---|---|---|")
    for cap in a.caps:
        ig = image_view_graph(
            images, K, options=PairwiseOptions(max_features=a.max_features, use_scores=not a.no_scores, estimator_options=(("max_iterations", cap),)), cache_dir=cache
        )
        st = {(i, j): s for i, j, _, _, s in ig.pair_stats}
        stats[cap] = st
        c = collections.Counter(st.values())
        errs = []
        across = 0
        for e in ig.graph.edges:
            if scene_of[e.i] != scene_of[e.j]:
                across += 1
                continue
            errs.append(float(rotation_error_deg(R_gt[e.j] @ R_gt[e.i].T, e.R)))
        er = np.array(errs)
        err_s = f"{np.median(er):.3f} / {er.max():.2f}, {int(np.sum(er > 5))}" if er.size else "-"
        other = sum(c.values()) - c["ok"] - c["too_few_inliers"]
        print(f"| {cap} | {ig.times_s.get('two_view', float('nan')):.1f} | {c['ok']} | {err_s} | {c['too_few_inliers']} | {other} | {across} |")
    base = a.caps[0]
    for cap in a.caps[1:]:
        flips = [(p, stats[base][p], stats[cap].get(p)) for p in stats[base] if stats[cap].get(p) != stats[base][p]]
        print(f"\nstatus at {base} -> {cap}: {len(flips)} pairs differ: {dict(collections.Counter((b, c) for _, b, c in flips))}")
        for (i, j), b, c in flips:
            print(f"  {images[i].parent.parent.name}/{images[i].name} - {images[j].parent.parent.name}/{images[j].name}: {b} -> {c}")
    return 0


if __name__ == "__main__":
    from poseonly.experiments.report import provenance

    print(provenance(), flush=True)
    raise SystemExit(main())
