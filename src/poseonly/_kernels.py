"""Optional compiled kernels (numba) for the hot paths; pure-numpy code is the fallback.

numba is an optional dependency: nothing here is imported until a hot path asks for a kernel, and
every kernel has a numpy twin that computes the same numbers (to rounding; the equivalence tests
run both). ``POSEONLY_NUMBA=0`` in the environment (or :func:`use` ``(False)``) disables the
kernels. Kernels are compiled with ``cache=True`` (the first call of a fresh install pays the
compilation once, later processes load the cache) and without ``fastmath`` (IEEE semantics, so the
results do not depend on the compiler's reassociation).

Kernels (docs/speed_notes.md has the profiles that motivated each one):

* :func:`rank_candidates` -- pose identification and PPO ranking of ``k`` candidate essential
  matrices against ``n`` points (:func:`poseonly.identify.identify_and_rank`): a 3x3 Jacobi
  eigen-decomposition per candidate instead of LAPACK calls, then two passes over the points with
  everything in registers (numpy materialises ~40 temporaries of shape ``(2, k, n)``);
* :func:`lirp_action`, :func:`lirp_post` -- LiRP before and after LAPACK's ``eig`` (Demazure
  template and least squares; candidate assembly, case-2 cubic, ``d_min``): ~40 small numpy calls
  per problem become two calls;
* :func:`svd9` -- the 9x9 SVD of LiRP's null space by one-sided Jacobi, four disjoint rotations per
  round (LAPACK's ``dgesdd`` spends ~9 us on a 9x9 matrix, Jacobi ~4 us);
* :func:`qr_r9` -- the triangular factor of LiRP's epipolar rows (Householder up to 64 rows, LAPACK's
  ``dgeqrf`` from compiled code above);
* :func:`gnc_lirp` -- the whole GNC-IRLS loop with LiRP (identified pose or all candidates) and
  ``v_LiGT`` / ``v_sampson`` / ``v_sampson_chiral`` per problem (``_kernels_nb.gnc_lirp_nb``);
* :func:`ransac_score` -- residual and MSAC score of every RANSAC hypothesis in one pass;
* :func:`residual` -- ``v_LiGT`` and ``v_sampson`` of ``k`` poses on ``n`` points in one pass;
* :func:`ligt_normal` -- LiGTopt's robust cost and 5x5 Gauss-Newton normal equations in one pass
  over the points (the numpy twin builds the ``(n, 3, 5)`` Jacobian with ~40 array calls);
* :func:`fivept_real` -- the Stewenius five-point solver on minimal samples returning the real
  solutions only (:mod:`poseonly.solvers.fivept`): 10x10 action matrix reduced to Hessenberg form
  and its real eigenvalues found by the Francis double-shift QR, eigenvectors by a 9x9 solve,
  instead of LAPACK's ``dgeev`` with all ten complex eigenvectors (~30 us per sample).
"""

from __future__ import annotations

import os
from contextlib import contextmanager

import numpy as np

__all__ = ["available", "enabled", "use", "rank_candidates", "lirp_action", "lirp_post", "fivept_real", "residual", "ligt_normal",
           "gnc_lirp", "svd9", "qr_r9", "ransac_score"]

_state = {"checked": False, "available": False, "enabled": os.environ.get("POSEONLY_NUMBA", "1") not in ("0", "false", "no", "off")}
_impl: dict = {}


def available() -> bool:
    """True when numba can be imported (checked once, lazily)."""
    if not _state["checked"]:
        _state["checked"] = True
        try:
            import numba  # noqa: F401

            _state["available"] = True
        except Exception:  # pragma: no cover - depends on the environment
            _state["available"] = False
    return _state["available"]


def enabled() -> bool:
    return _state["enabled"] and available()


@contextmanager
def use(flag: bool):
    """Temporarily enable (``True``) or disable (``False``) the compiled kernels."""
    old = _state["enabled"]
    _state["enabled"] = bool(flag)
    try:
        yield
    finally:
        _state["enabled"] = old


def _compiled():
    if not _impl:
        from . import _kernels_nb

        _impl["rank"] = _kernels_nb.rank_candidates_nb
        _impl["fivept"] = _kernels_nb.fivept_real_nb
        _impl["lirp_action"] = _kernels_nb.lirp_action_nb
        _impl["lirp_post"] = _kernels_nb.lirp_post_nb
        _impl["residual"] = _kernels_nb.residual_nb
        _impl["eig6"] = _kernels_nb.eig6_nb
        _impl["kron"] = _kernels_nb.kron_rows_nb
        _impl["ligt_normal"] = _kernels_nb.ligt_normal_nb
        _impl["svd9"] = _kernels_nb.svd9_nb
        _impl["qr_r9"] = _kernels_nb.qr_r9_nb
        _impl["score"] = _kernels_nb.score_nb
        _impl["gnc_lirp"] = _kernels_nb.gnc_lirp_nb
    return _impl


