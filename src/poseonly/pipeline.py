"""Images to relative pose: features, matching, robust estimation, drawing (used by the CLI and demo)."""

from __future__ import annotations

import os
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ._fileutil import atomic_write_bytes
from .api import RelativePoseResult, estimate_relative_pose
from .geometry import InputError, rotation_error_deg, translation_error_deg

__all__ = ["relpose_images", "relpose_matches", "draw_matches", "run_demo", "PairResult"]


@dataclass
class PairResult:
    """A pair's result with its matches ``u1, u2 (k, 2)`` in the images' pixels (OpenCV's convention
    for our own features), the stage times and ``dropped``: matches left out because a camera model
    could not undistort a keypoint of theirs (with ``camera1/camera2``); ``kept``: where matches were
    given and some dropped, the indices of the given rows that ``u1, u2`` (and ``result``'s arrays) are."""

    result: RelativePoseResult
    u1: np.ndarray
    u2: np.ndarray
    time_features_s: float
    time_estimate_s: float
    dropped: int = 0
    kept: np.ndarray | None = None


def _liftable(u1: np.ndarray, u2: np.ndarray, options: dict[str, Any], shift: float = 0.0) -> tuple[np.ndarray, dict[str, Any]]:
    """With ``camera1`` (/ ``camera2``) in ``options``: the mask of the matches ``(k, 2)`` whose two
    keypoints (plus ``shift`` pixels) the camera models can undistort, and the options with the cameras
    converted (:func:`poseonly.cameras.as_camera`); all True and ``options`` unchanged without them."""
    if options.get("camera1") is None or not len(u1):
        return np.ones(len(u1), bool), options
    from .cameras import as_camera

    c1 = as_camera(options["camera1"], "camera1")
    c2 = c1 if options.get("camera2") is None else as_camera(options["camera2"], "camera2")
    ok = np.isfinite(c1.unproject(u1 + shift, invalid="nan")[:, 0]) & np.isfinite(c2.unproject(u2 + shift, invalid="nan")[:, 0])
    return ok, {**options, "camera1": c1, "camera2": c2}


def relpose_matches(u1: np.ndarray, u2: np.ndarray, K1: np.ndarray | None, K2: np.ndarray | None, **options: Any) -> PairResult:
    """Robust relative pose from pixel matches (validated; ``ValueError`` below 6 matches). With
    ``camera1`` (/ ``camera2``) options, matches with a keypoint the model cannot undistort are left out
    (``PairResult.dropped``; their ``scores`` and ``noise_scales`` with them)."""
    u1 = np.asarray(u1, float)
    u2 = np.asarray(u2, float)
    dropped = 0
    kept = None
    if u1.ndim == 2 and u1.shape == u2.shape and u1.shape[1] == 2 and np.isfinite(u1).all() and np.isfinite(u2).all():
        ok, options = _liftable(u1, u2, options)
        dropped = int(np.count_nonzero(~ok))
        if dropped:
            kept = np.flatnonzero(ok)
            u1, u2 = u1[ok], u2[ok]
            for key in ("scores", "noise_scales"):
                v = options.get(key)
                if v is not None and np.ndim(v) == 1 and len(v) == len(ok):
                    options = {**options, key: np.asarray(v)[ok]}
    if len(u1) < 6:
        why = f" ({dropped} left out: a camera model could not undistort a keypoint)" if dropped else ""
        raise InputError(f"only {len(u1)} matches{why}: at least 6 are needed for a relative pose")
    t0 = time.perf_counter()
    r = estimate_relative_pose(u1, u2, K1, K2, **options)
    return PairResult(r, u1, u2, 0.0, time.perf_counter() - t0, dropped, kept)


