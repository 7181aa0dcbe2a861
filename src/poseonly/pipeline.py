"""Images to relative pose: features, matching, robust estimation, drawing (used by the CLI and demo)."""

from __future__ import annotations

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
    result: RelativePoseResult
    u1: np.ndarray
    u2: np.ndarray
    time_features_s: float
    time_estimate_s: float


def relpose_matches(u1, u2, K1, K2, **options: Any) -> PairResult:
    """Robust relative pose from pixel matches (validated; ``ValueError`` below 6 matches)."""
    u1 = np.asarray(u1, float)
    u2 = np.asarray(u2, float)
    if len(u1) < 6:
        raise InputError(f"only {len(u1)} matches: at least 6 are needed for a relative pose")
    t0 = time.perf_counter()
    r = estimate_relative_pose(u1, u2, K1, K2, **options)
    return PairResult(r, u1, u2, 0.0, time.perf_counter() - t0)


def relpose_images(img1, img2, K1, K2=None, *, ratio: float = 0.8, mutual: bool = False, cache_dir=None, **options: Any) -> PairResult:
    """SIFT + ratio-test matching + :func:`poseonly.estimate_relative_pose` on two image files."""
    from .features import match_images

    t0 = time.perf_counter()
    m = match_images(img1, img2, ratio=ratio, mutual=mutual, cache_dir=cache_dir)
    tf = time.perf_counter() - t0
    if len(m.u1) < 6:
        raise InputError(f"only {len(m.u1)} matches between {img1} and {img2}: at least 6 are needed")
    options.setdefault("scores", m.scores)  # the ratio test's quality drives PROSAC sampling
    pr = relpose_matches(m.u1, m.u2, K1, K1 if K2 is None else K2, **options)
    pr.time_features_s = tf
    return pr


DRAW_FORMATS = (".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff", ".webp")


def draw_matches(img1, img2, u1, u2, inliers, out: str | Path, max_lines: int = 400, seed: int = 0) -> Path:
    """Side-by-side drawing: inliers green, outliers red (a random subset of ``max_lines``)."""
    import cv2

    from .features import read_image

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
    rng = np.random.default_rng(seed)
    idx = rng.permutation(len(u1))[:max_lines]
    for i in idx:
        p = tuple(int(round(v)) for v in u1[i])
        q = (int(round(u2[i][0] + a.shape[1])), int(round(u2[i][1])))
        col = (0, 200, 0) if inliers[i] else (0, 0, 255)
        cv2.line(canvas, p, q, col, 1, cv2.LINE_AA)
        cv2.circle(canvas, p, 2, col, -1)
        cv2.circle(canvas, q, 2, col, -1)
    out = Path(out)
    ext = out.suffix.lower()
    if out.is_dir():
        raise InputError(f"--draw/out {out} is a directory; give an image file name (e.g. matches.png)")
    if ext not in DRAW_FORMATS:
        raise InputError(f"cannot write a match drawing as {out.name!r}: the suffix must be one of {list(DRAW_FORMATS)}")
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
        "time_features_s": pr.time_features_s,
        "time_estimate_s": pr.time_estimate_s,
    }
    if draw:
        out["drawing"] = str(draw_matches(d.image1, d.image2, pr.u1, pr.u2, r.inliers, draw))
    return out
