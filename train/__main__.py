"""Train a stable-baselines3 agent on a soft-arm env.

    python -m train --algo sac --env SoftArmTrackWang2023-v0 --timesteps 200000 --seed 0
    python -m train --algo td3 --preset wang2023 --env-kwargs feedback=em 'path=[circle,pentagram]' --randomize
    python -m train --resume results/train/sac_SoftArmTrackWang2023-v0_seed0 --timesteps 50000
    python -m train --algo ppo_lstm --trained-agent ppo_lstm_wang2023_track --env-kwargs feedback=fused
    python -m train sweep --env SoftArmTrackWang2023-v0 --trials 8 --steps 20000   (Ray Tune;
        python -m train sweep --help, train/sweep.py)

Hyperparameters come from train/configs/<algo>.yml (rl-baselines3-zoo's format: the same file
works with ``python -m rl_zoo3.train --conf-file ...``); ``-hp KEY=VALUE`` overrides single
entries and ``--env-kwargs KEY=VALUE`` the env's keyword arguments (values are YAML: numbers,
true/false, [lists], {dicts}; quote those from the shell, where brackets are file patterns). The
run directory (``--out``/``--name``) gets the model, its VecNormalize statistics, checkpoints,
the best evaluated model, TensorBoard and CSV logs, the resolved config, versions and git
revision, and learning_curve.png; its path is printed at the end. An off-policy run's replay
buffer (tens of MB) is saved only with ``--save-replay-buffer``, for ``--resume`` to continue with
it.

Every option is checked before training starts (one line naming the option, the value and what
is allowed, exit status 2): counts and frequencies, the env id or preset, the config file, each
``-hp`` key (refused unless the algorithm takes it, naming those it does) and value (``gamma`` in
(0, 1], ``learning_rate`` > 0, ``batch_size`` an integer >= 1, ...), the env keyword arguments
(the env is built once, without calibration), the output directory, and a ``--resume`` run
directory (it must hold config.yaml and model.zip). An option that applies only with another is
refused when given without it, even at its default (``--bc-epochs``, ``--critic-warmup`` without
``--demos`` or ``--demo-dataset``; ``--plateau-fraction``, ``--plateau-improvement``,
``--min-timesteps`` without ``--until-plateau``), and so are curve options that cannot act within
the run's steps: a ``--curve-freq`` above them (no curve would be written), a ``--min-timesteps``
not below them or too few evaluations for the plateau rule (``--until-plateau`` could never stop
the run).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import yaml

from agents.policies.run_dir import CONFIG_FILE, MODEL_FILE
from soft_gym._cli import (CommandParser, HelpFormatter, check_environment, check_file, check_output_dir, fail,
                           finite_float, non_negative_int, positive_int, seed_int)
from soft_gym.engines import REFERENCE_ENGINE, engine_supports
from train.cli_options import (add_env_options, check_arm_env_kwargs, check_conf_file,
                               check_env_kwargs, check_hyperparameter_overrides,
                               parse_env_and_hyperparameters, randomization_hint, resolve_env_id)
from train.config import ALGORITHMS, OFF_POLICY, VEC_KINDS, batched_engines, parse_key_values
from train.sweep import main as sweep_main


class Given(argparse.Action):
    """Store the value and add the option's ``dest`` to ``args.given``: an option that applies
    only with another is refused when given without it, even at its default value (which
    argparse alone cannot tell from leaving it out)."""

    def __call__(self, parser, namespace, values, option_string=None):
        setattr(namespace, self.dest, values)
        namespace.given = namespace.given | {self.dest}


def build_parser() -> argparse.ArgumentParser:
    parser = CommandParser(prog="python -m train", description=__doc__,
                                     formatter_class=HelpFormatter)
    parser.set_defaults(given=frozenset())
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
    parser.add_argument("--timesteps", type=positive_int, default=None,
                        help="env steps to train, >= 1 (default: the config's n_timesteps)")
    parser.add_argument("--seed", type=seed_int, default=0,
                        help="seed of envs, networks, evaluation (integer >= 0)")
    parser.add_argument("--n-envs", type=positive_int, default=None,
                        help="parallel envs, >= 1 (default: the config's n_envs)")
    parser.add_argument("--vec", choices=VEC_KINDS, default="subprocess",
                        help="how the --n-envs envs run: 'subprocess' (one process each) or "
                             "'batched' (arms stepped as one batch in this process; needs "
                             f"--env-kwargs {batched_engines()})")
    parser.add_argument("--eval-freq", type=non_negative_int, default=10_000,
                        help="env steps between evaluations (0: none)")
    parser.add_argument("--eval-episodes", type=positive_int, default=2,
                        help="episodes per evaluation (>= 1)")
    parser.add_argument("--curve-freq", type=non_negative_int, default=0,
                        help="env steps between tracking evaluations: the mean last-cycle error "
                             "on the recipe's paths, nominal and with a load from its "
                             "randomised range, written to eval/tracking_curve.csv and "
                             "tracking_curve.png, the best kept as best_tracking_model.zip "
                             "(0: none; track envs; train/tracking_curve.py)")
    parser.add_argument("--until-plateau", action="store_true",
                        help="stop once the tracking curve has flattened: the last "
                             "--plateau-fraction of the steps lowered the best error by under "
                             "--plateau-improvement of it (needs --curve-freq; --timesteps is "
                             "then the most it may take)")
    parser.add_argument("--plateau-fraction", type=finite_float(0.0, 1.0, True, True),
                        default=0.2, action=Given,
                        help="the plateau rule's share of the latest steps, in (0, 1) (with "
                             "--until-plateau)")
    parser.add_argument("--plateau-improvement", type=finite_float(0.0, 1.0, True, True),
                        default=0.05, action=Given,
                        help="the plateau rule's relative improvement, in (0, 1) (with "
                             "--until-plateau)")
    parser.add_argument("--min-timesteps", type=non_negative_int, default=0, action=Given,
                        help="env steps before --until-plateau may stop training (a curve flat "
                             "before learning takes hold is not a plateau), below the run's "
                             "steps")
    parser.add_argument("--checkpoint-freq", type=non_negative_int, default=50_000,
                        help="env steps between checkpoints (0: none)")
    parser.add_argument("--threads", type=positive_int, default=1, help="torch threads (>= 1)")
    parser.add_argument("--out", default="results/train",
                        help="directory of run directories (made; must be writable)")
    parser.add_argument("--name", default=None,
                        help="run directory name (default <algo>_<env>_seed<seed>); a directory "
                             "already holding a run is refused")
    parser.add_argument("--resume", default=None, metavar="RUN_DIR",
                        help="continue a run (a directory holding config.yaml and model.zip) "
                             "for --timesteps more steps (model and normalisation restored, and "
                             "the replay buffer where the run saved one: "
                             "--save-replay-buffer)")
    parser.add_argument("--save-replay-buffer", action="store_true",
                        help="also save an off-policy run's (sac, td3, ddpg) replay buffer, "
                             "replay_buffer.pkl beside the model: tens of MB (its whole "
                             "buffer_size; 45 MB for SAC on a track env), needed only for "
                             "--resume to continue with the transitions gathered so far "
                             "(without it a resumed run starts with an empty buffer). A "
                             "resumed run that saved one keeps saving it; with --resume this "
                             "starts saving it")
    parser.add_argument("-i", "--trained-agent", default=None, metavar="AGENT",
                        help="start a new run from a trained agent's weights and normalisation "
                             "statistics (a run directory, a model .zip or a shipped agent's "
                             "name, e.g. one of agents/trained/), trained on this run's env and "
                             "hyperparameters; its training segments open this run's "
                             "training.yaml (train/warm_start.py)")
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")
    demos = parser.add_argument_group(
        "starting from demonstrations (off-policy algorithms; train/demonstrations.py)")
    demos.add_argument("--demos", default=None, metavar="BASELINE",
                       help="a baseline (e.g. hybrid_gpr, lwpr_rwr) whose episodes on the "
                            "training env seed the agent: recorded as a Minari dataset in the "
                            "run directory, cloned into the actor, put in the replay buffer")
    demos.add_argument("--demo-dataset", default=None, metavar="ID",
                       help="instead of --demos, a Minari dataset of demonstrations with the "
                            "training env's spaces (e.g. a suite's --record minari output)")
    demos.add_argument("--demo-root", default=None, metavar="DIR",
                       help="the datasets root --demo-dataset lies under (default: the "
                            "package's, python -m eval datasets --help)")
    demos.add_argument("--demo-episodes", type=positive_int, default=4, action=Given,
                       help="episodes of --demos to record (>= 1)")
    demos.add_argument("--demo-params", nargs="*", default=[], metavar="KEY=VALUE",
                       help="the --demos baseline's parameters (e.g. kp=0.06)")
    demos.add_argument("--bc-epochs", type=non_negative_int, default=100, action=Given,
                       help="behaviour-cloning epochs of the actor on the demonstrations")
    demos.add_argument("--critic-warmup", type=non_negative_int, default=2000, action=Given,
                       help="critic gradient steps on the demonstrations, actor held")
    return parser


def check_demonstrations(parser: argparse.ArgumentParser, args: argparse.Namespace) -> dict:
    """``--demos`` / ``--demo-dataset`` and their options; returns the baseline's parameters."""
    from agents.policies import BASELINES  # lazy, as train.trainer: --help skips it

    given = [option for option, value in (("--demos", args.demos),
                                          ("--demo-dataset", args.demo_dataset)) if value]
    if not given:
        extra = [option for option, value, default in (
            ("--demo-root", args.demo_root, None), ("--demo-params", args.demo_params, []))
            if value != default]
        extra += [f"--{dest.replace('_', '-')}" for dest in ("bc_epochs", "critic_warmup",
                                                             "demo_episodes")
                  if dest in args.given]
        if extra:
            parser.error(f"{extra[0]} applies with --demos or --demo-dataset, given neither")
        return {}
    if args.demos is None and "demo_episodes" in args.given:
        parser.error("--demo-episodes is how many episodes --demos records: it applies with "
                     "--demos, not with --demo-dataset (whose episodes are all read)")
    if len(given) == 2:
        parser.error("--demos and --demo-dataset: give one (record a baseline, or read a "
                     "dataset)")
    if args.algo not in OFF_POLICY:
        parser.error(f"{given[0]} seeds an off-policy agent's actor and replay buffer: --algo "
                     f"must be one of {list(OFF_POLICY)}, got {args.algo!r}")
    if args.demos is not None and args.demos not in BASELINES:
        parser.error(f"--demos must be a baseline ({', '.join(BASELINES)}), got "
                     f"{args.demos!r}")
    if args.demo_dataset is not None:
        from soft_gym.datasets.store import load_dataset

        try:
            load_dataset(args.demo_dataset, args.demo_root)
        except ValueError as error:
            fail(parser, "--demo-dataset", error)
    try:
        return parse_key_values(args.demo_params, "--demo-params")
    except ValueError as error:
        parser.error(str(error))


