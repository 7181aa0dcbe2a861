"""LiRP: the linear six-point relative pose solver (Section 5, Algorithm 1), computed by the core.

Construction (``src/core/lirp.cpp``; the numpy reference is ``tests/reference/lirp.py``):

1. ``A_i = w_i kron(f1_i, f2_i)`` (``vec`` column-major, ``A_i q = f2^T Q f1``); rows scaled by
   ``w_i`` as written in Alg. 1 (IRLS theory would use ``sqrt(w_i)``; with near-binary GNC weights the
   two are indistinguishable, notes section 14). Weights are divided by their maximum first (the null
   space does not change), so huge or mixed 1e150 / 1e-150 weights neither overflow nor underflow.
2. ``q1, q2, q3``: right singular vectors of the three smallest singular values (``q3`` smallest),
   from a Jacobi SVD of the 9x9 ``R`` factor of a Householder QR of ``A`` (no ``A^T A``).
3. Case 1 (``c = 1``): the nine Demazure cubics ``2 Q Q^T Q - tr(Q Q^T) Q = 0`` of
   ``Q = a Q1 + b Q2 + Q3`` as ``B y = 0`` (Eq. 14), ``M = B1^+ B2``, the 6x6 action matrices
   ``C1 g = a g`` and ``C2 g = b g`` with ``g = (a^2, ab, b^2, a, b, 1)``: 12 candidates. Decision:
   complex eigenvectors contribute the real parts of ``a, b`` (paper silent), read homogeneously
   (``Re(g4 conj(g6)) q1 + Re(g5 conj(g6)) q2 + |g6|^2 q3``) so that ``g6 -> 0`` cannot divide by zero.
4. Case 2 (``c = 0, b = 1``): ``det(a Q1 + Q2) = 0`` (Eq. 15), a cubic in ``a`` (or in ``1/a`` when its
   leading coefficient is the smaller one): 3 candidates (a complex pair of roots contributes its
   real parts, as in case 1; paper silent).
5. ``q1, q2, q3`` themselves: 3 candidates; 18 in all.
6. Each candidate is identified with the pose-only depth conditions and ranked by the weighted mean
   PPO residual (:mod:`poseonly.identify`).

``d_min`` is the paper's Table 2 indicator ``min_{i != j} |lambda_i - lambda_j|`` over the
eigenvalues of ``C1`` (``d_min_C2`` for ``C2``).

Exactness: the true ``E`` lies in the 3-D null space for general scenes (rank 8), planar scenes and
pure rotation (rank 6); one candidate is exact. In a planar scene the homography twin is exact too,
and PPO cannot break that tie (notes section 5): the status analysis of :mod:`poseonly.api` can.
"""

from __future__ import annotations

from dataclasses import dataclass, field, fields
from typing import Any

import numpy as np

from .. import _core
from .._equality import ValueEquality
from .._json import json_array, json_float
from ..geometry import ZERO_BEARING, check_correspondences

__all__ = ["lirp", "lirp_batch", "lirp_checked", "lirp_plain", "LiRPResult", "lirp_candidates", "NUM_CANDIDATES", "RANK_TOL"]

NUM_CANDIDATES = int(_core.LIRP_CANDIDATES)
# numerical rank of A: singular values above RANK_TOL * sigma_1 count (8 general, 6 planar / rotation)
RANK_TOL = 1e-9
MIN_RANK = 6  # a rank below it leaves a null space larger than 3-D: the pose is not determined
GENERAL_RANK = 8  # a general scene's A; 6: a planar scene or a pure rotation (module docstring)


def lirp_batch(f1: np.ndarray, f2: np.ndarray, w: np.ndarray | None = None, *, all_costs: bool = True) -> dict[str, np.ndarray]:
    """Weighted LiRP on ``h`` stacked problems ``f1, f2 (h, n, 3)``, ``w (h, n)`` or ``None`` (no validation).

    Returns a dict with the identified pose ``R (h, 3, 3)``, ``t (h, 3)``, ``E (h, 3, 3)``, ``best (h,)``;
    the 18 candidates ``cand_E (h, 18, 3, 3)`` (unit Frobenius norm), ``cand_R``, ``cand_t``,
    ``cand_valid (h, 18)`` (pose-only depth conditions), ``cand_M1``, ``cand_cost`` (weighted mean PPO;
    with ``all_costs=False`` only what the best needs: valid candidates, least algebraic error first,
    each stopped at ``inf`` once its running mean exceeds the least cost so far, so the best candidate
    and its cost are those of ``all_costs=True`` bit for bit where some candidate is valid; if none is,
    every candidate is scored by the general PPO residual, equal to ~1e-16);
    ``singular_values (h, 9)`` of ``A``, ``d_min`` and ``d_min_C2 (h,)``.
    """
    o = _core.lirp_batch(np.ascontiguousarray(f1, dtype=float), np.ascontiguousarray(f2, dtype=float), None if w is None else np.ascontiguousarray(w, dtype=float), all_costs)
    o["cand_valid"] = o["cand_valid"].astype(bool)
    return o


