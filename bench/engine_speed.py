"""The MuJoCo engine against the PyBullet reference: env steps per second side by side, and each
engine's step-size accuracy.

For every preset (or ``--presets``), in one process, taking turns block by block (A B C A B C
..., so that every candidate sees the same machine load; the median block is reported):

1. **PyBullet env**: ``gym.make(id, engine="pybullet")``, ground-truth feedback, seeded random
   actions, ``--steps`` control steps a block;
2. **MuJoCo env**: the same with ``engine="mujoco"``;
3. **MuJoCo batch**: ``gym.make_vec(id, num_envs=--batch, vectorization_mode=
   "vector_entry_point", engine="mujoco", threads=--threads)``, ``--steps // --batch`` vector
   steps a block, counted as arm-steps (aggregate env steps per second);
4. **MuJoCo physics alone**: ``mj_step`` over one control period of substeps, on the model an
   arm far from its stops rides, nothing else: ``phys/pb`` is the ceiling of any env (single or
   batched, per core) on this model and physics step.

Ratios are over the PyBullet env in the same run: ``mj/pb`` (one env each, one core) and
``batch/pb`` (aggregate; per core when ``--threads 1``). Also per preset: each engine's physics
step and the deviation of its tip from its own 4x finer step on ``bench/env_speed.py``'s accuracy
sequence (seeded random pressures in ``[p_pre, p_max]`` each held for 10 control periods, 60
periods after a 0.5 s settle), and the two engines' largest tip gap on it.

Example::

    python bench/engine_speed.py
    python bench/engine_speed.py --presets wang2023 zhao2021 --steps 2000 --batch 64 --json out.json
"""

from __future__ import annotations

import argparse
import json
import sys
import time

import gymnasium as gym
import mujoco
import numpy as np

import soft_gym  # noqa: F401  (registers the ids)
from soft_gym._cli import CommandParser, HelpFormatter, positive_int
from soft_gym.engines import make_simulator
from soft_gym.robots.presets import PRESETS, get_preset

REFINEMENT = 4
"""The accuracy reference's physics step is the engine's over this."""


def _env(preset: str, engine: str):
    env = gym.make("SoftArmReach-v0", preset=preset, engine=engine, feedback="ground_truth")
    env.reset(seed=0)
    return env


def _time_single(env, actions: np.ndarray) -> float:
    """Env steps per second over ``actions`` (resets when an episode ends, not timed)."""
    elapsed = 0.0
    for action in actions:
        start = time.perf_counter()
        _, _, terminated, truncated, _ = env.step(action)
        elapsed += time.perf_counter() - start
        if terminated or truncated:
            env.reset()
    return len(actions) / elapsed


def _time_batch(vector, actions: np.ndarray) -> float:
    """Aggregate arm-steps per second over ``actions`` (vector steps; NextStep autoresets
    included: they are part of a vector step)."""
    start = time.perf_counter()
    for action in actions:
        vector.step(action)
    return actions.shape[0] * actions.shape[1] / (time.perf_counter() - start)


def _time_physics(model, data, periods: int, substeps: int) -> float:
    """Control periods per second of ``mj_step`` alone (``substeps`` each), no actuation, no
    env: the ceiling of any env on this model."""
    start = time.perf_counter()
    for _ in range(periods):
        mujoco.mj_step(model, data, substeps)
    return periods / (time.perf_counter() - start)


def _tips(spec, engine: str, physics_dt_s: float, commands: np.ndarray) -> np.ndarray:
    sim = make_simulator(spec, engine, physics_dt_s=physics_dt_s)
    sim.reset(settle_s=0.5)
    tips = [sim.tip_pose()[0]]
    for pressure in commands:
        sim.set_pressures(pressure)
        sim.step_physics(spec.control_period_s)
        tips.append(sim.tip_pose()[0])
    sim.close()
    return np.array(tips)


def accuracy(preset: str) -> dict:
    """Each engine's tip deviation from its own 4x finer step, and the engines' gap (mm)."""
    spec = get_preset(preset)
    rng = np.random.default_rng(0)
    held = spec.p_pre_pa + rng.random((6, spec.n_chambers)) * (spec.p_max_pa - spec.p_pre_pa)
    commands = np.repeat(held, 10, axis=0)
    steps = {"pybullet": spec.physics_dt_s,
             "mujoco": spec.mujoco_physics_dt_s or spec.physics_dt_s}
    tips = {engine: _tips(spec, engine, dt, commands) for engine, dt in steps.items()}
    result = {f"{engine}_dt_ms": dt * 1e3 for engine, dt in steps.items()}
    for engine, dt in steps.items():
        fine = _tips(spec, engine, dt / REFINEMENT, commands)
        result[f"{engine}_dev_mm"] = float(1e3 * np.linalg.norm(tips[engine] - fine,
                                                                axis=1).max())
    result["gap_mm"] = float(1e3 * np.linalg.norm(tips["pybullet"] - tips["mujoco"],
                                                  axis=1).max())
    return result


