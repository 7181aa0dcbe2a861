"""The public entry point: :func:`estimate_relative_pose`.

Input: ``x1, x2`` as pixels ``(n, 2)`` with ``K1``/``K2``, normalized image coordinates ``(n, 2)``
without ``K``, or unit bearing vectors ``(n, 3)``. Output: :class:`RelativePoseResult` with
``X2 = R X1 + t`` (unit ``t``), the inlier mask computed against the returned model, weights, an
honest ``status`` and diagnostics.

Methods
-------
``"poseonly"`` (default)
    LO-RANSAC built from the paper's parts and measured to beat them (docs/RESULTS.md):
    5-point minimal hypotheses (``solver="lirp"`` uses LiRP on 6 points), MSAC scoring of the
    Sampson error against the pixel threshold with a preemptive subset test, adaptive stopping,
    and local optimisation of every new best model by warm-started TLS IRLS on LiRP (all 18
    candidates, the one minimising the weighted objective kept) with the cheirality-aware Sampson
    residual (points behind a camera count as outliers). The final model is chosen among the RANSAC
    model, the LiRP candidates of its consensus set and its polished homography twin by
    cheirality-consistent support, then refined by LiGTopt with the angular normalisation (the
    paper's LiGT weighting measured less accurate than LiRP itself). Each final stage is kept only if
    the cheirality-aware MSAC score does not drop.
``"gnc-ransac"``
    The paper's Algorithm 3 as written: samples of ``n_s = 30``, GNC-IRLS with the adaptive
    ``c = 5.54 * 1.4826 * median(v)``, 50 iterations, inliers ``v_LiGT < theta``.
``"gnc-irls"``
    Algorithm 2 on all points. Default noise bound from the pixel threshold (measured far more
    robust than the paper's adaptive median rule, which ``scale="median"`` selects).
``"lirp"``
    Algorithm 1 on all points (no robustness).

Threshold conversion: ``threshold_px`` pixels at focal ``f`` is the angle ``tau = threshold_px / f``
(``f`` = mean of the focal lengths of ``K1`` and ``K2``, or ``focal_px``). The Sampson residual on
the sphere is compared with ``tau`` directly. For ``v_LiGT`` (unit baseline) the identity
``v_LiGT = theta^2 ||f2 x (z1 R f1 + t)|| = sin(parallax) sin(alpha) * d2 * |angle error| / d2``
bounds ``v_LiGT <= sin(parallax) * |angle error| <= |angle error|`` (law of sines in the epipolar
triangle; ``alpha`` = angle between ray 1 and the baseline), so ``theta = tau`` never rejects a point
whose error is within ``threshold_px`` (it is loose for low-parallax points).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from . import _core
from .estimator import lirp_estimator
from .geometry import InputError, as_bearings, check_intrinsics, essential_from_pose, rotation_error_deg
from .identify import identify_poses
from .residuals import get_residual, v_sampson, v_sampson_chiral
from .robust.gnc import GNCOptions, gnc_irls_batch
from .robust.ransac import core_seed, ransac_relpose
from .robust.ransac import gnc_ransac as _gnc_ransac
from .solvers.lirp import lirp_batch
from .twin import homography_twin

__all__ = ["estimate_relative_pose", "RelativePoseResult", "gnc_irls", "gnc_ransac", "METHODS", "DEFAULT_METHOD"]

DEFAULT_METHOD = "poseonly"
# LiGTopt's optimiser inside the robust methods: the compact LM of poseonly.refine.ligt (same
# objective as scipy's least_squares, ~10-20x less time per call; docs/RESULTS.md section 2)
REFINE_SOLVER = "lm"
METHODS = ("poseonly", "gnc-ransac", "gnc-irls", "lirp")

# allowed options per method: name -> (type(s), validator or None, default)
_COMMON = {
    "threshold_px": ((int, float), lambda v: v > 0, 2.0),
    "focal_px": ((int, float), lambda v: v > 0, None),
    "seed": ((int, np.integer, np.random.Generator), None, 0),
    "refine": ((bool,), None, True),
    "min_inliers": ((int, np.integer), lambda v: v >= 6, 15),
}
_OPTS: dict[str, dict[str, tuple]] = {
    "poseonly": {
        "max_iterations": ((int, np.integer), lambda v: v >= 1, 100000),
        "min_iterations": ((int, np.integer), lambda v: v >= 0, 50),
        "confidence": ((float,), lambda v: 0 < v < 1, 0.999),
        "solver": ((str,), None, "5pt"),
        "batch": ((int, np.integer), lambda v: v >= 1, 128),
        "max_lo": ((int, np.integer), lambda v: v >= 0, 8),
        "preemptive": ((int, np.integer), lambda v: v >= 0, 32),
        "scoring": ((str,), lambda v: v in ("msac", "msac-multi", "count"), "msac-multi"),
        "lo_residual": ((str,), None, "sampson-chiral"),
        "lo_mu0": ((int, float), lambda v: v > 0, 1e3),
        "lo_iterations": ((int, np.integer), lambda v: v >= 1, 10),
        "adaptive_threshold": ((bool,), None, True),
        "noise_factor": ((int, float), lambda v: v > 0, 2.5),
        "lo": ((str,), lambda v: v in ("lirp", "sampson"), "lirp"),
        "final": ((str,), lambda v: v in ("ml", "ligt"), "ml"),
        "ml_range": ((int, float), lambda v: 1.0 < v < 100.0, 3.0),
        "rival_distance": ((int, float), lambda v: 0.0 <= v <= 180.0, 0.0),
    },
    "gnc-ransac": {
        "max_iterations": ((int, np.integer), lambda v: v >= 1, 50),
        "sample_size": ((int, np.integer), lambda v: v >= 6, 30),
        "adaptive": ((bool,), None, False),
        "confidence": ((float,), lambda v: 0 < v < 1, 0.99),
        "residual": ((str,), None, "ligt"),
        "schedule": ((str,), None, "ms-tls"),
        "scale": ((str, int, float), None, "median"),
    },
    "gnc-irls": {
        "residual": ((str,), None, "ligt"),
        "schedule": ((str,), None, "ms-tls"),
        "scale": ((str, int, float), None, None),
        "max_iterations": ((int, np.integer), lambda v: v >= 1, 100),
    },
    "lirp": {},
}


@dataclass
class RelativePoseResult:
    """Relative pose ``X2 = R X1 + t`` (unit ``t``) with inliers and an honest status.

    ``status`` is one of

    * ``"ok"`` -- a confident calibrated pose;
    * ``"planar_ambiguous"`` -- the inliers are (near) planar and the homography twin (``R_twin``,
      ``t_twin``) explains them about as well; the caller must decide (e.g. with a third view);
    * ``"pure_rotation"`` -- rotation-only motion explains the inliers: ``R`` is reliable, the
      translation direction is not (``parallax_deg`` says how much parallax there is);
    * ``"too_few_inliers"`` -- fewer than 6 inliers (or fewer than ``min_inliers``); ``R, t`` are the
      best guess and should not be trusted;
    * ``"degenerate"`` -- the correspondences do not determine a pose (e.g. all points identical).
    """

    R: np.ndarray
    t: np.ndarray
    E: np.ndarray
    inliers: np.ndarray
    weights: np.ndarray
    residuals_px: np.ndarray
    num_inliers: int
    num_iterations: int
    status: str
    message: str
    method: str
    threshold_px: float
    focal_px: float
    parallax_deg: float = float("nan")
    R_twin: np.ndarray | None = None
    t_twin: np.ndarray | None = None
    twin_inliers: int = 0
    time_s: float = 0.0
    diagnostics: dict[str, Any] = field(default_factory=dict)

    @property
    def ok(self) -> bool:
        return self.status == "ok"

    @property
    def inlier_ratio(self) -> float:
        return self.num_inliers / max(len(self.inliers), 1)

    def to_dict(self) -> dict[str, Any]:
        """JSON-friendly summary."""
        d = {
            "R": self.R.tolist(),
            "t": self.t.tolist(),
            "num_inliers": self.num_inliers,
            "num_points": int(len(self.inliers)),
            "inlier_ratio": self.inlier_ratio,
            "num_iterations": self.num_iterations,
            "status": self.status,
            "message": self.message,
            "method": self.method,
            "threshold_px": self.threshold_px,
            "focal_px": self.focal_px,
            "parallax_deg": self.parallax_deg,
            "time_s": self.time_s,
        }
        if self.R_twin is not None:
            d["R_twin"] = self.R_twin.tolist()
            d["t_twin"] = self.t_twin.tolist()
            d["twin_inliers"] = self.twin_inliers
        return d


# ------------------------------------------------------------------------------------------------
# option handling


def _validate_options(method: str, opts: dict[str, Any]) -> dict[str, Any]:
    if method not in _OPTS:
        raise InputError(f"unknown method {method!r}; choose one of {list(METHODS)}")
    allowed = {**_COMMON, **_OPTS[method]}
    out = {}
    for k, v in opts.items():
        if k not in allowed:
            raise InputError(f"unknown option {k!r} for method {method!r}; valid options: {sorted(allowed)}")
        types, check, _ = allowed[k]
        if v is None:
            continue
        if isinstance(v, bool) and bool not in types:
            raise InputError(f"option {k!r} must be of type {'/'.join(t.__name__ for t in types)}, got bool")
        if not isinstance(v, types):
            raise InputError(f"option {k!r} must be of type {'/'.join(t.__name__ for t in types)}, got {type(v).__name__}")
        if check is not None and not check(v):
            raise InputError(f"option {k!r} has an invalid value {v!r}")
        out[k] = v
    for k, (_, _, default) in allowed.items():
        out.setdefault(k, default)
    return out


_CONTROLLER = None


def _blas_single_thread():
    """Limit BLAS to one thread while estimating (the matrices are tiny: a multi-threaded BLAS on a
    loaded machine made the demo pair 2.7x slower). No-op without ``threadpoolctl``."""
    global _CONTROLLER
    try:
        from threadpoolctl import ThreadpoolController
    except ImportError:  # pragma: no cover - optional
        import contextlib

        return contextlib.nullcontext()
    if _CONTROLLER is None:
        _CONTROLLER = ThreadpoolController()
    return _CONTROLLER.limit(limits=1, user_api="blas")



def _focal(K1, K2, focal_px):
    if focal_px is not None:
        return float(focal_px)
    fs = [0.5 * (K[0, 0] + K[1, 1]) for K in (K1, K2) if K is not None]
    return float(np.mean(fs)) if fs else 800.0


# ------------------------------------------------------------------------------------------------
# analysis of the final model: planar twin, pure rotation


def _parallax_deg(R, f1, f2, inl):
    if not np.any(inl):
        return float("nan")
    Rf1 = f1[inl] @ R.T
    c = np.clip(np.sum(Rf1 * f2[inl], axis=1), -1.0, 1.0)
    return float(np.degrees(np.median(np.arccos(c))))


def _analyse(R, t, f1, f2, tau, inl):
    """Planar homography twin (:mod:`poseonly.twin`) and the pure-rotation test on the inliers."""
    info: dict[str, Any] = {}
    twin = None
    sel = np.nonzero(inl)[0]
    tw = homography_twin(R, t, f1[sel], f2[sel]) if len(sel) >= 6 else None
    if tw is not None:
        info["planarity"] = tw[2]
    if tw is not None and _plausible_twin(R, t, tw, f1, f2, tau):
        Rt, tt = _polish(tw[0], tw[1], f1, f2, tau)
        sup = _support(np.stack([R, Rt]), np.stack([t, tt]), f1, f2, tau).sum(axis=1)
        info["support"], info["twin_support"] = int(sup[0]), int(sup[1])
        if sup[1] >= 0.9 * sup[0] and rotation_error_deg(R, Rt) > 0.1:
            twin = (Rt, tt, int(sup[1]))
    par = _parallax_deg(R, f1, f2, inl)
    if len(sel) >= 3:
        # pure-rotation model X2 ~ R_rot X1 fitted to the inliers (Kabsch, one re-selection)
        Rr = _kabsch(f1[sel], f2[sel])
        ang = np.arccos(np.clip(np.sum((f1[sel] @ Rr.T) * f2[sel], axis=1), -1, 1))
        if np.count_nonzero(ang < 2.0 * tau) >= 3:
            keep = sel[ang < 2.0 * tau]
            Rr = _kabsch(f1[keep], f2[keep])
            ang = np.arccos(np.clip(np.sum((f1[sel] @ Rr.T) * f2[sel], axis=1), -1, 1))
        info["rotation_only_fraction"] = float(np.mean(ang < 2.0 * tau))
        info["R_rotation_only"] = Rr
        par = float(np.degrees(np.median(ang)))
    return twin, par, info


def _kabsch(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Rotation ``R`` minimising ``sum ||b_i - R a_i||^2`` (unit bearings)."""
    U, _, Vt = np.linalg.svd(b.T @ a)
    D = np.diag([1.0, 1.0, np.sign(np.linalg.det(U @ Vt))])
    return U @ D @ Vt


