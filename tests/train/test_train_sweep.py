"""``python -m train sweep`` (train/sweep.py): a two-trial Ray Tune search on a local Ray (two
CPUs) writes the best trial's hyperparameters as a zoo-format YAML that the trainer loads, a
trial's score on Ray equals the same trial run in this process, and bad options fail in one
line before any trial. ``python -m train --algo ...`` is unchanged. The searches on a real
local Ray (an optional extra) run with ``-m slow``."""

from __future__ import annotations

import json
import sys

import gymnasium
import pytest
import yaml

from train import sweep
from train.__main__ import build_parser as train_parser
from train.__main__ import main as train_main
from train.config import read_hyperparameters, split_hyperparameters
from train.trainer import TrainRequest, resolve

ENV_ID = "SoftArmTrackWang2023-v0"
FAST_ENV = ["feedback=ground_truth", "path=circle", "speed_m_s=0.05", "randomization=false"]
"""A 26-step circle with the true tip pose: training and evaluation take seconds."""
FIXED = ["learning_starts=100", "buffer_size=10000"]


@pytest.mark.slow
def test_a_two_trial_sweep_writes_the_best_config_in_the_zoo_format(tmp_path, local_ray,
                                                                     capsys):
    out = tmp_path / "sweep"
    train_main(["sweep", "--env", ENV_ID, "--env-kwargs", *FAST_ENV, "-hp", *FIXED,
                "--trials", "2", "--steps", "300", "--eval-episodes", "2", "--out", str(out),
                "--no-progress"])
    lines = capsys.readouterr().out.strip().splitlines()
    assert lines[-2:] == [f"best config: {out / 'sac.yml'}", f"trials: {out / 'trials.json'}"]
    assert (out / "trials.md").read_text().count("\n") == 2 + 2  # header, rule, two trials
    assert local_ray.is_initialized()  # a Ray the sweep did not start is left running

    summary = json.loads((out / "trials.json").read_text())
    trials = summary["trials"]
    assert len(trials) == 2 and all(t["status"] == "done" for t in trials)
    for trial in trials:
        assert set(trial["hyperparameters"]) == set(sweep.SEARCH_SPACE)
        assert trial["score"] == trial["error_mm"] > 0 and trial["reward"] < 0
        assert trial["episodes"] == 2 and trial["eval_steps"] == 52
    # the first trial is the config entry's own values (they lie in the space)
    assert trials[0]["hyperparameters"] == {
        "learning_rate": 3e-4, "gamma": 0.9, "tau": 0.005, "batch_size": 256, "train_freq": 1,
        "gradient_steps": 1, "hidden_units": 128, "action_rate_weight": 1e-3}
    best = min(trials, key=lambda t: t["score"])
    assert summary["best"] == best and summary["mode"] == "min"

    # sac.yml: {env id: entry} loading through the trainer's own reader
    text = (out / "sac.yml").read_text()
    assert text.startswith("# Best of 2 SAC trials")
    table = yaml.safe_load(text)
    assert list(table) == [ENV_ID]
    entry = read_hyperparameters("sac", ENV_ID, out / "sac.yml")
    assert sweep.entry_values(entry) == best["hyperparameters"]
    assert entry["learning_starts"] == 100 and entry["buffer_size"] == 10000
    assert entry["env_kwargs"] == {"feedback": "ground_truth", "path": "circle",
                                   "speed_m_s": 0.05, "randomization": False,
                                   "action_rate_weight": best["hyperparameters"][
                                       "action_rate_weight"]}
    reference = read_hyperparameters("sac", ENV_ID)
    assert entry["n_timesteps"] == reference["n_timesteps"]  # the full budget, not the trials'
    units = best["hyperparameters"]["hidden_units"]
    assert entry["policy_kwargs"] == f"dict(net_arch=[{units}, {units}])"
    settings, _ = resolve(TrainRequest(algo="sac", env_id=ENV_ID,
                                       config_file=str(out / "sac.yml")))
    assert settings.algo_kwargs["batch_size"] == best["hyperparameters"]["batch_size"]
    assert settings.algo_kwargs["tau"] == best["hyperparameters"]["tau"]
    split_hyperparameters("sac", entry)

    # the Ray trial's score is the same trial's score in this process
    context = {"env_id": ENV_ID, "entry": summary["base_entry"], "steps": 300, "seed": 0,
               "eval_episodes": 2, "metric": "error_mm"}
    local = sweep.run_trial(best["hyperparameters"], context)
    assert local["score"] == best["score"] and local["reward"] == best["reward"]


