"""Train a stable-baselines3 agent on a soft-arm env.

    python -m train --algo sac --env SoftArmTrackWang2023-v0 --timesteps 200000 --seed 0
    python -m train --algo td3 --preset wang2023 --env-kwargs feedback=em 'path=[circle,pentagram]' --randomize
    python -m train --resume results/train/sac_SoftArmTrackWang2023-v0_seed0 --timesteps 50000
    python -m train sweep --env SoftArmTrackWang2023-v0 --trials 8 --steps 20000   (Ray Tune;
        python -m train sweep --help, train/sweep.py)

Hyperparameters come from train/configs/<algo>.yml (rl-baselines3-zoo's format: the same file
works with ``python -m rl_zoo3.train --conf-file ...``); ``-hp KEY=VALUE`` overrides single
entries and ``--env-kwargs KEY=VALUE`` the env's keyword arguments (values are YAML: numbers,
true/false, [lists], {dicts}; quote those from the shell, where brackets are file patterns). The
run directory (``--out``/``--name``) gets the model, its VecNormalize statistics, checkpoints,
the best evaluated model, TensorBoard and CSV logs, the resolved config, versions and git
revision, and learning_curve.png; its path is printed at the end.
"""

from __future__ import annotations

import argparse
import sys

from soft_gym._cli import HelpFormatter
from train.cli_options import add_env_options, parse_env_and_hyperparameters
from train.config import ALGORITHMS


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="python -m train", description=__doc__,
                                     formatter_class=HelpFormatter)
    parser.add_argument("--algo", default="sac", choices=ALGORITHMS, help="SB3 algorithm")
    add_env_options(parser)
    parser.add_argument("--randomize", action="store_true",
                        help="turn domain randomisation on (env kwarg randomization=true)")
    parser.add_argument("--randomization-config", default=None, metavar="YAML",
                        help="ranges of the randomisation (e.g. train/configs/randomization.yaml)")
    parser.add_argument("-hp", "--hyperparams", nargs="*", default=[], metavar="KEY=VALUE",
                        help="hyperparameters over the config's (e.g. learning_rate=3e-4)")
    parser.add_argument("--conf-file", default=None,
                        help="hyperparameter YAML (default train/configs/<algo>.yml)")
    parser.add_argument("--timesteps", type=int, default=None,
                        help="env steps to train (default: the config's n_timesteps)")
    parser.add_argument("--seed", type=int, default=0, help="seed of envs, networks, evaluation")
    parser.add_argument("--n-envs", type=int, default=None,
                        help="parallel envs in subprocesses (default: the config's n_envs)")
    parser.add_argument("--eval-freq", type=int, default=10_000,
                        help="env steps between evaluations (0: none)")
    parser.add_argument("--eval-episodes", type=int, default=2, help="episodes per evaluation")
    parser.add_argument("--checkpoint-freq", type=int, default=50_000,
                        help="env steps between checkpoints (0: none)")
    parser.add_argument("--threads", type=int, default=1, help="torch threads")
    parser.add_argument("--out", default="results/train", help="directory of run directories")
    parser.add_argument("--name", default=None,
                        help="run directory name (default <algo>_<env>_seed<seed>)")
    parser.add_argument("--resume", default=None, metavar="RUN_DIR",
                        help="continue a run for --timesteps more steps (model, replay buffer "
                             "and normalisation restored)")
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")
    return parser


def main(argv: list[str] | None = None) -> None:
    argv = sys.argv[1:] if argv is None else list(argv)
    if argv[:1] == ["sweep"]:  # the one subcommand; every other form trains as before
        from train.sweep import main as sweep_main

        sweep_main(argv[1:])
        return
    parser = build_parser()
    args = parser.parse_args(argv)
    from train.trainer import TrainRequest, train

    env_kwargs, hyperparameters = parse_env_and_hyperparameters(parser, args)
    if args.randomization_config is not None:
        env_kwargs["randomization"] = args.randomization_config
    elif args.randomize:
        env_kwargs["randomization"] = True
    if args.resume is not None and args.timesteps is None:
        parser.error("--resume needs --timesteps (how many more steps to train)")
    if args.env is None:
        from soft_gym.envs.registration import preset_env_id

        args.env = preset_env_id("track", args.preset)
    request = TrainRequest(
        algo=args.algo, env_id=args.env, env_kwargs=env_kwargs, hyperparameters=hyperparameters,
        timesteps=args.timesteps, seed=args.seed, n_envs=args.n_envs, config_file=args.conf_file,
        out_dir=args.out, run_name=args.name, resume=args.resume, eval_freq=args.eval_freq,
        eval_episodes=args.eval_episodes, checkpoint_freq=args.checkpoint_freq,
        threads=args.threads, progress=not args.no_progress)
    try:
        run_dir = train(request)
    except ValueError as error:
        print(f"error: {error}", file=sys.stderr)
        raise SystemExit(2) from error
    print(f"run directory: {run_dir}")


if __name__ == "__main__":
    main()
