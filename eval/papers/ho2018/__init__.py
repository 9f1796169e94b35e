"""ho2018's evaluation: the online-learning experiments (``experiments``: Tables 1-2), the factor
study (``factors``), the claims (``claims``) and the pre-training dataset (``dataset``)."""

from eval.papers.ho2018.claims import CLAIMS, EXPERIMENTS
from eval.papers.ho2018.dataset import DATASET
import eval.papers.ho2018.command as _command
from eval.commands import Command

COMMANDS = {"ho2018": Command(_command.add_parser, _command.run)}
"""Its subcommand, ``python -m eval ho2018``."""

__all__ = ["CLAIMS", "COMMANDS", "DATASET", "EXPERIMENTS"]
