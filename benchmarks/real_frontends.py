"""The real-data benchmark's methods on matches of other front-ends than full-resolution SIFT.

    python benchmarks/real_frontends.py DIR [DIR ...] [--front-end sift-1600 sift-1024 orb]
        [--seeds 3] [--methods poseonly poselib-1px poselib-2px opencv-magsac] [--cache /tmp/frontend_cache]
        [--out DIR] [--realpairs-sample N] [--status-table METHOD] [--max-pairs N]

``poseonly bench real`` matches full-resolution SIFT. Pipelines often resize first (hloc to 1024 or
1600 px, COLMAP to 3200), which scales the keypoints' noise in full-resolution pixels by the inverse
of the factor, and some use other detectors. Front-ends:

* ``sift-S``: OpenCV SIFT on the image resized (``INTER_AREA``) so that its long side is at most ``S``
  pixels; keypoints and sizes mapped back to full-resolution pixels (the ground truth's ``K`` is kept);
* ``orb``: OpenCV ORB (8000 features) on the full-resolution image, binary descriptors matched by
  Hamming distance.

Matching is the bench's: two nearest neighbours, Lowe's ratio 0.8 (not mutual), the score ``1 - ratio``
(PROSAC for the default), keypoint sizes as noise scales. The methods, metrics and tables are
:mod:`poseonly.experiments.real_bench`'s (``run_pair``, ``summarize``, ``overview_markdown``), time
ratios to PoseLib 1 px in the same run. Features and matches are cached per front-end in ``--cache``.

The front-ends of the frontends18 trial (status reliability on other front-ends) work in the pixels of
the image they detect on, as a pipeline that resizes would feed them: the keypoints are not mapped back,
the ground truth's ``K`` is scaled instead (``fx sx``, ``(cx + 0.5) sx - 0.5``, likewise in y). Images
wider than 1500 px (Strecha's 3072) are resized (``INTER_AREA``) to 1536 px wide; Middlebury temple
(640 px) and KITTI (1241 px) keep their size. Matching is OpenCV's brute force (``BFMatcher``, L2 or
Hamming), two nearest neighbours:

* ``sift-r0.8``, ``sift-r0.9``: SIFT, Lowe's ratio 0.8 / 0.9;
* ``sift-mnn``: SIFT, mutual nearest neighbours without a ratio test (no match scores: every method
  runs without them, as the trial passed ``scores=None``);
* ``brisk-r0.8``, ``akaze-r0.8``: OpenCV's BRISK / AKAZE (defaults), ratio 0.8. They need an OpenCV with
  BRISK and AKAZE (``cv2.BRISK_create`` or, in OpenCV 5, ``cv2.xfeatures2d.BRISK_create`` of
  ``opencv-contrib-python-headless``); without them they are skipped with a note;
* ``sift640-r0.8``: SIFT on every image resized to 640 px wide, ratio 0.8;
* ``orb500-r0.8``: ORB with 500 features, ratio 0.8;
* ``sift-jpeg20-r0.8``: SIFT on the (resized) image re-encoded as JPEG at quality 20, ratio 0.8.

``--status-table METHOD`` adds the trial's table per front-end and dataset, seed 0: pairs, median matches,
``ok`` statuses of METHOD, ``ok`` poses more than 5 deg off (and 2-5 deg off), pairs where PoseLib 1 px
is within 2 deg of the truth and the share of those METHOD calls ``ok``, the median rotation errors of
METHOD (its ``ok`` poses, all pairs; a failure counts as infinite) and of PoseLib 1 px, and the status
counts. ``--realpairs-sample N`` keeps N evenly spaced pairs of every realpairs dataset (Strecha scenes
keep every pair). The trial's table (PoseLib 1 px and poseonly's default with the ratio scores but no
noise scales, seed 0; 28 + 55 + 45 Strecha pairs, 40 temple and 40 KITTI pairs):

    S=/work/shared/data/strecha P=/work/shared/data/realpairs
    python benchmarks/real_frontends.py $S/Herz-Jesus-P8 $S/fountain-P11 $S/entry-P10 $P/middlebury_temple $P/kitti_seq1
        --front-end sift-r0.8 brisk-r0.8 akaze-r0.8 sift-r0.9 sift-mnn sift640-r0.8 orb500-r0.8 sift-jpeg20-r0.8
        --realpairs-sample 40 --seeds 1 --methods poseonly-noscale poselib-1px --status-table poseonly-noscale --out DIR

(BRISK and AKAZE: in an environment whose ``cv2`` has them, e.g. a virtual environment made with
``--system-site-packages`` holding ``opencv-contrib-python-headless``.)
"""

