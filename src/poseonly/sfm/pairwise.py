"""From images to a view graph: SIFT features, all-pairs matching and two-view estimation.

Only the public two-view API is used (:func:`poseonly.estimate_relative_pose`); features and
matching are :mod:`poseonly.features`. Putative matches are cached per pair (``cache_dir/matches``,
written atomically, keyed by the two feature caches' content and the matching parameters), so a
repeated run only re-estimates. Pairs are estimated with a seed per pair (:func:`pair_seed`: ``seed``
plus the pair's index among all pairs of the images, so a pair's result does not depend on which
other pairs are matched) and added to the graph in pair order, so the graph never depends on scheduling: ``jobs`` threads extract
the features and match and estimate the pairs concurrently (OpenCV and the compiled core release the
GIL) with the same result as one.
"""

from __future__ import annotations

import hashlib
import os
import threading
import time
from collections import OrderedDict
from collections.abc import Callable, Iterable, Iterator, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from .. import __version__
from .._fileutil import CACHE_READ_ERRORS, cache_savez
from ..api import estimate_relative_pose
from ..cameras import OPENCV_TO_COLMAP_PX
from ..features import Features, extract_features, match_features, match_noise_scales, unreadable_images
from ..geometry import InputError, bearings_from_normalized, bearings_from_pixels, pair_focal
from ..options import MANY_PAIRS_MAX_ITERATIONS, SEED_LIMIT
from ..quantization import check_coordinate_step
from .inputs import checked_pairs
from .tracks import Tracks
from .viewgraph import ViewGraph

DEFAULT_MAX_FEATURES = 8000  # strongest SIFT features per image

__all__ = [
    "PAIRWISE_MAX_ITERATIONS",
    "ImageGraph",
    "PairwiseOptions",
    "TwoView",
    "image_view_graph",
    "map_ordered",
    "observation_bearings",
    "pair_seed",
    "parse_estimator_options",
    "two_view",
]

MIN_PUTATIVE = 30
# images whose descriptors image_view_graph keeps in memory at once when it has a feature cache to read
# them back from (4 MB an image at 8000 SIFT features: 1 GB); beyond it the least recently used are dropped
RESIDENT_IMAGES = 256
# part of the two-view cache key with the package version: bump when the default estimator's results
# change between versions (2: the core-era default at its own threshold, with match scores; 3: its
# cheirality-aware search; 4: the Student-t ML stage; 5: the keypoints' sizes as noise scales; 6: their
# review fixes; 7: the search's challengers; 8: their review fixes; 9: the search's LO on at most 1000
# points, poses moved at rounding level; 10: the Nister five-point solver, other search paths on a few
# pairs; 11: matches sharing a keypoint scored once in the search; 12: rivals and challengers ranked by
# exact costs; 13: the pose-only choice keeps the search's pose against candidates within 1 deg, the
# pure-rotation precision test; 14: a pure rotation's R refitted robustly; 15: the precision test's
# rounding floor on noise-free data; 16-17: the ML collapse guard; 18: the cross-fitted inliers; 19: the
# cross-fit as a veto; 20: PROSAC's stopping rule; 21: the sample floor by parallax; 22: the
# neighbour-consistency fallback of searches that have not converged after 3000 samples; 23: its two
# stages' rivals merged, ties of the scores in input order; 24-25: the ML stage's inlier share bounded by the
# matches just outside its band; 26: the status uncertain, the pure-rotation precision test at noise up to the
# threshold; 27: its noise check; 28: the stopping rule assumes min_inliers inliers; 29: that rule
# without replacement and, with scores, on PROSAC's uniform draws only; 30: PAIRWISE_MAX_ITERATIONS; 31: the
# pure-rotation test's locally supported translation, PROSAC's remainder search; 32: the
# uniqueness test against every basin the search kept, a duplicated match counted once in the status, the
# planar twin's spread in the covariance and its DLT fallback, pair_focal for two focal lengths; 33: the
# rounding noise of quantised keypoints as the noise floor, inliers on a great circle degenerate, a
# refined rival that beats the search's pose replaces it; 34: the rival test's far points counted by their
# Sampson error, the ML stage's rerun from the band where its decision fell inside the noise, the
# rotation-only alternative judged at a threshold capped by the noise; 35: far points counted by their Sampson
# error in the rival swap)
TWO_VIEW_CACHE_TAG = 35
# the default method's sample cap in the pairwise stage (``max_iterations``; an ``estimator_options``
# entry overrides it): COLMAP's two-view cap, as ``poseonly colmap verify`` (options.MANY_PAIRS_MAX_ITERATIONS)
PAIRWISE_MAX_ITERATIONS = MANY_PAIRS_MAX_ITERATIONS
# part of the match cache key: bump when match_features's results can change (2: the blocked matrix
# products, which may swap neighbours that tie to float32 precision)
MATCHER_TAG = 2


