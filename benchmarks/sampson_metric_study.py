"""Sampson's error on the unit sphere (the ML stage's) against Sampson's error in pixels (the ML objective
of isotropic pixel noise on a pinhole camera): how much accuracy the sphere's weighting loses.

A study, not a default: on the unit sphere a match at angle ``theta`` off the axis counts its error in
radians, while its pixel noise maps to ``cos^2 theta`` (radially) and ``cos theta`` (tangentially) of that
angle, so the sphere under-weights the image's borders. Two parts:

* ``--synthetic``: least squares from the truth under each objective, on pinhole scenes (1280x720, depths
  4-12 m, 0.5 px noise, ``--trials`` noise draws of one scene) for focal lengths giving 85 / 120 / 137 deg
  of horizontal field of view, sideways and forward motion; RMS rotation and translation-direction errors.
* ``--real DIR ...``: on a ``poseonly bench real`` dataset's cached SIFT matches, the default's ``ok``
  poses (seed 0) refitted on their inliers under each objective (Cauchy loss at the pair's noise scale),
  median / mean rotation error against the ground truth.

    python benchmarks/sampson_metric_study.py --synthetic --trials 40
    python benchmarks/sampson_metric_study.py --real /work/shared/data/realpairs/kitti_seq1 /work/shared/data/strecha/fountain-P11
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
from scipy.optimize import least_squares
from scipy.spatial.transform import Rotation

W, H = 1280, 720
NOISE_PX = 0.5


def _skew(t: np.ndarray) -> np.ndarray:
    return np.array([[0.0, -t[2], t[1]], [t[2], 0.0, -t[0]], [-t[1], t[0], 0.0]])


def sampson_px(R: np.ndarray, t: np.ndarray, u1: np.ndarray, u2: np.ndarray, K1: np.ndarray, K2: np.ndarray) -> np.ndarray:
    """Sampson's error in pixels of pixel matches ``u1, u2 (n, 2)`` (its gradient taken in the pixels)."""
    A1, A2 = np.linalg.inv(K1), np.linalg.inv(K2)
    x1 = np.c_[u1, np.ones(len(u1))] @ A1.T
    x2 = np.c_[u2, np.ones(len(u2))] @ A2.T
    E = _skew(t) @ R
    Ex1, Etx2 = x1 @ E.T, x2 @ E
    num = np.sum(x2 * Ex1, axis=1)
    g1, g2 = Etx2 @ A1[:, :2], Ex1 @ A2[:, :2]
    return num / np.sqrt(np.sum(g1**2, axis=1) + np.sum(g2**2, axis=1))


def sampson_sphere(R: np.ndarray, t: np.ndarray, u1: np.ndarray, u2: np.ndarray, K1: np.ndarray, K2: np.ndarray) -> np.ndarray:
    """Sampson's error on the unit sphere (poseonly's ``v_sampson``), times the pair's focal."""
    from poseonly.geometry import as_bearings, pair_focal
    from poseonly.residuals import v_sampson

    return v_sampson(R, t, as_bearings(u1, K1), as_bearings(u2, K2)) * pair_focal(K1[0, 0], K2[0, 0])


