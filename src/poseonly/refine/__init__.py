"""Nonlinear two-view refinement and the comparison methods of the paper's experiments.

* :func:`ligt_refine` -- LiGTopt (Section 4 after Eq. 8), least-squares form, optional robust loss;
* :func:`ligt_translation` -- LiGT translation for a fixed rotation (smallest eigenvector);
* :func:`eigensolver` -- Kneip & Lynen 2013 eigensolver (OpenGV ``eigensolver``);
* :func:`opengv_nonlinear` -- OpenGV ``optimize_nonlinear`` (midpoint-triangulation residual);
* :func:`bundle_adjust` -- two-view bundle adjustment (pose + 3-D points, sparse Jacobian);
* :func:`npt` -- Zhao 2020 N-point SDP (needs ``cvxpy``: ``pip install poseonly[sdp]``).

All use ``X2 = R X1 + t``, ``E = [t]x R``, unit bearings ``f1, f2 (n, 3)`` and return a unit ``t``.
The refiners optimise ``R = exp([w]x) R0`` and ``t = normalize(t0 + B v)`` (5 parameters,
:mod:`poseonly.refine._manifold`) and return a :class:`RefineResult`.
"""

from ._common import RefineResult
from ._manifold import PoseChart, left_jacobian_so3, tangent_basis
from .ba import bundle_adjust
from .eigensolver import eigensolver
from .ligt import ligt_refine, ligt_translation
from .nonlinear import opengv_nonlinear
from .npt import npt

__all__ = [
    "RefineResult",
    "ligt_refine",
    "ligt_translation",
    "eigensolver",
    "opengv_nonlinear",
    "bundle_adjust",
    "npt",
    "PoseChart",
    "tangent_basis",
    "left_jacobian_so3",
]
