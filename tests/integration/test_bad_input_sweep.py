"""A sweep of bad input over the surfaces added since the last hardening (suite YAML, the sensing
options of the zhao2021/zou2022 sources, the baselines' seeds and parameters, the command lines
of eval, train and train sweep): each case is one ``ValueError`` naming the parameter (or, on a
command line, one line naming the option with exit status 2), checked before any work."""

from __future__ import annotations

import datetime
import time
from pathlib import Path

import pytest
import yaml

import eval.__main__ as eval_main
from agents.policies import make_policy
from cli_errors import assert_one_line_error
from eval import suite
from soft_gym._validation import SEED_MAX
from soft_gym.papers.zhao2021.shape_reconstruction import ReconstructionConfig
from soft_gym.papers.zou2022.shape_dnn import ShapeDNNConfig
from soft_gym.papers.zou2022.stereo_shape import ASESConfig
from suite_specs import tiny_suite
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


# ----------------------------------------------------------------------------- suite YAML
TINY = tiny_suite("yaml")

BOMB = "a: &a [x, x, x, x, x, x, x, x, x]\n" + "".join(
    f"{chr(98 + i)}: &{chr(98 + i)} [{', '.join([f'*{chr(97 + i)}'] * 9)}]\n" for i in range(8))
"""A billion-laughs alias bomb, under 600 bytes: 9**9 strings once expanded."""

def _speed(value: str) -> str:
    """The tiny suite with the first arm's ``speed_m_s`` written as ``value``."""
    return TINY.replace("speed_m_s: 0.05", f"speed_m_s: {value}", 1)


SPEED = "arms.wang2023.env.speed_m_s"
YAML_CASES = {  # case -> (the file's text, the key named, words of the message)
    "a date": (_speed("2024-01-01"), SPEED, "got a date"),
    "binary": (_speed("!!binary aGVsbG8="), SPEED, "got a bytes"),
    "a set": (TINY.replace("nominal: {}", "nominal: !!set {a, b}", 1),
              "arms.wang2023.conditions.nominal", "got a set"),
    "a number as key": (TINY.replace("nominal: {}", "1: {}", 1),
                        "arms.wang2023.conditions", "keys must be text"),
    "nan": (_speed(".nan"), SPEED, "finite number"),
    "inf": (_speed("-.inf"), SPEED, "finite number"),
    "deep nesting": (TINY.replace("description", "d") + "description: " + "[" * 3000
                     + "]" * 3000 + "\n", "", "nesting deeper than"),
    "an alias bomb": (BOMB, "", "aliases"),
    "a pipe in a condition": (TINY.replace("nominal: {}", "a|b: {}", 1),
                              "arms.wang2023.conditions.a|b", "letters, digits"),
    "a long value": (TINY.replace("cycles: 1", "cycles: [" + ", ".join(["7"] * 5000) + "]", 1),
                     "cycles", "..."),
}


@pytest.mark.smoke
@pytest.mark.parametrize("case", sorted(YAML_CASES))
def test_suite_yaml_refuses_non_json_values_aliases_and_depth_naming_the_key(case, tmp_path):
    text, key, words = YAML_CASES[case]
    path = tmp_path / "bad.yaml"
    path.write_text(text)
    start = time.perf_counter()
    with pytest.raises(ValueError) as error:
        suite.load_suite(path)
    assert time.perf_counter() - start < 5.0
    message = str(error.value)
    assert type(error.value) is suite.SuiteError and message.startswith(f"{path}: {key}")
    assert words in message and "\n" not in message, message
    assert len(message) <= suite.spec.MESSAGE_CHARS


def test_suite_yaml_aliases_within_the_budget_load(tmp_path):
    text = TINY.replace("env: {speed_m_s: 0.05}", "env: &slow {speed_m_s: 0.05}", 1).replace(
        "env: {speed_m_s: 0.05}", "env: *slow", 1)
    assert "*slow" in text
    path = tmp_path / "aliases.yaml"
    path.write_text(text)
    spec = suite.load_suite(path)
    assert [arm.env for arm in spec.arms] == [{"speed_m_s": 0.05}, {"speed_m_s": 0.05}]


def test_suite_file_that_is_not_utf8_names_the_file_and_the_byte(tmp_path):
    path = tmp_path / "latin1.yaml"
    path.write_bytes(TINY.replace("name: yaml", "name: caf\xe9").encode("latin-1"))
    with pytest.raises(ValueError, match=rf"^{path}: not UTF-8 text: byte 0xe9 at line 1"):
        suite.load_suite(path)