@pytest.mark.slow
def test_a_sweep_whose_trials_all_fail_exits_1_naming_the_error(tmp_path, local_ray, capsys):
    """A failure only training meets (the replay buffer refuses a keyword argument; bad options
    and env keyword arguments are refused before any trial)."""
    out = tmp_path / "failed"
    with pytest.raises(SystemExit) as exit_info:
        train_main(["sweep", "--env", ENV_ID, "--env-kwargs", *FAST_ENV, "-hp",
                    "learning_starts=10", "replay_buffer_kwargs=dict(bogus=1)", "--trials", "1",
                    "--steps", "20", "--out", str(out), "--no-progress"])
    assert exit_info.value.code == 1
    error = capsys.readouterr().err.strip().splitlines()[-1]
    assert error.startswith("error: all 1 trials failed") and "bogus" in error
    trial, = json.loads((out / "trials.json").read_text())["trials"]
    assert trial["status"] == "error" and trial["error"].startswith("TypeError:")
    assert not (out / "sac.yml").exists()


@pytest.mark.slow
def test_an_optuna_search_runs_and_keeps_the_baseline_trial(tmp_path, local_ray):
    pytest.importorskip("optuna")
    request = sweep.SweepRequest(
        env_id=ENV_ID, env_kwargs={"feedback": "ground_truth", "path": "circle",
                                   "speed_m_s": 0.05, "randomization": False},
        hyperparameters={"learning_starts": 100, "buffer_size": 10000}, trials=3, steps=300,
        eval_episodes=1, search="optuna", out=str(tmp_path / "optuna"), progress=False)
    result = sweep.run_sweep(request)
    assert len(result.trials) == 3 and all(t["status"] == "done" for t in result.trials)
    assert any(t["hyperparameters"]["batch_size"] == 256 and t["hyperparameters"]["gamma"] == 0.9
               for t in result.trials)
    assert yaml.safe_load(result.config_path.read_text())[ENV_ID]["batch_size"] in (64, 128, 256)


def test_searched_values_land_where_sac_and_the_env_read_them():
    """Top-level SAC keys, ``hidden_units`` as ``net_arch`` inside ``policy_kwargs`` (a rl-zoo3 string stays a
    string with its other keys) and the action-rate weight among the env's keyword arguments;
    the entry's own values read back, SAC's and the env's defaults where it has none."""
    entry = {"n_timesteps": 1000, "policy": "MlpPolicy", "gamma": 0.9,
             "policy_kwargs": "dict(log_std_init=-1.0, net_arch=[128, 128])",
             "env_kwargs": {"feedback": "em"}}
    point = {"learning_rate": 5e-4, "gamma": 0.95, "tau": 0.01, "batch_size": 64,
             "train_freq": 4, "gradient_steps": 2, "hidden_units": 64,
             "action_rate_weight": 1e-3}
    applied = sweep.apply_values(entry, point)
    assert sweep.entry_values(applied) == point
    assert applied["policy_kwargs"] == "dict(log_std_init=-1.0, net_arch=[64, 64])"
    assert applied["env_kwargs"] == {"feedback": "em", "action_rate_weight": 1e-3}
    assert entry["env_kwargs"] == {"feedback": "em"}  # the entry itself is left as it was
    settings = split_hyperparameters("sac", applied)
    assert settings.algo_kwargs["policy_kwargs"] == {"log_std_init": -1.0, "net_arch": [64, 64]}
    assert (settings.algo_kwargs["train_freq"], settings.algo_kwargs["gradient_steps"]) == (4, 2)
    defaults = sweep.entry_values({"n_timesteps": 1000})
    env = gymnasium.make(ENV_ID, feedback="ground_truth")
    assert defaults["action_rate_weight"] == env.unwrapped.action_rate_weight  # the env's own
    env.close()
    assert defaults["hidden_units"] == 256
    assert defaults["train_freq"] == 1 and defaults["batch_size"] == 256
    assert sweep.baseline_point({"n_timesteps": 1000, "gamma": 0.5}) is None  # outside
    assert sweep.baseline_point({"policy_kwargs": {"net_arch": [64, 32]}}) is None
    assert sweep.trial_arms({"n_envs": 4, "env_kwargs": {"engine": "mujoco"}}) == (4, "batched")
    assert sweep.trial_arms({"n_envs": 4, "env_kwargs": {}}) == (1, "subprocess")


