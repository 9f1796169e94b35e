"""The help formatter every command line of the repository uses (``python -m eval``,
``python -m train``, ``python -m train.ship``, ``python -m soft_gym.demo``, ``bench/*.py``)."""

from __future__ import annotations

import argparse


class HelpFormatter(argparse.RawDescriptionHelpFormatter, argparse.ArgumentDefaultsHelpFormatter):
    """Keeps the description's line breaks (a module docstring with its examples) and appends
    each option's default to its help, ``(default: ...)``.

    Options whose default is ``None`` (their help says what leaving them out means) and flags
    (``store_true`` and the like, which take no value) get no default appended.
    """

    def _get_help_string(self, action: argparse.Action) -> str | None:
        if action.default is None or action.nargs == 0:
            return action.help
        return super()._get_help_string(action)
