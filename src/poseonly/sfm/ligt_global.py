"""LiGT global translation (Cai et al.; the global_sfm notes, section 1), built sparse.

For fixed rotations, every observation ``i != l`` of a track gives three rows (rank 2), in world
frame (the notes' rows left-multiplied by the orthogonal ``R_i^T``, which leaves ``L^T L``
unchanged)::

    (w_i x w_l) g^T (c_r - c_l) + theta^2 [w_i]x (c_i - c_l) = 0

(``w`` world bearings, ``g``, ``theta``, ``l``, ``r`` of :mod:`.posegeom`). ``L`` is assembled as a
``scipy.sparse`` matrix with at most 27 non-zeros per row triple, so memory and time are linear in
the observations; ``H = L^T L`` is sparse with the co-visibility pattern, accumulated in chunks
(:func:`_gram`). Gauge: the reference view (most observations) has ``c = 0`` (its columns dropped);
scale: the eigenvector of the smallest eigenvalue of the pencil ``(H, N)`` with ``N`` the expected
noise part of ``H`` (Taubin's normalisation, :func:`build_noise_matrix`; the paper's unit norm,
``N = I``, is ``normalization="unit"``), found densely up to :data:`DENSE_MAX` unknowns, else by
``eigsh`` in shift-invert mode around a small negative shift from a fixed start vector (``H - sigma
N`` is then positive definite, factorised once by SuperLU). Sign: the majority of the depth rows
``g^T (c_l - c_r) = d_l theta^2`` must be positive (openMVG's vote).

What cannot constrain the solution is removed explicitly and reported: observations in views
without a rotation, tracks left with fewer than two views, tracks whose base parallax is below
``min_parallax_deg`` (pure rotation / far points carry no translation), views not joined to the
reference's component by the remaining tracks, and views whose own block of ``L^T L`` is singular
(:func:`_weak_views`; the system is then rebuilt without them). Tracks that fix no unique solution
raise :class:`TranslationUndetermined`: none left, fewer than two views, two views joined by one
track, or (noise normalisation) a second eigenvalue below ``NONUNIQUE_RTOL`` of the mean, e.g. two
groups of views joined through one camera. ``info["eig_ratio"]`` (``lambda_1 / lambda_2``) near 1
flags a solution that noise can mix with another mode (long rings of short tracks).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np
import scipy.linalg
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components
from scipy.sparse.linalg import eigsh

from ..geometry import InputError
from .choices import LIGT_NORMALIZATIONS
from .inputs import checked_bearings, checked_count, checked_positive, checked_rotations
from .posegeom import base_views, g_vectors, world_bearings
from .tracks import Tracks

__all__ = [
    "LIGT_NORMALIZATIONS",
    "MIN_PARALLAX_DEG",
    "LiGTResult",
    "TranslationUndetermined",
    "build_ligt_matrix",
    "build_noise_matrix",
    "ligt_blocks",
    "ligt_positions",
    "noise_blocks",
]

MIN_PARALLAX_DEG = 1.0
SHIFT_REL = 1e-10  # shift-invert shift, relative to the mean diagonal of H
DENSE_MAX = 600  # unknowns (200 views) up to which the eigenproblem is solved densely
# row triples assembled at a time when accumulating L^T L (bounds the peak memory of the build)
GRAM_CHUNK = 65536
# a view whose own block of L^T L has a smallest eigenvalue below this share of its largest is not
# determined by its rows (exactly singular in exact arithmetic: ~1e-16 when it happens); such views
# are removed and the system rebuilt until none is left (each round removes one view at least)
WEAK_VIEW_RTOL = 1e-10
# a second eigenvalue of (L^T L, N) below this share of their mean: the centres are not unique (exactly
# degenerate tracks give ~1e-16; a noise-free 10000-view ring's bending mode 5e-7, ~1 / N^2). Only with
# the noise normalisation: under the unit norm a ring's bending mode falls as ~1 / N^4 (7e-12 at 10000
# views), so "unit" keeps the paper's behaviour and eig_ratio is the only flag there
NONUNIQUE_RTOL = 1e-10
# bearing_scale="z": a bearing's z below this share of its length is taken for one not in front
MIN_Z_BEARING = 1e-6


class TranslationUndetermined(InputError):
    """Valid input whose tracks do not determine the camera centres: every track too short or without
    parallax (a pure rotation, a panorama), fewer than two views joined by usable ones, or a singular
    system. :func:`poseonly.sfm.pipeline.run_global` turns it into a result with rotations and no
    centres; called directly, :func:`ligt_positions` raises it (an :class:`InputError`)."""


@dataclass
class LiGTResult:
    """``centres (N, 3)`` (NaN where not estimated; reference view at 0; scale arbitrary),
    ``estimated (N,)``, ``track_used (T,)``, ``reference`` view, ``times_s`` and ``info``
    (eigenvalues, counts of what was dropped and why)."""

    centres: np.ndarray
    estimated: np.ndarray
    track_used: np.ndarray
    reference: int
    times_s: dict[str, float] = field(default_factory=dict)
    info: dict[str, object] = field(default_factory=dict)


def _skew_batch(v: np.ndarray) -> np.ndarray:
    z = np.zeros(len(v))
    return np.stack([np.stack([z, -v[:, 2], v[:, 1]], 1), np.stack([v[:, 2], z, -v[:, 0]], 1), np.stack([-v[:, 1], v[:, 0], z], 1)], 1)


def _smallest_eigvec(H: sp.csc_matrix, m: int, N: sp.csc_matrix | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Eigenvector of the smallest eigenvalue of the PSD ``H`` (of the pencil ``H x = lambda N x``
    when the positive definite ``N`` is given) and up to 3 smallest eigenvalues: dense (LAPACK) up to
    :data:`DENSE_MAX` unknowns, else shift-invert Lanczos around ``-SHIFT_REL * mean(diag H) /
    mean(diag N)`` from a fixed start vector (ARPACK's own is random: a degenerate system then gave
    a different answer on every call)."""
    shift = SHIFT_REL * float(H.diagonal().mean())
    if N is not None:
        shift /= float(N.diagonal().mean())
    k = min(3, m - 1)
    if not (np.isfinite(shift) and shift > 0):
        raise TranslationUndetermined("LiGT: the linear system is zero (no track constrains the translations)")
    try:
        if m <= DENSE_MAX:
            vals, vecs = scipy.linalg.eigh(H.toarray(), None if N is None else N.toarray(), subset_by_index=[0, k - 1])
        else:
            v0 = np.random.default_rng(0).standard_normal(m)
            vals, vecs = eigsh(H, k=k, M=N, sigma=-shift, which="LM", tol=0.0, v0=v0)
    except (RuntimeError, np.linalg.LinAlgError) as exc:  # ArpackError too: a singular factor, or N not definite
        raise TranslationUndetermined(f"LiGT: the linear system is singular or its eigenproblem failed ({exc})") from None
    o = np.argsort(vals)
    return vecs[:, o[0]], vals[o]