def relpose_images(
    img1: str | os.PathLike | np.ndarray,
    img2: str | os.PathLike | np.ndarray,
    K1: np.ndarray | None,
    K2: np.ndarray | None = None,
    *,
    ratio: float = 0.8,
    mutual: bool = False,
    cache_dir: str | os.PathLike | None = None,
    **options: Any,
) -> PairResult:
    """SIFT + ratio-test matching + :func:`poseonly.estimate_relative_pose` on two image files. With
    ``camera1`` (/ ``camera2``) options instead of ``K1``: cameras in COLMAP's pixel convention (an
    OpenCV ``(K, dist)`` converted to it; the OpenCV keypoints are shifted by
    :data:`poseonly.cameras.OPENCV_TO_COLMAP_PX`), and matches with a
    keypoint the model cannot undistort are left out (``PairResult.dropped``)."""
    from .features import match_images

    t0 = time.perf_counter()
    m = match_images(img1, img2, ratio=ratio, mutual=mutual, cache_dir=cache_dir)
    tf = time.perf_counter() - t0
    u1, u2, scores, scales = m.u1, m.u2, m.scores, m.noise_scales
    dropped = 0
    if options.get("camera1") is not None:
        from .cameras import OPENCV_TO_COLMAP_PX, as_colmap_camera

        c1 = as_colmap_camera(options["camera1"], "camera1")
        c2 = c1 if options.get("camera2") is None else as_colmap_camera(options["camera2"], "camera2")
        ok, options = _liftable(u1, u2, {**options, "camera1": c1, "camera2": c2}, OPENCV_TO_COLMAP_PX)
        dropped = int(np.count_nonzero(~ok))
        u1, u2 = u1[ok], u2[ok]
        scores = None if scores is None else scores[ok]
        scales = None if scales is None else scales[ok]
    if len(u1) < 6:
        why = f" ({dropped} left out: a camera model could not undistort a keypoint)" if dropped else ""
        raise InputError(f"only {len(u1)} matches between {img1} and {img2}{why}: at least 6 are needed")
    options.setdefault("scores", scores)  # the ratio test's quality drives PROSAC sampling
    options.setdefault("noise_scales", scales)  # the keypoints' sizes weight the ML refinement
    if options.get("camera1") is not None:
        t1 = time.perf_counter()
        r = estimate_relative_pose(u1 + OPENCV_TO_COLMAP_PX, u2 + OPENCV_TO_COLMAP_PX, K1, K2, **options)
        pr = PairResult(r, u1, u2, tf, time.perf_counter() - t1, dropped)
    else:
        pr = relpose_matches(u1, u2, K1, K1 if K2 is None else K2, **options)
        pr.time_features_s = tf
    return pr


DRAW_FORMATS = (".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff", ".webp")


# drawing colours (BGR) and layout
INLIER_BGR, OUTLIER_BGR, EPIPOLAR_BGR = (0, 200, 0), (0, 0, 255), (255, 160, 0)
LEGEND_ROW_PX = 22
LEGEND_FONT_SCALE = 0.55  # cv2.putText scale of the legend text (cv2.FONT_HERSHEY_SIMPLEX)


def _clip_line(line: np.ndarray, w: int, h: int) -> tuple[tuple[int, int], tuple[int, int]] | None:
    """End points of the image line ``l = (a, b, c)``, ``a x + b y + c = 0``, inside a ``w x h`` image."""
    a, b, c = (float(v) for v in line)
    pts = []
    if abs(b) > 1e-12:
        pts += [(x, -(a * x + c) / b) for x in (0.0, w - 1.0)]
    if abs(a) > 1e-12:
        pts += [(-(b * y + c) / a, y) for y in (0.0, h - 1.0)]
    inside = [(x, y) for x, y in pts if -0.5 <= x <= w - 0.5 and -0.5 <= y <= h - 0.5]
    if len(inside) < 2:
        return None
    (x0, y0), (x1, y1) = inside[0], inside[-1]
    return (int(round(x0)), int(round(y0))), (int(round(x1)), int(round(y1)))