def _chance_inliers(R, t, f1, f2, tau, repeats: int = 3) -> float:
    """Mean inlier count of the model on randomly re-paired matches (fixed seed): how many inliers
    the model collects by chance. A pose whose support is not well above it is not trusted."""
    rng = np.random.default_rng(20240611)
    n = len(f1)
    perms = np.stack([rng.permutation(n) for _ in range(repeats)])
    # one pose per re-pairing, so that the compiled residual takes the stacked points
    v = v_sampson(np.broadcast_to(R, (repeats, 3, 3)), np.broadcast_to(t, (repeats, 3)),
                  np.broadcast_to(f1, (repeats,) + f1.shape), f2[perms])  # (repeats, n)
    return float(np.mean(np.count_nonzero(v < tau, axis=1)))


def _finish(method, R, t, f1, f2, w, tau, focal, thr_px, iters, t0, diag, min_inliers=15) -> RelativePoseResult:
    if "tau_effective" in diag:  # the default method's noise-matched threshold (<= the user's)
        tau = diag["tau_effective"]
        thr_px = tau * focal
    v = v_sampson(R, t, f1, f2)
    inl = v < tau
    n_in = int(inl.sum())
    weights = inl.astype(float) if w is None else w
    twin, par, info = (None, float("nan"), {})
    if n_in >= 6:
        twin, par, info = _analyse(R, t, f1, f2, tau, inl)
    R_twin = t_twin = None
    twin_n = 0
    chance = _chance_inliers(R, t, f1, f2, tau) if n_in >= 6 else 0.0
    diag["chance_inliers"] = chance
    needed = max(6, min_inliers, int(np.ceil(chance + 4.0 * np.sqrt(chance) + 4.0)))
    if n_in < needed:
        status, msg = "too_few_inliers", (f"only {n_in} inliers within {thr_px:g} px (needed {needed}; the same "
                                          f"model keeps {chance:.1f} of randomly re-paired matches): the pose is not reliable")
    elif info.get("rotation_only_fraction", 0.0) > 0.9:
        status = "pure_rotation"
        R = info.pop("R_rotation_only")  # the rotation-only fit is the better estimate of R here
        msg = (f"{100 * info['rotation_only_fraction']:.0f}% of the inliers fit a pure rotation within "
               f"{2 * thr_px:g} px (median parallax {par:.3f} deg): R is reliable, the translation direction is not")
    elif twin is not None:
        status = "planar_ambiguous"
        R_twin, t_twin, twin_n = twin
        msg = (f"the inliers are explained by two poses {rotation_error_deg(R, R_twin):.2f} deg apart "
               f"(planar scene: the homography twin keeps {twin_n} inliers in front of both cameras); see R_twin, t_twin")
    else:
        status, msg = "ok", f"{n_in} inliers within {thr_px:g} px"
    info.pop("R_rotation_only", None)
    diag.update(info)
    return RelativePoseResult(
        R=R, t=t, E=essential_from_pose(R, t), inliers=inl, weights=np.asarray(weights, float), residuals_px=v * focal,
        num_inliers=n_in, num_iterations=int(iters), status=status, message=msg, method=method, threshold_px=float(thr_px),
        focal_px=focal, parallax_deg=par, R_twin=R_twin, t_twin=t_twin, twin_inliers=twin_n,
        time_s=time.perf_counter() - t0, diagnostics=diag,
    )


