"""Train a stable-baselines3 agent on a soft-arm env and keep everything needed to reproduce it.

A run directory holds (:mod:`agents.policies.run_dir` names its files and writes the YAML ones):

* ``model.zip`` (final), ``best_model.zip`` (best evaluation), and checkpoints
  ``checkpoints/<algo>_<N>_steps.zip``;
* ``vecnormalize.pkl``, ``best_vecnormalize.pkl`` and
  ``checkpoints/<algo>_vecnormalize_<N>_steps.pkl`` beside them when observations are normalised
  (``sb3:PATH`` loads each model with its own);
* ``config.yaml``: the resolved algorithm, env id, env kwargs, hyperparameters, seed and envs;
* ``versions.yaml``: Python and package versions and the git revision;
* ``logs/`` (``progress.csv`` and TensorBoard events), ``monitor/`` (per-episode CSVs),
  ``eval/evaluations.npz``, and ``learning_curve.png``;
* with ``curve_freq`` (:mod:`train.tracking_curve`): ``eval/tracking_curve.csv``,
  ``tracking_curve.png`` and ``best_tracking_model.zip`` (with
  ``best_tracking_vecnormalize.pkl``);
* ``training.yaml``: one entry per training (a resumed run adds one): steps, wall time, env
  steps/s, envs, and the curve's evaluations, best error and whether it stopped at a plateau;
  a run started from a trained agent opens with that agent's entries
  (:mod:`train.warm_start`).

Ctrl-C (``KeyboardInterrupt``) stops training and keeps the run: the model so far is saved and
summarised as above, its ``training.yaml`` entry marked ``interrupted``.
"""

from __future__ import annotations

import copy
import platform
import subprocess
import time
from dataclasses import dataclass, field
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path

import gymnasium
import numpy as np
import stable_baselines3
import torch
import yaml
from stable_baselines3.common.callbacks import (BaseCallback, CallbackList, CheckpointCallback,
                                                EvalCallback)
from stable_baselines3.common.env_util import make_vec_env as sb3_make_vec_env
from stable_baselines3.common.logger import configure
from stable_baselines3.common.vec_env import DummyVecEnv, SubprocVecEnv, VecNormalize

import soft_gym  # noqa: F401  (registers the env ids)
from soft_gym.envs.registration import preset_env_id
from soft_gym.papers import DEFAULT_PRESET
from agents.policies.run_dir import (BEST_NORMALIZATION_FILE, CHECKPOINTS_DIR, CONFIG_FILE,
                                     MODEL_FILE, NORMALIZATION_FILE, REPLAY_BUFFER_FILE,
                                     append_training_segment, write_run_config,
                                     write_training_segments, write_versions)
from agents.policies.sb3 import mark_normalization
from soft_gym._distributions import REFERENCE_ENGINE_PACKAGE
from soft_gym.engines import REFERENCE_ENGINE, engine_supports
from train.batched import Sb3VectorEnv
from train.config import (OFF_POLICY, VEC_KINDS, TrainSettings, algorithm_class, batched_engines,
                          build_action_noise, read_hyperparameters, split_hyperparameters)
from train.curves import plot_learning_curve, plot_tracking_curve
from train.demonstrations import (load_demonstrations, record_demonstrations,
                                  start_from_demonstrations)
from train.progress import StepProgress
from train.tracking_curve import (PLATEAU_FRACTION, PLATEAU_IMPROVEMENT, TrackingCurveCallback,
                                  evaluation_cases)
from train.warm_start import (check_fits, find_trained_agent, inherited_segments,
                               load_trained_model)

DEMO_SEED_OFFSET = 20_000
"""Demonstrations are recorded on reset seeds ``seed + DEMO_SEED_OFFSET`` onward, apart from
the training envs' (``seed``...) and the evaluation env's (``seed + 10_000``)."""