def _centres(x: np.ndarray, cols: np.ndarray, n: int) -> np.ndarray:
    c = np.zeros(3 * n)
    c[cols] = x
    return c.reshape(n, 3)


def _non_base(tracks: Tracks, l_obs: np.ndarray) -> np.ndarray:
    """Observation indices ``i != l`` in the row order of :func:`build_ligt_matrix`."""
    other = np.ones(tracks.num_observations, dtype=bool)
    other[l_obs] = False
    return np.flatnonzero(other)


Blocks = tuple[tuple[np.ndarray, np.ndarray], ...]  # ((M (K, 3, 3), views (K,)), ...): see _assemble


def ligt_blocks(tracks: Tracks, wb: np.ndarray, l_obs: np.ndarray, r_obs: np.ndarray) -> tuple[Blocks, np.ndarray, np.ndarray]:
    """The row blocks of the LiGT matrix (for :func:`_assemble`), ``g (T, 3)`` and the ``(l, r)``
    views ``(T, 2)`` (depth of track t: ``g_t^T (c_l - c_r)``). ``wb (M, 3)`` world bearings,
    ``l_obs, r_obs (T,)`` base observation indices."""
    views = tracks.views
    tr = tracks.track_of_observation
    oi = _non_base(tracks, l_obs)  # observations i != l
    t_i = tr[oi]
    wl, wr = wb[l_obs], wb[r_obs]
    g = g_vectors(wl, wr)
    th2 = np.sum(np.cross(wl, wr) ** 2, axis=1)
    wi = wb[oi]
    M1 = np.cross(wi, wl[t_i])[:, :, None] * g[t_i][:, None, :]  # (K, 3, 3)
    M2 = th2[t_i][:, None, None] * _skew_batch(wi)
    vl, vr, vi = views[l_obs][t_i], views[r_obs][t_i], views[oi]
    return ((M1, vr), (M2, vi), (-(M1 + M2), vl)), g, np.stack([views[l_obs], views[r_obs]], axis=1)


