"""Wall time of the sfm pairwise stage (features, matching, two-view) on 1 and N threads, from images
with a fresh cache each run (runs alternate; medians).

    python benchmarks/sfm_pairwise_threads.py /work/shared/data/strecha/Herz-Jesus-P8/images --jobs 2 --repeats 2
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("images", help="a folder of .jpg / .png images with K.txt")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--repeats", type=int, default=2)
    ap.add_argument("--max-images", type=int, default=None)
    a = ap.parse_args(argv)
    if a.jobs < 2:
        ap.error("--jobs must be at least 2 (it is compared with one thread)")
    from poseonly.sfm.pairwise import image_view_graph

    folder = Path(a.images)
    images = sorted(p for p in folder.iterdir() if p.suffix.lower() in (".jpg", ".jpeg", ".png"))[: a.max_images]
    K = np.loadtxt(folder / "K.txt")
    walls: dict[int, list[float]] = {1: [], a.jobs: []}
    graphs = {}
    for _ in range(a.repeats):
        for jobs in (1, a.jobs):
            with tempfile.TemporaryDirectory() as d:
                t0 = time.perf_counter()
                ig = image_view_graph(images, K, cache_dir=d, jobs=jobs)
                walls[jobs].append(time.perf_counter() - t0)
            graphs[jobs] = ig.pair_stats
            stages = ", ".join(f"{k} {v:.1f} s" for k, v in ig.times_s.items())
            print(f"{jobs} thread(s): {walls[jobs][-1]:.1f} s wall (summed per-item stage times: {stages})", flush=True)
    print(f"speed-up of {a.jobs} threads (medians): {np.median(walls[1]) / np.median(walls[a.jobs]):.2f}x; the same view graph: {graphs[1] == graphs[a.jobs]}")
    return 0


if __name__ == "__main__":
    from poseonly.experiments.report import provenance

    print(provenance(), flush=True)
    raise SystemExit(main())
