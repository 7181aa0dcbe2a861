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
* :func:`fivept_real` -- the Stewenius five-point solver on minimal samples returning the real
  solutions only (:mod:`poseonly.solvers.fivept`): 10x10 action matrix reduced to Hessenberg form
  and its real eigenvalues found by the Francis double-shift QR, eigenvectors by a 9x9 solve,
  instead of LAPACK's ``dgeev`` with all ten complex eigenvectors (~30 us per sample).
"""

from __future__ import annotations

import os
from contextlib import contextmanager

import numpy as np

__all__ = ["available", "enabled", "use", "rank_candidates", "lirp_action", "lirp_post", "fivept_real"]

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
    return _impl


def rank_candidates(E, f1, f2, w, with_cost=True):
    """Compiled :func:`poseonly.identify._rank_numpy` on flat ``E (H,k,3,3)``, ``f (H,n,3)``, ``w (H,n) | None``."""
    H, k = E.shape[:2]
    n = f1.shape[1]
    R = np.empty((H, k, 3, 3))
    t = np.empty((H, k, 3))
    valid = np.empty((H, k), np.bool_)
    M1 = np.empty((H, k))
    cost = np.empty((H, k))
    ww = np.empty((H, n)) if w is None else np.ascontiguousarray(w, dtype=np.float64)
    _compiled()["rank"](np.ascontiguousarray(E, dtype=np.float64), np.ascontiguousarray(f1, dtype=np.float64),
                        np.ascontiguousarray(f2, dtype=np.float64), ww, w is not None, bool(with_cost), R, t, valid, M1, cost)
    return R, t, valid, M1, (cost if with_cost else None)


_MONO27 = None


def lirp_action(q):
    """Action matrices ``C (h, 2, 6, 6)`` and ``ok (h,)`` from the null-space bases ``q (h, 3, 9)``."""
    global _MONO27
    if _MONO27 is None:
        from .solvers.lirp import _G

        _MONO27 = np.argmax(_G.reshape(27, 10), axis=1).astype(np.int64)
    h = q.shape[0]
    C = np.empty((h, 2, 6, 6))
    ok = np.empty(h, np.bool_)
    _compiled()["lirp_action"](np.ascontiguousarray(q, dtype=np.float64), _MONO27, C, ok)
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


_FIVEPT_TABLES = None


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
