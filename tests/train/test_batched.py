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


# ---------------------------------------------------------------------- arm_env_kwargs
def _write_recipe(tmp_path, arms: str, n_envs: int = 4) -> str:
    path = tmp_path / "recipe.yml"
    path.write_text(f"""SoftArmTrackWang2023-v0:
  n_timesteps: 256
  policy: MlpPolicy
  n_envs: {n_envs}
  env_kwargs: {{engine: mujoco, feedback: em, path: circle, speed_m_s: 0.02,
               randomization: null}}
  arm_env_kwargs: {arms}
  n_steps: 32
  batch_size: 32
""")
    return str(path)


def test_arm_env_kwargs_give_each_arm_of_the_batch_its_own_feedback(tmp_path, monkeypatch):
    """A recipe's arm_env_kwargs, taken in turn by the arms: arm i builds the env of entry
    i mod 2 over env_kwargs (its feedback source and sensors), the batch python -m train trains
    on is built so, and the tracking curve evaluates the agent on each entry's env, labelled by
    it."""
    recipe = _write_recipe(tmp_path, "[{feedback: em}, {feedback: ground_truth}]", n_envs=3)
    from train.config import read_hyperparameters, split_hyperparameters
    settings = split_hyperparameters("ppo", read_hyperparameters("ppo", "SoftArmTrackWang2023-v0",
                                                                 recipe))
    assert settings.per_arm_env_kwargs() == [{"feedback": "em"}, {"feedback": "ground_truth"},
                                             {"feedback": "em"}]
    assert settings.arm_variants() == [{"feedback": "em"}, {"feedback": "ground_truth"}]
    batched = Sb3VectorEnv("SoftArmTrackWang2023-v0", 3, per_env_kwargs=settings.per_arm_env_kwargs(),
                           **settings.env_kwargs)
    assert [env.unwrapped.feedback for env in batched.envs] == ["em", "ground_truth", "em"]
    batched.close()
    import train.trainer
    trained_on = []

    class Recorded(Sb3VectorEnv):  # the batch the trainer builds, its arms' feedback recorded
        def __init__(self, *args, **kwargs):
            super().__init__(*args, **kwargs)
            trained_on.append([env.unwrapped.feedback for env in self.envs])

    monkeypatch.setattr(train.trainer, "Sb3VectorEnv", Recorded)
    train_main(["--algo", "ppo", "--env", "SoftArmTrackWang2023-v0", "--conf-file", recipe,
                "--vec", "batched", "--curve-freq", "96", "--eval-freq", "0",
                "--checkpoint-freq", "0", "--out", str(tmp_path), "--name", "arms",
                "--no-progress"])
    assert trained_on == [["em", "ground_truth", "em"]]
    header = (tmp_path / "arms" / "eval" / "tracking_curve.csv").read_text().splitlines()[0]
    assert header.split(",")[3:] == ["feedback=em circle nominal (mm)",
                                     "feedback=ground_truth circle nominal (mm)"]


@pytest.mark.parametrize("arms, vec, words", [
    ("[{feedback: em}]", "subprocess", ["--conf-file", "--vec batched"]),
    ("[{feedback: nope}]", "batched", ["--conf-file", "arm_env_kwargs entry", "nope"]),
    ("[]", "batched", ["arm_env_kwargs must be a list of one or more mappings"]),
])
def test_bad_arm_env_kwargs_are_one_cli_line(tmp_path, capsys, arms, vec, words):
    recipe = _write_recipe(tmp_path, arms)
    with pytest.raises(SystemExit) as stop:
        train_main(["--algo", "ppo", "--env", "SoftArmTrackWang2023-v0", "--conf-file", recipe,
                    "--vec", vec, "--out", str(tmp_path), "--no-progress"])
    assert stop.value.code == 2
    error = capsys.readouterr().err.strip().splitlines()[-1]
    assert all(word in error for word in words), error
    assert not list(tmp_path.glob("*/config.yaml"))  # refused before any work


def test_arm_env_kwargs_outside_a_batch_is_refused_by_the_trainer():
    from train.trainer import make_vec_env
    with pytest.raises(ValueError, match="arm_env_kwargs .* --vec batched"):
        make_vec_env("SoftArmTrackWang2023-v0", {"feedback": "em"}, 2, 0,
                     per_arm=[{}, {"feedback": "ground_truth"}])


# ---------------------------------------------------------------------- bad input
def test_an_id_other_than_a_soft_arm_one_is_refused_before_its_arguments():
    """``CartPole-v1`` is refused by ``env_id``, listing the soft-arm ids, not by the
    ``threads`` its vector entry point does not take."""
    with pytest.raises(ValueError, match=r"^env_id must be a soft-arm id, one of "
                                         r"\['SoftArmReach-v0', 'SoftArmTrack-v0', .*\], got "
                                         r"'CartPole-v1'$"):
        Sb3VectorEnv("CartPole-v1", 2)


@pytest.mark.parametrize("call", [
    lambda vec, indices: vec.env_method("reset", indices=indices),
    lambda vec, indices: vec.get_attr("step_count", indices=indices),
    lambda vec, indices: vec.set_attr("step_count", 0, indices=indices),
    lambda vec, indices: vec.env_is_wrapped(gym.Wrapper, indices=indices),
], ids=["env_method", "get_attr", "set_attr", "env_is_wrapped"])
@pytest.mark.parametrize("indices, bad", [([5], "5"), (2, "2"), ([0, -1], "-1"),
                                          ([0, 1.0], "1.0")], ids=repr)
def test_an_index_outside_the_batch_is_refused_naming_the_range(call, indices, bad):
    batched = Sb3VectorEnv("SoftArmReach-v0", 2, engine="mujoco", feedback="ground_truth")
    with pytest.raises(ValueError, match=rf"^indices must be arm indices in \[0, 1\] \(this "
                                         rf"batch has 2 arms\), got {bad} in "):
        call(batched, indices)
    assert batched.get_attr("step_count", indices=[1, 0]) == [0, 0]
    batched.close()


def test_ragged_actions_are_refused_naming_the_shape():
    batched = Sb3VectorEnv("SoftArmReach-v0", 2, engine="mujoco", feedback="ground_truth")
    batched.reset()
    with pytest.raises(ValueError, match=r"^actions must have shape \(2, 3\) \(num_envs, "
                                         r"n_chambers\), got a ragged sequence whose row 1 "
                                         r"has shape \(2,\)$"):
        batched.step([[0.1, 0.2, 0.3], [0.1, 0.2]])
    batched.close()
