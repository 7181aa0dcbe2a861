"""Memory of the pairwise stage (features, matching, two-view) of ``poseonly sfm`` by pair list.

    python benchmarks/pairwise_memory.py DIR [DIR ...] [--max-features 8000] [--sequential 2]
        [--resident 4] [--out docs/results/pairwise_memory.md]

Takes every image of the Strecha-style folders ``DIR/images/*.jpg`` with ``DIR/images/K.txt`` (one
sequence, in folder then name order). The features are extracted once into a shared cache before
the timers; each configuration then runs :func:`poseonly.sfm.pairwise.image_view_graph` in a fresh
subprocess with a copy of that feature cache and an empty match cache (so every pair is matched and
estimated), and reports its wall time, the peak RSS of the process (descriptors,
matching buffers, the two-view results; ``VmHWM`` of ``/proc/self/status``, Linux) and ``peak_resident_images`` (the most images whose
descriptors were in memory at once). Configurations: all pairs (every image's descriptors held, as
before the pool), all pairs with ``resident_images = --resident`` (read back from the cache), and
``--sequential N`` (each image with its next N).
"""

from __future__ import annotations

import argparse
import json
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

CHILD = r"""
import json, sys, time
import numpy as np
from poseonly.sfm.pairwise import PairwiseOptions, image_view_graph
a = json.loads(sys.argv[1])
t0 = time.perf_counter()
ig = image_view_graph(a["images"], np.array(a["K"]), options=PairwiseOptions(max_features=a["max_features"]),
                      cache_dir=a["cache"], pairs=a["pairs"], **({"resident_images": a["resident"]} if a["resident"] else {}))
wall = time.perf_counter() - t0
hwm = [l for l in open("/proc/self/status") if l.startswith("VmHWM:")]  # this process's peak RSS (ru_maxrss keeps the parent's across exec)
print(json.dumps({"wall_s": wall, "peak_rss_mb": int(hwm[0].split()[1]) / 1024,
                  "peak_resident_images": ig.peak_resident_images, "edges": len(ig.graph), "pairs": len(ig.pair_stats),
                  "features_s": ig.times_s["features"], "matching_s": ig.times_s["matching"], "two_view_s": ig.times_s["two_view"]}))
"""


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("dirs", nargs="+")
    ap.add_argument("--max-features", type=int, default=8000)
    ap.add_argument("--sequential", type=int, default=2)
    ap.add_argument("--resident", type=int, default=4)
    ap.add_argument("--out", default=None)
    a = ap.parse_args(argv)
    import numpy as np

    from poseonly.sfm.pairwise import PairwiseOptions, image_view_graph

    images: list[str] = []
    Ks: list[list[list[float]]] = []
    for d in a.dirs:
        im = sorted((Path(d) / "images").glob("*.jpg"))
        K = np.loadtxt(Path(d) / "images" / "K.txt")
        images += [str(p) for p in im]
        Ks += [K.tolist()] * len(im)
    n = len(images)
    work = Path(tempfile.mkdtemp(prefix="pairwise_memory_"))
    try:
        t0 = time.perf_counter()
        # extract once (one pair per image: the features land in the shared cache)
        image_view_graph(images, np.array(Ks), options=PairwiseOptions(max_features=a.max_features), cache_dir=work / "shared", pairs=[(i, i + 1) for i in range(n - 1)])
        print(f"{n} images, features extracted in {time.perf_counter() - t0:.1f} s", flush=True)
        all_pairs = [(i, j) for i in range(n) for j in range(i + 1, n)]
        seq = [(i, j) for i in range(n) for j in range(i + 1, min(n, i + 1 + a.sequential))]
        configs = [("all pairs", all_pairs, None), (f"all pairs, resident_images {a.resident}", all_pairs, a.resident), (f"sequential {a.sequential}", seq, None)]
        rows = []
        for name, pairs, resident in configs:
            cache = work / f"c{len(rows)}"
            shutil.copytree(work / "shared" / "features", cache / "features")
            arg = json.dumps({"images": images, "K": Ks, "max_features": a.max_features, "cache": str(cache), "pairs": pairs, "resident": resident})
            out = subprocess.run([sys.executable, "-c", CHILD, arg], check=True, capture_output=True, text=True).stdout
            r = json.loads(out.strip().splitlines()[-1])
            rows.append((name, r))
            print(name, r, flush=True)
            shutil.rmtree(cache)
    finally:
        shutil.rmtree(work, ignore_errors=True)
    lines = [
        f"# Pairwise stage memory ({n} images, {a.max_features} features; `python benchmarks/pairwise_memory.py {' '.join(a.dirs)}`)",
        "",
        "| pairs | pairs matched | wall s | peak RSS MB | images with descriptors in memory at once | reading features s | matching s | two-view s |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for name, r in rows:
        cells = [name, r["pairs"], f"{r['wall_s']:.1f}", f"{r['peak_rss_mb']:.0f}", r["peak_resident_images"]]
        cells += [f"{r[k]:.1f}" for k in ("features_s", "matching_s", "two_view_s")]
        lines.append("| " + " | ".join(str(c) for c in cells) + " |")
    text = "\n".join(lines) + "\n"
    print(text)
    if a.out:
        Path(a.out).write_text(text)
    return 0


if __name__ == "__main__":
    from poseonly.experiments.report import provenance

    print(provenance(), flush=True)
    raise SystemExit(main())
