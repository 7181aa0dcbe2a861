"""Solvers: pure functions from correspondences (and weights) to candidate models."""

from .lirp import LiRPResult, lirp, lirp_batch, lirp_candidates

__all__ = ["lirp", "lirp_batch", "lirp_candidates", "LiRPResult"]