@dataclass
class TrainRequest:
    """What to train (command-line options; ``None`` means "from the config file").

    Attributes:
        algo: ``sac``, ``td3``, ``ppo``, ``a2c`` or ``ddpg``.
        env_id: Gymnasium id (e.g. ``SoftArmTrackWang2023-v0``).
        env_kwargs: overrides of the config's ``env_kwargs``.
        hyperparameters: overrides of the config's hyperparameters.
        timesteps: total env steps (overrides ``n_timesteps``).
        seed: seed of the envs, the networks and the evaluation.
        n_envs: parallel envs (``SubprocVecEnv`` when > 1, or arms of one batch).
        vec: ``"subprocess"`` (SB3's ``SubprocVecEnv``/``DummyVecEnv``) or ``"batched"``
            (:class:`train.batched.Sb3VectorEnv`: ``n_envs`` MuJoCo arms in this process,
            stepped as one batch; needs ``engine="mujoco"`` in the env kwargs).
        config_file: hyperparameter YAML (default ``train/configs/<algo>.yml``).
        out_dir: where run directories are made.
        run_name: the run directory's name (default ``<algo>_<env>_seed<seed>``).
        resume: an earlier run directory to continue from.
        eval_freq: env steps between evaluations (0: none).
        eval_episodes: episodes per evaluation.
        checkpoint_freq: env steps between checkpoints (0: none).
        threads: torch threads.
        progress: show a progress bar.
        demos: a baseline whose rollouts on the training env seed the agent (off-policy
            algorithms; :mod:`train.demonstrations`), or ``None``.
        demo_dataset: instead, a Minari dataset id of demonstrations with the training env's
            spaces (under ``demo_root``, default the package's datasets root).
        demo_root: where ``demo_dataset`` lies (recordings go to ``<run_dir>/demonstrations``).
        demo_episodes: episodes of ``demos`` to record.
        demo_params: the ``demos`` baseline's keyword arguments.
        bc_epochs: behaviour-cloning epochs of the actor on the demonstrations.
        critic_warmup: critic gradient steps on the demonstrations with the actor held.
        trained_agent: a trained agent (run directory, model ``.zip`` or shipped agent name)
            whose weights and VecNormalize statistics start the run, which then trains on its
            own env and hyperparameters (:mod:`train.warm_start`), or ``None``: a new model.
        curve_freq: env steps between tracking evaluations (:mod:`train.tracking_curve`; 0:
            none; a track env only).
        until_plateau: stop once the tracking curve has flattened
            (:func:`train.tracking_curve.has_plateaued`); ``timesteps`` is then the most.
        plateau_fraction: the plateau rule's share of the latest steps (0.2).
        plateau_improvement: the plateau rule's relative improvement (0.05).
        min_timesteps: env steps before the plateau rule may stop training.
        save_replay_buffer: also save an off-policy run's replay buffer
            (:data:`~agents.policies.run_dir.REPLAY_BUFFER_FILE`, all of its ``buffer_size``
            transitions preallocated: tens of MB, 45 MB for SAC on the track envs) beside the
            model, so that ``resume`` continues with the transitions gathered so far; without it
            a resumed run starts with an empty buffer. A resumed run that had one saved keeps
            saving it.
    """

    algo: str = "sac"
    env_id: str = preset_env_id("track", DEFAULT_PRESET)
    env_kwargs: dict = field(default_factory=dict)
    hyperparameters: dict = field(default_factory=dict)
    timesteps: int | None = None
    seed: int = 0
    n_envs: int | None = None
    vec: str = "subprocess"
    config_file: str | None = None
    out_dir: str = "results/train"
    run_name: str | None = None
    resume: str | None = None
    eval_freq: int = 10_000
    eval_episodes: int = 2
    checkpoint_freq: int = 50_000
    threads: int = 1
    progress: bool = True
    demos: str | None = None
    demo_dataset: str | None = None
    demo_root: str | None = None
    demo_episodes: int = 4
    demo_params: dict = field(default_factory=dict)
    bc_epochs: int = 100
    critic_warmup: int = 2000
    trained_agent: str | None = None
    curve_freq: int = 0
    until_plateau: bool = False
    plateau_fraction: float = PLATEAU_FRACTION
    plateau_improvement: float = PLATEAU_IMPROVEMENT
    min_timesteps: int = 0
    save_replay_buffer: bool = False

    @property
    def uses_demonstrations(self) -> bool:
        """Whether the agent starts from demonstrations (``demos`` or ``demo_dataset``)."""
        return self.demos is not None or self.demo_dataset is not None


def resolve(request: TrainRequest) -> tuple[TrainSettings, dict]:
    """The settings of a request: config entry, then the request's overrides."""
    hyperparameters = read_hyperparameters(request.algo, request.env_id, request.config_file)
    hyperparameters.update(request.hyperparameters)
    if request.timesteps is not None:
        hyperparameters["n_timesteps"] = request.timesteps
    if request.n_envs is not None:
        hyperparameters["n_envs"] = request.n_envs
    settings = split_hyperparameters(request.algo, hyperparameters)
    settings.env_kwargs.update(request.env_kwargs)
    return settings, hyperparameters


