"""Pressure-driven braid twist (``SegmentSpec.braid_twist_m``; zou2022 Section 3: the arm "twists
into complex 3D curves", which constant curvature cannot describe).

References: the torsion moment ``r_t sum_i p_i A_c`` written out here by hand; a torsion joint's
static twist ``M ds / (G J)`` under that moment; symmetry (a straight arm under equal pressures
stays on its axis however it twists); RSES, the constant-curvature shape of the chamber lengths,
against the simulated backbone with and without the twist.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from soft_gym.robots.pneumatics import twist_of_effective_pressure
from soft_gym.robots.presets import get_preset
from soft_gym.robots.spec import SegmentSpec
from soft_gym.papers.zou2022.cc_shape import cc_shape_points
from soft_gym.papers.zou2022.shape_dnn import true_shape_points
from soft_gym.engines.pybullet.simulator import ArmSimulator

ZOU = get_preset("zou2022")


def _without_twist(spec):
    segment = dataclasses.replace(spec.segments[0], braid_twist_m=0.0)
    return dataclasses.replace(spec, segments=(segment,))


def _settled(spec, pressure_bar, seconds=3.0) -> ArmSimulator:
    sim = ArmSimulator(spec)
    sim.reset(settle_s=0.5)
    sim.set_pressures(np.asarray(pressure_bar, dtype=float) * 1e5)
    sim.step_physics(seconds)
    return sim


def test_the_moment_is_the_lever_times_the_summed_chamber_forces():
    segment = ZOU.segments[0]
    pressure = np.array([0.4e5, 1.7e5, 2.9e5])
    expected = segment.braid_twist_m * segment.chamber_area_m2 * pressure.sum()
    assert twist_of_effective_pressure(ZOU, pressure)[0] == pytest.approx(expected, rel=1e-12)
    assert twist_of_effective_pressure(_without_twist(ZOU), pressure)[0] == 0.0
    mirrored = dataclasses.replace(segment, braid_twist_m=-segment.braid_twist_m)
    assert twist_of_effective_pressure(dataclasses.replace(ZOU, segments=(mirrored,)),
                                       pressure)[0] == pytest.approx(-expected, rel=1e-12)


def test_a_twist_lever_needs_torsion_joints_and_must_be_finite():
    base = dict(length_m=0.1, outer_radius_m=0.01, chamber_offset_m=0.005,
                chamber_area_m2=1e-5, youngs_modulus_pa=1e5)
    with pytest.raises(ValueError, match="braid_twist_m"):
        SegmentSpec(**base, braid_twist_m=1e-3)
    with pytest.raises(ValueError, match="braid_twist_m"):
        SegmentSpec(**base, torsion=True, braid_twist_m=float("nan"))


def test_each_link_twists_by_the_static_torsion_of_its_moment():
    segment = ZOU.segments[0]
    sim = _settled(ZOU, [1.0, 1.0, 1.0])
    try:
        moment = segment.braid_twist_m * segment.chamber_area_m2 * 3e5
        expected = moment * segment.link_length_m / segment.torsional_rigidity_nm2
        np.testing.assert_allclose(sim.link_twists(), expected, rtol=0.02)
        # equal pressures: however much it twists, the straight arm stays on its axis
        assert np.abs(sim.backbone()[:, :2]).max() < 1e-4
    finally:
        sim.close()


def test_the_twist_stays_inside_the_torsion_joints_range_at_full_pressure():
    sim = _settled(ZOU, [3.0, 3.0, 3.0])
    try:
        assert np.abs(sim.link_twists()).max() < 0.5
    finally:
        sim.close()


def test_twist_turns_a_bend_into_a_curve_that_constant_curvature_misses():
    """The paper's Table 4 pose (PMA2 at 2.5 bar, the others at 1 bar): RSES fits the untwisted
    arm within a few mm and misses the twisted one by several times more."""
    errors = {}
    for label, spec in (("twisted", ZOU), ("untwisted", _without_twist(ZOU))):
        sim = _settled(spec, [1.0, 2.5, 1.0])
        try:
            rses = cc_shape_points(sim.chamber_lengths(), spec.segments[0].chamber_offset_m)
            truth = true_shape_points(spec, sim.backbone())
            errors[label] = float(np.linalg.norm(rses[-1] - truth[-1]) * 1e3)
        finally:
            sim.close()
    assert errors["untwisted"] < 3.0
    assert errors["twisted"] > 4.0 * errors["untwisted"]
    assert errors["twisted"] > 10.0
