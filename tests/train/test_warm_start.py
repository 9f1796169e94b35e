"""``python -m train --trained-agent``: a run that starts from a trained agent's weights and
statistics, on its own env and hyperparameters, with the agent's budget counted."""

from __future__ import annotations

import pickle
from pathlib import Path

import numpy as np
import pytest
import torch
import yaml
from stable_baselines3 import PPO

import soft_gym  # noqa: F401
from agents.policies.sb3 import training_budget
from eval.suite.report import budget_text
from tests.cli_errors import assert_one_line_error
from train.__main__ import main as train_main
from train.trainer import TrainRequest, train
from train.warm_start import TRAINED_AGENT_KEY, find_trained_agent

FAST_ENV = {"feedback": "ground_truth", "path": "circle", "speed_m_s": 0.02}
SMALL_PPO = {"n_steps": 128, "batch_size": 64, "n_epochs": 1}


@pytest.fixture(scope="module")
def source_run(tmp_path_factory) -> Path:
    """A 256-step PPO run on FAST_ENV with ground-truth feedback (read only)."""
    return train(TrainRequest(algo="ppo", env_kwargs=FAST_ENV, n_envs=1, timesteps=256,
                              hyperparameters=SMALL_PPO, run_name="source",
                              out_dir=str(tmp_path_factory.mktemp("warm")), eval_freq=0,
                              checkpoint_freq=0, progress=False))


def _parameters(model) -> list[torch.Tensor]:
    return [tensor.detach().clone() for tensor in model.policy.state_dict().values()]


def test_a_run_starts_from_the_agent_and_counts_its_steps(tmp_path, source_run):
    run = train(TrainRequest(
        algo="ppo", env_kwargs={**FAST_ENV, "feedback": "em"}, n_envs=1, timesteps=128,
        hyperparameters={**SMALL_PPO, "learning_rate": 1e-12}, out_dir=str(tmp_path),
        run_name="tuned", eval_freq=0, checkpoint_freq=0, progress=False,
        trained_agent=str(source_run), curve_freq=128))
    source, tuned = PPO.load(source_run / "model.zip"), PPO.load(run / "model.zip")
    # a learning rate of 1e-12 moves no weight visibly: the run began from the agent's weights
    for before, after in zip(_parameters(source), _parameters(tuned)):
        np.testing.assert_allclose(after.numpy(), before.numpy(), atol=1e-8)
    assert tuned.learning_rate == pytest.approx(1e-12)  # the run's hyperparameters, not the saved
    # the agent's normalisation statistics, updated by the run's first reset and 128 steps
    with open(source_run / "vecnormalize.pkl", "rb") as handle:
        start = pickle.load(handle)
    with open(run / "vecnormalize.pkl", "rb") as handle:
        end = pickle.load(handle)
    assert end.obs_rms.count == pytest.approx(start.obs_rms.count + 1 + 128)
    segments = yaml.safe_load((run / "training.yaml").read_text())
    assert [segment["timesteps"] for segment in segments] == [256, 128]
    assert segments[0][TRAINED_AGENT_KEY] == "source" and segments[0]["feedback"] == "ground_truth"
    assert TRAINED_AGENT_KEY not in segments[1]
    budget = training_budget(run)
    assert budget["timesteps"] == 384 and budget["trained_agent"] == "source"
    assert budget["feedback"] == "em" and budget_text(budget).endswith("fine-tuned from source")
    curve = (run / "eval" / "tracking_curve.csv").read_text().splitlines()
    assert [row.split(",")[0] for row in curve[1:]] == ["0", "128"]  # the agent, then the run
    config = yaml.safe_load((run / "config.yaml").read_text())
    assert config["request"]["trained_agent"] == str(source_run)

    again = train(TrainRequest(
        algo="ppo", env_kwargs=FAST_ENV, n_envs=1, timesteps=64,
        hyperparameters={**SMALL_PPO, "n_steps": 64}, out_dir=str(tmp_path), run_name="again",
        eval_freq=0, checkpoint_freq=0, progress=False, trained_agent=str(run)))
    segments = yaml.safe_load((again / "training.yaml").read_text())
    assert [(segment["timesteps"], segment.get(TRAINED_AGENT_KEY), segment.get("feedback"))
            for segment in segments] == [(256, "source", "ground_truth"), (128, "tuned", "em"),
                                         (64, None, None)]
    assert training_budget(again)["timesteps"] == 448
    assert training_budget(again)["trained_agent"] == "tuned"


