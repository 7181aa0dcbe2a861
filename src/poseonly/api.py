"""The public entry point: :func:`estimate_relative_pose`.

Input: ``x1, x2`` as pixels ``(n, 2)`` with ``K1``/``K2``, normalized image coordinates ``(n, 2)``
without ``K``, or unit bearing vectors ``(n, 3)``. Output: :class:`RelativePoseResult` with
``X2 = R X1 + t`` (unit ``t``), the inlier mask computed against the returned model, weights, an
honest ``status`` and diagnostics.

Methods
-------
``"poseonly"`` (default)
    Decided on real image pairs (docs/RESULTS_real.md). LO-RANSAC in the compiled core: 5-point
    hypotheses (``solver="lirp"``: LiRP on 6 points), multi-scale MSAC scoring of the Sampson error at
    ``threshold_px`` (1 px) with an exact bail-out, at least 500 samples and adaptive stopping at
    confidence 0.9999, PROSAC sampling when match ``scores`` are given, and local optimisation of every
    new best model (Sampson LM with a Cauchy loss; ``lo="lirp"``: warm-started TLS IRLS on all-candidate
    LiRP). Then the pose-only choice among the RANSAC model, the LiRP candidates of its consensus set
    and its polished homography twin by cheirality-consistent support, and the ML pose under a
    Gaussian-uniform mixture of Sampson errors (EM, noise scale estimated; ``final="ligt"`` keeps the
    earlier noise-matched LO + angular LiGTopt).
``"gnc-ransac"``
    The paper's Algorithm 3 as written: samples of ``n_s = 30``, GNC-IRLS with the adaptive
    ``c = 5.54 * 1.4826 * median(v)``, 50 iterations, inliers ``v_LiGT < theta``.
``"gnc-irls"``
    Algorithm 2 on all points. Default noise bound from the pixel threshold (measured far more
    robust than the paper's adaptive median rule, which ``scale="median"`` selects).
``"lirp"``
    Algorithm 1 on all points (no robustness).

Layout: this module only validates, converts and dispatches. Options are the frozen dataclasses
of :mod:`poseonly.options`; the runners live in :mod:`poseonly.robust.default` (the default method)
and :mod:`poseonly.robust.methods`; the result type and the status decision in
:mod:`poseonly.result`; the planar-twin, pure-rotation and chance-inlier (a-contrario) analysis in
:mod:`poseonly.analysis`. The angular threshold ``threshold_px / focal`` must lie in
``[1e-12, 1]`` rad (:func:`poseonly.options.check_angle`).

Threshold conversion: ``threshold_px`` pixels at focal ``f`` is the angle ``tau = threshold_px / f``
(``f`` = :func:`poseonly.geometry.pair_focal` of the focal lengths of ``K1`` and ``K2``: their value
when equal; or ``focal_px``). The Sampson residual on
the sphere is compared with ``tau`` directly. For ``v_LiGT`` (unit baseline) the identity
``v_LiGT = theta^2 ||f2 x (z1 R f1 + t)|| = sin(parallax) sin(alpha) * d2 * |angle error| / d2``
bounds ``v_LiGT <= sin(parallax) * |angle error| <= |angle error|`` (law of sines in the epipolar
triangle; ``alpha`` = angle between ray 1 and the baseline), so ``theta = tau`` never rejects a point
whose error is within ``threshold_px`` (it is loose for low-parallax points).
"""

from __future__ import annotations

import contextlib
import os
import threading
import time
from collections.abc import Iterator
from typing import Any, Literal, cast

import numpy as np

from . import _core
from .analysis import REFINE_SOLVER
from .estimator import lirp_estimator
from .geometry import InputError, NonFiniteInputError, as_bearings, as_coordinates, as_real_array, check_correspondences, check_intrinsics, opencv_points, pair_focal
from .options import OPTIONS, PoseonlyOptions, Spec, check_angle, check_value, parse_options
from .quantization import check_coordinate_step, grid_step, rounding_sigma_px
from .result import RelativePoseResult
from .robust.default import make_rng, run_poseonly
from .robust.gnc import GNCOptions, GNCResult, gnc_irls_batch
from .robust.methods import RUNNERS
from .robust.ransac import RansacResult
from .robust.ransac import gnc_ransac as _gnc_ransac_loop
from .solvers.lirp import LiRPResult, lirp_checked, lirp_plain
from .status import degenerate_result, finish

