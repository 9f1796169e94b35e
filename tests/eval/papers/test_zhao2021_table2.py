"""zhao2021 Table II: the backbone fit on FEM-like shapes with noisy key points (Section V-A).

The shapes are the paper's eight actuations simulated on the zhao2021 arm with four spiralling
1 N forces (:mod:`eval.papers.zhao2021.table2`); the criteria are Table II's own numbers.
"""

from __future__ import annotations

import numpy as np
import pytest

from eval.papers.zhao2021.table2 import (CONFIGURATIONS, PAPER_TABLE2_MM, XI_MM, plot_table2,
                                         report_table2, run_table2, simulate_shapes)
from soft_gym.papers.zhao2021.backbone_fit import BACKBONE_CURVES

PAPER_LARGEST_MM = np.max(list(PAPER_TABLE2_MM.values()), axis=0)
"""Table II's largest error at each xi (mm): 3.18, 3.88, 3.97, 3.68."""


@pytest.fixture(scope="module")
def table2():
    return run_table2(seed=0, draws=4, progress=False, shapes=simulate_shapes())


def test_the_shapes_are_the_papers_eight_configurations_and_bend_in_3d():
    shapes = simulate_shapes(links_per_segment=4)
    assert list(shapes) == list(CONFIGURATIONS) == list(PAPER_TABLE2_MM)
    for name, (key_points, backbone) in shapes.items():
        assert key_points.shape == (7, 3) and backbone.shape == (9, 3)
        np.testing.assert_array_equal(key_points[0], np.zeros(3))
        # every configuration leaves the axis (bent by its chambers and the forces); some bend
        # back towards it (row 2,5's tip ends 10.7 mm off the axis), so the farthest key point
        # is what leaves it
        assert np.max(np.hypot(key_points[:, 0], key_points[:, 1])) > 0.02, name


def test_the_papers_curve_fits_every_configuration_within_table_ii_without_noise(table2):
    # Table II at xi = 0: 2.42-3.18 mm. Measured 0.80-3.17 mm (mean 1.97).
    errors = np.array([row[0] for row in table2["error_mm"]["paper"].values()])
    assert np.all(errors <= PAPER_LARGEST_MM[0])
    counts = table2["subsegments"]["paper"]
    assert counts["isf"] > 10 * counts["cubic"]  # the paper's ISF, not the fallback


@pytest.mark.xfail(strict=True, reason=(
    "Table II's error stays within 3.88 / 3.97 / 3.68 mm at xi = 2 / 3 / 4; measured (20 "
    "draws, seeds 0-2) 3.59-4.15 / 4.60-4.80 / 5.58-5.85 mm: per-coordinate noise moves the key "
    "points by 0.96 xi and the curve starts on them (the cubic through them: 3.9 mm at xi = 4)"))
def test_the_papers_curve_stays_within_table_ii_with_noisy_key_points(table2):
    means = table2["mean_error_mm"]["paper"]
    assert all(mean <= bound for mean, bound in zip(means[1:], PAPER_LARGEST_MM[1:]))


def test_the_error_rises_with_the_key_point_noise(table2):
    # Table II's qualitative finding: a larger xi, a larger error.
    means = table2["mean_error_mm"]["paper"]
    assert all(later > earlier for earlier, later in zip(means, means[1:]))


def test_the_base_frame_reading_misses_the_papers_shapes(table2):
    # Measured 10.0 mm mean at xi = 0, 22-24 mm on rows 1,5 and 3,5 (module docstring).
    base = table2["error_mm"]["paper_base_frame"]
    assert np.mean([row[0] for row in base.values()]) > 2 * PAPER_LARGEST_MM[0]
    assert np.mean(table2["mean_error_mm"]["paper_base_frame"]) > np.mean(
        table2["mean_error_mm"]["paper"])


def test_the_report_and_plot_give_every_curve_and_the_subsegment_counts(table2, tmp_path):
    lines = "\n".join(report_table2(table2))
    for curve in BACKBONE_CURVES:
        assert f"| subsegments | {curve} | ISF " in lines
    assert lines.count("|") > 8 * len(BACKBONE_CURVES) * len(XI_MM)
    assert plot_table2(tmp_path / "table2.png", table2).stat().st_size > 10_000


@pytest.mark.parametrize("kwargs, name", [({"draws": 0}, "draws"), ({"seed": -1}, "seed"),
                                          ({"draws": 2.5}, "draws")])
def test_bad_settings_are_refused_by_name(kwargs, name):
    with pytest.raises(ValueError, match=name):
        run_table2(progress=False, shapes={}, **kwargs)