@dataclass(frozen=True)
class PairwiseOptions:
    """Feature, matching and two-view options: ``max_features`` per image, Lowe ``ratio``,
    ``mutual`` nearest neighbours, minimum putative matches per pair, ``threshold_px`` (``None``: the
    method's default, 1 px for the default method) and ``method`` of
    :func:`poseonly.estimate_relative_pose`, base ``seed``; ``use_scores`` passes each match's
    ratio-test quality ``1 - d1 / d2`` as ``scores`` (PROSAC order, as the two-view benchmark does);
    ``use_noise_scales`` passes ``sqrt(size1 * size2)`` of its keypoints as ``noise_scales`` (when the
    features have sizes); ``estimator_options``: further keyword options of the method, as ``(name, value)`` pairs (e.g.
    ``(("ml_tails", "gauss"),)``), checked at construction (:func:`poseonly.options.parse_options`). The
    default method runs with ``max_iterations`` :data:`PAIRWISE_MAX_ITERATIONS` (10000, COLMAP's
    two-view cap) unless ``estimator_options`` sets it."""

    max_features: int | None = DEFAULT_MAX_FEATURES
    ratio: float = 0.8
    mutual: bool = True
    min_matches: int = MIN_PUTATIVE
    threshold_px: float | None = None
    method: str = "poseonly"
    seed: int = 0
    use_scores: bool = True
    use_noise_scales: bool = True
    estimator_options: tuple[tuple[str, Any], ...] = ()

    def __post_init__(self) -> None:
        from ..options import parse_options
        from .inputs import checked_count, checked_positive

        def keep(name: str, value: Any) -> None:  # the checked value, as the pipeline uses it
            object.__setattr__(self, name, value)

        if self.max_features is not None:
            keep("max_features", checked_count(self.max_features, "max_features"))  # 0: every feature
        keep("ratio", checked_positive(self.ratio, "ratio"))
        if self.ratio > 1.0:
            raise InputError(f"ratio must be a number in (0, 1] (Lowe's ratio test), got {self.ratio!r}")
        keep("min_matches", checked_count(self.min_matches, "min_matches", 6))
        keep("seed", checked_count(self.seed, "seed"))
        if self.seed >= SEED_LIMIT:
            raise InputError(f"seed must be an integer in [0, 2**64), got {self.seed!r}")
        if self.threshold_px is not None:
            keep("threshold_px", checked_positive(self.threshold_px, "threshold_px"))
        for name in ("mutual", "use_scores", "use_noise_scales"):
            if not isinstance(getattr(self, name), (bool, np.bool_)):
                raise InputError(f"{name} must be True or False, got {getattr(self, name)!r}")
            keep(name, bool(getattr(self, name)))
        try:
            pairs = tuple((k, v) for k, v in self.estimator_options)
        except (TypeError, ValueError):
            pairs = None
        if pairs is None or not all(isinstance(k, str) for k, _ in pairs):
            raise InputError(f"estimator_options must be (name, value) pairs, got {self.estimator_options!r}")
        keep("estimator_options", pairs)
        reserved = {"seed", "scores", "noise_scales", "threshold_px", "focal_px", "method"} & {k for k, _ in self.estimator_options}
        if reserved:
            raise InputError(f"estimator_options: {sorted(reserved)} are set by the pipeline (use the PairwiseOptions fields)")
        eo = dict(self.estimator_options)
        if "coordinate_step_px" in eo:  # a keyword of the estimate, not a method option: the grid's override
            check_coordinate_step(eo.pop("coordinate_step_px"))
        parse_options(self.method, eo)  # unknown names and wrong types raise here


