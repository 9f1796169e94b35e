"""zou2022's evaluation: the shape-estimation experiments (``experiments``), the closed-loop
comparison (``control``), the levers study (``levers``), the claims (``claims``) and the
ASES-labelled dataset (``dataset``)."""

from eval.papers.zou2022.claims import CLAIMS, EXPERIMENTS
from eval.papers.zou2022.dataset import DATASET
import eval.papers.zou2022.command as _command
from eval.commands import Command

COMMANDS = {"zou2022": Command(_command.add_parser, _command.run)}
"""Its subcommand, ``python -m eval zou2022``."""

__all__ = ["CLAIMS", "COMMANDS", "DATASET", "EXPERIMENTS"]