def lirp_candidates(f1: np.ndarray, f2: np.ndarray, w: np.ndarray | None = None) -> dict[str, np.ndarray]:
    """The 18 candidate essential matrices of Alg. 1 for stacked problems ``(h, n, 3)``: ``E (h, 18, 3, 3)``,
    ``singular_values (h, 9)``, ``d_min`` and ``d_min_C2 (h,)``."""
    o = lirp_batch(f1, f2, w, all_costs=False)
    return {"E": o["cand_E"], "singular_values": o["singular_values"], "d_min": o["d_min"], "d_min_C2": o["d_min_C2"]}


@dataclass(eq=False)
class LiRPResult(ValueEquality):
    """Result of :func:`lirp`.

    ``R, t``: the identified pose (``X2 = R X1 + t``, unit ``t``); ``E = [t]x R`` (the package's
    convention, Frobenius norm sqrt(2); a researcher's trial: it was the raw candidate, unit norm and of
    either sign); ``candidates_E/R/t``: all 18 candidates (order: 12 action-matrix, 3 det-cubic, q1, q2,
    q3; ``candidates_E`` as Alg. 1 gives them, unit Frobenius norm, each up to sign), ``candidate_valid`` (pose-only depth conditions), ``candidate_cost`` (weighted mean PPO);
    ``d_min``: Table 2 indicator for ``C1`` (``d_min_C2`` for ``C2``); ``singular_values`` of ``A``
    (with the weights divided by their maximum: only their ratios matter);
    ``rank``: numerical rank of ``A`` (8 general, 6 planar or pure rotation, < 6 degenerate);
    ``status``: ``"ok"`` or ``"degenerate"`` (rank < 6: the null space is larger than 3-D and the
    pose is not determined by the data; ``R``, ``t`` and ``E`` are then NaN, the candidates kept).
    """

    R: np.ndarray
    t: np.ndarray
    E: np.ndarray
    candidates_E: np.ndarray
    candidates_R: np.ndarray
    candidates_t: np.ndarray
    candidate_valid: np.ndarray
    candidate_cost: np.ndarray
    best: int
    d_min: float
    d_min_C2: float
    singular_values: np.ndarray
    rank: int
    status: str
    notes: list[str] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        return self.status == "ok"

    def to_dict(self) -> dict[str, Any]:
        """Every field as strict JSON (nested lists, ``None`` where a value is not finite)."""
        d: dict[str, Any] = {}
        for f in fields(self):
            v = getattr(self, f.name)
            if isinstance(v, np.ndarray):
                d[f.name] = v.astype(bool).tolist() if v.dtype == bool else json_array(v)
            elif isinstance(v, (float, np.floating)):
                d[f.name] = json_float(v)
            elif isinstance(v, (bool, np.bool_)):
                d[f.name] = bool(v)
            elif isinstance(v, (int, np.integer)):
                d[f.name] = int(v)
            else:
                d[f.name] = v
        return d


MIN_POINTS = 6  # Alg. 1 needs a 3-D null space of the n x 9 matrix A: n >= 6 (fewer positive weights: degenerate)


def lirp(f1: np.ndarray, f2: np.ndarray, weights: np.ndarray | None = None, *, rank_tol: float = RANK_TOL) -> LiRPResult:
    """Weighted LiRP (Alg. 1) on ``n >= 6`` correspondences.

    ``f1, f2``: ``(n, 3)`` bearing vectors or ``(n, 2)`` normalized image coordinates of views 1
    and 2; ``weights``: optional non-negative ``(n,)``. Returns a :class:`LiRPResult` with the pose
    ``X2 = R X1 + t`` (unit ``t``), all 18 candidates and the ``d_min`` diagnostic. Raises
    :class:`ValueError` on bad input; degenerate-but-valid input (e.g. all points identical)
    returns ``status == "degenerate"``.
    """
    fast = lirp_plain(f1, f2, weights, rank_tol)
    if fast is not None:
        return fast
    if isinstance(rank_tol, bool) or not isinstance(rank_tol, (int, float, np.integer, np.floating)) or not 0 < rank_tol < 1:
        raise ValueError(f"rank_tol must be a number in (0, 1), got {rank_tol!r}")
    f1, f2, w = check_correspondences(f1, f2, weights, min_points=MIN_POINTS, min_positive=0)  # fewer positive weights: degenerate
    return lirp_checked(f1, f2, w, float(rank_tol))


