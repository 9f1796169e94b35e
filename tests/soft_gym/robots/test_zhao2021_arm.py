"""The zhao2021 arm against its paper: the central thread, Table III's key points, the workspace.

zhao2021 Section II-A: an inextensible thread at the centre of each segment's end rings holds
the segment to at most 150 mm. zhao2021 Table III: the key points P0..P6 of the backbone (thirds
of each segment, P6 the tip) under regulator pressures 0, 0.5, 0.6, 0.8, 0.7, 0 bar. zhao2021
Section VI-C: point to point from (40, 20, 300) mm to (-50, 70, 210) mm. Section VI-D: a
circular path of 100 mm diameter. The paper's frame and chamber numbering map onto
ours through ``soft_gym.robots.presets`` (``ZHAO2021_PAPER_CHAMBERS``,
``paper_point_from_base``).
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from soft_gym.procedures.static_reach import closest_reach
from soft_gym.papers.zhao2021.arm_fit import (
    CIRCLE_MASS_KG,
    P2P_GOAL_MM,
    P2P_LOADS_KG,
    P2P_START_MM,
    SWAY_MASS_KG,
    ZHAO2021_ARM_FIT,
    circle_point_mm,
    evaluate_table3,
)
from soft_gym.papers.zhao2021.arm import ZHAO2021
from soft_gym.papers.zhao2021.frames import (ZHAO2021_PAPER_CHAMBERS, ZHAO2021_PAPER_FRAME_DEG,
                                             ZHAO2021_PAPER_ORIGIN_Z_M, base_point_from_paper,
                                             paper_point_from_base, paper_pressures_to_chambers)
from soft_gym.robots.statics import StaticArm
from soft_gym.robots.spec import SegmentSpec
from soft_gym.engines.pybullet.simulator import ArmSimulator

BAR_PA = 1e5
THREAD_M = 0.150

TABLE_III_PRESSURES_BAR = np.array([0.0, 0.5, 0.6, 0.8, 0.7, 0.0])
"""zhao2021 Table III / Section VI-B: regulators 1-6 in the paper's order (bar)."""

TABLE_III_TRUE_MM = np.array([
    (0.0, 0.0, 0.0), (-0.1, 0.5, 49.6), (4.2, 4.9, 90.1), (3.8, 9.6, 133.2),
    (-22.6, 19.9, 172.9), (-35.9, 35.2, 210.8), (-58.7, 64.7, 248.5)])
"""zhao2021 Table III, "True Position" of P0..P6 (mm, paper frame)."""

PAPER_KEY_POINT_RMS_MM = 3.0
"""zhao2021 Table III / Section VI-B: the key points are known to within 3 mm (the RGB-D
camera's and the networks' errors both under it)."""

REACH_TOLERANCE_MM = 2.0
"""A point counts as reached when the tip rests within this distance of it (mm)."""

START_MM = np.array(P2P_START_MM)
END_MM = np.array(P2P_GOAL_MM)
"""zhao2021 Section VI-C: the point-to-point task's start and end (mm, paper frame)."""


def _settle(sim: ArmSimulator, paper_bar: np.ndarray, hold_s: float = 3.0) -> None:
    """Ramp from rest to the paper-order pressures over 1 s and hold them for ``hold_s``."""
    target = paper_pressures_to_chambers(np.asarray(paper_bar) * BAR_PA)
    sim.reset(settle_s=0.2)
    for fraction in np.linspace(0.0, 1.0, 6)[1:]:
        sim.set_pressures(target * fraction)
        sim.step_physics(0.2)
    sim.step_physics(hold_s)


def _key_points(sim: ArmSimulator) -> np.ndarray:
    """Backbone points at thirds of each segment (m, base frame), P0..P6: along each link's chord,
    by arc fraction of the segment's links."""
    backbone = sim.backbone()
    points, first = [backbone[0]], 0
    for segment in sim.spec.segments:
        n = segment.n_links
        for fraction in (1 / 3, 2 / 3, 1.0):
            station = fraction * n
            j = min(int(np.floor(station)), n - 1)
            t = station - j
            points.append((1 - t) * backbone[first + j] + t * backbone[first + j + 1])
        first += n
    return np.array(points)


