"""How well the reported deviations describe the errors of `ok` poses in forward motion (a SLAM trial).

Synthetic driving-like pairs: KITTI's intrinsics (1226 x 370 px, f = 707), the camera moving
``--baseline`` forward (with a 0.05 sideways jitter and ~0.6 deg of rotation), points at depths 4-80,
``--noise`` px Gaussian noise in both images, a fraction of the matches replaced by uniform random ones.
For every `ok` pose of the default method: the squared Mahalanobis distance of the true translation
direction under ``translation_covariance`` (2 degrees of freedom: its median is 1.39 and 1 % exceed
9.21 when the covariance is right), that of the rotation under ``rotation_covariance`` (3: median 2.37,
1 % above 11.34), and the share of translation errors above 3 and 10 ``translation_std_deg`` (the
deviation along the least constrained axis: at most ~1.1 % above 3 when right).

    python benchmarks/forward_motion_uncertainty.py --scenes 150 --outliers 0 0.2
"""

from __future__ import annotations

import argparse

import numpy as np
from scipy.spatial.transform import Rotation

import poseonly

K = np.array([[707.0, 0.0, 601.9], [0.0, 707.0, 183.1], [0.0, 0.0, 1.0]])
WIDTH, HEIGHT = 1226, 370
DEPTH_RANGE = (4.0, 80.0)
CHI2_2_MEDIAN, CHI2_2_99 = 1.386, 9.210
CHI2_3_MEDIAN, CHI2_3_99 = 2.366, 11.345


def scene(rng: np.random.Generator, n: int, baseline: float, noise: float, outliers: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Pixels ``u1, u2 (n, 2)`` and the truth ``R, t`` (unit t, ``X2 = R X1 + t``)."""
    R = Rotation.from_rotvec(rng.normal(0.0, 0.01, 3)).as_matrix()
    t = np.array([0.0, 0.0, -1.0]) + rng.normal(0.0, 0.05, 3)
    t = baseline * t / np.linalg.norm(t)
    u = np.c_[rng.uniform(0, WIDTH, 3 * n), rng.uniform(0, HEIGHT, 3 * n)]
    Z = rng.uniform(*DEPTH_RANGE, 3 * n)
    X1 = (np.c_[u, np.ones(len(u))] @ np.linalg.inv(K).T) * Z[:, None]
    X2 = X1 @ R.T + t
    x2 = X2 @ K.T
    u2 = x2[:, :2] / x2[:, 2:]
    seen = (X2[:, 2] > 1) & (u2[:, 0] > 0) & (u2[:, 0] < WIDTH) & (u2[:, 1] > 0) & (u2[:, 1] < HEIGHT)
    u1, u2 = u[seen][:n], u2[seen][:n]
    u1 = u1 + rng.normal(0.0, noise, u1.shape)
    u2 = u2 + rng.normal(0.0, noise, u2.shape)
    k = int(outliers * n)
    u2[:k] = np.c_[rng.uniform(0, WIDTH, k), rng.uniform(0, HEIGHT, k)]
    return u1, u2, R, t / np.linalg.norm(t)


def _mahalanobis2(d: np.ndarray, C: np.ndarray) -> float:
    """``d^T C^+ d`` over C's range (the translation's covariance has rank 2)."""
    w, V = np.linalg.eigh(C)
    keep = w > 1e-12 * max(float(w.max()), 1e-300)
    return float(sum((V[:, k] @ d) ** 2 / w[k] for k in range(len(w)) if keep[k]))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenes", type=int, default=150)
    ap.add_argument("--points", type=int, default=600)
    ap.add_argument("--baseline", type=float, default=0.3)
    ap.add_argument("--noise", type=float, default=0.3, help="pixels")
    ap.add_argument("--outliers", type=float, nargs="+", default=[0.0, 0.2])
    ap.add_argument("--seed", type=int, default=11)
    a = ap.parse_args(argv)
    print(f"{a.scenes} scenes, {a.points} matches, forward {a.baseline}, depths {DEPTH_RANGE[0]:g}-{DEPTH_RANGE[1]:g}, {a.noise} px noise")
    print("| outliers | ok | t: Mahalanobis^2 median (1.39) | t: above chi2_2 99 % | t err > 3 std | t err > 10 std | R: Mahalanobis^2 median (2.37) | R: above chi2_3 99 % |")
    print("|---|---|---|---|---|---|---|---|")
    for frac in a.outliers:
        rng = np.random.default_rng(a.seed)
        mt, mr, z = [], [], []
        for _ in range(a.scenes):
            u1, u2, R, t = scene(rng, a.points, a.baseline, a.noise, frac)
            r = poseonly.estimate_relative_pose(u1, u2, K)
            if r.status != "ok" or r.translation_covariance is None or r.rotation_covariance is None:
                continue
            d = t - r.t * float(t @ r.t)  # the error in the tangent plane at the estimate
            mt.append(_mahalanobis2(d, r.translation_covariance))
            w = Rotation.from_matrix(R @ r.R.T).as_rotvec()  # left perturbation: R = exp([w]x) R_est
            mr.append(_mahalanobis2(w, r.rotation_covariance))
            z.append(poseonly.translation_error_deg(r.t, t) / r.translation_std_deg)
        if not mt:
            print(f"| {100 * frac:.0f} % | 0 | | | | | | |")
            continue
        mt_, mr_, z_ = np.array(mt), np.array(mr), np.array(z)
        print(
            f"| {100 * frac:.0f} % | {len(mt_)} | {np.median(mt_):.2f} | {100 * np.mean(mt_ > CHI2_2_99):.1f} % | {100 * np.mean(z_ > 3):.1f} % | "
            f"{100 * np.mean(z_ > 10):.1f} % | {np.median(mr_):.2f} | {100 * np.mean(mr_ > CHI2_3_99):.1f} % |"
        )
    return 0


if __name__ == "__main__":
    from poseonly.experiments.report import provenance

    print(provenance(), flush=True)
    raise SystemExit(main())