__all__ = [
    "DEFAULT_METHOD",
    "METHODS",
    "REFINE_SOLVER",
    "RelativePoseResult",
    "estimate_relative_pose",
    "gnc_irls",
    "gnc_ransac",
    "lirp",
]

DEFAULT_METHOD = "poseonly"
METHODS = tuple(OPTIONS)
# the epipolar system of a pose needs rank >= 6 (relative singular-value cut-off below)
MIN_EPIPOLAR_RANK = 6
RANK_RTOL = 1e-9

_BLAS_LOCK = threading.Lock()
_BLAS_STATE: dict[str, Any] = {"controller": None, "limiter": None, "users": 0}


def _reset_blas_state_in_child() -> None:
    """A child forked while estimates ran in other threads starts with none running (its copy of the
    count would otherwise never return to 0, and its estimates would never set the limit), and with the
    BLAS limits of before those estimates where they had set theirs (a concurrency trial: the child kept
    one thread for good, and its own estimates then took one as the limit to restore)."""
    limiter = _BLAS_STATE.get("limiter")
    if limiter is not None and _BLAS_STATE.get("users", 0) > 0:
        with contextlib.suppress(Exception):  # the child's libraries are the parent's: best effort
            if _blas_still_single(_BLAS_STATE["controller"]):
                limiter.restore_original_limits()
    _BLAS_STATE.update(limiter=None, users=0)
    global _BLAS_LOCK
    _BLAS_LOCK = threading.Lock()


if hasattr(os, "register_at_fork"):
    os.register_at_fork(after_in_child=_reset_blas_state_in_child)


@contextlib.contextmanager
def _blas_single_thread() -> Iterator[None]:
    """Limit BLAS to one thread while estimating (the matrices are tiny: a multi-threaded BLAS on a
    loaded machine made the demo pair 2.7x slower). No-op without ``threadpoolctl``.

    The limit is process-wide, so concurrent estimates (a caller's thread pool, the batch's thread
    backend) share it: the first to enter sets it and the last to leave restores the original limits
    (a per-call limit would be restored by the first estimate to finish while others still run)."""
    with _BLAS_LOCK:
        st = _BLAS_STATE
        if st["controller"] is None:
            try:
                from threadpoolctl import ThreadpoolController
            except ImportError:  # pragma: no cover - optional
                st["controller"] = False
            else:
                st["controller"] = ThreadpoolController()
        if st["controller"] and st["users"] == 0:
            st["limiter"] = st["controller"].limit(limits=1, user_api="blas")
        st["users"] += 1
    try:
        yield
    finally:
        with _BLAS_LOCK:
            st["users"] -= 1
            if st["users"] == 0 and st["limiter"] is not None:
                if _blas_still_single(st["controller"]):
                    st["limiter"].restore_original_limits()
                st["limiter"] = None


def _blas_still_single(controller: Any) -> bool:
    """Every BLAS is still at the one thread :func:`_blas_single_thread` set: nobody changed the limit while
    the estimates ran. An application that set its own meanwhile (``threadpool_limits`` in another thread)
    keeps it: restoring the limits of before overwrote it (a SLAM user's trial)."""
    return all(lib.num_threads == 1 for lib in controller.select(user_api="blas").lib_controllers)


def _focal(K1, K2, focal_px):
    if focal_px is not None:
        return float(focal_px)
    fs = [0.5 * float(K[0, 0]) + 0.5 * float(K[1, 1]) for K in (K1, K2) if K is not None]  # no overflow
    return pair_focal(fs[0], fs[-1])


def _check_scores(scores: Any, n: int, dropped: np.ndarray | None = None) -> np.ndarray | None:
    """``scores`` as a finite real ``(n,)`` array (or None); ``dropped (n,)``: rows left out of the
    estimate (``unliftable="outlier"``), whose values are not checked (set to 0)."""
    if scores is None:
        return None
    a = as_real_array(scores, "scores")  # (object arrays of numbers as the coordinates take them)
    if a.shape != (n,):
        raise InputError(f"scores must be a real array of shape ({n},), got {a.dtype} {a.shape}")
    a = np.array(a, dtype=float)
    if dropped is not None:
        a[dropped] = 0.0
    if not np.all(np.isfinite(a)):
        raise InputError("scores must be finite")
    return a


