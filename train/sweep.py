"""Search SAC hyperparameters with Ray Tune; write the best in rl-baselines3-zoo's format.

    python -m train sweep --env SoftArmTrackWang2023-v0 --trials 8 --steps 20000
    python -m train sweep --preset ho2018 --trials 16 --steps 50000 --address auto
    python -m train sweep --env SoftArmTrackWang2023-v0 --env-kwargs feedback=ground_truth \\
        -hp learning_starts=100 --trials 2 --steps 300 --out results/sweep_smoke

Each trial trains SAC with the project's trainer (:func:`train.trainer.train`) for ``--steps``
env steps from the env's entry of the config file (``train/configs/sac.yml`` by default, its
``default`` entry for an env without one), with ``--env-kwargs`` and ``-hp`` applied to every
trial and the trial's sampled values over them. The trained model (with its observation
normalisation) then runs ``--eval-episodes`` deterministic episodes on an env seeded apart from
training's, scored by ``--metric``:

* ``error_mm`` (default): the mean tip-to-target distance over every evaluation step (mm, lower
  is better), the benchmark's figure of merit;
* ``reward``: the mean episode return (higher is better).

Search space (:data:`SEARCH_SPACE`; where each value goes: :data:`PLACES`):

====================== ============================ ==========================================
hyperparameter         values                       meaning
====================== ============================ ==========================================
``learning_rate``      log-uniform in [1e-4, 1e-3]  Adam step size of actor, critics, entropy
``gamma``              0.8, 0.9, 0.95, 0.98         discount per control step (0.05 s)
``tau``                0.002, 0.005, 0.01, 0.02     Polyak averaging of the target critics,
                                                    per gradient step
``batch_size``         64, 128, 256                 transitions per gradient step
``train_freq``         1, 2, 4                      vector env steps between updates
``gradient_steps``     1, 2, 4                      gradient steps per update
``hidden_units``       64, 128, 256                 units of each of the actor's and critics'
                                                    two hidden layers (``policy_kwargs``'
                                                    ``net_arch=[n, n]``)
``action_rate_weight`` 0, 1e-4, 1e-3, 1e-2          the reward's action-rate penalty (an env
                                                    keyword argument; the score does not
                                                    include it)
====================== ============================ ==========================================

A trial trains on the entry's ``n_envs`` arms of one MuJoCo batch when the entry's env runs on
the ``mujoco`` engine (``python -m train --vec batched``), else on one env.

The first trial evaluates the config entry's own values when they lie in the space, so the best
is never worse than the current config on this budget. ``--search random`` (default) samples
the rest at random from ``--seed``; ``--search optuna`` uses Optuna's TPE through Ray Tune. All
trials train with the same seed, so they differ only in their hyperparameters.

Outputs in ``--out``:

* ``sac.yml``: ``{<env id>: entry}``, the entry as the config file has it with ``--env-kwargs``,
  ``-hp`` and the best trial's values applied (``n_timesteps`` stays the entry's full budget),
  usable as ``python -m train --conf-file <out>/sac.yml --env <env id>`` and
  ``python -m rl_zoo3.train --algo sac --env <env id> --gym-packages soft_gym --conf-file
  <out>/sac.yml``;
* ``trials.json``: the settings, the search space, every trial (values, scores, wall time,
  status) and the best one; ``trials.md``: the trials as a Markdown table, best first;
* ``tune/``: Ray Tune's experiment directory.

Where the trials run: a local Ray with ``--workers`` CPUs (one trial per CPU), or with
``--address`` an existing cluster (``auto``, ``ray://host:10001``, ``host:6379``), whose CPUs
all take trials. The package must be importable on every node (installed there, or shipped with
``ray job submit --working-dir . -- python -m train sweep ... --address auto``); trials train in
a temporary directory on their node and return only their scores. On a multi-node cluster give
``--storage`` a location every node can write (a shared path or ``s3://...``).

Ray Tune is an optional extra: ``pip install "soft-arm-gym[ray]"``.
"""

from __future__ import annotations

import argparse
import contextlib
import inspect
import json
import math
import os
import re
import sys
import tempfile
import time
from collections.abc import Iterator, Mapping
from dataclasses import asdict, dataclass, field, fields
from pathlib import Path
from typing import Any

import gymnasium
import numpy as np
import yaml
from tqdm import tqdm