def _segment_lengths(sim: ArmSimulator) -> np.ndarray:
    """Backbone length of each segment (m)."""
    q = sim.joint_positions()
    links = sim.arm.station_rest_length + q[sim.arm.station_axial_joint]
    return np.bincount(sim.arm.station_segment, weights=links)


@pytest.fixture(scope="module")
def sim():
    simulator = ArmSimulator(ZHAO2021)
    yield simulator
    simulator.close()


def test_thread_length_is_validated():
    base = ZHAO2021.segments[0]
    longest = base.length_m * base.max_extension_ratio
    for bad in (0.9 * base.length_m, 1.05 * longest, float("nan"), float("inf"), True, "0.15"):
        with pytest.raises(ValueError, match="thread_length_m"):
            dataclasses.replace(base, thread_length_m=bad)
    rest = dataclasses.replace(base, length_m=THREAD_M, thread_length_m=THREAD_M)
    assert rest.max_length_m == THREAD_M
    free = SegmentSpec(length_m=0.1, outer_radius_m=0.01, chamber_offset_m=0.005,
                       chamber_area_m2=1e-5, youngs_modulus_pa=1e5)
    assert free.max_length_m == pytest.approx(0.16)
    assert ZHAO2021.max_reach_m == pytest.approx(2 * THREAD_M)


def test_paper_frame_mapping_round_trips():
    point = np.array([0.04, 0.02, 0.30])
    assert np.allclose(paper_point_from_base(base_point_from_paper(point)), point)
    assert sorted(ZHAO2021_PAPER_CHAMBERS) == list(range(6))
    with pytest.raises(ValueError, match="paper_pa"):
        paper_pressures_to_chambers(np.zeros(5))


def _table_iii_errors_mm(sim: ArmSimulator) -> np.ndarray:
    _settle(sim, TABLE_III_PRESSURES_BAR)
    simulated = paper_point_from_base(_key_points(sim)) * 1e3
    return np.linalg.norm(simulated - TABLE_III_TRUE_MM, axis=1)[1:]


def test_table_iii_key_points_are_the_fits(sim):
    """The simulated arm settles where the fit's static arm rests: Table III's key points as
    far from the paper's as the fit's residuals say (the preset's notes)."""
    errors = _table_iii_errors_mm(sim)
    fitted = evaluate_table3(ZHAO2021_ARM_FIT)
    np.testing.assert_allclose(errors, fitted, atol=0.3)


@pytest.mark.xfail(strict=True, reason=(
    "the arm that holds the paper's experiments (the goal (-50, 70, 210) mm with 100 g on the "
    "tip) cannot also rest on Table III's key points: RMS 29.3 mm (P1..P6 2.8, 9.6, 17.2, 19.8, "
    "26.7, 60.3 mm). Fitted to Table III alone the arm gets 7.0 mm, 6.7 mm with the circle and "
    "the starts too, but then the goal lies 23-34 mm out of reach with 0-100 g (12.2 mm RMS "
    "holding the goal unloaded): docs/architecture.md, \"zhao2021 arm fit\""))
def test_table_iii_key_points_within_the_papers_3_mm(sim):
    """zhao2021 Table III: the arm under the table's pressures rests on its key points."""
    errors = _table_iii_errors_mm(sim)
    assert np.sqrt(np.mean(errors ** 2)) < PAPER_KEY_POINT_RMS_MM, np.round(errors, 1)


