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
import eval.estimation as estimation
from soft_gym import demo
from train import ship
from train.__main__ import main as train_main

ROOT = Path(__file__).resolve().parent.parent
DEFAULT = re.compile(r"\(default:\s+[^)]+\)")


def _bench_main(name: str):
    """``main`` of ``bench/<name>.py`` (the bench scripts are not a package)."""
    spec = importlib.util.spec_from_file_location(f"bench_{name}", ROOT / "bench" / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
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
    monkeypatch.setattr(eval_main, "_track", lambda args: print("table"))
    eval_main.main(["benchmark", "--out", str(tmp_path / "b")])
    assert capsys.readouterr().out.strip().splitlines()[-1] == f"output directory: {tmp_path / 'b'}"
    monkeypatch.setattr(eval_main, "run_experiments",
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