from __future__ import annotations

import argparse
import dataclasses
import hashlib
import json
import sys
from pathlib import Path
from typing import Any

import numpy as np

RATIO = 0.8
# the frontends18 trial's front-ends: (detector, image preparation, Lowe's ratio or None for mutual nearest neighbours)
TRIAL_FRONT_ENDS: dict[str, tuple[str, str, float | None]] = {
    "sift-r0.8": ("sift", "base", 0.8),
    "brisk-r0.8": ("brisk", "base", 0.8),
    "akaze-r0.8": ("akaze", "base", 0.8),
    "sift-r0.9": ("sift", "base", 0.9),
    "sift-mnn": ("sift", "base", None),
    "sift640-r0.8": ("sift", "w640", 0.8),
    "orb500-r0.8": ("orb500", "base", 0.8),
    "sift-jpeg20-r0.8": ("sift", "jpeg20", 0.8),
}
FRONT_ENDS = ("sift-1600", "sift-1024", "orb", *TRIAL_FRONT_ENDS)
ORB_FEATURES = 8000
DEFAULT_METHODS = ("poseonly", "poselib-1px", "poselib-2px", "opencv-magsac")
WIDE_PX = 1500  # the trial's preparations "base" and "jpeg20" resize images wider than this ...
BASE_WIDTH = 1536  # ... to this width (Strecha's 3072 px halved)
SMALL_WIDTH = 640  # "w640": every image to this width
JPEG_QUALITY = 20  # "jpeg20"
ORB_SMALL_FEATURES = 500  # "orb500"
CONTRIB = {"brisk": "BRISK", "akaze": "AKAZE"}  # detectors some OpenCV builds lack
REFERENCE = "poselib-1px"  # the status table's reference (its "PL")


def _trial_features_name(det: str, prep: str) -> str:
    """The cache name of a trial front-end's features: detector, preparation and OpenCV's version (the
    matches index the features, so features of another OpenCV must not meet cached matches; a review)."""
    import cv2

    return f"{det}-{prep}-opencv{cv2.__version__}"


def _key(path: Path, front_end: str) -> str:
    st = path.stat()
    return hashlib.sha256(json.dumps([str(path.resolve()), st.st_size, st.st_mtime_ns, front_end, 1]).encode()).hexdigest()[:32]


def features(path: Path, front_end: str, cache: Path) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Keypoints ``(m, 2)`` in full-resolution pixels, descriptors ``(m, D)`` and sizes ``(m,)`` (cached)."""
    import cv2

    from poseonly._fileutil import atomic_savez
    from poseonly.features import extract_features, read_image

    if front_end in TRIAL_FRONT_ENDS:
        raise SystemExit(f"{front_end!r} works in the pixels of its resized image: use prepared_features() and prepared_pair()")
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


# ------------------------------------------------------------------------------------------------
# the frontends18 trial's front-ends (keypoints in the pixels of the image they were detected on)


def _contrib_factory(cv2: Any, detector: str) -> Any:
    """``cv2.BRISK_create`` / ``cv2.AKAZE_create`` (OpenCV 4) or ``cv2.xfeatures2d``'s (OpenCV 5 contrib); ``None`` if absent."""
    name = f"{CONTRIB[detector]}_create"
    for mod in (cv2, getattr(cv2, "xfeatures2d", None)):
        if mod is not None and hasattr(mod, name):
            return getattr(mod, name)
    return None


