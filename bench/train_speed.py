"""Training throughput: env steps per second of SAC with 1 and 2 envs, beside the env alone.

Measured side by side in one run on the same env configuration (default: the shipped agents'
training env, wang2023 tracking with EM feedback and domain randomisation):

1. **env only**: random actions through a ``DummyVecEnv`` of one env (no learning);
2. **SAC, n_envs=1**: ``python -m train``'s setup (VecNormalize, one gradient step per env step);
3. **SAC, n_envs=2**: two envs in ``SubprocVecEnv`` workers; one gradient step per vector step,
   i.e. per two env steps (SB3's ``train_freq`` counts vector steps).

Each learning run first fills ``learning_starts`` steps (not timed), then times ``--steps`` env
steps. ``--env-kwargs KEY=VALUE`` overrides the env's keyword arguments, as ``python -m train``
does (e.g. ``feedback=fused`` for the camera + FBG pipeline). Example::

    python bench/train_speed.py --steps 3000
    python bench/train_speed.py --steps 1000 --env-kwargs feedback=fused
"""

from __future__ import annotations

import argparse
import tempfile
import time

import numpy as np
import torch

from soft_gym._cli import HelpFormatter
from train.config import parse_key_values, read_hyperparameters, split_hyperparameters
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
             env_kwargs: dict | None = None) -> float:
    from stable_baselines3.common.vec_env import VecNormalize

    settings = split_hyperparameters(algo, read_hyperparameters(algo, env_id))
    settings.env_kwargs.update(env_kwargs or {})
    with tempfile.TemporaryDirectory() as monitor_dir:
        env = make_vec_env(env_id, settings.env_kwargs, n_envs, seed=0, monitor_dir=monitor_dir)
        if settings.normalize is not None:
            env = VecNormalize(env, **settings.normalize)
        model = new_model(algo, settings, env, seed=0)
        warmup = int(settings.algo_kwargs.get("learning_starts", 0)) + 200
        model.learn(warmup)
        start = time.perf_counter()
        model.learn(steps, reset_num_timesteps=False)
        elapsed = time.perf_counter() - start
        env.close()
    return steps / elapsed


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=HelpFormatter)
    parser.add_argument("--algo", default="sac", help="algorithm (its train/configs entry)")
    parser.add_argument("--env", default="SoftArmTrackWang2023-v0", help="Gymnasium id")
    parser.add_argument("--steps", type=int, default=3000, help="timed env steps per run")
    parser.add_argument("--env-kwargs", nargs="*", default=[], metavar="KEY=VALUE",
                        help="env keyword arguments over the configuration's (YAML values)")
    args = parser.parse_args(argv)
    try:
        overrides = parse_key_values(args.env_kwargs, "--env-kwargs")
    except ValueError as error:
        parser.error(str(error))
    torch.set_num_threads(1)
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