def _check_noise_scales(noise_scales: Any, n: int, dropped: np.ndarray | None = None) -> np.ndarray | None:
    """``noise_scales`` as a finite positive real ``(n,)`` array (or None); ``dropped`` as
    :func:`_check_scores` (set to 1)."""
    if noise_scales is None:
        return None
    a = as_real_array(noise_scales, "noise_scales")
    if a.shape != (n,):
        raise InputError(f"noise_scales must be a real array of shape ({n},), got {a.dtype} {a.shape}")
    a = np.array(a, dtype=float)
    if dropped is not None:
        a[dropped] = 1.0
    if not np.all(np.isfinite(a) & (a > 0)):
        raise InputError("noise_scales must be finite and > 0")
    return a


def _epipolar_rank(f1: np.ndarray, f2: np.ndarray) -> int:
    """Numerical rank of the ``n x 9`` epipolar matrix (singular values above ``RANK_RTOL`` times the
    largest; the core's QR + Jacobi SVD, GIL released)."""
    s = _core.epipolar_singular_values(np.ascontiguousarray(f1, dtype=float), np.ascontiguousarray(f2, dtype=float))
    return int(np.count_nonzero(s > RANK_RTOL * s[0]))


def _lost_rows(x1: Any, x2: Any) -> tuple[Any, Any, np.ndarray | None]:
    """Pixel arrays with their NaN / inf rows (in either view) replaced by a placeholder pixel (the first
    finite one, else 0) and the mask of those rows, or the input unchanged (mask None) where there are
    none or the shapes are not matching ``(n, 2)`` pixels (their errors come from the lifting)."""
    a1, a2 = as_coordinates(x1, "x1"), as_coordinates(x2, "x2")  # (boolean arrays refused here too: a review)
    if a1.ndim != 2 or a1.shape[1:] != (2,) or a2.shape != a1.shape:
        return x1, x2, None
    lost = ~(np.isfinite(a1).all(axis=1) & np.isfinite(a2).all(axis=1))
    if not lost.any():
        return x1, x2, None
    out = []
    for a in (a1, a2):
        good = a[~lost]
        a = a.copy()  # (the caller's array is not modified)
        a[lost] = good[0] if len(good) else 0.0
        out.append(a)
    return out[0], out[1], lost


def _without_unliftable(
    f1: np.ndarray,
    f2: np.ndarray,
    lifted: np.ndarray,
    cam_focal: float,
    method: str,
    scores: np.ndarray | None,
    noise_scales: np.ndarray | None,
    coordinate_step_px: float,
    options: dict[str, Any],
) -> RelativePoseResult:
    """:func:`estimate_relative_pose` on the lifted matches (bearings, the cameras' focal unless
    ``focal_px`` is given, the pixels' grid step), its per-match arrays widened back to all ``n`` matches."""
    n, k = len(f1), int(np.count_nonzero(lifted))
    if k < 6:
        raise InputError(f"only {k} of {n} matches can be lifted through the cameras (unliftable='outlier'): at least 6 are needed")
    opts = options if options.get("focal_px") is not None else {**options, "focal_px": cam_focal}
    sc = None if scores is None else np.asarray(scores)[lifted]
    ns = None if noise_scales is None else np.asarray(noise_scales)[lifted]
    r = estimate_relative_pose(f1[lifted], f2[lifted], method=method, scores=sc, noise_scales=ns, coordinate_step_px=coordinate_step_px, **opts)
    inliers, weights, res = np.zeros(n, bool), np.zeros(n), np.full(n, np.nan)
    inliers[lifted], weights[lifted], res[lifted] = r.inliers, r.weights, r.residuals_px
    r.inliers, r.weights, r.residuals_px = inliers, weights, res
    r.diagnostics["unliftable"] = n - k
    r.message += f" ({n - k} of {n} matches without a bearing, NaN pixels or past a camera's fold, are outliers)"
    return r


