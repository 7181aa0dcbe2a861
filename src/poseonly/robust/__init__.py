"""Robust loops, generic over :class:`poseonly.estimator.Estimator`."""

from .gnc import GNCBatchResult, GNCOptions, gnc_irls_batch, tls_weights
from .ransac import RansacResult, adaptive_iterations, gnc_ransac, ransac, sample_indices

__all__ = [
    "GNCOptions",
    "GNCBatchResult",
    "gnc_irls_batch",
    "tls_weights",
    "RansacResult",
    "ransac",
    "gnc_ransac",
    "sample_indices",
    "adaptive_iterations",
]
