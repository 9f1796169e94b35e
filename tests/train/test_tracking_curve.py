"""Training budgets from evaluation curves (train/tracking_curve.py): the plateau rule on curves
whose answer is known, the fixed evaluation set of a recipe, and a short run that writes its
curve, keeps its best model (which tracks exactly as recorded when loaded back) and stops at a
plateau; the command line's refusals."""

from __future__ import annotations

import csv

import gymnasium as gym
import numpy as np
import pytest

import soft_gym  # noqa: F401
from agents.policies import make_policy
from agents.policies.run_dir import BEST_TRACKING_MODEL_FILE
from agents.rollout import run_episode
from agents.tracking_error import last_cycle_error_mm
from tests.cli_errors import assert_one_line_error
from train.__main__ import main as train_main
from train.tracking_curve import (CURVE_CYCLES, CURVE_FILE, CURVE_SEED, evaluation_cases,
                                  has_plateaued)
from train.trainer import TrainRequest, train


@pytest.mark.smoke
def test_the_plateau_rule_on_curves_whose_answer_is_known():
    steps = np.arange(1, 21) * 1000
    # a line falling 2 % of its start per evaluation improves by > 5 % in any last 20 %
    assert not has_plateaued(steps, 100.0 - 2.0 * np.arange(20))
    # flat (or noise around a level): a plateau once there are enough evaluations
    assert has_plateaued(steps, np.full(20, 7.0))
    noisy = 7.0 + np.random.default_rng(0).uniform(-0.1, 0.1, 20)
    assert has_plateaued(steps, noisy)
    assert not has_plateaued(steps[:4], np.full(4, 7.0))  # too few evaluations
    # an exponential approach: judged on its own numbers, best at 0.8 T against best at T
    curve = 1.0 + 20.0 * np.exp(-steps / 2000.0)
    for n in range(5, 21):
        earlier = curve[:n][steps[:n] <= 0.8 * steps[n - 1]].min()
        expected = earlier - curve[:n].min() < 0.05 * earlier
        assert has_plateaued(steps[:n], curve[:n]) == expected, n
    assert not has_plateaued(steps[:6], curve[:6]) and has_plateaued(steps, curve)
    # a late drop after a long flat stretch is not a plateau
    late = np.r_[np.full(18, 10.0), 9.0, 8.0]
    assert not has_plateaued(steps, late)


@pytest.mark.smoke
def test_the_evaluation_set_is_each_path_nominal_and_with_a_load_seen_in_training():
    cases = evaluation_cases({"path": ["circle", "pentagram"], "randomization": True})
    assert [case.label for case in cases] == ["circle nominal", "circle 5 g",
                                              "pentagram nominal", "pentagram 5 g"]
    assert cases[1].env_kwargs == {"path": "circle",
                                   "scenario": {"name": "tip_mass", "mass_kg": 0.005}}
    ranged = evaluation_cases({"path": "circle", "randomization": {"tip_mass_kg": [0.0, 0.15]}})
    assert ranged[1].env_kwargs["scenario"]["mass_kg"] == pytest.approx(0.075)
    assert [case.label for case in evaluation_cases({"path": "rectangle"})] == [
        "rectangle nominal"]
    no_masses = {"randomization": {"load_weights": {"none": 1.0, "tip_mass": 0.0}}}
    assert len(evaluation_cases({"path": "circle", **no_masses})) == 1


def test_a_run_writes_its_curve_keeps_the_best_model_and_stops_at_a_plateau(tmp_path):
    """PPO on two batched MuJoCo arms, evaluated every 128 steps: the CSV holds every
    evaluation, the best model kept loads back and tracks the evaluation set exactly as
    recorded, and a plateau (the rule with a 100 % improvement to beat) stops the run early."""
    env_kwargs = {"engine": "mujoco", "feedback": "em", "path": "circle", "speed_m_s": 0.02,
                  "randomization": {"load_weights": {"none": 0.5, "tip_mass": 0.5,
                                                     "filling_load": 0.0, "push": 0.0,
                                                     "swaying_mass": 0.0},
                                    "tip_mass_kg": [0.0, 0.01]}}
    run_dir = train(TrainRequest(
        algo="ppo", env_id="SoftArmTrackWang2023-v0", env_kwargs=env_kwargs, timesteps=4096,
        hyperparameters={"n_steps": 64, "batch_size": 64, "n_epochs": 1}, n_envs=2,
        vec="batched", out_dir=str(tmp_path), eval_freq=0, checkpoint_freq=0, progress=False,
        curve_freq=128, until_plateau=True, plateau_improvement=0.999))
    with open(run_dir / CURVE_FILE) as handle:
        rows = list(csv.DictReader(handle))
    assert len(rows) == 5  # the rule's fewest evaluations, then the (certain) plateau
    assert [int(row["timesteps"]) for row in rows] == [128, 256, 384, 512, 640]
    assert list(rows[0])[3:] == ["circle nominal (mm)", "circle 5 g (mm)"]
    means = [float(row["mean_last_cycle_mm"]) for row in rows]
    best = int(np.argmin(means))
    assert (run_dir / BEST_TRACKING_MODEL_FILE).is_file()
    assert (run_dir / "tracking_curve.png").is_file()
    # the best model, loaded back, tracks each case as its row records (deterministic episodes)
    errors = []
    for case in evaluation_cases(env_kwargs):
        env = gym.make("SoftArmTrackWang2023-v0",
                       **{**{k: v for k, v in env_kwargs.items() if k != "randomization"},
                          **case.env_kwargs, "cycles": CURVE_CYCLES})
        policy = make_policy(f"sb3:{run_dir / BEST_TRACKING_MODEL_FILE}", env=env)
        errors.append(last_cycle_error_mm(run_episode(env, policy, seed=CURVE_SEED,
                                                      learn=False)))
        env.close()
    assert np.mean(errors) == pytest.approx(means[best], abs=1e-4)
    summary = (run_dir / "training.yaml").read_text()
    assert "stopped_at_plateau: true" in summary and "timesteps: 640" in summary


