"""Figures the docs quote from the scenes of the test suite, printed (a docs audit found three quoted with
no command that prints them):

* ``planar-twin``: on 500 noise-free planar scenes of n = 30 (wide and pinhole cameras), the share where
  a wrong LiRP candidate passes the pose-only depth conditions with the exact one's PPO cost (the
  homography twin) and the share where LiRP picks it (docs/RESULTS.md, "Planar two-fold ambiguity";
  ``tests/test_lirp.py::test_planar_exact_or_twin``);
* ``still-camera``: a still camera before an object that moves (600 static matches, 80 on the object,
  0.5 px noise, the KITTI camera; seeds 0-9): statuses, median rotation error and median reported
  deviation (docs/RELIABILITY.md, "A still camera before a moving object";
  ``tests/test_pure_rotation_honesty.py``);
* ``ra-outliers``: 60 cameras, 0.5 deg relative-rotation noise, 10 % outlier edges: the averaged
  rotations' error with and without the outlier edges and the edges removed (docs/SFM.md, "Synthetic
  checks"; ``tests/test_sfm.py::test_rotation_averaging_outliers_removed_and_within_1p2x_of_clean``).

    python benchmarks/scene_figures.py planar-twin still-camera ra-outliers
"""

from __future__ import annotations

import argparse

import numpy as np


def planar_twin(seeds: int = 500) -> None:
    from poseonly import lirp
    from poseonly.geometry import rotation_error_deg
    from poseonly.sim import make_scene

    for cam in ("wide", "pinhole"):
        twins = picks = 0
        for s in range(seeds):
            sc = make_scene(30, "planar", cam, seed=s)
            r = lirp(sc.f1, sc.f2)
            err = rotation_error_deg(sc.R, r.candidates_R)
            exact = err < 1e-6
            wrong = (~exact) & r.candidate_valid & (err > 1e-3)
            if np.any(r.candidate_cost[wrong] <= r.candidate_cost[exact].min() + 1e-9):
                twins += 1
                picks += bool(rotation_error_deg(sc.R, r.R) > 1e-3)
        print(f"planar-twin {cam:8s} {seeds} scenes: a twin as good as the pose in {100 * twins / seeds:.1f} %, LiRP picks it in {100 * picks / seeds:.1f} %")


def still_camera(seeds: int = 10) -> None:
    from poseonly import estimate_relative_pose
    from poseonly.geometry import rotation_error_deg

    K = np.array([[707.0912, 0.0, 601.8873], [0.0, 707.0912, 183.1104], [0.0, 0.0, 1.0]])
    errors, devs, statuses = [], [], []
    for seed in range(seeds):
        rng = np.random.default_rng(seed)
        u1 = np.c_[rng.uniform(0, 1241, 600), rng.uniform(0, 376, 600)]
        u2 = u1.copy()
        c = np.array([rng.uniform(150, 1091), rng.uniform(80, 296)])
        p = c + np.c_[rng.uniform(-60, 60, 80), rng.uniform(-40, 40, 80)]
        d = rng.normal(0, 1, 2)
        u1, u2 = np.r_[u1, p], np.r_[u2, p + 10.0 * d / np.linalg.norm(d)]
        u1, u2 = u1 + rng.normal(0, 0.5, u1.shape), u2 + rng.normal(0, 0.5, u2.shape)
        r = estimate_relative_pose(u1, u2, K, K)
        statuses.append(r.status)
        errors.append(float(rotation_error_deg(np.eye(3), r.R)) if r.R is not None else np.nan)
        devs.append(r.rotation_std_deg)
    print(
        f"still-camera {seeds} scenes: statuses {sorted(set(statuses))} ({statuses.count('ok')} ok), "
        f"median rotation error {np.nanmedian(errors):.3f} deg, median deviation {np.nanmedian(devs):.3f} deg"
    )


def ra_outliers() -> None:
    from poseonly.sfm import average_rotations
    from poseonly.sfm.so3 import angle_deg, project_so3
    from poseonly.sfm.synthetic import make_scene

    def aligned(R: np.ndarray, R_gt: np.ndarray) -> float:
        Q = project_so3(np.einsum("nji,njk->ik", R, R_gt)[None])[0]
        return float(angle_deg(np.einsum("nji,njk->nik", R_gt, R @ Q)).mean())

    s = make_scene(60, 6000, seed=2, rotation_noise_deg=0.5, outlier_fraction=0.1)
    ra = average_rotations(60, s.pairs, s.R_rel, s.weights)
    clean = ~s.outlier
    ra_c = average_rotations(60, s.pairs[clean], s.R_rel[clean], s.weights[clean])
    removed = {(i, j) for i, j, _ in ra.outlier_edges}
    truth = {tuple(p) for p in s.pairs[s.outlier].tolist()}
    print(
        f"ra-outliers 60 views, {len(s.pairs)} edges, {len(truth)} outlier edges: mean rotation error {aligned(ra.rotations, s.rotations):.5f} deg "
        f"(clean edges only: {aligned(ra_c.rotations, s.rotations):.5f}); removed {len(removed)}, {len(truth & removed)} of them outliers"
    )


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("figures", nargs="+", choices=("planar-twin", "still-camera", "ra-outliers"))
    a = ap.parse_args(argv)
    for f in a.figures:
        {"planar-twin": planar_twin, "still-camera": still_camera, "ra-outliers": ra_outliers}[f]()
    return 0


if __name__ == "__main__":
    from poseonly.experiments.report import provenance

    print(provenance(), flush=True)
    raise SystemExit(main())
