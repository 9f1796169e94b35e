"""Env steps per second of this working tree against a git revision, measured side by side.

A speed claim ("the ground-truth env is 1.1x faster than at v0.2.0") needs both versions timed on
the same machine at the same moment. This script extracts ``--against`` (any git revision:
a commit, tag or branch) into a temporary directory with ``git archive``, then, for every
``--presets`` entry, runs the same measurement in fresh processes taking turns, this tree and
the revision (A B A B ... over ``--rounds`` rounds, so both see the same machine load):

    make the env (``feedback=--feedback``, ``engine=--engine``, one long episode), reset it
    with ``--seed``, draw ``--steps`` seeded random actions, and time ``env.step`` over all of
    them.

Each process imports ``soft_gym`` from its own tree; making the env (and, for the camera
feedbacks, a calibration the revision's cache lacks) is not timed; who goes first alternates
from round to round. Printed per preset: the median steps per wall second of each tree and the
medians of the per-round ratios (this tree over the revision) of wall-clock and of CPU-time
rates, with the CPU ratio's range (on a machine shared with other work the CPU ratio is the
steadier of the two). ``--json PATH`` writes every round's figures.

    python bench/revision_speed.py --against v0.2.0
    python bench/revision_speed.py --against HEAD~3 --presets wang2023 ho2018 --rounds 5
    python bench/revision_speed.py --against main --feedback fused --steps 300
    python bench/revision_speed.py --against HEAD~1 --engine mujoco --steps 4000
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tarfile
import tempfile
from pathlib import Path

from soft_gym._cli import CommandParser, HelpFormatter, check_output_dir, positive_int
from soft_gym.engines import ENGINES
from soft_gym.robots.presets import PRESETS
from soft_gym.sensing import FEEDBACK_SOURCES

ROOT = Path(__file__).resolve().parent.parent

CHILD = """
import sys, time
sys.path.insert(0, sys.argv[1])
import numpy as np, gymnasium as gym
import soft_gym  # noqa: F401  (registers the ids)
preset, feedback, steps, seed = sys.argv[2], sys.argv[3], int(sys.argv[4]), int(sys.argv[5])
engine = {"engine": sys.argv[6]} if len(sys.argv) > 6 else {}
env = gym.make("SoftArmReach-v0", preset=preset, feedback=feedback, episode_steps=10**6, **engine)
env.reset(seed=seed)
rng = np.random.default_rng(seed)
actions = rng.uniform(-1.0, 1.0, (steps,) + env.action_space.shape).astype(np.float32)
start, start_cpu = time.perf_counter(), time.process_time()
for action in actions:
    env.step(action)
print(steps / (time.perf_counter() - start), steps / (time.process_time() - start_cpu))
"""
"""The measurement, run by ``python -c`` with the tree's root put first on ``sys.path``."""


def resolve_commit(revision: str) -> str | None:
    """Full hash of the commit ``revision`` names in this repository, or ``None``."""
    try:
        done = subprocess.run(
            ["git", "-C", str(ROOT), "rev-parse", "--verify", "--quiet", f"{revision}^{{commit}}"],
            capture_output=True, text=True)
    except FileNotFoundError:  # no git on the PATH
        return None
    return done.stdout.strip() if done.returncode == 0 else None


def extract_commit(commit: str, directory: Path) -> Path:
    """Unpack ``commit``'s tracked files under ``directory``; returns the tree's root."""
    archive = directory / "revision.tar"
    with archive.open("wb") as out:
        subprocess.run(["git", "-C", str(ROOT), "archive", "--format=tar", commit],
                       check=True, stdout=out)
    with tarfile.open(archive) as tar:
        tar.extractall(directory / "tree", filter="data")
    archive.unlink()
    return directory / "tree"


def steps_per_second(tree: Path, preset: str, feedback: str, steps: int,
                     seed: int, engine: str | None = None) -> tuple[float, float]:
    """One measurement in a fresh process importing ``soft_gym`` from ``tree``: env steps per
    second of wall time and per second of the process's CPU time (``engine``: the env's
    ``engine=``, else the default)."""
    env = dict(os.environ, PYTHONPATH=str(tree))
    command = [sys.executable, "-c", CHILD, str(tree), preset, feedback, str(steps), str(seed)]
    done = subprocess.run(command + ([engine] if engine else []), capture_output=True,
                          text=True, env=env, cwd=str(tree))
    if done.returncode != 0:
        raise RuntimeError(f"the measurement in {tree} failed for {preset}:\n{done.stderr}")
    wall, cpu = done.stdout.strip().splitlines()[-1].split()
    return float(wall), float(cpu)


