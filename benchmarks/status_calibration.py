"""Status calibration of ``poseonly.estimate_relative_pose``: how often is ``ok`` said wrongly?

Two experiments (issue 14):

1. **Random matches** (no pose at all): ``n`` uniform pixels in each of two 640x480 images with
   ``K = poseonly.sim.default_K()`` ("pixels"), or ``n`` uniform random unit bearings in each view
   ("bearings", ``focal_px = 800``). Every ``ok`` is a false alarm. Target: at most 1 in 1000 draws
   at every ``n`` (0 in the committed run).
2. **Pure rotation** (``t = 0``, ``poseonly.sim.make_scene(kind="rotation")``, pinhole, 0.5 px
   noise) with 0-80 % outliers. Every ``ok`` is wrong (the translation is undetermined); the status
   should be ``pure_rotation``. Targets: ``ok`` in 0 of 500, ``pure_rotation`` in >= 95 %.

3. (``--parts genuine``) **Genuine poses**, the power side: normal scenes, pinhole, 0.5 px noise,
   the ``--outliers`` ratios; counts ``ok`` with a rotation error below 1 deg as right.

Every draw has its own seed (``SEED_BASE + draw``); the estimator runs with its default options
except ``max_iterations`` (``--max-iterations``; default the library's own 100000). The a-contrario
test counts the hypotheses actually tried, so a lower cap changes the bound, not its validity.

    python benchmarks/status_calibration.py --out docs/results/status_calibration.md

Writes a markdown table (atomically) and prints it. Slow at the default cap (tens of seconds per
random-match draw at n >= 200 on a loaded 2-core machine); ``--draws``/``--rotation-draws`` reduce it.
"""

from __future__ import annotations

import argparse
import sys
import time
from collections import Counter
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

SEED_BASE = 1_000_000
IMAGE_SIZE = (640, 480)
BEARING_FOCAL = 800.0


def _random_case(kind: str, n: int, seed: int, max_iterations: int | None) -> str:
    import poseonly
    from poseonly.sim import default_K

    rng = np.random.default_rng(seed)
    opts = {} if max_iterations is None else {"max_iterations": max_iterations, "min_iterations": min(50, max_iterations)}
    if kind == "pixels":
        K = default_K()
        u1 = rng.uniform((0, 0), IMAGE_SIZE, (n, 2))
        u2 = rng.uniform((0, 0), IMAGE_SIZE, (n, 2))
        r = poseonly.estimate_relative_pose(u1, u2, K, seed=seed, **opts)
    else:
        f1 = rng.standard_normal((n, 3))
        f2 = rng.standard_normal((n, 3))
        r = poseonly.estimate_relative_pose(f1, f2, focal_px=BEARING_FOCAL, seed=seed, **opts)
    return r.status


def _rotation_case(n: int, outliers: float, seed: int, max_iterations: int | None) -> str:
    import poseonly
    from poseonly.sim import make_scene

    opts = {} if max_iterations is None else {"max_iterations": max_iterations, "min_iterations": min(50, max_iterations)}
    sc = make_scene(n, "rotation", camera="pinhole", noise_px=0.5, outlier_fraction=outliers, seed=seed)
    return poseonly.estimate_relative_pose(sc.u1, sc.u2, sc.K, seed=seed, **opts).status


def _genuine_case(n: int, outliers: float, seed: int, max_iterations: int | None) -> str:
    import poseonly
    from poseonly.sim import make_scene

    opts = {} if max_iterations is None else {"max_iterations": max_iterations, "min_iterations": min(50, max_iterations)}
    sc = make_scene(n, "normal", camera="pinhole", noise_px=0.5, outlier_fraction=outliers, seed=seed)
    r = poseonly.estimate_relative_pose(sc.u1, sc.u2, sc.K, seed=seed, **opts)
    good = r.R is not None and float(poseonly.rotation_error_deg(sc.R, r.R)) < 1.0
    return f"{r.status}{'' if good else '-wrong'}"