def check_resume(parser: argparse.ArgumentParser, run_dir: str) -> None:
    """``--resume``: a run directory of ``python -m train`` (config.yaml with its request, and
    model.zip)."""
    path = Path(run_dir)
    if not path.is_dir():
        parser.error(f"--resume {run_dir!r} is not a directory: give the run directory of an "
                     f"earlier python -m train")
    missing = [name for name in (CONFIG_FILE, MODEL_FILE) if not (path / name).is_file()]
    if missing:
        parser.error(f"--resume {run_dir!r} holds no {' or '.join(missing)}: give the run "
                     f"directory of an earlier python -m train")
    try:
        saved = yaml.safe_load((path / CONFIG_FILE).read_text())
    except yaml.YAMLError as error:
        fail(parser, "--resume", f"{run_dir!r}: config.yaml is not YAML: {error}")
    if not isinstance(saved, dict) or not isinstance(saved.get("request"), dict):
        parser.error(f"--resume {run_dir!r}: config.yaml has no 'request' (not written by "
                     f"python -m train)")
    check_output_dir(parser, "--resume", path)


def check_trained_agent(parser: argparse.ArgumentParser, args: argparse.Namespace, env_id: str,
                        settings) -> None:
    """``--trained-agent``: an agent of ``--algo`` that reads the run's observations and writes
    its actions, normalised as the run is (one line naming the option otherwise)."""
    from soft_gym.envs.uncalibrated import make_uncalibrated_env
    from train.warm_start import check_fits, find_trained_agent

    env = make_uncalibrated_env(env_id, {**settings.env_kwargs, **settings.arm_variants()[0]})
    try:
        check_fits(find_trained_agent(args.trained_agent, args.algo), env,
                   normalized=settings.normalize is not None)
    except ValueError as error:
        arm = getattr(error, "trained_preset", None)  # an agent of another arm: the option to it
        fail(parser, "--trained-agent",
             f"{error}" + ("" if arm is None else f"; {_arm_option(args, env_id, arm)}"))
    finally:
        env.close()