import soft_gym  # noqa: F401  (registers the env ids)
from soft_gym._cli import (CommandParser, HelpFormatter, check_environment, check_output_dir,
                           seed_int)
from soft_gym._validation import SEED_MAX
from soft_gym.engines import REFERENCE_ENGINE, engine_supports
from soft_gym.envs.config import EnvConfig
from soft_gym.envs.registration import preset_env_id
from soft_gym.papers import DEFAULT_PRESET
from train.cli_options import (add_env_options, check_conf_file, check_env_kwargs,
                               check_hyperparameter_overrides, parse_env_and_hyperparameters,
                               randomization_hint, resolve_env_id)
from train.config import (algorithm_class, parse_python_value, read_hyperparameters,
                          split_hyperparameters)

ALGO = "sac"
INSTALL_HINT = 'pip install "soft-arm-gym[ray]"'
"""The install command of the optional extra (``ray[tune]``)."""

SEARCH_SPACE: dict[str, tuple] = {
    "learning_rate": ("loguniform", 1e-4, 1e-3),
    "gamma": ("choice", [0.8, 0.9, 0.95, 0.98]),
    "tau": ("choice", [0.002, 0.005, 0.01, 0.02]),
    "batch_size": ("choice", [64, 128, 256]),
    "train_freq": ("choice", [1, 2, 4]),
    "gradient_steps": ("choice", [1, 2, 4]),
    "hidden_units": ("choice", [64, 128, 256]),
    "action_rate_weight": ("choice", [0.0, 1e-4, 1e-3, 1e-2]),
}
"""Hyperparameter -> ``("loguniform", low, high)`` or ``("choice", values)`` (see the module
docstring for units)."""

PLACES: dict[str, str] = {"hidden_units": "policy_kwargs", "action_rate_weight": "env_kwargs"}
"""Where a searched value goes in a config entry when not a top-level hyperparameter of SAC:
inside ``policy_kwargs`` or the env's keyword arguments."""
SB3_SAC_NET_ARCH = [256, 256]
"""SB3's SAC network when ``policy_kwargs`` gives no ``net_arch`` (``SACPolicy``'s default)."""

METRICS = {"error_mm": "min", "reward": "max"}
"""Score -> Tune's mode (``min``: lower is better)."""
SEARCHES = ("random", "optuna")
EVAL_SEED_OFFSET = 20_000
"""The evaluation env's seed is the training seed plus this (training's own evaluation env
uses +10,000)."""
CONFIG_NAME = f"{ALGO}.yml"
TRIALS_NAME = "trials.json"
TABLE_NAME = "trials.md"


@dataclass
class SweepRequest:
    """What to search (the command line's options).

    Attributes:
        env_id: Gymnasium id (e.g. ``SoftArmTrackWang2023-v0``).
        env_kwargs: env keyword arguments over the config entry's.
        hyperparameters: fixed hyperparameters over the entry's, in every trial (not searched).
        trials: number of trials (>= 1).
        steps: env steps of training per trial (>= 1, more than ``learning_starts``).
        eval_episodes: evaluation episodes per trial (>= 1).
        seed: seed of training, of the search and (plus :data:`EVAL_SEED_OFFSET`) evaluation.
        metric: ``error_mm`` (mean tracking error, mm, minimised) or ``reward`` (mean episode
            return, maximised).
        search: ``random`` or ``optuna`` (TPE).
        workers: CPUs of the local Ray this starts (concurrent trials); ignored with ``address``.
        address: an existing Ray cluster, or ``None`` for a local Ray.
        out: output directory.
        storage: Ray Tune's storage (default ``<out>/tune``).
        config_file: hyperparameter YAML (default ``train/configs/sac.yml``).
        progress: show a progress bar over the trials.
    """

    env_id: str = preset_env_id("track", DEFAULT_PRESET)
    env_kwargs: dict = field(default_factory=dict)
    hyperparameters: dict = field(default_factory=dict)
    trials: int = 8
    steps: int = 20_000
    eval_episodes: int = 3
    seed: int = 0
    metric: str = "error_mm"
    search: str = "random"
    workers: int = 2
    address: str | None = None
    out: str = "results/sweep"
    storage: str | None = None
    config_file: str | None = None
    progress: bool = True


@dataclass
class SweepResult:
    """A finished sweep: the ``best`` trial, every trial, and the files written."""

    best: dict[str, Any]
    trials: list[dict[str, Any]]
    config_path: Path
    trials_path: Path
    wall_s: float


