"""A suite on another engine (``python -m eval suite SPEC --engine mujoco``,
:func:`eval.suite.on_engine`): every arm moved, only what the engine cannot run left out with
the engine's reason, the same cells as a file that names the engine itself, bad input refused."""

from __future__ import annotations

import json
import textwrap
from pathlib import Path

import pytest

import eval.__main__ as eval_main
from eval import suite
from suite_specs import tiny_suite

pytest.importorskip("rliable")

BASE = tiny_suite("engines")
"""wang2023 nominal and with a 10 g tip, and an n/a (the wang2023 agent on ho2018)."""

SPEC = BASE.replace(
    "      load_10g: {scenario: {name: tip_mass, mass_kg: 0.01}}\n",
    "      load_10g: {scenario: {name: tip_mass, mass_kg: 0.01}}\n"
    "      swaying: {scenario: {name: swaying_mass, mass_kg: 0.02}}\n") + """\
  zou2022:
    paths: [circle]
    feedback: stereo
    conditions:
      nominal: {}
    policies: [cc_model]
"""
"""``BASE`` with a wang2023 condition that needs a body beside the arm (a swaying mass) and a
zou2022 arm whose stereo feedback needs cameras: the MuJoCo engine runs ``BASE``'s cells."""

NAMED = BASE.replace("env: {speed_m_s: 0.05}", "env: {speed_m_s: 0.05, engine: mujoco}")
"""What ``SPEC`` is on MuJoCo, written by hand: the reference for its cells."""


def _write(tmp_path: Path, text: str, name: str = "engines.yaml") -> Path:
    path = tmp_path / name
    path.write_text(textwrap.dedent(text))
    return path


def test_only_what_the_engine_cannot_run_is_left_out_with_its_reason(tmp_path):
    spec = suite.load_suite(_write(tmp_path, SPEC))
    moved, left_out = suite.on_engine(spec, "mujoco")
    assert [item.label() for item in left_out] == ["wang2023/swaying", "zou2022"]
    assert "rigid bodies beside the arm" in left_out[0].reason
    assert "camera frames" in left_out[1].reason
    assert all("mujoco engine does not have" in item.reason for item in left_out)
    assert [arm.preset for arm in moved.arms] == ["wang2023", "ho2018"]
    assert list(moved.arms[0].conditions) == ["nominal", "load_10g"]
    assert "mujoco" in moved.description and "wang2023/swaying, zou2022" in moved.description


def test_the_cells_are_those_of_a_file_that_names_the_engine(tmp_path):
    moved, _ = suite.on_engine(suite.load_suite(_write(tmp_path, SPEC)), "mujoco")
    named = suite.load_suite(_write(tmp_path, NAMED, "named.yaml"))
    assert [cell.key for cell in suite.expand(moved)] == \
        [cell.key for cell in suite.expand(named)]
    assert all(cell.config["env_kwargs"]["engine"] == "mujoco" for cell in suite.expand(moved))


def test_the_reference_engine_leaves_nothing_out_and_overrides_a_files_engine(tmp_path):
    spec = suite.load_suite(_write(tmp_path, NAMED))
    moved, left_out = suite.on_engine(spec, "pybullet")
    assert left_out == []
    assert [arm.env for arm in moved.arms] == [{"speed_m_s": 0.05, "engine": "pybullet"}] * 2


def test_an_engine_a_condition_or_policy_names_is_overridden_too(tmp_path):
    """Every run goes on the asked engine, a condition's or a policy entry's own ``engine``
    included."""
    text = (BASE.replace("      nominal: {}\n      load_10g",
                         "      nominal: {engine: pybullet}\n      load_10g", 1)
            .replace("{name: cc_model, params: {probe_steps: 5}}",
                     "{name: cc_model, params: {probe_steps: 5}, env: {engine: pybullet}}"))
    spec = suite.load_suite(_write(tmp_path, text))
    wang = [cell for cell in suite.expand(spec) if cell.labels["preset"] == "wang2023"]
    assert [cell.config["env_kwargs"]["engine"] for cell in wang] == ["pybullet"] * 2
    moved, left_out = suite.on_engine(spec, "mujoco")
    assert left_out == []
    assert {cell.config["env_kwargs"]["engine"] for cell in suite.expand(moved)} == {"mujoco"}


