"""The benchmark suite (eval/suite/, ``python -m eval suite``): spec validation naming the file
and key, deterministic expansion and keys, n/a records for a refusing baseline, resume redoing no
finished run, the report's statistics against hand-computed references, and the command line's
bad options."""

from __future__ import annotations

import json
import math
import os
import textwrap
from pathlib import Path

import numpy as np
import pytest
import scipy.stats

import eval.__main__ as eval_main
from eval import suite
from eval.suite import report
from suite_specs import assert_suite_cli_error, counting_backend, tiny_suite

pytest.importorskip("rliable")

TINY = tiny_suite()
"""Two quick wang2023 runs (a 26-step circle) and one n/a (the wang2023 agent on ho2018)."""


def _write(tmp_path: Path, text: str, name: str = "suite.yaml") -> Path:
    path = tmp_path / name
    path.write_text(textwrap.dedent(text))
    return path


def _edit(old: str, new: str, text: str = TINY) -> str:
    assert old in text, old
    return text.replace(old, new, 1)


# ------------------------------------------------------------------------------ validation
STRUCTURE_ERRORS = {
    "unknown top-level key": (_edit("cycles: 1", "cycle: 1"), "cycle", "allowed"),
    "unknown arm key": (_edit("    paths: [circle]", "    path: [circle]"),
                        "arms.wang2023.path", "allowed"),
    "unknown preset": (_edit("  ho2018:", "  ho2019:"), "arms.ho2019", "ho2018"),
    "unknown path": (_edit("[circle]", "[circel]"), "arms.wang2023.paths[0]", "pentagram"),
    "unknown policy": (_edit("{name: cc_model, params", "{name: cc_modle, params"),
                       "arms.wang2023.policies[0].name", "hybrid_gpr"),
    "unknown policy parameter": (_edit("probe_steps: 5", "probe_stepz: 5"),
                                 "arms.wang2023.policies[0].params.probe_stepz", "kp"),
    "unknown condition key": (_edit("{scenario: {name: tip_mass", "{scenaro: {name: tip_mass"),
                              "arms.wang2023.conditions.load_10g.scenaro", "faults"),
    "suite key in a condition": (_edit("nominal: {}", "nominal: {cycles: 3}"),
                                 "arms.wang2023.conditions.nominal.cycles", "allowed"),
    "unknown feedback": (_edit("feedback: ground_truth", "feedback: gps"),
                         "arms.wang2023.feedback", "em"),
    "bad seeds": (_edit("seeds: [0]", "seeds: [0, 0]"), "seeds", "distinct"),
    "duplicate key": (_edit("  ho2018:", "  wang2023:"), "", "duplicate key"),
}


@pytest.mark.smoke
@pytest.mark.parametrize("case", sorted(STRUCTURE_ERRORS))
def test_structure_errors_name_the_file_the_key_and_what_is_allowed(case, tmp_path):
    text, key, allowed = STRUCTURE_ERRORS[case]
    path = _write(tmp_path, text, name="bad_suite.yaml")
    with pytest.raises(ValueError) as error:
        suite.load_suite(path)
    first, *others = str(error.value).splitlines()  # each further mistake on its own line
    assert str(path) in first and key in first and allowed in first, first
    assert all(line.startswith(f"{path}: ") for line in others)
    if case == "unknown arm key":  # and the key it was meant to be is missing
        assert others == [f"{path}: arms.wang2023.paths: missing required key 'paths' "
                          "(arms.wang2023 needs ['paths', 'conditions', 'policies'])"]
    else:
        assert others == []


