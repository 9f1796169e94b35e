"""zhao2021's evaluation: the shape-sensing and control experiments (``experiments``; Table II in
``table2``), the claims (``claims``) and the exploration dataset (``dataset``)."""

from eval.papers.zhao2021.claims import CLAIMS, EXPERIMENTS
from eval.papers.zhao2021.dataset import DATASET

__all__ = ["CLAIMS", "DATASET", "EXPERIMENTS"]