_EMPTY2 = np.zeros((0, 0))


def rank_candidates(E, f1, f2, w, with_cost=True):
    """Compiled :func:`poseonly.identify._rank_numpy` on flat ``E (H,k,3,3)``, ``f (H,n,3)``, ``w (H,n) | None``.

    Returns ``R, t, valid, M1, cost`` (``inf`` where not finite; ``None`` without ``with_cost``)
    and ``best (H,)`` (the argmin of ``cost``, invalid candidates ``+10``)."""
    H, k = E.shape[:2]
    R = np.empty((H, k, 3, 3))
    t = np.empty((H, k, 3))
    valid = np.empty((H, k), np.bool_)
    M1 = np.empty((H, k))
    cost = np.empty((H, k))
    best = np.empty(H, np.int64)
    ww = _EMPTY2 if w is None else np.ascontiguousarray(w, dtype=np.float64)
    _compiled()["rank"](np.ascontiguousarray(E, dtype=np.float64), np.ascontiguousarray(f1, dtype=np.float64),
                        np.ascontiguousarray(f2, dtype=np.float64), ww, w is not None, bool(with_cost), R, t, valid, M1, cost, best)
    return R, t, valid, M1, (cost if with_cost else None), best


_MONO27 = None


def _mono27():
    global _MONO27
    if _MONO27 is None:
        from .solvers.lirp import _G

        _MONO27 = np.argmax(_G.reshape(27, 10), axis=1).astype(np.int64)
    return _MONO27


def lirp_action(q):
    """Action matrices ``C (h, 2, 6, 6)`` and ``ok (h,)`` from the null-space bases ``q (h, 3, 9)``."""
    h = q.shape[0]
    C = np.empty((h, 2, 6, 6))
    ok = np.empty(h, np.bool_)
    _compiled()["lirp_action"](np.ascontiguousarray(q, dtype=np.float64), _mono27(), C, ok)
    return C, ok


def lirp_post(q, lam, G):
    """The 18 unit candidate vecs ``(h, 18, 9)``, ``d_min (h, 2)`` and the mask of problems whose
    case-2 cubic must be redone in numpy, from ``q`` and the eigen-decompositions."""
    h = q.shape[0]
    cand = np.empty((h, 18, 9))
    dmin = np.empty((h, 2))
    need = np.empty(h, np.bool_)
    _compiled()["lirp_post"](np.ascontiguousarray(q, dtype=np.float64), np.ascontiguousarray(lam, dtype=np.complex128),
                             np.ascontiguousarray(G, dtype=np.complex128), cand, dmin, need)
    return cand, dmin, need


def qr_r9(A):
    """Triangular factors ``(h, 9, 9)`` of the QR of stacked ``A (h, n, 9)``, ``n > 9``: a compiled
    Householder QR up to 64 rows (equal to LAPACK's to ~1e-15), LAPACK's ``dgeqrf`` above (the bits of
    ``numpy.linalg.qr(A, mode="r")``), both without numpy's per-call overhead."""
    A = np.ascontiguousarray(A, dtype=np.float64)
    R = np.empty((A.shape[0], 9, 9))
    _compiled()["qr_r9"](A, R)
    return R


def svd9(R):
    """Singular values ``(h, 9)`` (descending) and right singular vectors as rows ``(h, 9, 9)`` of
    stacked 9x9 matrices by one-sided Jacobi (LiRP's null space)."""
    R = np.ascontiguousarray(R, dtype=np.float64)
    h = R.shape[0]
    s = np.empty((h, 9))
    Vt = np.empty((h, 9, 9))
    _compiled()["svd9"](R, s, Vt)
    return s, Vt


def kron_rows(f1, f2):
    """Rows ``kron(f1_i, f2_i)`` ``(h, n, 9)`` of stacked bearings (numpy's broadcast product runs an
    inner loop of length 3 and is ~10x slower at n = 3000; same products, same bits)."""
    f1 = np.ascontiguousarray(f1, dtype=np.float64)
    A = np.empty(f1.shape[:-1] + (9,))
    _compiled()["kron"](f1, np.ascontiguousarray(f2, dtype=np.float64), A)
    return A


