"""Copy a trained run into the repository as a shipped agent (``agents/trained/<name>/``).

    python -m train.ship results/train/sac_wang2023_track sac_wang2023_track --model best
    python -m train.ship --evaluate sac_wang2023_track     (write its evaluation again)

Only what loading and provenance need is kept: the model, its VecNormalize statistics, the
resolved config, versions, the training summary and the learning curve (no replay buffer or
checkpoints, so the repository stays small), and ``evaluation.yaml``: the agent's nominal
tracking error by :func:`nominal_evaluation`, which
``tests/agents/policies/test_shipped_agents.py`` checks the agent against (within 20 %).
"""

from __future__ import annotations

import argparse
import shutil
from pathlib import Path

import gymnasium as gym
import numpy as np
import yaml

import soft_gym  # noqa: F401  (registers the env ids)
from agents.policies import (SHIPPED_DIR, BaselinePolicy, make_policy, mark_model_file,
                             model_normalization_mark, normalization_file, resolve_sb3_path)
from agents.policies.run_dir import (BEST_MODEL_FILE, BEST_TRACKING_MODEL_FILE, CONFIG_FILE,
                                     EVALUATION_FILE, MODEL_FILE, NORMALIZATION_FILE, SOURCE_FILE,
                                     TRAINING_FILE, VERSIONS_FILE)
from agents.rollout import run_episode
from soft_gym._cli import CommandParser, HelpFormatter
from soft_gym.engines import ENGINES, REFERENCE_ENGINE, EngineFeatureError
from train.tracking_curve import CURVE_FILE

MODEL_CHOICES = {"final": MODEL_FILE, "best": BEST_MODEL_FILE,
                 "best_tracking": BEST_TRACKING_MODEL_FILE}
"""Which model of a run to ship: the final one, SB3's best evaluated (by return), or the best on
the tracking curve (:mod:`train.tracking_curve`), each with its normalisation statistics
(:func:`~agents.policies.sb3.normalization_file`)."""
EVALUATION_SEED = 123


class _PrePressure(BaselinePolicy):
    """Every chamber held at its pre-pressure (action -1 in the absolute mode): the error an
    agent that tracks must stay far below."""

    name = "pre_pressure"

    def __init__(self, env: gym.Env) -> None:
        self.env = env.unwrapped
        self._action = -np.ones(env.action_space.shape, np.float32)

    def predict(self, observation, state=None, episode_start=None, deterministic: bool = True):
        return self._action.copy(), None


def _agent_directory(agent: str | Path) -> Path:
    """The directory of an agent given as a path or a shipped agent's name
    (:func:`~agents.policies.resolve_sb3_path`), refused unless it holds config.yaml."""
    directory = resolve_sb3_path(agent)
    if not (directory / CONFIG_FILE).is_file():
        raise ValueError(f"agent {str(agent)!r} is neither a directory holding config.yaml nor a "
                         f"shipped agent in {SHIPPED_DIR}")
    return directory


def training_engine(config: dict) -> str:
    """The physics engine an agent trained on (its run's env keyword ``engine``, default
    PyBullet)."""
    return config["env_kwargs"].get("engine", REFERENCE_ENGINE)