def missing_detector(front_end: str) -> str | None:
    """Why ``front_end`` cannot run here (its detector is not in this ``cv2``), or ``None``."""
    det = TRIAL_FRONT_ENDS[front_end][0] if front_end in TRIAL_FRONT_ENDS else None
    if det not in CONTRIB:
        return None
    import cv2

    if _contrib_factory(cv2, det) is not None:
        return None
    return (
        f"this OpenCV ({cv2.__version__}, {Path(cv2.__file__).parent}) has no {CONTRIB[det]} (neither cv2.{CONTRIB[det]}_create nor cv2.xfeatures2d.{CONTRIB[det]}_create); "
        "run in an environment with opencv-contrib-python-headless"
    )


def _detector(det: str) -> Any:
    import cv2

    if det == "sift":
        return cv2.SIFT_create()
    if det == "orb500":
        return cv2.ORB_create(nfeatures=ORB_SMALL_FEATURES)
    make = _contrib_factory(cv2, det)
    if make is None:
        raise SystemExit(f"{det}: {missing_detector(next(k for k, v in TRIAL_FRONT_ENDS.items() if v[0] == det))}")
    return make()


def prepared_image(path: Path, prep: str) -> tuple[np.ndarray, tuple[float, float]]:
    """The grayscale image the detector sees under preparation ``prep`` and its scale ``(sx, sy)`` to the file's pixels."""
    import cv2

    from poseonly.features import read_image

    gray = read_image(path)
    h, w = gray.shape
    target = w
    if prep in ("base", "jpeg20") and w > WIDE_PX:
        target = BASE_WIDTH
    elif prep == "w640":
        target = SMALL_WIDTH
    elif prep not in ("base", "jpeg20"):
        raise SystemExit(f"unknown image preparation {prep!r}")
    if target < w:
        gray = cv2.resize(gray, (target, round(h * target / w)), interpolation=cv2.INTER_AREA)
    if prep == "jpeg20":
        ok, buf = cv2.imencode(".jpg", gray, [cv2.IMWRITE_JPEG_QUALITY, JPEG_QUALITY])
        if not ok:
            raise SystemExit(f"JPEG encoding failed for {path}")
        gray = cv2.imdecode(buf, cv2.IMREAD_GRAYSCALE)
    return gray, (gray.shape[1] / w, gray.shape[0] / h)


def prepared_features(path: Path, front_end: str, cache: Path) -> tuple[np.ndarray, np.ndarray, np.ndarray, tuple[float, float]]:
    """Keypoints ``(m, 2)`` in the prepared image's pixels, descriptors ``(m, D)``, sizes ``(m,)`` and the
    image's scale ``(sx, sy)`` of a trial front-end (cached per detector and preparation, shared by the
    front-ends that differ in matching only)."""
    from poseonly._fileutil import atomic_savez

    det, prep, _ = TRIAL_FRONT_ENDS[front_end]
    name = _trial_features_name(det, prep)
    f = cache / "features" / f"{name}_{_key(path, name)}.npz"
    if f.is_file():
        with np.load(f) as z:
            return z["kp"], z["desc"], z["sizes"], (float(z["scale"][0]), float(z["scale"][1]))
    gray, scale = prepared_image(path, prep)
    kps, d = _detector(det).detectAndCompute(gray, None)
    kp = np.array([k.pt for k in kps], dtype=np.float64).reshape(-1, 2)
    sizes = np.array([k.size for k in kps], dtype=np.float64)
    desc = d if d is not None else (np.zeros((0, 128), np.float32) if det == "sift" else np.zeros((0, 64), np.uint8))
    atomic_savez(f, kp=kp, desc=desc, sizes=sizes, scale=np.array(scale))
    return kp, desc, sizes, scale