def draw_matches(
    img1: str | os.PathLike,
    img2: str | os.PathLike,
    u1: np.ndarray,
    u2: np.ndarray,
    inliers: np.ndarray,
    out: str | Path,
    max_lines: int = 400,
    seed: int = 0,
    *,
    F: np.ndarray | None = None,
    epipolar: int = 0,
    title: str | None = None,
) -> Path:
    """Side-by-side drawing of matches ``u1, u2 (n, 2)`` (pixels): inliers green, outliers red (a
    seeded random subset of ``max_lines``), a legend with the counts, and, with a fundamental matrix
    ``F (3, 3)`` (``u2^T F u1 = 0``) and ``epipolar > 0``, the epipolar lines of that many inliers in
    both images (``F u1`` in image 2, ``F^T u2`` in image 1). Written atomically."""
    import cv2

    from .features import read_image

    out = Path(out)
    ext = out.suffix.lower()
    if out.is_dir():
        raise InputError(f"--draw/out {out} is a directory; give an image file name (e.g. matches.png)")
    if ext not in DRAW_FORMATS:
        raise InputError(f"cannot write a match drawing as {out.name!r}: the suffix must be one of {list(DRAW_FORMATS)}")
    u1 = np.asarray(u1, float)
    u2 = np.asarray(u2, float)
    inl = np.asarray(inliers, bool)
    if not (u1.shape == u2.shape == (len(inl), 2)):
        raise InputError(f"draw_matches: u1, u2 must be (n, 2) and inliers (n,), got {u1.shape}, {u2.shape}, {inl.shape}")
    if epipolar and F is None:
        raise InputError("epipolar lines need the fundamental matrix F (a pose and pinhole calibrations)")
    a = read_image(img1, grayscale=False)
    b = read_image(img2, grayscale=False)
    if a.ndim == 2:
        a = cv2.cvtColor(a, cv2.COLOR_GRAY2BGR)
    if b.ndim == 2:
        b = cv2.cvtColor(b, cv2.COLOR_GRAY2BGR)
    h = max(a.shape[0], b.shape[0])
    canvas = np.zeros((h, a.shape[1] + b.shape[1], 3), np.uint8)
    canvas[: a.shape[0], : a.shape[1]] = a
    canvas[: b.shape[0], a.shape[1] :] = b
    off = a.shape[1]
    rng = np.random.default_rng(seed)
    idx = rng.permutation(len(u1))[:max_lines]
    for i in idx:
        p = (int(round(u1[i, 0])), int(round(u1[i, 1])))
        q = (int(round(u2[i, 0] + off)), int(round(u2[i, 1])))
        col = INLIER_BGR if inl[i] else OUTLIER_BGR
        cv2.line(canvas, p, q, col, 1, cv2.LINE_AA)
        cv2.circle(canvas, p, 2, col, -1)
        cv2.circle(canvas, q, 2, col, -1)
    n_epi = 0
    if epipolar and F is not None:
        Fm = np.asarray(F, float)
        ids = np.flatnonzero(inl)
        for i in rng.permutation(ids)[:epipolar]:
            l2 = Fm @ np.array([u1[i, 0], u1[i, 1], 1.0])
            l1 = Fm.T @ np.array([u2[i, 0], u2[i, 1], 1.0])
            s2 = _clip_line(l2, b.shape[1], b.shape[0])
            s1 = _clip_line(l1, a.shape[1], a.shape[0])
            if s2 is not None:
                cv2.line(canvas, (s2[0][0] + off, s2[0][1]), (s2[1][0] + off, s2[1][1]), EPIPOLAR_BGR, 2, cv2.LINE_AA)
            if s1 is not None:
                cv2.line(canvas, s1[0], s1[1], EPIPOLAR_BGR, 2, cv2.LINE_AA)
            n_epi += int(s1 is not None or s2 is not None)
    n, k = len(inl), int(np.count_nonzero(inl))
    rows = [(f"inliers: {k} / {n} matches ({100.0 * k / max(n, 1):.1f}%)", INLIER_BGR), (f"outliers: {n - k}", OUTLIER_BGR)]
    if len(idx) < n:
        rows.append((f"drawn: {len(idx)} random matches of {n}", (255, 255, 255)))
    if n_epi:
        rows.append((f"epipolar lines of {n_epi} inliers", EPIPOLAR_BGR))
    if title:
        rows.insert(0, (title, (255, 255, 255)))
    box_h = LEGEND_ROW_PX * len(rows) + 8
    cv2.rectangle(canvas, (0, 0), (min(canvas.shape[1] - 1, 430), min(h - 1, box_h)), (0, 0, 0), -1)
    for r, (text, col) in enumerate(rows):
        cv2.putText(canvas, text, (8, LEGEND_ROW_PX * (r + 1)), cv2.FONT_HERSHEY_SIMPLEX, LEGEND_FONT_SCALE, col, 1, cv2.LINE_AA)
    ok, buf = cv2.imencode(ext, canvas)
    if not ok:
        raise InputError(f"could not encode the drawing as {ext}")
    atomic_write_bytes(out, buf.tobytes())
    return out


def run_demo(draw: str | Path | None = "poseonly_demo_matches.png", method: str = "poseonly", seed: int = 0) -> dict[str, Any]:
    """The embedded real pair (fountain-P11, 960x640): features, matching, robust pose, error vs GT."""
    from .demo_data import load_demo_pair

    d = load_demo_pair()
    pr = relpose_images(d.image1, d.image2, d.K1, d.K2, method=method, seed=seed)
    r = pr.result
    out = {
        "pair": f"{d.meta.get('scene', 'fountain-P11')} {d.image1.name} / {d.image2.name}",
        "num_matches": int(len(pr.u1)),
        "num_inliers": r.num_inliers,
        "inlier_ratio": r.inlier_ratio,
        "status": r.status,
        "R": r.R,
        "t": r.t,
        "R_gt": d.R_gt,
        "t_gt": d.t_gt,
        "rotation_error_deg": float(rotation_error_deg(d.R_gt, r.R)) if r.R is not None else float("nan"),
        "translation_error_deg": float(translation_error_deg(d.t_gt, r.t)) if r.t is not None else float("nan"),
        "rotation_std_deg": float(r.diagnostics.get("rotation_std_deg", float("nan"))),
        "translation_std_deg": float(r.diagnostics.get("translation_std_deg", float("nan"))),
        "time_features_s": pr.time_features_s,
        "time_estimate_s": pr.time_estimate_s,
    }
    if draw:
        out["drawing"] = str(draw_matches(d.image1, d.image2, pr.u1, pr.u2, r.inliers, draw))
    return out
