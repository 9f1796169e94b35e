"""The training CLI: zoo-format configs, a 1,000-step smoke run per algorithm, save/load symmetry,
resume, and rl-baselines3-zoo training the registered ids."""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
import torch.nn as nn
import yaml

import soft_gym  # noqa: F401
from cli_errors import assert_one_line_error
from agents.policies import SHIPPED_DIR, make_policy, model_normalization_mark
from train.__main__ import main as train_main
from train.config import (ALGORITHMS, check_hyperparameters, parse_key_values,
                          parse_python_value, read_hyperparameters, split_hyperparameters)
from train.trainer import TrainRequest, train

ROOT = Path(__file__).resolve().parents[2]
FAST_ENV = {"feedback": "ground_truth", "path": "circle", "speed_m_s": 0.02}


def test_policy_kwargs_strings_parse_without_eval():
    parsed = parse_python_value("dict(net_arch=[64, 64], activation_fn=nn.ReLU, log_std_init=-1.0)")
    assert parsed == {"net_arch": [64, 64], "activation_fn": nn.ReLU, "log_std_init": -1.0}
    for hostile in ("__import__('os').system('true')", "dict(x=open('f'))", "nn.functional"):
        with pytest.raises(ValueError):
            parse_python_value(hostile)


def test_zoo_special_keys_are_split_out():
    settings = split_hyperparameters("sac", {
        "n_timesteps": 2e3, "n_envs": 2, "normalize": "dict(norm_obs=True, norm_reward=False)",
        "gamma": 0.8, "learning_rate": "lin_1e-3", "env_kwargs": {"feedback": "em"},
        "policy_kwargs": "dict(net_arch=[32])", "noise_type": "normal", "noise_std": 0.2})
    assert settings.n_timesteps == 2000 and settings.n_envs == 2
    assert settings.normalize == {"norm_obs": True, "norm_reward": False, "gamma": 0.8}
    assert settings.env_kwargs == {"feedback": "em"}
    assert settings.algo_kwargs["learning_rate"](1.0) == pytest.approx(1e-3)
    assert settings.algo_kwargs["learning_rate"](0.5) == pytest.approx(5e-4)
    assert settings.algo_kwargs["action_noise"] == ("normal", 0.2)
    assert settings.algo_kwargs["policy_kwargs"] == {"net_arch": [32]}
    with pytest.raises(ValueError, match="noise_type"):
        split_hyperparameters("ppo", {"n_timesteps": 10, "noise_type": "normal"})


def test_every_algorithm_has_a_config():
    for algo in ALGORITHMS:
        assert "n_timesteps" in read_hyperparameters(algo, "SoftArmReachHo2018-v0")
    with pytest.raises(ValueError, match="does not exist"):
        read_hyperparameters("sac", "x", "no/such/file.yml")


@pytest.mark.smoke
def test_key_values_are_yaml():
    assert parse_key_values(["a=1", "b=[circle, pentagram]", "c=em", "d=true"], "x") == {
        "a": 1, "b": ["circle", "pentagram"], "c": "em", "d": True}
    with pytest.raises(ValueError, match="KEY=VALUE"):
        parse_key_values(["novalue"], "--env-kwargs")