def test_parsed_suites_are_validated_before_anything_is_hashed():
    data = yaml.safe_load(TINY)
    data["arms"]["wang2023"]["conditions"]["nominal"] = {"speed_m_s": datetime.date(2024, 1, 1)}
    with pytest.raises(suite.SuiteError, match="conditions.nominal.speed_m_s: .* got a date"):
        suite.parse_suite(data, source="<data>")


def test_an_env_refusal_blames_the_key_that_set_the_value(tmp_path):
    """``cycles: 1000000`` makes too long an episode: the check names ``cycles``, not the arm's
    feedback; a condition's refused keyword is named within the condition."""
    path = tmp_path / "cycles.yaml"
    path.write_text(TINY.replace("cycles: 1", "cycles: 1000000", 1))
    with pytest.raises(ValueError, match=rf"^{path}: cycles: cycles=1000000"):
        suite.check_suite(suite.load_suite(path))
    path.write_text(TINY.replace("nominal: {}", "nominal: {faults: low_light}", 1))
    with pytest.raises(ValueError, match=rf"^{path}: arms.wang2023.conditions.nominal.faults: "):
        suite.check_suite(suite.load_suite(path))


# ------------------------------------------------------------------ learning parameters
LWPR_RWR_BAD = {  # parameters -> the name the message must hold
    "w_gen 0": ({"w_gen": 0.0}, "w_gen"),
    "w_gen 1": ({"w_gen": 1.0}, "w_gen"),
    "attractor_gain 1e160": ({"attractor_gain": 1e160}, "attractor_gain"),
    "ridge 1e-30": ({"ridge": 1e-30}, "ridge"),
    "ridge 1e30": ({"ridge": 1e30}, "ridge"),
    "too few pre-training transitions": ({"pretrain_waypoints": 2, "leg_decisions": 1},
                                         "pretrain_waypoints * leg_decisions"),
}


@pytest.mark.parametrize("case", sorted(LWPR_RWR_BAD))
def test_lwpr_rwr_learning_parameters_are_bounded_at_construction(case, zhao_env):
    params, name = LWPR_RWR_BAD[case]
    with pytest.raises(ValueError, match=name.replace("*", r"\*")):
        make_policy("lwpr_rwr", env=zhao_env, cache=False, **params)


LEARNING_RATES = {
    "strain_sr (shape reconstruction)": lambda lr: ReconstructionConfig.from_options(
        {"learning_rate": lr}),
    "encoder_dnn (shape DNN)": lambda lr: ShapeDNNConfig.from_options({"learning_rate": lr}),
}


@pytest.mark.parametrize("case", sorted(LEARNING_RATES))
@pytest.mark.parametrize("rate", [1e12, 1.5, 0.0, -1e-3])
def test_learning_rates_above_one_or_not_positive_are_refused(case, rate):
    with pytest.raises(ValueError, match=r"learning_rate must be a finite number > 0 and <= 1"):
        LEARNING_RATES[case](rate)
    LEARNING_RATES[case](1.0)


def test_local_ik_asdm_learning_rate_is_bounded(zhao_env):
    with pytest.raises(ValueError, match="learning_rate .* <= 1"):
        make_policy("local_ik_asdm", env=zhao_env, learning_rate=1e12)


# -------------------------------------------------------------------- env arguments
@pytest.mark.smoke
@pytest.mark.parametrize("mode", ["human", "rgb_array_list", "ansi"])
def test_render_modes_the_env_lacks_are_refused_at_construction(mode):
    import gymnasium as gym

    with pytest.raises(ValueError, match=rf"render_mode must be None or 'rgb_array', got '{mode}'"):
        gym.make("SoftArmTrack-v0", preset="wang2023", feedback="ground_truth", render_mode=mode)
    env = gym.make("SoftArmTrack-v0", preset="wang2023", feedback="ground_truth",
                   render_mode="rgb_array")
    assert env.render_mode == "rgb_array" and env.metadata["render_modes"] == ["rgb_array"]
    env.close()


@pytest.mark.smoke
@pytest.mark.parametrize("name", ["target_m", "start_m"])
@pytest.mark.parametrize("point", [[False, False, True], ["0", "0", "0.08"], [b"0", 0, 0]],
                         ids=["booleans", "text", "bytes"])
def test_points_must_be_numbers(name, point):
    import gymnasium as gym

    with pytest.raises(ValueError, match=rf"^{name} must be three numbers \(m\)"):
        gym.make("SoftArmReach-v0", preset="wang2023", feedback="ground_truth", **{name: point})


