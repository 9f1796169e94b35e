"""zou2022 closed-loop comparison (eval/papers/zou2022/control.py): rows, faults, refusals, table,
plot.

The runs are short: a circle at four times the default speed (two ~5 s cycles), ``cc_model``
only, and a tiny DNN for ``encoder_dnn``; the grid of every feedback and condition (about 40 s)
runs with ``-m slow``.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from eval.papers.zou2022.control import (CONTROL_CONDITIONS, CONTROL_FEEDBACK, CONTROL_POLICIES,
                                  control_table, cycle_duration_s, env_kwargs, plot_control,
                                  run_control, stereo_fault, strip_records)

TINY_DNN = {"n_samples": 120, "epochs": 20}
FAST_M_S = 0.045
"""About four times the default target speed: one cycle in ~5 s (m/s)."""


@pytest.fixture(scope="module")
def short_grid():
    """``cc_model`` with every feedback source, nominal and stereo-faulted, two short cycles."""
    return run_control(seed=0, dnn_options=TINY_DNN, cycles=2, policies=("cc_model",),
                       speed_m_s=FAST_M_S, progress=False)


def _row(rows, feedback, condition):
    (row,) = [r for r in rows if r["feedback"] == feedback and r["condition"] == condition]
    return row


@pytest.mark.smoke
def test_constants():
    assert CONTROL_POLICIES == ("cc_model", "hybrid_gpr", "lwpr_rwr")
    assert CONTROL_FEEDBACK == ("encoder_cc", "stereo", "encoder_dnn")
    assert CONTROL_CONDITIONS == ("nominal", "stereo faulted")


def test_fault_covers_the_last_cycle_and_reaches_the_pair():
    assert stereo_fault(2, 20.0) == {"name": "low_light", "strength": 1.0, "start_s": 20.0}
    assert stereo_fault(1, 20.0)["start_s"] == 10.0
    assert cycle_duration_s() == pytest.approx(20.0)
    nominal = env_kwargs("encoder_cc", "nominal", 2)
    assert "faults" not in nominal and "sensors" not in nominal
    faulted = env_kwargs("encoder_cc", "stereo faulted", 2)
    assert faulted["sensors"] == ("stereo",)  # simulated, faulted, never read
    assert faulted["faults"]["stereo"]["start_s"] == pytest.approx(20.0)
    assert "sensors" not in env_kwargs("stereo", "stereo faulted", 2)
    assert env_kwargs("encoder_dnn", "nominal", 2, {"n_samples": 50})["sensing"] == {
        "n_samples": 50}


@pytest.mark.slow
def test_one_row_per_feedback_and_condition_with_finite_true_errors(short_grid):
    assert [(r["policy"], r["feedback"], r["condition"]) for r in short_grid] == [
        ("cc_model", source, condition) for source in CONTROL_FEEDBACK
        for condition in CONTROL_CONDITIONS]
    for row in short_grid:
        assert row["refused"] is None and row["seed"] == 0 and row["cycles"] == 2
        for key in ("track_last_cycle_mm", "dev_last_cycle_mm", "max_last_cycle_mm",
                    "feedback_error_last_cycle_mm", "track_mean_mm", "run_s"):
            assert math.isfinite(row[key]), (row["feedback"], row["condition"], key)
        assert row["max_last_cycle_mm"] >= row["track_last_cycle_mm"] > 0.0
        record = row["record"]
        steps = len(record["time_s"])
        # the table's error is the ground-truth tip against the target, not the feedback
        np.testing.assert_allclose(
            np.linalg.norm(record["tip_m"] - record["target_m"], axis=1) * 1000.0,
            record["error_mm"], atol=1e-6)
        assert set(np.unique(record["cycle"])) == {0, 1} and steps > 150


@pytest.mark.slow
def test_the_dark_pair_is_lost_for_stereo_and_unread_by_the_encoders(short_grid):
    faulted = _row(short_grid, "stereo", "stereo faulted")
    nominal = _row(short_grid, "stereo", "nominal")
    assert faulted["stereo_lost_last_cycle"] == 1.0
    assert 0.4 < faulted["stereo_lost_fraction"] < 0.6
    assert nominal["stereo_lost_fraction"] < 0.05
    lost = faulted["record"]["lost"].astype(bool)
    assert faulted["record"]["time_s"][lost].min() >= faulted["fault_start_s"] - 1e-9
    # blind, the stereo source holds its last shape: its feedback drifts from the true tip
    assert faulted["feedback_error_last_cycle_mm"] > nominal["feedback_error_last_cycle_mm"]
    for source in ("encoder_cc", "encoder_dnn"):
        rows = [_row(short_grid, source, condition) for condition in CONTROL_CONDITIONS]
        for row in rows:
            assert row["stereo_lost_fraction"] is None and row["stereo_lost_last_cycle"] is None
            assert "lost" not in row["record"]
        # the dark frames only shift the encoders' noise samples (one shared generator)
        assert rows[1]["track_last_cycle_mm"] == pytest.approx(rows[0]["track_last_cycle_mm"],
                                                              abs=0.5)


@pytest.mark.slow
def test_table_and_plot(short_grid, tmp_path):
    table = control_table(short_grid)
    lines = table.strip().splitlines()
    assert len(lines) == 2 + len(short_grid)
    assert "tracking, last cycle (mm)" in lines[0] and "stereo lost" in lines[0]
    assert "n/a (not read)" in table
    stereo_faulted = [line for line in lines if "| stereo | stereo faulted |" in line]
    assert len(stereo_faulted) == 1 and "/ 100 |" in stereo_faulted[0]
    path = plot_control(tmp_path / "control.png", short_grid)
    assert path.is_file() and path.stat().st_size > 0
    mapping = {(r["policy"], r["feedback"], r["condition"]): r["record"] for r in short_grid}
    assert plot_control(tmp_path / "mapping.png", mapping).is_file()
    assert all("record" not in row for row in strip_records(short_grid))


def test_a_baseline_that_cannot_drive_the_arm_is_a_refused_row(tmp_path):
    rows = run_control(seed=0, dnn_options=TINY_DNN, cycles=1, policies=("local_ik_asdm",),
                       feedback=("encoder_cc",), progress=False)
    assert [r["condition"] for r in rows] == list(CONTROL_CONDITIONS)
    for row in rows:
        assert "local_ik_asdm" in row["refused"] and row["record"] is None
        assert math.isnan(row["track_last_cycle_mm"])
    table = control_table(rows)
    assert table.count("refused: ") == 2
    with pytest.raises(ValueError, match="records"):
        plot_control(tmp_path / "none.png", rows)


@pytest.mark.smoke
@pytest.mark.parametrize("kwargs, name", [
    ({"seed": -1}, "seed"), ({"seed": 1.5}, "seed"), ({"cycles": 0}, "cycles"),
    ({"policies": ("pid",)}, "policies"), ({"policies": "cc_model"}, "policies"),
    ({"feedback": ("ground_truth",)}, "feedback"), ({"conditions": ("fog",)}, "conditions"),
    ({"dnn_options": [("n_samples", 10)]}, "dnn_options"), ({"speed_m_s": -0.01}, "speed_m_s"),
])
def test_bad_arguments_name_the_parameter(kwargs, name):
    arguments = {"seed": 0, "dnn_options": TINY_DNN, "progress": False, **kwargs}
    with pytest.raises(ValueError, match=name):
        run_control(**arguments)


def test_bad_fault_and_env_arguments():
    with pytest.raises(ValueError, match="cycle_s"):
        stereo_fault(2, 0.0)
    with pytest.raises(ValueError, match="feedback"):
        env_kwargs("fused", "nominal")
    with pytest.raises(ValueError, match="condition"):
        env_kwargs("stereo", "rain")


@pytest.mark.slow
def test_every_baseline_with_stereo_feedback_short():
    """All three baselines on ``stereo`` feedback (``lwpr_rwr`` pre-trains: minutes uncached)."""
    rows = run_control(seed=0, dnn_options=TINY_DNN, cycles=2, feedback=("stereo",),
                       speed_m_s=FAST_M_S, progress=False)
    assert len(rows) == len(CONTROL_POLICIES) * len(CONTROL_CONDITIONS)
    for row in rows:
        assert row["refused"] is None and math.isfinite(row["track_last_cycle_mm"])
        if row["condition"] == "stereo faulted":
            assert row["stereo_lost_last_cycle"] == 1.0