@pytest.mark.smoke
def test_hyperparameters_are_checked_by_key_and_value():
    """A key the algorithm does not take is refused naming those it does; values out of range
    are refused naming what is allowed; every shipped config passes."""
    with pytest.raises(ValueError, match=r"unknown hyperparameter 'nonsense' for sac; allowed: "
                                         r"\[.*'learning_rate'"):
        check_hyperparameters("sac", {"nonsense": 1})
    with pytest.raises(ValueError, match="n_epochs"):  # PPO's keys, not SAC's
        check_hyperparameters("ppo", {"buffer_size": 10})
    for key, value, allowed in (("gamma", 2.0, r"\(0, 1\]"), ("gamma", 0, r"\(0, 1\]"),
                                ("learning_rate", -1.0, "> 0"), ("learning_rate", "lin_x", "lin_"),
                                ("batch_size", 0, ">= 1"), ("batch_size", 1.5, "integer"),
                                ("buffer_size", True, "integer"), ("tau", 1.5, r"\(0, 1\]"),
                                ("learning_starts", -1, ">= 0"), ("train_freq", [1, "x"], "step"),
                                ("ent_coef", "autox", "auto"), ("n_timesteps", 0, ">= 1"),
                                ("normalize", 3, "dict"), ("arm_env_kwargs", [], "list"),
                                ("arm_env_kwargs", [{"feedback": "em"}, 3], "mappings")):
        with pytest.raises(ValueError, match=f"{key} must be .*{allowed}"):
            check_hyperparameters("sac", {key: value})
    check_hyperparameters("sac", {"learning_rate": "lin_3e-4", "ent_coef": "auto_0.1",
                                  "train_freq": [1, "episode"], "gradient_steps": -1,
                                  "normalize": "dict(norm_obs=True)", "n_timesteps": 2e5})
    with pytest.raises(ValueError, match="policy must be 'MlpLstmPolicy' .* for ppo_lstm"):
        check_hyperparameters("ppo_lstm", {"policy": "MlpPolicy"})
    with pytest.raises(ValueError, match="policy must be 'MlpPolicy' .* for ppo, got 'MlpLstm"):
        check_hyperparameters("ppo", {"policy": "MlpLstmPolicy"})
    def owner(stem: str) -> str:  # the longest algo naming the file: ppo_lstm_*.yml is not PPO's
        return max((a for a in ALGORITHMS if stem == a or stem.startswith(f"{a}_")), key=len)

    for algo in ALGORITHMS:  # sac_ho2018_small_rectangle.yml is SAC's
        for path in [ROOT / "train" / "configs" / f"{algo}.yml",
                     *sorted(path for path in (ROOT / "train" / "configs").glob(f"{algo}_*.yml")
                             if owner(path.stem) == algo)]:
            for entry in yaml.safe_load(path.read_text()).values():
                split_hyperparameters(algo, entry)


def test_numbers_in_e_notation_are_numbers():
    """YAML 1.1 reads ``1e-3`` as text; ``-hp learning_rate=1e-3`` means the number."""
    assert parse_key_values(["learning_rate=1e-3", "x=2E5", "name=e5"], "-hp") == {
        "learning_rate": 1e-3, "x": 2e5, "name": "e5"}


def test_resume_without_a_model_is_refused(tmp_path):
    with pytest.raises(ValueError, match="model.zip"):
        train(TrainRequest(resume=str(tmp_path), timesteps=10, progress=False))


SLOW_SMOKE = ("td3", "ddpg", "ppo_lstm")
"""Smoke trainings run only with ``-m slow`` (13-24 s each on one core): SAC's takes the same
off-policy path in the default suite, and the recurrent test below ppo_lstm's."""


@pytest.mark.parametrize("algo", [pytest.param(algo, marks=pytest.mark.slow)
                                  if algo in SLOW_SMOKE else algo for algo in ALGORITHMS])
def test_smoke_training_saves_a_model_that_loads_back_identically(tmp_path, algo):
    hyperparameters = {"learning_starts": 200} if algo in ("sac", "td3", "ddpg") else {}
    if algo in ("ppo", "ppo_lstm"):
        hyperparameters = {"n_steps": 256, "batch_size": 64, "n_epochs": 2}
    run_dir = train(TrainRequest(
        algo=algo, env_id="SoftArmTrackWang2023-v0", env_kwargs=FAST_ENV, n_envs=1,
        hyperparameters=hyperparameters, timesteps=1000, out_dir=str(tmp_path), eval_freq=500,
        eval_episodes=1, checkpoint_freq=0, progress=False))
    for name in ("model.zip", "best_model.zip", "vecnormalize.pkl", "config.yaml",
                 "versions.yaml", "learning_curve.png", "logs/progress.csv"):
        assert (run_dir / name).is_file(), name
    assert list((run_dir / "logs").glob("events.out.tfevents.*"))
    versions = yaml.safe_load((run_dir / "versions.yaml").read_text())
    assert versions["git_revision"] != "" and versions["torch"].startswith("2.13")
    config = yaml.safe_load((run_dir / "config.yaml").read_text())
    assert config["env_kwargs"]["feedback"] == "ground_truth" and config["algo"] == algo
    assert model_normalization_mark(run_dir / "model.zip") is True
    assert model_normalization_mark(run_dir / "best_model.zip") is True

    env = gym.make("SoftArmTrackWang2023-v0", **FAST_ENV)
    loaded = make_policy(f"sb3:{run_dir}", env=env)
    observations = [env.reset(seed=0)[0]] + [env.step(env.action_space.sample())[0]
                                             for _ in range(5)]
    again = make_policy(f"sb3:{run_dir}", env=env)
    first = [loaded.predict(o)[0] for o in observations]
    assert all(np.array_equal(a, again.predict(o)[0]) for a, o in zip(first, observations))
    saved = tmp_path / "saved_again"
    loaded.save(saved)
    reloaded = make_policy(f"sb3:{saved}", env=env)
    assert all(np.array_equal(a, reloaded.predict(o)[0]) for a, o in zip(first, observations))
    env.close()