def parse_estimator_options(items: Sequence[str] | None) -> tuple[tuple[str, Any], ...]:
    """``KEY=VALUE`` strings (the CLI's ``--two-view-option``) as ``(name, value)`` pairs; a VALUE that
    parses as JSON (numbers, true / false, null) is that value, ``inf`` / ``-inf`` / ``nan`` the float,
    else the string."""
    import json

    out: list[tuple[str, Any]] = []
    for it in items or ():
        key, sep, val = it.partition("=")
        if not sep or not key.strip():
            raise InputError(f"--two-view-option expects KEY=VALUE, got {it!r}")
        try:
            value: Any = json.loads(val)
        except ValueError:
            # inf / nan as Python spells them (JSON has no such numbers; e.g. max_rotation_std_deg=inf)
            value = float(val) if val.strip().lower() in ("inf", "+inf", "-inf", "nan") else val
        out.append((key.strip(), value))
    return tuple(out)


@dataclass
class ImageGraph:
    """``features`` per image, the :class:`ViewGraph` and per-stage ``times_s``; ``K`` per image
    ``(N, 3, 3)``; ``pair_stats`` ``(i, j, putative, inliers, status)``; ``putative[(i, j)]`` the
    ``(k, 2)`` putative keypoint matches of every pair that was matched. From
    :func:`image_view_graph`, ``features`` hold keypoints, sizes and image sizes with ``(0, 128)``
    descriptors (released after matching), and ``peak_resident_images`` is the most images whose
    descriptors were in memory at once. ``normalized``: per image, its keypoints lifted through its
    camera model, ``(m_k, 2)`` undistorted normalized coordinates or ``(m_k, 3)`` unit bearings (NaN
    rows where the model cannot undistort), ``None`` for pinhole ``K``; ``cameras``: per image, the
    COLMAP camera ``{"model", "width", "height", "params"}`` the keypoints were lifted through (the
    exported COLMAP model's; from images with ``K`` a PINHOLE camera in COLMAP's pixel convention),
    ``None`` where ``K`` holds the calibration in the keypoints' convention; ``keypoint_offset``: what to add to the
    features' keypoints to get the cameras' pixel convention (:data:`poseonly.cameras.OPENCV_TO_COLMAP_PX`
    for our OpenCV keypoints with COLMAP cameras, 0 otherwise)."""

    features: list[Features]
    K: np.ndarray
    graph: ViewGraph
    pair_stats: list[tuple[int, int, int, int, str]] = field(default_factory=list)
    times_s: dict[str, float] = field(default_factory=dict)
    putative: dict[tuple[int, int], np.ndarray] = field(default_factory=dict)
    normalized: list[np.ndarray] | None = None
    peak_resident_images: int = 0
    cameras: list[dict[str, Any]] | None = None
    keypoint_offset: float = 0.0

    def camera_keypoints(self, k: int) -> np.ndarray:
        """Image ``k``'s keypoints in its camera's pixel convention (``features[k].keypoints`` plus
        ``keypoint_offset``): what a COLMAP model or database of this graph holds."""
        kp = self.features[k].keypoints
        return kp + self.keypoint_offset if self.keypoint_offset else kp

    def bearings(self, tracks: Tracks) -> np.ndarray:
        """Unit camera-frame bearings ``(M, 3)`` of the tracks' observations (from the undistorted
        normalized keypoints when present, else from the pixels and ``K``)."""
        return observation_bearings(tracks, self.features, self.K, self.normalized)


