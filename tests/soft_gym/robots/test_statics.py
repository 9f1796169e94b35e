"""The static arm (soft_gym.robots.statics) against the settled simulator and beam theory.

References: the PyBullet arm settled under held pressures and a tip mass (the rest shape both
engines reach); a weightless arm under a pure pressure moment lies on a constant-curvature arc of
curvature ``M / (E I)`` (docs/architecture.md, "Pneumatic actuation"); a horizontal cantilever
with a small tip force deflects ``F L^3 / (3 E I)``.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from soft_gym.engines import make_simulator
from soft_gym.robots.pneumatics import chamber_loads, effective_pressure_pa
from soft_gym.papers.wang2023.arm import WANG2023
from soft_gym.papers.zhao2021.arm import ZHAO2021
from soft_gym.papers.zhao2021.frames import paper_pressures_to_chambers
from soft_gym.robots.statics import StaticArm
from soft_gym.procedures.static_reach import closest_reach

TABLE3_BAR = np.array([0.0, 0.5, 0.6, 0.8, 0.7, 0.0])


@pytest.mark.parametrize("tip_mass_kg", [pytest.param(0.0, marks=pytest.mark.slow), 0.05])
def test_rest_shape_matches_the_settled_simulator(tip_mass_kg):
    """zhao2021 under Table III's pressures, free and with 50 g on the tip, settled 12 s in
    PyBullet: every backbone vertex within 0.05 mm of the static arm's."""
    pressures = paper_pressures_to_chambers(TABLE3_BAR * 1e5)
    state = StaticArm(ZHAO2021).equilibrium(pressures, tip_mass_kg=tip_mass_kg)
    sim = make_simulator(ZHAO2021, "pybullet")
    try:
        sim.reset()
        if tip_mass_kg:
            sim.set_tip_payload("test", tip_mass_kg)
        sim.set_pressures(pressures)
        sim.step_physics(12.0)
        gap = np.linalg.norm(sim.backbone() - state.backbone_m, axis=1).max()
    finally:
        sim.close()
    assert gap < 5e-5, gap
    assert state.residual_n < 1e-9


def test_weightless_pressure_bends_on_a_constant_curvature_arc():
    """No gravity, no stiffening, one chamber: the link ends lie on the constant-curvature arc
    whose chords are the links, stretched by the chambers' axial force ``F`` to
    ``ds (1 + F / (E A))``, each turning by ``M ds / (E I)``."""
    segment = dataclasses.replace(WANG2023.segments[0], bending_stiffening=0.0,
                                  axial_stiffening=0.0)
    spec = dataclasses.replace(WANG2023, segments=(segment,))
    arm = StaticArm(spec)
    arm.gravity = np.zeros(3)
    pressures = np.array([0.6, 0.0, 0.0]) * spec.p_max_pa
    state = arm.equilibrium(pressures)
    axial, moment = chamber_loads(spec, pressures)
    link = segment.link_length_m * (1.0 + axial[0] / segment.axial_rigidity_n)
    turn = np.hypot(*moment[0]) / segment.bending_rigidity_nm2 * segment.link_length_m
    # the links are chords of the arc, each turning by M ds / (E I) (rest link length ds)
    radius = link / (2 * np.sin(turn / 2))
    theta = segment.n_links * turn
    # chamber 0 at +x pushes its side longer: the arm bends towards -x
    expected = radius * np.array([-(1 - np.cos(theta)), 0.0, np.sin(theta)])
    assert np.linalg.norm(state.tip_m - expected) < 1e-9, (state.tip_m, expected)


def test_small_tip_force_deflects_a_cantilever_by_beam_theory():
    """Weightless arm, a 1 mN tip force across it: deflection F L^3 / (3 E I) within the discrete
    beam's 4 % (four links, docs in soft_gym.robots.presets)."""
    segment = dataclasses.replace(WANG2023.segments[0], bending_stiffening=0.0)
    spec = dataclasses.replace(WANG2023, segments=(segment,))
    arm = StaticArm(spec)
    arm.gravity = np.zeros(3)
    force = 1e-3
    state = arm.equilibrium(np.zeros(3), tip_force_n=np.array([force, 0.0, 0.0]))
    expected = force * segment.length_m ** 3 / (3 * segment.bending_rigidity_nm2)
    assert state.tip_m[0] == pytest.approx(expected, rel=0.04)