# ------------------------------------------------------------------------------------------------
# methods


def _support(R, t, f1, f2, tau):
    """Inliers of stacked poses ``(h,3,3), (h,3)``: Sampson error below ``tau`` and positive depths
    (``v_sampson_chiral`` is 1 where a depth is not positive, and ``tau`` is far below 1)."""
    return v_sampson_chiral(R, t, f1, f2) < min(tau, 0.5)


def _plausible_twin(R, t, tw, f1, f2, tau) -> bool:
    """Cheap screen before polishing a twin: its raw support reaches 30 % of the pose's (the twin of
    a non-planar scene keeps a few per cent; an unpolished planar twin measured 40-65 %)."""
    sup = _support(np.stack([R, tw[0]]), np.stack([t, tw[1]]), f1, f2, tau * 1.5).sum(axis=1)
    return bool(sup[1] >= 0.3 * max(sup[0], 1))


def _polish(R, t, f1, f2, tau):
    """Angular LiGTopt of a candidate on its cheirality-consistent inliers (twin comparison)."""
    from .refine.ligt import ligt_refine

    inl = _support(R[None], t[None], f1, f2, tau * 1.5)[0]
    if inl.sum() < 6:
        inl = v_sampson(R, t, f1, f2) < tau * 1.5
        if inl.sum() < 6:
            return R, t
    try:
        r = ligt_refine(R, t, f1[inl], f2[inl], loss="cauchy", loss_scale=tau, normalization="angular", max_iter=20, solver=REFINE_SOLVER)
    except ValueError:  # a degenerate candidate: keep it unpolished
        return R, t
    if np.all(np.isfinite(r.R)) and np.all(np.isfinite(r.t)):
        return r.R, r.t
    return R, t


