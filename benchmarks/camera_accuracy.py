"""Pose accuracy through distorted cameras vs the undistorted camera on the same scenes.

    python benchmarks/camera_accuracy.py [--scenes 12] [--points 200]

Scenes: poseonly.sim pinhole scenes (640x480, f = 800), 20 % outliers, imaged by a PINHOLE camera and
by distorted OPENCV / OPENCV_FISHEYE cameras with the same f and principal point. Two noise models:
``bearing`` -- 1 px noise at f = 800 on the bearings (the same angular noise for every camera: the
ratio measures what the camera handling loses); ``pixel`` -- exact bearings projected, then the same
1 px Gaussian noise added to each camera's pixels (the distorted images compress the periphery, so
the same pixel noise is more angular noise: a property of the camera, not of the estimator).
Prints the median rotation error (deg) and the ratio distorted / undistorted.
"""

from __future__ import annotations

import argparse

import numpy as np

from poseonly import estimate_relative_pose, rotation_error_deg
from poseonly.cameras import Camera
from poseonly.sim import default_K, make_scene

CAMERAS = {
    "OPENCV": Camera("OPENCV", 640, 480, (800.0, 800.0, 320.0, 240.0, -0.25, 0.08, 0.001, -0.0015)),
    "OPENCV_FISHEYE": Camera("OPENCV_FISHEYE", 640, 480, (800.0, 800.0, 320.0, 240.0, -0.05, 0.01, -0.002, 0.0003)),
}
PINHOLE = Camera("PINHOLE", 640, 480, (800.0, 800.0, 320.0, 240.0))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenes", type=int, default=12, help="seeded scenes per configuration")
    ap.add_argument("--points", type=int, default=200, help="matches per scene")
    a = ap.parse_args(argv)
    print(f"{'noise':<8} {'camera':<16} {'undistorted':>12} {'distorted':>10} {'ratio':>7}")
    for mode in ("bearing", "pixel"):
        for name, cam in CAMERAS.items():
            e0, e1 = [], []
            for s in range(a.scenes):
                sc = make_scene(a.points, camera="pinhole", noise_px=1.0 if mode == "bearing" else 0.0, outlier_fraction=0.2, seed=s)
                nz = np.random.default_rng(1000 + s).standard_normal((2, a.points, 2)) if mode == "pixel" else np.zeros((2, a.points, 2))
                u1, u2 = PINHOLE.project(sc.f1) + nz[0], PINHOLE.project(sc.f2) + nz[1]
                d1, d2 = cam.project(sc.f1) + nz[0], cam.project(sc.f2) + nz[1]
                r0 = estimate_relative_pose(u1, u2, default_K(), seed=s)
                r1 = estimate_relative_pose(d1, d2, camera1=cam, seed=s)
                e0.append(rotation_error_deg(sc.R, r0.R))
                e1.append(rotation_error_deg(sc.R, r1.R))
            m0, m1 = float(np.median(e0)), float(np.median(e1))
            print(f"{mode:<8} {name:<16} {m0:12.4f} {m1:10.4f} {m1 / m0:7.3f}")
    return 0


if __name__ == "__main__":
    from poseonly.experiments.report import provenance

    print(provenance(), flush=True)
    raise SystemExit(main())