def test_every_structure_error_of_a_file_is_listed_one_line_each(tmp_path):
    """A file with several mistakes lists them all at once, in the file's order, each on its own
    line naming the file and the key (with the wording it has alone)."""
    text = TINY
    for case in ("unknown top-level key", "bad seeds", "unknown path", "unknown feedback",
                 "unknown policy parameter", "unknown condition key", "unknown preset"):
        old, new = {
            "unknown top-level key": ("cycles: 1", "cycle: 1"),
            "bad seeds": ("seeds: [0]", "seeds: [0, 0]"),
            "unknown path": ("[circle]", "[circel]"),
            "unknown feedback": ("feedback: ground_truth", "feedback: gps"),
            "unknown policy parameter": ("probe_steps: 5", "probe_stepz: 5"),
            "unknown condition key": ("{scenario: {name: tip_mass", "{scenaro: {name: tip_mass"),
            "unknown preset": ("  ho2018:", "  ho2019:"),
        }[case]
        text = _edit(old, new, text)
    path = _write(tmp_path, text, name="many_mistakes.yaml")
    with pytest.raises(ValueError) as error:
        suite.load_suite(path)
    lines = str(error.value).splitlines()
    keys = ["cycle", "seeds", "arms.wang2023.paths[0]", "arms.wang2023.feedback",
            "arms.wang2023.conditions.load_10g.scenaro",
            "arms.wang2023.policies[0].params.probe_stepz", "arms.ho2019"]
    assert [line.split(": ")[1] for line in lines] == keys, lines
    assert all(line.startswith(f"{path}: ") for line in lines)
    for line, case in zip(lines, ("unknown top-level key", "bad seeds", "unknown path",
                                  "unknown feedback", "unknown condition key",
                                  "unknown policy parameter", "unknown preset")):
        alone = _write(tmp_path, STRUCTURE_ERRORS[case][0], name="many_mistakes.yaml")
        with pytest.raises(ValueError) as single:
            suite.load_suite(alone)
        assert str(single.value) == line  # the wording it has alone
    assert [e.key for e in error.value.errors] == keys

ENV_ERRORS = {
    "unknown scenario": (_edit("name: tip_mass", "name: tip_mas"),
                         "arms.wang2023.conditions.load_10g", "swaying_mass"),
    "negative mass": (_edit("mass_kg: 0.01", "mass_kg: -0.01"),
                      "arms.wang2023.conditions.load_10g", "mass_kg"),
    "too heavy for the arm": (_edit("mass_kg: 0.01", "mass_kg: 0.5"),
                              "arms.wang2023.conditions.load_10g", "N"),
    "faults without a camera": (_edit("nominal: {}", "nominal: {faults: low_light}"),
                                "arms.wang2023.conditions.nominal", "camera"),
    "bad policy value": (_edit("probe_steps: 5", "probe_steps: 0"),
                         "arms.wang2023.policies[0].params", "probe_steps"),
}


@pytest.mark.parametrize("case", sorted(ENV_ERRORS))
def test_env_and_policy_values_are_checked_before_any_run(case, tmp_path):
    text, key, detail = ENV_ERRORS[case]
    path = _write(tmp_path, text, name="bad_values.yaml")
    spec = suite.load_suite(path)
    with pytest.raises(ValueError) as error:
        suite.check_suite(spec)
    message = str(error.value)
    assert str(path) in message and key in message and detail in message, message


def test_a_baseline_refusing_the_arm_is_not_a_suite_error(tmp_path):
    """The wang2023 agent refuses ho2018 (its six chambers): an n/a run, not a validation error."""
    spec = suite.load_suite(_write(tmp_path, TINY))
    assert len(suite.check_suite(spec)) == 3


def test_bundled_suites_load_and_expand():
    for name in ("default", "small"):
        spec = suite.load_suite(name)
        cells = suite.expand(spec)
        arms = [arm.preset for arm in spec.arms]
        assert arms == ["wang2023", "ho2018", "zhao2021", "zou2022"]
        expected = sum(len(arm.paths) * len(arm.conditions) * len(arm.policies)
                       for arm in spec.arms) * len(spec.seeds)
        assert len(cells) == expected
    assert set(suite.bundled_suites()) >= {"default", "small"}


@pytest.mark.parametrize("name", ["small", "default", "demos", "wang2023_feedback",
                                  "feedback_check"])
def test_bundled_suites_pass_their_checks(name):
    """The README's main job, the default suite, the demonstrations' comparison, wang2023's
    feedback comparison and the ho2018/zhao2021 feedback check pass the check a run starts with (an arm whose path needs the arm's
    waypoints: the check judges keyword arguments that only work together as a whole before it
    blames one)."""
    assert len(suite.check_suite(suite.load_suite(name))) == {
        "small": 38, "default": 570, "demos": 63, "wang2023_feedback": 36,
        "feedback_check": 28}[name]


def test_a_refusal_is_blamed_on_the_key_that_causes_it_not_on_a_partial_set(tmp_path):
    text = TINY.replace("paths: [circle]", "paths: [waypoints]", 1)
    spec = suite.load_suite(_write(tmp_path, text, "waypoints.yaml"))
    with pytest.raises(ValueError, match=r"arms\.wang2023\.paths\[0\].*waypoints_m"):
        suite.check_suite(spec)


