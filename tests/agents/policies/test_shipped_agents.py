"""Every shipped SB3 agent (``agents/trained/<name>``): it loads on its arm's env, it was trained
by the recipe its config file names (``train/configs/<algo>.yml``, or the ``--conf-file`` it
was trained with), and it tracks its path: over
one clean episode with its recipe's feedback its mean tip error is well below the path's own
size, far below holding the arm at its pre-pressure, and within 20 % of its recorded
evaluation; and it ships the tracking curve its training stopped on, flattened (the last 20 % of
the steps improved its best error by under 5 %)."""

from __future__ import annotations

from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
import yaml

import soft_gym  # noqa: F401
from agents.policies import SHIPPED_DIR, make_policy
from agents.policies.run_dir import EVALUATION_FILE
from train.ship import nominal_evaluation
from train.tracking_curve import read_curve

AGENTS = sorted(path.name for path in SHIPPED_DIR.iterdir() if (path / "model.zip").is_file())

LONG_CALIBRATIONS = {"strain_sr": "zhao2021's shape reconstruction: an exploration and two "
                                  "networks, about 13 minutes on a fresh machine, then cached"}
"""Feedback sources whose first calibration is too long for the default test run: an agent
judged with one runs its episodes with ``-m slow`` only (its loading is tested by default)."""


def _agent_params() -> list:
    params = []
    for name in AGENTS:
        config = yaml.safe_load((SHIPPED_DIR / name / "config.yaml").read_text())
        feedback = (config.get("env_kwargs") or {}).get("feedback")
        marks = [pytest.mark.slow] if feedback in LONG_CALIBRATIONS else []
        params.append(pytest.param(name, marks=marks))
    return params


def test_every_new_arm_has_a_shipped_agent():
    arms = {yaml.safe_load((SHIPPED_DIR / name / "config.yaml").read_text())["env_id"]
            for name in AGENTS}
    assert {"SoftArmTrackWang2023-v0", "SoftArmTrackHo2018-v0", "SoftArmTrackZhao2021-v0",
            "SoftArmTrackZou2022-v0"} <= arms, arms


@pytest.mark.parametrize("name", AGENTS)
def test_a_shipped_agent_carries_a_tracking_curve_that_flattened(name):
    """Its training stopped on its curve, not on a clock: ``eval/tracking_curve.csv`` and its
    plot are shipped, and the last 20 % of the steps improved the best error by under 5 %
    (:func:`train.tracking_curve.has_plateaued`'s rule, checked here by hand); the shipped
    ``training.yaml`` records the same best error."""
    timesteps, errors_mm = (np.array(values, float) for values in read_curve(SHIPPED_DIR / name))
    assert len(timesteps) >= 5, f"{name} has no tracking curve"
    assert (SHIPPED_DIR / name / "tracking_curve.png").is_file()
    assert np.all(np.diff(timesteps) > 0)
    best_before = errors_mm[timesteps <= 0.8 * timesteps[-1]].min()
    assert best_before - errors_mm.min() < 0.05 * best_before, (best_before, errors_mm.min())
    training = yaml.safe_load((SHIPPED_DIR / name / "training.yaml").read_text())[-1]
    assert training["best_tracking_mm"] == pytest.approx(errors_mm.min(), abs=1e-4)


@pytest.mark.parametrize("name", _agent_params())
def test_a_shipped_agent_follows_its_recipe_and_tracks_its_path(name):
    """It trained by its recipe; over one clean episode (train.ship's nominal evaluation) it
    tracks well below a quarter of holding the pre-pressure and below 10 mm, and within 20 % of
    the error recorded when it was shipped (``evaluation.yaml``)."""
    config = yaml.safe_load((SHIPPED_DIR / name / "config.yaml").read_text())
    # the recipe file it was trained by: --conf-file's where one was given, else the algo's
    recipe_file = (config.get("request") or {}).get("config_file") or \
        f"train/configs/{config['algo']}.yml"
    recipes = yaml.safe_load((SHIPPED_DIR.parents[1] / recipe_file).read_text())
    assert config["env_id"] in recipes, f"no recipe for {config['env_id']} in {recipe_file}"
    recipe = recipes[config["env_id"]]
    assert config["env_kwargs"] == recipe["env_kwargs"]
    assert config["hyperparameters"].get("arm_env_kwargs") == recipe.get("arm_env_kwargs")
    evaluation = nominal_evaluation(name)
    settled, resting = evaluation["settled_error_mm"], evaluation["resting_error_mm"]
    assert settled < 0.25 * resting, (settled, resting)
    assert settled < 10.0, settled
    recorded = yaml.safe_load((SHIPPED_DIR / name / EVALUATION_FILE).read_text())
    assert (recorded["env_id"], recorded["env_kwargs"], recorded["reset_seed"]) == (
        evaluation["env_id"], evaluation["env_kwargs"], evaluation["reset_seed"])
    assert abs(settled - recorded["settled_error_mm"]) <= 0.2 * recorded["settled_error_mm"], (
        settled, recorded["settled_error_mm"])


def test_a_study_agent_loads_by_its_path_in_the_repository_from_any_directory(tmp_path,
                                                                                monkeypatch):
    """``sb3:agents/studies/...`` resolves from the repository's root when the working directory
    holds no such path, and is not listed among the shipped agents."""
    from agents.policies import shipped_agents
    from agents.policies.sb3 import REPOSITORY_DIR, resolve_sb3_path

    monkeypatch.chdir(tmp_path)
    relative = "agents/studies/demos/sac_ho2018_track_demos_20k"
    assert resolve_sb3_path(relative) == REPOSITORY_DIR / relative
    assert "sac_ho2018_track_demos_20k" not in shipped_agents()
    env = gym.make("SoftArmTrackHo2018-v0", feedback="em", path="circle")
    agent = make_policy(f"sb3:{relative}", env=env)
    observation, _ = env.reset(seed=0)
    assert env.action_space.contains(agent.predict(observation, deterministic=True)[0])
    env.close()
    assert resolve_sb3_path("no/such/agent") == Path("no/such/agent")


@pytest.mark.parametrize("name", _agent_params())
def test_a_shipped_agent_tracks_as_recorded_on_every_engine(name):
    """``evaluation.yaml`` records the nominal error on each engine beside the training engine
    (the sim-to-sim gap): the training engine's entry is ``settled_error_mm`` itself, and on the
    other engine the agent still tracks within 20 % of the recorded error there."""
    recorded = yaml.safe_load((SHIPPED_DIR / name / EVALUATION_FILE).read_text())
    engines = recorded["engines"]
    errors = engines["settled_error_mm"]
    assert errors[engines["training_engine"]] == recorded["settled_error_mm"]
    for engine, error_mm in errors.items():
        if engine == engines["training_engine"]:
            continue
        settled = nominal_evaluation(name, engine)["settled_error_mm"]
        assert abs(settled - error_mm) <= 0.2 * error_mm, (engine, settled, error_mm)
