"""ho2018's pre-training check (Section 3.2, Figs. 4-5) on its quick amount of data: the 80/20
split, the forward model's RMSE against predicting no motion, and that the model checked is the
one the static experiment's lwpr_rwr keeps."""

from __future__ import annotations

import json
import math

import gymnasium as gym
import pytest

from agents.policies import make_policy
from eval.papers.ho2018 import experiments as ho2018


@pytest.fixture(scope="module")
def quick_check():
    return ho2018.run_pretraining_check(seed=0, quick=True, progress=False)


def _numbers(value):
    if isinstance(value, dict):
        for item in value.values():
            yield from _numbers(item)
    elif isinstance(value, list):
        for item in value:
            yield from _numbers(item)
    else:
        yield value


def test_the_check_reports_every_number_json_able_and_finite(quick_check):
    assert json.loads(json.dumps(quick_check)) == quick_check
    assert {"n_transitions", "n_train", "n_test", "receptive_fields", "forward_rmse_mm",
            "forward_rmse_axis_mm", "zero_dp_rmse_mm", "inverse_error_mm",
            "epochs"} <= set(quick_check)
    for part in ("train", "test"):
        assert len(quick_check["forward_rmse_axis_mm"][part]) == 3
    for key in ("inverse_error_mm", "inverse_error_reachable_mm", "inverse_error_deployed_mm"):
        assert len(quick_check[key]["max_per_axis"]) == 3
        assert all(v >= 0 for v in quick_check[key]["max_per_axis"])
    assert len(quick_check["receptive_fields"]) == 3
    assert all(n >= 1 for n in quick_check["receptive_fields"])
    numbers = list(_numbers(quick_check))
    assert all(isinstance(v, (int, float)) and math.isfinite(v) for v in numbers)


def test_the_walks_transitions_are_split_80_20(quick_check):
    """8 waypoints, 30 decisions a straight line: 240 transitions, 192 to train, 48 to test."""
    n = quick_check["n_transitions"]
    assert n == ho2018.QUICK_PRETRAIN_WAYPOINTS * 30 == 240
    assert quick_check["n_train"] + quick_check["n_test"] == n
    assert quick_check["n_train"] == round(0.8 * n)


def test_the_kept_epoch_has_the_lowest_test_rmse(quick_check):
    history = quick_check["forward_rmse_history_mm"]
    kept = quick_check["epochs"]
    assert 1 <= kept <= quick_check["epochs_run"] <= quick_check["max_epochs"] == 15
    assert len(history["train"]) == len(history["test"]) == quick_check["epochs_run"]
    assert history["test"][kept - 1] == min(history["test"])
    assert quick_check["forward_rmse_mm"]["test"] == pytest.approx(history["test"][kept - 1])
    assert quick_check["forward_rmse_mm"]["train"] == pytest.approx(history["train"][kept - 1])


def test_the_forward_model_predicts_the_held_out_motion_better_than_no_motion(quick_check):
    """The test transitions' RMSE is below that of predicting dp = 0, and, being read from the
    EM tracker's noisy positions, not below what its noise alone leaves."""
    test = quick_check["forward_rmse_mm"]["test"]
    assert test < quick_check["zero_dp_rmse_mm"]["test"]
    assert test > 0.9 * quick_check["em_noise_floor_mm"]
    axes = quick_check["forward_rmse_axis_mm"]["test"]
    assert math.sqrt(sum(v * v for v in axes)) == pytest.approx(test)


def test_the_checked_model_is_the_one_the_static_experiment_pre_trains(quick_check):
    """The same walk and training as the static experiment's lwpr_rwr, at the check's amount."""
    env = gym.make("SoftArmReach-v0", preset="ho2018", feedback="em", obs=("pose", "target"),
                   actuation=ho2018.ACTUATION)
    try:
        policy = make_policy("lwpr_rwr", env, cache=False, progress=False,
                             **ho2018.lwpr_rwr_settings(
                                 "static", False, 0,
                                 pretrain_waypoints=ho2018.QUICK_PRETRAIN_WAYPOINTS))
        report = policy.pretrain()
    finally:
        env.close()
    assert report["samples"] == quick_check["n_transitions"]
    assert report["best_epoch"] == quick_check["epochs"]
    assert report["best_test_rmse_mm"] == pytest.approx(quick_check["forward_rmse_mm"]["test"],
                                                        rel=1e-12)
    assert report["receptive_fields"] == quick_check["receptive_fields"]


def test_a_check_that_is_not_quick_or_full_is_refused():
    with pytest.raises(ValueError, match="quick must be True or False"):
        ho2018.run_pretraining_check(quick="yes")
