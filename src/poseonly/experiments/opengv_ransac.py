"""RANSAC + Stewenius 5pt with OpenGV's default settings (the paper's benchmark "RANSAC+5pt").

A vectorized re-implementation of ``opengv::sac::Ransac`` driving
``CentralRelativePoseSacProblem`` with ``algorithm = STEWENIUS`` (notes section 10), as used by
OpenGV's ``test/test_relative_pose_sac.cpp`` and ``matlab/opengv.cpp``:

* a sample has **8** correspondences: the Stewenius minimal solver runs on the first 5
  (:func:`poseonly.solvers.fivept.fivept_batch`, real parts of all ten complex solutions, as the SAC
  problem takes them), and each essential matrix is decomposed into its four ``(R, t)``; the one of
  the 40 poses with the smallest summed residual over all 8 sample points is the model (OpenGV's
  "5 + 3" scheme);
* the residual is OpenGV's ``getSelectedDistancesToModel``: midpoint triangulation, then
  ``(1 - f1 . r1) + (1 - f2 . r2)`` (the ``opengv-symmetric`` residual of :mod:`poseonly.residuals`);
* inliers: residual ``< threshold`` with the test-file threshold
  ``2 (1 - cos(atan(sqrt(2) * 0.5 / 800)))`` (0.5 sqrt(2) px at f = 800, both views);
* inlier-count scoring; adaptive stop ``k = log(1 - p) / log(1 - w^8)`` with ``p = 0.99`` after every
  improvement, at most ``max_iterations + 1`` samples (OpenGV's loop tests ``iterations > max``
  after incrementing); the test files set ``max_iterations = 50``;
* final inliers are re-selected with the best model; no refit, no local optimisation.

Vectorization: all samples of a chunk are solved and scored at once (batched 5pt, stacked residuals
over ``(samples, 40 poses, 8 points)`` and ``(samples, n points)``); the sequential adaptive stopping
rule is then replayed over the chunk in sample order, so the result equals the sequential loop fed
with the same samples. :func:`opengv_ransac_nonlinear` adds ``optimize_nonlinear`` on the inliers
(:func:`poseonly.refine.opengv_nonlinear`), the paper's "OpenGVopt".

Also home of :func:`get_refiner`, the lazy importer of :mod:`poseonly.refine` functions shared by
the experiments (the refiners are optional: an experiment skips a method whose import fails).
"""

from __future__ import annotations

import importlib
import math
from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from ..geometry import four_poses
from ..residuals import RESIDUALS
from ..robust.ransac import sample_indices
from ..solvers.fivept import fivept_batch
from ._common import code_version  # noqa: F401  (re-exported: older imports)

v_OpenGV_symmetric = RESIDUALS["opengv-symmetric"]

__all__ = ["OPENGV_THRESHOLD", "OpenGVRansacResult", "opengv_ransac_5pt", "opengv_ransac_nonlinear", "get_refiner", "code_version"]

OPENGV_THRESHOLD = 2.0 * (1.0 - math.cos(math.atan(math.sqrt(2.0) * 0.5 / 800.0)))
SAMPLE_SIZE = 8  # 5 for the minimal solver + 3 to choose among its solutions

_REFINE_MODULES = {
    "ligt_refine": "ligt",
    "eigensolver": "eigensolver",
    "opengv_nonlinear": "nonlinear",
    "bundle_adjust": "ba",
    "npt": "npt",
    "robust_npt": "npt",
}


def get_refiner(name: str) -> Callable | None:
    """``poseonly.refine.<name>`` (or its submodule), ``None`` when it cannot be imported."""
    try:
        mod = importlib.import_module("poseonly.refine")
        fn = getattr(mod, name, None)
        if fn is not None:
            return fn
    except ImportError:
        pass
    sub = _REFINE_MODULES.get(name)
    if sub is None:
        return None
    try:
        return getattr(importlib.import_module(f"poseonly.refine.{sub}"), name, None)
    except ImportError:
        return None


@dataclass
class OpenGVRansacResult:
    """``R, t`` (``X2 = R X1 + t``, unit ``t``), ``inliers (n,)`` of the best model, ``num_inliers``,
    ``num_iterations`` (samples drawn, OpenGV's ``iterations_``), ``residuals (n,)``."""

    R: np.ndarray
    t: np.ndarray
    inliers: np.ndarray
    num_inliers: int
    num_iterations: int
    residuals: np.ndarray
    info: dict = field(default_factory=dict)


