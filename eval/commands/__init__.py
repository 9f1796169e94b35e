"""The subcommands of ``python -m eval``, one module each: ``add_parser(subparsers)`` adds and
returns the subcommand's parser, ``run(parser, args)`` checks what the parser cannot and does the
work (a :class:`Command`). :func:`eval.__main__.commands` lists them in the order ``--help``
shows them.

* :mod:`.track`, :mod:`.compare`, :mod:`.claims`, :mod:`.suite`, :mod:`.datasets`: the
  subcommands of no paper in particular (and :mod:`eval.results_page`, ``results``);
* each paper's own come from its evaluation folder's ``COMMANDS`` (``eval/papers/<key>/``:
  wang2023's ``benchmark`` and ``estimation``, ``zhao2021``, ``zou2022``, ``ho2018``);
* :mod:`.options`: the options several subcommands share and their checks.
"""

from __future__ import annotations

import argparse
from collections.abc import Callable
from typing import Any, NamedTuple


class Command(NamedTuple):
    """One subcommand: ``add_parser(subparsers)`` adds and returns its parser; ``run(parser,
    args)`` checks what the parser cannot and does the work (``parser.error`` for one-line
    errors)."""

    add_parser: Callable[[Any], argparse.ArgumentParser]
    run: Callable[[argparse.ArgumentParser, argparse.Namespace], None]


__all__ = ["Command"]
