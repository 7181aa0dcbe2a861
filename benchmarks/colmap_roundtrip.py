"""COLMAP round trip on the Strecha scenes: pycolmap SIFT + exhaustive matching (no verification) ->
two-view verification by pycolmap or by ``poseonly colmap verify`` (with the keypoints' scales as
noise scales, and without: ``poseonly-noscale``) -> pycolmap's incremental and
global (GLOMAP) mappers -> camera errors against the ground truth after a similarity alignment.

    python benchmarks/colmap_roundtrip.py [--data /work/shared/data/strecha]
        [--scenes Herz-Jesus-P8 ...] [--max-image-size 1600] [--out DIR]

Cameras: one shared PINHOLE camera with the scene's K (the images are undistorted). Errors per
registered image: rotation (deg) and centre position (m, Strecha units) after the least-squares
similarity (Umeyama) of the registered centres onto the ground truth. Writes roundtrip.json and
roundtrip.md to ``--out`` (default: a new folder ./colmap_roundtrip_<time>).
"""

from __future__ import annotations

import argparse
import json
import shutil
import time
from pathlib import Path

import numpy as np

from poseonly.colmap_verify import verify_database
from poseonly.geometry import rotation_error_deg
from poseonly.io.strecha import find_scenes, load_scene


def umeyama(src: np.ndarray, dst: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
    """Similarity ``dst ~ s Q src + T`` of ``(n, 3)`` point sets (Umeyama 1991)."""
    ms, md = src.mean(0), dst.mean(0)
    a, b = src - ms, dst - md
    U, S, Vt = np.linalg.svd(b.T @ a / len(src))
    D = np.diag([1.0, 1.0, np.sign(np.linalg.det(U @ Vt))])
    Q = U @ D @ Vt
    s = float(np.trace(np.diag(S) @ D) / np.mean(np.sum(a * a, axis=1)))
    return s, Q, md - s * Q @ ms


def camera_errors(rec, scene) -> dict:
    """Median / max rotation and position errors of a reconstruction's images vs the ground truth."""
    gt = {p.name: c for p, c in zip(scene.image_paths, scene.cameras, strict=True)}
    names, C_est, R_est = [], [], []
    for im in rec.images.values():
        if not im.has_pose or im.name not in gt:
            continue
        T = im.cam_from_world()
        R = T.rotation.matrix()
        names.append(im.name)
        R_est.append(R)
        C_est.append(-R.T @ T.translation)
    if len(names) < 3:
        return {"registered": len(names)}
    C_gt = np.array([gt[n].C for n in names])
    s, Q, T = umeyama(np.array(C_est), C_gt)
    rot = [rotation_error_deg(gt[n].R_cw.T, R @ Q.T) for n, R in zip(names, R_est, strict=True)]
    pos = np.linalg.norm((s * np.array(C_est) @ Q.T + T) - C_gt, axis=1)
    return {"registered": len(names), "rot_med_deg": float(np.median(rot)), "rot_max_deg": float(np.max(rot)), "pos_med_m": float(np.median(pos)), "pos_max_m": float(np.max(pos))}


def verified_pairs(pycolmap, db: Path) -> dict:
    """Pairs per two-view configuration and the total number of inlier matches."""
    d = pycolmap.Database.open(str(db))
    try:
        _, geoms = d.read_two_view_geometries()
    finally:
        d.close()
    configs: dict[str, int] = {}
    for g in geoms:
        name = pycolmap.TwoViewGeometryConfiguration(int(g.config)).name
        configs[name] = configs.get(name, 0) + 1
    return {"configs": configs, "inlier_matches": int(sum(len(g.inlier_matches) for g in geoms))}


def run_mappers(pycolmap, db: Path, images: Path, out: Path, scene) -> dict:
    res = {}
    for name, fn in (("incremental", pycolmap.incremental_mapping), ("global", pycolmap.global_mapping)):
        o = out / name
        o.mkdir(parents=True, exist_ok=True)
        t0 = time.perf_counter()
        recs = fn(str(db), str(images), str(o))
        dt = time.perf_counter() - t0
        if not recs:
            res[name] = {"registered": 0, "time_s": dt}
            continue
        rec = max(recs.values(), key=lambda r: r.num_reg_images())
        res[name] = {**camera_errors(rec, scene), "time_s": dt}
    return res


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", default="/work/shared/data/strecha", help="folder holding the Strecha scenes")
    ap.add_argument("--scenes", nargs="*", help="scene folder names (default: all found)")
    ap.add_argument("--max-image-size", type=int, default=1600, help="SIFT on images downscaled to this size")
    ap.add_argument("--threads", type=int, default=2, help="threads of pycolmap's extraction and matching")
    ap.add_argument("--out", default=None, help="output folder (default: a new ./colmap_roundtrip_<time>)")
    a = ap.parse_args(argv)
    import pycolmap

    out = Path(a.out or f"colmap_roundtrip_{time.strftime('%Y%m%d-%H%M%S')}")
    out.mkdir(parents=True, exist_ok=True)
    scenes = [p for p in find_scenes(a.data) if not a.scenes or p.name in a.scenes]
    results = {}
    for sp in scenes:
        scene = load_scene(sp)
        sd = out / scene.name
        sd.mkdir(exist_ok=True)
        base = sd / "matches.db"
        if not base.exists():
            K = scene.K
            reader = pycolmap.ImageReaderOptions(camera_model="PINHOLE", camera_params=f"{K[0, 0]},{K[1, 1]},{K[0, 2]},{K[1, 2]}")
            ext = pycolmap.FeatureExtractionOptions(max_image_size=a.max_image_size, num_threads=a.threads)
            pycolmap.extract_features(
                str(base), str(scene.path / "images"), camera_mode=pycolmap.CameraMode.SINGLE, reader_options=reader, extraction_options=ext, device=pycolmap.Device.cpu
            )
            mo = pycolmap.FeatureMatchingOptions(skip_geometric_verification=True, num_threads=a.threads)
            pycolmap.match_exhaustive(str(base), matching_options=mo, device=pycolmap.Device.cpu)
        row = {}
        for verifier in ("pycolmap", "poseonly", "poseonly-noscale"):
            db = sd / f"{verifier}.db"
            shutil.copy(base, db)
            t0 = time.perf_counter()
            if verifier == "pycolmap":
                pycolmap.geometric_verification(str(db))
            else:
                verify_database(db, progress=False, noise_scales=verifier == "poseonly")
            tv = time.perf_counter() - t0
            row[verifier] = {"verify_time_s": tv, **verified_pairs(pycolmap, db), **run_mappers(pycolmap, db, scene.path / "images", sd / verifier, scene)}
            print(scene.name, verifier, json.dumps(row[verifier]), flush=True)
        results[scene.name] = row
    (out / "roundtrip.json").write_text(json.dumps(results, indent=2))
    lines = [
        ("| scene | verification | verified pairs (CALIBRATED / all) | inlier matches | verify s | mapper | registered | rot. median / max (deg) | position median / max (m) |"),
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for sc, row in results.items():
        for ver, r in row.items():
            for mp in ("incremental", "global"):
                e = r[mp]
                head = (
                    f"| {sc} | {ver} | {r['configs'].get('CALIBRATED', 0)} / {sum(r['configs'].values())} "
                    f"| {r['inlier_matches']} | {r['verify_time_s']:.1f} | {mp} | {e['registered']} |"
                )
                if "rot_med_deg" in e:
                    lines.append(f"{head} {e['rot_med_deg']:.3f} / {e['rot_max_deg']:.3f} | {e['pos_med_m']:.4f} / {e['pos_max_m']:.4f} |")
                else:
                    lines.append(f"{head} - | - |")
    (out / "roundtrip.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))
    print(f"wrote {out / 'roundtrip.json'} and {out / 'roundtrip.md'}")
    return 0


if __name__ == "__main__":
    from poseonly.experiments.report import provenance

    print(provenance(), flush=True)
    raise SystemExit(main())