def test_resume_continues_the_step_count(tmp_path):
    """A run saved with save_replay_buffer resumes with its buffer (and keeps saving it)."""
    common = dict(env_kwargs=FAST_ENV, hyperparameters={"learning_starts": 100}, out_dir=str(tmp_path),
                  eval_freq=0, checkpoint_freq=0, progress=False)
    run_dir = train(TrainRequest(algo="sac", timesteps=400, save_replay_buffer=True, **common))
    buffer = run_dir / "replay_buffer.pkl"
    assert buffer.is_file()
    from stable_baselines3 import SAC

    loaded = []
    original = SAC.load_replay_buffer

    def load_replay_buffer(self, path, *args, **kwargs):
        original(self, path, *args, **kwargs)
        loaded.append(self.replay_buffer.size())

    SAC.load_replay_buffer = load_replay_buffer
    try:
        train(TrainRequest(resume=str(run_dir), timesteps=300, progress=False))
    finally:
        SAC.load_replay_buffer = original
    assert loaded == [400]  # the first run's transitions, restored
    assert buffer.is_file()
    assert yaml.safe_load((run_dir / "config.yaml").read_text())["request"]["save_replay_buffer"]

    assert SAC.load(run_dir / "model.zip").num_timesteps == 700
    history = yaml.safe_load((run_dir / "training.yaml").read_text())
    assert [entry["timesteps"] for entry in history] == [400, 700]


def test_a_sac_run_saves_no_replay_buffer_unless_asked_and_resumes_without_one(tmp_path,
                                                                              capsys):
    """The replay buffer (tens of MB) is saved only with save_replay_buffer; a run without one
    still resumes (with an empty buffer, saying so) and still saves none; an on-policy
    algorithm refuses the option."""
    run_dir = train(TrainRequest(algo="sac", env_kwargs=FAST_ENV, timesteps=200,
                                 hyperparameters={"learning_starts": 100}, out_dir=str(tmp_path),
                                 eval_freq=0, checkpoint_freq=0, progress=False))
    assert (run_dir / "model.zip").is_file()
    assert not list(run_dir.rglob("*replay_buffer*"))
    train(TrainRequest(resume=str(run_dir), timesteps=150, progress=False))
    assert "continuing with an empty replay buffer" in capsys.readouterr().out
    from stable_baselines3 import SAC

    assert SAC.load(run_dir / "model.zip").num_timesteps == 350
    assert not list(run_dir.rglob("*replay_buffer*"))
    with pytest.raises(ValueError, match="keeps no replay buffer"):
        train(TrainRequest(algo="ppo", env_kwargs=FAST_ENV, timesteps=64,
                           save_replay_buffer=True, out_dir=str(tmp_path), progress=False))
    with pytest.raises(SystemExit):
        train_main(["--algo", "ppo", "--save-replay-buffer", "--timesteps", "64",
                    "--out", str(tmp_path)])
    assert "--save-replay-buffer" in capsys.readouterr().err


def test_checkpoints_load_with_their_own_normalization_or_are_refused(tmp_path):
    """sb3:<checkpoint zip> applies the VecNormalize statistics saved with that checkpoint and
    the run's env interface; with the statistics gone it refuses, naming the missing file."""
    import pickle

    run_dir = train(TrainRequest(algo="sac", env_kwargs=FAST_ENV, timesteps=300,
                                 hyperparameters={"learning_starts": 100}, out_dir=str(tmp_path),
                                 eval_freq=0, checkpoint_freq=200, progress=False))
    checkpoint = run_dir / "checkpoints" / "sac_200_steps.zip"
    statistics = run_dir / "checkpoints" / "sac_vecnormalize_200_steps.pkl"
    assert checkpoint.is_file() and statistics.is_file()
    env = gym.make("SoftArmTrackWang2023-v0", **FAST_ENV)
    policy = make_policy(f"sb3:{checkpoint}", env=env)
    with open(statistics, "rb") as handle:
        saved = pickle.load(handle)
    final = make_policy(f"sb3:{run_dir}", env=env).normalization
    np.testing.assert_array_equal(policy.normalization.obs_rms.mean, saved.obs_rms.mean)
    assert not np.array_equal(policy.normalization.obs_rms.mean, final.obs_rms.mean)
    assert policy.config["algo"] == "sac"  # the run's config.yaml, above checkpoints/
    assert model_normalization_mark(checkpoint) is True
    bare = tmp_path / "bare" / "model.zip"  # the final model copied alone, without a config
    bare.parent.mkdir()
    bare.write_bytes((run_dir / "model.zip").read_bytes())
    with pytest.raises(ValueError, match=re.escape(str(bare.parent / "vecnormalize.pkl"))):
        make_policy(f"sb3:{bare}", env=env)
    statistics.unlink()
    with pytest.raises(ValueError, match="sac_vecnormalize_200_steps.pkl"):
        make_policy(f"sb3:{checkpoint}", env=env)
    (run_dir / "vecnormalize.pkl").unlink()
    with pytest.raises(ValueError, match="vecnormalize.pkl"):
        make_policy(f"sb3:{run_dir}", env=env)
    env.close()