# -------------------------------------------------------------- environment variables
@pytest.mark.parametrize("main, argv", [
    (eval_main.main, ["suite", "small"]),
    (eval_main.main, ["track"]),
    (train_main, ["--timesteps", "64"]),
    (train_main, ["sweep", "--steps", "2000"]),
], ids=["eval suite", "eval track", "train", "train sweep"])
def test_a_bad_cache_setting_is_refused_before_any_work(main, argv, tmp_path, capsys,
                                                        monkeypatch):
    monkeypatch.setenv("SOFT_GYM_CACHE", "maybe")
    out = tmp_path / "out"
    line = assert_one_line_error(main, argv + ["--out", str(out)], "SOFT_GYM_CACHE", capsys,
                                 out=out)
    assert "'on' or 'off'" in line and "'maybe'" in line


def test_run_suite_refuses_a_bad_cache_setting_before_any_run(tmp_path, monkeypatch):
    monkeypatch.setenv("SOFT_GYM_CACHE", "maybe")
    ran = []
    with pytest.raises(ValueError, match="SOFT_GYM_CACHE must be 'on' or 'off'"):
        suite.run_suite("small", tmp_path / "out", check=False, progress=False,
                        backend=lambda fn, items, workers: ran.extend(items) or iter(()))
    assert ran == [] and not (tmp_path / "out").exists()


def test_sweep_blames_the_hyperparameter_option_for_a_bad_learning_starts(tmp_path, capsys):
    out = tmp_path / "out"
    line = assert_one_line_error(train_main, ["sweep", "-hp", "learning_starts=-5", "--steps",
                                              "2000", "--out", str(out)], "--hyperparams",
                                 capsys, out=out)
    assert "learning_starts must be an integer >= 0, got -5" in line and "--steps" not in line


def test_track_with_a_feedback_cc_model_cannot_calibrate_from_is_one_line(tmp_path, capsys):
    """zou2022's stereo pair in low light sees no arm: cc_model's probes move no feedback pose,
    and ``track`` says so in one line naming the feedback (exit 1: the run had started)."""
    with pytest.raises(SystemExit) as exit_info:
        eval_main.main(["track", "--preset", "zou2022", "--feedback", "stereo", "--faults",
                        '{"name": "low_light"}', "--policies", "cc_model", "--cycles", "1",
                        "--workers", "1", "--out", str(tmp_path / "out")])
    assert exit_info.value.code == 1
    lines = [line for line in capsys.readouterr().err.splitlines() if line.strip()]
    assert "Traceback" not in "\n".join(lines)
    assert lines[-1].startswith("error: ") and "feedback 'stereo'" in lines[-1]
    assert "cc_model cannot calibrate from it" in lines[-1]


# ------------------------------------------------------------------- calibration cache
@pytest.fixture
def cache_dir(tmp_path, monkeypatch):
    from soft_gym.sensing import calibration_cache

    monkeypatch.setattr(calibration_cache, "cache_directory", lambda: tmp_path / "cache")
    monkeypatch.delenv("SOFT_GYM_CACHE", raising=False)
    calibration_cache.clear_memory()
    yield calibration_cache
    calibration_cache.clear_memory()


def test_a_cache_file_with_a_valid_header_and_a_foreign_pickle_is_rebuilt(cache_dir):
    parts = {"what": "a test calibration"}
    digest, description = cache_dir.cache_key(parts)
    cache_dir._store(digest, description, {"forward": 1})  # valid header, someone else's value
    computed = []

    def compute():
        computed.append(1)
        return {"forward": 2, "inverse": 3}

    with pytest.warns(RuntimeWarning, match=r"not this calibration: KeyError: 'inverse'"):
        assert cache_dir.cached(parts, compute, use=lambda r: r["inverse"]) == 3
    assert computed == [1]
    cache_dir.clear_memory()  # the rebuilt file is used from now on, with no warning
    assert cache_dir.cached(parts, compute, use=lambda r: r["inverse"]) == 3
    assert computed == [1]


@pytest.mark.parametrize("load", ["zhao2021", "zou2022", "local_ik"])
def test_a_foreign_state_fails_the_way_the_cache_rebuilds_on(load, cache_dir):
    """What the calibrations' ``use`` raises on a foreign state is one of the cache's
    rebuild-on errors (the issue's KeyError 'n_gauges', not an uncaught one)."""
    from agents.learners.local_ik import LocalIKNetwork
    from soft_gym.papers.zhao2021.shape_reconstruction import ShapeReconstructor
    from soft_gym.papers.zou2022.shape_dnn import ShapeDNN

    from_state = {"zhao2021": ShapeReconstructor.from_state, "zou2022": ShapeDNN.from_state,
                  "local_ik": LocalIKNetwork.from_state}[load]
    for foreign in ({}, {"n_gauges": "six"}, [1, 2]):
        with pytest.raises(cache_dir._FOREIGN):
            from_state(foreign)
