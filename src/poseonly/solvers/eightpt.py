"""Linear eight-point essential-matrix solver (Longuet-Higgins 1981; Hartley & Zisserman Alg. 11.1).

For unit bearing vectors the system ``A vec(E) = 0`` (rows ``w_i kron(f1_i, f2_i)``, see
:mod:`poseonly.solvers.common`) is already well scaled, so Hartley's isotropic normalisation (a
remedy for pixel coordinates of order 1e2-1e3) is not applied. Steps:

1. ``e`` = right singular vector of the smallest singular value of ``A`` (``n >= 8``; the exact
   null vector for ``n = 8`` general points, the least-squares one for ``n > 8``);
2. :func:`eightpt`: project ``mat(e)`` onto the essential manifold, singular values ``(1, 1, 0)``
   (H&Z Sec. 11.7.3); :func:`eightpt_opengv`: only zero the smallest singular value, as OpenGV's
   ``relative_pose::eightpt`` does (notes sec. 10: the two largest are not equalised).

Both return one candidate; the pose follows from :func:`poseonly.solvers.common.pose_from_essentials`
(the decomposition uses ``U, V`` only, so the two variants give the same pose).

Degeneracy: for a planar scene ``rank(A) = 6`` and the null space is 3-D; the smallest singular
vector is then an arbitrary member of it and the pose is generally wrong (H&Z Sec. 11.9).
"""

from __future__ import annotations

import numpy as np

from .common import epipolar_rows, prepare, project_essential, right_singular, vec_to_mat

__all__ = ["eightpt", "eightpt_opengv", "eightpt_batch"]

MIN_POINTS = 8


def eightpt_batch(f1: np.ndarray, f2: np.ndarray, w: np.ndarray | None = None, *, variant: str = "essential") -> dict:
    """Eight-point on stacked problems ``f1, f2 (h, n, 3)``, ``w (h, n)``; no validation.

    Returns ``E (h, 1, 3, 3)`` (unit Frobenius norm), ``mask (h, 1)`` (all True) and
    ``singular_values (h, 9)`` of ``A``. ``variant="essential"`` projects to singular values
    ``(1, 1, 0)``; ``variant="opengv"`` zeroes the smallest one only.
    """
    s, Vt = right_singular(epipolar_rows(f1, f2, w))
    F = vec_to_mat(Vt[:, 8])
    if variant == "essential":
        E = project_essential(F)
    elif variant == "opengv":
        U, d, Wt = np.linalg.svd(F)
        d = d * np.array([1.0, 1.0, 0.0])
        E = (U * d[:, None, :]) @ Wt
        E = E / np.linalg.norm(E, axis=(-2, -1), keepdims=True)
    else:
        raise ValueError(f"unknown variant {variant!r}; use 'essential' or 'opengv'")
    h = len(E)
    return {"E": E[:, None], "mask": np.ones((h, 1), bool), "singular_values": s}


def eightpt(f1: np.ndarray, f2: np.ndarray, w: np.ndarray | None = None, return_info: bool = False):
    """Linear 8-point solver for ``n >= 8`` bearings; returns candidates ``E (1, 3, 3)``.

    ``f1, f2``: ``(n, 3)`` bearings (or ``(n, 2)`` normalized coordinates) of views 1 and 2;
    ``w``: optional non-negative weights ``(n,)`` scaling the rows. The candidate has singular values
    ``(1, 1, 0) / sqrt(2)``. With ``return_info`` also returns ``{"singular_values": (9,)}``.
    Raises :class:`poseonly.geometry.InputError` (``ValueError``) for fewer than 8 points.
    """
    b1, b2, ww = prepare(f1, f2, w, MIN_POINTS)
    out = eightpt_batch(b1, b2, ww)
    E = out["E"][0]
    return (E, {"singular_values": out["singular_values"][0]}) if return_info else E


def eightpt_opengv(f1: np.ndarray, f2: np.ndarray, w: np.ndarray | None = None, return_info: bool = False):
    """OpenGV's ``eightpt``: LS null vector with only the smallest singular value set to 0; ``(1, 3, 3)``.

    The two largest singular values are kept unequal (OpenGV ``src/relative_pose/methods.cpp``, notes
    sec. 10); scaled to unit Frobenius norm. Same input rules as :func:`eightpt`.
    """
    b1, b2, ww = prepare(f1, f2, w, MIN_POINTS)
    out = eightpt_batch(b1, b2, ww, variant="opengv")
    E = out["E"][0]
    return (E, {"singular_values": out["singular_values"][0]}) if return_info else E