class _FeaturePool:
    """Each image's :class:`Features`, extracted (or read from the feature cache) on first use.

    Descriptors (512 bytes a SIFT feature, 4 MB an image at 8000) are needed only to match, so an
    image holds them only while it has pairs left: after its last pair they are released, and with a
    feature cache at most ``resident`` images hold them at once (the least recently used are dropped
    and read back from the cache when needed again; without a cache, reading back would mean
    extracting again, so only the release after the last pair applies). :attr:`features` keep the
    keypoints, sizes and image sizes of every image, with ``(0, 128)`` descriptors. Thread-safe; an
    image is extracted by one thread at a time, and the features never depend on the order of the
    calls (SIFT and the cache are deterministic). ``peak_resident`` is the most images that held
    descriptors at once; ``extract_s`` the summed time spent extracting or reading features."""

    def __init__(self, images: Sequence[str | os.PathLike], max_features: int | None, cache: Path | None, uses: np.ndarray, resident: int) -> None:
        self._images = list(images)
        self._max_features = max_features
        self._cache = cache
        self._left = np.array(uses, dtype=np.int64)
        self._resident = int(resident) if cache is not None else len(self._images)
        self._lock = threading.Lock()
        self._image_locks = [threading.Lock() for _ in self._images]
        self._base: list[Features | None] = [None] * len(self._images)
        self._digests: list[str] = [""] * len(self._images)
        self._desc: OrderedDict[int, np.ndarray] = OrderedDict()
        self.peak_resident = 0
        self.extract_s = 0.0

    def get(self, i: int) -> tuple[Features, str]:
        """Image ``i``'s features with their descriptors, and its content digest (the match cache's key)."""
        with self._image_locks[i]:
            with self._lock:
                base, desc = self._base[i], self._desc.get(i)
                if base is not None and desc is not None:
                    self._desc.move_to_end(i)
                    return replace(base, descriptors=desc), self._digests[i]
            t0 = time.perf_counter()
            f = extract_features(self._images[i], max_features=self._max_features, cache_dir=self._cache)
            with self._lock:
                self.extract_s += time.perf_counter() - t0
                if self._base[i] is None:
                    self._base[i] = replace(f, descriptors=np.zeros((0, f.descriptors.shape[1]), np.float32))
                    self._digests[i] = _digest(f)
                if self._left[i] > 0:
                    self._desc[i] = f.descriptors
                    while len(self._desc) > self._resident:
                        self._desc.popitem(last=False)
                    self.peak_resident = max(self.peak_resident, len(self._desc))
            return f, self._digests[i]

    def done(self, i: int) -> None:
        """One of image ``i``'s pairs is matched; after its last, its descriptors are released."""
        with self._lock:
            self._left[i] -= 1
            if self._left[i] <= 0:
                self._desc.pop(i, None)

    def base(self, i: int) -> Features:
        """Image ``i``'s keypoints, sizes and image size (descriptors released); extracted if no pair
        has needed it yet."""
        if self._base[i] is None:
            self.get(i)
        out = self._base[i]
        assert out is not None
        return out


def _digest(f: Features) -> str:
    h = hashlib.sha1()
    h.update(np.ascontiguousarray(f.keypoints).tobytes())
    h.update(np.ascontiguousarray(f.descriptors).tobytes())
    return h.hexdigest()


def _matches(fa: Features, fb: Features, da: str, db: str, opt: PairwiseOptions, cache: Path | None) -> tuple[np.ndarray, np.ndarray]:
    """Putative matches ``(k, 2)`` and their ratio-test scores ``(k,)`` (cached by the two images'
    feature digests, the matching options and :data:`MATCHER_TAG`)."""
    f = None
    if cache is not None:
        key = f"{da}-{db}-{opt.ratio}-{int(opt.mutual)}-{MATCHER_TAG}".encode()
        f = cache / "matches" / f"m_{hashlib.sha1(key).hexdigest()[:24]}.npz"
        if f.is_file():
            try:
                with np.load(f) as z:
                    return z["idx"], z["scores"]
            except CACHE_READ_ERRORS:  # unreadable cache entry: recompute
                pass
    idx, scores = match_features(fa.descriptors, fb.descriptors, ratio=opt.ratio, mutual=opt.mutual, return_scores=True)
    if f is not None:
        cache_savez(f, idx=idx, scores=scores)
    return idx, scores


@dataclass(frozen=True)
class TwoView:
    """The fields of a two-view result the view graph uses (``R (3, 3)``, ``t (3,)``, ``inliers (n,)``,
    ``num_inliers``, ``status``); what the two-view cache stores."""

    R: np.ndarray
    t: np.ndarray
    inliers: np.ndarray
    num_inliers: int
    status: str