def _msac_chiral(R, t, f1, f2, tau) -> float:
    v = v_sampson_chiral(R, t, f1, f2)
    return float(np.sum(tau * tau - np.minimum(v * v, tau * tau)))


def _keep_better(a, b, f1, f2, tau, tol=1.0):
    """``b`` if its cheirality-aware MSAC score reaches ``tol`` times ``a``'s, else ``a``."""
    if not (np.all(np.isfinite(b[0])) and np.all(np.isfinite(b[1]))):
        return a
    return b if _msac_chiral(*b, f1, f2, tau) >= tol * _msac_chiral(*a, f1, f2, tau) else a


def _select_by_support(R, t, f1, f2, tau):
    """Best of ``(R, t)`` (re-identified on its Sampson inliers), its homography twin and the LiRP
    candidates of its consensus set, by cheirality-consistent support."""
    sel = np.nonzero(v_sampson(R, t, f1, f2) < tau)[0]
    if len(sel) < 6:
        return R, t
    Ri, ti, _, _ = identify_poses(essential_from_pose(R, t)[None], f1[sel], f2[sel])
    R, t = Ri[0], ti[0]
    inl = _support(R[None], t[None], f1, f2, tau)[0]
    o = lirp_batch(f1[sel][None], f2[sel][None])
    cR = [R[None], o["cand_R"][0]]
    ct = [t[None], o["cand_t"][0]]
    tw = homography_twin(R, t, f1[sel], f2[sel])
    if tw is not None and _plausible_twin(R, t, tw, f1, f2, tau):
        Rt, tt = _polish(tw[0], tw[1], f1, f2, tau)
        cR.append(Rt[None])
        ct.append(tt[None])
    cR, ct = np.concatenate(cR), np.concatenate(ct)
    sup = _support(cR, ct, f1, f2, tau).sum(axis=1)
    k = int(np.argmax(sup))
    return (cR[k], ct[k]) if sup[k] > inl.sum() else (R, t)