def _arm_option(args: argparse.Namespace, env_id: str, preset: str) -> str:
    """The option that trains on the arm ``preset`` instead of ``env_id``'s: ``--preset`` without
    ``--env``; an alias id's counterpart (``--env SoftArmTrackZhao2021-v0``); ``preset=`` among
    the env keyword arguments of a generic id."""
    from soft_gym.envs.registration import TASK_IDS, preset_env_id

    if args.env is None:
        return f"--preset {preset}"
    task = next((name for name, generic in TASK_IDS.items()
                 if env_id == generic or env_id.startswith(generic[:-3])), "track")
    if env_id in TASK_IDS.values():
        return f"--env-kwargs preset={preset}"
    return f"--env {preset_env_id(task, preset)}"


def check_curve_options(parser: argparse.ArgumentParser, args: argparse.Namespace) -> None:
    """The tracking curve's options: the plateau rule's only with ``--until-plateau``, and that
    only with ``--curve-freq``."""
    if args.until_plateau and args.curve_freq == 0:
        parser.error("--until-plateau stops on the tracking curve: give --curve-freq N (env "
                     "steps between its evaluations, >= 1)")
    if not args.until_plateau:
        for dest in ("min_timesteps", "plateau_fraction", "plateau_improvement"):
            if dest in args.given:
                parser.error(f"--{dest.replace('_', '-')} applies with --until-plateau, which "
                             f"is not given")


