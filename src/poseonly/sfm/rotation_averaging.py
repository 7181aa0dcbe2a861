"""Robust rotation averaging of Chatterjee and Govindu (TPAMI 2018): L1RA + Geman-McClure IRLS.

Input: relative rotations ``R_ij = R_j R_i^T`` (world -> camera globals) of ``E`` edges ``(i, j)``
with weights. Steps (global_sfm notes, section 3; as openMVG / COLMAP build them):

1. Initialisation from a maximum-weight spanning tree: ``R_j = R_ij R_i`` from the root (the view
   of largest weighted degree, ``R_root = I``, which also fixes the gauge). Edges that lie in triangles
   of the graph none of which close within ``TRIANGLE_MAX_DEG`` (:func:`triangle_support`, openMVG's
   triplet check) enter the tree only where it needs them to stay connected.
2. Linearisation with the right perturbation ``R_k <- R_k exp([x_k]x)``: per edge
   ``b_ij = log(R_j^T R_ij R_i)`` and the linear model ``x_j - x_i = b_ij``; ``D`` is the
   ``E x N`` signed incidence matrix, so ``A = D (x) I_3`` and ``A^T W A = (D^T W D) (x) I_3``:
   every solve factors one sparse ``(N-1) x (N-1)`` weighted Laplacian (root column dropped) with
   ``scipy.sparse.linalg.splu`` and solves three right-hand sides.
3. L1RA: ``min sum_e w_e ||D x - b||_1`` by scaled ADMM (``rho = 1``, cached factorisation of
   ``D^T D``), relinearised after every ``l1_admm_iterations`` (100) steps, up to ``l1_outer`` (50)
   times, until ``max |x| < l1_tol`` or a round that moved no view by more than ``L1_STALL_STEP``
   lowers the L1 cost by less than ``L1_COST_RTOL``. Frequent relinearisation matters: on a 1000-view ring with 10 %
   random outlier edges, 5 x 300 and 10 x 1000 steps left a block of views 115 deg off (its true edges
   then rejected as outliers), 20 x 300 and 50 x 100 (converged after 26) found exactly the 952 outliers.
4. IRLS with Geman-McClure weights per edge, ``w_e sigma^2 / (e^2 + sigma^2)^2`` with
   ``e = ||b_ij||`` (COLMAP's per-edge form), relinearised every iteration, until
   ``max |x| < irls_tol``. The scale ``sigma`` comes from the data (an M-estimator with an estimated
   scale): ``GM_SCALE_FACTOR`` (5) times the median edge residual after ``SCALE_PASS_ITERATIONS``
   IRLS steps at ``SIGMA_DEG`` (a least-squares-like fit: the L1 solution fits many edges of a sparse
   graph exactly), divided by ``sqrt(1 - (N - 1) / E)`` (the share of the errors the fit leaves in the
   residuals), within ``[SIGMA_MIN_DEG, SIGMA_DEG]``; ``SIGMA_DEG`` on graphs with little redundancy
   (``E < 3 (N - 1)``, ``MIN_SCALE_REDUNDANCY``). Chatterjee-Govindu, openMVG and COLMAP fix it at 5 deg, where a
   GM weight is flat for every residual below about a degree: an edge 0.6 deg off among edges good to
   0.02-0.05 deg (fountain-P11's widest pair) then weighs fully. Measured (docs/SFM.md, "The
   Geman-McClure scale"): 5 % of a synthetic graph's edges 0.6 deg off, mean error 0.82x; a clean
   graph 1.02x; Strecha under openMVG's protocol 0.93 / 1.01 / 0.81x (P8 / P10 / P11).
   ``sigma_deg`` fixes it instead.
5. Outlier edges: residual above ``min(max_error_deg, max(X84, min_error_deg))`` (X84 = median +
   5.2 MAD, openMVG's rule, floored so a clean graph keeps its edges, capped like COLMAP's 10 deg).
   They are removed, the largest connected component is kept and the IRLS re-run (``outlier_rounds``).

Edge weights: the caller's (the view graph uses the number of two-view inliers), divided by their
median so the GM scale means the same on every graph. With ``information (E, 3, 3)`` (each relative
rotation's inverse covariance in view i's frame, :mod:`poseonly.sfm.edge_information`) the IRLS
weighs edge e by ``GM_e R_i^T Lambda_e R_i`` instead of ``GM_e w_e`` (the residual ``b_ij`` of an
estimate ``R_ij exp([d]x)`` is ``R_i^T d``): the normal matrix is then the block Laplacian
``D^T W D`` with 3x3 blocks, factored once per iteration the same way. The spanning tree, L1RA and the
outlier rule keep the scalar weights.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import breadth_first_order, minimum_spanning_tree
from scipy.sparse.linalg import splu

from ..geometry import InputError, as_real_array
from .choices import checked_sigma_deg
from .inputs import checked_count, checked_pairs, checked_rotations
from .so3 import exp_so3, log_so3
from .viewgraph import largest_component, view_components

__all__ = ["RotationAveragingResult", "average_rotations", "gm_scale_deg", "rotation_residuals_deg", "spanning_tree_rotations", "triangle_support"]

SIGMA_DEG = 5.0  # Geman-McClure scale of Chatterjee-Govindu, openMVG, COLMAP: here its upper bound
GM_SCALE_FACTOR = 5.0  # the data's GM scale: this times the noise-corrected median edge residual (gm_scale_deg)
TRIANGLE_MAX_DEG = 5.0  # a triangle of relative rotations closes within this (the spanning tree's edge check)
# the triangles checked per edge (u, v) at most (third views w > v): time and memory linear in the edges
# on dense graphs (a complete graph of N views has N^3 / 6 triangles)
TRIANGLES_PER_EDGE = 10
SIGMA_MIN_DEG = 1e-4  # its lower bound (a noise-free graph's residuals are ~0)
# the data's scale needs redundancy: where the fit absorbs more than a third of the errors' variance (mean
# leverage (N - 1) / E above 1/3, e.g. a ring whose views see only their nearest neighbours, E / N = 2) a
# bad edge's error spreads onto its neighbours and a tight scale down-weights the wrong edges (such rings
# with 5 % of the edges 3 deg off: 1.47x the fixed scale's error; E / N = 4: 1.01x), so SIGMA_DEG is kept
MIN_SCALE_REDUNDANCY = 2.0 / 3.0
SCALE_PASS_ITERATIONS = 5  # IRLS steps at SIGMA_DEG whose residuals give the data's scale
X84_FACTOR = 5.2  # median + 5.2 MAD (openMVG)
MAD_TO_SIGMA = 1.4826
ADMM_RHO = 1.0
ADMM_TOL = 1e-5  # rad: primal residual and change of z (L1RA only initialises the IRLS)
# L1RA stops when a round lowers the L1 cost sum_e w_e ||b_e|| by less than this fraction after a
# round that moved no view by more than L1_STALL_STEP (rad): converged, the cost moves by ~1e-6 either
# way and the largest step stays ~2.5e-3 (the inexact ADMM), where 50 rounds took 4-7x the time for
# nothing; from bad starts the cost can rise for a round while blocks of views still turn, then fall by
# 40 % (a review's 500-view case: stopping on the cost alone left every view 53 deg off)
L1_COST_RTOL = 1e-4
L1_STALL_STEP = 0.05


@dataclass
class RotationAveragingResult:
    """``rotations (N, 3, 3)`` world -> camera (NaN for views not estimated), ``estimated (N,)``,
    ``inlier_edges (E,)`` mask of the edges kept, ``outlier_edges`` ``(i, j, residual_deg)`` of
    the removed ones, ``residual_deg (E,)`` final edge residuals (against all input edges),
    ``times_s`` per stage and solver ``info``."""

    rotations: np.ndarray
    estimated: np.ndarray
    inlier_edges: np.ndarray
    outlier_edges: list[tuple[int, int, float]]
    residual_deg: np.ndarray
    times_s: dict[str, float] = field(default_factory=dict)
    info: dict[str, object] = field(default_factory=dict)


def _check_inputs(num_views: object, pairs: np.ndarray, R_rel: np.ndarray, weights: np.ndarray | None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    n = checked_count(num_views, "num_views", 1)
    p = checked_pairs(pairs, n)
    R = checked_rotations(R_rel, "relative rotations", len(p))
    w = np.ones(len(p)) if weights is None else as_real_array(weights, "weights").ravel()
    if w.shape != (len(p),) or not np.all(np.isfinite(w)) or np.any(w <= 0):
        raise InputError(f"weights must be ({len(p)},) positive finite values")
    if len(p):
        lo, hi = np.minimum(p[:, 0], p[:, 1]), np.maximum(p[:, 0], p[:, 1])
        key = np.sort(lo.astype(np.int64) * n + hi)  # one number per unordered pair (a 2-D unique is 15x slower)
        dup = np.flatnonzero(key[1:] == key[:-1])
        if len(dup):
            i, j = divmod(int(key[dup[0]]), n)
            raise InputError(f"pairs holds the views ({i}, {j}) more than once: one relative rotation per pair of views")
        w = w / w.max()  # relative weights (the median of 1e308s overflowed)
    return p, R, w


def rotation_residuals_deg(rotations: np.ndarray, pairs: np.ndarray, R_rel: np.ndarray) -> np.ndarray:
    """``(E,)`` angle of ``R_j^T R_ij R_i`` in degrees (NaN where a view is not estimated)."""
    Ri, Rj = rotations[pairs[:, 0]], rotations[pairs[:, 1]]
    out = np.full(len(pairs), np.nan)
    ok = np.all(np.isfinite(Ri), axis=(1, 2)) & np.all(np.isfinite(Rj), axis=(1, 2))
    if np.any(ok):
        M = np.einsum("eji,ejk,ekl->eil", Rj[ok], R_rel[ok], Ri[ok])
        out[ok] = np.degrees(np.linalg.norm(log_so3(M), axis=1))
    return out


def triangle_support(n: int, pairs: np.ndarray, R_rel: np.ndarray, max_error_deg: float = TRIANGLE_MAX_DEG) -> tuple[np.ndarray, np.ndarray]:
    """Per edge of ``pairs (E, 2)`` (``R_rel``: ``R_j R_i^T``), the triangles ``(i, j, k)`` of the view graph it
    lies in and how many of them close: ``R_ki R_jk R_ij`` within ``max_error_deg`` of the identity
    (triangles ``u < v < w`` listed from their edge ``(u, v)``, at most ``TRIANGLES_PER_EDGE`` of them each).
    Returns ``(triangles (E,), consistent (E,))``. openMVG's triplet rotation check before averaging; an
    edge in triangles none of which close is an outlier with near certainty (the other two edges of
    each would have to be wrong too)."""
    e = len(pairs)
    tri = np.zeros(e, dtype=np.int64)
    good = np.zeros(e, dtype=np.int64)
    if e == 0:
        return tri, good
    a, b = np.minimum(pairs[:, 0], pairs[:, 1]), np.maximum(pairs[:, 0], pairs[:, 1])
    # R_{a -> b} for each undirected edge, and the edge index of (a, b)
    Rab = np.where((pairs[:, 0] == a)[:, None, None], R_rel, np.transpose(R_rel, (0, 2, 1)))
    index = sp.coo_matrix((np.arange(1, e + 1), (a, b)), shape=(n, n)).tocsr()
    adj = (index + index.T).tocsr()
    adj.sort_indices()
    # triangles a < b < c: c among the common neighbours of a and b above b
    ii: list[np.ndarray] = []
    jj: list[np.ndarray] = []
    kk: list[np.ndarray] = []
    for k in range(e):
        u, v = int(a[k]), int(b[k])
        nu = adj.indices[adj.indptr[u] : adj.indptr[u + 1]]
        nv = adj.indices[adj.indptr[v] : adj.indptr[v + 1]]
        c = np.intersect1d(nu[nu > v], nv[nv > v], assume_unique=True)
        if c.size > TRIANGLES_PER_EDGE:  # dense graphs: an even spread of the third views
            c = c[np.linspace(0, c.size - 1, TRIANGLES_PER_EDGE).astype(np.int64)]
        if c.size:
            ii.append(np.full(c.size, u))
            jj.append(np.full(c.size, v))
            kk.append(c)
    if not ii:
        return tri, good
    tu, tv, tw = np.concatenate(ii), np.concatenate(jj), np.concatenate(kk)
    e_uv = np.asarray(index[tu, tv]).ravel() - 1
    e_vw = np.asarray(index[tv, tw]).ravel() - 1
    e_uw = np.asarray(index[tu, tw]).ravel() - 1
    # R_{u -> w}^T R_{v -> w} R_{u -> v}: the loop u -> v -> w -> u
    loop = np.einsum("tji,tjk,tkl->til", Rab[e_uw], Rab[e_vw], Rab[e_uv])
    cosang = np.clip((np.trace(loop, axis1=1, axis2=2) - 1.0) / 2.0, -1.0, 1.0)
    ok = cosang >= np.cos(np.radians(max_error_deg))
    for ed in (e_uv, e_vw, e_uw):
        tri += np.bincount(ed, minlength=e)
        good += np.bincount(ed[ok], minlength=e)
    return tri, good


def spanning_tree_rotations(n: int, pairs: np.ndarray, R_rel: np.ndarray, weights: np.ndarray, root: int) -> np.ndarray:
    """Rotations ``(n, 3, 3)`` chained along the maximum-weight spanning tree from ``root``
    (``R_root = I``); the graph must be connected. An edge that lies in triangles of the graph none of
    which close (:func:`triangle_support`) enters the tree only where the graph needs it to stay
    connected: one wrong edge in the tree turns every view behind it (a 10000-view ring with 10 %
    random outlier edges, whose weights are those of the good ones, started 127 deg off in the median,
    and L1RA did not recover in its 50 rounds: 88 deg; docs/SFM.md, "Scale")."""
    tri, good = triangle_support(n, pairs, R_rel)
    # minimum spanning tree of a decreasing function of the weight = maximum-weight tree; the
    # unsupported edges after every supported one (costs in (0.5, 1) against (1.5, 2))
    cost = 1.0 / (1.0 + weights / weights.max()) + np.where((tri > 0) & (good == 0), 1.0, 0.0)
    g = sp.coo_matrix((cost, (pairs[:, 0], pairs[:, 1])), shape=(n, n)).tocsr()
    tree = minimum_spanning_tree(g)
    tree = tree + tree.T
    order, pred = breadth_first_order(tree, root, directed=False, return_predecessors=True)
    if len(order) != n:
        raise InputError("the view graph is not connected")
    lookup = {(int(a), int(b)): k for k, (a, b) in enumerate(pairs)}
    Rg = np.empty((n, 3, 3))
    Rg[root] = np.eye(3)
    for v in order[1:]:
        u = int(pred[v])
        k = lookup.get((u, int(v)))
        Rg[v] = R_rel[k] @ Rg[u] if k is not None else R_rel[lookup[(int(v), u)]].T @ Rg[u]
    return Rg


def _incidence(n: int, pairs: np.ndarray, root: int) -> sp.csr_matrix:
    """``E x (n-1)`` signed incidence matrix (+1 at j, -1 at i), root column dropped."""
    e = len(pairs)
    rows = np.repeat(np.arange(e), 2)
    cols = pairs[:, ::-1].ravel()  # j then i
    vals = np.tile([1.0, -1.0], e)
    D = sp.csr_matrix((vals, (rows, cols)), shape=(e, n))
    keep = np.ones(n, dtype=bool)
    keep[root] = False
    return D[:, np.flatnonzero(keep)].tocsr()


def _expand(x_red: np.ndarray, n: int, root: int) -> np.ndarray:
    x = np.zeros((n, 3))
    keep = np.ones(n, dtype=bool)
    keep[root] = False
    x[keep] = x_red
    return x


def _linearise(Rg: np.ndarray, pairs: np.ndarray, R_rel: np.ndarray) -> np.ndarray:
    """``(E, 3)`` ``b_ij = log(R_j^T R_ij R_i)``."""
    M = np.einsum("eji,ejk,ekl->eil", Rg[pairs[:, 1]], R_rel, Rg[pairs[:, 0]])
    return log_so3(M)


def _factor(D: sp.csr_matrix, w: np.ndarray):
    L = (D.T @ sp.diags(w) @ D).tocsc()
    return splu(L, permc_spec="MMD_AT_PLUS_A")


def _l1ra(Rg, pairs, R_rel, w, D, root, outer: int, admm_iters: int, tol: float) -> tuple[np.ndarray, int, int]:
    n = len(Rg)
    lu = _factor(D, np.ones(D.shape[0]))
    total_admm = 0
    it = 0
    prev_cost = np.inf
    last_step = np.inf
    for it in range(1, outer + 1):
        b = _linearise(Rg, pairs, R_rel)
        cost = float(np.sum(w * np.linalg.norm(b, axis=1)))
        if prev_cost - cost < L1_COST_RTOL * prev_cost and last_step < L1_STALL_STEP:
            # the last round moved no view by more than L1_STALL_STEP and did not lower the
            # relinearised L1 cost: the rounds have converged to the inexact ADMM's noise floor
            it -= 1
            break
        prev_cost = cost
        z = np.zeros_like(b)
        u = np.zeros_like(b)
        x = np.zeros((D.shape[1], 3))
        thr = w[:, None] / ADMM_RHO
        for k in range(admm_iters):
            x = lu.solve(np.asfortranarray(D.T @ (b + z - u)))
            r = D @ x - b
            z_old = z
            v = r + u
            z = np.sign(v) * np.maximum(np.abs(v) - thr, 0.0)
            u = u + r - z
            total_admm += 1
            if k > 5 and np.abs(r - z).max() < ADMM_TOL and np.abs(z - z_old).max() < ADMM_TOL:
                break
        xf = _expand(x, n, root)
        Rg = Rg @ exp_so3(xf)
        last_step = float(np.abs(xf).max())
        if last_step < tol:
            break
    return Rg, it, total_admm


# one IRLS step's weighted solve: (rotations, b (E, 3), Geman-McClure denominators (e^2 + sigma^2)^2)
# -> the reduced update (N - 1, 3)
WeightedSolve = Callable[[np.ndarray, np.ndarray, np.ndarray], np.ndarray]


def _scalar_solve(D: sp.csr_matrix, w: np.ndarray, sigma: float) -> WeightedSolve:
    """Edge weights ``GM_e w_e``: the weighted Laplacian ``D^T W D`` (one factorisation, three
    right-hand sides)."""

    def solve(Rg: np.ndarray, b: np.ndarray, den: np.ndarray) -> np.ndarray:
        wg = w * sigma**2 / den
        wg = wg / wg.max()
        return _factor(D, wg).solve(np.asfortranarray(D.T @ (wg[:, None] * b)))

    return solve


def _block_incidence(D: sp.csr_matrix) -> sp.csr_matrix:
    """``D (x) I_3``: row ``3e + a``, column ``3k + a``."""
    return sp.kron(D, sp.identity(3, format="csr"), format="csr")


def _information_solve(D: sp.csr_matrix, pairs: np.ndarray, info: np.ndarray, sigma: float) -> WeightedSolve:
    """Edge weights ``GM_e R_i^T info_e R_i`` (``info (E, 3, 3)`` in view i's frame): the block
    Laplacian ``(D (x) I_3)^T W (D (x) I_3)`` with 3x3 blocks."""
    A = _block_incidence(D)
    AT = A.T.tocsr()
    e = len(pairs)
    e_idx = np.arange(e)

    def solve(Rg: np.ndarray, b: np.ndarray, den: np.ndarray) -> np.ndarray:
        wg = sigma**2 / den
        wg = wg / wg.max()
        Ri = Rg[pairs[:, 0]]
        W = wg[:, None, None] * np.einsum("eji,ejk,ekl->eil", Ri, info, Ri)
        Wm = sp.bsr_matrix((W, e_idx, np.arange(e + 1)), shape=(3 * e, 3 * e)).tocsr()
        N = (AT @ Wm @ A).tocsc()
        rhs = AT @ np.einsum("eij,ej->ei", W, b).ravel()
        return splu(N, permc_spec="MMD_AT_PLUS_A").solve(rhs).reshape(-1, 3)

    return solve


def _irls(Rg, pairs, R_rel, solve: WeightedSolve, root, sigma: float, iters: int, tol: float) -> tuple[np.ndarray, int]:
    """Geman-McClure IRLS (module docstring, step 4), relinearised every iteration, until the update is
    below ``tol``; ``solve`` weighs the edges (:func:`_scalar_solve` or :func:`_information_solve`)."""
    n = len(Rg)
    it = 0
    for it in range(1, iters + 1):
        b = _linearise(Rg, pairs, R_rel)
        e2 = np.sum(b * b, axis=1)
        x = solve(Rg, b, (e2 + sigma**2) ** 2)
        xf = _expand(x, n, root)
        Rg = Rg @ exp_so3(xf)
        last_step = float(np.abs(xf).max())
        if last_step < tol:
            break
    return Rg, it


# an edge's information is capped at this multiple of the median (by trace): one edge whose matches
# scatter far less than the others' (a tiny noise estimate) must not pin the solution
MAX_INFORMATION_RATIO = 100.0


def _normalised_information(info: np.ndarray) -> np.ndarray:
    """``info (E, 3, 3)`` divided by the median of ``trace / 3`` (the scalar weights' median rule),
    each capped at :data:`MAX_INFORMATION_RATIO` (by trace)."""
    tr = np.trace(info, axis1=1, axis2=2) / 3.0
    med = float(np.median(tr))
    scale = np.minimum(1.0, MAX_INFORMATION_RATIO * med / tr) / med
    return info * scale[:, None, None]


def gm_scale_deg(residuals_deg: np.ndarray, num_views: int) -> float:
    """The Geman-McClure scale (degrees) of a connected graph of ``num_views`` views whose ``E`` edges
    have these residuals ``(E,)`` at a least-squares fit: ``GM_SCALE_FACTOR`` times their median over
    ``sqrt(1 - (num_views - 1) / E)`` (a fit absorbs the share ``(N - 1) / E`` of the errors' variance, the
    mean leverage), within ``[SIGMA_MIN_DEG, SIGMA_DEG]``; ``SIGMA_DEG`` where the residuals do not
    measure the noise (fewer than ``MIN_SCALE_REDUNDANCY`` of the edges' variance left, or no finite
    median). Module docstring, step 4."""
    r = np.asarray(residuals_deg, dtype=np.float64).ravel()
    keep = 1.0 - (int(num_views) - 1) / max(r.size, 1)
    if r.size == 0 or keep < MIN_SCALE_REDUNDANCY:
        return SIGMA_DEG
    med = float(np.median(r))
    if not np.isfinite(med):
        return SIGMA_DEG
    return float(min(SIGMA_DEG, max(SIGMA_MIN_DEG, GM_SCALE_FACTOR * med / np.sqrt(keep))))


def _x84_threshold(res_deg: np.ndarray, min_deg: float, max_deg: float) -> float:
    med = float(np.median(res_deg))
    mad = float(np.median(np.abs(res_deg - med)))
    return float(min(max_deg, max(med + X84_FACTOR * MAD_TO_SIGMA * mad, min_deg)))


def _checked_tolerance(value: object, name: str) -> float:
    """A stopping tolerance: a finite number >= 0 (0 runs every iteration)."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, float, np.integer, np.floating)) or not np.isfinite(value) or value < 0:
        raise InputError(f"{name} must be a finite number >= 0, got {value!r}")
    return float(value)


def checked_error_bounds(min_deg: object, max_deg: object, min_name: str = "min_error_deg", max_name: str = "max_error_deg") -> tuple[float, float]:
    """The outlier test's floor and ceiling (degrees): ``0 <= min <= max``, ``max`` may be ``inf``
    (no ceiling), ``min`` 0 (no floor)."""
    out = []
    for v, name in ((min_deg, min_name), (max_deg, max_name)):
        ok = isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, (bool, np.bool_)) and not np.isnan(v) and v >= 0
        if not ok:
            raise InputError(f"{name} must be a number of degrees >= 0 (inf: no bound), got {v!r}")
        out.append(float(v))  # type: ignore[arg-type]
    if out[0] > out[1] or not np.isfinite(out[0]):
        raise InputError(f"{min_name} ({out[0]:g}) must be finite and at most {max_name} ({out[1]:g})")
    return out[0], out[1]


def average_rotations(
    num_views: int,
    pairs: np.ndarray,
    R_rel: np.ndarray,
    weights: np.ndarray | None = None,
    *,
    information: np.ndarray | None = None,
    init: np.ndarray | None = None,
    l1: bool = True,
    l1_outer: int = 50,
    l1_admm_iterations: int = 100,
    l1_tol: float = 1e-3,
    irls_iterations: int = 100,
    irls_tol: float = 1e-13,
    sigma_deg: float | None = None,
    max_error_deg: float = 5.0,
    min_error_deg: float = 1.0,
    outlier_rounds: int = 3,
) -> RotationAveragingResult:
    """Robust global rotations ``(N, 3, 3)`` from ``E`` relative rotations ``R_rel (E, 3, 3)`` of
    ``pairs (E, 2)`` with ``weights (E,)`` (see the module docstring for every step).

    Views outside the largest connected component (after outlier removal) are not estimated
    (``estimated`` False, NaN rotations). ``init (N, 3, 3)`` replaces the spanning-tree start.
    ``information (E, 3, 3)``: each relative rotation's information in view i's frame (symmetric
    positive definite), used by the IRLS instead of the scalar weights (module docstring).
    ``sigma_deg``: the Geman-McClure scale (degrees, > 0); None estimates it from the data (module
    docstring, step 4; ``info["sigma_deg"]`` holds the scale used).
    """
    times: dict[str, float] = {}
    p, R, w = _check_inputs(num_views, pairs, R_rel, weights)
    n = checked_count(num_views, "num_views", 1)
    sigma_deg = checked_sigma_deg(sigma_deg)
    l1_outer = checked_count(l1_outer, "l1_outer", 1)
    l1_admm_iterations = checked_count(l1_admm_iterations, "l1_admm_iterations", 1)
    irls_iterations = checked_count(irls_iterations, "irls_iterations", 1)
    outlier_rounds = checked_count(outlier_rounds, "outlier_rounds", 0)
    l1_tol, irls_tol = _checked_tolerance(l1_tol, "l1_tol"), _checked_tolerance(irls_tol, "irls_tol")
    min_error_deg, max_error_deg = checked_error_bounds(min_error_deg, max_error_deg)
    if len(p) == 0:
        raise InputError("rotation averaging needs at least one edge")
    w = w / np.median(w)
    info_all = None
    if information is not None:
        info_all = as_real_array(information, "information")
        if info_all.shape != (len(p), 3, 3) or not np.all(np.isfinite(info_all)):
            raise InputError(f"information must be a finite ({len(p)}, 3, 3) array")
        top = float(np.max(np.abs(info_all))) if info_all.size else 0.0
        if top > 0.0:
            info_all = info_all / top  # only the matrices' ratios matter (their scale is normalised below)
        if not np.allclose(info_all, np.swapaxes(info_all, 1, 2), rtol=1e-9, atol=0.0):
            raise InputError("information matrices must be symmetric")
        info_all = 0.5 * (info_all + np.swapaxes(info_all, 1, 2))
        if np.any(np.linalg.eigvalsh(info_all)[:, 0] <= 0):
            raise InputError("information matrices must be positive definite")
        info_all = _normalised_information(info_all)
    edge_ok = np.ones(len(p), dtype=bool)
    outliers: list[tuple[int, int, float]] = []
    info: dict[str, object] = {}

    def component(mask: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        lab = view_components(n, p[mask])
        # a view with no edge is its own component; pick the largest by views
        vmask = largest_component(lab)
        return vmask, mask & vmask[p[:, 0]] & vmask[p[:, 1]]

    t0 = time.perf_counter()
    vmask, emask = component(edge_ok)
    views = np.flatnonzero(vmask)
    remap = np.full(n, -1, dtype=np.int64)
    remap[views] = np.arange(len(views))
    pe = remap[p[emask]]
    deg = np.bincount(pe.ravel(), weights=np.repeat(w[emask], 2), minlength=len(views))
    root = int(np.argmax(deg))
    if init is not None:
        Ri = checked_rotations(init, "init", n, missing=True)
        if not np.all(np.isfinite(Ri[views])):
            raise InputError("init must hold a rotation for every view of the graph's largest component")
        Rg = Ri[views] @ Ri[views][root].T
    else:
        Rg = spanning_tree_rotations(len(views), pe, R[emask], w[emask], root)
    times["init"] = time.perf_counter() - t0

    t0 = time.perf_counter()
    if l1 and len(views) > 1:
        D = _incidence(len(views), pe, root)
        Rg, info["l1_outer"], info["l1_admm"] = _l1ra(Rg, pe, R[emask], w[emask], D, root, l1_outer, l1_admm_iterations, l1_tol)
    times["l1"] = time.perf_counter() - t0

    t0 = time.perf_counter()
    irls_total = 0
    if sigma_deg is None:
        # the scale from the residuals of a least-squares-like fit (a few IRLS steps at SIGMA_DEG, where
        # the GM weights of residuals far below it are flat), not of the L1 solution, which fits many
        # edges exactly on sparse graphs (nor of the spanning tree's, exact on its edges)
        if len(views) > 1:
            sg = np.radians(SIGMA_DEG)
            D = _incidence(len(views), pe, root)
            solve = _scalar_solve(D, w[emask], sg) if info_all is None else _information_solve(D, pe, info_all[emask], sg)
            Rg, k = _irls(Rg, pe, R[emask], solve, root, sg, SCALE_PASS_ITERATIONS, irls_tol)
            irls_total += k
        start = np.full((n, 3, 3), np.nan)
        start[views] = Rg
        sigma_deg = gm_scale_deg(rotation_residuals_deg(start, p, R)[emask], len(views))
    info["sigma_deg"] = float(sigma_deg)
    sigma = np.radians(sigma_deg)
    full = np.full((n, 3, 3), np.nan)
    for rnd in range(outlier_rounds + 1):
        if len(views) > 1:
            D = _incidence(len(views), pe, root)
            solve = _scalar_solve(D, w[emask], sigma) if info_all is None else _information_solve(D, pe, info_all[emask], sigma)
            Rg, k = _irls(Rg, pe, R[emask], solve, root, sigma, irls_iterations, irls_tol)
            irls_total += k
        full[:] = np.nan
        full[views] = Rg
        res = rotation_residuals_deg(full, p, R)
        if rnd == outlier_rounds or not np.any(np.isfinite(res[emask])):
            break
        thr = _x84_threshold(res[emask], min_error_deg, max_error_deg)
        bad = emask & (res > thr)
        if not np.any(bad):
            break
        for e in np.flatnonzero(bad).tolist():
            outliers.append((int(p[e, 0]), int(p[e, 1]), float(res[e])))
        edge_ok &= ~bad
        old_views = views
        vmask, emask = component(edge_ok)
        views = np.flatnonzero(vmask)
        old_R = full[views]
        remap[:] = -1
        remap[views] = np.arange(len(views))
        pe = remap[p[emask]]
        root = int(np.argmax(np.bincount(pe.ravel(), weights=np.repeat(w[emask], 2), minlength=len(views))))
        Rg = old_R @ old_R[root].T
        info["views_dropped"] = int(len(old_views) - len(views)) + int(info.get("views_dropped", 0))  # type: ignore[call-overload]
    times["irls"] = time.perf_counter() - t0
    info["irls_iterations"] = irls_total
    info["root"] = int(views[root])
    inl = emask.copy()
    return RotationAveragingResult(full, vmask.copy(), inl, outliers, res, times, info)
