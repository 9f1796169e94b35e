"""The zhao2021 experiments (``python -m eval zhao2021``).

Default: a short version on a small model (the runner's plumbing, reachability of the paper's
points, the tables). Slow (``pytest -m slow``): the paper's patterns on seeds 0, 1 and 2 with the
paper's exploration and training (Sections VI-B to VI-D).
"""

from __future__ import annotations

from dataclasses import asdict

import numpy as np
import pytest

from eval.papers import zhao2021
from soft_gym.sensing.zhao2021.shape_reconstruction import ReconstructionConfig

SMALL = ReconstructionConfig(n_free=240, n_loaded=120, max_iterations=80)
"""The small model of tests/soft_gym/sensing/zhao2021/test_shape_reconstruction.py (one training
per test process)."""


def test_paper_start_is_reached_and_the_goal_is_the_nearest_reachable_point():
    start = zhao2021.p2p_start_m()
    paper_start = zhao2021.base_point_from_paper(np.array(zhao2021.P2P_START_MM) / 1000.0)
    assert np.linalg.norm(start - paper_start) < 2e-3
    goal = zhao2021.p2p_goal_m()
    paper_goal = zhao2021.base_point_from_paper(np.array(zhao2021.P2P_END_MM) / 1000.0)
    # the calibrated arm falls ~23 mm short of the paper's end free (presets notes["reach"]),
    # 72 mm with the heaviest load of the runs (100 g)
    assert 0.015 < np.linalg.norm(goal - paper_goal) < 0.08
    assert np.linalg.norm(goal - start) > 0.06  # still a long move (73 mm)


def test_short_point_to_point_run_reports_and_plots(tmp_path):
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


@pytest.mark.slow
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_paper_patterns(seed, tmp_path):
    results = zhao2021.run_and_report(list(zhao2021.EXPERIMENTS), [seed], tmp_path,
                                      progress=False)[f"seed{seed}"]
    shape = results["shape"]
    # Table III: the key points predicted as well as the paper's on average (its errors 1.3-2.1
    # mm; seeds 0-2 here: mean 0.61, 0.38, 1.54 mm, the far tip up to 6.1 mm on seed 2) and the
    # backbone far within its 5.85 mm (0.37, 0.47, 0.31 mm)
    assert np.mean(shape["table3"]["errors_mm"]) < 2.14
    assert shape["mean_backbone_error_mm"] < 5.85
    # Table IV: the backbone error grows only slightly with the tip load
    free = np.mean(shape["table4"]["0"]["mean_backbone_mm"])
    heaviest = np.mean(shape["table4"]["150"]["mean_backbone_mm"])
    assert heaviest < free + 3.0
    runs = results["p2p"]["runs"]
    steps = {label: run["steps"] for label, run in runs.items()}
    assert all(value is not None for value in steps.values()), steps
    # ASDM needs no more steps than d = 8 and a fraction of d = 2's (seeds 0-2: 7/7/28, 9/10/37,
    # 8/9/28; the paper: 14, 24, 75), without oscillating (at most one rise of the distance)
    assert steps["ASDM (d1 = 8)"] <= steps["d = 8"] < steps["d = 2"] / 2
    assert runs["ASDM (d1 = 8)"]["distance_rises"] <= 1
    # loads slow it down but are rejected (seed 0: 9, 10, 12 steps with 50, 75, 100 g)
    assert steps["ASDM, 100 g"] >= steps["ASDM (d1 = 8)"]
    sway = results["sway"]
    assert sway["steps"] is not None
    assert sway["step_mm_during_pull"] > sway["step_mm_before_pull"]
    circle = results["circle"]
    for run in circle.values():  # round the whole circle, free and loaded (seeds 0-2: 53-108 steps)
        assert run["points_reached"] == zhao2021.CIRCLE_POINTS, run["points_reached"]
    assert circle["free"]["path_error_mean_mm"] < 5.0
    carried = circle["50 g, steps 29-60"]["recovery_steps"]
    assert carried["added"] is not None and carried["added"] <= 10  # seed 0: 4 steps
    # 263 g is beyond the arm's reach around the circle; once removed, the arm is back in a few
    heavy = circle["263 g, steps 29-60"]["recovery_steps"]
    assert heavy["removed"] is not None and heavy["removed"] <= 10  # seed 0: 7 steps