def check_curve_budget(parser: argparse.ArgumentParser, args: argparse.Namespace,
                       timesteps: int) -> None:
    """``--curve-freq``, ``--until-plateau`` and ``--min-timesteps`` against the run's
    ``timesteps`` (``--timesteps``, or the config's ``n_timesteps``): a curve that would never
    be written, or a plateau rule that could never stop the run, is refused."""
    from train.tracking_curve import MIN_EVALUATIONS  # lazy: stable-baselines3 (see main)

    budget = ("--timesteps" if args.timesteps is not None
              else f"the config's n_timesteps, {'--conf-file' if args.conf_file else '--algo'}")
    if args.curve_freq > timesteps:
        parser.error(f"--curve-freq {args.curve_freq} is more than the run's {timesteps} env "
                     f"steps ({budget}): no tracking curve would be written; give --curve-freq "
                     f"<= {timesteps} or more --timesteps")
    if not args.until_plateau:
        return
    if args.min_timesteps >= timesteps:
        parser.error(f"--min-timesteps {args.min_timesteps} is not below the run's {timesteps} "
                     f"env steps ({budget}): --until-plateau could never stop the run; give "
                     f"--min-timesteps < {timesteps} or more --timesteps")
    # a run started from a trained agent evaluates it once before the first step
    evaluations = timesteps // args.curve_freq + (args.trained_agent is not None)
    if evaluations < MIN_EVALUATIONS:
        parser.error(f"--until-plateau needs {MIN_EVALUATIONS} tracking evaluations before it "
                     f"may stop the run, and --curve-freq {args.curve_freq} makes "
                     f"{evaluations} in its {timesteps} env steps ({budget}): give a smaller "
                     f"--curve-freq or more --timesteps")


