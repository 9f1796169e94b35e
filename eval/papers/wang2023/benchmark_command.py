"""``python -m eval benchmark``: the wang2023 comparison (``track`` with fixed settings: a loaded
circle, fused feedback and a partly occluding hand)."""

from __future__ import annotations

import argparse
import textwrap

from agents.policies import shipped_agents
from eval.commands import track
from eval.commands.options import add_video_flag, add_workers
from soft_gym._cli import HelpFormatter


BENCHMARK_LOAD_KG = 0.010
"""The tip mass of ``benchmark``'s runs (kg)."""

BENCHMARK_OCCLUDER = {"name": "moving_occluder", "mode": "partial", "strength": 0.8,
                      "start_s": 40.0}
"""The visual fault of ``benchmark``'s runs: a partly occluding hand from 40 s on."""

BENCHMARK_DESCRIPTION = (
    "The wang2023 comparison: cc_model, hybrid_gpr and the shipped SB3 agents trained on "
    "SoftArmTrackWang2023-v0 track the circle for 3 cycles with a "
    f"{BENCHMARK_LOAD_KG * 1000:g} g tip load, fused camera/FBG feedback, and a partly occluding "
    f"hand moving in front of the camera from {BENCHMARK_OCCLUDER['start_s']:g} s on. Prints the "
    "table and writes per-run CSVs, a JSON summary and plots to --out (about 1 minute on 2 idle "
    "cores, 2 beside another job). The README's main job is 'suite small'.")
"""``benchmark --help``'s description (its runs are fixed)."""


def benchmark_title() -> str:
    """The title of ``benchmark``'s error plot: the arm, path, load, feedback and the occlusion
    window (``{end_s}``: the runs' end, filled in once they are done)."""
    occluder = BENCHMARK_OCCLUDER
    return (f"wang2023 circle, {BENCHMARK_LOAD_KG * 1000:g} g tip load, fused feedback; "
            f"{occluder['mode']} occluder (strength {occluder['strength']:g}) "
            f"from {occluder['start_s']:g} s to {{end_s:.0f}} s (the end)")


def add_parser(sub) -> argparse.ArgumentParser:
    """The ``benchmark`` subcommand's parser (its runs are fixed)."""
    benchmark = sub.add_parser("benchmark", help="the wang2023 comparison: loaded circle, fused "
                               "feedback, an occluding hand",
                               description=textwrap.fill(BENCHMARK_DESCRIPTION, 96),
                               formatter_class=HelpFormatter)
    benchmark.add_argument("--out", default="results/benchmark",
                           help="output directory (made; must be writable)")
    add_workers(benchmark)
    add_video_flag(benchmark)
    return benchmark


def run(parser: argparse.ArgumentParser, args: argparse.Namespace) -> None:
    """``benchmark``: ``track`` with the README's main job's fixed settings."""
    args = argparse.Namespace(
        policies=["cc_model", "hybrid_gpr"] + [f"sb3:{name}" for name in
                                               shipped_agents("SoftArmTrackWang2023-v0")],
        kp=[0.06], preset="wang2023", path="circle",
        cycles=3, feedback="fused", scenario={"name": "tip_mass", "mass_kg": BENCHMARK_LOAD_KG},
        faults=dict(BENCHMARK_OCCLUDER), seeds=[0], out=args.out, workers=args.workers,
        video=args.video, title=benchmark_title())
    # benchmark's settings are fixed: a refusal names the part (a shipped agent, ...)
    track.run_tracks(args, parser, options={})
    print(f"output directory: {args.out}")
