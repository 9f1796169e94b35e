"""Starting an off-policy agent from a baseline's demonstrations (train/demonstrations.py): the
recording is the baseline's episodes, cloning fits the actor to them, the replay buffer and the
critic take them in with the actor held, and the CLI refuses what cannot work, one line each."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
import torch
import yaml
from stable_baselines3 import SAC, TD3
from stable_baselines3.common.vec_env import DummyVecEnv, VecNormalize

import soft_gym  # noqa: F401
from train.demonstrations import (clone_behaviour, load_demonstrations, prime_normalization,
                                  record_demonstrations, seed_replay_buffer, warm_up_critic)
from train.trainer import TrainRequest, train

ROOT = Path(__file__).resolve().parents[2]
ENV_ID = "SoftArmTrackWang2023-v0"
SHORT_ENV = {"feedback": "ground_truth", "path": "circle", "speed_m_s": 0.02}


@pytest.fixture(scope="module")
def recorded(tmp_path_factory):
    """Two episodes of cc_model on the short circle, and the dataset's root."""
    root = tmp_path_factory.mktemp("demos")
    dataset_id = record_demonstrations(ENV_ID, SHORT_ENV, "cc_model", episodes=2, seed=3,
                                       root=root, policy_params={"kp": 0.06})
    return dataset_id, root


def _model(algo=SAC, normalize=True):
    env = DummyVecEnv([lambda: gym.make(ENV_ID, **SHORT_ENV)])
    if normalize:
        env = VecNormalize(env, gamma=0.9)
    return algo("MlpPolicy", env, seed=0, learning_starts=10, batch_size=32,
                policy_kwargs={"net_arch": [32, 32]})


def test_the_recording_holds_the_baselines_episodes(recorded):
    dataset_id, root = recorded
    env = gym.make(ENV_ID, **SHORT_ENV)
    demos = load_demonstrations(dataset_id, root, env)
    assert int(demos.episode_starts.sum()) == 2
    assert demos.truncations.sum() == 2 and not demos.terminations.any()
    # within an episode, one step's next observation is the next step's observation
    inside = ~demos.episode_starts[1:]
    np.testing.assert_array_equal(demos.next_observations[:-1][inside],
                                  demos.observations[1:][inside])
    # the first episode is the baseline's run from reset seed 3, step for step
    from agents.policies import make_policy

    policy = make_policy("cc_model", env=env, kp=0.06)
    observation, _ = env.reset(seed=3)
    policy.reset()
    step, done = 0, False
    while not done:
        np.testing.assert_allclose(demos.observations[step], observation, rtol=0, atol=1e-6)
        action, _ = policy.predict(observation, deterministic=True)
        np.testing.assert_allclose(demos.actions[step], action, rtol=0, atol=1e-6)
        next_observation, reward, terminated, truncated, info = env.step(action)
        policy.update(observation, action, reward, next_observation, info)
        observation, done, step = next_observation, terminated or truncated, step + 1
    assert demos.episode_starts[step] and len(demos) == 2 * step  # two episodes of one length
    env.close()


def test_cloning_fits_the_actor_to_the_demonstrated_actions(recorded):
    dataset_id, root = recorded
    model = _model()
    demos = load_demonstrations(dataset_id, root, model.get_env())
    prime_normalization(model, demos)
    normalization = model.get_vec_normalize_env()
    np.testing.assert_allclose(normalization.obs_rms.mean, demos.observations.mean(axis=0),
                               rtol=1e-3, atol=1e-6)
    before = clone_behaviour(model, demos, epochs=1, seed=0)
    losses = clone_behaviour(model, demos, epochs=150, seed=0)
    assert losses[-1] < 0.2 * before[0]
    observations = normalization.normalize_obs(demos.observations)
    with torch.no_grad():
        acted = model.policy._predict(torch.as_tensor(observations, dtype=torch.float32),
                                      deterministic=True).numpy()
    scaled = model.policy.scale_action(demos.actions)
    assert np.mean((acted - scaled) ** 2) == pytest.approx(losses[-1], rel=0.5)


def test_td3s_target_actor_is_the_cloned_actor(recorded):
    dataset_id, root = recorded
    model = _model(TD3, normalize=False)
    demos = load_demonstrations(dataset_id, root, model.get_env())
    clone_behaviour(model, demos, epochs=3, seed=0)
    for cloned, target in zip(model.actor.parameters(), model.actor_target.parameters()):
        assert torch.equal(cloned, target)


def test_the_buffer_holds_the_transitions_and_the_critic_learns_with_the_actor_held(recorded):
    dataset_id, root = recorded
    model = _model()
    demos = load_demonstrations(dataset_id, root, model.get_env())
    seed_replay_buffer(model, demos)
    buffer = model.replay_buffer
    assert buffer.pos == len(demos)
    np.testing.assert_allclose(buffer.observations[:len(demos), 0], demos.observations,
                               rtol=1e-6)
    np.testing.assert_allclose(buffer.actions[:len(demos), 0],
                               model.policy.scale_action(demos.actions), rtol=1e-6)
    assert buffer.timeouts[:len(demos), 0].sum() == 2  # the truncated ends are timeouts
    from stable_baselines3.common.logger import configure

    model.set_logger(configure(None, []))
    actor = [p.detach().clone() for p in model.actor.parameters()]
    critic = [p.detach().clone() for p in model.critic.parameters()]
    warm_up_critic(model, 20)
    assert all(torch.equal(a, p) for a, p in zip(actor, model.actor.parameters()))
    assert not all(torch.equal(c, p) for c, p in zip(critic, model.critic.parameters()))
    model.train(gradient_steps=1, batch_size=32)  # held no longer: the actor moves again
    assert not all(torch.equal(a, p) for a, p in zip(actor, model.actor.parameters()))


