"""zou2022's evaluation: the shape-estimation experiments (``experiments``), the closed-loop
comparison (``control``), the levers study (``levers``), the claims (``claims``) and the
ASES-labelled dataset (``dataset``)."""

from eval.papers.zou2022.claims import CLAIMS, EXPERIMENTS
from eval.papers.zou2022.dataset import DATASET

__all__ = ["CLAIMS", "DATASET", "EXPERIMENTS"]