def frontend_matches(d1: np.ndarray, d2: np.ndarray, ratio: float | None) -> tuple[np.ndarray, np.ndarray]:
    """The trial's matching (``cv2.BFMatcher``, L2 or Hamming, two nearest neighbours): index pairs ``(k, 2)``
    and Lowe ratios ``(k,)`` of the ratio test at ``ratio``, or of the mutual nearest neighbours (ratios NaN)
    when ``ratio`` is ``None``."""
    import cv2

    if len(d1) < 2 or len(d2) < 2:
        return np.zeros((0, 2), np.int64), np.zeros(0)
    bf = cv2.BFMatcher(cv2.NORM_HAMMING if d1.dtype == np.uint8 else cv2.NORM_L2)
    knn = bf.knnMatch(d1, d2, k=2)
    q = np.array([m[0].queryIdx for m in knn], dtype=np.int64)
    tr = np.array([m[0].trainIdx for m in knn], dtype=np.int64)
    a = np.array([m[0].distance for m in knn], dtype=np.float64)
    b = np.array([m[1].distance for m in knn], dtype=np.float64)
    if ratio is not None:
        keep = a < ratio * b
        return np.stack([q[keep], tr[keep]], axis=1), a[keep] / np.maximum(b[keep], 1e-30)
    nn21 = np.full(len(d2), -1, dtype=np.int64)
    for m in bf.match(d2, d1):
        nn21[m.queryIdx] = m.trainIdx
    keep = nn21[tr] == q
    return np.stack([q[keep], tr[keep]], axis=1), np.full(int(keep.sum()), np.nan)


def cached_frontend_matches(p1: Path, p2: Path, front_end: str, d1: np.ndarray, d2: np.ndarray, cache: Path) -> tuple[np.ndarray, np.ndarray]:
    """:func:`frontend_matches` of a trial front-end, cached per image pair."""
    from poseonly._fileutil import atomic_savez

    det, prep, ratio = TRIAL_FRONT_ENDS[front_end]
    name = _trial_features_name(det, prep)
    key = hashlib.sha256(json.dumps([_key(p1, name), _key(p2, name), ratio]).encode()).hexdigest()[:32]
    f = cache / "matches" / f"{front_end}_{key}.npz"
    if f.is_file():
        with np.load(f) as z:
            return z["idx"], z["ratio"]
    idx, r = frontend_matches(d1, d2, ratio)
    atomic_savez(f, idx=idx, ratio=r)
    return idx, r


def scaled_K(K: np.ndarray, scale: tuple[float, float]) -> np.ndarray:
    """``K`` of the image resized by ``scale = (sx, sy)`` (pixel centres at integer coordinates)."""
    sx, sy = scale
    return np.array([[K[0, 0] * sx, K[0, 1] * sx, (K[0, 2] + 0.5) * sx - 0.5], [0.0, K[1, 1] * sy, (K[1, 2] + 0.5) * sy - 0.5], [0.0, 0.0, 1.0]])


def prepared_pair(pair: Any, s1: tuple[float, float], s2: tuple[float, float]) -> Any:
    """``pair`` (a :class:`~poseonly.experiments.real_bench.Pair`) with its intrinsics scaled to the prepared images."""
    return dataclasses.replace(pair, K1=scaled_K(pair.K1, s1), K2=scaled_K(pair.K2, s2))


def _without_scores(name: str, fn: Any) -> Any:
    """``fn`` called without match scores (a front-end with none): ``None`` (no PROSAC), or zeros for
    SupeRANSAC, which sorts by them (the matches' own order)."""

    def run(u1: np.ndarray, u2: np.ndarray, K1: np.ndarray, K2: np.ndarray, scores: Any, seed: int, noise_scales: np.ndarray | None = None) -> Any:
        return fn(u1, u2, K1, K2, np.zeros(len(u1)) if name == "superansac" else None, seed, noise_scales)

    return run


def sample_realpairs(data: dict[str, list], n: int | None) -> dict[str, list]:
    """``n`` evenly spaced pairs of every realpairs dataset (the trial's selection); Strecha scenes unchanged."""
    if n is None:
        return data
    out = {}
    for name, pairs in data.items():
        if pairs[0].kind == "realpairs" and len(pairs) > n:
            idx = np.unique(np.round(np.linspace(0, len(pairs) - 1, n)).astype(int))
            pairs = [pairs[i] for i in idx]
        out[name] = pairs
    return out


# ------------------------------------------------------------------------------------------------
# reports


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