def eig6(C, sep_tol=1e-6):
    """Eigenvalues and unit eigenvectors of stacked 6x6 matrices ``C (h, m, 6, 6)`` (Francis QR and
    inverse iteration); problems where it fails or eigenvalues nearly coincide are redone with
    ``numpy.linalg.eig`` (LAPACK). Returns ``lam (h, m, 6)``, ``G (h, m, 6, 6)`` complex."""
    h, m = C.shape[:2]
    lam = np.empty((h, m, 6), np.complex128)
    G = np.empty((h, m, 6, 6), np.complex128)
    fail = np.empty(h, np.bool_)
    _compiled()["eig6"](np.ascontiguousarray(C, dtype=np.float64), lam, G, fail, float(sep_tol))
    if fail.any():
        lf, Gf = np.linalg.eig(C[fail])
        lam[fail] = lf
        G[fail] = Gf
    return lam, G


_RESIDUAL_KIND = {"ligt": 0, "sampson": 1, "sampson-chiral": 2}


def residual(kind, R, t, f1, f2):
    """Compiled ``v_LiGT`` / ``v_sampson`` / ``v_sampson_chiral`` for ``R (k, 3, 3)`` or ``(3, 3)``,
    ``t`` to match, and points ``(n, 3)`` shared by all poses or ``(k, n, 3)``; also ``R (h, k, 3, 3)``
    with points ``(h, 1, n, 3)`` (``k`` candidates per problem, GNC-IRLS with multi-candidate
    solvers). ``None`` for other shapes (use numpy)."""
    R = np.asarray(R, dtype=np.float64)
    t = np.asarray(t, dtype=np.float64)
    f1 = np.asarray(f1, dtype=np.float64)
    f2 = np.asarray(f2, dtype=np.float64)
    if R.ndim == 4:
        h, k = R.shape[:2]
        if t.shape != (h, k, 3) or f1.shape != f2.shape or f1.ndim != 4 or f1.shape[:2] != (h, 1) or f1.shape[-1] != 3:
            return None
        n = f1.shape[2]
        if h == 1:
            F1, F2 = f1[0], f2[0]
        else:
            F1 = np.repeat(f1, k, axis=1).reshape(h * k, n, 3)
            F2 = np.repeat(f2, k, axis=1).reshape(h * k, n, 3)
        out = np.empty((h * k, n))
        _compiled()["residual"](np.ascontiguousarray(R.reshape(h * k, 3, 3)), np.ascontiguousarray(t.reshape(h * k, 3)),
                                np.ascontiguousarray(F1), np.ascontiguousarray(F2), _RESIDUAL_KIND[kind], out)
        return out.reshape(h, k, n)
    single = R.ndim == 2
    if single:
        R, t = R[None], t[None]
    if R.ndim != 3 or t.shape != (len(R), 3) or f1.shape != f2.shape or f1.shape[-1] != 3:
        return None
    k = len(R)
    if f1.ndim == 2:
        F1, F2 = f1[None], f2[None]
    elif f1.ndim == 3 and len(f1) == k and not single:
        F1, F2 = f1, f2
    else:
        return None
    out = np.empty((k, F1.shape[1]))
    _compiled()["residual"](np.ascontiguousarray(R), np.ascontiguousarray(t), np.ascontiguousarray(F1),
                            np.ascontiguousarray(F2), _RESIDUAL_KIND[kind], out)
    return out[0] if single else out


_FIVEPT_TABLES = None


_SCORE_MODE = {"count": 0, "msac": 1, "msac-multi": 2}


def ransac_score(kind, R, t, f1, f2, thr: float, scoring: str):
    """Scores ``(k,)`` of :func:`poseonly.robust.ransac._score` for the residual ``kind`` (``"sampson"``,
    ``"ligt"``, ``"sampson-chiral"``) of poses ``R (k, 3, 3)``, ``t (k, 3)`` on shared points ``(n, 3)``,
    without the ``(k, n)`` residual array (bit-identical)."""
    mode = _SCORE_MODE[scoring]
    if mode == 2:
        thr2 = np.array([(f * thr) ** 2 for f in (1.0, 0.5, 0.25)])
    else:
        thr2 = np.array([thr * thr])
    out = np.empty(len(R))
    _compiled()["score"](np.ascontiguousarray(R, dtype=np.float64), np.ascontiguousarray(t, dtype=np.float64),
                         np.ascontiguousarray(f1, dtype=np.float64), np.ascontiguousarray(f2, dtype=np.float64),
                         _RESIDUAL_KIND[kind], mode, float(thr), thr2, out)
    return out


