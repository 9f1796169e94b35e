"""The command lines: every ``--help`` shows the defaults, every eval runner ends by printing the
directory it wrote to, and the eval JSON outputs record the package version."""

from __future__ import annotations

import importlib.util
import json
import re
from importlib.metadata import version
from pathlib import Path

import numpy as np
import pytest

import eval.__main__ as eval_main
import eval.papers.wang2023.estimation as estimation
import eval.papers.ho2018.factors as ho2018_factors
import eval.papers.wang2023.estimation_command as paper_estimation
from eval.commands import track as track_command
from soft_gym import demo
from train import ship
from train.__main__ import main as train_main
from cli_errors import assert_one_line_error

ROOT = Path(__file__).resolve().parents[2]
DEFAULT = re.compile(r"\(default:\s+[^)]+\)")


def _bench_module(name: str):
    """``bench/<name>.py`` imported (the bench scripts are not a package)."""
    spec = importlib.util.spec_from_file_location(f"bench_{name}", ROOT / "bench" / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _bench_main(name: str):
    """``parse_args`` (or ``main``) of ``bench/<name>.py``."""
    module = _bench_module(name)
    return getattr(module, "parse_args", None) or module.main


COMMANDS = {
    "eval benchmark": (eval_main.main, ["benchmark"], "--workers"),
    "eval track": (eval_main.main, ["track"], "--kp"),
    "eval estimation": (eval_main.main, ["estimation"], "--steps"),
    "eval compare": (eval_main.main, ["compare"], "--seeds"),
    "train": (train_main, [], "--eval-freq"),
    "train.ship": (ship.main, [], "--model"),
    "soft_gym.demo": (demo.main, [], "--hold-s"),
    "bench env_speed": ("env_speed", [], "--steps"),
    "bench gp_speed": ("gp_speed", [], "--window"),
    "bench integration_tradeoff": ("integration_tradeoff", [], "--links"),
    "bench lwpr_rwr_update_speed": ("lwpr_rwr_update_speed", [], "--window"),
    "eval.papers.ho2018.factors": (ho2018_factors.main, [], "--seeds"),
    "bench revision_speed": ("revision_speed", [], "--rounds"),
    "bench sensor_speed": ("sensor_speed", [], "--steps"),
    "bench train_speed": ("train_speed", [], "--algo"),
}


@pytest.mark.parametrize("command", sorted(COMMANDS))
def test_every_help_shows_the_defaults(command, capsys):
    main, argv, option = COMMANDS[command]
    if isinstance(main, str):
        main = _bench_main(main)
    with pytest.raises(SystemExit) as exit_info:
        main(argv + ["--help"])
    assert exit_info.value.code == 0
    text = capsys.readouterr().out
    # the option's help, up to the next option, carries its default
    block = text[text.index(f"  {option}"):]
    block = re.split(r"\n  -", block[2:])[0]
    assert DEFAULT.search(block), (command, block)


def _read_results(path: Path) -> list[dict]:
    data = json.loads(path.read_text())
    assert data["soft_arm_gym_version"] == version("soft-arm-gym")
    return data["rows"]


def test_eval_track_prints_its_output_directory_and_records_the_version(tmp_path, capsys):
    out = tmp_path / "track"
    eval_main.main(["track", "--policies", "cc_model", "--cycles", "1", "--feedback",
                    "ground_truth", "--workers", "1", "--out", str(out)])
    lines = capsys.readouterr().out.strip().splitlines()
    assert lines[-1] == f"output directory: {out}"
    rows = _read_results(out / "track.json")
    assert [row["policy"] for row in rows] == ["cc_model"]


def test_eval_track_runs_on_the_mujoco_engine_beside_pybullet(tmp_path):
    """``--engine mujoco`` tracks the same path with the same controller as on PyBullet: the
    engines' tips agree within 0.5 mm open loop, so the closed loop's mean error within 0.5 mm
    too."""
    errors = {}
    for engine in ("pybullet", "mujoco"):
        out = tmp_path / engine
        eval_main.main(["track", "--policies", "cc_model", "--cycles", "1", "--feedback",
                        "ground_truth", "--workers", "1", "--engine", engine, "--out", str(out)])
        row = _read_results(out / "track.json")[0]
        assert row["engine"] == engine
        errors[engine] = row["track_mean_mm"]
    assert abs(errors["mujoco"] - errors["pybullet"]) < 0.5, errors


def test_eval_compare_prints_its_output_directory_and_records_the_version(tmp_path, capsys):
    out = tmp_path / "compare"
    eval_main.main(["compare", "--policies", "cc_model", "--paths", "circle", "--conditions",
                    "nominal", "--seeds", "0", "--cycles", "1", "--feedback", "ground_truth",
                    "--workers", "1", "--out", str(out)])
    lines = capsys.readouterr().out.strip().splitlines()
    assert lines[-1] == f"output directory: {out}"
    assert [row["condition"] for row in _read_results(out / "compare.json")] == ["nominal"]


def test_eval_benchmark_and_estimation_print_their_output_directories(tmp_path, capsys,
                                                                      monkeypatch):
    """The two long runners, with their work replaced by stand-ins."""
    monkeypatch.setattr(track_command, "run_tracks",
                        lambda args, parser, options=None: print("table"))
    eval_main.main(["benchmark", "--out", str(tmp_path / "b")])
    assert capsys.readouterr().out.strip().splitlines()[-1] == f"output directory: {tmp_path / 'b'}"
    monkeypatch.setattr(paper_estimation, "run_experiments",
                        lambda experiments, out, steps, seed: [{"experiment": "clean"}])
    eval_main.main(["estimation", "--out", str(tmp_path / "e")])
    assert capsys.readouterr().out.strip().splitlines()[-1] == f"output directory: {tmp_path / 'e'}"


def test_estimation_json_records_the_version(tmp_path, monkeypatch):
    """run_experiments writes estimation.json with the version (the run itself stood in for by
    a synthetic record)."""
    rng = np.random.default_rng(0)
    steps = 600
    tip = rng.normal(scale=0.01, size=(steps, 3))

    def record(experiment, steps, n_init, seed, progress):
        columns = {"time_s": np.arange(1, steps + 1) * 0.05, "tip_m": tip, "target_m": tip,
                   "reprojection_error_px": np.ones(steps), "lost": np.zeros(steps),
                   "femp_weight": np.full(steps, 0.3), "femp_updated": np.ones(steps)}
        for key in estimation.ESTIMATORS:
            columns[f"{key}_m"] = tip + rng.normal(scale=1e-3, size=tip.shape)
        return columns

    monkeypatch.setattr(estimation, "run_estimation", record)
    estimation.run_experiments(["clean"], tmp_path, steps=steps, progress=False)
    rows = _read_results(tmp_path / "estimation.json")
    assert [row["experiment"] for row in rows] == ["clean"]


# ------------------------------------------------------------------ bad options: one line, exit 2
def _wrong_space_model(path: Path, obs: int, act: int) -> Path:
    """A tiny SAC model reading ``obs`` numbers and writing ``act`` (not the arm's 16 and 3)."""
    import gymnasium as gym
    from stable_baselines3 import SAC

    class Dummy(gym.Env):
        observation_space = gym.spaces.Box(-1, 1, (obs,), np.float32)
        action_space = gym.spaces.Box(-1, 1, (act,), np.float32)

    SAC("MlpPolicy", Dummy(), buffer_size=10, policy_kwargs={"net_arch": [4]}).save(path)
    return path


@pytest.fixture(scope="module")
def wrong_models(tmp_path_factory) -> dict[str, str]:
    """``sb3:`` specs of a model with another observation space and one with another action
    space than SoftArmTrackWang2023-v0's (16 and 3)."""
    directory = tmp_path_factory.mktemp("wrong_models")
    return {"obs": f"sb3:{_wrong_space_model(directory / 'obs.zip', 5, 3)}",
            "act": f"sb3:{_wrong_space_model(directory / 'act.zip', 16, 9)}"}


NOT_A_DIR = "NOT_A_DIR"
"""Placeholder of an ``--out`` that is an existing file (made by the test)."""

EVAL_TRACK = ["track", "--policies", "cc_model", "--cycles", "1", "--workers", "1",
              "--feedback", "ground_truth"]
EVAL_BAD = [
    (EVAL_TRACK + ["--kp", "nan"], "--kp", "finite"),
    (EVAL_TRACK + ["--kp", "-1"], "--kp", "> 0"),
    (EVAL_TRACK + ["--kp", "abc"], "--kp", None),
    (EVAL_TRACK + ["--cycles", "0"], "--cycles", ">= 1"),
    (EVAL_TRACK + ["--seeds", "-1"], "--seeds", ">= 0"),
    (EVAL_TRACK + ["--workers", "0"], "--workers", ">= 1"),
    (EVAL_TRACK + ["--preset", "nonsense"], "--preset", "wang2023"),
    (EVAL_TRACK + ["--path", "nonsense"], "--path", "circle"),
    (EVAL_TRACK + ["--feedback", "nonsense"], "--feedback", "ground_truth"),
    (EVAL_TRACK + ["--scenario", "{bad json"], "--scenario", "JSON"),
    (EVAL_TRACK + ["--scenario", '{"name": "nonsense"}'], "--scenario", "tip_mass"),
    (EVAL_TRACK + ["--faults", '{"name": "nonsense"}'], "--faults", "nonsense"),
    (EVAL_TRACK + ["--policies", "nonsense"], "--policies", "cc_model"),
    (EVAL_TRACK + ["--policies", "sb3:/nonexistent/model"], "--policies", "/nonexistent"),
    (EVAL_TRACK + ["--out", NOT_A_DIR], "--out", "not a directory"),
    (["compare", "--policies", "cc_model", "--paths", "nonsense", "--conditions", "nominal",
      "--feedback", "ground_truth"], "--paths", "circle"),
    (["compare", "--kp", "inf"], "--kp", "finite"),
    (["compare", "--cycles", "0"], "--cycles", ">= 1"),
    (["compare", "--policies", "nonsense", "--paths", "circle", "--conditions", "nominal",
      "--feedback", "ground_truth"], "--policies", "cc_model"),
    (["benchmark", "--workers", "0"], "--workers", ">= 1"),
    (["benchmark", "--out", NOT_A_DIR], "--out", None),
    (["estimation", "--seed", "-1"], "--seed", ">= 0"),
    (["estimation", "--steps", "10"], "--steps", "600"),
    (["estimation", "--out", NOT_A_DIR], "--out", None),
    (["ho2018", "--cycle-s", "nan"], "--cycle-s", "[5, 3600]"),
    (["ho2018", "--baselines", "nonsense"], "--baselines", "cc_model"),
    (["ho2018", "--seeds", "-1"], "--seeds", ">= 0"),
    (["zhao2021", "--samples", "-1", "5"], "--samples", ">= 0"),
    (["zhao2021", "--iterations", "0"], "--iterations", ">= 1"),
    (["zhao2021", "--backbone-curve", "bezier"], "--backbone-curve", "paper_base_frame"),
    (["zhao2021", "--baselines", "sb3:/nonexistent/model"], "--baselines", "/nonexistent"),
    (["zhao2021", "--p2p-loads-g", "50", "5000"], "--p2p-loads-g", "allowed 0-789 g"),
    (["zhao2021", "--goal-mm", "-200", "70", "150", "--experiments", "p2p"], "--goal-mm",
     "mm from the nearest tip"),
    (["zou2022", "--samples", "5"], "--samples", ">= 20"),
    (["zou2022", "--epochs", "0"], "--epochs", ">= 1"),
    (["zou2022", "--poses", "0"], "--poses", ">= 1"),
    (["suite", "small", "--out", NOT_A_DIR], "--out", None),
    (EVAL_TRACK + ["--faults", "not a name!"], "--faults", "JSON"),
    (EVAL_TRACK + ["--faults", "nonsense"], "--faults", "wang2023_occlusion"),
    (EVAL_TRACK + ["--obs", "pose", "nonsense"], "--obs", "strain"),
    (EVAL_TRACK + ["--engine", "bullet"], "--engine", "mujoco"),
    (EVAL_TRACK + ["--feedback", "fused", "--engine", "mujoco"], "--engine", "camera"),
    (["suite", "nowhere/missing.yaml"], "spec", "not found"),
    (["suite", "smal"], "spec", "did you mean 'small'"),
]


@pytest.mark.smoke
@pytest.mark.parametrize("argv, option, also", EVAL_BAD,
                         ids=[" ".join(case[0][:1] + case[0][-2:]) for case in EVAL_BAD])
def test_eval_bad_option_exits_2_with_one_line(argv, option, also, tmp_path, capsys):
    out = tmp_path / "out"
    if NOT_A_DIR in argv:
        out = tmp_path / "a_file"
        out.write_text("")
        argv = [str(out) if a == NOT_A_DIR else a for a in argv]
    elif "--out" not in argv and argv[0] != "suite":
        argv = argv + ["--out", str(out)]
    assert_one_line_error(eval_main.main, argv, option, capsys,
                          out=None if NOT_A_DIR in argv or out.exists() else out, also=also)


@pytest.mark.parametrize("kind", ["obs", "act"])
def test_eval_track_refuses_an_agent_of_other_spaces_before_any_run(kind, wrong_models, tmp_path,
                                                                    capsys):
    """The baseline before it is not run either: nothing is written."""
    out = tmp_path / "out"
    assert_one_line_error(eval_main.main, EVAL_TRACK + ["--policies", "cc_model",
                                                        wrong_models[kind], "--out", str(out)],
                          "--policies", capsys, out=out, also=wrong_models[kind])


def test_eval_compare_refuses_an_agent_of_other_spaces_before_any_run(wrong_models, tmp_path,
                                                                      capsys):
    out = tmp_path / "out"
    assert_one_line_error(eval_main.main, ["compare", "--policies", "cc_model", wrong_models["obs"],
                                           "--paths", "circle", "--conditions", "nominal",
                                           "--feedback", "ground_truth", "--out", str(out)],
                          "--policies", capsys, out=out)


def test_eval_ho2018_refuses_an_agent_of_other_spaces(wrong_models, tmp_path, capsys):
    out = tmp_path / "out"
    assert_one_line_error(eval_main.main, ["ho2018", "--baselines", wrong_models["obs"],
                                           "--out", str(out)], "--baselines", capsys, out=out)


def _fake_record(steps: int = 20) -> dict[str, np.ndarray]:
    rng = np.random.default_rng(0)
    tip = rng.normal(scale=0.01, size=(steps, 3))
    return {"time_s": np.arange(1, steps + 1) * 0.05, "target_m": tip, "tip_m": tip + 1e-3,
            "feedback_m": tip, "action": np.zeros((steps, 3)), "pressure_pa": np.zeros((steps, 3)),
            "error_mm": np.ones(steps), "cycle": np.zeros(steps, dtype=int),
            "polyline_m": tip}


def test_eval_track_keeps_the_runs_finished_before_a_later_run_fails(tmp_path, monkeypatch):
    """Each run's CSV is written as it finishes: a crash in the second run keeps the first."""
    import eval.runner as runner

    def run(config, progress=False):
        if config.policy == "hybrid_gpr":
            raise RuntimeError("the second run crashes")
        return _fake_record()

    monkeypatch.setattr(runner, "run", run)
    out = tmp_path / "track"
    with pytest.raises(RuntimeError, match="second run"):
        eval_main.main(EVAL_TRACK + ["--policies", "cc_model", "hybrid_gpr", "--out", str(out)])
    assert (out / "cc_model_kp0.06_seed0.csv").is_file()
    assert not (out / "hybrid_gpr_kp0.06_seed0.csv").exists()


def test_eval_track_takes_a_plain_fault_name_and_runs_local_ik_asdm_with_the_obs_it_needs(
        tmp_path, monkeypatch):
    """``--faults wang2023_occlusion`` is the fault of that name (no JSON quoting);
    ``local_ik_asdm`` (no K_p) runs once per seed on an env with the parts it reads, which
    ``--obs`` replaces for every policy; SB3 agents keep their own interface."""
    import eval.runner as runner
    from eval.suite.spec import POLICY_ENV_DEFAULTS

    seen = []

    def run_many(configs, workers=1, progress=False, on_result=None):
        seen.extend(configs)
        records = [_fake_record() for _ in configs]
        for index, record in enumerate(records):
            on_result(index, record)
        return records

    monkeypatch.setattr(runner, "run_many", run_many)
    out = tmp_path / "track"
    eval_main.main(["track", "--preset", "zhao2021", "--policies", "local_ik_asdm", "lwpr_rwr",
                    "--kp", "0.3", "0.5", "--cycles", "1", "--feedback", "ground_truth",
                    "--workers", "1", "--out", str(out)])
    by_policy = {}
    for config in seen:
        by_policy.setdefault(config.policy, []).append(config)
    (ik,) = by_policy["local_ik_asdm"]
    assert ik.policy_params == {}
    assert ik.env_kwargs["obs"] == POLICY_ENV_DEFAULTS["local_ik_asdm"]["obs"]
    assert [c.policy_params for c in by_policy["lwpr_rwr"]] == [{"kp": 0.3}, {"kp": 0.5}]
    assert all("obs" not in c.env_kwargs for c in by_policy["lwpr_rwr"])
    assert (out / "local_ik_asdm_seed0.csv").is_file()
    seen.clear()
    eval_main.main(["track", "--policies", "cc_model", "--cycles", "1", "--feedback",
                    "ground_truth", "--obs", "pose", "target", "pressure", "strain",
                    "--workers", "1", "--out", str(tmp_path / "obs")])
    (config,) = seen
    assert config.env_kwargs["obs"] == ["pose", "target", "pressure", "strain"]
    seen.clear()
    eval_main.main(["track", "--policies", "cc_model", "--cycles", "1", "--feedback", "camera",
                    "--faults", "wang2023_occlusion", "--workers", "1",
                    "--out", str(tmp_path / "faults")])
    (config,) = seen
    assert config.env_kwargs["faults"] == "wang2023_occlusion"


def test_run_many_hands_each_record_over_as_it_finishes_and_stops_at_a_failure(monkeypatch):
    import eval.runner as runner

    def run(config, progress=False):
        if config.seed == 1:
            raise RuntimeError("run 1 fails")
        return {"seed": config.seed}

    monkeypatch.setattr(runner, "run", run)
    seen = []
    configs = [runner.RunConfig(policy="cc_model", seed=seed) for seed in (0, 1, 2)]
    with pytest.raises(RuntimeError, match="run 1 fails"):
        runner.run_many(configs, on_result=lambda index, record: seen.append(index))
    assert seen == [0]
    with pytest.raises(ValueError, match="workers"):
        runner.run_many(configs, workers=0)


TRAIN_BAD = [
    (["-hp", "nonsense=1"], "--hyperparams", "learning_rate"),
    (["-hp", "gamma=2.0"], "--hyperparams", "(0, 1]"),
    (["-hp", "learning_rate=-1"], "--hyperparams", "> 0"),
    (["-hp", "batch_size=0"], "--hyperparams", ">= 1"),
    (["-hp", "batch_size=1.5"], "--hyperparams", "integer"),
    (["-hp", "buffer_size=0"], "--hyperparams", "buffer_size"),
    (["-hp", "tau=0"], "--hyperparams", "(0, 1]"),
    (["-hp", "ent_coef=-1"], "--hyperparams", "auto"),
    (["-hp", "novalue"], "--hyperparams", "KEY=VALUE"),
    (["--algo", "ppo", "-hp", "n_steps=0"], "--hyperparams", "n_steps"),
    (["--algo", "ppo", "-hp", "buffer_size=10"], "--hyperparams", "n_epochs"),
    (["--eval-freq", "-1"], "--eval-freq", ">= 0"),
    (["--env", "SoftArmTrackWang2023"], "--env", "did you mean 'SoftArmTrackWang2023-v0'?"),
    (["--eval-episodes", "0"], "--eval-episodes", ">= 1"),
    (["--checkpoint-freq", "-1"], "--checkpoint-freq", ">= 0"),
    (["--threads", "0"], "--threads", ">= 1"),
    (["--timesteps", "0"], "--timesteps", ">= 1"),
    (["--timesteps", "-5"], "--timesteps", ">= 1"),
    (["--timesteps", "abc"], "--timesteps", "integer"),
    (["--n-envs", "0"], "--n-envs", ">= 1"),
    (["--seed", "-1"], "--seed", ">= 0"),
    (["--env", "NoSuchEnv-v0"], "--env", "SoftArmTrackWang2023-v0"),
    (["--preset", "nope"], "--preset", "wang2023"),
    (["--env-kwargs", "feedback=gps"], "--env-kwargs", "'gps'"),
    (["--env-kwargs", "nonsense=1"], "--env-kwargs", "nonsense"),
    (["--conf-file", "/nonexistent/sac.yml"], "--conf-file", "does not exist"),
    (["--randomization-config", "/nonexistent/r.yaml"], "--randomization-config", None),
    (["--resume", "/nonexistent/run"], "--resume", None),
    (["--out", NOT_A_DIR], "--out", None),
]


@pytest.mark.smoke
@pytest.mark.parametrize("argv, option, also", TRAIN_BAD,
                         ids=[" ".join(case[0]) for case in TRAIN_BAD])
def test_train_bad_option_exits_2_with_one_line(argv, option, also, tmp_path, capsys):
    out = tmp_path / "out"
    if NOT_A_DIR in argv:
        (tmp_path / "a_file").write_text("")
        argv = [str(tmp_path / "a_file") if a == NOT_A_DIR else a for a in argv]
    else:
        argv = argv + ["--out", str(out)]
    if "--timesteps" not in argv:
        argv = argv + ["--timesteps", "64"]
    assert_one_line_error(train_main, argv + ["--no-progress"], option, capsys,
                          out=None if NOT_A_DIR in " ".join(argv) else out, also=also)


def test_train_resume_needs_a_run_directory_with_a_model(tmp_path, capsys):
    (tmp_path / "run").mkdir()
    line = assert_one_line_error(train_main, ["--resume", str(tmp_path / "run"), "--timesteps",
                                              "10"], "--resume", capsys)
    assert "model.zip" in line and "config.yaml" in line


def test_train_refuses_a_run_directory_that_holds_a_run(tmp_path, capsys):
    run_dir = tmp_path / "sac_SoftArmTrackWang2023-v0_seed0"
    run_dir.mkdir()
    (run_dir / "config.yaml").write_text("{}")
    assert_one_line_error(train_main, ["--out", str(tmp_path), "--timesteps", "64"], "--name",
                          capsys)


def test_revision_speed_refuses_an_unknown_revision_before_any_work(tmp_path, capsys):
    out = tmp_path / "revision.json"
    assert_one_line_error(_bench_module("revision_speed").main,
                          ["--against", "no-such-revision", "--json", str(out)], "--against",
                          capsys, out=out, also="no-such-revision")


def test_sensor_speed_refuses_an_unknown_revision_before_any_work(tmp_path, capsys):
    out = tmp_path / "sensor.json"
    assert_one_line_error(_bench_module("sensor_speed").main,
                          ["--against", "no-such-revision", "--json", str(out)], "--against",
                          capsys, out=out, also="no-such-revision")


def test_revision_speed_makes_its_envs_on_the_engine_asked_for(tmp_path, capsys):
    """``--engine mujoco`` reaches the measured envs: ground truth steps and the JSON records
    the engine; the camera feedback, which only PyBullet renders, is refused there."""
    module = _bench_module("revision_speed")
    out = tmp_path / "revision.json"
    assert module.main(["--against", "HEAD", "--presets", "zou2022", "--engine", "mujoco",
                        "--steps", "20", "--rounds", "1", "--json", str(out)]) == 0
    assert "engine mujoco" in capsys.readouterr().out
    record = json.loads(out.read_text())
    assert record["engine"] == "mujoco"
    assert record["rows"][0]["this_tree_steps_per_wall_s"][0] > 0
    with pytest.raises(RuntimeError, match="mujoco engine does not have"):
        module.main(["--against", "HEAD", "--presets", "wang2023", "--engine", "mujoco",
                     "--feedback", "fused", "--steps", "5", "--rounds", "1"])


def test_revision_speed_times_this_tree_against_a_revision_in_turns(tmp_path, capsys):
    """Against HEAD (the same code, extracted from git): both trees run and give figures of the
    same order, each round's ratio is theirs, and the JSON holds every round."""
    module = _bench_module("revision_speed")
    out = tmp_path / "speed" / "revision.json"
    assert module.main(["--against", "HEAD", "--presets", "wang2023", "--steps", "30",
                        "--rounds", "2", "--json", str(out)]) == 0
    table = capsys.readouterr().out
    assert "revision HEAD = " in table and "wang2023" in table
    row = json.loads(out.read_text())["rows"][0]
    assert len(row["this_tree_steps_per_wall_s"]) == len(row["revision_steps_per_cpu_s"]) == 2
    for ours, theirs, ratio in zip(row["this_tree_steps_per_cpu_s"],
                                   row["revision_steps_per_cpu_s"], row["cpu_ratios"]):
        assert ratio == pytest.approx(ours / theirs)
    assert all(0.2 < ratio < 5.0 for ratio in row["wall_ratios"] + row["cpu_ratios"])


def test_eval_track_names_the_arm_of_a_shipped_agent_of_another_arm(tmp_path, capsys):
    """``--policies sb3:sac_zhao2021_track`` on the default --preset (wang2023): the one-line
    error ends with the --preset the agent was trained on."""
    out = tmp_path / "track"
    line = assert_one_line_error(eval_main.main, ["track", "--policies", "sb3:sac_zhao2021_track",
                                                  "--out", str(out)], "--policies", capsys,
                                 out=out, also="does not fit")
    assert line.endswith("; --preset zhao2021"), line
