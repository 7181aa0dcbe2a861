"""The real-data benchmark's methods on matches of other front-ends than full-resolution SIFT.

    python benchmarks/real_frontends.py DIR [DIR ...] [--front-end sift-1600 sift-1024 orb]
        [--seeds 3] [--methods poseonly poselib-1px poselib-2px opencv-magsac] [--cache /tmp/frontend_cache]
        [--out DIR]

``poseonly bench real`` matches full-resolution SIFT. Pipelines often resize first (hloc to 1024 or
1600 px, COLMAP to 3200), which scales the keypoints' noise in full-resolution pixels by the inverse
of the factor, and some use other detectors. Front-ends:

* ``sift-S``: OpenCV SIFT on the image resized (``INTER_AREA``) so that its long side is at most ``S``
  pixels; keypoints and sizes mapped back to full-resolution pixels (the ground truth's ``K`` is kept);
* ``orb``: OpenCV ORB (8000 features) on the full-resolution image, binary descriptors matched by
  Hamming distance (this OpenCV build has no AKAZE).

Matching is the bench's: two nearest neighbours, Lowe's ratio 0.8 (not mutual), the score ``1 - ratio``
(PROSAC for the default), keypoint sizes as noise scales. The methods, metrics and tables are
:mod:`poseonly.experiments.real_bench`'s (``run_pair``, ``summarize``, ``overview_markdown``), time
ratios to PoseLib 1 px in the same run. Features and matches are cached per front-end in ``--cache``.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import sys
from pathlib import Path

import numpy as np

RATIO = 0.8
FRONT_ENDS = ("sift-1600", "sift-1024", "orb")
ORB_FEATURES = 8000
DEFAULT_METHODS = ("poseonly", "poselib-1px", "poselib-2px", "opencv-magsac")


def _key(path: Path, front_end: str) -> str:
    st = path.stat()
    return hashlib.sha256(json.dumps([str(path.resolve()), st.st_size, st.st_mtime_ns, front_end, 1]).encode()).hexdigest()[:32]


def features(path: Path, front_end: str, cache: Path) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Keypoints ``(m, 2)`` in full-resolution pixels, descriptors ``(m, D)`` and sizes ``(m,)`` (cached)."""
    import cv2

    from poseonly._fileutil import atomic_savez
    from poseonly.features import extract_features, read_image

    f = cache / "features" / f"{front_end}_{_key(path, front_end)}.npz"
    if f.is_file():
        with np.load(f) as z:
            return z["kp"], z["desc"], z["sizes"]
    gray = read_image(path)
    if front_end.startswith("sift-"):
        side = int(front_end.split("-")[1])
        s = min(1.0, side / max(gray.shape))
        small = cv2.resize(gray, (round(gray.shape[1] * s), round(gray.shape[0] * s)), interpolation=cv2.INTER_AREA) if s < 1.0 else gray
        sx, sy = small.shape[1] / gray.shape[1], small.shape[0] / gray.shape[0]
        ft = extract_features(small)
        kp = (ft.keypoints + 0.5) / np.array([sx, sy]) - 0.5  # pixel centres at integer coordinates
        desc = ft.descriptors
        sizes = (ft.sizes if ft.sizes is not None else np.ones(len(kp))) / np.sqrt(sx * sy)
    elif front_end == "orb":
        kps, d = cv2.ORB_create(nfeatures=ORB_FEATURES).detectAndCompute(gray, None)
        kp = np.array([k.pt for k in kps], dtype=np.float64).reshape(-1, 2)
        sizes = np.array([k.size for k in kps], dtype=np.float64)
        desc = d if d is not None else np.zeros((0, 32), np.uint8)
    else:
        raise SystemExit(f"unknown front-end {front_end!r}; choose from {FRONT_ENDS}")
    atomic_savez(f, kp=kp, desc=desc, sizes=sizes)
    return kp, desc, sizes