def _refine(R, t, f1, f2, inl, tau, normalization="none"):
    """LiGTopt on the inliers with a robust Cauchy loss at the threshold scale.

    ``normalization="none"`` is the paper's LiGTopt (Eq. 9 residual ``||L~_i t||``);
    ``"angular"`` divides each residual by ``theta_i^2 ||z_i R f1_i + t||`` (the sine of the view-2
    reprojection angle), which measured as accurate as Sampson/ML refinement while the paper's
    weighting is not better than LiRP itself (docs/RESULTS.md).
    """
    from .refine.ligt import ligt_refine

    if inl.sum() < 6:
        return R, t
    r = ligt_refine(R, t, f1[inl], f2[inl], loss="cauchy", loss_scale=tau, normalization=normalization, solver=REFINE_SOLVER)
    if np.all(np.isfinite(r.R)) and np.all(np.isfinite(r.t)):
        return r.R, r.t
    return R, t


def _noise_threshold(R, t, f1, f2, tau, o) -> float:
    """Inlier threshold matched to the measured noise, for the final stages and the returned mask.

    Fixed-point iteration ``thr <- clip(k sigma(thr), tau / 4, 3 tau)`` (3 steps from ``thr = tau``)
    with ``sigma(thr) = 1.4826 median |v|`` over the Sampson errors below ``thr`` and ``k =
    noise_factor`` (2.5 keeps ~99 % of Gaussian inliers; the truncation at ``thr`` biases sigma low,
    which the iteration undoes). Real images (~0.3 px) get a tighter threshold than the 1 px default,
    1 px synthetic noise a wider one. ``adaptive_threshold=False`` keeps ``tau``.
    """
    if not o["adaptive_threshold"]:
        return tau
    v_all = v_sampson(R, t, f1, f2)
    thr = tau
    for _ in range(3):
        v = v_all[v_all < thr]
        if len(v) < 15:
            return tau
        thr = float(np.clip(o["noise_factor"] * 1.4826 * float(np.median(v)), 0.25 * tau, 3.0 * tau))
    return thr


