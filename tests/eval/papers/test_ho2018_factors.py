"""The ho2018 floor study's bookkeeping (the runs themselves are eval.papers.ho2018.experiments's)."""

from __future__ import annotations

import pytest

from eval.papers.ho2018 import factors as ho2018_factors
from eval.papers.ho2018.factors import (FACTORS, MEASURED_ON, RUNS, factor_keywords, main,
                                         report, run_factors)


def test_every_factor_changes_one_thing_the_experiment_takes():
    """Each factor changes one keyword of the measured experiment, which stays the shorter
    protocol with pressure-driven chambers (the EM noise's env options included)."""
    assert MEASURED_ON == {"protocol": "quick", "env_options": {"actuation": "pressure"}}
    assert FACTORS["default"] == {}
    for name, change in FACTORS.items():
        assert len(change) <= 1, name
        keywords = factor_keywords(name)
        assert keywords["protocol"] == "quick", name
        assert keywords["env_options"]["actuation"] == "pressure", name
    assert factor_keywords("no EM noise")["env_options"]["sensor_config"]["em"] == {
        "position_noise_m": 0.0, "orientation_noise_deg": 0.0}
    assert set().union(*FACTORS.values()) <= {"env_options", "ridge", "min_step_mm", "window",
                                             "hold_steps", "kp", "cycle_s"}


def test_the_report_gives_each_factor_its_cycles_and_ratios():
    results = {"default": {RUNS[0]: {"seeds": [0, 1], "cycle_mean_mm": [[2, 2, 2], [4, 4, 4]]},
                           RUNS[1]: {"seeds": [0, 1], "cycle_mean_mm": [[4, 3, 2], [2, 2, 1]]}}}
    table = report(results)
    assert "| default | 3.00, 3.00, 3.00 | 3.00, 2.50, 1.50 | 2.00, 1.00 | 0.50, 0.50 |" in table


def test_the_runs_forward_each_factor_to_the_experiment(monkeypatch):
    calls = []

    def fake(name, seed, progress, **kwargs):
        calls.append((name, seed, kwargs))
        return {run: {"cycle_mean_mm": [1.0, 1.0, 1.0]} for run in RUNS}

    monkeypatch.setattr(ho2018_factors, "run_experiment", fake)
    results = run_factors([0, 2], ["ridge 2", "path 3x slower"], progress=False)
    assert calls == [("static", 0, {**MEASURED_ON, "ridge": 2.0}),
                     ("static", 2, {**MEASURED_ON, "ridge": 2.0}),
                     ("static", 0, {**MEASURED_ON, "cycle_s": 120.0}),
                     ("static", 2, {**MEASURED_ON, "cycle_s": 120.0})]
    assert results["ridge 2"][RUNS[1]]["seeds"] == [0, 2]


def test_unknown_factors_are_refused_by_name(capsys):
    with pytest.raises(ValueError, match="factors"):
        run_factors([0], ["nonsense"], progress=False)
    with pytest.raises(SystemExit) as exit_:
        main(["--factors", "nonsense"])
    assert exit_.value.code == 2
    assert "--factors" in capsys.readouterr().err
