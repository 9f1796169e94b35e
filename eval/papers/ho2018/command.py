"""``python -m eval ho2018``: ho2018's static and varying tip-load experiments
(:mod:`eval.papers.ho2018`)."""

from __future__ import annotations

import argparse

from eval.commands.options import check_baselines, paper_parser
import eval.papers.ho2018.experiments as ho2018_module
from soft_gym._cli import finite_float


def add_parser(sub) -> argparse.ArgumentParser:
    """The ``ho2018`` subcommand's parser."""
    ho2018 = paper_parser(sub, "ho2018", ho2018_module,
                           "ho2018 static and varying tip-load experiments",
                           "seeds (pre-training waypoints and episode)")
    ho2018.add_argument("--quick", action="store_true",
                        help="the shorter protocol: 40 s static and 30 s varying cycles, "
                             "decisions at 10 Hz, a 15 s lead-in (default: the paper's, 133.3 s "
                             "static cycles at 20 Hz, 45 s varying cycles at 20 Hz offline "
                             "and 6.7 Hz online, a 30 s lead-in)")
    ho2018.add_argument("--cycle-s", type=finite_float(5.0, 3600.0), default=None,
                        help="seconds per rectangle cycle (s), in [5, 3600]; default: the "
                             "protocol's")
    ho2018.add_argument("--baselines", nargs="*", default=[],
                        help="further policies on the online run's load, e.g. cc_model "
                             "hybrid_gpr sb3:PATH")
    ho2018.add_argument("--lead-in-s", type=finite_float(0.0, 3600.0), default=None,
                        help="seconds tracking the first corner before recording (s), in "
                             "[0, 3600]; default: the protocol's")
    ho2018.add_argument("--out", default="results/ho2018",
                        help="output directory (made; must be writable)")
    return ho2018


def run(parser: argparse.ArgumentParser, args: argparse.Namespace) -> None:
    """``ho2018``: the further baselines checked, then the experiments."""
    check_baselines(parser, args.baselines, ho2018_module.check_baselines)
    ho2018_module.run_and_report(args.experiments, args.seeds, args.out,
                                 protocol="quick" if args.quick else "paper",
                                 cycle_s=args.cycle_s, lead_in_s=args.lead_in_s,
                                 baselines=tuple(args.baselines))
    print(f"output directory: {args.out}")