def _run(fn, jobs: list[tuple], workers: int) -> list[str]:
    if workers <= 1:
        return [fn(*j) for j in jobs]
    with ProcessPoolExecutor(workers) as ex:
        return list(ex.map(fn, *zip(*jobs), chunksize=4))


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--sizes", type=int, nargs="+", default=[30, 100, 300, 1000, 3000, 20000])
    p.add_argument("--draws", type=int, default=200, help="random-match draws per size and kind")
    p.add_argument("--large", type=int, default=None, help="sizes >= this use --draws-large draws")
    p.add_argument("--draws-large", type=int, default=None)
    p.add_argument("--rotation-n", type=int, default=200)
    p.add_argument("--outliers", type=float, nargs="+", default=[0.0, 0.2, 0.4, 0.6, 0.8])
    p.add_argument("--rotation-draws", type=int, default=100, help="draws per outlier ratio")
    p.add_argument("--max-iterations", type=int, default=None, help="RANSAC cap (default: the library's)")
    p.add_argument("--workers", type=int, default=1)
    p.add_argument(
        "--parts",
        nargs="+",
        choices=("random", "rotation", "genuine"),
        default=["random", "rotation"],
        help="genuine: the power side (ok rate on real poses, pinhole, 0.5 px, --outliers)",
    )
    p.add_argument("--out", type=Path, default=None)
    a = p.parse_args(argv)
    if a.draws < 1 or a.rotation_draws < 1 or a.workers < 1 or any(n < 6 for n in a.sizes):
        p.error("draws, rotation-draws and workers must be >= 1 and sizes >= 6")
    t0 = time.perf_counter()
    rows = []
    for kind in ("pixels", "bearings") if "random" in a.parts else ():
        for n in a.sizes:
            draws = a.draws_large if (a.large is not None and a.draws_large and n >= a.large) else a.draws
            st = Counter(_run(_random_case, [(kind, n, SEED_BASE + d, a.max_iterations) for d in range(draws)], a.workers))
            amb = st["planar_ambiguous"] + st["ambiguous"] + st["uncertain"]
            rows.append(f"| random {kind} | {n} | {draws} | {st['ok']} | {st['too_few_inliers']} | {st['pure_rotation']} | {amb} | {st['degenerate']} |")
            print(rows[-1], flush=True)
    rot_rows = []
    for w in a.outliers if "rotation" in a.parts else ():
        st = Counter(_run(_rotation_case, [(a.rotation_n, w, SEED_BASE + d, a.max_iterations) for d in range(a.rotation_draws)], a.workers))
        rot_rows.append(
            f"| {100 * w:.0f} % | {a.rotation_n} | {a.rotation_draws} | {st['ok']} | {st['pure_rotation']} "
            f"({100 * st['pure_rotation'] / a.rotation_draws:.1f} %) | {st['too_few_inliers']} | "
            f"{st['planar_ambiguous'] + st['ambiguous'] + st['uncertain'] + st['degenerate']} |"
        )
        print(rot_rows[-1], flush=True)
    gen_rows = []
    for w in a.outliers if "genuine" in a.parts else ():
        st = Counter(_run(_genuine_case, [(a.rotation_n, w, SEED_BASE + d, a.max_iterations) for d in range(a.rotation_draws)], a.workers))
        wrong = sum(v for k, v in st.items() if k.endswith("-wrong"))
        gen_rows.append(
            f"| {100 * w:.0f} % | {a.rotation_n} | {a.rotation_draws} | {st['ok']} "
            f"({100 * st['ok'] / a.rotation_draws:.1f} %) | {st['ok-wrong']} | {st['too_few_inliers']} | "
            f"{a.rotation_draws - st['ok'] - st['ok-wrong'] - st['too_few_inliers']} | {wrong} |"
        )
        print(gen_rows[-1], flush=True)
    cap = "the library default (100000)" if a.max_iterations is None else str(a.max_iterations)
    cmd = "python benchmarks/status_calibration.py " + " ".join(argv or sys.argv[1:])
    md = "\n".join(
        [
            "## Status calibration (benchmarks/status_calibration.py)",
            "",
            f"Command: `{cmd}`  ",
            f"RANSAC iteration cap: {cap}; wall time {time.perf_counter() - t0:.0f} s.",
            "",
            *(
                [
                    "Random matches (no pose exists; every `ok` is a false alarm):",
                    "",
                    "| data | n | draws | ok | too_few_inliers | pure_rotation | planar_ambiguous, ambiguous or uncertain | degenerate |",
                    "|---|---|---|---|---|---|---|---|",
                    *rows,
                    "",
                ]
                if rows
                else []
            ),
            *(
                [
                    "Pure rotation (t = 0, 0.5 px noise; `ok` is wrong, `pure_rotation` is right):",
                    "",
                    "| outliers | n | draws | ok | pure_rotation | too_few_inliers | other |",
                    "|---|---|---|---|---|---|---|",
                    *rot_rows,
                    "",
                ]
                if rot_rows
                else []
            ),
            *(
                [
                    "Genuine poses (pinhole, 0.5 px noise; `ok` with a rotation error < 1 deg is right):",
                    "",
                    "| outliers | n | draws | ok (right) | ok but wrong | too_few_inliers | other | any status, wrong R |",
                    "|---|---|---|---|---|---|---|---|",
                    *gen_rows,
                    "",
                ]
                if gen_rows
                else []
            ),
        ]
    )
    print(md)
    if a.out is not None:
        from poseonly._fileutil import atomic_write_text

        atomic_write_text(a.out, md)
    return 0


if __name__ == "__main__":
    from poseonly.experiments.report import provenance

    print(provenance(), flush=True)
    sys.exit(main())
