"""``python -m eval compare``: the SB3 agents against the baselines, nominal and out of
distribution (:mod:`eval.compare`)."""

from __future__ import annotations

import argparse

from agents.policies import shipped_agents
from eval import compare as compare_module
from eval.commands.options import add_video_flag, add_workers
from eval.report import markdown_table
from eval.runner import ConfigError
from soft_gym._cli import HelpFormatter, fail, positive_float, positive_int, seed_int
from soft_gym._validation import SEED_MAX
from soft_gym.envs.registration import preset_env_id
from soft_gym.papers import DEFAULT_PRESET


def add_parser(sub) -> argparse.ArgumentParser:
    """The ``compare`` subcommand's parser."""
    compare = sub.add_parser(
        "compare", help="SB3 agents against the baselines, nominal and out of distribution",
        description=compare_module.__doc__, formatter_class=HelpFormatter)
    compare.add_argument("--policies", nargs="+", default=None,
                         help="baselines, sb3:PATH or shipped agent names as sb3:<name> "
                              "(default: cc_model, hybrid_gpr and every shipped agent)")
    compare.add_argument("--paths", nargs="+", default=["circle", "pentagram"],
                         help="paths to track (circle, pentagram, rectangle, spiral, star)")
    compare.add_argument("--conditions", nargs="+", default=list(compare_module.CONDITIONS),
                         choices=list(compare_module.CONDITIONS), help="test conditions")
    compare.add_argument("--seeds", type=seed_int, nargs="+", default=[0, 1],
                         help=f"episode seeds (integers in [0, {SEED_MAX}])")
    compare.add_argument("--cycles", type=positive_int, default=2,
                         help="path cycles per run (>= 1)")
    compare.add_argument("--feedback", default="fused",
                         help="pose feedback of every policy: fused, camera, fbg, em, ground_truth")
    compare.add_argument("--kp", type=positive_float, default=0.06,
                         help="K_p of the CC baselines, a finite number > 0")
    compare.add_argument("--out", default="results/compare",
                         help="output directory (made; must be writable)")
    add_workers(compare)
    add_video_flag(compare)
    return compare


COMPARE_OPTIONS = {"env_kwargs.path": "--paths", "env_kwargs.cycles": "--cycles",
                   "env_kwargs.feedback": "--feedback", "env_kwargs.scenario": "--conditions",
                   "env_kwargs.faults": "--conditions", "policy": "--policies",
                   "policy_params": "--kp", "seed": "--seeds"}
"""The part of a run configuration -> the ``compare`` option that sets it."""


def run(parser: argparse.ArgumentParser, args: argparse.Namespace) -> None:
    """``compare``: check the options and every run, run (each run's CSV written as it
    finishes), print the table."""
    policies = args.policies or (["cc_model", "hybrid_gpr"]
                                 + [f"sb3:{name}" for name in
                                    shipped_agents(preset_env_id("track", DEFAULT_PRESET))])
    if args.feedback not in ("fused", "camera") and "occlusion" in args.conditions:
        parser.error("the occlusion condition needs camera feedback: --feedback fused or "
                     f"camera, got {args.feedback!r}")
    try:
        rows = compare_module.run_comparison(
            policies, args.paths, args.conditions, args.seeds, args.out, cycles=args.cycles,
            feedback=args.feedback, kp=args.kp, workers=args.workers,
            **({"video": True} if args.video else {}), check=True)
    except ConfigError as error:
        option = COMPARE_OPTIONS.get(error.part, "--policies")
        shown = {"--paths": error.config.env_kwargs.get("path"), "--kp": args.kp,
                 "--feedback": args.feedback, "--cycles": args.cycles,
                 "--conditions": error.config.labels.get("condition"),
                 "--policies": error.config.policy, "--seeds": error.config.seed}[option]
        fail(parser, option, f"{shown!r} refused: {error.message}")
    print(markdown_table(rows, float_format="{:.2f}"))
    print(f"output directory: {args.out}")
