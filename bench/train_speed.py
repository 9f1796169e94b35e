"""Training throughput: env steps per second of SAC with 1 and 2 envs, beside the env alone.

Measured side by side in one run on the same env configuration (default: the shipped agents'
training env, wang2023 tracking with EM feedback and domain randomisation):

1. **env only**: random actions through a ``DummyVecEnv`` of one env (no learning);
2. **SAC, n_envs=1**: ``python -m train``'s setup (VecNormalize, one gradient step per env step);
3. **SAC, n_envs=2**: two envs in ``SubprocVecEnv`` workers; one gradient step per vector step,
   i.e. per two env steps (SB3's ``train_freq`` counts vector steps).

Each learning run first fills ``learning_starts`` steps (not timed), then times ``--steps`` env
steps (PPO: whole rollouts, at least ``--steps``). ``--env-kwargs KEY=VALUE`` overrides the
env's keyword arguments, as ``python -m train`` does (e.g. ``feedback=fused`` for the camera +
FBG pipeline).

``--engines PRESET ...`` compares the two engines' training instead, per arm, on the arm's SAC
recipe env (``SoftArmTrack<Preset>-v0``, its feedback; randomisation, where the recipe has it,
from ``train/configs/randomization_mujoco.yaml`` on both engines, which lacks only the swaying
mass the MuJoCo engine does not simulate): PPO on ``--batch`` batched MuJoCo arms
(``--vec batched``) against PPO on 2 PyBullet envs in ``SubprocVecEnv``, and SAC on 4 batched
MuJoCo arms against SAC on one PyBullet env (SB3's ``train_freq`` counts vector steps, so SAC
on 4 arms takes a gradient step per 4 env steps). Example::

    python bench/train_speed.py --steps 3000
    python bench/train_speed.py --steps 1000 --env-kwargs feedback=fused
    python bench/train_speed.py --engines wang2023 zhao2021 zou2022 ho2018 --steps 4000
"""

from __future__ import annotations

import argparse
import tempfile
import time

import numpy as np
import torch

import yaml

from soft_gym._cli import CommandParser, HelpFormatter, positive_int
from soft_gym.robots.presets import PRESETS
from train.config import (CONFIG_DIR, parse_key_values, read_hyperparameters,
                          split_hyperparameters)
from train.trainer import make_vec_env, new_model


def env_only(env_id: str, env_kwargs: dict, steps: int) -> float:
    env = make_vec_env(env_id, env_kwargs, 1, seed=0)
    env.reset()
    rng = np.random.default_rng(0)
    start = time.perf_counter()
    for _ in range(steps):
        env.step(rng.uniform(-1, 1, size=(1,) + env.action_space.shape).astype(np.float32))
    elapsed = time.perf_counter() - start
    env.close()
    return steps / elapsed


def learning(algo: str, env_id: str, n_envs: int, steps: int,
             env_kwargs: dict | None = None, vec: str = "subprocess",
             replace_env_kwargs: bool = False) -> float:
    """Env steps per second of ``algo`` learning on ``n_envs`` envs (``vec``), after a warm-up;
    ``env_kwargs`` over the recipe's (or instead of them, ``replace_env_kwargs``)."""
    from stable_baselines3.common.vec_env import VecNormalize

    settings = split_hyperparameters(algo, read_hyperparameters(algo, env_id))
    if replace_env_kwargs:
        settings.env_kwargs = {}
    settings.env_kwargs.update(env_kwargs or {})
    with tempfile.TemporaryDirectory() as monitor_dir:
        env = make_vec_env(env_id, settings.env_kwargs, n_envs, seed=0, monitor_dir=monitor_dir,
                           vec=vec)
        if settings.normalize is not None:
            env = VecNormalize(env, **settings.normalize)
        model = new_model(algo, settings, env, seed=0)
        warmup = int(settings.algo_kwargs.get("learning_starts", 0)) + 200
        model.learn(warmup)
        done = model.num_timesteps
        start = time.perf_counter()
        model.learn(steps, reset_num_timesteps=False)
        elapsed = time.perf_counter() - start
        done = model.num_timesteps - done  # PPO learns whole rollouts
        env.close()
    return done / elapsed


ENGINE_RUNS = (("PPO, batched MuJoCo", "ppo", "mujoco", None, "batched"),
               ("PPO, 2 PyBullet (Subproc)", "ppo", "pybullet", 2, "subprocess"),
               ("SAC, 4 batched MuJoCo", "sac", "mujoco", 4, "batched"),
               ("SAC, 1 PyBullet", "sac", "pybullet", 1, "subprocess"))
