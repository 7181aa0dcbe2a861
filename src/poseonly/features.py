"""Real images: SIFT features, ratio-test matching, a feature cache and a match-file format.

OpenCV is an optional dependency (``pip install poseonly[opencv]``); it is imported inside the
functions that need it, so ``import poseonly.features`` works without it.

Pixel coordinates follow OpenCV: ``(x, y)`` = (column, row) with integer values at pixel centres.

Match files (:func:`load_matches_npz` / :func:`save_matches_npz`) are ``.npz`` archives with keys

* ``u1``, ``u2``: ``(k, 2)`` float pixel coordinates of the k matches in image 1 and image 2;
* ``K1``, ``K2`` (optional): ``(3, 3)`` intrinsics of each camera;
* ``K`` (optional): a ``(3, 3)`` intrinsic matrix shared by both cameras (used where ``K1``/``K2``
  is absent).
"""

from __future__ import annotations

import hashlib
import json
import os
import zipfile
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ._fileutil import CACHE_READ_ERRORS, atomic_savez, cache_savez, sweep_stale_temps
from .geometry import InputError, as_real_array, check_intrinsics, essential_from_pose, opencv_points

__all__ = [
    "Features",
    "MatchData",
    "Matches",
    "extract_features",
    "fundamental_from_pose",
    "load_matches_npz",
    "match_features",
    "match_images",
    "match_noise_scales",
    "read_image",
    "sampson_distance",
    "sampson_error_px",
    "save_matches_npz",
    "unreadable_images",
]

_CACHE_VERSION = 2  # 2: keypoint sizes cached
# rows of the first descriptor set per block of the distance matrix (1024 x m2 float32: 32 MB at 8000
# features), fewer where the block would exceed MATCH_BLOCK_BYTES (large m2)
MATCH_BLOCK_ROWS = 1024
MATCH_BLOCK_BYTES = 32 << 20
# descriptor magnitudes whose squared distances float32 holds; sets beyond are scaled (nothing else changes)
DESCRIPTOR_RANGE = (1e-15, 1e15)
# descriptor sets whose mean's squared norm exceeds this many times their squared spread are centred
# first (distances do not change; the products' rounding scales with |a|^2, not with the distance).
# SIFT's (whole numbers 0-255, mean about as large as the spread) are not: their products are exact.
OFFSET_RATIO = 100.0


def _cv2() -> Any:
    try:
        import cv2  # noqa: PLC0415
    except ImportError as exc:  # pragma: no cover - depends on the environment
        raise ImportError("OpenCV is required for image features and matching; install it with `pip install poseonly[opencv]` (or `pip install opencv-python-headless`)") from exc
    return cv2


# --------------------------------------------------------------------------------------------
# data classes


@dataclass(frozen=True)
class Features:
    """SIFT features of one image.

    ``keypoints (m, 2)`` float64 pixel coordinates, ``descriptors (m, 128)`` float32,
    ``image_size = (width, height)``, ``sizes (m,)`` the keypoints' diameters in pixels (OpenCV's
    ``KeyPoint.size``, proportional to the detection scale; ``None`` when unknown).
    """

    keypoints: np.ndarray
    descriptors: np.ndarray
    image_size: tuple[int, int]
    sizes: np.ndarray | None = None

    def __len__(self) -> int:
        return len(self.keypoints)


@dataclass(frozen=True)
class Matches:
    """Putative matches between two images.

    ``u1, u2 (k, 2)`` pixel coordinates, ``idx (k, 2)`` indices into the two keypoint arrays,
    ``image_size1, image_size2 = (width, height)``, ``scores (k,)`` match quality ``1 - ratio``
    (higher is better; ``None`` when unknown), ``noise_scales (k,)`` the geometric mean
    ``sqrt(size1 * size2)`` of the two keypoints' sizes (a match's relative localisation scale, for
    :func:`poseonly.estimate_relative_pose`'s ``noise_scales``; ``None`` when unknown).
    """

    u1: np.ndarray
    u2: np.ndarray
    idx: np.ndarray
    image_size1: tuple[int, int]
    image_size2: tuple[int, int]
    scores: np.ndarray | None = None
    noise_scales: np.ndarray | None = None

    def __len__(self) -> int:
        return len(self.u1)