def _plain_rows(a: object) -> bool:
    return type(a) is np.ndarray and a.dtype == np.float64 and a.ndim == 2 and a.shape[1] == 3


def lirp_plain(f1: object, f2: object, weights: object, rank_tol: object) -> LiRPResult | None:
    """The public :func:`lirp` in one core call (``_core.lirp_bearings``) for its common input: ``f1, f2``
    float64 ndarrays ``(n, 3)``, ``weights`` a float64 ndarray ``(n,)`` or None, ``rank_tol`` a float
    in ``(0, 1)``. None where the checked path decides (any other input, and what the core declines:
    a NaN / inf or zero row, rows that all end in 1, a negative or non-finite weight, ``n < 6``), so
    that the checks and their messages live in one place. The result is the checked path's bit for bit
    (the rows scaled by the same core routine; ``tests/test_lirp.py``). Why: the checks cost more than
    the solver at n = 30 (issue 11's ``poseonly bench speed`` row)."""
    if not (type(rank_tol) is float and 0.0 < rank_tol < 1.0 and _plain_rows(f1) and _plain_rows(f2)):
        return None
    if weights is not None and not (type(weights) is np.ndarray and weights.dtype == np.float64 and weights.ndim == 1):
        return None
    out = _core.lirp_bearings(f1, f2, weights, rank_tol, ZERO_BEARING, MIN_POINTS)  # type: ignore[arg-type]
    return None if out is None else _result(out)


def lirp_checked(f1: np.ndarray, f2: np.ndarray, w: np.ndarray | None, rank_tol: float) -> LiRPResult:
    """:func:`lirp` on input already validated (unit bearings ``(n, 3)`` float64 C-contiguous, ``n >= 6``,
    weights ``(n,)`` finite and non-negative or ``None``; ``0 < rank_tol < 1``): the public
    :func:`poseonly.lirp` validates once and calls this. One core call (``_core.lirp_one``)."""
    if w is not None:  # relative weights at most 1: the singular values and weight sums stay finite
        wmax = float(w.max())  # (uniform 1e308 overflowed them, 5e-324 the reciprocal: a wrong pose)
        if wmax > 0.0 and wmax != 1.0:
            w = np.ascontiguousarray(w / wmax)
    return _result(_core.lirp_one(f1, f2, w, True, rank_tol))


def _result(out: tuple) -> LiRPResult:
    """The result of one core LiRP call: ``R, t`` the best candidate's pose (its own arrays), ``E = [t]x
    R``; all three NaN for a degenerate ``A`` (rank < 6), whose ``best`` still names the least-cost
    candidate."""
    cE, cR, ct, valid, cost, s, best, d_min, d_min_c2, rank, R, t, E = out
    if rank >= GENERAL_RANK:
        status, notes = "ok", []
    elif rank >= MIN_RANK:  # a researcher's trial: a planar scene's twin came back 1-9 deg off, unflagged
        status = "ok"
        notes = [
            f"epipolar matrix A has rank {rank} < {GENERAL_RANK}: a planar scene or a pure rotation; in a planar scene the"
            " homography twin fits the matches exactly too and the candidates' costs cannot tell them apart"
            " (estimate_relative_pose's status analysis can)"
        ]
    else:  # no pose: NaN, not a candidate that looks like one (identity R)
        status = "degenerate"
        notes = [f"epipolar matrix A has rank {rank} < {MIN_RANK}: the correspondences do not determine the pose"]
        R, t, E = np.full((3, 3), np.nan), np.full(3, np.nan), np.full((3, 3), np.nan)
    return LiRPResult(
        R=R,
        t=t,
        E=E,
        candidates_E=cE,
        candidates_R=cR,
        candidates_t=ct,
        candidate_valid=valid,
        candidate_cost=cost,
        best=best,
        d_min=d_min,
        d_min_C2=d_min_c2,
        singular_values=s,
        rank=rank,
        status=status,
        notes=notes,
    )
