"""Study: rotation averaging weighted by the two-view rotations' uncertainty, on Strecha scenes.

For every edge of a scene's view graph (``poseonly experiment global``'s cached two-view stage), the
information of its relative rotation: the Gauss-Newton matrix of the Sampson errors of its inlier
matches at its pose (the core's refinement Jacobian, chart ``exp([w]x) R``, camera j's frame), scaled
by the edge's own noise (median squared Sampson error / the chi^2_1 median) and with the translation
marginalised (Schur complement); Zhang et al., "Revisiting Rotation Averaging: Uncertainties and
Robust Losses" (CVPR 2023) weight rotation averaging this way. The pipeline's IRLS (Geman-McClure at
5 deg, relinearised) is rerun from the pipeline's averaged rotations on its inlier edges with four
weightings: the inlier count (the pipeline's, a check that it reproduces the pipeline), the full 3x3
information rotated to the world frame, its trace / 3 and its smallest eigenvalue; the rotation error
after the best rotation-only alignment is printed per scene.

    python benchmarks/ra_uncertainty_study.py /work/shared/data/strecha/Herz-Jesus-P8 /work/shared/data/strecha/entry-P10
"""

from __future__ import annotations

import argparse
from pathlib import Path

CHI2_1_MEDIAN = 0.45493642311957283
GM_SIGMA_DEG = 5.0
IRLS_ITERATIONS = 50
IRLS_TOL = 1e-13


def _irls(R0, p, Rrel, kind: str, Ls, w):
    """The pipeline's Geman-McClure IRLS from ``R0 (n, 3, 3)`` on the edges ``p (E, 2)`` with the edge
    weighting ``kind``; returns the rotations."""
    import numpy as np
    import scipy.sparse as sp
    from scipy.sparse.linalg import spsolve

    from poseonly.sfm.rotation_averaging import _linearise
    from poseonly.sfm.so3 import exp_so3

    sig = np.radians(GM_SIGMA_DEG)
    n = len(R0)
    Rg = R0.copy()
    for _ in range(IRLS_ITERATIONS):
        b = _linearise(Rg, p, Rrel)
        e2 = np.sum(b * b, 1)
        rho = sig**2 / (e2 + sig**2) ** 2
        rho /= rho.max()
        if kind == "full":
            Rj = Rg[p[:, 1]]
            W = rho[:, None, None] * np.einsum("eji,ejk,ekl->eil", Rj, Ls, Rj)  # R_j^T L R_j: world frame
        else:
            s = {"count": w, "trace": np.trace(Ls, axis1=1, axis2=2) / 3, "min": np.linalg.eigvalsh(Ls)[:, 0]}[kind]
            W = (rho * s)[:, None, None] * np.eye(3)[None]
        rows, cols, vals = [], [], []
        rhs = np.zeros((n, 3))
        for (i, j), We, be in zip(p, W, b):
            for u, v, sgn in ((i, i, 1.0), (j, j, 1.0), (i, j, -1.0), (j, i, -1.0)):
                rr, cc = np.meshgrid(3 * u + np.arange(3), 3 * v + np.arange(3), indexing="ij")
                rows.append(rr.ravel())
                cols.append(cc.ravel())
                vals.append(sgn * We.ravel())
            rhs[j] += We @ be
            rhs[i] -= We @ be
        A = sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(3 * n, 3 * n))
        keep = np.arange(3, 3 * n)  # view 0 fixed (gauge)
        x = np.zeros(3 * n)
        x[keep] = spsolve(A[keep][:, keep].tocsc(), rhs.ravel()[keep])
        Rg = Rg @ exp_so3(x.reshape(n, 3))
        if np.abs(x).max() < IRLS_TOL:
            break
    return Rg


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("scenes", nargs="+", help="Strecha scene folders")
    ap.add_argument("--cache", default="/tmp/sfm_cache", help="experiment global's cache")
    ap.add_argument("--max-features", type=int, default=8000)
    a = ap.parse_args(argv)
    import numpy as np

    from poseonly import _core
    from poseonly.experiments.global_sfm import _gt
    from poseonly.io.strecha import load_scene
    from poseonly.sfm.align import evaluate_poses
    from poseonly.sfm.pairwise import PairwiseOptions, image_view_graph
    from poseonly.sfm.pipeline import GlobalOptions, run_global
    from poseonly.sfm.tracks import Tracks

    print("| scene | inlier count (pipeline) | 3x3 information | trace / 3 | smallest eigenvalue | information anisotropy, median (max / min eigenvalue) |")
    print("|---|---|---|---|---|---|")
    for path in a.scenes:
        sc = load_scene(Path(path))
        R_gt, C_gt = _gt(sc)
        ig = image_view_graph(sc.image_paths, sc.K, options=PairwiseOptions(max_features=a.max_features, seed=0), cache_dir=a.cache)
        g = ig.graph
        res = run_global(g, ig.bearings, float(sc.K[0, 0]), GlobalOptions())
        pairs, E = g.pairs(), len(g)
        lam = np.zeros((E, 3, 3))
        count = np.array([len(e.matches) for e in g.edges], dtype=float)
        for k, e in enumerate(g.edges):
            m = e.matches
            b = ig.bearings(Tracks(np.arange(0, 2 * len(m) + 1, 2), np.tile([e.i, e.j], len(m)), m.ravel()))
            r, J = _core._refine_residuals(0, e.R, e.t, np.ascontiguousarray(b[0::2]), np.ascontiguousarray(b[1::2]), np.zeros(5), None)
            H = J.T @ J / (np.median(r * r) / CHI2_1_MEDIAN)
            L = H[:3, :3] - H[:3, 3:] @ np.linalg.solve(H[3:, 3:], H[3:, :3])
            lam[k] = 0.5 * (L + L.T)
        inl = res.rotation.inlier_edges
        p, Rrel = pairs[inl], g.rotations()[inl]
        Ls = lam[inl] / np.median(np.trace(lam[inl], axis1=1, axis2=2) / 3)
        w = count[inl] / np.median(count[inl])

        ev = np.linalg.eigvalsh(lam)
        cells = [f"{evaluate_poses(_irls(res.rotations, p, Rrel, k, Ls, w), res.centres, R_gt, C_gt)['rot_mean_deg_rotalign']:.4f}" for k in ("count", "full", "trace", "min")]
        print(f"| {sc.name} | " + " | ".join(cells) + f" | {np.median(ev[:, 2] / ev[:, 0]):.0f} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