def estimate_relative_pose(
    x1: np.ndarray,
    x2: np.ndarray,
    K1: np.ndarray | None = None,
    K2: np.ndarray | None = None,
    *,
    method: str = DEFAULT_METHOD,
    camera1: Any = None,
    camera2: Any = None,
    scores: np.ndarray | None = None,
    noise_scales: np.ndarray | None = None,
    unliftable: Literal["raise", "outlier"] = "raise",
    coordinate_step_px: float | None = None,
    **options: Any,
) -> RelativePoseResult:
    """Estimate the relative pose ``X2 = R X1 + t`` from point matches.

    ``x1, x2``: ``(n, 2)`` pixels (with ``K1``/``K2``; ``K2`` defaults to ``K1``), ``(n, 2)``
    normalized coordinates (no ``K``) or ``(n, 3)`` bearing vectors (OpenCV's ``(n, 1, 2)`` arrays are
    taken as ``(n, 2)``); at least 6 matches (5 determine a pose, but not its status). ``method``: one of
    :data:`METHODS` (see the module docstring). Common options: ``threshold_px`` (the RANSAC
    threshold; default 1.0 for the default method, 2.0 for the paper's methods. The default method's
    returned inliers are then those its ML refinement finds more likely inliers than not, and that
    decision threshold is reported as ``result.threshold_px``), ``min_inliers`` (15, for status ``ok``),
    ``focal_px`` (focal length in pixels converting ``threshold_px`` to an angle; required for
    normalized coordinates and bearings, overrides the cameras' focal otherwise), ``seed``
    (int in ``[0, 2**64)`` or ``numpy.random.Generator``; default 0: every run is reproducible, and
    ``seed=None``, like ``None`` for any option, means the default, not fresh entropy), ``refine`` (LiGTopt on the inliers; default
    True). ``camera1``/``camera2`` (instead of ``K1``/``K2``; ``camera2`` defaults to ``camera1``): any
    camera of :func:`poseonly.cameras.as_camera` (pycolmap.Camera, ``{"model", "width", "height",
    "params"}``, ``(K, dist)``); pixels are lifted through the distortion model and the threshold uses
    the cameras' focal length (:func:`poseonly.geometry.pair_focal` of the two); a pixel a camera cannot lift
    (past its distortion's fold) raises :class:`InputError` naming it, or with ``unliftable="outlier"`` its
    match is left out of the estimate and returned as an outlier (``inliers`` False, ``weights`` 0,
    ``residuals_px`` NaN; ``diagnostics["unliftable"]`` counts them); with ``unliftable="outlier"`` a pixel
    row of NaN / inf (a lost track), with ``K1`` or a camera, is such an outlier too (a VO trial: OpenCV
    skips them, the default raises). ``coordinate_step_px``: the grid the
    pixel coordinates were rounded to (None: detected from pixel input, :func:`poseonly.quantization.grid_step`,
    1 for integer keypoints such as FAST's / ORB's finest level; 0: none); the noise scales of the default
    method's ML stage and of the status analysis (every method's) are at least its rounding noise ``step / sqrt(12)`` (``diagnostics["coordinate_step_px"]``
    where one applies): a wrong pose can fit rounded coordinates exactly. ``scores (n,)``: match quality, higher is better (e.g. ``1 - ratio``
    of the ratio test, or a matcher's confidence); the default method then samples PROSAC-style, best
    matches first (PoseLib's ``progressive_sampling``, OpenCV's ``SAMPLING_PROSAC``).
    ``noise_scales (n,)``: each match's relative localisation scale (> 0; only ratios matter), e.g.
    ``sqrt(size1 * size2)`` of its SIFT keypoints' sizes (a keypoint's localisation error grows with
    its detection scale); the default method's ML refinement then weights the matches by them, as
    far as the likelihood of its errors says they explain the noise (``result.diagnostics["ml_alpha"]``:
    0 when they explain nothing). The paper's methods ignore ``scores`` and ``noise_scales``, and so
    does the default without its ML refinement (``refine=False`` or ``final="ligt"``).
    The options of each method are the fields of its dataclass in :mod:`poseonly.options`.
    Raises :class:`ValueError` (:class:`poseonly.InputError`) for invalid input or options;
    degenerate input returns a result whose ``status`` says so.

    Threads: calls may run concurrently (the core releases the GIL) and give the serial results; with
    ``threadpoolctl`` installed BLAS is limited to one thread, process-wide, while any estimate runs.
    Returns a :class:`poseonly.RelativePoseResult`: ``R (3, 3)``, ``t (3,)``, ``E (3, 3)`` (``None`` for
    ``degenerate``; :meth:`~poseonly.RelativePoseResult.pose` raises there), ``inliers (n,)`` bool,
    ``weights (n,)``, ``residuals_px (n,)``, ``status`` (:data:`poseonly.Status`).
    """
    t0 = time.perf_counter()
    o = parse_options(method, options)
    if unliftable not in ("raise", "outlier"):
        raise InputError(f"unliftable must be 'raise' or 'outlier' (what a match a camera cannot lift becomes), got {unliftable!r}")
    step = check_coordinate_step(coordinate_step_px)
    if K1 is not None:
        K1 = check_intrinsics(K1, "K1")
        K2 = K1 if K2 is None else check_intrinsics(K2, "K2")
    elif K2 is not None:
        raise InputError("K2 given without K1")
    cam_focal = None
    lost = None  # unliftable="outlier": the pixel rows of NaN / inf, lifted as a placeholder and dropped below
    if unliftable == "outlier" and (K1 is not None or camera1 is not None):
        x1, x2, lost = _lost_rows(x1, x2)
    try:
        if camera1 is not None or camera2 is not None:
            from .cameras import lift_pair

            if camera1 is None or K1 is not None:
                raise InputError("camera2 given without camera1" if camera1 is None else "give K1/K2 or camera1/camera2, not both")
            f1, f2, cam_focal = lift_pair(x1, x2, camera1, camera2, "nan" if unliftable == "outlier" else "raise")
        else:
            f1 = as_bearings(x1, K1, "x1", K_checked=True)  # K1, K2 checked above
            f2 = as_bearings(x2, K2, "x2", K_checked=True)
    except NonFiniteInputError as exc:  # say what to do (a batch trial: the message named neither)
        lifted = K1 is not None or camera1 is not None
        if unliftable == "outlier":  # given, but _lost_rows handles (n, 2) pixels of equal length only (a review)
            how = f"unliftable='outlier' needs pixel arrays (n, 2) of equal length with K1 or a camera; got {np.shape(x1)} and {np.shape(x2)}"
        elif lifted:
            how = "unliftable='outlier' makes them outliers"
        else:
            how = "drop them, or pass pixels with K1 or a camera and unliftable='outlier'"
        raise NonFiniteInputError(f"{exc}: {how}") from None
    if f1.shape != f2.shape:
        raise InputError(f"x1 and x2 differ in length: {len(f1)} vs {len(f2)}")
    if lost is not None:
        f1[lost], f2[lost] = np.nan, np.nan
    n = len(f1)
    if n < 6:
        raise InputError(f"at least 6 correspondences are needed, got {n}")
    # rows left out (unliftable="outlier": lost tracks, unliftable keypoints) need no valid score
    dropped = ~(np.isfinite(f1).all(axis=1) & np.isfinite(f2).all(axis=1)) if unliftable == "outlier" else None
    scores = _check_scores(scores, n, dropped)
    noise_scales = _check_noise_scales(noise_scales, n, dropped)
    if step is None:  # pixels (validated by the lifting above): the grid they lie on; else none known
        step = grid_step(*(x if lost is None else opencv_points(np.asarray(x, dtype=float))[~lost] for x in (x1, x2))) if K1 is not None or cam_focal is not None else 0.0
    if (cam_focal is not None or K1 is not None) and unliftable == "outlier":
        lifted = np.isfinite(f1).all(axis=1) & np.isfinite(f2).all(axis=1)
        if not lifted.all():  # a camera trial: one keypoint past the fold stopped a whole pair
            focal_here = cam_focal if cam_focal is not None else _focal(K1, K2, None)
            return _without_unliftable(f1, f2, lifted, focal_here, method, scores, noise_scales, step, options)
    if K1 is None and cam_focal is None and o.focal_px is None:
        raise InputError(
            "normalized coordinates or bearing vectors need focal_px (the focal length in pixels that converts "
            f"threshold_px = {float(o.threshold_px):g} to an angle); pass focal_px=..., or pixels with K1/K2 or camera1/camera2"
        )
    focal = _focal(K1, K2, o.focal_px) if cam_focal is None or o.focal_px is not None else cam_focal
    thr_px = float(o.threshold_px)
    tau = check_angle("the angular threshold threshold_px / focal", thr_px / focal, f" (threshold_px = {thr_px:g}, focal = {focal:g} px)")
    noise_floor = rounding_sigma_px(step) / focal  # radians: no noise scale below the coordinates' rounding
    rank = _epipolar_rank(f1, f2)
    if rank < MIN_EPIPOLAR_RANK:
        return degenerate_result(n, rank, method, thr_px, focal, t0)
    # overflow / invalid values inside the numerics end up as non-finite models, which finish()
    # reports as status "degenerate"; no RuntimeWarning reaches the caller (errstate is
    # thread-local and restored on exit)
    with _blas_single_thread(), np.errstate(all="ignore"):
        try:
            if method == "poseonly":
                R, t, w, iters, diag = run_poseonly(f1, f2, cast(PoseonlyOptions, o), tau, scores, noise_scales, noise_floor)
            else:
                R, t, w, iters, diag = RUNNERS[method](f1, f2, o, tau)
            diag["rank"] = rank
            if step > 0:
                diag["coordinate_step_px"] = step
            return finish(method, R, t, f1, f2, w, tau, focal, thr_px, iters, t0, diag, o.min_inliers, o.max_rotation_std_deg, o.max_translation_std_deg, noise_floor)
        except np.linalg.LinAlgError as exc:
            # valid but numerically extreme input (e.g. every bearing ~90 deg off the optical axis)
            # on which a solver's linear algebra fails: no pose, and the status says so
            return degenerate_result(
                n, rank, method, thr_px, focal, t0, reason=f"the {method!r} method failed numerically on this input ({exc}): the correspondences are numerically degenerate"
            )