def require_tune():
    """The ``ray.tune`` module.

    Raises:
        ImportError: Ray Tune is not installed (one line naming the extra to install).
    """
    try:
        from ray import tune
    except ImportError as error:
        raise ImportError(f"python -m train sweep needs Ray Tune, an optional extra: "
                          f"{INSTALL_HINT}") from error
    return tune


def _is_int(value: Any) -> bool:
    return isinstance(value, int) and not isinstance(value, bool)


def base_entry(request: SweepRequest) -> dict[str, Any]:
    """The config entry the trials start from: the file's entry for the env with the request's
    ``env_kwargs`` and fixed ``hyperparameters`` applied.

    Raises:
        ValueError: a bad field of the request (naming it, its value and what is allowed).
    """
    for name in ("trials", "steps", "eval_episodes", "workers"):
        value = getattr(request, name)
        if not _is_int(value) or value < 1:
            raise ValueError(f"{name} must be an integer >= 1, got {value!r}")
    if not _is_int(request.seed) or not 0 <= request.seed <= SEED_MAX - EVAL_SEED_OFFSET:
        raise ValueError(f"seed must be an integer in [0, {SEED_MAX - EVAL_SEED_OFFSET}] (the "
                         f"evaluation uses seed + {EVAL_SEED_OFFSET}), got {request.seed!r}")
    if request.metric not in METRICS:
        raise ValueError(f"metric must be one of {list(METRICS)}, got {request.metric!r}")
    if request.search not in SEARCHES:
        raise ValueError(f"search must be one of {list(SEARCHES)}, got {request.search!r}")
    if request.address is not None and (not isinstance(request.address, str)
                                        or not request.address.strip()):
        raise ValueError(f"address must be a Ray address (auto, ray://host:10001, host:6379) "
                         f"or None, got {request.address!r}")
    searched = sorted(set(request.hyperparameters) & set(SEARCH_SPACE))
    if searched:
        raise ValueError(f"hyperparameters {searched} are searched (space: "
                         f"{sorted(SEARCH_SPACE)}); fix only others")
    for key in ("n_timesteps", "n_envs"):
        if key in request.hyperparameters:
            raise ValueError(f"hyperparameters may not set {key!r}: steps sets the trial budget "
                             f"and the config entry the arms (one env, or its n_envs on the "
                             f"mujoco engine)")
    searched_env = sorted(set(request.env_kwargs) & {k for k, v in PLACES.items()
                                                      if v == "env_kwargs"})
    if searched_env:
        raise ValueError(f"env_kwargs {searched_env} are searched (space: "
                         f"{sorted(SEARCH_SPACE)}); fix only others")
    if request.env_id not in gymnasium.registry:
        ids = sorted(name for name in gymnasium.registry if name.startswith("SoftArm"))
        raise ValueError(f"env_id must be a registered id (e.g. {ids[:4]}), got "
                         f"{request.env_id!r}")
    entry = read_hyperparameters(ALGO, request.env_id, request.config_file)
    entry.update(request.hyperparameters)
    env_kwargs = entry.get("env_kwargs") or {}
    if isinstance(env_kwargs, str):
        env_kwargs = parse_python_value(env_kwargs)
    entry["env_kwargs"] = {**env_kwargs, **request.env_kwargs}
    split_hyperparameters(ALGO, entry)  # refuses a malformed entry now, not in every trial
    learning_starts = int(entry.get("learning_starts", 100))  # SAC's default
    if request.steps <= learning_starts:
        raise ValueError(f"steps must exceed learning_starts ({learning_starts}) or no trial "
                         f"learns anything, got {request.steps}: raise steps or fix "
                         f"learning_starts=N among the hyperparameters")
    return entry


def _in_space(name: str, value: Any) -> bool:
    kind, *spec = SEARCH_SPACE[name]
    if kind == "choice":
        return value in spec[0]
    return (isinstance(value, (int, float)) and not isinstance(value, bool)
            and spec[0] <= value <= spec[1])


def _policy_kwargs(entry: Mapping[str, Any]) -> dict[str, Any]:
    value = entry.get("policy_kwargs") or {}
    return dict(parse_python_value(value) if isinstance(value, str) else value)


