"""Loads and disturbances act through PyBullet and follow their schedules."""

from __future__ import annotations

import numpy as np
import pytest

from soft_gym.robots import get_preset
from soft_gym.scenarios import FillingLoad, Flick, ObstacleRod, Push, SwayingMass, make_scenario
from soft_gym.engines.pybullet.simulator import ArmSimulator


def _bent_sim(*loads) -> ArmSimulator:
    sim = ArmSimulator(get_preset("wang2023"))
    for load in loads:
        sim.add_load(load)
    sim.reset(settle_s=0.5)
    sim.set_pressures(np.array([100e3, 0.0, 0.0]))
    return sim


def test_filling_load_mass_rises_at_its_rate_to_its_maximum():
    """ho2018 fluid tip: 14 g container gaining 10 g at 0.6 g/s from t = 5 s."""
    load = FillingLoad()
    sim = _bent_sim(load)
    tip = sim.arm.tip_link
    base = sim.link_mass(tip) - sim.tip_payload_kg
    sim.step_physics(4.0)
    assert sim.link_mass(tip) - base == pytest.approx(0.014, abs=1e-6)
    sim.step_physics(5.0)  # t = 9 s: 4 s of filling at 0.6 g/s
    assert sim.link_mass(tip) - base == pytest.approx(0.014 + 0.0024, abs=1e-4)
    sim.step_physics(20.0)
    assert sim.link_mass(tip) - base == pytest.approx(0.024, abs=1e-6)


def test_swaying_mass_hangs_at_its_length_below_the_tip():
    load = SwayingMass(mass_kg=0.01, length_m=0.02)
    sim = _bent_sim(load)
    sim.step_physics(3.0)
    ball = np.array(sim.client.getBasePositionAndOrientation(load._body)[0])
    tip, _ = sim.tip_pose()
    assert np.linalg.norm(ball - tip) == pytest.approx(0.02, abs=1e-3)
    assert ball[2] > tip[2]  # hanging mount: gravity is +z in the base frame


@pytest.mark.smoke
def test_push_moves_the_tip_along_the_force_and_releases():
    free = _bent_sim()
    pushed = _bent_sim(Push(force_n=(0.0, 0.1, 0.0), start_s=0.0, end_s=3.0, ramp_s=0.5))
    free.step_physics(2.5)
    pushed.step_physics(2.5)
    assert pushed.tip_pose()[0][1] - free.tip_pose()[0][1] > 0.005
    free.step_physics(8.0)
    pushed.step_physics(8.0)
    assert abs(pushed.tip_pose()[0][1] - free.tip_pose()[0][1]) < 1e-3


def test_flick_displaces_briefly_then_the_arm_recovers():
    free = _bent_sim()
    flicked = _bent_sim(Flick(impulse_ns=(0.0, 0.003, 0.0), start_s=2.0))
    free.step_physics(2.1)
    flicked.step_physics(2.1)
    assert np.linalg.norm(flicked.tip_pose()[0] - free.tip_pose()[0]) > 0.002
    free.step_physics(6.0)
    flicked.step_physics(6.0)
    assert np.linalg.norm(flicked.tip_pose()[0] - free.tip_pose()[0]) < 1e-3


def test_obstacle_rod_limits_bending_on_its_side():
    free = _bent_sim()
    blocked = _bent_sim(ObstacleRod(point_m=(-0.02, 0.0, 0.07), axis=(0, 1, 0), radius_m=0.004))
    free.step_physics(3.0)
    blocked.step_physics(3.0)
    # chamber 0 bends the arm towards -x; the rod at x = -20 mm stops it
    assert free.tip_pose()[0][0] < -0.028
    assert blocked.tip_pose()[0][0] > free.tip_pose()[0][0] + 0.005


def test_scenarios_selectable_by_name_dict_and_list():
    loads = make_scenario(["tip_mass", {"name": "push", "link": 0}, None])
    assert [type(load).__name__ for load in loads] == ["TipMass", "Push"]
    with pytest.raises(ValueError, match="scenario"):
        make_scenario(42)
    with pytest.raises(ValueError, match="end_s"):
        make_scenario({"name": "push", "start_s": 2.0, "end_s": 1.0})