"""Label, algorithm, engine, envs (``None``: ``--batch``) and vector kind of each engine run."""


def engine_env_kwargs(env_id: str) -> dict:
    """The arm's SAC recipe env, its randomisation (if any) the MuJoCo-able ranges."""
    kwargs = dict(split_hyperparameters("sac", read_hyperparameters("sac", env_id)).env_kwargs)
    if kwargs.get("randomization"):
        path = CONFIG_DIR / "randomization_mujoco.yaml"
        kwargs["randomization"] = yaml.safe_load(path.read_text())
    return kwargs


def compare_engines(presets: list[str], steps: int, batch: int) -> list[dict]:
    """Per preset, env steps per second of each of :data:`ENGINE_RUNS`."""
    rows = []
    for preset in presets:
        env_id = f"SoftArmTrack{preset[0].upper()}{preset[1:]}-v0"
        kwargs = engine_env_kwargs(env_id)
        row = {"preset": preset, "env_kwargs": kwargs}
        for label, algo, engine, n_envs, vec in ENGINE_RUNS:
            row[label] = learning(algo, env_id, batch if n_envs is None else n_envs, steps,
                                  {**kwargs, "engine": engine}, vec=vec,
                                  replace_env_kwargs=True)
            print(f"{preset}: {label}: {row[label]:.0f} env steps/s", flush=True)
        rows.append(row)
    return rows


def print_engine_table(rows: list[dict], batch: int) -> None:
    labels = [label.replace("PPO, batched", f"PPO, {batch} batched")
              for label, *_ in ENGINE_RUNS]
    print(f"{'preset':<10}" + "".join(f"{label:>30}" for label in labels))
    for row in rows:
        print(f"{row['preset']:<10}" + "".join(f"{row[label]:>30.0f}"
                                                for label, *_ in ENGINE_RUNS))
    print("ratios (MuJoCo over PyBullet): "
          + "; ".join(f"{row['preset']} PPO {row[ENGINE_RUNS[0][0]] / row[ENGINE_RUNS[1][0]]:.1f}x, "
                      f"SAC {row[ENGINE_RUNS[2][0]] / row[ENGINE_RUNS[3][0]]:.1f}x"
                      for row in rows))


def main(argv: list[str] | None = None) -> None:
    parser = CommandParser(description=__doc__, formatter_class=HelpFormatter)
    parser.add_argument("--algo", default="sac", help="algorithm (its train/configs entry)")
    parser.add_argument("--env", default="SoftArmTrackWang2023-v0", help="Gymnasium id")
    parser.add_argument("--steps", type=int, default=3000, help="timed env steps per run")
    parser.add_argument("--env-kwargs", nargs="*", default=[], metavar="KEY=VALUE",
                        help="env keyword arguments over the configuration's (YAML values)")
    parser.add_argument("--engines", nargs="+", choices=list(PRESETS), default=None,
                        metavar="PRESET",
                        help=f"compare the engines' training on these arms instead "
                             f"({', '.join(PRESETS)})")
    parser.add_argument("--batch", type=positive_int, default=16,
                        help="batched MuJoCo arms of the PPO run (with --engines)")
    args = parser.parse_args(argv)
    if args.steps < 1:
        parser.error(f"--steps must be an integer >= 1, got {args.steps}")
    try:
        overrides = parse_key_values(args.env_kwargs, "--env-kwargs")
    except ValueError as error:
        parser.error(str(error))
    torch.set_num_threads(1)
    if args.engines:
        print_engine_table(compare_engines(args.engines, args.steps, args.batch), args.batch)
        return
    settings = split_hyperparameters(args.algo, read_hyperparameters(args.algo, args.env))
    settings.env_kwargs.update(overrides)
    base = env_only(args.env, settings.env_kwargs, args.steps)
    one = learning(args.algo, args.env, 1, args.steps, overrides)
    two = learning(args.algo, args.env, 2, args.steps, overrides)
    print(f"{args.env} {settings.env_kwargs}")
    print(f"{'run':<22}{'env steps/s':>12}{'vs env only':>13}")
    for name, value in (("env only", base), (f"{args.algo} n_envs=1", one),
                        (f"{args.algo} n_envs=2", two)):
        print(f"{name:<22}{value:>12.1f}{value / base:>13.3f}")
    print(f"n_envs=2 / n_envs=1: {two / one:.2f}")


if __name__ == "__main__":
    main()