def ratio_matches(d1: np.ndarray, d2: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Index pairs ``(k, 2)`` and ratios ``(k,)`` of Lowe's test (L2 for float descriptors, Hamming for binary)."""
    import cv2

    if len(d1) == 0 or len(d2) < 2:
        return np.zeros((0, 2), np.int64), np.zeros(0)
    if d1.dtype == np.uint8:
        nn = cv2.BFMatcher(cv2.NORM_HAMMING).knnMatch(d1, d2, k=2)
        rows = [(m[0].queryIdx, m[0].trainIdx, m[0].distance, m[1].distance) for m in nn if len(m) == 2]
        a = np.array(rows, dtype=np.float64).reshape(-1, 4)
        keep = a[:, 2] < RATIO * a[:, 3]
        return a[keep, :2].astype(np.int64), a[keep, 2] / np.maximum(a[keep, 3], 1e-30)
    from poseonly.features import match_features

    idx, score = match_features(d1, d2, ratio=RATIO, return_scores=True)
    return idx, 1.0 - score


def wrong_ok(records: list[dict], methods: list[str]) -> list[dict]:
    """Every ``ok`` pose of a method that reports a status with a rotation error above 5 deg, any seed."""
    from poseonly.experiments.real_bench import WRONG_DEG

    out = []
    for r in records:
        pl = r["methods"].get("poselib-1px")
        for m in methods:
            for s, x in enumerate(r["methods"][m]):
                if x["status"] == "ok" and x["R_err"] is not None and x["R_err"] > WRONG_DEG:
                    ref = pl[s]["R_err"] if pl else None
                    ref_err = None if ref is None else round(ref, 2)
                    out.append({"dataset": r["dataset"], "pair": r["id"], "seed": s, "method": m, "R_err": x["R_err"], "inliers": x["inliers"], "poselib_R_err": ref_err})
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("dirs", nargs="+")
    ap.add_argument("--front-end", nargs="+", default=list(FRONT_ENDS[:1]), choices=FRONT_ENDS)
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--methods", nargs="+", default=list(DEFAULT_METHODS))
    ap.add_argument("--cache", default="/tmp/frontend_cache")
    ap.add_argument("--out", default=None, help="write real_frontends.md / .json here")
    ap.add_argument("--full-json", action="store_true", help="keep every pair's records in the JSON (else the summaries and the wrong ok poses)")
    a = ap.parse_args(argv)
    from poseonly.experiments._common import code_version, machine, single_thread
    from poseonly.experiments.real_bench import GT_MIN, GT_PX, MIN_MATCHES, available_methods, load_datasets, overview_markdown, run_pair, summarize, warm_up

    single_thread()
    ms, notes = available_methods(a.methods)
    data = load_datasets(a.dirs)
    cache = Path(a.cache)
    plan = [p for pairs in data.values() for p in pairs]
    shown = sys.argv[1:] if argv is None else argv
    md = [f"# The real benchmark's methods on other front-ends (`python benchmarks/real_frontends.py {' '.join(shown)}`)", ""]
    out: dict = {"front_ends": {}, "machine": machine(), "code_version": code_version(), "notes": notes}
    for fe in a.front_end:
        matches = []
        for p in plan:
            k1, d1, s1 = features(p.im1, fe, cache)
            k2, d2, s2 = features(p.im2, fe, cache)
            idx, r = ratio_matches(d1, d2)
            matches.append((k1[idx[:, 0]].reshape(-1, 2), k2[idx[:, 1]].reshape(-1, 2), r, np.sqrt(s1[idx[:, 0]] * s2[idx[:, 1]])))
        warm_up(plan, matches, ms)
        records = [run_pair(p, m[0], m[1], m[2], ms, a.seeds, m[3]) for p, m in zip(plan, matches)]
        res = {
            "config": {"datasets": {k: v[0].kind for k, v in data.items()}, "seeds": a.seeds, "ratio": RATIO, "min_matches": MIN_MATCHES, "gt_px": GT_PX, "gt_min": GT_MIN},
            "methods": ms,
            "pairs": records,
        }
        res["summary"] = summarize(res)
        wrong = wrong_ok(records, ms)
        out["front_ends"][fe] = res if a.full_json else {k: v for k, v in res.items() if k != "pairs"} | {"wrong_ok": wrong}
        md += [f"## {fe}", "", f"matches per pair (median): {int(np.median([len(m[0]) for m in matches]))}", "", overview_markdown(res), ""]
        md += ["`ok` poses more than 5 deg off, every seed (pair, seed: error, inliers; PoseLib 1 px's error on the same pair and seed):", ""]
        md += [f"* {w['dataset']} {w['pair']} seed {w['seed']} ({w['method']}): {w['R_err']:.2f} deg, {w['inliers']} inliers; PoseLib {w['poselib_R_err']}" for w in wrong] or [
            "* none"
        ]
        md.append("")
        print("\n".join(md[-5:]), flush=True)
    md.append(f"Machine: {out['machine']}; code `{out['code_version']}`.")
    if a.out:
        from poseonly.experiments._common import atomic_write_text, write_json

        d = Path(a.out)
        d.mkdir(parents=True, exist_ok=True)
        atomic_write_text(d / "real_frontends.md", "\n".join(md) + "\n")
        write_json(d / "real_frontends.json", out)
    return 0


if __name__ == "__main__":
    from poseonly.experiments.report import provenance

    print(provenance(), flush=True)
    raise SystemExit(main())
