"""Per-correspondence residuals of Section 4 of the paper (and Sampson's), one table in the core.

Every residual is a :class:`Residual` ``(R, t, f1, f2) -> v`` with ``R (..., 3, 3)``, ``t (..., 3)``
and bearings ``f1, f2 (n, 3)`` (or stacked ``(..., n, 3)`` matching the poses' leading shape); it
returns ``v (..., n)``: one call scores ``k`` stacked hypotheses against all points in the compiled
core (:mod:`poseonly._core`, C++). ``t`` is normalised to unit length first, because v_LiGT, v_E and
v_PPO are homogeneous in ``t`` and a threshold only means something at a fixed scale (the paper does
not say; notes section 3).

| name | paper | definition (unit bearings, unit ``t``) |
|---|---|---|
| ``coplanar`` | v^E, Eq. 4 | ``|f2^T [t]x R f1|`` |
| ``ligt`` | v^LiGT, Eq. 8 | ``||L_i t|| = |c| |c . t|``, ``c = f2 x R f1`` |
| ``ppo`` | v^PPO, Eq. 7 | ``||normalize(|t x f2| R f1 + |f2 x R f1| t) - f2||`` |
| ``ba`` | v^BA | tangent-plane reprojection error of the midpoint (2 behind camera 2; see below) |
| ``opengv`` | v^OpenGV | ``1 - normalize(R X1 + t) . f2`` of the midpoint |
| ``opengv-symmetric`` | OpenGV's SAC score | both views' terms |
| ``sampson`` | (not in the paper) | first-order geometric epipolar error on the sphere (radians) |
| ``sampson-chiral`` | (ours) | ``sampson`` where both pose-only depths are positive, 1 elsewhere |

``ba`` differs from the paper's v^BA, the error in normalised image coordinates ``||eps / e3^T eps - x'||``:
the tangent plane at ``f2`` gives the same to first order near the optical axis and less off it (up to 18 %
less in a researcher's trial's scenes), and is defined for every bearing, beyond 90 deg too.

Convention: ``X2 = R X1 + t``, ``E = [t]x R``, ``f2^T E f1 = 0``. The numpy references are in
``tests/reference/residuals.py``; the tests compare them with the core to 1e-12.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from . import _core
from .geometry import ORTHO_TOL, InputError, as_real_array, normalize

__all__ = [
    "Residual",
    "CHIRAL_PENALTY",
    "RESIDUALS",
    "get_residual",
    "v_E",
    "v_BA",
    "v_OpenGV",
    "v_LiGT",
    "v_PPO",
    "v_sampson",
    "v_sampson_chiral",
    "ligt_depths",
]


def _one_pose(R: object, t: object, f1: object, f2: object) -> bool:
    """``R (3, 3)``, ``t (3,)``, ``f1, f2 (n, 3)``, all float64 ndarrays in C order."""
    for a, nd in ((R, 2), (t, 1), (f1, 2), (f2, 2)):
        if type(a) is not np.ndarray or a.ndim != nd or a.dtype != np.float64 or not a.flags.c_contiguous:
            return False
    return R.shape == (3, 3) and t.shape == (3,) and f1.shape[1] == 3 and f2.shape == f1.shape  # type: ignore[attr-defined]


def _checked_args(R: object, t: object, f1: object, f2: object) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """A residual's arguments as float arrays of the shapes it takes: ``R (..., 3, 3)``, ``t (..., 3)``,
    bearings ``f1, f2 (..., n, 3)`` with the same ``n``; :class:`InputError` naming the argument."""
    Ra, ta, g1, g2 = (as_real_array(a, name) for a, name in ((R, "R"), (t, "t"), (f1, "f1"), (f2, "f2")))
    if Ra.ndim < 2 or Ra.shape[-2:] != (3, 3):
        raise InputError(f"R must have shape (..., 3, 3), got {Ra.shape}")
    if ta.ndim < 1 or ta.shape[-1] != 3:
        raise InputError(f"t must have shape (..., 3), got {ta.shape}")
    for name, g in (("f1", g1), ("f2", g2)):
        if g.ndim < 2 or g.shape[-1] != 3:
            raise InputError(f"{name} must be bearing vectors of shape (..., n, 3), got {g.shape}")
    if g1.shape[-2] != g2.shape[-2]:
        raise InputError(f"f1 and f2 differ in length: {g1.shape[-2]} vs {g2.shape[-2]}")
    return Ra, ta, g1, g2


# |t| within these bounds is normalised directly (its square neither over- nor underflows)
T_NORM_SAFE = (1e-150, 1e150)


def _check_finite(R: np.ndarray, t: np.ndarray, f1: np.ndarray, f2: np.ndarray) -> None:
    for name, a in (("R", R), ("t", t), ("f1", f1), ("f2", f2)):
        if not np.isfinite(a).all():
            raise InputError(f"{name} contains NaN or inf values")


# a bearing's |f| may differ from 1 by this much (float32 storage); beyond it the residuals' values are
# wrong, not just scaled (bearings times 3 moved them 9x to 1e7x, v_OpenGV went negative: an adversarial trial)
BEARING_NORM_TOL = 1e-6


def _check_geometry(R: np.ndarray, t: np.ndarray, f1: np.ndarray, f2: np.ndarray) -> None:
    """The residuals' preconditions on finite input: unit bearings, rotations, translations of non-zero
    length (a zero ``t`` made every match fit; an arbitrary matrix was taken for a rotation)."""
    for name, f in (("f1", f1), ("f2", f2)):
        n2 = np.einsum("...i,...i->...", f, f)  # |f|^2: within 2 tol of 1 where |f| is within tol
        if n2.size and float(np.abs(n2 - 1.0).max()) > 2.0 * BEARING_NORM_TOL:
            lo, hi = np.sqrt(float(n2.min())), np.sqrt(float(n2.max()))
            raise InputError(f"{name} must be unit bearing vectors (|f| = 1; poseonly.geometry.as_bearings makes them), got norms from {lo:.6g} to {hi:.6g}")
    Rm = R.reshape(-1, 3, 3)
    ortho = np.abs(np.einsum("kji,kjl->kil", Rm, Rm) - np.eye(3)).max(axis=(1, 2))
    if np.any(ortho >= ORTHO_TOL) or np.any(np.linalg.det(Rm) <= 0):
        raise InputError("R must be rotation matrices (R^T R = I, det R = +1)")
    if np.any(np.max(np.abs(t), axis=-1) == 0):
        raise InputError("t must have non-zero length (a residual of the translation's direction; a zero t fits every match)")


@dataclass(frozen=True)
class Residual:
    """One residual of the core's table: its ``name`` and the core's ``code`` (its index in
    ``poseonly._core.RESIDUAL_KINDS``). Calling it evaluates ``(R, t, f1, f2) -> (..., n)``."""

    name: str
    code: int

    def __call__(self, R: np.ndarray, t: np.ndarray, f1: np.ndarray, f2: np.ndarray) -> np.ndarray:
        """The residual of each correspondence under each pose: ``R (..., 3, 3)``, ``t (..., 3)`` (any
        non-zero length; normalised), unit bearings ``f1, f2 (n, 3)`` or stacked ``(..., n, 3)`` ->
        ``(..., n)``, the leading axes of the poses and the point sets broadcast. :class:`InputError` for
        non-finite values, bearings whose norm is not 1, an ``R`` that is not a rotation and a zero ``t``
        (the library's own calls on input it validated use :meth:`unchecked`)."""
        if _one_pose(R, t, f1, f2):
            # one pose on one point set, already float64 and C-contiguous
            _check_finite(R, t, f1, f2)
            _check_geometry(R, t, f1, f2)
            return self._one(R, t, f1, f2)
        return self._stacked(R, t, f1, f2, True)

    def _stacked(self, R: object, t: object, f1: object, f2: object, checked: bool) -> np.ndarray:
        """Any shapes :meth:`__call__` takes; ``checked``: the values too (finite, unit bearings,
        rotations, non-zero t), else only the shapes (:meth:`unchecked`)."""
        R, t, f1, f2 = _checked_args(R, t, f1, f2)
        if checked:
            _check_finite(R, t, f1, f2)
            _check_geometry(R, t, f1, f2)
        m = np.max(np.abs(t), axis=-1, keepdims=True)
        t = normalize(np.where(m > 0, t / np.where(m > 0, m, 1.0), t))  # scaled first: any finite t
        lead = R.shape[:-2]
        if f1.ndim == 2 and f2.ndim == 2:
            Rk = np.ascontiguousarray(R.reshape(-1, 3, 3))
            tk = np.ascontiguousarray(np.broadcast_to(t, lead + (3,)).reshape(-1, 3))
            v = _core.residual_matrix(self.code, Rk, tk, np.ascontiguousarray(f1), np.ascontiguousarray(f2))
            return v.reshape(lead + (f1.shape[0],))
        # stacked point sets: one core call per leading index (poses broadcast against them)
        pl = np.broadcast_shapes(lead, f1.shape[:-2], f2.shape[:-2])
        n = f1.shape[-2]
        Rb = np.broadcast_to(R, pl + (3, 3)).reshape(-1, 3, 3)
        tb = np.broadcast_to(t, pl + (3,)).reshape(-1, 3)
        F1 = np.broadcast_to(f1, pl + (n, 3)).reshape(-1, n, 3)
        F2 = np.broadcast_to(f2, pl + (n, 3)).reshape(-1, n, 3)
        out = np.empty((len(Rb), n))
        for i in range(len(Rb)):
            out[i] = _core.residual_matrix(
                self.code, np.ascontiguousarray(Rb[i : i + 1]), np.ascontiguousarray(tb[i : i + 1]), np.ascontiguousarray(F1[i]), np.ascontiguousarray(F2[i])
            )[0]
        return out.reshape(pl + (n,))

    def _one(self, R: np.ndarray, t: np.ndarray, f1: np.ndarray, f2: np.ndarray) -> np.ndarray:
        """One pose on one point set, float64 and C-contiguous (``_one_pose``), unchecked: the core call
        with ``t`` normalised as :func:`normalize` does it, without its broadcasting."""
        a, b, c = float(t[0]), float(t[1]), float(t[2])  # Python floats: overflow without a warning
        tn = math.sqrt(a * a + b * b + c * c)
        if not T_NORM_SAFE[0] < tn < T_NORM_SAFE[1]:  # (scaled first where its square would over- or underflow)
            m = float(np.max(np.abs(t)))
            if m > 0:
                t = t / m
                tn = math.sqrt(t[0] * t[0] + t[1] * t[1] + t[2] * t[2])
        tk = t / tn if tn > 0 else t
        return _core.residual_matrix(self.code, R.reshape(1, 3, 3), tk.reshape(1, 3), f1, f2)[0]

    def unchecked(self, R: np.ndarray, t: np.ndarray, f1: np.ndarray, f2: np.ndarray) -> np.ndarray:
        """The residual for the library's own calls on bearings it validated: the values are not checked
        (a non-finite pose gives NaN residuals, a search's placeholder pose its residuals, instead of an
        :class:`InputError`), only the shapes; one float64 C-contiguous pose on one point set goes
        straight to the core."""
        if _one_pose(R, t, f1, f2):
            return self._one(R, t, f1, f2)
        return self._stacked(R, t, f1, f2, False)

    @property
    def __name__(self) -> str:  # residuals behave like the functions they replaced (reports, test ids)
        return self.name


RESIDUALS: dict[str, Residual] = {name: Residual(name, code) for code, name in enumerate(_core.RESIDUAL_KINDS)}
_ALIASES = {"e": "coplanar", "v_e": "coplanar", "v_ligt": "ligt", "v_ppo": "ppo", "v_ba": "ba", "v_opengv": "opengv", "reprojection": "ba", "v_sampson": "sampson"}

v_E = RESIDUALS["coplanar"]
v_LiGT = RESIDUALS["ligt"]
v_PPO = RESIDUALS["ppo"]
v_BA = RESIDUALS["ba"]
v_OpenGV = RESIDUALS["opengv"]
v_sampson = RESIDUALS["sampson"]
v_sampson_chiral = RESIDUALS["sampson-chiral"]
# what sampson-chiral gives a match behind either camera (src/core/residuals.h kChiralPenalty)
CHIRAL_PENALTY = 1.0


def get_residual(name: str | Residual) -> Residual:
    """Residual by name (``ligt``, ``ppo``, ``coplanar``, ``ba``, ``opengv``, ``opengv-symmetric``,
    ``sampson``, ``sampson-chiral``; aliases ``v_ligt`` ...) or a :class:`Residual` itself."""
    if isinstance(name, Residual):
        return name
    if not isinstance(name, str):
        raise ValueError(f"residual must be a name or a poseonly.residuals.Residual, got {type(name).__name__}")
    key = _ALIASES.get(name.lower(), name.lower())
    if key not in RESIDUALS:
        raise ValueError(f"unknown residual {name!r}; choose one of {sorted(RESIDUALS)}")
    return RESIDUALS[key]


def ligt_depths(R: np.ndarray, t: np.ndarray, f1: np.ndarray, f2: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Pose-only depth numerators ``h_i^T t``, ``h'_i^T t`` and ``theta_i^2`` (the equation after Eq. 7).

    ``h_i^T t = (R f1 x f2) . (f2 x t)`` and ``h'_i^T t = (R f1 x f2) . (R f1 x t)``; the depths are
    ``z1 = h^T t / theta^2`` and ``z2 = h'^T t / theta^2`` with ``theta = ||f2 x R f1||`` (unit ``t``).
    Shapes as the residuals: ``(..., n)`` each. Not a hot path (analysis and refinement set-up).
    """
    tt = normalize(np.asarray(t, dtype=float))[..., None, :]
    Rf1 = np.einsum("...ij,...nj->...ni", np.asarray(R, dtype=float), f1)
    c = np.cross(Rf1, f2)
    h = np.sum(c * np.cross(f2, tt), axis=-1)
    hp = np.sum(c * np.cross(Rf1, tt), axis=-1)
    return h, hp, np.sum(c * c, axis=-1)