def test_an_agent_of_another_algorithm_or_interface_is_refused(tmp_path, source_run):
    with pytest.raises(ValueError, match="trained_agent .* is a ppo agent, the run trains a2c"):
        find_trained_agent(source_run, "a2c")
    with pytest.raises(ValueError, match="trained_agent .* reads and writes other observations"):
        train(TrainRequest(algo="ppo", env_kwargs={**FAST_ENV, "obs": ["pose", "target"]},
                           n_envs=1, timesteps=128, hyperparameters=SMALL_PPO,
                           out_dir=str(tmp_path), eval_freq=0, checkpoint_freq=0,
                           progress=False, trained_agent=str(source_run)))
    with pytest.raises(ValueError, match="trained_agent .*normalised observations"):
        train(TrainRequest(algo="ppo", env_kwargs=FAST_ENV, n_envs=1, timesteps=128,
                           hyperparameters={**SMALL_PPO, "normalize": False},
                           out_dir=str(tmp_path), run_name="plain", eval_freq=0,
                           checkpoint_freq=0, progress=False, trained_agent=str(source_run)))
    with pytest.raises(ValueError, match="trained_agent 'nowhere'"):
        find_trained_agent("nowhere", "ppo")


def test_the_cli_refuses_a_bad_trained_agent_in_one_line(tmp_path, source_run, capsys):
    out = tmp_path / "runs"
    base = ["--algo", "ppo", "--env-kwargs", "feedback=ground_truth", "--out", str(out)]
    assert_one_line_error(train_main, [*base, "--trained-agent", "nowhere"],
                          "--trained-agent", capsys, out / "ppo_SoftArmTrackWang2023-v0_seed0")
    assert_one_line_error(train_main, [*base, "--algo", "sac", "--trained-agent",
                                       str(source_run)], "--trained-agent", capsys,
                          also="is a ppo agent")
    assert_one_line_error(train_main, [*base, "--env-kwargs", "feedback=ground_truth",
                                       "obs=[pose,target]", "--trained-agent", str(source_run)],
                          "--trained-agent", capsys, also="observations")
    assert_one_line_error(train_main, ["--resume", str(source_run), "--timesteps", "10",
                                       "--trained-agent", str(source_run)],
                          "--trained-agent", capsys)
    assert_one_line_error(train_main, [*base, "--trained-agent", str(source_run), "--demos",
                                       "cc_model"], "--trained-agent", capsys)


def test_an_off_policy_run_keeps_its_recipes_action_noise(tmp_path):
    """The run's hyperparameters over the agent's include the exploration noise, built for the
    run's action space as a new model's is."""
    from stable_baselines3 import TD3
    from stable_baselines3.common.noise import NormalActionNoise

    common = dict(algo="td3", env_kwargs=FAST_ENV, n_envs=1, out_dir=str(tmp_path),
                  eval_freq=0, checkpoint_freq=0, progress=False)
    source = train(TrainRequest(timesteps=150, run_name="source",
                                hyperparameters={"learning_starts": 100}, **common))
    tuned = train(TrainRequest(timesteps=50, run_name="tuned", trained_agent=str(source),
                               hyperparameters={"learning_starts": 0,
                                                "noise_type": "normal", "noise_std": 0.3},
                               **common))
    noise = TD3.load(tuned / "model.zip").action_noise
    assert isinstance(noise, NormalActionNoise)
    assert np.allclose(noise._sigma, 0.3)


def test_a_shipped_agent_of_another_arm_is_refused_naming_the_option_of_its_arm(tmp_path,
                                                                               capsys):
    """--trained-agent sac_zhao2021_track on the default arm (wang2023): the one-line error names
    the agent's arm: --preset, or with --env the alias id of that arm or the generic id's
    preset keyword."""
    out = tmp_path / "runs"
    base = ["--algo", "sac", "--trained-agent", "sac_zhao2021_track", "--out", str(out)]
    line = assert_one_line_error(train_main, base, "--trained-agent", capsys, also="(6,)")
    assert line.endswith("; --preset zhao2021"), line
    line = assert_one_line_error(train_main, [*base, "--env", "SoftArmTrackWang2023-v0"],
                                 "--trained-agent", capsys)
    assert line.endswith("; --env SoftArmTrackZhao2021-v0"), line
    line = assert_one_line_error(train_main, [*base, "--env", "SoftArmTrack-v0"],
                                 "--trained-agent", capsys)
    assert line.endswith("; --env-kwargs preset=zhao2021"), line