def versions() -> dict[str, str]:
    """Python, package versions and the git revision of this checkout."""
    info = {"python": platform.python_version(), "platform": platform.platform(),
            "gymnasium": gymnasium.__version__, "stable_baselines3": stable_baselines3.__version__,
            "torch": str(torch.__version__), "numpy": np.__version__}
    for package in (REFERENCE_ENGINE_PACKAGE, "soft-arm-gym"):
        try:
            info[package] = version(package)
        except PackageNotFoundError:
            info[package] = "unknown"
    root = Path(__file__).resolve().parent.parent
    try:
        revision = subprocess.run(["git", "rev-parse", "HEAD"], cwd=root, capture_output=True,
                                  text=True, check=True).stdout.strip()
        dirty = subprocess.run(["git", "status", "--porcelain"], cwd=root, capture_output=True,
                               text=True, check=True).stdout.strip()
        info["git_revision"] = revision + ("-dirty" if dirty else "")
    except (OSError, subprocess.CalledProcessError):
        info["git_revision"] = "unknown"
    return info


def make_vec_env(env_id: str, env_kwargs: dict, n_envs: int, seed: int,
                 monitor_dir: str | None = None, vec: str = "subprocess",
                 per_arm: list[dict] | None = None):
    """``n_envs`` monitored envs: in subprocesses when there are several (``vec="subprocess"``),
    or the arms of one MuJoCo batch (``vec="batched"``), each arm with its own keyword
    arguments over ``env_kwargs`` where ``per_arm`` gives them (a batch's ``per_env_kwargs``;
    the recipe's ``arm_env_kwargs``)."""
    if vec not in VEC_KINDS:
        raise ValueError(f"vec must be one of {list(VEC_KINDS)}, got {vec!r}")
    if per_arm is not None and vec != "batched":
        raise ValueError("arm_env_kwargs gives the arms of one batch their own env keyword "
                         f"arguments: train with --vec batched (and {batched_engines()}), got "
                         f"vec={vec!r}")
    if vec == "batched":
        batched = Sb3VectorEnv(env_id.split(":")[-1], n_envs, monitor_dir=monitor_dir,
                               per_env_kwargs=per_arm, **env_kwargs)
        batched.seed(seed)
        return batched
    if not engine_supports(env_kwargs.get("engine", REFERENCE_ENGINE), "rendering"):
        # SB3 asks for rgb_array frames, which an engine without cameras cannot give
        env_kwargs = {"render_mode": None, **env_kwargs}
    vec_cls = SubprocVecEnv if n_envs > 1 else DummyVecEnv
    kwargs = {"start_method": "spawn"} if n_envs > 1 else {}
    if ":" not in env_id:
        env_id = f"soft_gym:{env_id}"  # subprocesses import the package that registers the ids
    return sb3_make_vec_env(env_id, n_envs=n_envs, seed=seed, env_kwargs=env_kwargs,
                            monitor_dir=monitor_dir, vec_env_cls=vec_cls,
                            vec_env_kwargs=kwargs or None,
                            wrapper_kwargs=None)


def model_kwargs(settings: TrainSettings, env) -> dict:
    """The settings' keyword arguments of the algorithm, its action noise built for ``env``."""
    kwargs = dict(settings.algo_kwargs)
    if "action_noise" in kwargs:
        kwargs["action_noise"] = build_action_noise(kwargs["action_noise"],
                                                    env.action_space.shape[0])
    return kwargs


def new_model(algo: str, settings: TrainSettings, env, seed: int):
    """A fresh ``algo`` model on ``env`` with the settings' hyperparameters (action noise built)."""
    return algorithm_class(algo)(settings.policy, env, seed=seed, verbose=0,
                                 **model_kwargs(settings, env))