def test_the_trials_table_lists_the_best_first_and_failures_last():
    values = {name: (spec[1] if spec[0] == "loguniform" else spec[1][0])
              for name, spec in sweep.SEARCH_SPACE.items()}
    trials = [{"trial_id": "a", "hyperparameters": values, "status": "done", "score": 4.0,
               "wall_s": 10.0},
              {"trial_id": "b", "hyperparameters": values, "status": "error",
               "error": "ValueError: x"},
              {"trial_id": "c", "hyperparameters": values, "status": "done", "score": 2.5,
               "wall_s": 12.0}]
    lines = sweep.trials_table(trials, "error_mm").splitlines()
    assert lines[0].split(" | ")[1:3] == list(sweep.SEARCH_SPACE)[:2]
    assert [line.split(" | ")[0] for line in lines[2:]] == ["| c", "| a", "| b"]
    assert "failed: ValueError: x" in lines[-1]
    by_reward = sweep.trials_table(trials, "reward").splitlines()  # higher is better
    assert [line.split(" | ")[0] for line in by_reward[2:]] == ["| a", "| c", "| b"]


# ----------------------------------------------------------------------- command line
@pytest.mark.parametrize("argv, option", [
    (["--trials", "0"], "--trials"),
    (["--steps", "-5"], "--steps"),
    (["--eval-episodes", "0"], "--eval-episodes"),
    (["--workers", "0"], "--workers"),
    (["--seed", "-1"], "--seed"),
    (["--address", " "], "--address"),
    (["-hp", "gamma=0.95"], "--hyperparams"),
    (["-hp", "n_timesteps=1000"], "--hyperparams"),
    (["-hp", "novalue"], "--hyperparams"),
    (["--env", "NoSuchEnv-v0"], "--env"),
    (["--metric", "accuracy"], "--metric"),
    (["--search", "grid"], "--search"),
    (["--trials", "two"], "--trials"),
    (["-hp", "nonsense=1"], "--hyperparams"),
    (["-hp", "tau=2"], "--hyperparams"),
    (["--env-kwargs", "feedback=gps"], "--env-kwargs"),
    (["--env-kwargs", "action_rate_weight=0.1"], "--env-kwargs"),
    (["-hp", "hidden_units=8"], "--hyperparams"),
    (["--preset", "nope"], "--preset"),
    (["--conf-file", "/nonexistent/sac.yml"], "--conf-file"),
])
def test_cli_bad_options_exit_2_with_one_line(argv, option, tmp_path, capsys):
    with pytest.raises(SystemExit) as exit_info:
        train_main(["sweep", "--out", str(tmp_path / "o"), "--steps", "2000"] + argv)
    assert exit_info.value.code == 2
    error = capsys.readouterr().err.strip().splitlines()[-1]
    assert error.startswith("python -m train sweep: error:") and option in error, error
    assert not (tmp_path / "o").exists()


def test_cli_steps_below_learning_starts_is_refused(tmp_path, capsys):
    with pytest.raises(SystemExit) as exit_info:
        train_main(["sweep", "--out", str(tmp_path / "o"), "--steps", "500"])
    assert exit_info.value.code == 2
    error = capsys.readouterr().err.strip().splitlines()[-1]
    assert "--steps" in error and "learning_starts (1000)" in error



def test_cli_drawn_swaying_masses_on_mujoco_name_the_randomisation_file_without_them(
        tmp_path, capsys):
    """The recipe's randomisation draws swaying masses, which MuJoCo lacks: the one-line error
    names the --env-kwargs entry that draws none."""
    with pytest.raises(SystemExit) as exit_info:
        train_main(["sweep", "--out", str(tmp_path / "o"), "--steps", "5000", "--env-kwargs",
                    "engine=mujoco"])
    assert exit_info.value.code == 2
    error = capsys.readouterr().err.strip().splitlines()[-1]
    assert error.startswith("python -m train sweep: error: --env-kwargs:"), error
    assert error.endswith("; --env-kwargs randomization=train/configs/randomization_mujoco.yaml "
                          "draws none"), error
    assert not (tmp_path / "o").exists()

def test_cli_without_ray_names_the_extra(tmp_path, capsys, monkeypatch):
    monkeypatch.setitem(sys.modules, "ray", None)  # import ray raises ImportError
    with pytest.raises(SystemExit) as exit_info:
        train_main(["sweep", "--out", str(tmp_path / "o")])
    assert exit_info.value.code == 2
    error = capsys.readouterr().err.strip().splitlines()[-1]
    assert 'pip install "soft-arm-gym[ray]"' in error
    assert not (tmp_path / "o").exists()


def test_the_sweep_help_shows_the_space_and_the_training_cli_is_unchanged(capsys):
    with pytest.raises(SystemExit) as exit_info:
        train_main(["sweep", "--help"])
    assert exit_info.value.code == 0
    text = capsys.readouterr().out
    assert "learning_rate" in text and "(default: 8)" in text
    args = train_parser().parse_args(["--algo", "td3", "--timesteps", "10"])
    assert (args.algo, args.timesteps) == ("td3", 10)
    with pytest.raises(SystemExit):
        train_main(["--algo", "nope"])  # still the training parser's own error
    assert "invalid choice" in capsys.readouterr().err
