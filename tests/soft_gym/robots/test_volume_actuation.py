"""Volume actuation (ho2018 Section 3.1): chambers as closed gas volumes driven by cylinder
strokes (docs/architecture.md, "Volume actuation")."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from soft_gym.engines import make_simulator
from soft_gym.envs.config import EnvConfig
from soft_gym.robots.pneumatics import VolumeSupply
from soft_gym.papers.ho2018.arm import HO2018, HO2018_CYLINDERS
from soft_gym.robots.presets import PRESETS, volume_actuated
from soft_gym.robots.spec import CylinderSpec

VOLUME_HO2018 = volume_actuated(HO2018)
CYL = HO2018_CYLINDERS
AREA = HO2018.segments[0].chamber_area_m2


def _gas_volume_m3(lengths_m: np.ndarray, strokes_m: np.ndarray) -> np.ndarray:
    """Chamber + cylinder + dead volume from the constants alone (m^3)."""
    return AREA * lengths_m + CYL.bore_area_m2 * (CYL.max_stroke_m - strokes_m) + CYL.dead_volume_m3


@pytest.mark.parametrize("engine", ["pybullet", "mujoco"])
def test_a_load_compressing_a_closed_chamber_raises_its_pressure_by_the_gas_law(engine):
    sim = make_simulator(VOLUME_HO2018, engine)
    strokes = np.full(6, 0.4 * CYL.max_stroke_m)
    sim.reset(settle_s=0.5)
    sim.set_cylinder_strokes(strokes)
    sim.step_physics(3.0)
    lengths_before, pressure_before = sim.chamber_lengths(), sim.pressures_pa
    tip_before = sim.tip_pose()[0]
    # a sideways tip force bends the arm: the chambers on its side shorten, the others lengthen
    sim.apply_tip_force(np.array([0.3, 0.0, 0.0]))
    sim.step_physics(3.0)
    lengths_after, pressure_after = sim.chamber_lengths(), sim.pressures_pa
    shortened = lengths_after < lengths_before - 1e-3  # by over 1 mm
    assert shortened[0]  # chamber 0 faces +x
    # Boyle: (p + p_atm) V = const for each closed chamber, V from the read-out lengths
    expected = ((pressure_before + CYL.atmospheric_pa) * _gas_volume_m3(lengths_before, strokes)
                / _gas_volume_m3(lengths_after, strokes) - CYL.atmospheric_pa)
    assert np.all(pressure_after[shortened] - pressure_before[shortened] > 1e3)
    # the pressure is the gas law's at the lengths of the last 10 ms update: the arm is at rest
    np.testing.assert_allclose(pressure_after, expected, rtol=1e-6)
    # a held pressure yields more to the same load than the closed volume does
    held = make_simulator(HO2018, engine)
    held.reset(pressure_pa=pressure_before, settle_s=3.0)
    held_before = held.tip_pose()[0]
    held.apply_tip_force(np.array([0.3, 0.0, 0.0]))
    held.step_physics(3.0)
    yield_volume = sim.tip_pose()[0][0] - tip_before[0]
    yield_pressure = held.tip_pose()[0][0] - held_before[0]
    assert 0.0 < yield_volume < 0.97 * yield_pressure  # 3.4 % stiffer here


@pytest.mark.parametrize("engine", ["pybullet", "mujoco"])
def test_held_strokes_at_zero_load_match_pressure_mode(engine):
    """The strokes that give pressures p at the pressure-mode equilibrium hold the arm there.

    Both arms settle to one fixed point (the gas gives p at the chamber lengths that p holds);
    after 4 s of settling the tips differ only by what has not yet decayed, well under 0.2 mm
    (a tenth of the engines' 0.5 mm agreement bound)."""
    # the chambers a bend shortens need some stroke to stay at their pressure: none at p_pre
    pressure = np.full(6, 70e3)
    pressure[[0, 4]] = [200e3, 120e3]
    held = make_simulator(HO2018, engine)
    held.reset(pressure_pa=pressure, settle_s=4.0)
    lengths = held.chamber_lengths()
    sim = make_simulator(VOLUME_HO2018, engine)
    # the gas charge: the pre-pressure at the rest lengths with the rest stroke 0
    rest = sim.supply.rest_lengths_m
    charge = (HO2018.p_pre_pa + CYL.atmospheric_pa) * _gas_volume_m3(rest, np.zeros(6))
    cylinder_gas = charge / (pressure + CYL.atmospheric_pa) - AREA * lengths - CYL.dead_volume_m3
    strokes = CYL.max_stroke_m - cylinder_gas / CYL.bore_area_m2
    sim.reset(settle_s=0.5)
    sim.set_cylinder_strokes(strokes)
    sim.step_physics(4.0)
    np.testing.assert_allclose(sim.pressures_pa, pressure, atol=300.0)
    assert np.linalg.norm(sim.tip_pose()[0] - held.tip_pose()[0]) < 2e-4
    # and a reset to those pressures starts at those strokes
    sim.reset(pressure_pa=pressure)
    np.testing.assert_allclose(sim.supply.stroke_for(pressure, sim.chamber_lengths()),
                               sim.cylinder_strokes_m, atol=1e-12)


def test_rest_and_supply_constants():
    supply = VolumeSupply(VOLUME_HO2018, np.full(6, 0.0808))
    np.testing.assert_allclose(supply.pressure_at(np.full(6, 0.0808), np.zeros(6)),
                               HO2018.p_pre_pa, rtol=1e-12)
    strokes = np.linspace(0.0, CYL.max_stroke_m, 6)
    lengths = np.linspace(0.075, 0.09, 6)
    np.testing.assert_allclose(
        supply.stroke_for(supply.pressure_at(lengths, strokes), lengths), strokes, atol=1e-12)
    # the pressure arms' cache keys (their reprs) are unchanged; a volume arm's names its cylinders
    assert all("CylinderSpec" not in repr(spec) for spec in PRESETS.values())
    assert "CylinderSpec(" in repr(VOLUME_HO2018) and VOLUME_HO2018 != HO2018
    assert VOLUME_HO2018.actuation == "volume" and HO2018.actuation == "pressure"
    assert EnvConfig(preset="ho2018", actuation="volume", feedback="ground_truth").arm \
        == VOLUME_HO2018


def test_the_env_drives_strokes_and_reports_pressures():
    from soft_gym.envs.soft_arm_env import SoftArmEnv
    env = SoftArmEnv("ho2018", actuation="volume", feedback="ground_truth", obs=("pressure",),
                     settle_s=0.1, engine="mujoco")
    env.reset(seed=0)
    action = np.array([1.0, -1.0, -1.0, -1.0, -1.0, -1.0], dtype=np.float32)
    for _ in range(20):
        observation, *_ = env.step(action)
    np.testing.assert_allclose(env.sim.cylinder_strokes_m[0], CYL.max_stroke_m, rtol=1e-3)
    np.testing.assert_allclose(observation * HO2018.p_max_pa, env.sim.pressures_pa, rtol=1e-5)
    assert env.sim.pressures_pa[0] > 200e3
    env.close()


def test_bad_input_is_refused_naming_the_parameter():
    sim = make_simulator(VOLUME_HO2018, "mujoco")
    with pytest.raises(ValueError, match=r"strokes_m must lie within .*\[0, max_stroke_m=0.0616\]"):
        sim.set_cylinder_strokes(np.full(6, 0.08))
    with pytest.raises(ValueError, match="strokes_m"):
        sim.set_cylinder_strokes(np.full(6, -1e-3))
    with pytest.raises(ValueError, match="strokes_m"):
        sim.set_cylinder_strokes(np.zeros(5))
    with pytest.raises(ValueError, match="pressures_pa cannot be commanded"):
        sim.set_pressures(HO2018.p_pre_pa)
    with pytest.raises(ValueError, match="pressure_pa=.* outside the cylinders' range"):
        sim.reset(pressure_pa=np.full(6, 430e3))  # all at p_max: a chamber stretched past it
    with pytest.raises(ValueError, match="strokes_m cannot be commanded"):
        make_simulator(HO2018, "mujoco").set_cylinder_strokes(np.zeros(6))
    with pytest.raises(ValueError, match="max_stroke_m=0.08 would put"):
        VolumeSupply(dataclasses.replace(VOLUME_HO2018, cylinders=dataclasses.replace(
            CYL, max_stroke_m=0.08)), np.full(6, 0.0808))
    with pytest.raises(ValueError, match="bore_area_m2"):
        CylinderSpec(bore_area_m2=-1.0, max_stroke_m=0.05)
    with pytest.raises(ValueError, match="dead_volume_m3"):
        CylinderSpec(bore_area_m2=math.pi * 1e-4, max_stroke_m=0.05, dead_volume_m3=-1e-6)
    with pytest.raises(ValueError, match="cylinders must be None or a CylinderSpec"):
        dataclasses.replace(HO2018, cylinders=0.05)
    with pytest.raises(ValueError, match="actuation must be one of"):
        EnvConfig(preset="ho2018", actuation="stroke")
    with pytest.raises(ValueError, match="actuation='volume' needs an arm with cylinders"):
        EnvConfig(preset="wang2023", actuation="volume")
    with pytest.raises(ValueError, match="action_mode='delta' needs pressure actuation"):
        EnvConfig(preset="ho2018", actuation="volume", action_mode="delta")
    with pytest.raises(ValueError, match="actuation='pressure' needs an arm without cylinders"):
        EnvConfig(preset=VOLUME_HO2018)