def build_ligt_matrix(num_views: int, tracks: Tracks, wb: np.ndarray, l_obs: np.ndarray, r_obs: np.ndarray) -> tuple[sp.csr_matrix, np.ndarray, np.ndarray]:
    """The sparse LiGT matrix ``L (3 (M - T), 3 N)``, ``g`` and the ``(l, r)`` views of
    :func:`ligt_blocks` (the solver accumulates ``L^T L`` in chunks instead, :func:`_gram`)."""
    blocks, g, lr = ligt_blocks(tracks, wb, l_obs, r_obs)
    return _assemble(blocks, num_views), g, lr


def _assemble(blocks: tuple[tuple[np.ndarray, np.ndarray], ...], num_views: int) -> sp.csr_matrix:
    """Sparse ``(3 K, 3 N)`` matrix whose row triple ``k`` holds the ``3 x 3`` block ``M[k]`` in the
    columns of view ``v[k]``, for every ``(M (K, 3, 3), v (K,))`` of ``blocks`` (summed)."""
    K = len(blocks[0][1])
    rows = 3 * np.arange(K)[:, None] + np.arange(3)[None, :]  # (K, 3)
    R_idx, C_idx, V = [], [], []
    for Mb, vb in blocks:
        R_idx.append(np.repeat(rows, 3, axis=1).ravel())
        C_idx.append((3 * vb[:, None, None] + np.arange(3)[None, None, :]).repeat(3, axis=1).ravel())
        V.append(Mb.ravel())
    return sp.csr_matrix((np.concatenate(V), (np.concatenate(R_idx), np.concatenate(C_idx))), shape=(3 * K, 3 * num_views))


def _gram(blocks: Blocks, num_views: int, row_weights: np.ndarray | None = None) -> sp.csr_matrix:
    """``C^T C (3 N, 3 N)`` for ``C = diag(row_weights) _assemble(blocks)`` (each weight on its row
    triple), accumulated over chunks of :data:`GRAM_CHUNK` row triples so that ``C`` is never held
    whole (its COO indices were most of LiGT's peak memory: 2.5 -> 1.0 GiB at 1.08M observations)."""
    K = len(blocks[0][1])
    G = sp.csr_matrix((3 * num_views, 3 * num_views))
    for a in range(0, K, GRAM_CHUNK):
        sl = slice(a, min(a + GRAM_CHUNK, K))
        C = _assemble(tuple((M[sl], v[sl]) for M, v in blocks), num_views)
        if row_weights is not None:
            C = sp.diags(np.repeat(row_weights[sl], 3)) @ C
        G = G + (C.T @ C).tocsr()
    return G


