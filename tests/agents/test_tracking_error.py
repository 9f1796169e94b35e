"""The tracking error of an episode record (agents/tracking_error.py): training's last-cycle score
is the suites' (the last per-cycle mean of eval.metrics.summarize), bit for bit."""

from __future__ import annotations

import math

import numpy as np
import pytest

from agents.tracking_error import (error_stats, last_cycle_error_mm, record_cycles,
                                   tracking_error_mm)
from eval.metrics import summarize

pytestmark = pytest.mark.smoke


def _record(cycles: int = 3, steps_per_cycle: int = 40, seed: int = 0) -> dict[str, np.ndarray]:
    """A synthetic track record: a target on a circle, the tip scattered around it (m)."""
    rng = np.random.default_rng(seed)
    steps = cycles * steps_per_cycle
    theta = 2.0 * np.pi * np.arange(steps) / steps_per_cycle
    target = np.column_stack((0.02 * np.cos(theta), 0.02 * np.sin(theta), np.full(steps, 0.1)))
    return {"target_m": target, "tip_m": target + rng.normal(0.0, 0.002, target.shape),
            "cycle": np.repeat(np.arange(cycles), steps_per_cycle)}


@pytest.mark.parametrize("cycles", [1, 3])
def test_last_cycle_error_is_the_suites_score_bit_for_bit(cycles):
    record = _record(cycles)
    assert last_cycle_error_mm(record) == summarize(record)["tracking"]["per_cycle"]["mean_mm"][-1]


def test_last_cycle_error_skips_non_finite_steps_and_reads_a_record_without_cycles():
    record = _record(2)
    record["tip_m"][-1] = np.nan
    last = tracking_error_mm(record)[40:-1]
    assert last_cycle_error_mm(record) == pytest.approx(float(np.mean(last)), rel=1e-12)
    no_cycles = {key: value for key, value in record.items() if key != "cycle"}
    assert np.array_equal(record_cycles(no_cycles), np.zeros(80, dtype=int))
    assert last_cycle_error_mm(no_cycles) == pytest.approx(float(np.nanmean(
        tracking_error_mm(no_cycles))), rel=1e-12)
    assert math.isnan(error_stats(np.array([np.nan]))["mean_mm"])


def test_malformed_records_are_refused_naming_the_column():
    record = _record(1)
    with pytest.raises(ValueError, match="no 'target_m' column"):
        last_cycle_error_mm({"tip_m": record["tip_m"]})
    with pytest.raises(ValueError, match=r"record\['cycle'\] must have shape"):
        last_cycle_error_mm({**record, "cycle": record["cycle"][:-1]})
    with pytest.raises(ValueError, match=r"record\['tip_m'\] must have shape \(T, 3\)"):
        tracking_error_mm({**record, "tip_m": record["tip_m"][:, :2]})