def test_a_dataset_of_other_spaces_is_refused_by_name(recorded):
    dataset_id, root = recorded
    other = gym.make(ENV_ID, obs=("pose", "target"), **SHORT_ENV)
    with pytest.raises(ValueError, match=f"dataset '{dataset_id}' holds observations"):
        load_demonstrations(dataset_id, root, other)
    with pytest.raises(ValueError, match="not under"):
        load_demonstrations("soft-arm/demos/nothing-v0", root, other)
    other.close()


def test_training_from_a_recorded_dataset_reports_the_demonstrations(tmp_path, recorded):
    dataset_id, root = recorded
    run_dir = train(TrainRequest(
        algo="sac", env_kwargs=SHORT_ENV, timesteps=64, demo_dataset=dataset_id,
        demo_root=str(root), bc_epochs=5, critic_warmup=10, out_dir=str(tmp_path),
        hyperparameters={"batch_size": 32, "learning_starts": 1000}, eval_freq=0,
        checkpoint_freq=0, progress=False))
    summary = yaml.safe_load((run_dir / "training.yaml").read_text())[-1]
    assert summary["demonstrations"] == dataset_id
    assert summary["demo_steps"] == len(load_demonstrations(dataset_id, root, gym.make(
        ENV_ID, **SHORT_ENV)))
    assert summary["timesteps"] == 64 and summary["critic_warmup_steps"] == 10
    assert summary["bc_loss_last"] < summary["bc_loss_first"]


@pytest.mark.smoke
@pytest.mark.parametrize("argv, option", [
    (["--algo", "ppo", "--demos", "cc_model"], "--demos"),
    (["--demos", "nonsense"], "--demos"),
    (["--demos", "cc_model", "--demo-dataset", "soft-arm/x/y-v0"], "--demo-dataset"),
    (["--demo-params", "kp=0.1"], "--demo-params"),
    (["--demo-dataset", "soft-arm/demos/none-v0"], "--demo-dataset"),
    (["--demos", "cc_model", "--demo-episodes", "0"], "--demo-episodes"),
    (["--demos", "cc_model", "--bc-epochs", "-1"], "--bc-epochs"),
])
def test_cli_refuses_in_one_line_before_any_work(tmp_path, argv, option):
    result = subprocess.run([sys.executable, "-m", "train", *argv, "--out", str(tmp_path)],
                            cwd=ROOT, capture_output=True, text=True, timeout=120)
    assert result.returncode == 2
    lines = result.stderr.strip().splitlines()
    assert option in lines[-1] and lines[-1].startswith("usage") is False
    assert not any(tmp_path.iterdir())



@pytest.mark.smoke
@pytest.mark.parametrize("argv, option, needs", [
    (["--bc-epochs", "5"], "--bc-epochs", "--demos or --demo-dataset"),
    (["--critic-warmup", "10"], "--critic-warmup", "--demos or --demo-dataset"),
    (["--demo-episodes", "2"], "--demo-episodes", "--demos"),
    (["--demo-dataset", "soft-arm/demos/none-v0", "--demo-episodes", "2"], "--demo-episodes",
     "--demos"),
])
def test_demonstration_options_without_demonstrations_are_refused(argv, option, needs, capsys,
                                                                  tmp_path, monkeypatch):
    """An option of the demonstrations given without them would be ignored: refused before any
    work, naming it and what it needs."""
    from tests.cli_errors import assert_one_line_error
    from train.__main__ import main as train_main

    def no_training(request):
        raise AssertionError(f"trained instead of refusing: {request}")

    monkeypatch.setattr("train.trainer.train", no_training)
    assert_one_line_error(train_main, argv + ["--out", str(tmp_path / "out")], option, capsys,
                          out=tmp_path / "out", also=needs)


def test_demonstration_options_keep_their_defaults_and_apply_with_demos(tmp_path):
    from train.__main__ import build_parser, check_training

    parser = build_parser()
    request = check_training(parser, parser.parse_args(["--out", str(tmp_path)]),
                             {"feedback": "ground_truth"}, {})
    assert (request.bc_epochs, request.critic_warmup, request.demo_episodes) == (100, 2000, 4)
    args = parser.parse_args(["--demos", "cc_model", "--bc-epochs", "5", "--critic-warmup", "10",
                              "--demo-episodes", "2", "--out", str(tmp_path)])
    request = check_training(parser, args, {"feedback": "ground_truth"}, {})
    assert (request.bc_epochs, request.critic_warmup, request.demo_episodes) == (5, 10, 2)