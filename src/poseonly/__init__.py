"""poseonly: robust two-view relative pose founded on pose-only imaging geometry.

Convention: ``X2 = R X1 + t`` (camera 1 -> camera 2), ``E = [t]x R``, ``f2^T E f1 = 0``, unit ``t``.
"""

from typing import TYPE_CHECKING, Any

from . import _build  # noqa: F401  (first: a checkout's core must be built from its sources, _build.py)
from .api import DEFAULT_METHOD, METHODS, RelativePoseResult, estimate_relative_pose, gnc_irls, gnc_ransac, lirp
from .batch import Pair, PairResult, estimate_relative_poses
from .geometry import InputError, rotation_error_deg, translation_error_deg
from .residuals import v_BA, v_E, v_LiGT, v_OpenGV, v_PPO
from .result import STATUSES, NoPoseError, Status
from .solvers.lirp import LiRPResult

__version__ = "0.1.0"

# the submodules the docs name, importable as attributes of the package (``poseonly.cameras.from_opencv``
# after ``import poseonly``), each on first use: the front-end (OpenCV) and the SfM pipeline stay out
# of a plain import's time
_LAZY_SUBMODULES = frozenset(
    {
        "analysis",
        "batch",
        "cameras",
        "cli",
        "colmap_verify",
        "estimator",
        "experiments",
        "features",
        "geometry",
        "io",
        "options",
        "pipeline",
        "refine",
        "residuals",
        "result",
        "robust",
        "sfm",
        "sim",
        "sim_hard",
        "solvers",
        "twin",
    }
)


if TYPE_CHECKING:  # the type checker sees the submodules themselves (a misspelt name stays an error)
    from . import (  # noqa: F401
        analysis,
        batch,
        cameras,
        cli,
        colmap_verify,
        estimator,
        experiments,
        features,
        geometry,
        io,
        options,
        pipeline,
        refine,
        residuals,
        result,
        robust,
        sfm,
        sim,
        sim_hard,
        solvers,
        twin,
    )
else:

    def __getattr__(name: str) -> Any:
        if name in _LAZY_SUBMODULES:
            import importlib

            return importlib.import_module(f"{__name__}.{name}")
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


__all__ = [
    "estimate_relative_pose",
    "estimate_relative_poses",
    "RelativePoseResult",
    "Status",
    "STATUSES",
    "NoPoseError",
    "Pair",
    "PairResult",
    "gnc_irls",
    "gnc_ransac",
    "METHODS",
    "DEFAULT_METHOD",
    "InputError",
    "lirp",
    "LiRPResult",
    "v_E",
    "v_BA",
    "v_OpenGV",
    "v_LiGT",
    "v_PPO",
    "rotation_error_deg",
    "translation_error_deg",
]