_LO_CODES = {"lirp": 0, "sampson": 1}


def _run_poseonly(f1, f2, o, tau, scores=None):
    if o["solver"] not in ("5pt", "lirp"):
        raise InputError(f"option 'solver' must be '5pt' or 'lirp', got {o['solver']!r}")
    lo_res = get_residual(o["lo_residual"])
    lo_code = _LO_CODES[o["lo"]]
    seed = core_seed(o["seed"])

    def lo(R, t, thr):
        # the core's LO step from the cheirality-consistent inliers at thr, on the points within 4 thresholds
        Rl, tl, ok = _core.relpose_lo(R, t, f1, f2, thr, float(o["lo_mu0"]), int(o["lo_iterations"]), lo_res.code, lo_code)
        return (Rl, tl) if ok else (R, t)

    r = ransac_relpose(
        f1, f2, tau, seed, solver=o["solver"], scoring=o["scoring"], max_iterations=o["max_iterations"],
        min_iterations=o["min_iterations"], confidence=o["confidence"], max_lo=o["max_lo"], lo_mu0=o["lo_mu0"],
        lo_iterations=o["lo_iterations"], lo_residual=lo_res, scores=scores, lo=o["lo"], rival_distance=o["rival_distance"],
    )
    diag = {"num_lo": r.num_lo, "ransac_score": r.score, "num_scored": r.num_scored}
    if o["rival_distance"] > 0:
        # uniqueness: the support of the best model at least rival_distance degrees away, relative to
        # the result's (support = the scorer's maximum minus its cost; 1 means an equally good rival)
        full = 3.0 * len(f1) if o["scoring"] == "msac-multi" else (len(f1) * tau * tau if o["scoring"] == "msac" else float(len(f1)))
        rc = r.stats.get("rival_cost", np.inf)
        diag["rival_support_ratio"] = float(max(full - rc, 0.0) / max(full - r.score, 1e-300)) if np.isfinite(rc) else 0.0
    # the pose-only choice among the RANSAC model (re-identified on its inliers), its homography twin
    # and the LiRP candidates of its consensus set, by cheirality-consistent support (the Sampson score
    # cannot tell a planar scene's twin from the truth; depth signs can)
    R, t = _select_by_support(r.R, r.t, f1, f2, tau)
    if o["final"] == "ml":
        if o["refine"]:
            # the ML pose under a Gaussian-uniform mixture of Sampson errors (EM with the noise scale
            # estimated, outliers uniform up to ml_range thresholds): least squares when every match is
            # an inlier; the returned inliers are those more likely inliers than not
            m = _core.ml_refine(R, t, f1, f2, float(o["ml_range"]) * tau)
            if m["rounds"] > 0 and m["decision"] > 0:
                cand = (m["R"], m["t"])
                if _msac_chiral(*cand, f1, f2, tau) >= 0.98 * _msac_chiral(R, t, f1, f2, tau):
                    R, t = cand
                    diag.update(tau_effective=float(m["decision"]), sigma=float(m["sigma"]), ml_rounds=int(m["rounds"]))
        return R, t, None, r.num_iterations, diag
    # "ligt": at the noise-matched threshold, IRLS from that model's support and LiGTopt, each kept only
    # if the cheirality-aware MSAC score does not drop
    thr = _noise_threshold(R, t, f1, f2, tau, o)
    R, t = _keep_better((R, t), lo(R, t, thr), f1, f2, thr)
    if o["refine"]:
        ref = _refine(R, t, f1, f2, _support(R[None], t[None], f1, f2, thr)[0], thr, normalization="angular")
        R, t = _keep_better((R, t), ref, f1, f2, thr, tol=0.98)
    diag["tau_effective"] = thr
    return R, t, None, r.num_iterations, diag


def _run_gnc_ransac(f1, f2, o, tau):
    if o["sample_size"] > len(f1):
        raise InputError(f"sample_size n_s = {o['sample_size']} is larger than the number of points {len(f1)}")
    est = lirp_estimator(o["residual"])
    gopts = GNCOptions(schedule=o["schedule"], scale=o["scale"])
    r = _gnc_ransac(f1, f2, tau, core_seed(o["seed"]), estimator=est, sample_size=o["sample_size"], max_iterations=o["max_iterations"],
                    gnc_options=gopts, adaptive=o["adaptive"], confidence=o["confidence"])
    R, t = r.R, r.t
    if o["refine"]:
        R, t = _refine(R, t, f1, f2, r.inliers, tau)
    return R, t, r.weights, r.num_iterations, {"best_sample_inliers": int(r.score)}