def test_a_model_trained_without_normalization_is_marked_so_and_ignores_stray_statistics(
        tmp_path):
    run_dir = train(TrainRequest(algo="ppo", env_kwargs=FAST_ENV, timesteps=128,
                                 hyperparameters={"n_steps": 128, "batch_size": 64, "n_epochs": 1,
                                                  "normalize": False},
                                 out_dir=str(tmp_path), eval_freq=0, checkpoint_freq=0,
                                 progress=False))
    assert not (run_dir / "vecnormalize.pkl").exists()
    assert model_normalization_mark(run_dir / "model.zip") is False
    shutil.copy(SHIPPED_DIR / "sac_wang2023_track" / "vecnormalize.pkl", run_dir)
    env = gym.make("SoftArmTrackWang2023-v0", **FAST_ENV)
    assert make_policy(f"sb3:{run_dir}", env=env).normalization is None
    env.close()


@pytest.mark.smoke
def test_cli_help_and_bad_input(capsys):
    with pytest.raises(SystemExit) as exit_info:
        train_main(["--help"])
    assert exit_info.value.code == 0
    assert "--randomize" in capsys.readouterr().out
    with pytest.raises(SystemExit):
        train_main(["--algo", "dqn"])
    with pytest.raises(SystemExit):
        train_main(["--resume", "somewhere"])


def test_a_refused_env_keyword_is_the_one_that_fails_the_whole_set(tmp_path, capsys):
    """engine=mujoco alone fails on ho2018's camera feedback, which feedback=em lifts; what the
    whole set fails on is the randomisation's swaying mass, so that is the keyword named."""
    config = tmp_path / "ppo.yml"
    config.write_text(yaml.safe_dump({"SoftArmTrackHo2018-v0": {
        "n_timesteps": 1000, "policy": "MlpPolicy", "env_kwargs": {
            "engine": "mujoco", "feedback": "em",
            "randomization": {"tip_mass_kg": [0.0, 0.02]}}}}))
    with pytest.raises(SystemExit) as exit_info:
        train_main(["--algo", "ppo", "--env", "SoftArmTrackHo2018-v0", "--conf-file",
                    str(config), "--out", str(tmp_path)])
    assert exit_info.value.code == 2
    error = capsys.readouterr().err.strip().splitlines()[-1]
    assert "--conf-file" in error and "env keyword randomization=" in error, error
    assert "swaying" in error and "camera" not in error, error


def test_the_engine_refusal_names_the_feedback_that_runs_there_on_one_line(tmp_path, capsys):
    """``--env-kwargs engine=mujoco feedback=fused``: fused feedback needs the eye-in-hand
    camera, which MuJoCo lacks; the one-line error names the option, the camera and the
    feedback sources the MuJoCo engine runs."""
    out = tmp_path / "runs"
    line = assert_one_line_error(
        train_main, ["--env-kwargs", "engine=mujoco", "feedback=fused", "--out", str(out)],
        "--env-kwargs", capsys, out=out, also="sensor 'image' (feedback 'fused'")
    assert "use engine= one of ['pybullet'] or pass feedback= one of [" in line, line
    able = line.split("or pass feedback= one of ")[1]
    assert "'em'" in able and "'ground_truth'" in able and "'fused'" not in able, line