_SPEC_NOISE = Spec("real", lo=0.0, lo_open=True)
_SPEC_ITER = Spec("int", lo=1)
_SPEC_EPS0 = Spec("real", lo=0.0)
_SPEC_SCALE = Spec("scale", choices=("median", "mad"))
_SPEC_SCHEDULE = Spec("str", choices=("ms-tls", "gnc-tls"))
_SPEC_RESIDUAL = Spec("name", doc="residual")
_SPEC_SAMPLE = Spec("int", lo=6)
_SPEC_BOOL = Spec("bool")
_SPEC_SEED = Spec("seed")
_SPEC_RANK_TOL = Spec("real", lo=0.0, hi=1.0, lo_open=True, hi_open=True)


def gnc_irls(
    f1: np.ndarray,
    f2: np.ndarray,
    weights: np.ndarray | None = None,
    *,
    noise_bound: float | None = None,
    residual: str = "ligt",
    schedule: str = "ms-tls",
    scale: str | float = "median",
    max_iterations: int = 100,
    eps0: float = 1e-9,
) -> GNCResult:
    """GNC-IRLS (Alg. 2) with LiRP on bearing vectors ``f1, f2 (n, 3)`` (or normalized ``(n, 2)``);
    returns a :class:`poseonly.robust.gnc.GNCResult` (``R (3, 3)``, ``t (3,)``, ``weights (n,)``,
    ``residuals (n,)``, ``c``, ``num_iterations``, ``converged``).

    ``noise_bound=None`` uses the paper's adaptive ``c = 5.54 * 1.4826 * median(v)`` (``scale``);
    a number fixes ``c`` (recommended: ``threshold_px / focal``, see :mod:`poseonly.api`).
    ``weights (n,)`` are the initial weights (default ones). Raises :class:`InputError` for bad input.
    """
    f1, f2, w = check_correspondences(f1, f2, weights)
    if noise_bound is not None:
        noise_bound = check_angle("noise_bound", check_value("noise_bound", noise_bound, _SPEC_NOISE))
    opts = GNCOptions(
        schedule=check_value("schedule", schedule, _SPEC_SCHEDULE),
        scale=check_value("scale", scale, _SPEC_SCALE),
        noise_bound=noise_bound,
        max_iterations=check_value("max_iterations", max_iterations, _SPEC_ITER),
        eps0=check_value("eps0", eps0, _SPEC_EPS0),
    )
    est = lirp_estimator(check_value("residual", residual, _SPEC_RESIDUAL))
    with np.errstate(all="ignore"):
        g = gnc_irls_batch(f1[None], f2[None], est, opts, None if w is None else w[None])
    return GNCResult(R=g.R[0], t=g.t[0], weights=g.weights[0], residuals=g.residuals[0], c=float(g.c[0]), num_iterations=int(g.num_iterations[0]), converged=bool(g.converged[0]))


