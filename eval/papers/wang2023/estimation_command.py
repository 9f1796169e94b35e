"""``python -m eval estimation``: wang2023's estimation experiments
(:mod:`eval.papers.wang2023.estimation`)."""

from __future__ import annotations

import argparse

from eval.commands.options import add_video_flag
import eval.papers.wang2023.estimation as estimation_module
from eval.papers.wang2023.estimation import EXPERIMENTS, run_experiments
from eval.report import markdown_table
from soft_gym._cli import HelpFormatter, seed_int


def add_parser(sub) -> argparse.ArgumentParser:
    """The ``estimation`` subcommand's parser."""
    estimation = sub.add_parser("estimation", help="wang2023 estimation experiments",
                                description=estimation_module.__doc__,
                                formatter_class=HelpFormatter)
    estimation.add_argument("--experiments", nargs="+", default=["clean"],
                            choices=list(EXPERIMENTS) + ["all"],
                            help="which runs ('all' for every one)")
    estimation.add_argument("--steps", type=int, default=4000,
                            help="control steps of 0.05 s per run, >= 600 (paper: ~4000)")
    estimation.add_argument("--seed", type=seed_int, default=0,
                            help="episode seed (integer >= 0)")
    estimation.add_argument("--out", default="results/estimation",
                            help="output directory (made; must be writable)")
    add_video_flag(estimation)
    return estimation


def run(parser: argparse.ArgumentParser, args: argparse.Namespace) -> None:
    """``estimation``: the chosen experiments, then their table."""
    if args.steps < 600:
        parser.error(f"--steps must be >= 600 (the F-emp calibration alone takes 450), "
                     f"got {args.steps}")
    experiments = list(EXPERIMENTS) if "all" in args.experiments else args.experiments
    rows = run_experiments(experiments, args.out, steps=args.steps, seed=args.seed,
                           **({"video": True} if args.video else {}))
    print(markdown_table(rows, float_format="{:.2f}"))
    print(f"output directory: {args.out}")