def _models(f1: np.ndarray, f2: np.ndarray, idx: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """OpenGV's ``computeModelCoefficients`` for samples ``idx (b, 8)``: ``R (b, 3, 3)``, ``t (b, 3)``, ``ok (b,)``."""
    s1, s2 = f1[idx], f2[idx]  # (b, 8, 3)
    E = fivept_batch(s1[:, :5], s2[:, :5])["E"]  # (b, 10, 3, 3), real parts
    E = np.where(np.isfinite(E), E, 0.0)
    R, t = four_poses(E)  # (b, 10, 4, 3, 3), (b, 10, 4, 3)
    b = len(idx)
    R = R.reshape(b, 40, 3, 3)
    t = t.reshape(b, 40, 3)
    q = v_OpenGV_symmetric(R, t, s1[:, None], s2[:, None]).sum(axis=-1)  # (b, 40)
    q = np.where(np.isfinite(q), q, np.inf)
    k = np.argmin(q, axis=1)
    rows = np.arange(b)
    ok = np.isfinite(q[rows, k]) & (np.linalg.norm(E.reshape(b, -1), axis=1) > 0)
    return R[rows, k], t[rows, k], ok


def opengv_ransac_5pt(
    f1: np.ndarray,
    f2: np.ndarray,
    rng: np.random.Generator | int | None = None,
    max_iterations: int = 50,
    threshold: float = OPENGV_THRESHOLD,
    probability: float = 0.99,
    chunk: int = 64,
) -> OpenGVRansacResult:
    """RANSAC + Stewenius 5pt exactly as OpenGV's ``Ransac`` + ``CentralRelativePoseSacProblem`` (module docstring).

    ``f1, f2``: ``(n, 3)`` unit bearings (``n >= 8``); ``rng``: numpy Generator or seed;
    ``max_iterations`` (OpenGV's test files: 50); ``threshold`` on the symmetric OpenGV residual;
    ``probability`` for the adaptive stop (OpenGV default 0.99); ``chunk``: samples solved at once.
    """
    f1 = np.asarray(f1, float)
    f2 = np.asarray(f2, float)
    n = len(f1)
    if n < SAMPLE_SIZE:
        raise ValueError(f"RANSAC + 5pt needs at least {SAMPLE_SIZE} correspondences, got {n}")
    rng = rng if isinstance(rng, np.random.Generator) else np.random.default_rng(rng)
    log_p = math.log(1.0 - probability)
    eps = np.finfo(float).eps
    best_count, best_R, best_t = -1, np.eye(3), np.zeros(3)
    k = 1.0
    it = 0
    skipped = 0
    done = False
    while not done:
        # at most the samples the cap (and, after the first chunk, the current k) can still ask for
        b = min(chunk, max_iterations + 1 - it)
        if it > 0 and math.isfinite(k):
            b = min(b, max(math.ceil(k) - it, 1))
        b = int(max(b, 1))
        idx = sample_indices(rng, n, SAMPLE_SIZE, b)
        R, t, ok = _models(f1, f2, idx)
        counts = np.full(b, -1)
        if np.any(ok):
            v = v_OpenGV_symmetric(R[ok], t[ok], f1, f2)  # (b_ok, n)
            counts[ok] = np.count_nonzero(v < threshold, axis=1)
        for j in range(b):  # replay OpenGV's sequential loop over the solved chunk
            if not it < k:
                done = True
                break
            if not ok[j]:
                skipped += 1
                if skipped >= 10 * max_iterations:
                    done = True
                    break
                continue
            if counts[j] > best_count:
                best_count, best_R, best_t = int(counts[j]), R[j], t[j]
                w = best_count / n
                p_no = 1.0 - w**SAMPLE_SIZE
                p_no = min(max(p_no, eps), 1.0 - eps)
                k = log_p / math.log(p_no)
            it += 1
            if it > max_iterations:
                done = True
                break
        if it >= k:
            done = True
    v = v_OpenGV_symmetric(best_R, best_t, f1, f2)
    inl = v < threshold
    t_unit = best_t / max(float(np.linalg.norm(best_t)), 1e-300)
    return OpenGVRansacResult(
        R=best_R, t=t_unit, inliers=inl, num_inliers=int(inl.sum()), num_iterations=it, residuals=v, info={"threshold": threshold, "skipped": skipped, "k": k}
    )


def opengv_ransac_nonlinear(
    f1: np.ndarray,
    f2: np.ndarray,
    rng: np.random.Generator | int | None = None,
    **kwargs,
) -> OpenGVRansacResult:
    """:func:`opengv_ransac_5pt` followed by OpenGV's ``optimize_nonlinear`` on its inliers ("OpenGVopt").

    Raises ``ImportError`` when :func:`poseonly.refine.opengv_nonlinear` is unavailable. With fewer
    than 6 inliers the RANSAC model is returned unchanged (``info["refined"] = False``).
    """
    nl = get_refiner("opengv_nonlinear")
    if nl is None:
        raise ImportError("poseonly.refine.opengv_nonlinear is not available")
    r = opengv_ransac_5pt(f1, f2, rng, **kwargs)
    r.info["refined"] = False
    if r.num_inliers >= 6 and np.linalg.norm(r.t) > 0:
        try:
            o = nl(r.R, r.t, np.asarray(f1, float)[r.inliers], np.asarray(f2, float)[r.inliers])
        except ValueError as exc:  # degenerate inlier set
            r.info["refine_error"] = str(exc)
            return r
        if np.all(np.isfinite(o.R)) and np.all(np.isfinite(o.t)):
            r.R, r.t = o.R, o.t
            r.info["refined"] = True
            r.residuals = v_OpenGV_symmetric(r.R, r.t, f1, f2)
            # inliers stay those RANSAC selected (the refinement does not re-select)
    return r