# ---------------------------------------------------------------------- expansion and keys
@pytest.mark.smoke
def test_expansion_and_keys_are_deterministic(tmp_path):
    first = suite.expand(suite.load_suite(_write(tmp_path, TINY, "a.yaml")))
    again = suite.expand(suite.load_suite(_write(tmp_path, TINY, "b.yaml")))
    assert [c.key for c in first] == [c.key for c in again]
    assert all(len(c.key) == suite.KEY_DIGITS and int(c.key, 16) >= 0 for c in first)
    assert [(c.labels["preset"], c.labels["condition"]) for c in first] == [
        ("wang2023", "nominal"), ("wang2023", "load_10g"), ("ho2018", "nominal")]
    config = first[1].config
    assert config["env_kwargs"] == {"preset": "wang2023", "path": "circle", "cycles": 1,
                                    "feedback": "ground_truth", "speed_m_s": 0.05,
                                    "scenario": {"name": "tip_mass", "mass_kg": 0.01}}
    assert config["policy_params"] == {"probe_steps": 5} and config["seed"] == 0
    assert first[1].key == suite.cell_key(config)
    changed = suite.expand(suite.load_suite(
        _write(tmp_path, _edit("mass_kg: 0.01", "mass_kg: 0.02"), "c.yaml")))
    differs = [a.key != b.key for a, b in zip(first, changed)]
    assert differs == [False, True, False]


def test_seed_params_and_seed_override_enter_the_config(tmp_path):
    text = _edit("{name: cc_model, params: {probe_steps: 5}}",
                 "{name: lwpr_rwr, params: {pretrain_waypoints: 4}, seed_params: [seed]}")
    spec = suite.load_suite(_write(tmp_path, text)).with_seeds([3, 4])
    cells = [c for c in suite.expand(spec) if c.labels["policy"] == "lwpr_rwr"]
    assert [(c.config["seed"], c.config["policy_params"]["seed"]) for c in cells] == [
        (3, 3), (4, 4), (3, 3), (4, 4)]
    assert len({c.key for c in cells}) == 4


# --------------------------------------------------------------------------- running
def test_run_records_na_and_resume_redoes_no_finished_run(tmp_path):
    spec = suite.load_suite(_write(tmp_path, TINY))
    out = tmp_path / "out"
    ran: list[str] = []
    counts = suite.run_suite(spec, out, backend=counting_backend(ran), progress=False)
    cells = suite.expand(spec)
    assert sorted(ran) == sorted(c.key for c in cells)
    assert (counts["done"], counts["n/a"], counts["skipped"]) == (2, 1, 0)
    records = {c.labels["preset"] + "/" + c.labels["condition"]: suite.read_record(out, c.key)
               for c in cells}
    done = records["wang2023/load_10g"]
    assert done["status"] == "done" and done["reason"] is None
    assert done["labels"] == {"preset": "wang2023", "path": "circle", "condition": "load_10g",
                              "policy": "cc_model", "seed": 0}
    assert done["config"] == cells[1].config and done["suite"] == "tiny"
    metrics = done["metrics"]
    for name in ("last_cycle_error_mm", "mean_error_mm", "max_error_mm", "path_deviation_mm"):
        assert math.isfinite(metrics[name]) and metrics[name] >= 0
    assert metrics["max_error_mm"] >= metrics["mean_error_mm"]
    assert set(done["versions"]) == {"soft_arm_gym", "gymnasium", "stable_baselines3", "torch",
                                     "numpy", "pybullet", "python"}
    assert "git_revision" in done and done["wall_s"] > 0
    steps = suite.read_steps(out, cells[1].key)
    assert steps["tip_m"].shape == (metrics["n_steps"], 3)
    refused = records["ho2018/nominal"]
    assert refused["status"] == "n/a" and refused["metrics"] is None
    assert "does not fit the env's observations and actions" in refused["reason"]
    assert suite.read_steps(out, cells[2].key) is None
    assert not list(out.rglob("*.tmp"))

    # resume: only the run whose record was deleted runs again
    mtimes = {c.key: suite.record_path(out, c.key).stat().st_mtime_ns for c in cells}
    suite.record_path(out, cells[0].key).unlink()
    ran.clear()
    counts = suite.run_suite(spec, out, resume=True, backend=counting_backend(ran),
                             progress=False, check=False)
    assert ran == [cells[0].key]
    assert (counts["done"], counts["skipped"]) == (1, 2)
    for cell in cells[1:]:
        assert suite.record_path(out, cell.key).stat().st_mtime_ns == mtimes[cell.key]

    # the report of these records
    text = report.write_report(spec, out, reps=200, profile_reps=100)
    assert "| 1 | cc_model |" in text and "does not fit the env" in text
    for name in ("leaderboard.md", "runs.csv", "suite.json", "aggregate_iqm.png",
                 "performance_profiles.png", "plots/error_wang2023_circle_load_10g.png",
                 "plots/trajectory_wang2023_circle_nominal.png"):
        assert (out / name).is_file(), name
    provenance = json.loads((out / "suite.json").read_text())
    assert provenance["spec_text"] == spec.text and provenance["spec_sha256"] == spec.sha256
    assert provenance["counts"] == {"cells": 3, "done": 2, "n/a": 1, "missing": 0, "bad": 0}


