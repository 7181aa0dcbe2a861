"""Statuses of short-baseline pairs whose every match shows parallax (a migrating user's trial).

f = 800, 640 x 480, a 0.3 baseline mostly sideways, a ~1.7 deg rotation, 0.5 px noise, uniform outliers;
depths either uniform in 4-20 (``random``) or a smooth field 9 + 3 sin(x / 200) + 2 cos(y / 150)
(``smooth``, where a rotation absorbs most of the parallax in this 43 deg view). Per cell (matches,
outliers, depths): the statuses over ``--seeds`` scenes, and where a pair is ``pure_rotation`` the
rotation error of the returned rotation-only fit against the epipolar pose kept in its diagnostics.

    python benchmarks/parallax_statuses.py --seeds 12
"""

from __future__ import annotations

import argparse
from collections import Counter

import numpy as np

import poseonly
from poseonly.geometry import rotation_error_deg, rotation_from_rotvec

K = np.array([[800.0, 0.0, 320.0], [0.0, 800.0, 240.0], [0.0, 0.0, 1.0]])
W, H = 640, 480
BASELINE = 0.3
NOISE_PX = 0.5


def scene(n: int, seed: int, outliers: float, smooth: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """Pixels ``u1, u2 (n, 2)``, the true ``R`` and the least parallax (px) once it is removed."""
    rng = np.random.default_rng(seed)
    R = rotation_from_rotvec(rng.normal(size=3) * 0.03)
    t = np.r_[rng.normal(size=2), 0.2]
    t = BASELINE * t / np.linalg.norm(t)
    u1 = rng.uniform([0, 0], [W, H], (n, 2))
    d = 9 + 3 * np.sin(u1[:, 0] / 200) + 2 * np.cos(u1[:, 1] / 150) if smooth else rng.uniform(4, 20, n)
    X1 = (np.c_[u1, np.ones(n)] @ np.linalg.inv(K).T) * d[:, None]
    x2 = (X1 @ R.T + t) @ K.T
    u2 = x2[:, :2] / x2[:, 2:]
    g = np.c_[u1, np.ones(n)] @ np.linalg.inv(K).T @ R.T @ K.T
    least = float(np.linalg.norm(g[:, :2] / g[:, 2:] - u2, axis=1).min())
    u1 = u1 + rng.normal(0, NOISE_PX, u1.shape)
    u2 = u2 + rng.normal(0, NOISE_PX, u2.shape)
    k = int(outliers * n)
    u2[:k] = rng.uniform([0, 0], [W, H], (k, 2))
    return u1, u2, R, least


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=12)
    ap.add_argument("--matches", type=int, nargs="+", default=[40, 60, 100])
    ap.add_argument("--outliers", type=float, nargs="+", default=[0.0, 0.3])
    a = ap.parse_args(argv)
    for smooth in (False, True):
        for n in a.matches:
            for out in a.outliers:
                st: Counter[str] = Counter()
                rot, pose, least = [], [], []
                for s in range(a.seeds):
                    u1, u2, R, lp = scene(n, s, out, smooth)
                    least.append(lp)
                    r = poseonly.estimate_relative_pose(u1, u2, K)
                    st[r.status] += 1
                    if r.status == "pure_rotation":
                        rot.append(rotation_error_deg(R, r.R))
                        pose.append(rotation_error_deg(R, r.diagnostics["pose_R"]))
                line = f"{'smooth' if smooth else 'random'} depths, {n:3d} matches, {out:.0%} outliers: least parallax {min(least):.1f} px; {dict(sorted(st.items()))}"
                if rot:
                    line += f"; pure_rotation R err median {np.median(rot):.2f} deg (its epipolar pose {np.median(pose):.2f})"
                print(line)
    return 0


if __name__ == "__main__":
    from poseonly.experiments.report import provenance

    print(provenance(), flush=True)
    raise SystemExit(main())