def _weak_views(G: sp.csr_matrix, view_in: np.ndarray, reference: int, keep_reference: bool) -> np.ndarray:
    """Views ``(N,)`` whose own ``3 x 3`` block of ``G = L^T L`` is singular (smallest eigenvalue below
    :data:`WEAK_VIEW_RTOL` of the largest): the centre slides along a direction no row sees while
    every other centre stays, so the solution is not unique (a view in a single two-view track: its
    rows see ``c_r - c_l`` only through a rank-2 map). A caller's reference (``keep_reference``) is
    never weak; in a component of two views the other view's slide along the baseline is the scale,
    not a freedom."""
    n = len(view_in)
    if int(np.sum(view_in)) <= 2:
        return np.zeros(n, dtype=bool)
    coo = G.tocoo()
    same = (coo.row // 3) == (coo.col // 3)
    D = np.zeros((n, 3, 3))
    np.add.at(D, (coo.row[same] // 3, coo.row[same] % 3, coo.col[same] % 3), coo.data[same])
    ev = np.linalg.eigvalsh(D[view_in])
    weak = np.zeros(n, dtype=bool)
    weak[np.flatnonzero(view_in)[ev[:, 0] <= WEAK_VIEW_RTOL * ev[:, 2]]] = True
    if keep_reference:
        weak[reference] = False
    return weak


def build_noise_matrix(num_views: int, tracks: Tracks, wb: np.ndarray, l_obs: np.ndarray, r_obs: np.ndarray) -> sp.csr_matrix:
    """The first-order noise map ``S V (3 (M - T), 3 N)`` of the LiGT rows, in the row order of
    :func:`build_ligt_matrix`: row triple ``k`` (observation ``i`` of track ``t``) is
    ``w_i x v_k`` with ``v_k = w_l g^T (c_r - c_l) + theta^2 (c_i - c_l)`` (``= theta^2 (c_i - X_t)``
    at the truth), so an isotropic tangent error ``dw`` of ``w_i`` (variance ``s^2`` per axis)
    gives it ``E ||v x dw||^2 = s^2 v^T (I + w_i w_i^T) v``; ``S = I + (sqrt 2 - 1) w_i w_i^T`` is
    that form's square root. ``N = (S V)^T (S V)`` is the expected noise part of ``L^T L``
    (Taubin's normalisation; the base bearings' errors are left out)."""
    return _assemble(noise_blocks(tracks, wb, l_obs, r_obs), num_views)


def noise_blocks(tracks: Tracks, wb: np.ndarray, l_obs: np.ndarray, r_obs: np.ndarray) -> Blocks:
    """The row blocks of :func:`build_noise_matrix`'s ``S V`` (for :func:`_assemble`)."""
    views = tracks.views
    tr = tracks.track_of_observation
    oi = _non_base(tracks, l_obs)
    t_i = tr[oi]
    wl, wr, wi = wb[l_obs], wb[r_obs], wb[oi]
    g = g_vectors(wl, wr)
    th2 = np.sum(np.cross(wl, wr) ** 2, axis=1)
    S = np.eye(3)[None] + (np.sqrt(2.0) - 1.0) * wi[:, :, None] * wi[:, None, :]
    A = S @ (wl[t_i][:, :, None] * g[t_i][:, None, :])  # (K, 3, 3): S w_l g^T
    B = th2[t_i][:, None, None] * S
    vl, vr, vi = views[l_obs][t_i], views[r_obs][t_i], views[oi]
    return ((A, vr), (B, vi), (-(A + B), vl))


@dataclass
class _System:
    """The observations LiGT uses (:func:`_usable_system`)."""

    tracks: Tracks
    wb: np.ndarray
    l_obs: np.ndarray
    r_obs: np.ndarray
    view_in: np.ndarray
    track_used: np.ndarray
    reference: int
    counts: dict[str, int]


def _usable_system(n: int, tracks: Tracks, wb_all: np.ndarray, view_ok: np.ndarray, min_parallax_deg: float, reference: int | None, chosen: bool) -> _System:
    """Drop the observations of views not in ``view_ok``, then tracks with < 2 views, tracks whose
    base parallax is below ``min_parallax_deg``, and everything not joined to the reference view (the
    given one, or the view of most observations) by the remaining tracks; counts of each. A given
    reference left without usable tracks is the caller's error, unless it was ``chosen`` here before
    (then the views removed since left it alone: :class:`TranslationUndetermined`)."""
    counts: dict[str, int] = {}
    obs_ok = view_ok[tracks.views]
    tr_all = tracks.track_of_observation
    cnt = np.bincount(tr_all[obs_ok], minlength=len(tracks))
    long_enough = cnt >= 2
    counts["tracks_too_short"] = int(np.sum(~long_enough))
    track_used = long_enough.copy()
    keep_obs = obs_ok & long_enough[tr_all]
    sub2 = Tracks(np.concatenate([[0], np.cumsum(cnt[long_enough])]).astype(np.int64), tracks.views[keep_obs], tracks.keypoints[keep_obs])
    wb2 = wb_all[keep_obs]
    _l_obs, _r_obs, theta = base_views(sub2, wb2)
    par_ok = theta > np.sin(np.radians(min_parallax_deg))
    counts["tracks_low_parallax"] = int(np.sum(~par_ok))
    ids = np.flatnonzero(long_enough)
    track_used[ids[~par_ok]] = False
    sub3 = sub2.subset(par_ok)
    wb3 = wb2[np.repeat(par_ok, sub2.lengths)]
    # views joined by the remaining tracks: connected components of the track-view incidence
    tr3 = sub3.track_of_observation
    T3 = len(sub3)
    if T3 == 0:
        raise TranslationUndetermined("LiGT: no track constrains the translations (all too short or without parallax)")
    inc = sp.coo_matrix((np.ones(len(tr3)), (sub3.views, n + tr3)), shape=(n + T3, n + T3))
    _, lab = connected_components(inc, directed=False)
    nobs = np.bincount(sub3.views, minlength=n)
    if reference is None:
        reference = int(np.argmax(nobs))
    elif not (0 <= reference < n and nobs[reference] > 0):
        err = TranslationUndetermined if chosen else InputError
        raise err(f"reference view {reference} is not observed by any usable track")
    comp = lab[reference]
    view_in = (lab[:n] == comp) & (nobs > 0)
    tr_in = lab[n + np.arange(T3)] == comp
    counts["views_disconnected"] = int(np.sum((nobs > 0) & ~view_in))
    counts["tracks_disconnected"] = int(np.sum(~tr_in))
    used_ids = np.flatnonzero(track_used)
    track_used[used_ids[~tr_in]] = False
    sub4 = sub3.subset(tr_in)
    wb4 = wb3[np.repeat(tr_in, sub3.lengths)]
    l4, r4, _ = base_views(sub4, wb4)
    return _System(sub4, wb4, l4, r4, view_in, track_used, int(reference), counts)


def ligt_positions(
    rotations: np.ndarray,
    tracks: Tracks,
    bearings: np.ndarray,
    *,
    min_parallax_deg: float = MIN_PARALLAX_DEG,
    reference: int | None = None,
    reweight_iterations: int = 0,
    bearing_scale: str = "unit",
    normalization: str = "noise",
) -> LiGTResult:
    """Camera centres ``(N, 3)`` from global ``rotations (N, 3, 3)`` (world -> camera, NaN for
    views without one), ``tracks`` and their unit camera-frame ``bearings (M, 3)``.

    ``reweight_iterations > 0`` re-solves with every row triple divided by ``theta^2 ||X - c_i||``
    of the previous solution (its residual becomes the angular error of the observation; openMVG's
    LiGT is ``0``). ``bearing_scale``: ``"unit"`` bearings (the paper) or ``"z"`` normalized image
    coordinates ``(x, y, 1)`` (openMVG); the rows are homogeneous in the bearings, so this changes the
    implicit weighting only.

    ``normalization`` fixes the scale of the eigenvector: ``"unit"`` is the paper's and openMVG's
    ``||x|| = 1`` over the centres relative to the reference view, which weighs far views most, so
    noise bends long graphs (a 5000-view ring from the true rotations: 4.8 % of its extent off);
    ``"noise"`` (default) takes ``x^T N x = 1`` with ``N`` the expected noise part of ``L^T L``
    (:func:`build_noise_matrix`, Taubin's normalisation), independent of the gauge (0.16 %)."""
    if normalization not in LIGT_NORMALIZATIONS:
        raise InputError(f"normalization must be 'noise' or 'unit', got {normalization!r}")
    times: dict[str, float] = {}
    t_start = time.perf_counter()
    Rg = checked_rotations(rotations, "rotations", missing=True)
    n = len(Rg)
    if not isinstance(tracks, Tracks):
        raise InputError(f"tracks must be a poseonly.sfm.tracks.Tracks, got {type(tracks).__name__}")
    f = checked_bearings(bearings, "bearings", tracks.num_observations)
    if len(tracks) and tracks.views.max() >= n:
        raise InputError(f"tracks reference view {tracks.views.max()} but only {n} rotations are given")
    if bearing_scale == "z":  # normalized image coordinates (x, y, 1), openMVG's input
        if np.any(f[:, 2] < MIN_Z_BEARING):
            raise InputError(f"bearing_scale='z' needs every bearing in front of its camera (z >= {MIN_Z_BEARING:g} of its length)")
        f = f / f[:, 2:3]
    elif bearing_scale != "unit":
        raise InputError(f"bearing_scale must be 'unit' or 'z', got {bearing_scale!r}")
    reweight_iterations = checked_count(reweight_iterations, "reweight_iterations")
    if not min_parallax_deg == 0:
        min_parallax_deg = checked_positive(min_parallax_deg, "min_parallax_deg")
    if not 0 <= float(min_parallax_deg) < 90:
        raise InputError(f"min_parallax_deg must be a number of degrees in [0, 90), got {min_parallax_deg!r}")
    if reference is not None:
        reference = checked_count(reference, "reference")
    info: dict[str, object] = {}
    has_R = np.all(np.isfinite(Rg), axis=(1, 2))
    info["observations_without_rotation"] = int(np.sum(~has_R[tracks.views]))
    Rsafe = np.where(has_R[:, None, None], Rg, np.eye(3))
    wb_all = world_bearings(Rsafe, tracks.views, f)
    weak = np.zeros(n, dtype=bool)
    chosen = reference is None
    allowed = has_R.copy()
    while True:  # ends: every round that does not break removes a view
        sysm = _usable_system(n, tracks, wb_all, allowed & ~weak, min_parallax_deg, reference, chosen)
        t0 = time.perf_counter()
        blocks, g, lr = ligt_blocks(sysm.tracks, sysm.wb, sysm.l_obs, sysm.r_obs)
        G = _gram(blocks, n)
        new_weak = _weak_views(G, sysm.view_in, sysm.reference, keep_reference=not chosen)
        times["build"] = times.get("build", 0.0) + time.perf_counter() - t0
        if not new_weak.any():
            break
        weak |= new_weak
        if new_weak[sysm.reference]:  # a chosen reference its rows do not fix: choose again in its component
            allowed &= sysm.view_in
            reference = None
        else:  # the choice stays: its component is the one solved
            reference = sysm.reference
    reference = sysm.reference
    info.update(sysm.counts)
    info["views_weak"] = int(np.sum(weak))
    # views with a rotation and observations left out of the solved component (a re-chosen reference
    # restricts the later rounds to its component, whose outside then counts here)
    observed = np.bincount(tracks.views, minlength=n) > 0
    info["views_disconnected"] = int(np.sum(observed & has_R & ~sysm.view_in & ~weak))
    if int(np.sum(sysm.view_in)) == 2 and len(sysm.tracks) < 2:
        # one point fixes only a plane of baseline directions; LiGT's rank-2 rows pick one of them
        raise TranslationUndetermined("LiGT: two views joined by a single track (one point does not fix the baseline's direction)")
    sub4, wb4, l4, r4, view_in, track_used, reference = sysm.tracks, sysm.wb, sysm.l_obs, sysm.r_obs, sysm.view_in, sysm.track_used, sysm.reference
    times["setup"] = time.perf_counter() - t_start - times["build"]

    t0 = time.perf_counter()
    cols = np.flatnonzero(np.repeat(view_in, 3))
    ref_cols = np.arange(3 * reference, 3 * reference + 3)
    cols = cols[~np.isin(cols, ref_cols)]
    H = G[cols][:, cols].tocsc()
    nblocks = noise_blocks(sub4, wb4, l4, r4) if normalization == "noise" else None
    Nm = _gram(nblocks, n)[cols][:, cols].tocsc() if nblocks is not None else None
    info["normalization"] = normalization
    info["rows"] = 3 * len(blocks[0][1])
    info["unknowns"] = len(cols)
    info["nnz_H"] = int(H.nnz)
    times["build"] += time.perf_counter() - t0

    t0 = time.perf_counter()
    if len(cols) < 3:
        raise TranslationUndetermined("LiGT needs at least two views joined by usable tracks")
    x, vals = _smallest_eigvec(H, len(cols), Nm)
    # the mean eigenvalue of the pencil: the scale against which a second zero eigenvalue is judged
    mean_eig = float(H.diagonal().sum() / Nm.diagonal().sum()) if Nm is not None else float("nan")
    if Nm is not None and len(vals) >= 2 and vals[1] < NONUNIQUE_RTOL * mean_eig:
        raise TranslationUndetermined(
            f"LiGT: the tracks do not fix the centres uniquely (a second eigenvalue {vals[1] / mean_eig:.2g} of the mean: e.g. groups of views joined through a single camera)"
        )
    # optional reweighting: row triple i of track t scaled by 1 / (theta_t^2 ||X_t - c_i||) so its
    # residual becomes the sine of the angular error of observation i (IRLS on the same system)
    oi = _non_base(sub4, l4)
    tr_oi = sub4.track_of_observation[oi]
    th2 = np.sum(np.cross(wb4[l4], wb4[r4]) ** 2, axis=1)
    for _ in range(int(reweight_iterations)):
        C_cur = _centres(x, cols, n)
        d = np.sum(g * (C_cur[lr[:, 0]] - C_cur[lr[:, 1]]), axis=1) / th2
        if np.sum(d > 0) < np.sum(d <= 0):  # the eigenvector's sign is the solver's: fix it first
            x, C_cur, d = -x, -C_cur, -d
        X = C_cur[lr[:, 0]] + d[:, None] * wb4[l4]
        dist = np.linalg.norm(X[tr_oi] - C_cur[sub4.views[oi]], axis=1)
        good = np.isfinite(dist) & (dist > 0)
        med = float(np.median(dist[good])) if np.any(good) else 1.0
        dist = np.where(good, np.maximum(dist, 1e-3 * med), med)
        w = 1.0 / (th2[tr_oi] * dist)
        w /= np.median(w)
        H = _gram(blocks, n, w)[cols][:, cols].tocsc()
        if nblocks is not None:
            Nm = _gram(nblocks, n, w)[cols][:, cols].tocsc()
        x, vals = _smallest_eigvec(H, len(cols), Nm)
    info["reweight_iterations"] = int(reweight_iterations)
    info["eigenvalues"] = [float(v) for v in vals]
    if len(vals) >= 2:
        info["eig_ratio"] = float(vals[0] / vals[1]) if vals[1] > 0 else float("nan")
    if len(vals) >= 3:
        info["eig_ratio_23"] = float(vals[1] / vals[2]) if vals[2] > 0 else float("nan")
    times["solve"] = time.perf_counter() - t0

    C = _centres(x, cols, n)
    depth = np.sum(g * (C[lr[:, 0]] - C[lr[:, 1]]), axis=1)
    npos = int(np.sum(depth > 0))
    if npos < len(depth) - npos:
        C = -C
        npos = len(depth) - npos
    info["positive_depth_fraction"] = npos / max(len(depth), 1)
    C[~view_in] = np.nan
    return LiGTResult(C, view_in, track_used, int(reference), times, info)
