"""poseonly: robust two-view relative pose founded on pose-only imaging geometry.

Convention: ``X2 = R X1 + t`` (camera 1 -> camera 2), ``E = [t]x R``, ``f2^T E f1 = 0``, unit ``t``.
"""

from .api import DEFAULT_METHOD, METHODS, RelativePoseResult, estimate_relative_pose, gnc_irls, gnc_ransac, lirp
from .batch import estimate_relative_poses
from .geometry import InputError, rotation_error_deg, translation_error_deg
from .residuals import v_BA, v_E, v_LiGT, v_OpenGV, v_PPO
from .solvers.lirp import LiRPResult

__version__ = "0.1.0"

__all__ = [
    "estimate_relative_pose",
    "estimate_relative_poses",
    "RelativePoseResult",
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
