"""Statuses on real images warped by a known motion: pure rotations (the camera turning on a tripod),
a 0.3 px shift, and a plane seen after a real translation.

A pure rotation ``X2 = R X1`` maps image 1 to image 2 by ``H = K R K^-1`` exactly, so the honest status
is ``pure_rotation`` (or another non-``ok`` one): any translation direction fits the true matches, and
a repeated structure's wrong matches, displaced by its period, can pick one. A plane-induced homography
``K (R - t n^T / d) K^-1`` is a real motion whose pose is the truth or its homography twin
(``planar_ambiguous`` where cheirality cannot tell them apart). Images: ``--scenes`` Strecha scene
folders (image ``--image`` of each, resized to ``--width`` px) and the embedded demo image; SIFT and
ratio-test matches (``poseonly.features``, ratio scores for PROSAC), the default method on ``--seeds``
seeds. Prints, per case, the statuses and the largest rotation error of an ``ok`` pose, and in total
the ``ok`` poses of the pure rotations (each one a confident pose with a made-up translation).

    S=/work/shared/data/strecha
    python benchmarks/warped_statuses.py $S/fountain-P11 $S/Herz-Jesus-P8 $S/entry-P10 --seeds 10
"""

from __future__ import annotations

import argparse
import collections
import json
import sys
from pathlib import Path

import numpy as np

# (name, rotation axis, angle in degrees); the shift and the planar motions are added below
ROTATIONS = (("rot y 5", (0, 1, 0), 5.0), ("rot x 2", (1, 0, 0), 2.0), ("rot (1,2,1) 15", (1, 2, 1), 15.0), ("in-plane 30", (0, 0, 1), 30.0))
SHIFT_PX = 0.3
# planar scenes: the plane's normal (camera 1; the plane n^T X = 1), the translation in units of the plane's
# distance, the rotation axis and angle
PLANES = (("plane, t = 0.2 d sideways", (0.1, 0.0, 1.0), (0.2, 0.0, 0.0), (0, 1, 0), 3.0), ("plane, t = 0.15 d oblique", (0.3, 0.2, 1.0), (0.1, -0.08, 0.06), (1, 1, 0), 4.0))


def _rotation(axis, deg) -> np.ndarray:
    from poseonly.geometry import rotation_from_rotvec

    a = np.asarray(axis, float)
    return rotation_from_rotvec(a / np.linalg.norm(a) * np.radians(deg))


def _load(path: Path, width: int):
    import cv2

    im = cv2.imread(str(path))
    if im is None:
        raise SystemExit(f"cannot read {path}")
    K0 = np.loadtxt(path.parent / "K.txt")
    s = width / im.shape[1]
    im = cv2.resize(im, (width, int(round(im.shape[0] * s))), interpolation=cv2.INTER_AREA)
    K = K0.copy()
    K[:2, :2] *= s
    K[:2, 2] = s * (K0[:2, 2] + 0.5) - 0.5  # OpenCV's pixel centres
    return im, K


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("scenes", nargs="*", help="Strecha scene folders (images/NNNN.jpg and images/K.txt)")
    ap.add_argument("--image", type=int, default=4, help="the image of each scene (default 4)")
    ap.add_argument("--width", type=int, default=1024, help="resize to this width (default 1024 px)")
    ap.add_argument("--seeds", type=int, default=10)
    ap.add_argument("--options", type=json.loads, default={}, help='the method\'s options as JSON (default {}: the default method), e.g. \'{"lo": "sampson-cauchy-auto"}\'')
    ap.add_argument("--no-demo", action="store_true", help="leave out the embedded demo image")
    a = ap.parse_args(argv)
    import cv2

    from poseonly import estimate_relative_pose, rotation_error_deg
    from poseonly.demo_data import load_demo_pair
    from poseonly.features import extract_features, match_features

    images = [(Path(s).name, *_load(Path(s) / "images" / f"{a.image:04d}.jpg", a.width)) for s in a.scenes]
    if not a.no_demo:
        d = load_demo_pair()
        images.append(("demo", cv2.imread(str(d.image1)), d.K1))
    total: collections.Counter = collections.Counter()
    wrong_ok = 0
    print(f"command: python benchmarks/warped_statuses.py {' '.join(sys.argv[1:] if argv is None else argv)}")
    for name, im, K in images:
        Ki = np.linalg.inv(K)
        cases = [(h, _rotation(ax, deg), np.zeros(3), K @ _rotation(ax, deg) @ Ki) for h, ax, deg in ROTATIONS]
        cases.append((f"shift {SHIFT_PX} px", np.eye(3), np.zeros(3), np.array([[1.0, 0.0, SHIFT_PX], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])))
        for h, n, t, ax, deg in PLANES:
            R = _rotation(ax, deg)
            nn = np.asarray(n, float) / np.linalg.norm(n)
            cases.append((h, R, np.asarray(t, float), K @ (R + np.outer(t, nn)) @ Ki))  # X2 = R X1 + t on the plane n^T X1 = 1
        for h, R, t, H in cases:
            im2 = cv2.warpPerspective(im, H, (im.shape[1], im.shape[0]), flags=cv2.INTER_LINEAR)
            f1, f2 = extract_features(im), extract_features(im2)
            idx, sc = match_features(f1.descriptors, f2.descriptors, return_scores=True)
            u1, u2 = f1.keypoints[idx[:, 0]].astype(float), f2.keypoints[idx[:, 1]].astype(float)
            rotation = not np.any(t) and h.startswith(("rot", "in-plane", "shift"))
            st: collections.Counter = collections.Counter()
            err_ok = []
            for seed in range(a.seeds):
                r = estimate_relative_pose(u1, u2, K, K, scores=sc, seed=seed, **a.options)
                st[r.status] += 1
                if r.status == "ok":
                    err_ok.append(rotation_error_deg(R, r.R))
                if rotation:
                    total[r.status] += 1
                    wrong_ok += r.status == "ok"
            worst = f"{max(err_ok):.3f}" if err_ok else "-"
            print(f"{name:14s} {h:28s} {len(u1):5d} matches  {dict(sorted(st.items()))}  largest ok rotation error {worst} deg", flush=True)
    n = sum(total.values())
    print(f"pure rotations and shifts: {dict(sorted(total.items()))}; ok (a made-up translation) {wrong_ok} of {n}")
    return 0


if __name__ == "__main__":
    from poseonly.experiments.report import provenance

    print(provenance(), flush=True)
    raise SystemExit(main())
