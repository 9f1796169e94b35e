"""A sweep of bad input over the surfaces added since the last hardening (suite YAML, the sensing
options of the zhao2021/zou2022 sources, the baselines' seeds and parameters, the command lines
of eval, train and train sweep): each case is one ``ValueError`` naming the parameter (or, on a
command line, one line naming the option with exit status 2), checked before any work."""

from __future__ import annotations

from pathlib import Path

import pytest

import eval.__main__ as eval_main
from agents.policies import make_policy
from cli_errors import assert_one_line_error
from eval import suite
from soft_gym._validation import SEED_MAX
from soft_gym.sensing.zhao2021.shape_reconstruction import ReconstructionConfig
from soft_gym.sensing.zou2022.shape_dnn import ShapeDNNConfig
from soft_gym.sensing.zou2022.stereo_shape import ASESConfig
from train import sweep
from train.__main__ import main as train_main

TOO_BIG = SEED_MAX + 1  # 2**32: np.random.seed refuses it, torch.manual_seed takes < 2**64


# ------------------------------------------------------------------------------------ seeds
SEED_OPTIONS = {  # name -> a call with a seed out of range
    "ASES seed": lambda seed: ASESConfig.from_options({"seed": seed}),
    "shape DNN seed": lambda seed: ShapeDNNConfig.from_options({"seed": seed}),
    "shape reconstruction seed": lambda seed: ReconstructionConfig.from_options({"seed": seed}),
}


@pytest.mark.smoke
@pytest.mark.parametrize("case", sorted(SEED_OPTIONS))
@pytest.mark.parametrize("seed", [TOO_BIG, 2**64, -1])
def test_sensing_seeds_out_of_range_are_refused_naming_seed(case, seed):
    with pytest.raises(ValueError, match=rf"seed must be an integer >= 0 and <= {SEED_MAX}"):
        SEED_OPTIONS[case](seed)
    SEED_OPTIONS[case](SEED_MAX)  # the largest seed is accepted


@pytest.fixture(scope="module")
def zhao_env():
    import gymnasium as gym

    env = gym.make("SoftArmTrack-v0", preset="zhao2021", feedback="ground_truth",
                   obs=["pose", "target", "strain", "pressure"])
    yield env
    env.close()


@pytest.mark.parametrize("policy", ["lwpr_rwr", "local_ik_asdm"])
def test_baseline_seeds_out_of_range_are_refused_at_construction(policy, zhao_env):
    with pytest.raises(ValueError, match=rf"seed must be an integer >= 0 and <= {SEED_MAX}"):
        make_policy(policy, env=zhao_env, seed=TOO_BIG)


def test_suite_seeds_out_of_range_are_refused_naming_the_key(tmp_path):
    path = tmp_path / "seeds.yaml"
    path.write_text(f"name: s\nseeds: [0, {TOO_BIG}]\narms: {{}}\n")
    with pytest.raises(ValueError, match=rf"{path}: seeds: must be .* <= {SEED_MAX}"):
        suite.load_suite(path)
    with pytest.raises(ValueError, match="seeds"):
        suite.load_suite("small").with_seeds([TOO_BIG])


CLI_SEEDS = [
    (eval_main.main, ["suite", "small", "--seeds", str(TOO_BIG)], "--seeds"),
    (eval_main.main, ["track", "--seeds", str(TOO_BIG)], "--seeds"),
    (eval_main.main, ["estimation", "--seed", str(TOO_BIG)], "--seed"),
    (train_main, ["--seed", str(TOO_BIG), "--timesteps", "64"], "--seed"),
    (train_main, ["sweep", "--seed", str(TOO_BIG), "--steps", "2000"], "--seed"),
    (train_main, ["sweep", "--seed", str(SEED_MAX), "--steps", "2000"], "--seed"),
]


@pytest.mark.parametrize("main, argv, option", CLI_SEEDS,
                         ids=[" ".join(argv[:3]) for _, argv, _ in CLI_SEEDS])
def test_command_line_seeds_out_of_range_exit_2_naming_the_option(main, argv, option, tmp_path,
                                                                  capsys):
    out = tmp_path / "out"
    line = assert_one_line_error(main, argv + ["--out", str(out)], option, capsys, out=out)
    assert str(SEED_MAX - (sweep.EVAL_SEED_OFFSET if argv[-3] == str(SEED_MAX) else 0)) in line


def test_the_sweep_request_bounds_its_seed_by_the_evaluation_offset():
    request = sweep.SweepRequest(env_id="SoftArmTrackWang2023-v0", env_kwargs={},
                                 hyperparameters={}, seed=SEED_MAX - sweep.EVAL_SEED_OFFSET + 1,
                                 steps=2000, out=str(Path("unused")))
    with pytest.raises(ValueError, match=r"seed must be an integer in \[0, "):
        sweep.base_entry(request)