@dataclass(frozen=True)
class MatchData:
    """Contents of a match file: ``u1, u2 (k, 2)`` pixels and the intrinsics (``None`` if absent).

    ``K1``/``K2`` are already resolved: a shared ``K`` in the file fills both.
    """

    u1: np.ndarray
    u2: np.ndarray
    K1: np.ndarray | None = None
    K2: np.ndarray | None = None
    scores: np.ndarray | None = None  # (k,) match quality, higher is better (optional key 'scores')
    noise_scales: np.ndarray | None = None  # (k,) > 0 relative localisation scales (optional key 'noise_scales')

    def __len__(self) -> int:
        return len(self.u1)


# --------------------------------------------------------------------------------------------
# images


def read_image(path: str | os.PathLike, grayscale: bool = True) -> np.ndarray:
    """Read an image file (grayscale ``(h, w)`` uint8 by default, else BGR ``(h, w, 3)``).

    Raises :class:`InputError` if the file is missing, not a file, or cannot be decoded.
    """
    cv2 = _cv2()
    p = Path(path)
    if not p.exists():
        raise InputError(f"image file not found: {p}")
    if not p.is_file():
        raise InputError(f"image path is not a file: {p}")
    try:
        buf = np.fromfile(p, dtype=np.uint8)  # works with non-ASCII paths, unlike cv2.imread
    except OSError as exc:
        raise InputError(f"cannot read image file {p}: {exc}") from None
    img = None
    if buf.size:
        img = cv2.imdecode(buf, cv2.IMREAD_GRAYSCALE if grayscale else cv2.IMREAD_COLOR)
    if img is None or img.size == 0:
        raise InputError(f"cannot decode image file {p} (empty, corrupt or not an image format OpenCV reads)")
    return img


def _to_gray_u8(img: np.ndarray) -> np.ndarray:
    cv2 = _cv2()
    a = np.asarray(img)
    if a.ndim == 3 and a.shape[2] == 1:
        a = a[:, :, 0]
    if a.ndim == 3 and a.shape[2] in (3, 4):
        if a.dtype != np.uint8:
            a = _to_u8(a)
        a = cv2.cvtColor(a, cv2.COLOR_BGR2GRAY if a.shape[2] == 3 else cv2.COLOR_BGRA2GRAY)
    if a.ndim != 2 or min(a.shape) < 1:
        raise InputError(f"image must be a (h, w) grayscale or (h, w, 3) color array, got shape {a.shape}")
    return np.ascontiguousarray(_to_u8(a))


def _to_u8(a: np.ndarray) -> np.ndarray:
    if a.dtype == np.uint8:
        return a
    if a.dtype == bool:
        return a.astype(np.uint8) * 255
    if not np.issubdtype(a.dtype, np.number):
        raise InputError(f"image must be numeric, got dtype {a.dtype}")
    f = a.astype(np.float64)
    if not np.all(np.isfinite(f)):
        raise InputError("image contains NaN or inf values")
    if np.issubdtype(a.dtype, np.floating) and f.size and f.max() <= 1.0:
        f = f * 255.0  # float images in [0, 1]
    elif np.issubdtype(a.dtype, np.integer) and a.dtype.itemsize > 1:
        f = f / (np.iinfo(a.dtype).max / 255.0)
    return np.clip(np.rint(f), 0, 255).astype(np.uint8)


# --------------------------------------------------------------------------------------------
# features


MAX_FEATURES_LIMIT = 2**31 - 1  # OpenCV's nfeatures is a C int


def unreadable_images(paths: Iterable[str | os.PathLike]) -> list[str]:
    """The ``paths`` that are not files OpenCV can decode by their header (missing, empty, another
    format): checked without decoding, so a truncated image still fails when it is read."""
    import cv2

    return [str(p) for p in paths if not (os.path.isfile(p) and cv2.haveImageReader(str(p)))]