def entry_values(entry: Mapping[str, Any]) -> dict[str, Any]:
    """The entry's own values of the searched hyperparameters (SAC's and the env's defaults
    where the entry has none)."""
    # lazy: stable-baselines3 costs 1.2 s (-X importtime) that python -m train --help skips
    from stable_baselines3 import SAC

    defaults = {name: parameter.default for name, parameter
                in inspect.signature(SAC.__init__).parameters.items()}
    env_defaults = {f.name: f.default for f in fields(EnvConfig)}
    env_kwargs = entry.get("env_kwargs") or {}
    values = {}
    for name in SEARCH_SPACE:
        place = PLACES.get(name)
        if place == "policy_kwargs":
            net_arch = _policy_kwargs(entry).get("net_arch", SB3_SAC_NET_ARCH)
            two_equal = isinstance(net_arch, list) and len(net_arch) == 2 \
                and net_arch[0] == net_arch[1]
            values[name] = net_arch[0] if two_equal else net_arch  # else outside the space
        elif place == "env_kwargs":
            values[name] = env_kwargs.get(name, env_defaults[name])
        else:
            values[name] = entry.get(name, defaults.get(name))
    return values


def baseline_point(entry: Mapping[str, Any]) -> dict[str, Any] | None:
    """The entry's own values of the searched hyperparameters, or ``None`` when one is outside
    the space."""
    point = entry_values(entry)
    if all(_in_space(name, value) for name, value in point.items()):
        return point
    return None


def _with_net_arch(policy_kwargs: Any, net_arch: list[int]) -> Any:
    """``policy_kwargs`` (a mapping or rl-zoo3's ``"dict(...)"`` string, kept in its form)
    with ``net_arch`` set."""
    if isinstance(policy_kwargs, str):
        text = policy_kwargs.strip()
        if re.search(r"\bnet_arch\s*=", text):
            text = re.sub(r"\bnet_arch\s*=\s*\[[^\]]*\]", f"net_arch={net_arch}", text, count=1)
        else:
            inner = text[len("dict("):-1].strip()
            text = f"dict(net_arch={net_arch}" + (f", {inner})" if inner else ")")
        if parse_python_value(text).get("net_arch") != net_arch:  # a nested or odd net_arch
            raise ValueError(f"policy_kwargs {policy_kwargs!r}: cannot set net_arch={net_arch}")
        return text
    return {**(policy_kwargs or {}), "net_arch": list(net_arch)}


def apply_values(entry: Mapping[str, Any], values: Mapping[str, Any]) -> dict[str, Any]:
    """``entry`` with the searched ``values`` put where they belong (:data:`PLACES`)."""
    entry = dict(entry)
    for name, value in values.items():
        place = PLACES.get(name)
        if place == "policy_kwargs":
            entry["policy_kwargs"] = _with_net_arch(entry.get("policy_kwargs"),
                                                    [int(value), int(value)])
        elif place == "env_kwargs":
            entry["env_kwargs"] = {**(entry.get("env_kwargs") or {}), name: value}
        else:
            entry[name] = value
    return entry


def trial_arms(entry: Mapping[str, Any]) -> tuple[int, str]:
    """``(n_envs, vec)`` of a trial: the entry's arms in one batch when its env runs on an
    engine that steps arms as one batch (MuJoCo; :func:`soft_gym.engines.engine_supports`),
    else one env."""
    engine = (entry.get("env_kwargs") or {}).get("engine", REFERENCE_ENGINE)
    if engine_supports(engine, "batched"):
        return int(entry.get("n_envs", 1)), "batched"
    return 1, "subprocess"


def tune_space(tune) -> dict[str, Any]:
    """:data:`SEARCH_SPACE` as Ray Tune's sampling domains."""
    space = {}
    for name, (kind, *spec) in SEARCH_SPACE.items():
        space[name] = tune.loguniform(*spec) if kind == "loguniform" else tune.choice(spec[0])
    return space


def _plain(value: Any) -> Any:
    """A YAML/JSON-safe Python scalar (numpy numbers become ``int``/``float``)."""
    if hasattr(value, "item") and not isinstance(value, (list, dict, str)):
        value = value.item()
    return value


