"""Robust loops of the compiled core (``src/core/ransac.h``, ``gnc.cpp``) and their option/result types."""

from .generic import GenericRansacResult, RansacEstimator
from .generic import ransac as ransac_generic
from .gnc import GNCBatchResult, GNCOptions, GNCResult, gnc_irls_batch
from .ransac import RansacResult, gnc_ransac, ransac_relpose, sample_indices

__all__ = [
    "GNCOptions",
    "GNCBatchResult",
    "GNCResult",
    "gnc_irls_batch",
    "RansacResult",
    "ransac_relpose",
    "gnc_ransac",
    "sample_indices",
    "ransac_generic",
    "RansacEstimator",
    "GenericRansacResult",
]