def _run_gnc_irls(f1, f2, o, tau):
    est = lirp_estimator(o["residual"])
    if o["scale"] is None:
        gopts = GNCOptions(schedule=o["schedule"], noise_bound=tau, max_iterations=o["max_iterations"])
    else:
        gopts = GNCOptions(schedule=o["schedule"], scale=o["scale"], max_iterations=o["max_iterations"])
    g = gnc_irls_batch(f1[None], f2[None], est, gopts)
    R, t, w = g.R[0], g.t[0], g.weights[0]
    if o["refine"]:
        R, t = _refine(R, t, f1, f2, w > 0.5, tau)
    return R, t, w, int(g.num_iterations[0]), {"converged": bool(g.converged[0]), "noise_bound": float(g.c[0])}


def _run_lirp(f1, f2, o, tau):
    out = lirp_batch(f1[None], f2[None])
    return out["R"][0], out["t"][0], np.ones(len(f1)), 1, {"d_min": float(out["d_min"][0])}


_RUN = {"poseonly": _run_poseonly, "gnc-ransac": _run_gnc_ransac, "gnc-irls": _run_gnc_irls, "lirp": _run_lirp}


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
    **options: Any,
) -> RelativePoseResult:
    """Estimate the relative pose ``X2 = R X1 + t`` from point matches.

    ``x1, x2``: ``(n, 2)`` pixels (with ``K1``/``K2``; ``K2`` defaults to ``K1``), ``(n, 2)``
    normalized coordinates (no ``K``) or ``(n, 3)`` bearing vectors. ``method``: one of
    :data:`METHODS` (see the module docstring). Common options: ``threshold_px`` (default 2.0; the
    RANSAC threshold. The default method then matches its final threshold to the measured noise
    within ``threshold_px / 4 .. 3 threshold_px`` -- ``adaptive_threshold=False`` disables it -- and
    reports it as ``result.threshold_px``), ``min_inliers`` (15, for status ``ok``),
    ``focal_px`` (focal for the pixel conversion when no ``K`` is given; default 800), ``seed``
    (int or ``numpy.random.Generator``; default 0), ``refine`` (LiGTopt on the inliers; default
    True). ``camera1``/``camera2`` (instead of ``K1``/``K2``; ``camera2`` defaults to ``camera1``): any
    camera of :func:`poseonly.cameras.as_camera` (pycolmap.Camera, ``{"model", "width", "height",
    "params"}``, ``(K, dist)``); pixels are lifted through the distortion model and the threshold uses
    the cameras' mean focal length. ``scores (n,)``: match quality, higher is better (e.g. ``1 - ratio``
    of the ratio test, or a matcher's confidence); the default method then samples PROSAC-style, the
    best matches first (PoseLib's ``progressive_sampling``, OpenCV's ``SAMPLING_PROSAC``). Method options are listed in the error raised for an unknown one. Raises
    :class:`ValueError` (:class:`poseonly.InputError`) for invalid input or options; degenerate
    input returns a result whose ``status`` says so.
    """
    t0 = time.perf_counter()
    if not isinstance(method, str):
        raise InputError(f"method must be a string, got {type(method).__name__}")
    o = _validate_options(method, options)
    if K1 is not None:
        K1 = check_intrinsics(K1, "K1")
        K2 = K1 if K2 is None else check_intrinsics(K2, "K2")
    elif K2 is not None:
        raise InputError("K2 given without K1")
    cam_focal = None
    if camera1 is not None or camera2 is not None:
        from .cameras import lift_pair

        if camera1 is None or K1 is not None:
            raise InputError("camera2 given without camera1" if camera1 is None else "give K1/K2 or camera1/camera2, not both")
        f1, f2, cam_focal = lift_pair(x1, x2, camera1, camera2)
    else:
        f1 = as_bearings(x1, K1, "x1")
        f2 = as_bearings(x2, K2, "x2")
    if f1.shape != f2.shape:
        raise InputError(f"x1 and x2 differ in length: {len(f1)} vs {len(f2)}")
    n = len(f1)
    if n < 6:
        raise InputError(f"at least 6 correspondences are needed, got {n}")
    if scores is not None:
        scores = np.asarray(scores)
        if scores.shape != (n,) or not np.issubdtype(scores.dtype, np.number) or np.iscomplexobj(scores):
            raise InputError(f"scores must be a real array of shape ({n},), got {scores.dtype} {scores.shape}")
        scores = scores.astype(float)
        if not np.all(np.isfinite(scores)):
            raise InputError("scores must be finite")
    focal = _focal(K1, K2, o["focal_px"]) if cam_focal is None or o["focal_px"] is not None else cam_focal
    thr_px = float(o["threshold_px"])
    tau = thr_px / focal
    # degenerate-but-valid input: the epipolar matrix has rank < 6
    A = (f1[:, :, None] * f2[:, None, :]).reshape(1, n, 9)
    with _blas_single_thread():
        s = np.linalg.svd(np.linalg.qr(A, mode="r")[0] if n > 9 else A[0], compute_uv=False)
    rank = int(np.count_nonzero(s > 1e-9 * s[0]))
    if rank < 6:
        R, t = np.eye(3), np.zeros(3)
        return RelativePoseResult(
            R=R, t=t, E=np.zeros((3, 3)), inliers=np.zeros(n, bool), weights=np.zeros(n), residuals_px=np.full(n, np.nan),
            num_inliers=0, num_iterations=0, status="degenerate",
            message=f"the correspondences span a rank-{rank} epipolar system (< 6): the pose is not determined",
            method=method, threshold_px=thr_px, focal_px=focal, time_s=time.perf_counter() - t0, diagnostics={"rank": rank},
        )
    with _blas_single_thread():
        R, t, w, iters, diag = _run_poseonly(f1, f2, o, tau, scores) if method == "poseonly" else _RUN[method](f1, f2, o, tau)
    diag["rank"] = rank
    return _finish(method, R, t, f1, f2, w, tau, focal, thr_px, iters, t0, diag, o["min_inliers"])


