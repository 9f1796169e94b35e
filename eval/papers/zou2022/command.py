"""``python -m eval zou2022``: zou2022's shape estimation and control experiments
(:mod:`eval.papers.zou2022.experiments`, :mod:`eval.papers.zou2022.levers`)."""

from __future__ import annotations

import argparse

from eval.commands.options import paper_parser
import eval.papers.zou2022.experiments as zou2022_module
import eval.papers.zou2022.levers as zou2022_levers
from soft_gym._cli import int_at_least, positive_int
from soft_gym.papers.zou2022.shape_dnn import ShapeDNNConfig


def add_parser(sub) -> argparse.ArgumentParser:
    """The ``zou2022`` subcommand's parser."""
    zou2022 = paper_parser(sub, "zou2022", zou2022_module,
                            "zou2022 shape estimation (RSES, ASES, DNN) and control with each "
                            "shape source", "seeds (exploration, training, sensor noise, poses)")
    zou2022.add_argument("--samples", type=int_at_least(20), default=29791,
                         help="exploration samples of the DNN's data set, >= 20 (paper: 31^3 = "
                              "29791, ~25 min on one core, cached)")
    zou2022.add_argument("--epochs", type=positive_int, default=500,
                         help="DNN training epochs, >= 1 (paper: 500)")
    zou2022.add_argument("--lever-samples", type=int_at_least(20), default=3000,
                         help="exploration samples of the DNN trained at each lever of the "
                              "'levers' experiment (Table 4 at braid-twist levers 0-5 mm), "
                              ">= 20")
    zou2022.add_argument("--poses", type=positive_int, default=20,
                         help="random poses of the ASES fault experiment (>= 1)")
    zou2022.add_argument("--out", default="results/zou2022",
                         help="output directory (made; must be writable)")
    return zou2022


def run(parser: argparse.ArgumentParser, args: argparse.Namespace) -> None:
    """``zou2022``: the experiments with the given DNN data set and training."""
    config = ShapeDNNConfig(n_samples=args.samples, epochs=args.epochs)
    zou2022_module.run_and_report(args.experiments, args.seeds, args.out, config=config,
                                  n_poses=args.poses)
    if "levers" in args.experiments:
        zou2022_levers.run_and_report(args.seeds, args.out, ShapeDNNConfig(
            n_samples=args.lever_samples, epochs=args.epochs))
    print(f"output directory: {args.out}")