# ------------------------------------------------------------------------------ one trial
def evaluate_run(run_dir: str | os.PathLike, episodes: int, seed: int) -> dict[str, float]:
    """Run the model of a training run directory deterministically for ``episodes`` episodes.

    The env (id and keyword arguments) and the observation normalisation are the run's own;
    the env is seeded with ``seed``.

    Returns:
        ``{"error_mm": mean tip-to-target distance over every step (mm), "reward": mean
        episode return, "episodes", "eval_steps"}``.
    """
    # lazy: stable-baselines3 and train.trainer cost 1.3 s (-X importtime), see baseline_point
    from stable_baselines3.common.vec_env import VecNormalize

    from agents.policies.run_dir import CONFIG_FILE, MODEL_FILE, NORMALIZATION_FILE
    from train.trainer import make_vec_env

    run_dir = Path(run_dir)
    config = yaml.safe_load((run_dir / CONFIG_FILE).read_text())
    env = make_vec_env(config["env_id"], config["env_kwargs"], 1, seed)
    if (run_dir / NORMALIZATION_FILE).is_file():
        env = VecNormalize.load(str(run_dir / NORMALIZATION_FILE), env)
        env.training, env.norm_reward = False, False
    model = algorithm_class(config["algo"]).load(str(run_dir / MODEL_FILE), device="cpu")
    returns, errors, total = [], [], 0.0
    memory, starts = None, np.ones(1, dtype=bool)  # a recurrent agent's state (ppo_lstm)
    try:
        observation = env.reset()
        while len(returns) < episodes:
            action, memory = model.predict(observation, state=memory, episode_start=starts,
                                           deterministic=True)
            observation, reward, done, infos = env.step(action)
            starts = done
            total += float(reward[0])
            errors.append(float(infos[0]["error_mm"]))
            if done[0]:
                returns.append(total)
                total = 0.0
    finally:
        env.close()
    return {"error_mm": float(np.mean(errors)), "reward": float(np.mean(returns)),
            "episodes": len(returns), "eval_steps": len(errors)}


def run_trial(values: Mapping[str, Any], context: Mapping[str, Any]) -> dict[str, Any]:
    """Train one trial and score it (a Ray worker's job; runs without Ray too).

    Args:
        values: the sampled hyperparameters (names of :data:`SEARCH_SPACE`).
        context: ``env_id``, ``entry`` (:func:`base_entry`), ``steps``, ``seed``,
            ``eval_episodes`` and ``metric``.

    Returns:
        ``{"score", "error_mm", "reward", "episodes", "eval_steps", "train_wall_s",
        "wall_s"}`` (times in s); the run directory is deleted.
    """
    # lazy: train.trainer costs 1.3 s (-X importtime), see baseline_point
    from train.trainer import TrainRequest, train

    start = time.perf_counter()
    values = {name: _plain(value) for name, value in values.items()}
    entry = apply_values(context["entry"], values)
    n_envs, vec = trial_arms(entry)
    with tempfile.TemporaryDirectory(prefix="sweep_trial_") as work:
        config_file = Path(work) / CONFIG_NAME
        config_file.write_text(yaml.safe_dump({context["env_id"]: entry}, sort_keys=False))
        run_dir = train(TrainRequest(
            algo=ALGO, env_id=context["env_id"], timesteps=int(context["steps"]),
            seed=int(context["seed"]), n_envs=n_envs, vec=vec, config_file=str(config_file),
            out_dir=work, run_name="run", eval_freq=0, checkpoint_freq=0, threads=1,
            progress=False))
        trained = time.perf_counter()
        scores = evaluate_run(run_dir, int(context["eval_episodes"]),
                              int(context["seed"]) + EVAL_SEED_OFFSET)
    scores["score"] = scores[context["metric"]]
    scores["train_wall_s"] = trained - start
    scores["wall_s"] = time.perf_counter() - start
    return scores


def _tune_trial(config: dict[str, Any], context: Mapping[str, Any]) -> None:
    """Ray Tune's function trainable: one trial, reported once."""
    from ray import tune

    tune.report(run_trial(config, context))


# ------------------------------------------------------------------------------ the sweep
@contextlib.contextmanager
def ray_session(address: str | None, workers: int) -> Iterator[None]:
    """Ray for the sweep: the one already initialised in this process, else a connection to
    ``address`` or a local Ray of ``workers`` CPUs, shut down (disconnected) on exit."""
    import ray

    started = not ray.is_initialized()
    if started:
        if address is None:
            ray.init(num_cpus=workers, include_dashboard=False)
        else:
            ray.init(address=address, include_dashboard=False)
    try:
        yield
    finally:
        if started:
            ray.shutdown()