def _sift(gray: np.ndarray, max_features: int | None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Keypoints ``(m, 2)``, descriptors ``(m, 128)`` and sizes ``(m,)`` of OpenCV's SIFT."""
    cv2 = _cv2()
    sift = cv2.SIFT_create(nfeatures=int(max_features or 0))
    kps, desc = sift.detectAndCompute(gray, None)
    if not kps or desc is None:
        return np.zeros((0, 2)), np.zeros((0, 128), np.float32), np.zeros(0)
    kp = np.array([k.pt for k in kps], dtype=np.float64).reshape(-1, 2)
    size = np.array([k.size for k in kps], dtype=np.float64)
    return kp, np.ascontiguousarray(desc, dtype=np.float32), size


def _cache_file(path: Path, max_features: int | None, cache_dir: Path) -> Path:
    st = path.stat()
    key = json.dumps(
        {
            "v": _CACHE_VERSION,
            "path": str(path.resolve()),
            "size": st.st_size,
            "mtime_ns": st.st_mtime_ns,
            "max_features": int(max_features or 0),
            "detector": "sift",
        },
        sort_keys=True,
    )
    h = hashlib.sha256(key.encode()).hexdigest()[:32]
    return cache_dir / f"sift_{h}.npz"


def _read_cache(f: Path) -> Features | None:
    """Load a cached :class:`Features`; ``None`` if absent, truncated or inconsistent."""
    if not f.is_file():
        return None
    try:
        with np.load(f, allow_pickle=False) as z:
            kp = np.asarray(z["keypoints"], dtype=np.float64)
            desc = np.asarray(z["descriptors"])
            size = tuple(int(s) for s in z["image_size"])
            sizes = np.asarray(z["sizes"], dtype=np.float64)
    except CACHE_READ_ERRORS:  # a truncated or garbage cache is simply recomputed
        return None
    if kp.ndim != 2 or kp.shape[1] != 2 or desc.shape != (len(kp), 128) or desc.dtype != np.float32 or len(size) != 2 or sizes.shape != (len(kp),):
        return None
    return Features(kp, desc, (size[0], size[1]), sizes)


def clean_cache(cache_dir: str | os.PathLike) -> int:
    """Remove temp files that killed cache writes left in ``cache_dir``; returns how many."""
    return sweep_stale_temps(cache_dir)


def extract_features(
    image_or_path: str | os.PathLike | np.ndarray,
    max_features: int | None = None,
    cache_dir: str | os.PathLike | None = None,
) -> Features:
    """SIFT keypoints and descriptors of a full-resolution grayscale image.

    ``image_or_path`` is an image file or an array (grayscale, or BGR color). ``max_features``
    keeps the strongest ones (``None``: all). With ``cache_dir`` (file inputs only) the result is
    cached in an ``.npz`` keyed by the absolute path, file size, mtime and parameters; the cache is
    written atomically and an unreadable cache file is ignored and rewritten.
    """
    if max_features is not None and (isinstance(max_features, bool) or not isinstance(max_features, (int, np.integer)) or not 0 <= int(max_features) <= MAX_FEATURES_LIMIT):
        raise InputError(f"max_features must be None or a whole number in [0, {MAX_FEATURES_LIMIT}] (0: all), got {max_features!r}")
    if isinstance(image_or_path, np.ndarray):
        gray = _to_gray_u8(image_or_path)
        kp, desc, sizes = _sift(gray, max_features)
        return Features(kp, desc, (gray.shape[1], gray.shape[0]), sizes)

    path = Path(image_or_path)
    cache = None
    if cache_dir is not None:
        if not path.is_file():
            raise InputError(f"image file not found: {path}")
        cache = _cache_file(path, max_features, Path(cache_dir))
        hit = _read_cache(cache)
        if hit is not None:
            return hit
    gray = read_image(path)
    kp, desc, sizes = _sift(gray, max_features)
    feats = Features(kp, desc, (gray.shape[1], gray.shape[0]), sizes)
    if cache is not None:
        cache_savez(cache, keypoints=kp, descriptors=desc, image_size=np.array(feats.image_size, dtype=np.int64), sizes=sizes)
    return feats


# --------------------------------------------------------------------------------------------
# matching


def _check_desc(d: np.ndarray, name: str) -> np.ndarray:
    """``d`` as a finite ``(m, D)`` array: float32 as given, any other numeric type as float64 (so
    that values beyond float32's range can still be scaled into it)."""
    try:
        a = np.asarray(d)
        a = a if a.dtype == np.float32 else np.asarray(a, dtype=np.float64)
    except (TypeError, ValueError):
        raise InputError(f"{name} must be a numeric (m, D) descriptor array") from None
    if a.ndim != 2:
        raise InputError(f"{name} must have shape (m, D), got {a.shape}")
    if not np.all(np.isfinite(a)):
        raise InputError(f"{name} contains NaN or inf values")
    return a


def match_features(d1: np.ndarray, d2: np.ndarray, ratio: float = 0.8, mutual: bool = False, return_scores: bool = False) -> Any:
    """Match descriptors with Lowe's ratio test; returns ``(k, 2)`` int index pairs ``(i1, i2)``
    (and with ``return_scores`` also their quality ``1 - dist1 / dist2`` ``(k,)``, higher is better:
    the PROSAC order of :func:`poseonly.estimate_relative_pose`).

    Brute-force L2 two-nearest-neighbour search (blocked float32 matrix products,
    :func:`_nearest_neighbours`; no OpenCV needed); a match is kept when ``dist1 < ratio * dist2``.
    With ``mutual`` the match must also be the nearest neighbour in the reverse direction.
    """
    r = ratio[()] if isinstance(ratio, np.ndarray) and ratio.ndim == 0 else ratio
    if isinstance(r, (bool, np.bool_)) or not isinstance(r, (int, float, np.integer, np.floating)) or not (0.0 < float(r) <= 1.0):
        raise InputError(f"ratio must be a number in (0, 1], got {ratio!r}")
    d1 = _check_desc(d1, "d1")
    d2 = _check_desc(d2, "d2")
    if d1.shape[1] != d2.shape[1]:
        raise InputError(f"descriptor lengths differ: {d1.shape[1]} vs {d2.shape[1]}")
    empty = np.zeros((0, 2), dtype=np.int64)
    if len(d1) == 0 or len(d2) < 2:  # the ratio test needs a second neighbour
        return (empty, np.zeros(0)) if return_scores else empty
    big = max(float(np.abs(d1).max(initial=0.0)), float(np.abs(d2).max(initial=0.0)))
    if big > DESCRIPTOR_RANGE[1] or 0.0 < big < DESCRIPTOR_RANGE[0]:  # keep the squares within float32
        d1, d2 = d1 / d1.dtype.type(big), d2 / d2.dtype.type(big)
    d1, d2 = np.ascontiguousarray(d1, dtype=np.float32), np.ascontiguousarray(d2, dtype=np.float32)
    centre = d2.mean(axis=0, dtype=np.float64)
    c2 = float(centre @ centre)
    spread = float(np.einsum("ij,ij->", d2, d2, dtype=np.float64)) / len(d2) - c2  # mean |d - centre|^2
    if c2 > OFFSET_RATIO * spread:  # a common offset would swamp the distances' digits
        d1, d2 = (d1 - centre).astype(np.float32), (d2 - centre).astype(np.float32)
    nn, back = _nearest_neighbours(d1, d2, mutual)
    rows = np.arange(len(d1))
    dist = np.stack([_l2(d1, d2[nn[:, 0]]), _l2(d1, d2[nn[:, 1]])], axis=1)
    keep = dist[:, 0] < float(ratio) * dist[:, 1]
    i1 = rows[keep]
    i2 = nn[keep, 0]
    if mutual and len(i1):
        assert back is not None
        ok = back[i2] == i1
        i1, i2 = i1[ok], i2[ok]
    idx = np.stack([i1, i2], axis=1).astype(np.int64) if len(i1) else empty
    if not return_scores:
        return idx
    d = dist[i1]
    return idx, 1.0 - d[:, 0] / np.maximum(d[:, 1], 1e-300)


def _l2(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise Euclidean distances ``(m,)`` of ``a, b (m, D)``, accumulated in float64."""
    diff = a.astype(np.float64) - b
    return np.sqrt(np.einsum("ij,ij->i", diff, diff))


def _nearest_neighbours(d1: np.ndarray, d2: np.ndarray, mutual: bool) -> tuple[np.ndarray, np.ndarray | None]:
    """The nearest and second-nearest rows of ``d2 (m2, D)`` for each row of ``d1 (m1, D)``,
    ``(m1, 2)`` indices, and with ``mutual`` the nearest row of ``d1`` for each row of ``d2``
    ``(m2,)`` (else None); ``m2 >= 2``.

    The squared distances ``|a|^2 + |b|^2 - 2 a.b`` come from one float32 matrix product per block of
    :data:`MATCH_BLOCK_ROWS` rows, at most :data:`MATCH_BLOCK_BYTES` (BLAS; the whole ``m1 x m2`` matrix
    is never held), and both
    directions from the same blocks: ~7x faster than OpenCV's ``batchDistance`` run both ways
    (median 0.072 against 0.481 s on 26 overlapping Strecha pairs of ~4900 SIFT features, the same
    matches; ``benchmarks/match_speed.py``). The
    expansion's rounding (~1e-7 of |a|^2) can only swap neighbours whose distances tie to that
    precision; the ratio test then uses their distances recomputed in float64 (:func:`_l2`)."""
    m1, m2 = len(d1), len(d2)
    sq2 = np.einsum("ij,ij->i", d2, d2)
    d2t = np.ascontiguousarray(d2.T)
    nn = np.empty((m1, 2), dtype=np.int64)
    back_d = np.full(m2, np.inf, dtype=np.float32)
    back = np.zeros(m2, dtype=np.int64)
    cols = np.arange(m2)
    rows = max(1, min(MATCH_BLOCK_ROWS, MATCH_BLOCK_BYTES // (4 * m2)))
    for s in range(0, m1, rows):
        a = d1[s : s + rows]
        r = np.arange(len(a))
        D = a @ d2t
        D *= -2.0
        D += sq2[None, :]
        D += np.einsum("ij,ij->i", a, a)[:, None]
        if mutual:
            bi = D.argmin(axis=0)
            bd = D[bi, cols]
            better = bd < back_d
            back_d[better] = bd[better]
            back[better] = bi[better] + s
        first = D.argmin(axis=1)
        nn[s : s + len(a), 0] = first
        D[r, first] = np.inf
        nn[s : s + len(a), 1] = D.argmin(axis=1)
    return nn, (back if mutual else None)


def match_images(
    img1: str | os.PathLike | np.ndarray,
    img2: str | os.PathLike | np.ndarray,
    ratio: float = 0.8,
    mutual: bool = False,
    cache_dir: str | os.PathLike | None = None,
    max_features: int | None = None,
) -> Matches:
    """SIFT-match two images (files or arrays): :func:`extract_features` + :func:`match_features`."""
    f1 = extract_features(img1, max_features=max_features, cache_dir=cache_dir)
    f2 = extract_features(img2, max_features=max_features, cache_dir=cache_dir)
    idx, scores = match_features(f1.descriptors, f2.descriptors, ratio=ratio, mutual=mutual, return_scores=True)
    return Matches(f1.keypoints[idx[:, 0]], f2.keypoints[idx[:, 1]], idx, f1.image_size, f2.image_size, scores, match_noise_scales(f1, f2, idx))


def match_noise_scales(f1: Features, f2: Features, idx: np.ndarray) -> np.ndarray | None:
    """``sqrt(size1 * size2) (k,)`` of the matched keypoints ``idx (k, 2)`` (``None`` without sizes;
    non-positive sizes count as the median)."""
    if f1.sizes is None or f2.sizes is None:
        return None
    s = np.sqrt(np.asarray(f1.sizes, float)[idx[:, 0]] * np.asarray(f2.sizes, float)[idx[:, 1]])
    ok = np.isfinite(s) & (s > 0)
    if not ok.all():
        s = np.where(ok, s, np.median(s[ok]) if ok.any() else 1.0)
    return s


# --------------------------------------------------------------------------------------------
# match files


def _check_pixels(a: Any, name: str, src: str) -> np.ndarray:
    try:
        a = as_real_array(a, name)
    except InputError as exc:
        raise InputError(f"{src}: '{name}' must be a real numeric (k, 2) array of pixel coordinates ({exc})") from None
    a = opencv_points(a)  # OpenCV's (k, 1, 2), as the Python API takes it (a migrating user's trial)
    if a.ndim != 2 or a.shape[1] != 2:
        raise InputError(f"{src}: '{name}' must have shape (k, 2) (pixel coordinates), got {a.shape}")
    if not np.all(np.isfinite(a)):
        bad = int(np.count_nonzero(~np.all(np.isfinite(a), axis=1)))
        raise InputError(f"{src}: '{name}' contains NaN or inf values ({bad} rows)")
    return a


def _check_match_arrays(u1: Any, u2: Any, K1: Any, K2: Any, K: Any, src: str, scores: Any = None, noise_scales: Any = None) -> MatchData:
    u1 = _check_pixels(u1, "u1", src)
    u2 = _check_pixels(u2, "u2", src)
    if len(u1) != len(u2):
        raise InputError(f"{src}: 'u1' and 'u2' differ in length: {len(u1)} vs {len(u2)}")
    if len(u1) == 0:
        raise InputError(f"{src}: contains no matches (u1, u2 have 0 rows)")
    Ks = {}
    for name, val in (("K", K), ("K1", K1), ("K2", K2)):
        if val is not None:
            try:
                Ks[name] = check_intrinsics(val, name)
            except InputError as exc:
                raise InputError(f"{src}: {exc}") from None
    for name in ("K1", "K2"):  # one calibration per view: a shared K and a different own one is ambiguous
        if "K" in Ks and name in Ks and not np.array_equal(Ks["K"], Ks[name]):
            raise InputError(f"{src}: holds both 'K' and a different '{name}': which calibration applies is ambiguous (keep one)")
    k1 = Ks.get("K1", Ks.get("K"))
    k2 = Ks.get("K2", Ks.get("K"))
    if (k1 is None) != (k2 is None):
        have, miss = ("K1", "K2") if k1 is not None else ("K2", "K1")
        raise InputError(f"{src}: '{have}' is given but '{miss}' is missing (give both, or a shared 'K')")
    sc = None
    if scores is not None:
        sc = np.asarray(scores)
        if sc.shape != (len(u1),) or sc.dtype.kind not in "biuf" or not np.all(np.isfinite(sc)):
            raise InputError(f"{src}: 'scores' must be a finite real array of shape ({len(u1)},), got {sc.dtype} {sc.shape}")
        sc = sc.astype(float)
    ns = None
    if noise_scales is not None:
        ns = np.asarray(noise_scales)
        if ns.shape != (len(u1),) or ns.dtype.kind not in "biuf" or not np.all(np.isfinite(ns) & (ns > 0)):
            raise InputError(f"{src}: 'noise_scales' must be a finite positive real array of shape ({len(u1)},), got {ns.dtype} {ns.shape}")
        ns = ns.astype(float)
    return MatchData(u1, u2, k1, k2, sc, ns)


def load_matches_npz(path: str | os.PathLike) -> MatchData:
    """Load a match file (keys ``u1``, ``u2``; optional ``K1``, ``K2`` or shared ``K``; optional
    ``scores (k,)``, match quality, higher is better; optional ``noise_scales (k,) > 0``, each match's
    relative localisation scale, e.g. ``sqrt(size1 * size2)`` of its keypoints).

    Raises :class:`InputError` with a clear message if the file is missing, not an ``.npz``
    archive, truncated, lacks a required key, or holds arrays of the wrong shape or with NaN/inf.
    """
    p = Path(path)
    src = f"match file {p}"
    if not p.is_file():
        raise InputError(f"{src} not found")
    try:
        with open(p, "rb") as fh:
            magic = fh.read(6)
    except OSError as exc:
        raise InputError(f"cannot read {src}: {exc}") from None
    if magic.startswith(b"\x93NUMPY"):
        raise InputError(f"{src} is a single .npy array, not an .npz archive with keys 'u1', 'u2'")
    if not magic.startswith(b"PK"):
        raise InputError(f"{src} is not a readable .npz archive (no zip header; write it with numpy.savez)")
    try:
        z = np.load(p, allow_pickle=False)
    except (ValueError, OSError, EOFError, zipfile.BadZipFile) as exc:
        raise InputError(f"{src} is not a readable .npz archive ({type(exc).__name__}: {exc})") from None
    if not isinstance(z, np.lib.npyio.NpzFile):
        raise InputError(f"{src} is a single .npy array, not an .npz archive with keys 'u1', 'u2'")
    with z:
        keys = set(z.files)
        missing = [k for k in ("u1", "u2") if k not in keys]
        if missing:
            raise InputError(
                f"{src} lacks required key(s) {missing}; expected 'u1', 'u2' ((k, 2) pixels) and optionally 'K1', 'K2' or 'K' (3x3); found {sorted(keys) or 'no keys'}"
            )
        arrays: dict[str, np.ndarray | None] = {}
        for k in ("u1", "u2", "K1", "K2", "K", "scores", "noise_scales"):
            if k not in keys:
                arrays[k] = None
                continue
            try:
                arrays[k] = z[k]
            except (ValueError, OSError, EOFError, zipfile.BadZipFile, KeyError) as exc:
                raise InputError(f"{src}: cannot read key '{k}' ({type(exc).__name__}: {exc})") from None
    return _check_match_arrays(arrays["u1"], arrays["u2"], arrays["K1"], arrays["K2"], arrays["K"], src, arrays["scores"], arrays["noise_scales"])


def save_matches_npz(
    path: str | os.PathLike,
    u1: np.ndarray,
    u2: np.ndarray,
    K1: np.ndarray | None = None,
    K2: np.ndarray | None = None,
    K: np.ndarray | None = None,
    scores: np.ndarray | None = None,
    noise_scales: np.ndarray | None = None,
) -> Path:
    """Validate and write a match file atomically (see the module docstring for the keys).

    Returns the path written (``.npz`` is not appended: the given name is used as is).
    """
    p = Path(path)
    data = _check_match_arrays(u1, u2, K1, K2, K, "matches to save", scores, noise_scales)
    arrays = {"u1": data.u1, "u2": data.u2}
    if data.scores is not None:
        arrays["scores"] = data.scores
    if data.noise_scales is not None:
        arrays["noise_scales"] = data.noise_scales
    if K is not None:
        arrays["K"] = np.asarray(K, dtype=np.float64)
    if K1 is not None:
        arrays["K1"] = np.asarray(K1, dtype=np.float64)
    if K2 is not None:
        arrays["K2"] = np.asarray(K2, dtype=np.float64)
    atomic_savez(p, **arrays)
    return p


# --------------------------------------------------------------------------------------------
# epipolar errors in pixels


def fundamental_from_pose(K1: np.ndarray, K2: np.ndarray, R: np.ndarray, t: np.ndarray) -> np.ndarray:
    """``F = K2^-T [t]x R K1^-1`` so that ``u2^T F u1 = 0`` (homogeneous pixels)."""
    K1 = check_intrinsics(K1, "K1")
    K2 = check_intrinsics(K2, "K2")
    E = essential_from_pose(np.asarray(R, float), np.asarray(t, float))
    return np.linalg.inv(K2).T @ E @ np.linalg.inv(K1)


def sampson_distance(u1: np.ndarray, u2: np.ndarray, F: np.ndarray) -> np.ndarray:
    """First-order geometric (Sampson) distance in pixels of pixel matches ``(k, 2)`` under ``F``.

    ``|u2^T F u1| / sqrt((F u1)_x^2 + (F u1)_y^2 + (F^T u2)_x^2 + (F^T u2)_y^2)``.
    """
    u1 = np.asarray(u1, dtype=float)
    u2 = np.asarray(u2, dtype=float)
    h1 = np.concatenate([u1, np.ones((len(u1), 1))], axis=1)
    h2 = np.concatenate([u2, np.ones((len(u2), 1))], axis=1)
    Fx1 = h1 @ np.asarray(F, float).T
    Ftx2 = h2 @ np.asarray(F, float)
    num = np.abs(np.sum(h2 * Fx1, axis=1))
    den = np.sqrt(Fx1[:, 0] ** 2 + Fx1[:, 1] ** 2 + Ftx2[:, 0] ** 2 + Ftx2[:, 1] ** 2)
    return num / np.where(den > 0, den, np.finfo(float).tiny)


def sampson_error_px(u1: np.ndarray, u2: np.ndarray, K1: np.ndarray, K2: np.ndarray, R: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Sampson distance (pixels) of pixel matches under the pose ``(R, t)`` (``X2 = R X1 + t``)."""
    return sampson_distance(u1, u2, fundamental_from_pose(K1, K2, R, t))