def test_the_equilibrium_is_a_minimum_of_the_energy():
    """The residual is minus the energy's gradient, and nudging the rest shape raises the
    energy."""
    arm = StaticArm(ZHAO2021)
    pressures = paper_pressures_to_chambers(TABLE3_BAR * 1e5)
    state = arm.equilibrium(pressures, tip_mass_kg=0.1)
    load = arm.stiffness0 * (arm.rest_matrix @ effective_pressure_pa(ZHAO2021, pressures))
    force = 0.1 * arm.gravity
    rng = np.random.default_rng(0)
    q = state.q + rng.normal(0, 1e-3, len(state.q))
    gradient = np.array([(arm.energy(q + e, load, force) - arm.energy(q - e, load, force)) / 2e-7
                         for e in np.eye(len(q)) * 1e-7])
    np.testing.assert_allclose(-gradient, arm.residual(q, load, force), rtol=1e-4, atol=1e-6)
    rest_energy = arm.energy(state.q, load, force)
    for _ in range(5):
        assert arm.energy(state.q + rng.normal(0, 1e-3, len(q)), load, force) > rest_energy


def test_bad_input_is_refused():
    arm = StaticArm(ZHAO2021)
    with pytest.raises(ValueError, match="pressures_pa"):
        arm.equilibrium(np.full(6, 2e5))
    with pytest.raises(ValueError, match="tip_mass_kg"):
        arm.equilibrium(np.zeros(6), tip_mass_kg=-0.1)
    with pytest.raises(ValueError, match="point_m"):
        closest_reach(arm, np.array([0.0, np.nan, 0.2]))


def test_closest_reach_finds_a_point_the_arm_was_put_on():
    """A tip the arm rests at under known pressures is found again by the pressure search."""
    arm = StaticArm(ZHAO2021)
    target = arm.equilibrium(np.array([0.6, 0.1, 0.3, 0.5, 0.2, 0.4]) * 1e5,
                             tip_mass_kg=0.05).tip_m
    reach = closest_reach(arm, target, tip_mass_kg=0.05)
    assert reach.distance_m < 2e-4, reach
    np.testing.assert_allclose(arm.equilibrium(reach.pressures_pa, tip_mass_kg=0.05).tip_m,
                               reach.tip_m, atol=1e-9)


@pytest.mark.parametrize("preset", ["wang2023", "zhao2021", "zou2022", "ho2018"])
def test_the_closed_form_gravity_stiffness_matches_finite_differences(preset):
    """``external_jacobian`` against central differences of the generalised force, on random
    bent shapes with a tip force in any direction (every joint kind: bending, torsion on
    zou2022, axial), and symmetric, as the Jacobian of a conservative force is."""
    from soft_gym.robots.presets import get_preset

    arm = StaticArm(get_preset(preset))
    rng = np.random.default_rng(3)
    n, step = arm.chain.n_joints, 1e-6
    for _ in range(3):
        q = rng.normal(0.0, 0.15, n)
        force = 0.1 * arm.gravity + rng.normal(0.0, 0.5, 3)
        expected = np.empty((n, n))
        for j in range(n):
            shift = np.zeros(n)
            shift[j] = step
            expected[:, j] = (arm._external(q + shift, force)[0]
                              - arm._external(q - shift, force)[0]) / (2 * step)
        jacobian = arm.external_jacobian(q, force)
        scale = np.abs(expected).max()
        np.testing.assert_allclose(jacobian, expected, rtol=0, atol=1e-7 * scale)
        np.testing.assert_allclose(jacobian, jacobian.T, rtol=0, atol=1e-12 * scale)
