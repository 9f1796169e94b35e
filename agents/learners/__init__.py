"""Online learners of the baselines: sliding-window GP regression (wang2023 Section III-B)."""

from agents.learners.lwpr import LWPR
from agents.learners.sliding_gp import SlidingWindowGP, cholesky_rank1_update

__all__ = ["LWPR", "SlidingWindowGP", "cholesky_rank1_update"]