def _progress_callback(tune, total: int, enabled: bool):
    class Progress(tune.Callback):
        """A progress bar over the trials, advanced as each ends."""

        def __init__(self) -> None:
            self.bar = tqdm(total=total, desc="sweep", unit="trial", disable=not enabled)

        def on_trial_complete(self, iteration, trials, trial, **info) -> None:
            score = (trial.last_result or {}).get("score")
            if score is not None:
                self.bar.set_postfix_str(f"last score {score:.4g}", refresh=False)
            self.bar.update(1)

        def on_trial_error(self, iteration, trials, trial, **info) -> None:
            self.bar.update(1)

        def on_experiment_end(self, trials, **info) -> None:
            self.bar.close()

    return Progress()


def _search_algorithm(request: SweepRequest, point: dict[str, Any] | None):
    points = [point] if point is not None else None
    if request.search == "optuna":
        from ray.tune.search.optuna import OptunaSearch

        return OptunaSearch(points_to_evaluate=points, seed=request.seed)
    from ray.tune.search.basic_variant import BasicVariantGenerator

    return BasicVariantGenerator(points_to_evaluate=points, random_state=request.seed)


def _error_text(error: BaseException) -> str:
    """One line of a failed trial's error: the exception raised in the trial, not Ray's
    wrapper around it (its traceback is in Tune's trial directory)."""
    while getattr(error, "cause", None) is not None and error.cause is not error:
        error = error.cause
    lines = [line.strip() for line in str(error).strip().splitlines() if line.strip()]
    return f"{type(error).__name__}: {lines[-1] if lines else ''}"[:500]


def trials_table(trials: list[Mapping[str, Any]], metric: str) -> str:
    """A Markdown table of ``trials`` (best first; failed ones last with their error): each
    searched value, the score and the wall time."""
    mode = METRICS[metric]
    names = list(SEARCH_SPACE)

    def order(trial: Mapping[str, Any]) -> tuple:
        score = trial.get("score", math.nan)
        done = trial["status"] == "done" and math.isfinite(score)
        return (False, score if mode == "min" else -score) if done else (True, 0.0)

    def cell(value: Any) -> str:
        return f"{value:.3g}" if isinstance(value, float) else str(value)

    lines = ["| " + " | ".join(["trial", *names, metric, "wall (s)"]) + " |",
             "|" + "---|" * (len(names) + 3)]
    for trial in sorted(trials, key=order):
        values = trial["hyperparameters"]
        score = (f"{trial['score']:.4g}" if trial["status"] == "done"
                 else f"failed: {trial.get('error', '')}")
        wall = f"{trial['wall_s']:.0f}" if "wall_s" in trial else ""
        lines.append("| " + " | ".join([str(trial["trial_id"]),
                                        *(cell(values.get(n)) for n in names), score, wall])
                     + " |")
    return "\n".join(lines) + "\n"