def gnc_ransac(
    f1: np.ndarray,
    f2: np.ndarray,
    *,
    theta: float,
    seed: int | np.random.Generator = 0,
    sample_size: int = 30,
    max_iterations: int = 50,
    adaptive: bool = False,
    residual: str = "ligt",
    schedule: str = "ms-tls",
    scale: str | float = "median",
) -> RansacResult:
    """The paper's GNC-RANSAC (Alg. 3) on bearing vectors ``f1, f2 (n, 3)`` with inlier threshold
    ``theta`` on ``v_LiGT``, as Alg. 3 thresholds it. ``v_LiGT`` is not an angle: with unit ``t`` it is at
    most ``sin(parallax) * |angular error|`` (module docstring), so ``theta = threshold_px / focal`` keeps
    every match within ``threshold_px`` and, at low parallax, many far beyond it (a researcher's trial at
    2 px / 800: matches moved 10 px passed 84-100 % of the time). Returns
    :class:`poseonly.robust.RansacResult` (``R (3, 3)``, ``t (3,)``, ``inliers (n,)``). Raises
    :class:`InputError` for bad input."""
    f1, f2, _ = check_correspondences(f1, f2)
    if theta is None or isinstance(theta, (bool, np.bool_)) or not isinstance(theta, (int, float, np.integer, np.floating)) or not theta > 0:
        raise InputError(f"theta must be a finite number > 0 (a bound on v_LiGT), got {type(theta).__name__} {theta!r}")
    theta = check_angle("theta", float(theta))
    sample_size = check_value("sample_size", sample_size, _SPEC_SAMPLE)
    if sample_size > len(f1):
        raise InputError(f"sample_size n_s = {sample_size} is larger than the number of points {len(f1)}")
    gopts = GNCOptions(schedule=check_value("schedule", schedule, _SPEC_SCHEDULE), scale=check_value("scale", scale, _SPEC_SCALE))
    est = lirp_estimator(check_value("residual", residual, _SPEC_RESIDUAL))
    rng = make_rng(check_value("seed", seed, _SPEC_SEED))
    with np.errstate(all="ignore"):
        return _gnc_ransac_loop(
            f1,
            f2,
            theta,
            rng,
            estimator=est,
            sample_size=sample_size,
            max_iterations=check_value("max_iterations", max_iterations, _SPEC_ITER),
            gnc_options=gopts,
            adaptive=check_value("adaptive", adaptive, _SPEC_BOOL),
        )


def lirp(f1: np.ndarray, f2: np.ndarray, weights: np.ndarray | None = None, *, rank_tol: float = 1e-9) -> LiRPResult:
    """Weighted LiRP (Alg. 1) on ``n >= 6`` correspondences: :func:`poseonly.solvers.lirp.lirp` with
    its arguments checked (``f1, f2 (n, 3)`` bearings or ``(n, 2)`` normalized coordinates,
    ``weights (n,)`` non-negative, ``0 < rank_tol < 1``). Raises :class:`InputError` for bad input;
    degenerate-but-valid input returns ``status == "degenerate"`` (so do fewer than 6 positive weights,
    as an IRLS loop can give: a researcher's trial found them refused; ``E = [t]x R``)."""
    fast = lirp_plain(f1, f2, weights, rank_tol)  # plain float64 input valid as it is: one core call
    if fast is not None:
        return fast
    f1, f2, w = check_correspondences(f1, f2, weights, min_positive=0)  # fewer than 6 positive weights: degenerate
    rank_tol = check_value("rank_tol", rank_tol, _SPEC_RANK_TOL)
    return lirp_checked(f1, f2, w, float(rank_tol))
