"""ho2018's experiments as the paper ran them: the protocols' timing against the paper's
figures, the cylinders driving lwpr_rwr's chambers, and the records' bookkeeping (transitions
learnt per cycle, the lead-in's settling) on a tiny run."""

from __future__ import annotations

import math

import numpy as np
import pytest

from eval.papers.ho2018 import experiments as ho2018
from soft_gym.robots.presets import get_preset

TINY_MODEL = {"pretrain_waypoints": 6, "max_epochs": 2, "leg_decisions": 5}


def test_paper_protocol_runs_the_papers_time_and_the_nearest_update_rates():
    """Section 3.4: three static cycles in 400 s, online updates at 23 Hz on average; Section
    3.5.3: the online run's updates at about 7 Hz with about 300 new points per cycle, its
    offline runs without updates at the loop's own rate. Each rate is the nearest of the env's
    20 Hz control rate divided by a whole number of steps."""
    paper = ho2018.PROTOCOLS["paper"]
    period = get_preset("ho2018").control_period_s
    assert 3 * paper.cycle_s["static"] == pytest.approx(400.0)
    rates = {hold: 1.0 / (hold * period) for hold in range(1, 10)}
    for name, run, paper_hz in (("static", "offline", 23.0), ("static", "online", 23.0),
                                ("varying", "offline", 23.0), ("varying", "online", 7.0)):
        nearest = min(rates, key=lambda hold: abs(rates[hold] - paper_hz))
        assert paper.hold_steps[name][run] == nearest, (name, run)
    decisions = paper.cycle_s["varying"] / (paper.hold_steps["varying"]["online"] * period)
    assert decisions == pytest.approx(300.0)
    quick = ho2018.PROTOCOLS["quick"]
    for name in ho2018.EXPERIMENT_SPECS:
        assert quick.cycle_s[name] < paper.cycle_s[name]


def test_unknown_protocol_is_refused_by_name():
    with pytest.raises(ValueError, match=r"protocol must be one of \['paper', 'quick'\], got "
                                         r"'fast'"):
        ho2018.run_experiment("static", protocol="fast")


@pytest.fixture(scope="module")
def tiny_static():
    return ho2018.run_experiment("static", seed=0, cycle_s=6.0, lead_in_s=12.0, progress=False,
                                 cache=False, **TINY_MODEL)


def test_lwpr_rwr_drives_the_cylinders_at_the_protocols_rate(tiny_static):
    for record in tiny_static.values():
        assert record["actuation"] == "volume"
        assert record["decision_hz"] == pytest.approx(20.0)


def test_learnt_transitions_are_counted_per_cycle(tiny_static):
    """Offline learns nothing; online learns in every cycle at most one transition per decision
    (20 Hz over a 6 s cycle: 120 decisions), only those past the 1 mm minimum step."""
    assert tiny_static["offline, no load"]["learnt_per_cycle"] == [0, 0, 0]
    online = tiny_static["online, 14.2 g tip"]["learnt_per_cycle"]
    assert len(online) == 3 and all(0 < n <= 120 for n in online)


def test_lead_in_settling_is_the_last_windows_mean_and_its_change():
    """Written out: errors 9, 7, 5, 3, 2, 2 mm read in windows of 2 steps settle at 2 mm, having
    fallen by 2 mm from the 4 mm of the window before; a lead-in of one window has no change,
    one shorter than a window is read over what it has, an empty one over nothing."""
    settled, drift = ho2018.lead_in_settling(np.array([9.0, 7.0, 5.0, 3.0, 2.0, 2.0]), 2)
    assert (settled, drift) == (2.0, -2.0)
    settled, drift = ho2018.lead_in_settling(np.array([3.0, 1.0]), 2)
    assert settled == 2.0 and math.isnan(drift)
    settled, drift = ho2018.lead_in_settling(np.array([4.0]), 2)
    assert settled == 4.0 and math.isnan(drift)
    assert all(math.isnan(v) for v in ho2018.lead_in_settling(np.zeros(0), 2))


def test_lead_in_settling_is_read_from_its_last_two_windows(tiny_static):
    """The 12 s lead-in holds two 5 s windows, so both readings are finite, and the recorded
    errors start after the lead-in: three cycles of 120 control steps."""
    for record in tiny_static.values():
        assert math.isfinite(record["lead_in_settled_mm"]) and record["lead_in_settled_mm"] > 0
        assert math.isfinite(record["lead_in_drift_mm"])
        assert np.isfinite(record["errors_mm"]).all()
        assert len(record["errors_mm"]) == 3 * 120