def test_a_failed_write_leaves_no_record(tmp_path, monkeypatch):
    result = {"key": "0" * 16, "suite": "s", "labels": {}, "config": {}, "status": "done",
              "reason": None, "metrics": {}, "wall_s": 1.0, "versions": {},
              "git_revision": None, "steps": {"tip_m": np.zeros((3, 3))}}

    def fail(*args, **kwargs):
        raise OSError("disk full")

    monkeypatch.setattr(np, "savez_compressed", fail)
    with pytest.raises(OSError):
        suite.write_record(tmp_path, result)
    assert not any(suite.records_dir(tmp_path).iterdir())
    assert not suite.is_finished(tmp_path, result["key"])


# ---------------------------------------------------------------------------- statistics
REPORT_SUITE = """\
name: synthetic
seeds: [0, 1, 2]
cycles: 2
arms:
  zou2022:
    paths: [circle]
    feedback: encoder_cc
    conditions:
      nominal: {}
      loaded: {scenario: {name: tip_mass, mass_kg: 0.02}}
    policies: [cc_model, lwpr_rwr, hybrid_gpr]
"""

SCORES = {  # policy -> seed -> (nominal, loaded) last-cycle errors (mm)
    "cc_model": [[1.0, 10.0], [2.0, 20.0], [4.0, 30.0]],
    "lwpr_rwr": [[0.5, 1.0], [0.7, 3.0], [0.6, 2.0]],
}


def _synthetic_records(tmp_path: Path):
    spec = suite.load_suite(_write(tmp_path, REPORT_SUITE))
    out = tmp_path / "out"
    column = {"nominal": 0, "loaded": 1}
    for cell in suite.expand(spec):
        labels = cell.labels
        result = {"key": cell.key, "suite": spec.name, "labels": labels, "config": cell.config,
                  "wall_s": 1.0, "versions": {"numpy": np.__version__},
                  "git_revision": "abc", "steps": None}
        if labels["policy"] == "hybrid_gpr":
            result.update(status="n/a", reason="hybrid_gpr refuses this arm", metrics=None)
        else:
            error = SCORES[labels["policy"]][labels["seed"]][column[labels["condition"]]]
            result.update(status="done", reason=None, metrics={
                "last_cycle_error_mm": error, "mean_error_mm": error + 1.0,
                "max_error_mm": 3 * error, "path_deviation_mm": error / 2})
        suite.write_record(out, result)
    return spec, out


def _reference_interval(scores: np.ndarray, statistic, reps: int, seed: int) -> np.ndarray:
    """The stratified percentile bootstrap, slowly: runs resampled within each task."""
    state = np.random.get_state()
    np.random.seed(seed)
    try:
        n_runs, n_tasks = scores.shape
        values = [statistic(scores[np.random.choice(n_runs, (n_runs, n_tasks), replace=True),
                                   np.arange(n_tasks)[None, :]]) for _ in range(reps)]
    finally:
        np.random.set_state(state)
    return np.percentile(np.asarray(values), [2.5, 97.5], axis=0)