def take_turns(revision_tree: Path, preset: str, feedback: str, steps: int, seed: int,
               rounds: int, engine: str | None = None
               ) -> tuple[list[tuple[float, float]], list[tuple[float, float]]]:
    """``rounds`` measurements (:func:`steps_per_second`) of this tree and of ``revision_tree``,
    taking turns (who goes first alternates, so neither always gets the fresher machine):
    (this tree's figures, the revision's), each a (wall, CPU) steps/s pair per round."""
    ours, theirs = [], []
    for round_index in range(rounds):
        print(f"{preset}: round {round_index + 1} of {rounds}", file=sys.stderr, flush=True)
        pair = [(ROOT, ours), (revision_tree, theirs)]
        for tree, figures in pair if round_index % 2 == 0 else pair[::-1]:
            figures.append(steps_per_second(tree, preset, feedback, steps, seed, engine))
    return ours, theirs


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    parser = CommandParser(description=__doc__, formatter_class=HelpFormatter)
    parser.add_argument("--against", required=True, metavar="REVISION",
                        help="git revision to compare with (commit, tag or branch)")
    parser.add_argument("--presets", nargs="+", choices=list(PRESETS), default=list(PRESETS),
                        metavar="NAME", help=f"arm presets, from {list(PRESETS)}")
    parser.add_argument("--feedback", choices=sorted(FEEDBACK_SOURCES), default="ground_truth",
                        metavar="SOURCE",
                        help=f"feedback source of the env, from {sorted(FEEDBACK_SOURCES)} "
                             "('fused': camera + vision + F-emp)")
    parser.add_argument("--engine", choices=sorted(ENGINES), default=None,
                        help=f"physics engine of the env, from {sorted(ENGINES)}; not given: "
                             "the env's default (passed to neither tree, so that revisions "
                             "older than engine= run too)")
    parser.add_argument("--steps", type=positive_int, default=2000,
                        help="timed env steps per process")
    parser.add_argument("--rounds", type=positive_int, default=3,
                        help="processes per tree and preset, taking turns")
    parser.add_argument("--seed", type=int, default=0, help="seed of the env and its actions")
    parser.add_argument("--json", metavar="PATH", default=None,
                        help="write every round's figures here")
    args = parser.parse_args(argv)
    args.commit = resolve_commit(args.against)
    if args.commit is None:
        parser.error(f"--against {args.against!r} names no commit of the repository at {ROOT}: "
                     "give a commit, tag or branch")
    if args.json is not None:
        check_output_dir(parser, "--json", Path(args.json).absolute().parent)
    return args


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    commit = args.commit
    with tempfile.TemporaryDirectory(prefix="revision_speed_") as scratch:
        revision_tree = extract_commit(commit, Path(scratch))
        rows = []
        for preset in args.presets:
            ours, theirs = take_turns(revision_tree, preset, args.feedback, args.steps,
                                      args.seed, args.rounds, args.engine)
            rows.append({
                "preset": preset,
                "this_tree_steps_per_wall_s": [wall for wall, _ in ours],
                "this_tree_steps_per_cpu_s": [cpu for _, cpu in ours],
                "revision_steps_per_wall_s": [wall for wall, _ in theirs],
                "revision_steps_per_cpu_s": [cpu for _, cpu in theirs],
                "wall_ratios": [a[0] / b[0] for a, b in zip(ours, theirs)],
                "cpu_ratios": [a[1] / b[1] for a, b in zip(ours, theirs)]})
    header = (f"{'preset':<10} {'this tree st/s':>14} {'revision st/s':>14} {'wall ratio':>10} "
              f"{'cpu ratio':>9}  cpu ratio range")
    print(f"env steps/s (wall), feedback {args.feedback}, engine {args.engine or 'default'}, "
          f"{args.steps} steps, {args.rounds} rounds taking turns; revision {args.against} = "
          f"{commit[:12]}; ratios: this tree over the revision, median of the rounds")
    print(header)
    print("-" * len(header))
    median = statistics.median
    for row in rows:
        print(f"{row['preset']:<10} {median(row['this_tree_steps_per_wall_s']):>14.0f} "
              f"{median(row['revision_steps_per_wall_s']):>14.0f} "
              f"{median(row['wall_ratios']):>10.3f} {median(row['cpu_ratios']):>9.3f}  "
              f"{min(row['cpu_ratios']):.3f}-{max(row['cpu_ratios']):.3f}")
    if args.json:
        Path(args.json).parent.mkdir(parents=True, exist_ok=True)
        Path(args.json).write_text(json.dumps(
            {"against": args.against, "commit": commit, "feedback": args.feedback,
             "engine": args.engine,
             "steps": args.steps, "rounds": args.rounds, "seed": args.seed, "rows": rows},
            indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