def gnc_irls(f1: np.ndarray, f2: np.ndarray, weights: np.ndarray | None = None, *, noise_bound: float | None = None,
             residual: str = "ligt", schedule: str = "ms-tls", scale: str | float = "median", max_iterations: int = 100,
             eps0: float = 1e-9):
    """GNC-IRLS (Alg. 2) with LiRP on bearing vectors; returns :class:`poseonly.robust.GNCBatchResult`
    for the single problem (``R (3, 3)``, ``t (3,)``, ``weights (n,)``...).

    ``noise_bound=None`` uses the paper's adaptive ``c = 5.54 * 1.4826 * median(v)`` (``scale``);
    a number fixes ``c`` (recommended: ``threshold_px / focal``, see :mod:`poseonly.api`).
    ``weights`` are the initial weights (default ones).
    """
    from .geometry import check_correspondences

    f1, f2, w = check_correspondences(f1, f2, weights)
    opts = GNCOptions(schedule=schedule, scale=scale, noise_bound=noise_bound, max_iterations=max_iterations, eps0=eps0)
    g = gnc_irls_batch(f1[None], f2[None], lirp_estimator(residual), opts, None if w is None else w[None])
    g.R, g.t, g.weights, g.residuals = g.R[0], g.t[0], g.weights[0], g.residuals[0]
    g.c, g.num_iterations, g.converged = float(g.c[0]), int(g.num_iterations[0]), bool(g.converged[0])
    return g


def gnc_ransac(f1: np.ndarray, f2: np.ndarray, *, theta: float, seed: int | np.random.Generator = 0, sample_size: int = 30,
               max_iterations: int = 50, adaptive: bool = False, residual: str = "ligt", schedule: str = "ms-tls",
               scale: str | float = "median"):
    """The paper's GNC-RANSAC (Alg. 3) on bearing vectors with inlier threshold ``theta`` on
    ``v_LiGT`` (e.g. ``threshold_px / focal``). Returns :class:`poseonly.robust.RansacResult`."""
    from .geometry import check_correspondences

    f1, f2, _ = check_correspondences(f1, f2)
    if not theta > 0:
        raise InputError(f"theta must be > 0, got {theta}")
    if sample_size > len(f1):
        raise InputError(f"sample_size n_s = {sample_size} is larger than the number of points {len(f1)}")
    return _gnc_ransac(f1, f2, theta, core_seed(seed), estimator=lirp_estimator(residual), sample_size=sample_size,
                       max_iterations=max_iterations, gnc_options=GNCOptions(schedule=schedule, scale=scale),
                       adaptive=adaptive)