def speed(preset: str, steps: int, rounds: int, batch: int, threads: int) -> dict:
    pybullet_env, mujoco_env = _env(preset, "pybullet"), _env(preset, "mujoco")
    vector = gym.make_vec("SoftArmReach-v0", num_envs=batch, vectorization_mode="vector_entry_point",
                          preset=preset, engine="mujoco", feedback="ground_truth", threads=threads)
    vector.reset(seed=0)
    spec = get_preset(preset)
    # the physics alone: the model an arm far from its stops rides, bent by held moments
    physics = make_simulator(spec, "mujoco")
    physics.reset(pressure_pa=0.5 * (spec.p_pre_pa + spec.p_max_pa))
    if physics.with_stops:
        raise RuntimeError(f"{preset}: the physics-alone timing expects the arm far from its stops")
    substeps = int(round(spec.control_period_s / physics.physics_dt_s))
    rng = np.random.default_rng(0)
    runs: dict[str, list[float]] = {"pybullet": [], "mujoco": [], "batch": [], "physics": []}
    for _ in range(rounds):
        actions = rng.uniform(-1, 1, (steps, spec.n_chambers)).astype(np.float32)
        runs["pybullet"].append(_time_single(pybullet_env, actions))
        runs["mujoco"].append(_time_single(mujoco_env, actions))
        batch_actions = rng.uniform(-1, 1, (max(1, steps // batch), batch, spec.n_chambers))
        runs["batch"].append(_time_batch(vector, batch_actions.astype(np.float32)))
        runs["physics"].append(_time_physics(physics.model, physics.data, steps, substeps))
    for env in (pybullet_env, mujoco_env, vector):
        env.close()
    median = {name: float(np.median(values)) for name, values in runs.items()}
    return {"pybullet_steps_per_s": median["pybullet"], "mujoco_steps_per_s": median["mujoco"],
            "batch_steps_per_s": median["batch"], "physics_steps_per_s": median["physics"],
            "mujoco_over_pybullet": median["mujoco"] / median["pybullet"],
            "batch_over_pybullet": median["batch"] / median["pybullet"],
            "physics_over_pybullet": median["physics"] / median["pybullet"],
            "ratio_ranges": {name: [min(values), max(values)] for name, values in runs.items()}}


COLUMNS = (("preset", "preset", "{}"), ("pb st/s", "pybullet_steps_per_s", "{:.0f}"),
           ("mj st/s", "mujoco_steps_per_s", "{:.0f}"), ("mj/pb", "mujoco_over_pybullet", "{:.2f}"),
           ("batch st/s", "batch_steps_per_s", "{:.0f}"), ("batch/pb", "batch_over_pybullet", "{:.2f}"),
           ("phys/pb", "physics_over_pybullet", "{:.1f}"),
           ("pb dt ms", "pybullet_dt_ms", "{:.3g}"), ("mj dt ms", "mujoco_dt_ms", "{:.3g}"),
           ("pb dev mm", "pybullet_dev_mm", "{:.3f}"), ("mj dev mm", "mujoco_dev_mm", "{:.3f}"),
           ("gap mm", "gap_mm", "{:.3f}"))


def format_table(rows: list[dict]) -> str:
    cells = [[header for header, _, _ in COLUMNS]]
    cells += [[fmt.format(row[key]) for _, key, fmt in COLUMNS] for row in rows]
    widths = [max(len(row[i]) for row in cells) for i in range(len(COLUMNS))]
    return "\n".join("  ".join(cell.rjust(width) for cell, width in zip(row, widths))
                     for row in cells)


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    parser = CommandParser(prog="python bench/engine_speed.py", description=__doc__,
                                     formatter_class=HelpFormatter)
    parser.add_argument("--presets", nargs="+", choices=list(PRESETS), default=list(PRESETS),
                        help="arm presets")
    parser.add_argument("--steps", type=positive_int, default=1000,
                        help="env steps per timed block (the batch: arm-steps)")
    parser.add_argument("--rounds", type=positive_int, default=3,
                        help="blocks per candidate, taking turns")
    parser.add_argument("--batch", type=positive_int, default=64, help="arms in the batch")
    parser.add_argument("--threads", type=positive_int, default=1,
                        help="threads of the batch (1: the per-core figure)")
    parser.add_argument("--json", metavar="PATH", default=None, help="write the results here")
    return parser.parse_args(argv)


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    rows = []
    for preset in args.presets:
        row = {"preset": preset, **speed(preset, args.steps, args.rounds, args.batch,
                                         args.threads), **accuracy(preset)}
        rows.append(row)
        print(f"{preset}: done", file=sys.stderr, flush=True)
    print(format_table(rows))
    print(f"(batch: {args.batch} arms, {args.threads} thread(s); median of {args.rounds} blocks "
          f"of {args.steps} steps, taking turns)")
    if args.json:
        with open(args.json, "w") as handle:
            json.dump({"settings": vars(args), "rows": rows}, handle, indent=2)
    return 0


if __name__ == "__main__":
    sys.exit(main())
