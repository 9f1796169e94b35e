"""zhao2021's evaluation: the shape-sensing and control experiments (``experiments``; Table II in
``table2``), the claims (``claims``) and the exploration dataset (``dataset``)."""

from eval.papers.zhao2021.claims import CLAIMS, EXPERIMENTS
from eval.papers.zhao2021.dataset import DATASET
import eval.papers.zhao2021.command as _command
from eval.commands import Command

COMMANDS = {"zhao2021": Command(_command.add_parser, _command.run)}
"""Its subcommand, ``python -m eval zhao2021``."""

__all__ = ["CLAIMS", "COMMANDS", "DATASET", "EXPERIMENTS"]