def test_report_statistics_equal_hand_computed_references(tmp_path):
    spec, out = _synthetic_records(tmp_path)
    rows = report.collect_rows(suite.expand(spec), out)
    matrices, tasks, excluded = report.score_matrices(rows, "zou2022")
    assert tasks == [("circle", "nominal"), ("circle", "loaded")]
    assert excluded == {"hybrid_gpr": "n/a"}
    np.testing.assert_array_equal(matrices["cc_model"], SCORES["cc_model"])

    # IQM by hand: cc_model's six scores 1 2 4 10 20 30, the middle half is 2 4 10 20
    assert scipy.stats.trim_mean(matrices["cc_model"], 0.25, axis=None) == 9.0
    aggregates = report.aggregate_scores(matrices, reps=400, seed=7)
    cc = aggregates["cc_model"]
    assert cc["iqm_mm"] == pytest.approx(9.0)
    assert cc["mean_mm"] == pytest.approx((7.0 / 3 + 20.0) / 2)   # mean of the task means
    assert cc["median_mm"] == pytest.approx((7.0 / 3 + 20.0) / 2)  # median of two task means
    assert aggregates["lwpr_rwr"]["iqm_mm"] == pytest.approx(np.mean([0.6, 0.7, 1.0, 2.0]))
    assert (cc["n_runs"], cc["n_tasks"]) == (3, 2)

    def statistics(x):
        return np.array([scipy.stats.trim_mean(x, 0.25, axis=None), np.mean(np.mean(x, axis=0)),
                         np.median(np.mean(x, axis=0))])

    # the policies are bootstrapped in turn from one seeded generator: cc_model first
    reference = _reference_interval(matrices["cc_model"], statistics, 400, 7)
    np.testing.assert_allclose(cc["iqm_ci_mm"], reference[:, 0])
    np.testing.assert_allclose(cc["mean_ci_mm"], reference[:, 1])
    assert cc["iqm_ci_mm"][0] <= cc["iqm_mm"] <= cc["iqm_ci_mm"][1]

    taus = [0.0, 1.0, 2.0, 10.0, 25.0, 30.0]
    profiles = report.performance_profiles(matrices, taus, reps=300, seed=5)
    assert profiles["cc_model"]["fraction"] == pytest.approx([0, 1 / 6, 2 / 6, 4 / 6, 5 / 6, 1])
    assert profiles["lwpr_rwr"]["fraction"] == pytest.approx([0, 4 / 6, 5 / 6, 1, 1, 1])
    reference = _reference_interval(matrices["cc_model"],
                                    lambda x: report.fraction_within(x, taus), 300, 5)
    np.testing.assert_allclose(profiles["cc_model"]["ci_low"], reference[0])
    np.testing.assert_allclose(profiles["cc_model"]["ci_high"], reference[1])

    boards = report.leaderboards(rows)
    nominal = boards[("zou2022", "nominal")]
    assert [(e["rank"], e["policy"]) for e in nominal] == [
        (1, "lwpr_rwr"), (2, "cc_model"), (None, "hybrid_gpr")]
    assert nominal[1]["last_cycle_error_mm"] == pytest.approx(7.0 / 3)
    assert nominal[1]["path_deviation_mm"] == pytest.approx(7.0 / 6)
    assert nominal[2]["note"] == "hybrid_gpr refuses this arm"


def test_single_seed_intervals_collapse_to_the_point():
    aggregates = report.aggregate_scores({"a": np.array([[3.0, 5.0]])}, reps=50)
    assert aggregates["a"]["iqm_ci_mm"] == [4.0, 4.0]


# ------------------------------------------------------------------------- command line
@pytest.mark.parametrize("argv, option", [
    (["--workers", "0"], "--workers"),
    (["--seeds", "-1"], "--seeds"),
    (["--seeds", "1", "1"], "--seeds"),
    (["--report-only", "--resume"], "--resume"),
    (["--workers", "two"], "--workers"),
    (["--report-only"], "--report-only"),
])
def test_cli_bad_options_exit_2_with_one_line(argv, option, tmp_path, capsys):
    assert_suite_cli_error(argv, option, tmp_path, capsys)


def test_cli_bad_spec_exits_2_naming_the_file_and_key(tmp_path, capsys):
    path = _write(tmp_path, _edit("  ho2018:", "  ho2019:"), "bad.yaml")
    for spec, expected in ((str(path), "arms.ho2019"), ("no_such_suite", "small")):
        with pytest.raises(SystemExit) as exit_info:
            eval_main.main(["suite", spec, "--out", str(tmp_path / "o")])
        assert exit_info.value.code == 2
        error = capsys.readouterr().err.strip().splitlines()[-1]
        assert expected in error, error
    assert not (tmp_path / "o").exists()