@pytest.mark.smoke
@pytest.mark.parametrize("argv, option", [
    (["--until-plateau"], "--until-plateau"),
    (["--curve-freq", "100", "--min-timesteps", "50"], "--min-timesteps"),
    (["--curve-freq", "-1"], "--curve-freq"),
    (["--curve-freq", "100", "--until-plateau", "--plateau-fraction", "1.5"],
     "--plateau-fraction"),
    (["--curve-freq", "100", "--until-plateau", "--plateau-improvement", "nan"],
     "--plateau-improvement"),
    (["--env", "SoftArmReachWang2023-v0", "--curve-freq", "100"], "--curve-freq"),
])
def test_bad_curve_options_are_one_line_errors(argv, option, capsys, tmp_path):
    assert_one_line_error(train_main, argv + ["--out", str(tmp_path / "out")], option, capsys,
                          out=tmp_path / "out")


def _no_training(request):
    raise AssertionError(f"trained instead of refusing: {request}")


@pytest.mark.smoke
@pytest.mark.parametrize("argv, option, also", [
    # the plateau rule's options without the rule
    (["--curve-freq", "100", "--plateau-fraction", "0.3"], "--plateau-fraction",
     "--until-plateau"),
    (["--curve-freq", "100", "--plateau-improvement", "0.1"], "--plateau-improvement",
     "--until-plateau"),
    # a rule that can never fire within the run's steps
    (["--curve-freq", "16", "--until-plateau", "--min-timesteps", "1000", "--timesteps", "640"],
     "--min-timesteps", "640"),
    (["--curve-freq", "16", "--until-plateau", "--min-timesteps", "640", "--timesteps", "640"],
     "--min-timesteps", "640"),
    (["--curve-freq", "16", "--until-plateau", "--timesteps", "64"], "--until-plateau", "5"),
    # a curve that is never written
    (["--curve-freq", "100000", "--timesteps", "64"], "--curve-freq", "64"),
    (["--curve-freq", "100001", "--conf-file", "train/configs/sac_ho2018_small_rectangle.yml",
      "--preset", "ho2018"], "--curve-freq", "n_timesteps"),
])
def test_curve_options_that_cannot_act_are_refused(argv, option, also, capsys, tmp_path,
                                                 monkeypatch):
    """An option the run would ignore is refused before any work, naming it and what it needs:
    the plateau rule's settings without --until-plateau, a rule that can never stop the run
    (--min-timesteps not below the run's steps, or too few evaluations for the rule), and a
    --curve-freq beyond the run's steps (no curve would be written)."""
    monkeypatch.setattr("train.trainer.train", _no_training)
    assert_one_line_error(train_main, argv + ["--out", str(tmp_path / "out")], option, capsys,
                          out=tmp_path / "out", also=also)


def test_curve_options_with_what_they_need_are_accepted(tmp_path):
    """The same options given with what they need pass every check, and left out they keep
    their defaults."""
    from train.__main__ import build_parser, check_training

    parser = build_parser()
    args = parser.parse_args(["--curve-freq", "16", "--until-plateau", "--timesteps", "80",
                              "--min-timesteps", "40", "--plateau-fraction", "0.3",
                              "--plateau-improvement", "0.1", "--env-kwargs",
                              "feedback=ground_truth", "--out", str(tmp_path)])
    request = check_training(parser, args, {"feedback": "ground_truth"}, {})
    assert (request.plateau_fraction, request.plateau_improvement) == (0.3, 0.1)
    assert request.min_timesteps == 40 and request.curve_freq == 16
    args = parser.parse_args(["--curve-freq", "16", "--timesteps", "80", "--out", str(tmp_path)])
    request = check_training(parser, args, {"feedback": "ground_truth"}, {})
    assert (request.plateau_fraction, request.plateau_improvement) == (0.2, 0.05)
