"""``python -m eval zhao2021``: zhao2021's shape reconstruction and local-IK control experiments
(:mod:`eval.papers.zhao2021`)."""

from __future__ import annotations

import argparse

from eval.commands.options import check_baselines, paper_parser
import eval.papers.zhao2021.experiments as zhao2021_module
from soft_gym._cli import non_negative_int, positive_int
from soft_gym.papers.zhao2021.backbone_fit import BACKBONE_CURVES
from soft_gym.papers.zhao2021.shape_reconstruction import ReconstructionConfig


def add_parser(sub) -> argparse.ArgumentParser:
    """The ``zhao2021`` subcommand's parser."""
    zhao2021 = paper_parser(sub, "zhao2021", zhao2021_module,
                             "zhao2021 shape reconstruction and local-IK control experiments",
                             "seeds (exploration, training and episodes)")
    zhao2021.add_argument("--samples", type=non_negative_int, nargs=2, default=[4000, 2000],
                          metavar=("FREE", "LOADED"),
                          help="exploration samples free and with the 75 g tip, >= 0 each and "
                               ">= 24 together (paper: 4000 2000)")
    zhao2021.add_argument("--iterations", type=positive_int, default=1000,
                          help="most training iterations of the networks, >= 1 (paper: 1000)")
    zhao2021.add_argument("--backbone-curve", choices=BACKBONE_CURVES, default="paper",
                          help="the curve fitted through the key points (shape and control): "
                               "paper = eqs. 7-10 in each subsegment's frame (default), "
                               "paper_base_frame = all in the base frame, cubic_fallback = a "
                               "cubic where the paper's curve misses a key point by > 1 mm")
    zhao2021.add_argument("--paper-training", action="store_true",
                          help="train the networks with the paper's settings where the defaults "
                               "differ: SFE-PD dropout 0.3 and Adam at 0.001, the local IK "
                               "network at 0.001 without its skip connection (separate cache "
                               "entries; about as long to build as the defaults)")
    zhao2021.add_argument("--goal-mm", type=float, nargs=3, metavar=("X", "Y", "Z"),
                          default=list(zhao2021_module.P2P_GOAL_MM),
                          help="the point-to-point goal in the paper's frame (mm; paper: "
                               "-50 70 210); refused unless the arm holds it with every load")
    zhao2021.add_argument("--p2p-loads-g", type=float, nargs="*",
                          default=[1000 * m for m in zhao2021_module.P2P_LOADS_KG[1:]],
                          help="tip loads of the loaded ASDM point-to-point runs (g; paper: "
                               "50 75 100)")
    zhao2021.add_argument("--circle-load-g", type=float,
                          default=1000 * zhao2021_module.CIRCLE_MASS_KG,
                          help="the block added at step 29 and removed at step 60 of the "
                               "circle (g; paper: 263)")
    zhao2021.add_argument("--baselines", nargs="*", default=[],
                          help="further policies on the free point-to-point run and circle, "
                               "e.g. lwpr_rwr cc_model sb3:PATH")
    zhao2021.add_argument("--out", default="results/zhao2021",
                          help="output directory (made; must be writable)")
    return zhao2021


def run(parser: argparse.ArgumentParser, args: argparse.Namespace) -> None:
    """``zhao2021``: the sample counts and further baselines checked, then the experiments."""
    free, loaded = args.samples
    if free + loaded < 24:
        parser.error(f"--samples must be two counts >= 0 adding up to >= 24, got "
                     f"{args.samples}")
    check_baselines(parser, args.baselines, zhao2021_module.check_baselines)
    setup = {"goal_mm": tuple(args.goal_mm),
             "p2p_loads_kg": tuple(g / 1000.0 for g in args.p2p_loads_g),
             "circle_mass_kg": args.circle_load_g / 1000.0}
    if {"p2p", "sway", "circle"} & set(args.experiments):
        try:
            zhao2021_module.check_setup(**setup)
        except ValueError as error:  # "goal_mm: ..." names its option: "--goal-mm: ..."
            name, _, reason = str(error).partition(":")
            parser.error(f"--{name.replace('_', '-')}:{reason}")
    paper = zhao2021_module.PAPER_TRAINING if args.paper_training else {}
    config = ReconstructionConfig(n_free=free, n_loaded=loaded,
                                  max_iterations=args.iterations,
                                  backbone_curve=args.backbone_curve,
                                  **paper.get("sensing", {}))
    zhao2021_module.run_and_report(args.experiments, args.seeds, args.out, config=config,
                                   baselines=tuple(args.baselines),
                                   controller=paper.get("controller"), **setup)
    print(f"output directory: {args.out}")