def test_the_thread_holds_every_segment_to_150_mm(sim):
    """No pressures and no load the arm accepts lengthen a segment past its thread."""
    rng = np.random.default_rng(7)
    commands = [np.full(6, 0.8)] + [rng.uniform(0.0, 0.8, 6) for _ in range(6)]
    longest = 0.0
    for load in (0.0, ZHAO2021.max_load_n):
        sim.reset(settle_s=0.1)
        sim.apply_tip_force(sim.gravity / np.linalg.norm(sim.gravity) * load)
        for command in commands:
            sim.set_pressures(paper_pressures_to_chambers(command * BAR_PA))
            for _ in range(8):
                sim.step_physics(0.1)
                longest = max(longest, float(np.max(_segment_lengths(sim))))
        if load == 0.0:
            # all chambers at 0.8 bar pull both threads taut
            sim.set_pressures(np.full(6, 0.8 * BAR_PA))
            sim.step_physics(2.0)
            assert np.all(_segment_lengths(sim) > THREAD_M - 1e-3), _segment_lengths(sim)
        sim.apply_tip_force(np.zeros(3))
    assert longest <= THREAD_M + 0.5e-3, longest


def _tip_in_paper_frame_mm(sim: ArmSimulator) -> np.ndarray:
    return paper_point_from_base(sim.tip_pose()[0]) * 1e3


@pytest.fixture(scope="module")
def static_arm():
    return StaticArm(ZHAO2021)


@pytest.mark.slow
@pytest.mark.parametrize("mass_kg", P2P_LOADS_KG[:-1])
def test_the_goal_is_within_reach_with_every_load(static_arm, mass_kg):
    """zhao2021 Section VI-C-1: the goal (-50, 70, 210) mm, free and with 50 and 75 g (100 g:
    the next test)."""
    goal = base_point_from_paper(END_MM / 1000.0)
    reach = closest_reach(static_arm, goal, mass_kg)
    assert reach.distance_m * 1e3 < REACH_TOLERANCE_MM, reach


@pytest.mark.slow
@pytest.mark.parametrize("mass_kg", [0.0, SWAY_MASS_KG])
def test_the_start_is_within_reach(static_arm, mass_kg):
    """zhao2021 Section VI-C: the start (40, 20, 300) mm, free and with the 119 g block."""
    reach = closest_reach(static_arm, base_point_from_paper(START_MM / 1000.0), mass_kg)
    assert reach.distance_m * 1e3 < REACH_TOLERANCE_MM, reach


def _circle_reach_mm(arm: StaticArm, k: int, n: int, mass_kg: float) -> float:
    point = base_point_from_paper(circle_point_mm(k, ZHAO2021_ARM_FIT.circle_z_mm, n=n) / 1000.0)
    return closest_reach(arm, point, mass_kg).distance_m * 1e3


@pytest.mark.slow
@pytest.mark.parametrize("mass_kg", [0.0, CIRCLE_MASS_KG])
def test_the_circle_is_within_reach_free_and_with_263_g(static_arm, mass_kg):
    """zhao2021 Section VI-D: four points, 90 deg apart, of the 100 mm circle (at the fitted
    height) free and carrying the 263 g block; twelve in the slow test below."""
    for k in range(4):
        assert _circle_reach_mm(static_arm, 2 * k + 1, 8, mass_kg) < REACH_TOLERANCE_MM, k


@pytest.mark.slow
@pytest.mark.parametrize("mass_kg", [0.0, CIRCLE_MASS_KG])
def test_twelve_circle_points_are_within_reach(static_arm, mass_kg):
    for k in range(12):
        assert _circle_reach_mm(static_arm, k, 12, mass_kg) < REACH_TOLERANCE_MM, k


def test_the_goal_is_held_with_100_g(sim, static_arm):
    """zhao2021 Section VI-C-1: the goal (-50, 70, 210) mm with the heaviest static load, 100 g:
    the static search finds pressures within 2 mm of it, and they hold the simulated arm's tip
    there (the other loads, the start and the circle: slow tests above)."""
    goal = base_point_from_paper(END_MM / 1000.0)
    reach = closest_reach(static_arm, goal, 0.100)
    assert reach.distance_m * 1e3 < REACH_TOLERANCE_MM, reach
    sim.reset(settle_s=0.2)
    sim.set_tip_payload("goal", 0.100)
    try:
        sim.set_pressures(reach.pressures_pa)
        sim.step_physics(10.0)
        tip = _tip_in_paper_frame_mm(sim)
    finally:
        sim.set_tip_payload("goal", 0.0)
    assert np.linalg.norm(tip - END_MM) < REACH_TOLERANCE_MM + 0.5, np.round(tip, 1)