def status_rows(front_end: str, records: list[dict], method: str, datasets: list[str]) -> list[dict]:
    """The trial's figures per dataset, seed 0: ``method``'s statuses and rotation errors against PoseLib 1 px's."""
    from poseonly.experiments.real_bench import GOOD_DEG, WRONG_DEG

    rows = []
    for ds in datasets:
        rs = [r for r in records if r["dataset"] == ds]
        if not rs:
            continue
        err = np.array([np.inf if r["methods"][method][0]["R_err"] is None else r["methods"][method][0]["R_err"] for r in rs])
        ref = np.array([np.inf if r["methods"][REFERENCE][0]["R_err"] is None else r["methods"][REFERENCE][0]["R_err"] for r in rs])
        status = [str(r["methods"][method][0]["status"]) for r in rs]
        ok = np.array([s == "ok" for s in status])
        good = ref <= GOOD_DEG
        counts: dict[str, int] = {}
        missed: dict[str, int] = {}
        for s, g in zip(status, good):
            counts[s] = counts.get(s, 0) + 1
            if g and s != "ok":
                missed[s] = missed.get(s, 0) + 1
        rows.append(
            {
                "front_end": front_end,
                "dataset": ds,
                "pairs": len(rs),
                "median_matches": int(np.median([r["matches"] for r in rs])),
                "ok": int(ok.sum()),
                "wrong_ok": int((ok & (err > WRONG_DEG)).sum()),
                "ok_2_5": int((ok & (err > GOOD_DEG) & (err <= WRONG_DEG)).sum()),
                "reference_good": int(good.sum()),
                "ok_among_reference_good": int((ok & good).sum()),
                "median_err_ok": float(np.median(err[ok])) if ok.any() else None,
                "median_err_all": float(np.median(err)),
                "median_err_reference": float(np.median(ref)),
                "statuses": counts,
                "reference_good_not_ok": missed,
            }
        )
    return rows