def write_best_config(path: str | os.PathLike, env_id: str, entry: Mapping[str, Any],
                      header: str) -> Path:
    """Write ``{env_id: entry}`` in rl-baselines3-zoo's format, ``header`` as comment lines."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    comments = "".join(f"# {line}\n" if line else "#\n" for line in header.splitlines())
    body = yaml.safe_dump({env_id: {key: _plain(value) for key, value in entry.items()}},
                          sort_keys=False)
    path.write_text(comments + body)
    return path


def run_sweep(request: SweepRequest) -> SweepResult:
    """Run the search as ``request`` says and write ``sac.yml`` and ``trials.json``.

    Raises:
        ValueError: a bad request (before any trial).
        ImportError: Ray Tune (or, for ``search="optuna"``, Optuna) is not installed.
        RuntimeError: every trial failed (their errors are in ``trials.json``).
    """
    entry = base_entry(request)
    tune = require_tune()
    if request.search == "optuna":
        try:
            import optuna  # noqa: F401
        except ImportError as error:
            raise ImportError("search 'optuna' needs optuna: pip install optuna") from error
    out = Path(request.out)
    storage = request.storage or str((out / "tune").resolve())
    point = baseline_point(entry)
    context = {"env_id": request.env_id, "entry": entry, "steps": request.steps,
               "seed": request.seed, "eval_episodes": request.eval_episodes,
               "metric": request.metric}
    mode = METRICS[request.metric]
    start = time.perf_counter()
    # Tune's console output: the classic reporter, which verbose=0 silences (the progress bar
    # says what is going on); an explicit setting in the environment wins.
    os.environ.setdefault("RAY_AIR_NEW_OUTPUT", "0")
    with ray_session(request.address, request.workers):
        trainable = tune.with_resources(tune.with_parameters(_tune_trial, context=context),
                                        {"cpu": 1})
        tuner = tune.Tuner(
            trainable, param_space=tune_space(tune),
            tune_config=tune.TuneConfig(metric="score", mode=mode, num_samples=request.trials,
                                        search_alg=_search_algorithm(request, point)),
            run_config=tune.RunConfig(
                name=f"sweep_{ALGO}_{request.env_id}", storage_path=storage, verbose=0,
                callbacks=[_progress_callback(tune, request.trials, request.progress)]))
        grid = tuner.fit()
        trials = []
        for result in grid:
            metrics = dict(result.metrics or {})
            values = {name: _plain(result.config.get(name)) for name in SEARCH_SPACE}
            record = {"trial_id": metrics.get("trial_id") or Path(result.path).name,
                      "hyperparameters": values,
                      "status": "error" if result.error is not None else "done"}
            if result.error is not None:
                record["error"] = _error_text(result.error)
            for key in ("score", "error_mm", "reward", "episodes", "eval_steps",
                        "train_wall_s", "wall_s"):
                if key in metrics:
                    record[key] = _plain(metrics[key])
            trials.append(record)
    wall_s = time.perf_counter() - start
    trials.sort(key=lambda record: str(record["trial_id"]))
    finished = [t for t in trials if t["status"] == "done" and math.isfinite(t.get("score",
                                                                                    math.nan))]
    summary = {"algo": ALGO, "env_id": request.env_id, "metric": request.metric, "mode": mode,
               "request": {**asdict(request), "out": str(out)},
               "search_space": {name: list(spec) for name, spec in SEARCH_SPACE.items()},
               "base_entry": entry, "baseline_point": point, "trials": trials, "best": None,
               "wall_s": wall_s}
    trials_path = out / TRIALS_NAME
    out.mkdir(parents=True, exist_ok=True)
    if not finished:
        trials_path.write_text(json.dumps(summary, indent=2, default=str) + "\n")
        raise RuntimeError(f"all {len(trials)} trials failed (errors in {trials_path}); first: "
                           f"{trials[0].get('error') if trials else 'no trial ran'}")
    pick = min if mode == "min" else max
    best = pick(finished, key=lambda t: t["score"])
    summary["best"] = best
    trials_path.write_text(json.dumps(summary, indent=2, default=str) + "\n")
    (out / TABLE_NAME).write_text(trials_table(trials, request.metric))
    best_entry = apply_values(entry, best["hyperparameters"])
    unit = "mm, lower is better" if request.metric == "error_mm" else "higher is better"
    header = (f"Best of {len(trials)} SAC trials ({len(finished)} finished) of "
              f"`python -m train sweep` on {request.env_id}:\n"
              f"{request.metric} {best['score']:.6g} ({unit}) after {request.steps} training "
              f"steps, over {request.eval_episodes} evaluation episode(s), seed {request.seed}.\n"
              f"Searched: {', '.join(SEARCH_SPACE)}; every trial: {TRIALS_NAME}.\n"
              f"n_timesteps is the config entry's full budget, not the trials'.")
    config_path = write_best_config(out / CONFIG_NAME, request.env_id, best_entry, header)
    return SweepResult(best=best, trials=trials, config_path=config_path,
                       trials_path=trials_path, wall_s=wall_s)


# ------------------------------------------------------------------------------ command line
def build_parser() -> argparse.ArgumentParser:
    parser = CommandParser(prog="python -m train sweep", description=__doc__,
                                     formatter_class=HelpFormatter)
    add_env_options(parser)
    parser.add_argument("-hp", "--hyperparams", nargs="*", default=[], metavar="KEY=VALUE",
                        help="fixed hyperparameters of every trial, not searched (e.g. "
                             "learning_starts=500)")
    parser.add_argument("--conf-file", default=None,
                        help="hyperparameter YAML (default train/configs/sac.yml)")
    parser.add_argument("--trials", type=int, default=8, help="number of trials")
    parser.add_argument("--steps", type=int, default=20_000,
                        help="env steps of training per trial")
    parser.add_argument("--eval-episodes", type=int, default=3,
                        help="deterministic evaluation episodes per trial")
    parser.add_argument("--metric", default="error_mm", choices=list(METRICS),
                        help="score: mean tracking error (mm, minimised) or mean episode "
                             "return (maximised)")
    parser.add_argument("--search", default="random", choices=list(SEARCHES),
                        help="random sampling, or Optuna's TPE")
    parser.add_argument("--seed", type=seed_int, default=0, help="seed of training, search and "
                        "evaluation")
    parser.add_argument("--workers", type=int, default=max(1, min(2, os.cpu_count() or 1)),
                        help="CPUs of the local Ray, one trial each (ignored with --address)")
    parser.add_argument("--address", default=None, metavar="ADDR",
                        help="an existing Ray cluster (auto, ray://host:10001, host:6379); "
                             "default: a local Ray")
    parser.add_argument("--storage", default=None,
                        help="Ray Tune's storage (a shared path or s3://... on a multi-node "
                             "cluster); default: <out>/tune")
    parser.add_argument("--out", default="results/sweep", help="output directory")
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")
    return parser


def main(argv: list[str] | None = None) -> None:
    """``python -m train sweep``: one-line errors exit 2 before any trial (every option, each
    ``-hp`` key and value, the env built once with the env keyword arguments, the output and
    storage directories)."""
    parser = build_parser()
    args = parser.parse_args(argv)
    check_environment(parser)
    env_kwargs, hyperparameters = parse_env_and_hyperparameters(parser, args)
    args.env = resolve_env_id(parser, args)
    check_conf_file(parser, args.conf_file)
    check_output_dir(parser, "--out", args.out)
    if args.storage is not None and "://" not in args.storage:
        check_output_dir(parser, "--storage", args.storage)
    request = SweepRequest(
        env_id=args.env, env_kwargs=env_kwargs, hyperparameters=hyperparameters,
        trials=args.trials, steps=args.steps, eval_episodes=args.eval_episodes, seed=args.seed,
        metric=args.metric, search=args.search, workers=args.workers, address=args.address,
        out=args.out, storage=args.storage, config_file=args.conf_file,
        progress=not args.no_progress)
    options = {"trials": "--trials", "steps": "--steps", "eval_episodes": "--eval-episodes",
               "workers": "--workers", "seed": "--seed", "address": "--address",
               "hyperparameters": "--hyperparams", "env_kwargs": "--env-kwargs", "env_id": "--env",
               "config": "--conf-file"}
    try:
        base_entry(request)  # the request's own fields first: they name their option
    except ValueError as error:
        text = " ".join(str(error).split())
        name = text.split(" ", 1)[0]
        if name not in options:  # the entry's values: the file's or -hp's
            check_hyperparameter_overrides(parser, ALGO, hyperparameters)
            parser.error(f"--conf-file: {text}" if args.conf_file else text)
        parser.error(f"{options[name]}: {text}")
    check_hyperparameter_overrides(parser, ALGO, hyperparameters)
    entry = base_entry(request)
    check_env_kwargs(parser, args.env, entry["env_kwargs"],
                     {key: "--env-kwargs" for key in env_kwargs},
                     randomization_hint("--env-kwargs randomization="))
    try:
        require_tune()
        if request.search == "optuna":
            import optuna  # noqa: F401
    except ImportError as error:
        parser.error(" ".join(str(error).split()))
    try:
        result = run_sweep(request)
    except RuntimeError as error:
        print(f"error: {error}", file=sys.stderr)
        raise SystemExit(1) from error
    best = result.best
    values = ", ".join(f"{name}={value:.4g}" if isinstance(value, float) else f"{name}={value}"
                       for name, value in best["hyperparameters"].items())
    print(f"best of {len(result.trials)} trials: {args.metric} {best['score']:.4g} ({values}) "
          f"in {result.wall_s:.0f} s")
    print(f"best config: {result.config_path}")
    print(f"trials: {result.trials_path}")


__all__ = ["METRICS", "PLACES", "SEARCHES", "SEARCH_SPACE", "SweepRequest", "SweepResult",
           "apply_values", "base_entry", "baseline_point", "entry_values", "evaluate_run", "main",
           "require_tune", "run_sweep", "run_trial", "trial_arms", "trials_table", "tune_space",
           "write_best_config"]