def refit(R0: np.ndarray, t0: np.ndarray, u1: np.ndarray, u2: np.ndarray, K1: np.ndarray, K2: np.ndarray, fun, loss: str = "linear", scale: float = 1.0):
    """``fun``'s (robust) least squares from ``(R0, t0)`` over the rotation and the unit translation."""
    a = np.cross(t0, [1.0, 0.0, 0.0])
    if np.linalg.norm(a) < 0.1:
        a = np.cross(t0, [0.0, 1.0, 0.0])
    a /= np.linalg.norm(a)
    b = np.cross(t0, a)

    def pose(p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        t = t0 + p[3] * a + p[4] * b
        return Rotation.from_rotvec(p[:3]).as_matrix() @ R0, t / np.linalg.norm(t)

    r = least_squares(lambda p: fun(*pose(p), u1, u2, K1, K2), np.zeros(5), loss=loss, f_scale=scale, x_scale=1e-3)
    return pose(r.x)


def scene(rng: np.random.Generator, f: float, baseline: float, sideways: bool, n: int = 500):
    """Pixel matches (noise-free) of points at depths 4-12 m, the motion ``(R, unit t)`` and ``K``."""
    K = np.array([[f, 0.0, W / 2], [0.0, f, H / 2], [0.0, 0.0, 1.0]])
    u = rng.uniform([0, 0], [W, H], (n, 2))
    X = (np.c_[u, np.ones(n)] @ np.linalg.inv(K).T) * rng.uniform(4, 12, n)[:, None]
    R = Rotation.from_rotvec(np.radians(rng.normal(0, 3, 3))).as_matrix()
    t = -R @ (baseline * (np.array([1.0, 0, 0]) if sideways else np.array([0, 0, 1.0])))
    X2 = X @ R.T + t
    x2 = X2 @ K.T
    u2 = x2[:, :2] / x2[:, 2:]
    keep = (X2[:, 2] > 0.5) & np.all((u2 > 0) & (u2 < [W, H]), axis=1)
    return u[keep], u2[keep], K, R, t / np.linalg.norm(t)


def synthetic(trials: int) -> None:
    from poseonly.geometry import rotation_error_deg

    rms = lambda x: float(np.sqrt(np.mean(np.square(x))))  # noqa: E731
    print(f"least squares from the truth, {trials} noise draws of one scene, {NOISE_PX} px noise; RMS errors, sphere / pixels")
    for f in (700.0, 370.0, 250.0):
        for sideways in (True, False):
            errs = []
            for s in range(trials):
                u1, u2, K, R, t = scene(np.random.default_rng(5), f, 0.5, sideways)
                rn = np.random.default_rng(100 + s)
                u1, u2 = u1 + rn.normal(0, NOISE_PX, u1.shape), u2 + rn.normal(0, NOISE_PX, u2.shape)
                row = []
                for fun in (sampson_sphere, sampson_px):
                    Re, te = refit(R, t, u1, u2, K, K, fun)
                    row += [rotation_error_deg(Re, R), float(np.degrees(np.arccos(min(1.0, abs(float(te @ t))))))]
                errs.append(row)
            e = np.array(errs)
            fov = np.degrees(2 * np.arctan(W / 2 / f))
            print(
                f"  FOV {fov:3.0f} deg, {'sideways' if sideways else 'forward '}: R {rms(e[:, 0]):.4f} / {rms(e[:, 2]):.4f} ({rms(e[:, 0]) / rms(e[:, 2]):.2f}x),"
                f" t {rms(e[:, 1]):.3f} / {rms(e[:, 3]):.3f} ({rms(e[:, 1]) / rms(e[:, 3]):.2f}x)"
            )


def real(dirs: list[str], cache: Path) -> None:
    import poseonly
    from poseonly.experiments import real_bench as RB
    from poseonly.geometry import rotation_error_deg

    print("the default's ok poses (seed 0) refitted on their inliers, Cauchy loss at the pair's noise; R err median / mean, deg")
    for name, pairs in RB.load_datasets(dirs).items():
        e = []
        for p in pairs:
            u1, u2, ratio, scales = RB.pair_match_data(p, cache)
            if len(u1) < 15:
                continue
            r = poseonly.estimate_relative_pose(u1, u2, p.K1, p.K2, scores=1 - ratio, noise_scales=scales, seed=0)
            if r.status != "ok" or r.R is None or r.t is None:
                continue
            s = max(float(r.diagnostics.get("noise_sigma_px", NOISE_PX)), 0.1)
            i = r.inliers
            row = [rotation_error_deg(r.R, p.R)]
            for fun in (sampson_sphere, sampson_px):
                Re, _ = refit(r.R, r.t, u1[i], u2[i], p.K1, p.K2, fun, "cauchy", s)
                row.append(rotation_error_deg(Re, p.R))
            e.append(row)
        a = np.array(e)
        print(
            f"  {name} ({len(a)} pairs): default {np.median(a[:, 0]):.4f} / {np.mean(a[:, 0]):.4f}, sphere refit {np.median(a[:, 1]):.4f} / {np.mean(a[:, 1]):.4f},"
            f" pixel refit {np.median(a[:, 2]):.4f} / {np.mean(a[:, 2]):.4f}; pixels better on {100 * np.mean(a[:, 2] < a[:, 1]):.0f} % of the pairs"
        )


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--synthetic", action="store_true")
    ap.add_argument("--trials", type=int, default=40)
    ap.add_argument("--real", nargs="*", default=[])
    ap.add_argument("--cache", default="/tmp/realbench_cache", help="the real benchmark's match cache")
    a = ap.parse_args(argv)
    if a.synthetic:
        synthetic(a.trials)
    if a.real:
        real(a.real, Path(a.cache))
    return 0


if __name__ == "__main__":
    from poseonly.experiments.report import provenance

    print(provenance(), flush=True)
    raise SystemExit(main())
