"""ho2018's evaluation: the online-learning experiments (``experiments``: Tables 1-2), the factor
study (``factors``), the claims (``claims``) and the pre-training dataset (``dataset``)."""

from eval.papers.ho2018.claims import CLAIMS, EXPERIMENTS
from eval.papers.ho2018.dataset import DATASET

__all__ = ["CLAIMS", "DATASET", "EXPERIMENTS"]