@pytest.mark.parametrize("argv, option", [
    (["--env-kwargs", "engine=mujoco"], "--env-kwargs"),  # the recipe's randomization: true
    (["--conf-file", "MUJOCO", "--randomize"], "--randomize"),
    (["--conf-file", "MUJOCO", "--randomization-config", "train/configs/randomization.yaml"],
     "--randomization-config"),
])
def test_drawn_swaying_masses_on_mujoco_name_the_randomisation_file_without_them(
        argv, option, tmp_path, capsys):
    """Randomisation drawing swaying masses on MuJoCo: the one-line error names the option that
    gave what is refused (engine=mujoco on the recipe's randomisation; --randomize or
    --randomization-config on a MuJoCo recipe) and the file that draws none (which exists and
    has no swaying-mass odds)."""
    from soft_gym.scenarios.randomization import RandomizationConfig
    from train.config import CONFIG_DIR

    shipped = CONFIG_DIR / "randomization_mujoco.yaml"
    assert RandomizationConfig.from_any(shipped).load_weights.get("swaying_mass", 0) == 0
    config = tmp_path / "sac.yml"
    config.write_text(yaml.safe_dump({"SoftArmTrackWang2023-v0": {
        "n_timesteps": 1000, "policy": "MlpPolicy",
        "env_kwargs": {"engine": "mujoco", "feedback": "em"}}}))
    out = tmp_path / "runs"
    line = assert_one_line_error(
        train_main, [str(config) if arg == "MUJOCO" else arg for arg in argv]
        + ["--out", str(out)], option, capsys, out=out,
        also="randomization drawing swaying_mass loads")
    assert line.startswith(f"python -m train: error: {option}: env keyword "), line
    assert line.endswith("--randomization-config train/configs/randomization_mujoco.yaml "
                         "draws none"), line
    assert "RandomizationConfig.load_weights['swaying_mass']" in line, line
    from soft_gym.envs.uncalibrated import make_uncalibrated_env

    make_uncalibrated_env("SoftArmTrackWang2023-v0", {  # the file named runs on MuJoCo
        "engine": "mujoco", "feedback": "em", "randomization": str(shipped)}).close()


@pytest.fixture(scope="module")
def small_ppo_run(tmp_path_factory) -> Path:
    """A 256-step PPO run on FAST_ENV (its directory is only read by the tests that use it)."""
    return train(TrainRequest(algo="ppo", env_kwargs=FAST_ENV, timesteps=256,
                              hyperparameters={"n_steps": 128, "batch_size": 64, "n_epochs": 1},
                              out_dir=str(tmp_path_factory.mktemp("small_ppo")), eval_freq=0,
                              checkpoint_freq=0, progress=False))


def test_sb3_agent_with_another_interface_is_refused(small_ppo_run):
    run_dir = small_ppo_run
    env = gym.make("SoftArmTrackWang2023-v0", obs=("pose", "target"), **FAST_ENV)
    with pytest.raises(ValueError, match="interface"):
        make_policy(f"sb3:{run_dir}", env=env)
    env.close()


def test_shipping_keeps_what_loading_needs(tmp_path, small_ppo_run):
    from train.ship import ship

    run_dir = small_ppo_run
    shipped = ship(run_dir, "tiny", destination=tmp_path / "shipped")
    assert sorted(p.name for p in shipped.iterdir()) == [
        "config.yaml", "evaluation.yaml", "learning_curve.png", "model.zip", "source.txt",
        "training.yaml", "vecnormalize.pkl", "versions.yaml"]
    evaluation = yaml.safe_load((shipped / "evaluation.yaml").read_text())
    assert evaluation["reset_seed"] == 123 and evaluation["steps"] > 0
    assert 0 < evaluation["settled_error_mm"] < float("inf")
    env = gym.make("SoftArmTrackWang2023-v0", **FAST_ENV)
    observation, _ = env.reset(seed=0)
    np.testing.assert_array_equal(make_policy(f"sb3:{run_dir}", env=env).predict(observation)[0],
                                  make_policy(f"sb3:{shipped}", env=env).predict(observation)[0])
    with pytest.raises(ValueError, match="best_model"):
        ship(run_dir, "tiny", model="best", destination=tmp_path / "shipped")
    env.close()