def nominal_evaluation(agent: str | Path, engine: str | None = None) -> dict:
    """A shipped agent's nominal tracking: one episode (:func:`agents.rollout.run_episode`) of the
    env it trained on, with its recipe's keyword arguments less the randomisation (its feedback
    and path, no load), reset with seed 123, deterministic actions.

    Args:
        agent: the agent's directory, or a shipped agent's name.
        engine: the physics engine to run it on (one of :data:`soft_gym.engines.ENGINES`);
            ``None``, the one it trained on.

    Returns:
        ``settled_error_mm``, the mean tip error (mm) after the first quarter of the steps (the
        start from rest left out); ``resting_error_mm``, the mean error of holding every
        chamber at its pre-pressure over the same episode; the env id and keyword arguments
        (``engine`` among them where it is not the training engine), the reset seed and the
        steps.

    Raises:
        ValueError: an agent without its ``config.yaml``, or an unknown ``engine``.
    """
    directory = _agent_directory(agent)
    config = yaml.safe_load((directory / CONFIG_FILE).read_text())
    env_kwargs = {key: value for key, value in config["env_kwargs"].items()
                  if key != "randomization"}
    if engine is not None and engine != training_engine(config):
        if engine not in ENGINES:
            raise ValueError(f"engine must be one of {sorted(ENGINES)}, got {engine!r}")
        env_kwargs["engine"] = engine
    env = gym.make(config["env_id"], **env_kwargs)
    try:
        errors = run_episode(env, make_policy(f"sb3:{directory}", env=env),
                             seed=EVALUATION_SEED)["error_mm"]
        resting = run_episode(env, _PrePressure(env), seed=EVALUATION_SEED)["error_mm"]
    finally:
        env.close()
    return {"settled_error_mm": float(errors[len(errors) // 4:].mean()),
            "resting_error_mm": float(resting.mean()), "env_id": config["env_id"],
            "env_kwargs": env_kwargs, "reset_seed": EVALUATION_SEED, "steps": int(len(errors))}


def engine_gap(directory: str | Path) -> dict:
    """The agent's nominal error (:func:`nominal_evaluation`) on every engine that runs its env:
    ``{"training_engine": name, "settled_error_mm": {engine: mm}}``, the sim-to-sim gap beside
    the engine it trained on (an engine that lacks a feature of its env is left out)."""
    config = yaml.safe_load((Path(directory) / CONFIG_FILE).read_text())
    errors = {}
    for engine in ENGINES:
        try:
            errors[engine] = nominal_evaluation(directory, engine)["settled_error_mm"]
        except EngineFeatureError:  # e.g. camera feedback on an engine without cameras
            pass
    return {"training_engine": training_engine(config), "settled_error_mm": errors}


def write_evaluation(directory: str | Path) -> dict:
    """Evaluate the agent in ``directory`` (:func:`nominal_evaluation`, and on every engine,
    :func:`engine_gap`) and write the result to its ``evaluation.yaml``; returns it."""
    evaluation = {**nominal_evaluation(directory), "engines": engine_gap(directory)}
    text = ("# Nominal tracking of this agent, written by python -m train.ship (train/ship.py,\n"
            "# nominal_evaluation); tests/agents/policies/test_shipped_agents.py checks the\n"
            "# agent against settled_error_mm (within 20 %). engines: the same episode on\n"
            "# each physics engine, beside the one it trained on (the sim-to-sim gap).\n")
    (Path(directory) / EVALUATION_FILE).write_text(text + yaml.safe_dump(evaluation,
                                                                         sort_keys=False))
    return evaluation


def ship(run_dir: str | Path, name: str, model: str = "final",
         destination: str | Path = SHIPPED_DIR, evaluate: bool = True) -> Path:
    """Copy ``run_dir``'s final, best or best-tracking model (``model``, one of
    :data:`MODEL_CHOICES`) with its provenance and curves to ``destination/name``, and
    (``evaluate``) write its nominal evaluation there (:func:`write_evaluation`)."""
    run_dir = Path(run_dir)
    if model not in MODEL_CHOICES:
        raise ValueError(f"model must be one of {list(MODEL_CHOICES)}, got {model!r}")
    model_file = MODEL_CHOICES[model]
    statistics = normalization_file(run_dir / model_file)
    if not (run_dir / model_file).is_file() or not (run_dir / CONFIG_FILE).is_file():
        raise ValueError(f"run_dir {str(run_dir)!r} holds no {model_file} with a config.yaml")
    target = Path(destination) / name
    target.mkdir(parents=True, exist_ok=True)
    shutil.copy(run_dir / model_file, target / MODEL_FILE)
    normalized = statistics.is_file()
    if normalized:
        shutil.copy(statistics, target / NORMALIZATION_FILE)
    if model_normalization_mark(target / MODEL_FILE) is None:  # a model saved before the mark
        mark_model_file(target / MODEL_FILE, normalized)
    for extra in (CONFIG_FILE, VERSIONS_FILE, TRAINING_FILE, "learning_curve.png",
                  "tracking_curve.png", CURVE_FILE):
        if (run_dir / extra).is_file():
            (target / extra).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy(run_dir / extra, target / extra)
    (target / SOURCE_FILE).write_text(f"{model} model of run {run_dir.name}\n")
    if evaluate:
        write_evaluation(target)
    return target


def main(argv: list[str] | None = None) -> None:
    parser = CommandParser(prog="python -m train.ship", description=__doc__,
                                     formatter_class=HelpFormatter)
    parser.add_argument("run_dir", nargs="?", help="a run directory of python -m train")
    parser.add_argument("name", nargs="?", help="the shipped agent's name (sb3:<name> loads it)")
    parser.add_argument("--model", choices=list(MODEL_CHOICES), default="final",
                        help="the final model, the best evaluated one (by return), or the best "
                             "on the tracking curve (a run with --curve-freq)")
    parser.add_argument("--evaluate", nargs="+", default=None, metavar="AGENT",
                        help="instead of shipping, write the evaluation.yaml of agents already "
                             "shipped (names or directories)")
    args = parser.parse_args(argv)
    if args.evaluate is not None:
        if args.run_dir is not None:
            parser.error("--evaluate takes agents already shipped: give no run_dir or name")
        directories = [resolve_sb3_path(agent) for agent in args.evaluate]
        for agent, directory in zip(args.evaluate, directories):
            if not all((directory / file).is_file() for file in (MODEL_FILE, CONFIG_FILE)):
                parser.error(f"--evaluate: {agent!r} is not a shipped agent (no model.zip with a "
                             f"config.yaml in {directory})")
        for directory in directories:
            evaluation = write_evaluation(directory)
            print(f"{directory}: settled error {evaluation['settled_error_mm']:.2f} mm "
                  f"(resting {evaluation['resting_error_mm']:.2f} mm)")
        return
    if args.run_dir is None or args.name is None:
        parser.error("give run_dir and name (or --evaluate AGENT)")
    try:
        print(ship(args.run_dir, args.name, args.model))
    except ValueError as error:
        parser.error(str(error))


if __name__ == "__main__":
    main()