def train(request: TrainRequest) -> Path:
    """Train (or resume) as ``request`` says; returns the run directory."""
    torch.set_num_threads(max(1, int(request.threads)))
    if request.resume is not None:
        run_dir = Path(request.resume)
        missing = [name for name in (CONFIG_FILE, MODEL_FILE) if not (run_dir / name).is_file()]
        if missing:
            raise ValueError(f"resume {str(run_dir)!r} holds no {' or '.join(missing)}: give "
                             f"the run directory of an earlier training")
        saved = yaml.safe_load((run_dir / CONFIG_FILE).read_text())
        # the buffer goes on being saved where it was, or where this resume asks for it
        keep_buffer = (bool(saved["request"].get("save_replay_buffer"))
                       or request.save_replay_buffer or (run_dir / REPLAY_BUFFER_FILE).is_file())
        request = TrainRequest(**{**saved["request"], "resume": str(run_dir),
                                  "timesteps": request.timesteps, "progress": request.progress,
                                  "save_replay_buffer": keep_buffer})
        settings, hyperparameters = resolve(request)
    else:
        settings, hyperparameters = resolve(request)
        name = request.run_name or f"{request.algo}_{request.env_id}_seed{request.seed}"
        run_dir = Path(request.out_dir) / name
        if (run_dir / CONFIG_FILE).exists():
            raise ValueError(f"run directory {str(run_dir)!r} already holds a run: pick another "
                             "run_name or pass resume")
    if request.save_replay_buffer and request.algo not in OFF_POLICY:
        raise ValueError(f"save_replay_buffer: {request.algo} keeps no replay buffer (only "
                         f"{list(OFF_POLICY)} do)")
    run_dir.mkdir(parents=True, exist_ok=True)
    algo_cls = algorithm_class(request.algo)
    start = None
    if request.resume is None and request.trained_agent is not None:
        start = find_trained_agent(request.trained_agent, request.algo)

    env = make_vec_env(request.env_id, settings.env_kwargs, settings.n_envs, request.seed,
                       monitor_dir=str(run_dir / "monitor"), vec=request.vec,
                       per_arm=settings.per_arm_env_kwargs())
    if start is not None:
        try:
            check_fits(start, env, normalized=settings.normalize is not None)
        except ValueError:
            env.close()
            raise
    eval_env = make_vec_env(request.env_id, {**settings.env_kwargs, **settings.arm_variants()[0]},
                            1, request.seed + 10_000)
    if settings.normalize is not None:
        if request.resume is not None and (run_dir / NORMALIZATION_FILE).exists():
            env = VecNormalize.load(str(run_dir / NORMALIZATION_FILE), env)
        elif start is not None and start.normalization_path is not None:
            env = VecNormalize.load(str(start.normalization_path), env)
            env.training = True  # the statistics go on adapting to the new observations
        else:
            env = VecNormalize(env, **settings.normalize)
        eval_env = VecNormalize(eval_env, training=False, norm_reward=False,
                                **{k: v for k, v in settings.normalize.items()
                                   if k not in ("norm_reward", "training")})

    if request.resume is not None:
        model = algo_cls.load(str(run_dir / MODEL_FILE), env=env)
        if request.algo in OFF_POLICY and (run_dir / REPLAY_BUFFER_FILE).exists():
            model.load_replay_buffer(str(run_dir / REPLAY_BUFFER_FILE))
        elif request.algo in OFF_POLICY:
            print(f"resume: {str(run_dir)!r} holds no {REPLAY_BUFFER_FILE} (the run was trained "
                  "without --save-replay-buffer): continuing with an empty replay buffer",
                  flush=True)
    elif start is not None:
        model = load_trained_model(start, algo_cls, env, model_kwargs(settings, env),
                                   request.seed)
    else:
        model = new_model(request.algo, settings, env, request.seed)
    # every save (final, best, checkpoints) carries it: a bare model.zip copied without its
    # statistics is then refused by sb3:PATH rather than run on raw observations
    mark_normalization(model, settings.normalize is not None)
    model.set_logger(configure(str(run_dir / "logs"), ["csv", "tensorboard"]))
    demo_report = None
    if request.resume is None and request.uses_demonstrations:
        demo_report = _start_from_demonstrations(request, settings, model, env, run_dir)

    write_run_config(run_dir, {
        "request": {key: value for key, value in vars(request).items()
                    if key not in ("resume", "progress")},
        "algo": request.algo, "env_id": request.env_id,
        "env_kwargs": copy.deepcopy(settings.env_kwargs),
        "hyperparameters": hyperparameters, "seed": request.seed, "n_envs": settings.n_envs,
    })
    write_versions(run_dir, versions())
    if start is not None and start.segments:  # the steps that made the agent count too
        write_training_segments(run_dir, inherited_segments(start))

    callbacks: list[BaseCallback] = [ThroughputCallback()]
    if request.progress:
        callbacks.append(StepProgress(settings.n_timesteps, f"{request.algo} {request.env_id}"))
    curve = None
    if request.curve_freq > 0:
        curve = TrackingCurveCallback(
            request.env_id, settings.env_kwargs,
            evaluation_cases(settings.env_kwargs, settings.arm_variants()),
            request.curve_freq, run_dir, until_plateau=request.until_plateau,
            fraction=request.plateau_fraction, min_improvement=request.plateau_improvement,
            min_timesteps=request.min_timesteps,
            evaluate_at_start=start is not None)
        callbacks.append(curve)
    if request.eval_freq > 0:
        callbacks.append(EvalCallback(
            eval_env, best_model_save_path=str(run_dir), log_path=str(run_dir / "eval"),
            eval_freq=max(1, request.eval_freq // settings.n_envs),
            n_eval_episodes=request.eval_episodes, deterministic=True,
            callback_on_new_best=SaveNormalization(run_dir / BEST_NORMALIZATION_FILE)))
    if request.checkpoint_freq > 0:
        callbacks.append(CheckpointCallback(
            save_freq=max(1, request.checkpoint_freq // settings.n_envs),
            save_path=str(run_dir / CHECKPOINTS_DIR), name_prefix=request.algo,
            save_vecnormalize=settings.normalize is not None))
    started = time.perf_counter()
    interrupted = False
    try:
        model.learn(total_timesteps=settings.n_timesteps, callback=CallbackList(callbacks),
                    reset_num_timesteps=request.resume is None)
    except KeyboardInterrupt:  # Ctrl-C: keep the run so far (saved and summarised below)
        interrupted = True
        print(f"\ninterrupted at {model.num_timesteps} steps: saving the run", flush=True)
    elapsed = time.perf_counter() - started
    model.save(str(run_dir / MODEL_FILE))
    if settings.normalize is not None:
        model.get_vec_normalize_env().save(str(run_dir / NORMALIZATION_FILE))
    if request.algo in OFF_POLICY and request.save_replay_buffer:
        model.save_replay_buffer(str(run_dir / REPLAY_BUFFER_FILE))
    summary = {"timesteps": int(model.num_timesteps), "wall_s": round(elapsed, 1),
               "env_steps_per_s": round(callbacks[0].steps / max(elapsed, 1e-9), 1),
               "n_envs": settings.n_envs, **(demo_report or {})}
    if interrupted:
        summary["interrupted"] = True
    if curve is not None and curve.errors_mm:
        summary.update({"curve_evaluations": len(curve.errors_mm),
                        "best_tracking_mm": round(min(curve.errors_mm), 4),
                        "stopped_at_plateau": curve.plateaued,
                        "curve_evaluation_s": round(curve.evaluation_s, 1),
                        "training_env_steps_per_s": round(
                            callbacks[0].steps / max(elapsed - curve.evaluation_s, 1e-9), 1)})
    append_training_segment(run_dir, summary)
    env.close()
    eval_env.close()
    plot_learning_curve(run_dir, title=f"{request.algo.upper()} on {request.env_id}")
    if curve is not None and curve.errors_mm:
        plot_tracking_curve(run_dir, title=f"{request.algo.upper()} on {request.env_id}")
    return run_dir


def _start_from_demonstrations(request: TrainRequest, settings: TrainSettings, model, env,
                               run_dir: Path) -> dict:
    """Record (or read) the demonstrations and start ``model`` from them
    (:mod:`train.demonstrations`); returns the report for ``training.yaml``."""
    if request.algo not in OFF_POLICY:
        raise ValueError(f"demonstrations seed an off-policy agent's actor and replay buffer: "
                         f"algo must be one of {list(OFF_POLICY)}, got {request.algo!r}")
    started = time.perf_counter()
    if request.demo_dataset is not None:
        dataset_id, root = request.demo_dataset, request.demo_root
    else:
        root = str(run_dir / "demonstrations")
        dataset_id = record_demonstrations(
            request.env_id, settings.env_kwargs, request.demos, episodes=request.demo_episodes,
            seed=request.seed + DEMO_SEED_OFFSET, root=root, policy_params=request.demo_params,
            progress=request.progress)
    demos = load_demonstrations(dataset_id, root, env)
    report = start_from_demonstrations(model, demos, bc_epochs=request.bc_epochs,
                                       critic_warmup=request.critic_warmup, seed=request.seed,
                                       progress=request.progress)
    report["demo_wall_s"] = round(time.perf_counter() - started, 1)
    return report


class SaveNormalization(BaseCallback):
    """``callback_on_new_best``: save the normalisation statistics beside the best model."""

    def __init__(self, path: Path) -> None:
        super().__init__()
        self.path = Path(path)

    def _on_step(self) -> bool:
        normalization = self.model.get_vec_normalize_env()
        if normalization is not None:
            normalization.save(str(self.path))
        return True


class ThroughputCallback(BaseCallback):
    """Counts the env steps of one ``learn`` call (for the env steps/s figure)."""

    def __init__(self) -> None:
        super().__init__()
        self.steps = 0

    def _on_step(self) -> bool:
        self.steps += self.training_env.num_envs
        return True