def two_view(
    u1: np.ndarray,
    u2: np.ndarray,
    K1: np.ndarray | None,
    K2: np.ndarray | None,
    opt: PairwiseOptions,
    seed: int,
    cache: Path | None,
    focal_px: float | None = None,
    scores: np.ndarray | None = None,
    noise_scales: np.ndarray | None = None,
    coordinate_step_px: float | None = None,
) -> TwoView:
    """:func:`poseonly.estimate_relative_pose` of one pair (pixels ``(n, 2)`` with ``K1, K2``, or
    normalized coordinates with ``K = None`` and ``focal_px``; match ``scores (n,)`` used when
    ``opt.use_scores``, ``noise_scales (n,)`` when ``opt.use_noise_scales``; ``coordinate_step_px``: the
    grid the keypoints were rounded to where they were lifted before, :mod:`poseonly.quantization`),
    cached by the inputs, the options and the package version."""
    scores = scores if opt.use_scores else None
    noise_scales = noise_scales if opt.use_noise_scales else None
    f = None
    if cache is not None:
        h = hashlib.sha1()
        for a in (u1, u2, K1, K2, scores, noise_scales):
            if a is not None:
                h.update(np.ascontiguousarray(a, dtype=np.float64).tobytes())
        h.update(f"{__version__}-{TWO_VIEW_CACHE_TAG}-{opt.method}-{opt.threshold_px}-{seed}-{focal_px}-{scores is not None}-{noise_scales is not None}".encode())
        if coordinate_step_px is not None:
            h.update(f"step-{coordinate_step_px}".encode())
        if opt.estimator_options:
            h.update(repr(sorted(dict(opt.estimator_options).items())).encode())  # as the call sees them (the last of a repeated name)
        f = cache / "twoview" / f"r_{h.hexdigest()[:24]}.npz"
        if f.is_file():
            try:
                with np.load(f) as z:
                    return TwoView(z["R"], z["t"], z["inliers"], int(z["num_inliers"]), str(z["status"]))
            except CACHE_READ_ERRORS:  # unreadable cache entry: recompute
                pass
    extra: dict[str, Any] = {} if focal_px is None else {"focal_px": float(focal_px)}
    if opt.threshold_px is not None:
        extra["threshold_px"] = float(opt.threshold_px)
    options = ({"max_iterations": PAIRWISE_MAX_ITERATIONS} if opt.method == "poseonly" else {}) | dict(opt.estimator_options)
    if coordinate_step_px is not None and "coordinate_step_px" not in options:  # (an estimator option overrides it)
        extra["coordinate_step_px"] = float(coordinate_step_px)
    r = estimate_relative_pose(u1, u2, K1, K2, method=opt.method, seed=seed, scores=scores, noise_scales=noise_scales, **options, **extra)
    out = TwoView(np.asarray(r.R), np.asarray(r.t), np.asarray(r.inliers, dtype=bool), int(r.num_inliers), str(r.status))
    if f is not None:
        cache_savez(f, R=out.R, t=out.t, inliers=out.inliers, num_inliers=np.array(out.num_inliers), status=np.array(out.status))
    return out


_END = object()  # map_ordered's end-of-input marker (an item may be None)


def map_ordered(fn: Callable[[Any], Any], items: Iterable[Any], jobs: int = 1) -> Iterator[Any]:
    """``fn`` over ``items``, results in the items' order: in this thread (``jobs = 1``) or on a pool of
    ``jobs`` threads (``-1``: one per core available to this process) with at most ``2 jobs`` items in
    flight. An exception of ``fn`` is raised at its item; then, or when the caller stops early, the
    queued items are cancelled (only the running ones finish)."""
    if not isinstance(jobs, (int, np.integer)) or isinstance(jobs, bool) or jobs == 0 or jobs < -1:
        raise InputError(f"jobs must be a positive int or -1 (all cores), got {jobs!r}")
    n = _available_cores() if jobs == -1 else int(jobs)
    if n == 1:
        yield from map(fn, items)
        return
    from collections import deque
    from concurrent.futures import ThreadPoolExecutor

    it = iter(items)
    ex = ThreadPoolExecutor(max_workers=n, thread_name_prefix="poseonly-sfm")
    try:
        window = deque(ex.submit(fn, x) for _, x in zip(range(2 * n), it))
        while window:
            yield window.popleft().result()
            nxt = next(it, _END)
            if nxt is not _END:
                window.append(ex.submit(fn, nxt))
    finally:
        ex.shutdown(wait=True, cancel_futures=True)


