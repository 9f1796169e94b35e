"""Soaks: long random runs that must stay physical, bounded and leak-free.

Three soaks, each printing its figures (and ``--json PATH`` writing them all):

1. **Random-action soak** per preset: ``--steps`` control steps of uniform random actions in a
   reach env with domain randomisation on (a load of every kind, sensor noise, stiffness and
   pneumatic lag drawn per episode, ``--episode-steps`` steps each), ground-truth feedback and
   every proprioceptive sensor the arm carries in the observation. Counted: exceptions,
   non-finite observations or rewards, observations outside the observation space, tips farther
   from the base than :attr:`ArmSpec.max_reach_m`; reported: steps/s and the resident memory
   (RSS) growth between the end of a warm-up (the first 5 % of the steps) and the end.
2. **Create/close cycles**: ``--cycles`` times ``gym.make`` + ``reset`` + a few steps +
   ``close`` of a camera env (eye-in-hand camera in the observation, so the scene's meshes are
   built every time). Reported: RSS, open file descriptors and connected PyBullet clients before
   and after, and the RSS growth per cycle after a warm-up of 10 % of the cycles.
3. **Fused soak** under each wang2023 fault schedule (Fig. 6 occlusion, Fig. 7 lighting, 200 s
   each): ``--fused-steps`` steps of the wang2023 track env with camera/F-emp fusion feedback,
   driven by the CC model controller, the schedule starting over every episode (a circle,
   ``cycles=10``: 200 s). Counted as in 1, plus the frames the camera lost; reported: steps/s,
   RSS growth and the mean tracking error.

The issue-sized run (10^6 steps per preset, 1,000 cycles, 20,000 fused steps per schedule) takes
hours on one core; ``tests/integration/test_soak.py`` runs it under ``-m slow``. Example::

    PYTHONPATH=. python bench/soak.py --steps 100000 --cycles 200 --fused-steps 4000
    PYTHONPATH=. python bench/soak.py --only cycles --cycles 1000
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path
from typing import Any, Callable

import gymnasium as gym
import numpy as np
from tqdm import tqdm

import soft_gym  # noqa: F401  (registers the ids)
from soft_gym._cli import CommandParser, HelpFormatter, int_at_least
from soft_gym.engines.pybullet.quiet_import import pybullet  # imported without its banner
from soft_gym.robots.presets import PRESETS, get_preset

PROPRIOCEPTION = {"wang2023": ("fbg",), "ho2018": ("em",), "zhao2021": ("strain",),
                  "zou2022": ("encoder",)}
"""Each arm's own sensors, observed in the random-action soak next to pose, target, pressure."""

SCHEDULES = ("wang2023_occlusion", "wang2023_lighting")
"""The fault schedules of the fused soak (:mod:`soft_gym.sensors.faults`)."""


def rss_mb() -> float:
    """Resident set size of this process (MB), from ``/proc/self/statm``."""
    pages = int(Path("/proc/self/statm").read_text().split()[1])
    return pages * os.sysconf("SC_PAGE_SIZE") / 1e6


def open_fds() -> int:
    """Open file descriptors of this process."""
    return len(os.listdir("/proc/self/fd"))


def connected_clients(highest: int = 256) -> int:
    """PyBullet physics clients connected in this process (ids ``0..highest-1``)."""
    return sum(pybullet.isConnected(physicsClientId=i) for i in range(highest))


class _Tally:
    """Counts of the things a soak must never see, and where the first of each happened."""

    def __init__(self) -> None:
        self.counts = {"exceptions": 0, "non_finite": 0, "outside_space": 0, "beyond_reach": 0}
        self.first: dict[str, str] = {}

    def add(self, kind: str, where: str) -> None:
        self.counts[kind] += 1
        self.first.setdefault(kind, where)

    def check_step(self, env: gym.Env, obs: Any, reward: float, info: dict, reach_m: float,
                   where: str) -> float:
        """Tally one step's outcome; returns the tip's distance from the base (m)."""
        if not (np.all(np.isfinite(obs)) and np.isfinite(reward)):
            self.add("non_finite", where)
        if not env.observation_space.contains(obs):
            self.add("outside_space", where)
        distance = float(np.linalg.norm(info["tip_position_m"]))
        if not np.isfinite(distance) or distance > reach_m:
            self.add("beyond_reach", where)
        return distance