def test_cli_report_only_prints_the_leaderboard_and_the_output_directory(tmp_path, capsys):
    spec, out = _synthetic_records(tmp_path)
    eval_main.main(["suite", spec.source, "--out", str(out), "--report-only"])
    lines = capsys.readouterr().out.strip().splitlines()
    assert lines[-1] == f"output directory: {out}"
    assert any(line.startswith("| 1 | lwpr_rwr |") for line in lines)
    assert (out / "leaderboard.md").is_file()


def test_cli_suite_help_shows_the_defaults(capsys):
    with pytest.raises(SystemExit) as exit_info:
        eval_main.main(["suite", "--help"])
    assert exit_info.value.code == 0
    assert "(default: " in capsys.readouterr().out


def test_the_process_backend_yields_every_result_as_it_completes():
    results = list(suite.process_map(math.sqrt, [1.0, 4.0, 9.0, 16.0, 25.0], workers=2))
    assert sorted(results) == [1.0, 2.0, 3.0, 4.0, 5.0]
    assert list(suite.process_map(math.sqrt, [4.0], workers=2)) == [2.0]


def test_another_backend_can_be_registered(tmp_path):
    calls = []

    def backwards(fn, items, workers):
        calls.append(len(items))
        for item in reversed(list(items)):
            yield fn(item)

    suite.register_backend("backwards", backwards)
    try:
        assert suite.BACKENDS["backwards"] is backwards
        with pytest.raises(ValueError, match="backend"):
            suite.run_suite(suite.load_suite(_write(tmp_path, TINY)), tmp_path / "o",
                            backend="nope", progress=False, check=False)
    finally:
        suite.BACKENDS.pop("backwards")
    assert os.path.isdir(tmp_path) and calls == []


AGENT_SUITE = REPORT_SUITE.replace("seeds: [0, 1, 2]", "seeds: [0, 1]").replace(
    "mass_kg: 0.02}}\n", "mass_kg: 0.02}}\n      dark: {faults: {name: low_light, strength: 1.0}}\n"
).replace("[cc_model, lwpr_rwr, hybrid_gpr]", '[cc_model, lwpr_rwr, "sb3:sac_zou2022_track"]')
"""REPORT_SUITE on two seeds with a visual fault, hybrid_gpr replaced by the zou2022 agent."""

AGENT_SCORES = {  # policy -> (nominal, loaded, dark) last-cycle errors (mm), both seeds
    "cc_model": (2.0, 6.0, 9.0), "lwpr_rwr": (1.0, 5.0, 8.0), "sac_zou2022_track": (1.5, 4.0, 8.0)}


def test_the_leaderboard_sets_each_arms_best_agent_against_its_best_baseline(tmp_path):
    """Per condition the best baseline and the best agent, their ratio and whether the agent
    beats every baseline (a tie does not); the verdict names the loads and faults it wins
    under; each agent row carries its training budget from its training.yaml."""
    from agents.policies.sb3 import training_budget

    spec = suite.load_suite(_write(tmp_path, AGENT_SUITE))
    out = tmp_path / "out"
    column = {"nominal": 0, "loaded": 1, "dark": 2}
    for cell in suite.expand(spec):
        labels = cell.labels
        error = AGENT_SCORES[labels["policy"]][column[labels["condition"]]]
        suite.write_record(out, {
            "key": cell.key, "suite": spec.name, "labels": labels, "config": cell.config,
            "wall_s": 1.0, "versions": {}, "git_revision": "abc", "steps": None,
            "status": "done", "reason": None,
            "metrics": {"last_cycle_error_mm": error, "mean_error_mm": error,
                        "max_error_mm": error, "path_deviation_mm": error}})
    rows = report.collect_rows(suite.expand(spec), out)
    versus = {row["condition"]: row for row in report.agents_against_baselines(
        spec, report.leaderboards(rows))["zou2022"]}
    assert [versus[c]["kind"] for c in column] == ["nominal", "load", "visual fault"]
    assert (versus["nominal"]["best_baseline"], versus["nominal"]["best_agent"]) == (
        "lwpr_rwr", "sac_zou2022_track")
    assert versus["nominal"]["ratio"] == pytest.approx(1.5)
    assert [versus[c]["agent_beats_every_baseline"] for c in column] == [False, True, False]

    text = report.write_report(spec, out, reps=50, profile_reps=50, plots=False)
    assert "An agent beats every baseline under a load or visual fault: yes, on loaded." in text
    budget = report.budget_text(training_budget("sac_zou2022_track"))
    assert f"| {budget} |" in text and "k steps" in budget
    saved = json.loads((out / "suite.json").read_text())
    assert saved["agent_budgets"]["zou2022"]["sac_zou2022_track"] == training_budget(
        "sac_zou2022_track")