def test_rl_zoo3_trains_a_registered_id(tmp_path):
    """rl-baselines3-zoo trains our ids from our config file (its own format).

    The zoo runs torch with one thread, as ``python -m train`` does (``TrainRequest.threads``):
    with a thread per core, a busy second core made the 200 tiny gradient steps take 80 s."""
    pytest.importorskip("rl_zoo3")
    command = [sys.executable, "-m", "rl_zoo3.train", "--algo", "sac",
               "--env", "SoftArmTrackWang2023-v0", "--gym-packages", "soft_gym",
               "--conf-file", str(ROOT / "train" / "configs" / "sac.yml"),
               "-n", "300", "--eval-freq", "-1", "-f", str(tmp_path), "--seed", "1",
               "--env-kwargs", "feedback:'ground_truth'", "-params", "learning_starts:100",
               "--log-interval", "-1", "--verbose", "0"]
    result = subprocess.run(command, capture_output=True, text=True, timeout=600, cwd=ROOT,
                            env={**os.environ, "OMP_NUM_THREADS": "1"})
    assert result.returncode == 0, result.stderr[-2000:]
    models = list(tmp_path.rglob("SoftArmTrackWang2023-v0.zip"))
    assert models, result.stdout[-2000:]


@pytest.mark.parametrize("name", sorted(__import__("agents.policies", fromlist=["x"])
                                        .shipped_agents("SoftArmTrackWang2023-v0")))
def test_shipped_agent_tracks_the_circle(name):
    """Each shipped wang2023 agent loads with its own interface and tracks the nominal circle with EM
    feedback (measured: SAC 0.78 mm over the second cycle)."""
    from eval.runner import RunConfig, run

    record = run(RunConfig(policy=f"sb3:{name}", seed=100,
                           env_kwargs={"path": "circle", "cycles": 2, "feedback": "em"}))
    last = record["cycle"] == record["cycle"].max()
    assert np.mean(record["error_mm"][last]) < 1.5


def test_a_recurrent_agent_carries_its_memory_through_an_episode_and_forgets_it_on_reset(
        tmp_path):
    """ppo_lstm (sb3-contrib's RecurrentPPO): called step by step without a state, the loaded
    policy passes its LSTM state from one call to the next (the actions equal those of SB3's own
    state passing) and a reset starts the memory afresh (the same observations give the same
    actions again)."""
    run_dir = train(TrainRequest(
        algo="ppo_lstm", env_id="SoftArmTrackWang2023-v0", env_kwargs=FAST_ENV, n_envs=1,
        hyperparameters={"n_steps": 128, "batch_size": 64, "n_epochs": 1}, timesteps=128,
        out_dir=str(tmp_path), eval_freq=0, checkpoint_freq=0, progress=False))
    env = gym.make("SoftArmTrackWang2023-v0", **FAST_ENV)
    policy = make_policy(f"sb3:{run_dir}", env=env)
    assert policy.recurrent
    observations = [env.reset(seed=0)[0]] + [env.step(env.action_space.sample())[0]
                                             for _ in range(6)]
    env.close()
    policy.reset()
    carried = [policy.predict(o)[0] for o in observations]
    memory, expected = None, []
    for k, observation in enumerate(observations):
        normalized = policy.normalization.normalize_obs(observation)
        action, memory = policy.model.predict(normalized, state=memory,
                                              episode_start=np.array([k == 0]),
                                              deterministic=True)
        expected.append(action)
    assert all(np.array_equal(a, b) for a, b in zip(carried, expected))
    policy.reset()
    assert all(np.array_equal(a, policy.predict(o)[0]) for a, o in zip(carried, observations))
    policy.reset()
    hidden = [policy.predict(o)[1][0].copy() for o in observations[:2]]
    assert not np.array_equal(hidden[0], hidden[1])  # the memory moves with what it sees


def test_an_interrupted_training_keeps_its_run(tmp_path, monkeypatch):
    """Ctrl-C mid-training (a KeyboardInterrupt from inside learn) saves the model so far and its
    training.yaml entry, marked interrupted, with the steps it took."""
    import train.trainer as trainer

    def interrupt(self):
        if self.num_timesteps >= 250:
            raise KeyboardInterrupt
        return True

    monkeypatch.setattr(trainer.ThroughputCallback, "_on_step", interrupt)
    run_dir = train(TrainRequest(algo="sac", env_kwargs=FAST_ENV, timesteps=1000,
                                 hyperparameters={"learning_starts": 100}, out_dir=str(tmp_path),
                                 eval_freq=0, checkpoint_freq=0, progress=False))
    from stable_baselines3 import SAC

    assert SAC.load(run_dir / "model.zip").num_timesteps == 250
    (entry,) = yaml.safe_load((run_dir / "training.yaml").read_text())
    assert entry["interrupted"] is True and entry["timesteps"] == 250