def _stepping_soak(env: gym.Env, steps: int, act: Callable[[Any], Any], label: str,
                   seed: int, progress: bool, on_step: Callable[[dict], None] = lambda info: None,
                   on_reset: Callable[[], None] = lambda: None) -> dict[str, Any]:
    """Step ``env`` ``steps`` times with ``act(observation)``, a new seeded episode after each
    end or exception, tallying what a soak must never see (see the module doc); ``on_step``
    reads each step's ``info``, ``on_reset`` follows every reset. Closes ``env``."""
    reach_m = env.unwrapped.arm.max_reach_m
    tally, farthest = _Tally(), 0.0
    warmup = max(1, steps // 20)
    rss_start = rss_mb()
    episode, start = 0, time.perf_counter()
    obs, _ = env.reset(seed=seed)
    on_reset()
    for step in tqdm(range(steps), desc=label, unit="step", disable=not progress,
                     mininterval=2.0):
        where = f"{label} episode {episode} step {step}"
        try:
            obs, reward, terminated, truncated, info = env.step(act(obs))
            farthest = max(farthest, tally.check_step(env, obs, reward, info, reach_m, where))
            on_step(info)
            ended = terminated or truncated
        except Exception as error:  # counted, reported and soaked on
            tally.add("exceptions", f"{where}: {type(error).__name__}: {error}")
            ended = True
        if ended:
            episode += 1
            obs, _ = env.reset(seed=seed + episode)
            on_reset()
        if step + 1 == warmup:
            rss_start = rss_mb()
    wall_s = time.perf_counter() - start
    rss_end = rss_mb()
    env.close()
    return {"steps": steps, "episodes": episode + 1, **tally.counts, "first": tally.first,
            "farthest_mm": farthest * 1e3, "max_reach_mm": reach_m * 1e3,
            "steps_per_s": steps / wall_s, "rss_start_mb": rss_start, "rss_end_mb": rss_end,
            "rss_growth_pct": 100.0 * (rss_end - rss_start) / rss_start}


def random_action_soak(preset: str, steps: int, episode_steps: int = 200, seed: int = 0,
                       progress: bool = True) -> dict[str, Any]:
    """Soak 1 on ``preset``: ``steps`` random-action steps with randomisation (see module doc)."""
    n_chambers = get_preset(preset).n_chambers
    env = gym.make("SoftArmReach-v0", preset=preset, feedback="ground_truth",
                   obs=("pose", "target", "pressure") + PROPRIOCEPTION[preset],
                   randomization=True, episode_steps=episode_steps)
    rng = np.random.default_rng(seed)
    row = _stepping_soak(env, steps, lambda obs: rng.uniform(-1.0, 1.0, n_chambers).astype(
        np.float32), f"soak {preset}", seed, progress)
    return {"preset": preset, **row}


def create_close_cycles(cycles: int, preset: str = "wang2023",
                        progress: bool = True) -> dict[str, Any]:
    """Soak 2: ``cycles`` create/reset/step/close cycles of a camera env (see module doc)."""
    before = {"rss_mb": rss_mb(), "fds": open_fds(), "clients": connected_clients()}
    warmup = max(1, cycles // 10)
    rss_warm = before["rss_mb"]
    for cycle in tqdm(range(cycles), desc="create/close", unit="env", disable=not progress,
                      mininterval=2.0):
        env = gym.make("SoftArmReach-v0", preset=preset, feedback="ground_truth",
                       obs_format="dict", obs=("pose", "target", "image"), episode_steps=5)
        env.reset(seed=cycle)
        for _ in range(3):
            env.step(env.action_space.sample())
        env.close()
        if cycle + 1 == warmup:
            rss_warm = rss_mb()
    after = {"rss_mb": rss_mb(), "fds": open_fds(), "clients": connected_clients()}
    per_cycle = (after["rss_mb"] - rss_warm) / max(1, cycles - warmup)
    return {"preset": preset, "cycles": cycles, "before": before, "after": after,
            "rss_growth_mb_per_cycle": per_cycle}


def fused_soak(schedule: str, steps: int, seed: int = 0, progress: bool = True) -> dict[str, Any]:
    """Soak 3: ``steps`` steps of the fused wang2023 env under ``schedule`` (see module doc)."""
    from agents.policies import make_policy  # the controller is only needed here

    env = gym.make("SoftArmTrack-v0", preset="wang2023", feedback="fused", path="circle",
                   cycles=10, faults=schedule)
    policy = make_policy("cc_model", env=env)
    policy.calibrate_on_copy(seed=seed)  # the start-up probes are not part of the step rate
    lost, errors = [0], []

    def record(info: dict) -> None:
        lost[0] += bool(info.get("estimates", {}).get("lost", False))
        errors.append(float(info["error_mm"]))

    row = _stepping_soak(env, steps, lambda obs: policy.predict(obs, deterministic=True)[0],
                         f"fused {schedule}", seed, progress, on_step=record,
                         on_reset=policy.reset)
    return {"schedule": schedule, **row, "lost_frames": lost[0],
            "mean_error_mm": float(np.mean(errors))}


def build_parser() -> argparse.ArgumentParser:
    parser = CommandParser(
        prog="bench/soak.py", description=__doc__.split("\n\n")[0],
        epilog="Soaks: 1 random-action per preset, 2 create/close cycles, 3 fused under faults.",
        formatter_class=HelpFormatter)
    parser.add_argument("--presets", nargs="+", choices=list(PRESETS), default=list(PRESETS),
                        help="arms of the random-action soak")
    parser.add_argument("--steps", type=int_at_least(1), default=100_000,
                        help="random-action steps per preset")
    parser.add_argument("--episode-steps", type=int_at_least(1), default=200,
                        help="control steps per randomised episode")
    parser.add_argument("--cycles", type=int_at_least(1), default=200,
                        help="create/close cycles of a camera env")
    parser.add_argument("--fused-steps", type=int_at_least(1), default=4000,
                        help="fused-env steps per wang2023 fault schedule")
    parser.add_argument("--only", choices=("random", "cycles", "fused"), nargs="+",
                        default=["random", "cycles", "fused"], help="soaks to run")
    parser.add_argument("--seed", type=int_at_least(0), default=0,
                        help="seed of actions and episodes")
    parser.add_argument("--json", type=Path, default=None, help="write all figures here")
    parser.add_argument("--no-progress", action="store_true", help="no progress bars")
    return parser


def main(argv: list[str] | None = None) -> dict[str, Any]:
    args = build_parser().parse_args(argv)
    progress = not args.no_progress
    results: dict[str, Any] = {"random": [], "cycles": None, "fused": []}
    if "random" in args.only:
        for preset in args.presets:
            row = random_action_soak(preset, args.steps, args.episode_steps, args.seed, progress)
            results["random"].append(row)
            print(f"{preset:9s} {row['steps']} steps {row['steps_per_s']:.0f}/s: exceptions "
                  f"{row['exceptions']}, non-finite {row['non_finite']}, outside space "
                  f"{row['outside_space']}, beyond reach {row['beyond_reach']} (farthest "
                  f"{row['farthest_mm']:.1f} of {row['max_reach_mm']:.1f} mm), RSS "
                  f"{row['rss_start_mb']:.1f} -> {row['rss_end_mb']:.1f} MB "
                  f"({row['rss_growth_pct']:+.2f} %)", flush=True)
    if "cycles" in args.only:
        row = create_close_cycles(args.cycles, progress=progress)
        results["cycles"] = row
        b, a = row["before"], row["after"]
        print(f"create/close x{row['cycles']}: RSS {b['rss_mb']:.1f} -> {a['rss_mb']:.1f} MB "
              f"({row['rss_growth_mb_per_cycle'] * 1e3:.1f} kB/cycle after warm-up), fds "
              f"{b['fds']} -> {a['fds']}, PyBullet clients {b['clients']} -> {a['clients']}",
              flush=True)
    if "fused" in args.only:
        for schedule in SCHEDULES:
            row = fused_soak(schedule, args.fused_steps, args.seed, progress)
            results["fused"].append(row)
            print(f"fused {schedule}: {row['steps']} steps {row['steps_per_s']:.0f}/s, "
                  f"exceptions {row['exceptions']}, non-finite {row['non_finite']}, outside "
                  f"space {row['outside_space']}, beyond reach {row['beyond_reach']}, lost "
                  f"frames {row['lost_frames']}, mean error {row['mean_error_mm']:.1f} mm, RSS "
                  f"{row['rss_growth_pct']:+.2f} %", flush=True)
    if args.json is not None:
        args.json.write_text(json.dumps(results, indent=2))
        print(f"figures written to {args.json}")
    return results


if __name__ == "__main__":
    sys.exit(0 if main() is not None else 1)