def check_training(parser: argparse.ArgumentParser, args: argparse.Namespace,
                   env_kwargs: dict, hyperparameters: dict):
    """Every check of a new training run before it starts; returns its :class:`TrainRequest`."""
    # lazy: train.trainer (stable-baselines3, PyTorch) costs 1.3 s (-X importtime); --help skips it
    from train.trainer import TrainRequest, resolve

    env_id = resolve_env_id(parser, args)
    check_curve_options(parser, args)
    check_conf_file(parser, args.conf_file)
    if args.randomization_config is not None:
        check_file(parser, "--randomization-config", args.randomization_config,
                   "a randomisation YAML file (e.g. train/configs/randomization.yaml)")
    check_hyperparameter_overrides(parser, args.algo, hyperparameters)
    if args.save_replay_buffer and args.algo not in OFF_POLICY:
        parser.error(f"--save-replay-buffer saves an off-policy agent's replay buffer: --algo "
                     f"must be one of {list(OFF_POLICY)}, got {args.algo!r} (which keeps none)")
    check_output_dir(parser, "--out", args.out)
    request = TrainRequest(
        algo=args.algo, env_id=env_id, env_kwargs=env_kwargs, hyperparameters=hyperparameters,
        timesteps=args.timesteps, seed=args.seed, n_envs=args.n_envs, vec=args.vec,
        config_file=args.conf_file,
        out_dir=args.out, run_name=args.name, resume=None, eval_freq=args.eval_freq,
        eval_episodes=args.eval_episodes, checkpoint_freq=args.checkpoint_freq,
        threads=args.threads, progress=not args.no_progress, demos=args.demos,
        demo_dataset=args.demo_dataset, demo_root=args.demo_root,
        demo_episodes=args.demo_episodes, demo_params=check_demonstrations(parser, args),
        bc_epochs=args.bc_epochs, critic_warmup=args.critic_warmup,
        trained_agent=args.trained_agent, curve_freq=args.curve_freq,
        until_plateau=args.until_plateau,
        plateau_fraction=args.plateau_fraction, plateau_improvement=args.plateau_improvement,
        min_timesteps=args.min_timesteps, save_replay_buffer=args.save_replay_buffer)
    if args.curve_freq and not env_id.startswith("SoftArmTrack"):
        parser.error(f"--curve-freq evaluates tracking of a path: --env must be a track env "
                     f"(SoftArmTrack...), got {env_id!r}")
    try:
        settings, _ = resolve(request)
    except ValueError as error:  # the config file's entry (the overrides passed above)
        fail(parser, "--conf-file" if args.conf_file else "--algo", error)
    check_curve_budget(parser, args, settings.n_timesteps)
    randomization = ("--randomization-config" if args.randomization_config is not None
                     else "--randomize" if args.randomize else "--env-kwargs")
    overrides = {key: randomization if key == "randomization" else "--env-kwargs"
                 for key in env_kwargs}
    engine = settings.env_kwargs.get("engine", REFERENCE_ENGINE)
    if args.vec == "batched" and not engine_supports(engine, "batched"):
        parser.error(f"--vec batched steps arms as one batch: add --env-kwargs "
                     f"{batched_engines()} (got engine={engine!r})")
    check_env_kwargs(parser, env_id, settings.env_kwargs, overrides,
                     randomization_hint("--randomization-config "))
    check_arm_env_kwargs(parser, env_id, settings, args.vec,
                         "--conf-file" if args.conf_file else "--algo")
    if args.trained_agent is not None:
        check_trained_agent(parser, args, env_id, settings)
    name = args.name or f"{args.algo}_{env_id}_seed{args.seed}"
    if name.strip() in ("", ".", ".."):
        parser.error(f"--name must name a run directory, got {name!r}")
    if (Path(args.out) / name / CONFIG_FILE).exists():
        parser.error(f"--name: run directory {str(Path(args.out) / name)!r} already holds a "
                     f"run: give another --name or --out, or continue it with --resume")
    return request


def main(argv: list[str] | None = None) -> None:
    """``python -m train`` (and ``python -m train sweep ...``): check every option, then train."""
    argv = sys.argv[1:] if argv is None else list(argv)
    if argv[:1] == ["sweep"]:  # the one subcommand; every other form trains as before
        sweep_main(argv[1:])
        return
    parser = build_parser()
    args = parser.parse_args(argv)
    check_environment(parser)
    # lazy: train.trainer (stable-baselines3, PyTorch) costs 1.3 s (-X importtime); --help skips it
    from train.trainer import TrainRequest, train

    env_kwargs, hyperparameters = parse_env_and_hyperparameters(parser, args)
    if args.randomization_config is not None:
        env_kwargs["randomization"] = args.randomization_config
    elif args.randomize:
        env_kwargs["randomization"] = True
    if args.resume is not None:
        if args.timesteps is None:
            parser.error("--resume needs --timesteps (how many more steps to train)")
        if args.demos is not None or args.demo_dataset is not None:
            parser.error("--demos and --demo-dataset start a new run; --resume continues one "
                         "(its replay buffer, where it saved one with --save-replay-buffer, "
                         "holds the demonstrations)")
        if args.trained_agent is not None:
            parser.error("--trained-agent starts a new run; --resume continues one (from its "
                         "own model)")
        check_resume(parser, args.resume)
        request = TrainRequest(resume=args.resume, timesteps=args.timesteps,
                               progress=not args.no_progress,
                               save_replay_buffer=args.save_replay_buffer)
    else:
        if args.trained_agent is not None and (args.demos or args.demo_dataset):
            parser.error("--trained-agent starts from an agent's weights; --demos and "
                         "--demo-dataset from a baseline's episodes: give one")
        request = check_training(parser, args, env_kwargs, hyperparameters)
    try:
        run_dir = train(request)
    except ValueError as error:
        print(f"error: {error}", file=sys.stderr)
        raise SystemExit(2) from error
    print(f"run directory: {run_dir}")


if __name__ == "__main__":
    main()