def fivept_real(f1, f2):
    """Real five-point solutions of minimal samples ``f1, f2 (h, 5, 3)``: ``E (h, 10, 3, 3)`` (unit
    Frobenius norm, filled from slot 0), ``mask (h, 10)`` and ``fail (h,)`` (redo with numpy)."""
    global _FIVEPT_TABLES
    if _FIVEPT_TABLES is None:
        from .solvers import fivept as F5

        mono = np.argmax(F5._G20.reshape(64, 20), axis=1).astype(np.int64)
        unit_cols = np.argmax(F5._UNIT, axis=1).astype(np.int64)
        _FIVEPT_TABLES = (mono, unit_cols, np.asarray(F5._ACTION_ROWS, dtype=np.int64), float(F5.REAL_TOL))
    mono, unit_cols, rows, tol = _FIVEPT_TABLES
    h = f1.shape[0]
    E = np.empty((h, 10, 3, 3))
    mask = np.empty((h, 10), np.bool_)
    fail = np.empty(h, np.bool_)
    _compiled()["fivept"](np.ascontiguousarray(f1, dtype=np.float64), np.ascontiguousarray(f2, dtype=np.float64),
                          mono, unit_cols, rows, tol, E, mask, fail)
    return E, mask, fail


def ligt_normal(R, t, Jl, Jt, f1, f2, sw, norm: int, loss: int, scale: float, want: bool):
    """Compiled LiGTopt cost (and normal equations ``H (5, 5)``, ``g (5,)`` when ``want``)."""
    H = np.empty((5, 5))
    g = np.empty(5)
    c = _compiled()["ligt_normal"](
        np.ascontiguousarray(R, dtype=np.float64), np.ascontiguousarray(t, dtype=np.float64),
        np.ascontiguousarray(Jl, dtype=np.float64), np.ascontiguousarray(Jt, dtype=np.float64),
        np.ascontiguousarray(f1, dtype=np.float64), np.ascontiguousarray(f2, dtype=np.float64),
        np.ascontiguousarray(sw, dtype=np.float64), int(norm), int(loss), float(scale), bool(want), H, g,
    )
    return float(c), H, g


_GNC_RESIDUAL_KIND = {"v_LiGT": 0, "v_sampson": 1, "v_sampson_chiral": 2}


def gnc_lirp(f1, f2, w0, opts, period: int, min_sample: int, multi: bool = False, residual: str = "v_LiGT"):
    """Compiled GNC-IRLS with LiRP (``_kernels_nb.gnc_lirp_nb``) on ``f1, f2 (h, n, 3)`` from weights
    ``w0 (h, n)`` with :class:`poseonly.robust.gnc.GNCOptions` ``opts``; ``multi``: all candidates
    (``lirp_all_solver``) instead of the identified one; ``residual``: ``v_LiGT``, ``v_sampson`` or
    ``v_sampson_chiral`` (by function name). Returns
    ``R, t, weights, residuals, c, num_iterations, converged`` and ``redo (h,)``: problems that need
    the lockstep path (their outputs are undefined)."""
    h, n = f1.shape[:2]
    R = np.empty((h, 3, 3))
    t = np.empty((h, 3))
    w = np.empty((h, n))
    v = np.empty((h, n))
    c = np.empty(h)
    it = np.empty(h, np.int64)
    conv = np.empty(h, np.bool_)
    status = np.empty(h, np.int64)
    if isinstance(opts.scale, str):
        kind, sval = (0 if opts.scale == "median" else 1), 0.0
    else:
        kind, sval = 2, float(opts.scale)
    _compiled()["gnc_lirp"](
        np.ascontiguousarray(f1, dtype=np.float64), np.ascontiguousarray(f2, dtype=np.float64),
        np.ascontiguousarray(w0, dtype=np.float64), opts.schedule == "ms-tls", kind, sval, float(opts.c_factor),
        -1.0 if opts.noise_bound is None else float(opts.noise_bound), int(opts.max_iterations), float(opts.eps0),
        float(opts.sigma_floor), float(opts.mu_factor), -1.0 if opts.mu0 is None else float(opts.mu0), int(period),
        int(min_sample), _mono27(), R, t, w, v, c, it, conv, status, bool(multi), _GNC_RESIDUAL_KIND[residual])
    return R, t, w, v, c, it, conv, status != 0
