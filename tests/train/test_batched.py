"""``train.batched.Sb3VectorEnv`` against stable-baselines3's own ``DummyVecEnv`` of the same
MuJoCo envs: the same observations, rewards, dones, terminal observations and time-limit flags
step by step (SB3's autoreset), episode records as SB3's ``Monitor`` writes them, and a PPO run
through ``python -m train --vec batched``."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from stable_baselines3.common.monitor import Monitor
from stable_baselines3.common.vec_env import DummyVecEnv

import soft_gym  # noqa: F401  (registers the ids)
from train.__main__ import main as train_main
from train.batched import Sb3VectorEnv

KWARGS = {"preset": "wang2023", "engine": "mujoco", "feedback": "em", "episode_steps": 5,
          "randomization": {"load_weights": {"none": 0.5, "tip_mass": 0.5}}}


def test_batched_steps_as_sb3s_dummy_vec_env():
    n = 3
    batched = Sb3VectorEnv("SoftArmReach-v0", n, **KWARGS)
    dummy = DummyVecEnv([lambda: Monitor(gym.make("SoftArmReach-v0", **KWARGS))
                         for _ in range(n)])
    for vec in (batched, dummy):
        vec.seed(11)
    first, second = batched.reset(), dummy.reset()
    assert np.array_equal(first, second)
    rng = np.random.default_rng(0)
    finished = 0
    for _ in range(12):
        actions = rng.uniform(-1, 1, (n, 3)).astype(np.float32)
        ours, theirs = batched.step(actions), dummy.step(actions)
        for a, b in zip(ours[:3], theirs[:3]):
            assert np.array_equal(a, b)
        for info, reference in zip(ours[3], theirs[3]):
            assert ("terminal_observation" in info) == ("terminal_observation" in reference)
            if "terminal_observation" in info:
                finished += 1
                assert np.array_equal(info["terminal_observation"],
                                      reference["terminal_observation"])
                assert info["TimeLimit.truncated"] == reference["TimeLimit.truncated"]
                assert info["episode"]["r"] == pytest.approx(reference["episode"]["r"], abs=1e-6)  # Monitor rounds
                assert info["episode"]["l"] == reference["episode"]["l"]
    assert finished == 2 * n  # 12 steps of 5-step episodes
    batched.close()
    dummy.close()


def test_train_cli_runs_ppo_on_the_batch_and_writes_its_monitor(tmp_path):
    train_main(["--algo", "ppo", "--env", "SoftArmReachWang2023-v0", "--n-envs", "4",
                "--vec", "batched", "--env-kwargs", "engine=mujoco", "feedback=em",
                "randomization=null", "episode_steps=20",
                "--timesteps", "512", "-hp", "n_steps=64", "batch_size=64",
                "--eval-freq", "0", "--checkpoint-freq", "0", "--out", str(tmp_path),
                "--name", "batched", "--no-progress"])
    run = tmp_path / "batched"
    assert (run / "model.zip").exists()
    rows = (run / "monitor" / "batched.monitor.csv").read_text().splitlines()
    assert rows[1] == "r,l,t" and len(rows) > 2


def test_batched_without_mujoco_is_one_cli_line(capsys):
    with pytest.raises(SystemExit) as stop:
        train_main(["--vec", "batched", "--timesteps", "10"])
    assert stop.value.code == 2
    assert "--vec batched" in capsys.readouterr().err
