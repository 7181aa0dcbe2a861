"""Rotation averaging weighted by each edge's information against its inlier count, on synthetic
view graphs whose relative poses are two-view ML estimates (so their errors have the anisotropy of
real two-view poses, which the synthetic generator's isotropic rotation noise does not).

Per seed: a ring scene of :func:`poseonly.sfm.synthetic.make_scene` with pixel noise; every edge's
pose is the Sampson-LM fit (the core's, from the truth) to the bearings of the points both views see;
then :func:`poseonly.sfm.rotation_averaging.average_rotations` with the inlier counts as weights and
with :func:`poseonly.sfm.edge_information.edge_informations`. Prints the mean rotation error after
the rotation-only alignment, per seed and over seeds, and the ratio.

    python benchmarks/ra_information.py --seeds 10
    python benchmarks/ra_information.py --seeds 10 --half-fov 20
"""

from __future__ import annotations

import argparse

import numpy as np


def edge_graph(scene, min_matches: int = 8):
    """A :class:`ViewGraph` of ``scene``'s pairs with two-view Sampson-LM poses; keypoint index =
    observation index (so ``scene.bearings[tracks.keypoints]`` are the bearings)."""
    from poseonly import _core
    from poseonly.sfm.viewgraph import Edge, ViewGraph

    tr = scene.tracks
    tid = tr.track_of_observation
    obs_of: dict[tuple[int, int], int] = {(int(t), int(v)): k for k, (t, v) in enumerate(zip(tid, tr.views))}
    by_view: dict[int, set[int]] = {}
    for t, v in zip(tid.tolist(), tr.views.tolist()):
        by_view.setdefault(v, set()).add(t)
    g = ViewGraph(len(scene.rotations))
    for i, j in scene.pairs.tolist():
        i, j = min(i, j), max(i, j)
        common = sorted(by_view.get(i, set()) & by_view.get(j, set()))
        if len(common) < min_matches:
            continue
        m = np.array([[obs_of[(t, i)], obs_of[(t, j)]] for t in common], dtype=np.int64)
        f1, f2 = scene.bearings[m[:, 0]], scene.bearings[m[:, 1]]
        Ri, Rj, Ci, Cj = scene.rotations[i], scene.rotations[j], scene.centres[i], scene.centres[j]
        R0 = Rj @ Ri.T
        t0 = Rj @ (Ci - Cj)
        R, t, _ = _core.refine_sampson(np.ascontiguousarray(R0), np.ascontiguousarray(t0 / np.linalg.norm(t0)), np.ascontiguousarray(f1), np.ascontiguousarray(f2))
        g.add_edge(Edge(i, j, R, t, m, "ok", float(len(m))))
    return g


def run_seed(seed: int, views: int, points: int, noise_px: float) -> tuple[float, float]:
    from poseonly.sfm.align import evaluate_poses
    from poseonly.sfm.edge_information import edge_informations
    from poseonly.sfm.rotation_averaging import average_rotations
    from poseonly.sfm.synthetic import make_scene

    sc = make_scene(views, points, noise_px=noise_px, seed=seed)
    g = edge_graph(sc)
    info, fallback = edge_informations(g, lambda tr: sc.bearings[tr.keypoints])
    if info is None or fallback.any():
        raise SystemExit(f"seed {seed}: {int(fallback.sum())} of {len(fallback)} edges without an information")
    errs = []
    for inf in (None, info):
        ra = average_rotations(g.num_views, g.pairs(), g.rotations(), g.weights(), information=inf)
        ev = evaluate_poses(ra.rotations, sc.centres, sc.rotations, sc.centres)
        errs.append(float(ev["rot_mean_deg_rotalign"]))
    return errs[0], errs[1]


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seeds", type=int, default=10)
    ap.add_argument("--views", type=int, default=30)
    ap.add_argument("--points", type=int, default=3000)
    ap.add_argument("--noise-px", type=float, default=1.0)
    ap.add_argument("--half-fov", type=float, default=None, help="the cameras' half field of view (deg; the generator's default 50)")
    a = ap.parse_args(argv)
    if a.half_fov is not None:
        import poseonly.sfm.synthetic as S

        S.HALF_FOV_DEG = float(a.half_fov)
        S.HOME_CONE_DEG = min(S.HOME_CONE_DEG, 0.6 * float(a.half_fov))
    rows = [run_seed(s, a.views, a.points, a.noise_px) for s in range(a.seeds)]
    for s, (e0, e1) in enumerate(rows):
        print(f"seed {s}: inliers {e0:.5f} deg, information {e1:.5f} deg, ratio {e1 / e0:.3f}")
    r = np.array(rows)
    print(
        f"mean over {a.seeds} seeds: inliers {r[:, 0].mean():.5f} deg, information {r[:, 1].mean():.5f} deg; "
        f"ratio of means {r[:, 1].mean() / r[:, 0].mean():.3f}, median ratio {np.median(r[:, 1] / r[:, 0]):.3f}, "
        f"information better on {int(np.sum(r[:, 1] < r[:, 0]))} of {a.seeds}"
    )
    return 0


if __name__ == "__main__":
    from poseonly.experiments.report import provenance

    print(provenance(), flush=True)
    raise SystemExit(main())
