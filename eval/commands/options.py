"""The options several ``python -m eval`` subcommands share, and their checks: ``--workers``,
``--video``, ``--backend``/``--address``, ``--baselines``, and one paper's ``--experiments`` and
``--seeds``."""

from __future__ import annotations

import argparse
import os
from typing import Any

from agents.policies import BASELINES
from soft_gym._cli import HelpFormatter, fail, positive_int, seed_int
from soft_gym._validation import SEED_MAX

DEFAULT_WORKERS = max(1, min(2, os.cpu_count() or 1))
"""``--workers``' default: one process per core, at most 2."""


def add_video_flag(parser: argparse.ArgumentParser) -> None:
    """``--video``: an MP4 of each run beside its CSV."""
    parser.add_argument("--video", action="store_true",
                        help="also write an MP4 of each run next to its CSV (a GIF without "
                             "ffmpeg)")


def check_baselines(parser: argparse.ArgumentParser, baselines: list[str],
                    check_agent=None) -> None:
    """``--baselines``: known baseline names or ``sb3:PATH``, before any work; ``check_agent``
    (the experiment module's ``check_baselines``) then tries each on the experiment's env."""
    unknown = [name for name in baselines
               if name not in BASELINES and not (name.startswith("sb3:") and len(name) > 4)]
    if unknown:
        parser.error(f"--baselines must be names from {sorted(BASELINES)} or sb3:PATH, "
                     f"got {unknown}")
    if check_agent is not None:
        try:
            check_agent(tuple(baselines))
        except ValueError as error:
            fail(parser, "--baselines", error)


def paper_parser(sub, name: str, module, help_text: str,
                 seeds_help: str) -> argparse.ArgumentParser:
    """The subcommand of one paper's experiments: ``--experiments`` among the module's
    ``EXPERIMENTS`` (default all) and ``--seeds``; its description is the module's docstring."""
    paper = sub.add_parser(name, help=help_text, description=module.__doc__,
                           formatter_class=HelpFormatter)
    default = list(getattr(module, "DEFAULT_EXPERIMENTS", module.EXPERIMENTS))
    paper.add_argument("--experiments", nargs="+", default=default,
                       choices=list(module.EXPERIMENTS),
                       help="which experiments (default: " + " ".join(default) + ")")
    paper.add_argument("--seeds", type=seed_int, nargs="+", default=[0],
                       help=f"{seeds_help}; integers in [0, {SEED_MAX}]")
    return paper


def add_workers(parser: argparse.ArgumentParser) -> None:
    """``--workers``: runs in parallel processes (default :data:`DEFAULT_WORKERS`)."""
    parser.add_argument("--workers", type=positive_int, default=DEFAULT_WORKERS,
                        help="runs in parallel processes, >= 1 (up to 2 helps, one per core)")


def add_backend(parser: argparse.ArgumentParser, choices: list[str], what: str) -> None:
    """``--backend`` (``choices``, the first the default; ``what`` says what they run) and its
    ``--address``."""
    parser.add_argument("--backend", default=choices[0], choices=choices,
                        help=f"{what} (a local Ray or --address; extra: soft-arm-gym[ray])")
    parser.add_argument("--address", default=None, metavar="ADDR",
                        help="with --backend ray: an existing Ray cluster (auto, "
                             "ray://host:10001, host:6379); the package must be importable on "
                             "every node. Default: a local Ray")


def ray_backend(parser: argparse.ArgumentParser, args: argparse.Namespace,
                ray_module: str) -> Any:
    """The backend of ``--backend`` and ``--address`` (checked, a parser error otherwise): the
    name given, or with ``ray`` the map of ``make_ray_map(--address)`` of ``ray_module`` (the
    Ray backend's module, imported only then: Ray is an optional extra)."""
    if args.address is not None and args.backend != "ray":
        parser.error(f"--address is the Ray cluster of --backend ray, got --backend "
                     f"{args.backend}")
    if args.address is not None and not args.address.strip():
        parser.error("--address must be a Ray address (auto, ray://host:10001, host:6379), "
                     "got ''")
    if args.backend != "ray":
        return args.backend
    from importlib import import_module

    module = import_module(ray_module)
    try:
        module.require_ray()
    except ImportError as error:
        parser.error(f"--backend ray: {error}")
    return module.make_ray_map(args.address)
