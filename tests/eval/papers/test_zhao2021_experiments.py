"""The zhao2021 experiments (``python -m eval zhao2021``).

A short version on a small model: the runner's plumbing, reachability of the paper's points, the
tables. The paper's findings on seeds 0-2 are the claims ledger's (``eval/papers/zhao2021/claims.py``,
``pytest -m slow tests/eval/claims/test_claims_full.py``).
"""

from __future__ import annotations

from dataclasses import asdict

import numpy as np
import pytest

from eval.papers.zhao2021 import experiments as zhao2021
from soft_gym.papers.zhao2021.shape_reconstruction import ReconstructionConfig

SMALL = ReconstructionConfig(n_free=240, n_loaded=120, max_iterations=80)
"""The small model of tests/soft_gym/papers/zhao2021/test_shape_reconstruction.py (one training
per test process)."""


@pytest.mark.slow  # about 22 s, mostly the drive to the start
def test_the_papers_start_and_goal_are_run():
    """zhao2021 Section VI-C: from (40, 20, 300) to (-50, 70, 210) mm, a 137 mm move, the
    start reached by the env's drive, the goal within reach with 100 g."""
    start = zhao2021.p2p_start_m()
    paper_start = zhao2021.base_point_from_paper(np.array(zhao2021.P2P_START_MM) / 1000.0)
    assert np.linalg.norm(start - paper_start) < 2e-3
    goal = zhao2021.p2p_goal_m()
    paper_goal = zhao2021.base_point_from_paper(np.array(zhao2021.P2P_END_MM) / 1000.0)
    np.testing.assert_array_equal(goal, paper_goal)
    assert np.linalg.norm(goal - start) * 1000 == pytest.approx(137.0, abs=1.0)


@pytest.mark.parametrize("setup, message", [
    ({"goal_mm": (-200.0, 70.0, 150.0)}, r"goal_mm: .* lies \d+\.\d mm from the nearest tip"),
    pytest.param({"p2p_loads_kg": (0.05, 0.4)},
                 r"p2p_loads_g: .* lies \d+\.\d mm from the nearest tip", marks=pytest.mark.slow),
    ({"p2p_loads_kg": (5.0,)}, r"p2p_loads_g: a 5000 g tip load is past .* allowed 0-\d+ g"),
    pytest.param({"circle_mass_kg": 0.6}, r"circle_load_g: .* lies \d+\.\d mm from the nearest tip",
                 marks=pytest.mark.slow),
])
def test_a_goal_or_load_out_of_reach_is_refused_with_the_distance(setup, message):
    with pytest.raises(ValueError, match=message):
        zhao2021.check_setup(**setup)


@pytest.mark.slow
def test_short_point_to_point_run_reports_and_plots(tmp_path):
    """A 12-step ASDM run (about 30 s, slow, as is the claims ledger's quick sway through the
    same runner, tests/eval/claims/test_quick_claims.py)."""
    sensing = asdict(SMALL)
    result = zhao2021.run_p2p(sensing, seed=0, progress=False,
                              runs=(("ASDM (d1 = 8)", 8.0, True, 0.0),), max_steps=12)
    run = result["runs"]["ASDM (d1 = 8)"]
    records = run["records"]
    assert len(records) >= 2
    steps = [r["step_mm"] for r in records]
    assert all(2.0 <= d <= 15.0 for d in steps)
    # the distances recorded are those of the tip and feedback to the goal
    goal = np.array(result["goal_mm"])
    assert np.isclose(records[0]["true_distance_mm"],
                      np.linalg.norm(records[0]["tip_mm"] - goal), atol=1e-6)
    table = zhao2021.report_tables({"p2p": result})
    assert "ASDM (d1 = 8)" in table and "| run |" in table
    assert zhao2021.plot_control(tmp_path / "p2p.png", {"p2p": result}).stat().st_size > 10_000