def test_a_training_budget_sums_the_segments_of_a_resumed_run(tmp_path):
    from agents.policies.sb3 import training_budget

    (tmp_path / "config.yaml").write_text(
        "env_kwargs: {engine: mujoco, feedback: em}\n")
    (tmp_path / "training.yaml").write_text(
        "- {timesteps: 50000, wall_s: 100.0, n_envs: 4}\n"
        "- {timesteps: 20000, wall_s: 40.0, n_envs: 4, stopped_at_plateau: true}\n")
    assert training_budget(tmp_path) == {
        "timesteps": 70000, "wall_s": 140.0, "n_envs": 4, "engine": "mujoco",
        "feedback": "em", "plateau": True, "interrupted": False, "demonstrations": False,
        "trained_agent": None}
    assert report.budget_text(training_budget(tmp_path)) == (
        "70k steps, 2 min, mujoco x4, em, plateau")
    (tmp_path / "training.yaml").write_text("- {wall_s: 100.0}\n")
    with pytest.raises(ValueError, match="training.yaml"):
        training_budget(tmp_path)
    (tmp_path / "untrained").mkdir()
    assert training_budget(tmp_path / "untrained") is None


def _trained_feedbacks_from_run_files(agent: str) -> set[str]:
    """An agent's training feedback read straight from its run's config.yaml (its env's
    feedback, the env default where unset, and those of the envs trained beside it)."""
    import yaml

    from soft_gym.envs.config import EnvConfig

    root = Path(__file__).resolve().parents[3]
    directory = root / "agents" / "trained" / agent
    if not directory.is_dir():
        directory = root / agent
    config = yaml.safe_load((directory / "config.yaml").read_text())
    base = config["env_kwargs"].get("feedback", EnvConfig.feedback)
    extra = (config.get("hyperparameters") or {}).get("arm_env_kwargs") or []
    return {base} | {kwargs.get("feedback", base) for kwargs in extra}


@pytest.mark.parametrize("name", sorted(suite.bundled_suites()))
def test_every_bundled_suite_marks_each_agent_judged_off_its_training_feedback(name, tmp_path):
    """Every agent of a bundled suite is judged on the feedback it was trained on, or the report
    marks the mismatch: feedback_mismatches lists exactly the (arm, condition, agent) whose runs'
    feedback is not among those of the agent's training (read from its run files here), and
    the leaderboard says so under the arm and in each such row."""
    from soft_gym.envs.config import EnvConfig

    spec = suite.load_suite(name)
    expected = set()
    for cell in suite.expand(spec):
        if not cell.config["policy"].startswith("sb3:"):
            continue
        judged = cell.config["env_kwargs"].get("feedback", EnvConfig.feedback)
        trained = _trained_feedbacks_from_run_files(cell.config["policy"][len("sb3:"):])
        if judged not in trained:
            labels = cell.labels
            expected.add((labels["preset"], labels["condition"], labels["policy"], judged))
    found = report.feedback_mismatches(spec)
    assert {(m["preset"], m["condition"], m["policy"], m["judged"]) for m in found} == expected
    if name == "small":  # the main job's zhao2021 agent: trained on strain_sr, judged on truth
        assert ("zhao2021", "nominal", "sac_zhao2021_track", "ground_truth") in expected
    text = report.write_report(spec, tmp_path / "out", reps=10, profile_reps=10, plots=False)
    for preset, condition, policy, judged in expected:
        section = text.split(f"### {preset}: {condition}\n", 1)[1].split("\n#", 1)[0]
        row = next(line for line in section.splitlines() if f"| {policy} |" in line)
        assert f"FEEDBACK MISMATCH: judged on {judged}" in row
    for preset in {m[0] for m in expected}:
        heading = text.split(f"## {preset}\n", 1)[1].split("\n## ", 1)[0]
        assert "**Feedback mismatch**" in heading
    if not expected:
        assert "FEEDBACK MISMATCH" not in text and "**Feedback mismatch**" not in text