def _available_cores() -> int:
    """The cores this process may run on (its CPU affinity where the platform has one)."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # pragma: no cover - not on Linux
        return os.cpu_count() or 1


def pair_seed(seed: int, i: int, j: int, n: int) -> int:
    """The seed of pair ``i < j`` of ``n`` images: ``seed`` plus the pair's index in the
    lexicographic list of all ``n (n - 1) / 2`` pairs (with all pairs matched, its position), modulo 2**64."""
    return (int(seed) + i * n - i * (i + 1) // 2 + (j - i - 1)) % SEED_LIMIT  # the core's seeds are 64-bit


def image_view_graph(
    images: Sequence[str | os.PathLike],
    K: np.ndarray | None = None,
    *,
    camera: Any = None,
    options: PairwiseOptions | None = None,
    cache_dir: str | os.PathLike | None = None,
    pairs: Sequence[tuple[int, int]] | None = None,
    progress: Callable | None = None,
    jobs: int = 1,
    resident_images: int = RESIDENT_IMAGES,
) -> ImageGraph:
    """Features of ``images``, matches and two-view poses of ``pairs`` (default: all ``i < j``),
    as an :class:`ImageGraph`. ``K`` is ``(3, 3)`` shared or ``(N, 3, 3)`` per image (pinhole
    cameras); or ``camera``: a distorted camera shared by all images or a list of ``N``, anything
    :func:`poseonly.cameras.as_camera` accepts (taken in COLMAP's pixel convention, an OpenCV
    ``(K, dist)`` converted to it, :func:`poseonly.cameras.as_colmap_camera`: the OpenCV keypoints are
    shifted by :data:`poseonly.cameras.OPENCV_TO_COLMAP_PX`; width and height 0 take each image's
    size), whose keypoints are then lifted through the model (matches with a keypoint the model
    cannot undistort are dropped) and estimated as bearings at the camera's focal length; ``progress``
    wraps an iterable (e.g. tqdm); ``jobs`` threads (:func:`map_ordered`; the same graph for any
    number). ``times_s``: ``features``, ``matching`` and ``two_view`` are the summed per-image and
    per-pair times (with threads, more than their wall time).

    Features are extracted as the pairs need them, and an image's descriptors are held only until its
    last pair is matched; with ``cache_dir`` at most ``resident_images`` images hold them at once (the
    least recently used are read back from the feature cache when needed again). So a sequential or
    windowed pair list holds a window's descriptors, and any pair list at most ``resident_images``
    images' in the pool (4 MB each at 8000 features), plus those the pairs being matched still hold
    (two a pair; ``2 jobs`` pairs in flight); the returned features keep keypoints and sizes, with
    ``(0, 128)`` descriptors (:class:`ImageGraph`)."""
    if isinstance(resident_images, bool) or not isinstance(resident_images, (int, np.integer)) or resident_images < 2:
        raise InputError(f"resident_images must be an int >= 2 (the two images of a pair), got {resident_images!r}")
    if isinstance(images, (str, bytes, os.PathLike)) or not isinstance(images, Iterable):
        raise InputError(f"images must be a sequence of image paths, got {type(images).__name__}")
    images = list(images)
    if options is not None and not isinstance(options, PairwiseOptions):
        raise InputError(f"options must be a PairwiseOptions, got {type(options).__name__}")
    if progress is not None and not callable(progress):
        raise InputError(f"progress must be a callable wrapping an iterable (e.g. tqdm), got {progress!r}")
    if pairs is not None and not isinstance(pairs, np.ndarray):
        if isinstance(pairs, (str, bytes)) or not isinstance(pairs, Iterable):
            raise InputError(f"pairs must be a sequence of (i, j) index pairs, got {type(pairs).__name__}")
        pairs = list(pairs)
    opt = options or PairwiseOptions()
    n = len(images)
    if n < 2:
        raise InputError(f"need at least two images, got {n}")
    cams = None if camera is None else _image_cameras(camera, n, K)
    # one calibration for every image describes one image size: images of other sizes are refused (a
    # user's trial: a folder of 1536x1024, 3072x2048 and 1024x683 images with one K gave a model 12-36
    # deg off, status ok)
    shared = not isinstance(camera, list) if cams is not None else (K is not None and np.shape(K) == (3, 3))
    if cams is not None:
        Ks = np.stack([c.K for c in cams])
    elif K is None:
        raise InputError("give K ((3, 3) or (N, 3, 3)) or a camera")
    else:
        Ks = np.asarray(K, dtype=np.float64)
        Ks = np.broadcast_to(Ks, (n, 3, 3)).copy() if Ks.shape == (3, 3) else Ks
        if Ks.shape != (n, 3, 3):
            raise InputError(f"K must be (3, 3) or ({n}, 3, 3), got {Ks.shape}")
    if pairs is None:
        plist = [(i, j) for i in range(n) for j in range(i + 1, n)]
    else:  # whole indices in range, no self pair; each unordered pair once, in order
        if len(pairs) == 0:
            raise InputError("pairs is empty: give at least one pair, or None for all pairs")
        pa = checked_pairs(pairs, n)
        plist = sorted({(int(min(a, b)), int(max(a, b))) for a, b in pa.tolist()})
    bad = unreadable_images(images)  # before any work: a file that is no image would end the run midway
    if bad:
        raise InputError(f"{len(bad)} of the {n} images cannot be read as images: {bad[:3]}")
    wrap = progress or (lambda it, **_: it)
    cache = Path(cache_dir) if cache_dir is not None else None
    times: dict[str, float] = {}
    uses = np.bincount(np.asarray(plist, dtype=np.int64).ravel(), minlength=n)
    pool = _FeaturePool(images, opt.max_features, None if cache is None else cache / "features", uses, resident_images)
    lifted: dict[int, np.ndarray] = {}
    lift_lock = threading.Lock()
    first_size: list[tuple[int, tuple[int, int]]] = []  # (image, size) of the first image checked

    def check_shared_size(i: int) -> None:
        """:class:`InputError` when image ``i``'s size differs from the first checked image's (``shared``)."""
        w, h = pool.base(i).image_size
        size = (int(w), int(h))
        with lift_lock:
            if not first_size:
                first_size.append((i, size))
            j, ref = first_size[0]
        if size != ref:
            raise InputError(
                f"{images[i]} is {size[0]}x{size[1]} pixels but {images[j]} is {ref[0]}x{ref[1]}: one calibration for every image"
                " describes one image size; give the images one size, or one calibration per image (image_view_graph's K (N, 3, 3)"
                " or list of cameras; poseonly sfm: a COLMAP database with a camera per image, --database)"
            )

    def lift(i: int) -> np.ndarray:
        """Image ``i``'s keypoints as unit bearings through its camera model (NaN rows where it
        cannot undistort), computed once."""
        assert cams is not None
        with lift_lock:
            b = lifted.get(i)
        if b is None:
            base = pool.base(i)
            _check_image_size(cams[i], base.image_size, images[i])
            # OpenCV keypoints into the camera's (COLMAP's) pixel convention
            b = cams[i].unproject(base.keypoints + OPENCV_TO_COLMAP_PX, invalid="nan") if len(base.keypoints) else np.zeros((0, 3))
            with lift_lock:
                b = lifted.setdefault(i, b)
        return b

    def pair_job(kij: tuple[int, tuple[int, int]]) -> tuple[np.ndarray, TwoView | None, float, float]:
        k, (i, j) = kij
        try:
            (fa, da), (fb, db) = pool.get(i), pool.get(j)
            t1 = time.perf_counter()
            idx, scores = _matches(fa, fb, da, db, opt, cache)
            t2 = time.perf_counter()
        finally:
            pool.done(i)
            pool.done(j)
        del fa, fb  # the descriptors: the pool may release them now
        if shared:
            check_shared_size(i)
            check_shared_size(j)
        if cams is not None and len(idx):  # only matches whose keypoints the cameras can lift
            ok = np.isfinite(lift(i)[idx[:, 0], 0]) & np.isfinite(lift(j)[idx[:, 1], 0])
            if not ok.all():
                idx, scores = idx[ok], (None if scores is None else scores[ok])
        if len(idx) < opt.min_matches:
            return idx, None, t2 - t1, 0.0
        ba, bb = pool.base(i), pool.base(j)
        ns = match_noise_scales(ba, bb, idx)
        seed = pair_seed(opt.seed, i, j, n)
        if cams is None:
            r = two_view(ba.keypoints[idx[:, 0]], bb.keypoints[idx[:, 1]], Ks[i], Ks[j], opt, seed, cache, scores=scores, noise_scales=ns)
        else:
            focal = pair_focal(cams[i].focal_px, cams[j].focal_px)
            r = two_view(lift(i)[idx[:, 0]], lift(j)[idx[:, 1]], None, None, opt, seed, cache, focal_px=focal, scores=scores, noise_scales=ns)
        return idx, r, t2 - t1, time.perf_counter() - t2

    graph = ViewGraph(n)
    putative: dict[tuple[int, int], np.ndarray] = {}
    stats: list[tuple[int, int, int, int, str]] = []
    tm = te = 0.0
    done = map_ordered(pair_job, enumerate(plist), jobs)
    for (i, j), (idx, r, dm, de) in zip(plist, wrap(done, desc="pairs", total=len(plist)), strict=True):
        tm += dm
        te += de
        putative[(i, j)] = idx
        if r is None:
            graph.rejected.append((i, j, f"{len(idx)} putative matches"))
            stats.append((i, j, len(idx), 0, "few_matches"))
            continue
        graph.add_result(i, j, r, idx)
        stats.append((i, j, len(idx), int(r.num_inliers), r.status))
    unpaired = [i for i in range(n) if uses[i] == 0]
    for _ in wrap(map_ordered(pool.base, unpaired, jobs), desc="features", total=len(unpaired)) if unpaired else ():
        pass
    times["features"] = pool.extract_s
    times["matching"] = tm
    times["two_view"] = te
    feats = [pool.base(i) for i in range(n)]
    if cams is None:
        # the written COLMAP model in COLMAP's pixel convention, as with a camera model (a user's trial: with
        # --K it kept OpenCV's, so COLMAP's tools that read the images saw a principal point 0.5 px off)
        shift = OPENCV_TO_COLMAP_PX
        pinholes = [
            {"model": "PINHOLE", "width": int(f.image_size[0]), "height": int(f.image_size[1]), "params": [K[0, 0], K[1, 1], K[0, 2] + shift, K[1, 2] + shift]}
            for K, f in zip(Ks, feats)
        ]
        return ImageGraph(feats, Ks, graph, stats, times, putative, None, pool.peak_resident, pinholes, OPENCV_TO_COLMAP_PX)
    normalized = [lift(i) for i in range(n)]
    cam_dicts = [{**c.to_dict(), "width": int(f.image_size[0]), "height": int(f.image_size[1])} for c, f in zip(cams, feats)]
    return ImageGraph(feats, Ks, graph, stats, times, putative, normalized, pool.peak_resident, cam_dicts, OPENCV_TO_COLMAP_PX)


def _image_cameras(camera: Any, n: int, K: Any) -> list[Any]:
    """``N`` cameras (:class:`poseonly.cameras.Camera`) from one camera description or a list of ``N``."""
    from ..cameras import as_colmap_camera

    if K is not None:
        raise InputError("give K or camera, not both")
    if isinstance(camera, list):  # one per image (a tuple is an OpenCV (K, dist) camera)
        if len(camera) != n:
            raise InputError(f"camera: a list needs one camera per image ({n}), got {len(camera)}")
        return [as_colmap_camera(c, f"camera[{k}]") for k, c in enumerate(camera)]
    return [as_colmap_camera(camera)] * n


def _check_image_size(cam: Any, size: tuple[int, int], path: Any) -> None:
    """An image must have its camera's size (when the camera states one)."""
    if (cam.width or cam.height) and (cam.width, cam.height) != tuple(size):
        raise InputError(f"{path} is {size[0]}x{size[1]} pixels but its camera is {cam.width}x{cam.height}")


def observation_bearings(tracks: Tracks, features: Sequence[Features], K: np.ndarray, normalized: Sequence[np.ndarray] | None = None) -> np.ndarray:
    """Unit camera-frame bearings ``(M, 3)`` of every track observation: from the pixels and
    ``K (N, 3, 3)``, or from ``normalized`` keypoints per image when given (undistorted normalized
    coordinates ``(m_k, 2)`` or lifted unit bearings ``(m_k, 3)``)."""
    out = np.empty((tracks.num_observations, 3))
    for v in np.unique(tracks.views):
        sel = np.flatnonzero(tracks.views == v)
        if normalized is not None and normalized[v].shape[1] == 3:  # lifted bearings
            out[sel] = normalized[v][tracks.keypoints[sel]]
        elif normalized is not None:
            out[sel] = bearings_from_normalized(normalized[v][tracks.keypoints[sel]])
        else:
            out[sel] = bearings_from_pixels(features[v].keypoints[tracks.keypoints[sel]], K[v])
    return out