def test_the_fit_is_the_preset():
    """The preset is the fit's arm: its segments and the paper's frame."""
    fitted = ZHAO2021_ARM_FIT.spec()
    assert fitted.segments == ZHAO2021.segments
    assert ZHAO2021_PAPER_FRAME_DEG == pytest.approx(ZHAO2021_ARM_FIT.frame_deg)
    assert ZHAO2021_PAPER_ORIGIN_Z_M == pytest.approx(ZHAO2021_ARM_FIT.origin_z_m)


def test_chamber_area_growth_is_validated_and_grows_the_force():
    """``SegmentSpec.chamber_area_growth``: a number in [0, 4]; the chamber force goes with
    ``p (1 + g p / p_max)`` (``pneumatics.effective_pressure_pa``)."""
    from soft_gym.robots.pneumatics import chamber_loads, effective_pressure_pa

    base = ZHAO2021.segments[0]
    for bad in (-0.1, 4.5, float("nan"), float("inf"), True, "1", None):
        with pytest.raises(ValueError, match="chamber_area_growth"):
            dataclasses.replace(base, chamber_area_growth=bad)
    growth = 1.1
    linear = dataclasses.replace(base, chamber_area_growth=growth, chamber_area_growth_exponent=1.0)
    spec = dataclasses.replace(ZHAO2021, segments=(linear, linear))
    pressure = np.array([0.0, 0.4, 0.8, 0.8, 0.8, 0.8]) * BAR_PA
    effective = effective_pressure_pa(spec, pressure)
    np.testing.assert_allclose(effective, pressure * (1 + growth * pressure / base.p_max_pa))
    axial, _ = chamber_loads(spec, pressure)
    assert axial[1] == pytest.approx(3 * 0.8 * BAR_PA * base.chamber_area_m2 * (1 + growth))


def test_chamber_area_growth_exponent_sets_the_growth_in_late():
    """``SegmentSpec.chamber_area_growth_exponent`` ``n``: a number in [1, 6]; the force goes
    with ``p (1 + g (p / p_max)^n)``, the same at ``p_max`` for every ``n`` and lower below it
    for larger ``n``; ``n`` = 1 is the linear law."""
    from soft_gym.robots.pneumatics import effective_pressure_pa

    base = ZHAO2021.segments[0]
    for bad in (0.5, 6.5, float("nan"), True, "2", None):
        with pytest.raises(ValueError, match="chamber_area_growth_exponent"):
            dataclasses.replace(base, chamber_area_growth_exponent=bad)
    pressure = np.array([0.0, 0.4, 0.8, 0.2, 0.6, 0.8]) * BAR_PA
    growth, p_max = 2.0, base.p_max_pa
    for exponent in (1.0, 3.0):
        segment = dataclasses.replace(base, chamber_area_growth=growth,
                                      chamber_area_growth_exponent=exponent)
        spec = dataclasses.replace(ZHAO2021, segments=(segment, segment))
        np.testing.assert_allclose(effective_pressure_pa(spec, pressure),
                                   pressure * (1 + growth * (pressure / p_max) ** exponent),
                                   rtol=1e-12)
    late = dataclasses.replace(base, chamber_area_growth=growth, chamber_area_growth_exponent=3.0)
    spec = dataclasses.replace(ZHAO2021, segments=(late, late))
    linear = dataclasses.replace(ZHAO2021, segments=(dataclasses.replace(
        base, chamber_area_growth=growth, chamber_area_growth_exponent=1.0),) * 2)
    assert effective_pressure_pa(spec, pressure)[2] == pytest.approx(
        effective_pressure_pa(linear, pressure)[2])
    assert effective_pressure_pa(spec, pressure)[1] < effective_pressure_pa(linear, pressure)[1]
