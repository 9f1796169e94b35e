"""ho2018's findings on the full experiments, seeds 0, 1 and 2 (slow: about 6 minutes a seed).

Tables 1-2 of Ho et al. 2018: under an unknown static tip load, online learning lowers the
tracking error cycle by cycle while the offline model's error without load does not improve;
under a filling fluid tip the offline error grows (and goes unstable in the paper) while the
online learner's ends far below it. The absolute millimetres differ from the paper's (see the
closing of ``eval/papers/ho2018.py``'s table: the simulated arm, its pressures for the paper's
volumes, and the 10 Hz decisions).
"""

from __future__ import annotations

import pytest

from eval.papers.ho2018 import report_table, run_experiment

pytestmark = pytest.mark.slow


@pytest.fixture(scope="module", params=[0, 1, 2])
def runs(request):
    seed = request.param
    static = run_experiment("static", seed=seed, progress=False)
    varying = run_experiment("varying", seed=seed, progress=False)
    print(f"\nseed {seed}\n{report_table('static', static)}\n{report_table('varying', varying)}")
    return seed, static, varying


def test_static_load_online_learning_learns_the_load_away(runs):
    """Table 1: under the unknown 14.2 g tip the online learner ends at (within 10 %) or below
    the unloaded offline run's error and never ends worse than it started; where the load raised
    the first cycle's error by more than a fifth over the unloaded run, the online error falls
    by at least a tenth by cycle 3; the offline error without load does not improve.
    Measured (online under load / offline without, mm per cycle): seed 0 4.61, 2.70, 2.59 /
    2.51, 2.34, 2.38; seed 1 2.81, 2.50, 2.38 / 1.88, 2.14, 2.20; seed 2 2.57, 2.74, 2.61 /
    3.51, 3.76, 3.75 (on seed 2 the pre-trained model happens to suit the loaded arm better
    than the unloaded one, so there is nothing to learn)."""
    seed, static, _ = runs
    online = static["online, 14.2 g tip"]["cycle_mean_mm"]
    offline = static["offline, no load"]["cycle_mean_mm"]
    assert online[2] < 1.1 * offline[2], (seed, online, offline)
    assert online[2] < 1.05 * online[0], (seed, online)
    if online[0] > 1.2 * offline[0]:
        assert online[2] < 0.9 * online[0], (seed, online, offline)
    assert offline[2] > 0.8 * offline[0], (seed, offline)


def test_filling_load_offline_degrades_and_online_ends_far_below(runs):
    """Table 2: with the fluid tip filling in cycles 3-4 the offline error more than doubles
    while the online learner's ends below half of it and averages below its first cycle over
    cycles 2-4; with the empty tip the offline error does not improve. Measured (mm, cycle 1 -> 4): offline filling
    7.14 -> 21.95, 6.41 -> 23.07, 7.41 -> 24.00; online filling 2.82 -> 2.76, 3.00 -> 2.23,
    2.65 -> 2.17 (seeds 0, 1, 2)."""
    seed, _, varying = runs
    offline = varying["offline, filling"]["cycle_mean_mm"]
    online = varying["online, filling"]["cycle_mean_mm"]
    empty = varying["offline, empty 14 g tip"]["cycle_mean_mm"]
    assert offline[3] > 2.0 * offline[0], (seed, offline)
    assert empty[3] > 0.8 * empty[0], (seed, empty)  # without filling it does not improve
    assert online[3] < 0.5 * offline[3], (seed, online, offline)
    assert sum(online[1:]) / 3 < online[0], (seed, online)  # it learns the load