def test_loads_and_camera_faults_share_one_time_window():
    """Loads and visual faults take the same ``start_s`` / ``end_s`` window, checked alike."""
    from soft_gym._timing import TimeWindow
    from soft_gym.sensors.faults import LowLight

    push = Push(start_s=1.0, end_s=2.0)
    dim = LowLight(start_s=1.0, end_s=2.0)
    assert isinstance(push, TimeWindow) and isinstance(dim, TimeWindow)
    for element in (push, dim, TimeWindow(1.0, 2.0)):
        assert [element.active(t) for t in (0.99, 1.0, 1.99, 2.0)] == [False, True, True, False]
    assert TimeWindow().active(1e9)  # end_s=None: until the episode ends
    # FillingLoad's container is on the tip before it starts filling
    assert FillingLoad(start_s=5.0).active(0.0)
    for build in (lambda: TimeWindow(2.0, 1.0), lambda: Push(start_s=2.0, end_s=1.0),
                  lambda: LowLight(start_s=2.0, end_s=2.0)):
        with pytest.raises(ValueError, match="end_s must be None or > start_s=2.0"):
            build()
    with pytest.raises(ValueError, match="start_s"):
        TimeWindow(-1.0)
    with pytest.raises(ValueError, match="end_s"):
        LowLight(end_s="soon")


def test_obstacle_rod_clearance_from_the_arm():
    """The gap between the rod's surface and the arm's: wang2023's rod 20 mm beside the straight
    arm's axis (radius 4 mm) clears it; one through the axis, along it or too thick is refused
    when attached, naming the parameters that place it."""
    spec = get_preset("wang2023")
    arm_radius = max(segment.outer_radius_m for segment in spec.segments)
    straight = np.array([[0.0, 0.0, 0.0], [0.0, 0.0, spec.length_m]])
    rod = ObstacleRod(point_m=(-0.02, 0.0, 0.07), axis=(0, 1, 0), radius_m=0.004)
    assert rod.clearance_m(straight, arm_radius) == pytest.approx(0.02 - 0.004 - arm_radius)
    beyond = ObstacleRod(point_m=(0.0, 0.0, spec.length_m + 0.03), axis=(1, 0, 0),
                         radius_m=0.01)  # across, 30 mm past the tip
    assert beyond.clearance_m(straight, arm_radius) == pytest.approx(0.03 - 0.01 - arm_radius)
    sim = ArmSimulator(spec)
    try:
        for bad in (ObstacleRod(point_m=(0.0, 0.0, 0.05)),
                    ObstacleRod(point_m=(0.0, 0.0, 0.05), axis=(0, 0, 1)),
                    ObstacleRod(point_m=(-0.02, 0.0, 0.07), radius_m=0.05)):
            with pytest.raises(ValueError, match="point_m, axis and radius_m put the obstacle "
                                                 "rod through the wang2023 arm"):
                sim.add_load(bad)
        sim.add_load(rod)
        sim.reset(settle_s=0.5)
        assert np.isfinite(sim.tip_pose()[0]).all()
    finally:
        sim.close()


@pytest.mark.parametrize("build, name", [
    (lambda: FillingLoad(rate_kg_s=2.0), "rate_kg_s"),
    (lambda: SwayingMass(length_m=0.6), "length_m"),
    (lambda: SwayingMass(radius_m=0.06), "radius_m"),
    (lambda: SwayingMass(radius_m=1e-4), "radius_m"),
    (lambda: Push(link=1.0), "link"),
    (lambda: Push(link="tip"), "link"),
    (lambda: Push(on_tip_cap="yes"), "on_tip_cap"),
    (lambda: Flick(link=True), "link"),
    (lambda: ObstacleRod(radius_m=0.2), "radius_m"),
    (lambda: ObstacleRod(length_m=3.0), "length_m"),
])
def test_loads_refuse_unphysical_or_mistyped_parameters(build, name):
    with pytest.raises(ValueError, match=name):
        build()