def status_markdown(rows: list[dict], method: str) -> list[str]:
    from poseonly.experiments.real_bench import GOOD_DEG, WRONG_DEG

    def med(x: float | None) -> str:
        return "-" if x is None else f"{x:.2f}"

    md = [
        f"## Status reliability per front-end ({method}, seed 0; reference {REFERENCE})",
        "",
        f"| front-end | dataset | pairs | med matches | ok | wrong ok >{WRONG_DEG:g}° | ok {GOOD_DEG:g}-{WRONG_DEG:g}° | PL≤{GOOD_DEG:g}° | ok among PL≤{GOOD_DEG:g}° "
        "| med err ours (ok) | med err ours (all) | med err PL |",
        "|" + "---|" * 12,
    ]
    for r in rows:
        g, k = r["reference_good"], r["ok_among_reference_good"]
        md.append(
            f"| {r['front_end']} | {r['dataset']} | {r['pairs']} | {r['median_matches']} | {r['ok']} | {r['wrong_ok']} | {r['ok_2_5']} "
            f"| {g} | {k}/{g} ({100 * k / max(g, 1):.0f}%) | {med(r['median_err_ok'])} | {med(r['median_err_all'])} | {med(r['median_err_reference'])} |"
        )
    md += ["", "Statuses (all pairs; PoseLib within 2 deg but not `ok`):", ""]
    md += [f"* {r['front_end']} {r['dataset']}: {r['statuses']}; {r['reference_good_not_ok'] or 'none'}" for r in rows]
    return md + [""]


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("dirs", nargs="+")
    ap.add_argument("--front-end", nargs="+", default=list(FRONT_ENDS[:1]), choices=FRONT_ENDS)
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--methods", nargs="+", default=list(DEFAULT_METHODS))
    ap.add_argument("--cache", default="/tmp/frontend_cache")
    ap.add_argument("--out", default=None, help="write real_frontends.md / .json here")
    ap.add_argument("--full-json", action="store_true", help="keep every pair's records in the JSON (else the summaries and the wrong ok poses)")
    ap.add_argument("--realpairs-sample", type=int, default=None, metavar="N", help="N evenly spaced pairs of every realpairs dataset (the frontends18 trial: 40); default all")
    ap.add_argument("--max-pairs", type=int, default=None, metavar="N", help="the first N pairs of every dataset (quick checks)")
    ap.add_argument(
        "--status-table", default=None, metavar="METHOD", help=f"add the frontends18 trial's status table of METHOD against {REFERENCE} (seed 0; both must be in --methods)"
    )
    a = ap.parse_args(argv)
    if a.status_table and (a.status_table not in a.methods or REFERENCE not in a.methods):
        ap.error(f"--status-table needs {a.status_table} and {REFERENCE} in --methods")
    from unittest import mock

    from poseonly.experiments import real_bench
    from poseonly.experiments._common import code_version, machine, single_thread
    from poseonly.experiments.real_bench import GT_MIN, GT_PX, MIN_MATCHES, available_methods, load_datasets, overview_markdown, run_pair, summarize, warm_up

    single_thread()
    ms, notes = available_methods(a.methods)
    if a.status_table and (a.status_table not in ms or REFERENCE not in ms):
        raise SystemExit(f"--status-table: {a.status_table} or {REFERENCE} is unavailable ({'; '.join(notes)})")
    data = sample_realpairs(load_datasets(a.dirs), a.realpairs_sample)
    if a.max_pairs is not None:
        data = {k: v[: a.max_pairs] for k, v in data.items()}
    cache = Path(a.cache)
    plan = [p for pairs in data.values() for p in pairs]
    shown = sys.argv[1:] if argv is None else argv
    md = [f"# The real benchmark's methods on other front-ends (`python benchmarks/real_frontends.py {' '.join(shown)}`)", ""]
    out: dict = {"front_ends": {}, "machine": machine(), "code_version": code_version(), "notes": notes}
    table: list[dict] = []
    for fe in a.front_end:
        why = missing_detector(fe)
        if why:
            print(f"{fe} skipped: {why}", flush=True)
            out["notes"].append(f"{fe} skipped: {why}")
            md += [f"## {fe}", "", f"skipped: {why}", ""]
            continue
        matches = []
        pairs = plan
        ratio = RATIO
        if fe in TRIAL_FRONT_ENDS:
            ratio = TRIAL_FRONT_ENDS[fe][2]
            pairs = []
            for p in plan:
                k1, d1, s1, sc1 = prepared_features(p.im1, fe, cache)
                k2, d2, s2, sc2 = prepared_features(p.im2, fe, cache)
                idx, r = cached_frontend_matches(p.im1, p.im2, fe, d1, d2, cache)
                matches.append((k1[idx[:, 0]].reshape(-1, 2), k2[idx[:, 1]].reshape(-1, 2), r, np.sqrt(s1[idx[:, 0]] * s2[idx[:, 1]])))
                pairs.append(prepared_pair(p, sc1, sc2))
        else:
            for p in plan:
                k1, d1, s1 = features(p.im1, fe, cache)
                k2, d2, s2 = features(p.im2, fe, cache)
                idx, r = ratio_matches(d1, d2)
                matches.append((k1[idx[:, 0]].reshape(-1, 2), k2[idx[:, 1]].reshape(-1, 2), r, np.sqrt(s1[idx[:, 0]] * s2[idx[:, 1]])))
        # a front-end without match scores (mutual nearest neighbours): every method runs without them
        scoreless = {m: _without_scores(m, real_bench.METHODS[m]) for m in ms} if ratio is None else {}
        with mock.patch.dict(real_bench.METHODS, scoreless):
            warm_up(pairs, matches, ms)
            records = [run_pair(p, m[0], m[1], m[2], ms, a.seeds, m[3]) for p, m in zip(pairs, matches)]
        res = {
            "config": {"datasets": {k: v[0].kind for k, v in data.items()}, "seeds": a.seeds, "ratio": ratio, "min_matches": MIN_MATCHES, "gt_px": GT_PX, "gt_min": GT_MIN},
            "methods": ms,
            "pairs": records,
        }
        if fe in TRIAL_FRONT_ENDS:
            det, prep, _ = TRIAL_FRONT_ENDS[fe]
            res["config"] |= {"detector": det, "preparation": prep, "coordinates": "prepared image pixels, K scaled", "scores": ratio is not None}
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
        if a.status_table:
            table += status_rows(fe, records, a.status_table, list(data))
    if a.status_table:
        out["status_table"] = {"method": a.status_table, "reference": REFERENCE, "rows": table}
        md += status_markdown(table, a.status_table)
        print("\n".join(status_markdown(table, a.status_table)), flush=True)
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