def test_a_refusal_not_of_the_engine_stays_for_the_check_to_name(tmp_path):
    """A condition the env refuses on the file's own engine is not the engine's doing: it stays,
    and the suite's check names its key as without --engine."""
    text = SPEC.replace("mass_kg: 0.01}", "mass_kg: -0.01}")
    spec = suite.load_suite(_write(tmp_path, text))
    moved, left_out = suite.on_engine(spec, "mujoco")
    assert "load_10g" in moved.arms[0].conditions
    assert [item.label() for item in left_out] == ["wang2023/swaying", "zou2022"]
    with pytest.raises(ValueError, match=r"arms\.wang2023\.conditions\.load_10g"):
        suite.check_suite(moved)


@pytest.mark.parametrize("engine", ["gpu", None, 3])
def test_an_unknown_engine_is_refused_naming_the_allowed(engine, tmp_path):
    spec = suite.load_suite(_write(tmp_path, NAMED))
    with pytest.raises(ValueError, match=r"engine must be one of \['pybullet', 'mujoco'\]"):
        suite.on_engine(spec, engine)


def test_a_suite_the_engine_can_run_none_of_is_refused(tmp_path):
    text = SPEC.replace("feedback: ground_truth", "feedback: fused")
    spec = suite.load_suite(_write(tmp_path, text))
    with pytest.raises(ValueError, match="can run none of suite 'engines'"):
        suite.on_engine(spec, "mujoco")


def test_cli_runs_the_suite_on_the_engine_and_says_what_it_left_out(tmp_path, capsys):
    spec, out = _write(tmp_path, SPEC), tmp_path / "out"
    eval_main.main(["suite", str(spec), "--engine", "mujoco", "--out", str(out),
                    "--workers", "1"])
    captured = capsys.readouterr()
    left = [line for line in captured.err.splitlines() if line.startswith("left out on")]
    assert [line.split(": ")[0] for line in left] == ["left out on mujoco"] * 2
    assert "wang2023/swaying:" in left[0] and "zou2022:" in left[1]
    records = [json.loads(path.read_text()) for path in (out / "records").glob("*.json")]
    assert sorted((r["labels"]["preset"], r["labels"]["condition"], r["status"])
                  for r in records) == [("ho2018", "nominal", "n/a"),
                                        ("wang2023", "load_10g", "done"),
                                        ("wang2023", "nominal", "done")]
    assert {r["config"]["env_kwargs"]["engine"] for r in records} == {"mujoco"}
    leaderboard = (out / "leaderboard.md").read_text()
    assert "engine mujoco." in leaderboard and "(--engine mujoco)" in leaderboard


def test_cli_refuses_an_unknown_engine_in_one_line(tmp_path, capsys):
    with pytest.raises(SystemExit) as exit_info:
        eval_main.main(["suite", "small", "--engine", "gpu", "--out", str(tmp_path / "o")])
    assert exit_info.value.code == 2
    error = capsys.readouterr().err.strip().splitlines()[-1]
    assert "--engine" in error and "gpu" in error
    assert not (tmp_path / "o").exists()


def test_cli_refuses_a_suite_the_engine_can_run_none_of_before_any_run(tmp_path, capsys):
    spec = _write(tmp_path, SPEC.replace("feedback: ground_truth", "feedback: fused"))
    with pytest.raises(SystemExit) as exit_info:
        eval_main.main(["suite", str(spec), "--engine", "mujoco", "--out", str(tmp_path / "o")])
    assert exit_info.value.code == 2
    error = capsys.readouterr().err.strip().splitlines()[-1]
    assert error.startswith("python -m eval suite: error: --engine:")
    assert not (tmp_path / "o").exists()
