"""wang2023's evaluation: the estimation experiments (``estimation``: Figs. 5-10, Tables I-VI's
estimation side), the claims (``claims``) and the calibration dataset (``dataset``)."""

from eval.papers.wang2023.claims import CLAIMS, EXPERIMENTS
from eval.papers.wang2023.dataset import DATASET

__all__ = ["CLAIMS", "DATASET", "EXPERIMENTS"]
