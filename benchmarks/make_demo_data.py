"""Build the embedded demo pair ``src/poseonly/data/`` from the Strecha fountain-P11 scene.

Usage::

    python benchmarks/make_demo_data.py [STRECHA_ROOT] [--views 0004 0005] [--width 960] [--quality 90]

``STRECHA_ROOT`` defaults to ``../shared/data/strecha`` (relative to the repository root). The two
views are downscaled with ``cv2.INTER_AREA`` to ``width`` pixels (3072x2048 -> 960x640, scale 5/16,
exact in both axes) and re-encoded as JPEG. The intrinsics are rescaled with the pixel-centre
convention of OpenCV (integer coordinates at pixel centres, so pixel ``u`` covers
``[u - 0.5, u + 0.5]``): ``u' + 0.5 = s (u + 0.5)``, i.e. ``fx' = s fx``, ``fy' = s fy``,
``cx' = s (cx + 0.5) - 0.5``, ``cy' = s (cy + 0.5) - 0.5``. The ground-truth pose comes from
:func:`poseonly.io.strecha.relative_pose` (``X2 = R X1 + t``, unit ``t``).
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import cv2
import numpy as np

from poseonly.features import match_images, sampson_error_px
from poseonly.io.strecha import load_scene, relative_pose

REPO = Path(__file__).resolve().parents[1]
DEFAULT_ROOT = REPO / ".." / "shared" / "data" / "strecha"
OUT = REPO / "src" / "poseonly" / "data"

PROVENANCE = (
    "Images and ground truth from the Strecha et al. multi-view benchmark: C. Strecha, W. von Hansen, "
    "L. Van Gool, P. Fua, U. Thoennessen, 'On Benchmarking Camera Calibration and Multi-View Stereo for "
    "High Resolution Imagery', CVPR 2008 (originally http://cvlabwww.epfl.ch/data/multiview/), as "
    "redistributed by the public GitHub repository openMVG/SfM_quality_evaluation (commit "
    "348a981ef51112e9848acfb20004f4ed6fbc6ce3, folder Benchmarking_Camera_Calibration_2008/; JPEG re-encodes "
    "of the original PNGs). Here downscaled and re-encoded by benchmarks/make_demo_data.py. The data are "
    "provided by their authors for research use; cite the paper above when using them. The licence of the "
    "poseonly code does not apply to these images."
)


def scale_K(K: np.ndarray, sx: float, sy: float) -> np.ndarray:
    """Intrinsics after resizing by ``(sx, sy)`` with integer pixel coordinates at pixel centres."""
    S = np.array([[sx, 0.0, 0.5 * sx - 0.5], [0.0, sy, 0.5 * sy - 0.5], [0.0, 0.0, 1.0]])
    return S @ K


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("root", nargs="?", default=str(DEFAULT_ROOT), help="folder holding fountain-P11/ (default %(default)s)")
    ap.add_argument("--scene", default="fountain-P11")
    ap.add_argument("--views", nargs=2, default=["0004", "0005"], help="the two image stems")
    ap.add_argument("--width", type=int, default=960)
    ap.add_argument("--quality", type=int, default=90)
    ap.add_argument("--out", default=str(OUT))
    args = ap.parse_args(argv)

    scene = load_scene(Path(args.root) / args.scene)
    stems = [p.stem for p in scene.image_paths]
    i, j = (stems.index(v) for v in args.views)
    R, t, baseline = relative_pose(scene, i, j)

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    names, Ks, sizes, files = [], [], [], []
    for k in (i, j):
        cam = scene.cameras[k]
        img = cv2.imread(str(scene.image_paths[k]), cv2.IMREAD_COLOR)
        h0, w0 = img.shape[:2]
        w = args.width
        h = int(round(h0 * w / w0))
        small = cv2.resize(img, (w, h), interpolation=cv2.INTER_AREA)
        name = f"{scene.name}_{scene.image_paths[k].stem}.jpg"
        ok = cv2.imwrite(str(out / name), small, [cv2.IMWRITE_JPEG_QUALITY, args.quality])
        assert ok, name
        names.append(scene.image_paths[k].name)
        files.append(name)
        Ks.append(scale_K(cam.K, w / w0, h / h0))
        sizes.append([w, h])

    m = match_images(out / files[0], out / files[1])
    e = sampson_error_px(m.u1, m.u2, Ks[0], Ks[1], R, t)
    stats = {
        "sift_matches_ratio_0.8": len(m),
        "fraction_sampson_below_1px": round(float(np.mean(e < 1.0)), 4),
        "fraction_sampson_below_2px": round(float(np.mean(e < 2.0)), 4),
        "median_sampson_px": round(float(np.median(e)), 4),
    }
    meta = {
        "scene": scene.name,
        "source_images": names,
        "images": files,
        "image_size": sizes,
        "original_image_size": [scene.cameras[i].width, scene.cameras[i].height],
        "K1": Ks[0].tolist(),
        "K2": Ks[1].tolist(),
        "R": R.tolist(),
        "t": t.tolist(),
        "baseline_m": baseline,
        "convention": "X2 = R X1 + t (camera 1 -> camera 2), E = [t]x R, x2^T E x1 = 0, unit t; "
        "R_12 = R_2^T R_1, t_12 ~ R_2^T (C_1 - C_2) from the .camera files (R camera->world, C centre)",
        "pixel_convention": "OpenCV: integer pixel coordinates at pixel centres; K scaled as fx' = s fx, fy' = s fy, cx' = s (cx + 0.5) - 0.5, cy' = s (cy + 0.5) - 0.5",
        "resize": f"cv2.resize INTER_AREA, JPEG quality {args.quality}",
        "match_stats": stats,
        "provenance": PROVENANCE,
    }
    (out / "demo_pair.json").write_text(json.dumps(meta, indent=2) + "\n")
    total = sum((out / f).stat().st_size for f in files)
    print(f"wrote {files} ({total / 1024:.0f} KB) and demo_pair.json to {out}")
    print(json.dumps(stats))


if __name__ == "__main__":
    from poseonly.experiments.report import provenance

    print(provenance(), flush=True)
    main()
