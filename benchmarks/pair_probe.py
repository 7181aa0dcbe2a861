"""One real pair under the microscope: the default over several seeds against PoseLib, with how many
matches each returned pose explains and how many of them lie on the ground-truth geometry.

Used to tell a search failure (the truth explains clearly more matches than the returned pose) from
a pair whose matches do not single out a pose (several poses, degrees apart, explain about as many
matches as the truth: an honest status there is not `ok`). The pair comes from a ``poseonly bench
real`` dataset folder (a realpairs folder or a Strecha scene) with the benchmark's cached SIFT matches,
``1 - ratio`` as scores and the keypoints' sizes as noise scales, as the benchmark calls the default.

    python benchmarks/pair_probe.py /work/shared/data/strecha/Herz-Jesus-P8 0-6 --seeds 6
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

import numpy as np

GT_PX = 1.0  # a match is on a pose's geometry within this Sampson error (pixels)


def probe(
    u1: np.ndarray, u2: np.ndarray, K1: np.ndarray, K2: np.ndarray, R: np.ndarray, t: np.ndarray, scores: np.ndarray | None, scales: np.ndarray | None, seeds: int
) -> list[dict[str, Any]]:
    """Rows ``{"method", "seed", "status", "R_err", "inliers", "within", "gt_within"}`` for the default
    with seeds ``0..seeds-1`` and (if installed) PoseLib at 1 px; ``within`` counts the matches within
    :data:`GT_PX` of the pose, ``gt_within`` those of them also within it of the truth ``(R, t)``
    (pixels ``u1, u2 (n, 2)``, intrinsics ``K1, K2 (3, 3)``, ``X2 = R X1 + t``)."""
    import poseonly
    from poseonly.features import sampson_error_px
    from poseonly.geometry import rotation_error_deg

    gt = sampson_error_px(u1, u2, K1, K2, R, t) < GT_PX
    rows: list[dict[str, Any]] = [{"method": "truth", "seed": None, "status": None, "R_err": 0.0, "inliers": int(gt.sum()), "within": int(gt.sum()), "gt_within": int(gt.sum())}]

    def row(method: str, seed: int | None, status: str | None, Re: np.ndarray | None, te: np.ndarray | None, inliers: int) -> None:
        if Re is None or te is None:
            rows.append({"method": method, "seed": seed, "status": status, "R_err": float("nan"), "inliers": inliers, "within": 0, "gt_within": 0})
            return
        w = sampson_error_px(u1, u2, K1, K2, Re, te) < GT_PX
        err = float(rotation_error_deg(R, Re))
        rows.append({"method": method, "seed": seed, "status": status, "R_err": err, "inliers": inliers, "within": int(w.sum()), "gt_within": int((w & gt).sum())})

    for s in range(seeds):
        r = poseonly.estimate_relative_pose(u1, u2, K1, K2, scores=scores, noise_scales=scales, seed=s)
        row("poseonly", s, r.status, r.R, r.t, r.num_inliers)
    try:
        import poselib
    except ImportError:
        return rows

    def cam(K: np.ndarray) -> dict[str, Any]:  # the image size does not enter PoseLib's estimate
        return {"model": "PINHOLE", "width": int(np.ceil(2 * K[0, 2])), "height": int(np.ceil(2 * K[1, 2])), "params": [K[0, 0], K[1, 1], K[0, 2], K[1, 2]]}

    pose, info = poselib.estimate_relative_pose(u1, u2, cam(K1), cam(K2), {"max_epipolar_error": 1.0}, {})
    row("poselib-1px", None, None, np.asarray(pose.R), np.asarray(pose.t), int(info["num_inliers"]))
    return rows


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("dataset", help="a realpairs dataset folder or a Strecha scene folder")
    ap.add_argument("pair", help="the pair's id as the benchmark names it (Strecha: 'i-j')")
    ap.add_argument("--seeds", type=int, default=6)
    ap.add_argument("--cache", default="/tmp/realbench_cache", help="the real benchmark's match cache")
    a = ap.parse_args(argv)
    from poseonly.experiments import real_bench as RB

    ds = RB.load_datasets([a.dataset])
    pairs = {p.pid: p for g in ds.values() for p in g}
    if a.pair not in pairs:
        ap.error(f"no pair {a.pair!r} in {a.dataset}")
    p = pairs[a.pair]
    u1, u2, ratio, scales = RB.pair_match_data(p, Path(a.cache))
    rows = probe(u1, u2, p.K1, p.K2, p.R, p.t, 1.0 - ratio, scales, a.seeds)
    print(f"{p.dataset} {p.pid}: {len(u1)} matches; within {GT_PX:g} px of: the pose / the pose and the truth")
    for r in rows:
        seed = "" if r["seed"] is None else f" seed {r['seed']}"
        status = "" if r["status"] is None else f" {r['status']:<17}"
        print(f"  {r['method'] + seed:<18}{status} R err {r['R_err']:8.3f} deg  inliers {r['inliers']:5d}  within {r['within']:5d} / {r['gt_within']:5d}")
    return 0


if __name__ == "__main__":
    from poseonly.experiments.report import provenance

    print(provenance(), flush=True)
    raise SystemExit(main())
