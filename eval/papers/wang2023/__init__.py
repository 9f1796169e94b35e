"""wang2023's evaluation: the estimation experiments (``estimation``: Figs. 5-10, Tables I-VI's
estimation side), the claims (``claims``) and the calibration dataset (``dataset``)."""

from eval.papers.wang2023.claims import CLAIMS, EXPERIMENTS
from eval.papers.wang2023.dataset import DATASET
import eval.papers.wang2023.benchmark_command as _benchmark
import eval.papers.wang2023.estimation_command as _estimation
from eval.commands import Command

COMMANDS = {"benchmark": Command(_benchmark.add_parser, _benchmark.run),
            "estimation": Command(_estimation.add_parser, _estimation.run)}
"""Its subcommands, ``python -m eval benchmark`` and ``python -m eval estimation``."""

__all__ = ["CLAIMS", "COMMANDS", "DATASET", "EXPERIMENTS"]
