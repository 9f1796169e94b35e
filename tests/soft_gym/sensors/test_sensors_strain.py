"""Checks of the strain-type sensors (FBG fiber, strain gauges), the chamber encoders and the EM
tracker against independent references.

References are computed here from the segment properties only: a pure moment ``M`` gives the
constant curvature ``kappa = M / (E I)`` bending away from the pressurised chamber
(``phi = sigma_i + pi``), the chamber force ``F`` stretches the segment by ``F / (E A)``, and the
helix geometry of wang2023 (Section IV-A) puts grating ``j`` at ``s_j = s_0 + j spacing cos a``,
``psi_j = psi0 + 2 pi s_j / P`` with ``tan a = 2 pi r / P``. A grating's average of
``cos(psi - phi)`` over its length is ``cos(psi_j - phi) sin(h) / h`` with ``h = pi g cos a / P``.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from soft_gym.robots import get_preset
from soft_gym.robots.actuation import CHAMBER_ANGLES_RAD
from soft_gym.scenarios import Push, TipMass
from soft_gym.sensors.em_tracker import EMTracker
from soft_gym.sensors.encoder import ChamberEncoders
from soft_gym.sensors.fbg import FBGFiber, FBGLayout, fbg_strain, rest_vertex_arcs
from soft_gym.sensors.strain_gauge import StrainGauges
from soft_gym.engines.pybullet.simulator import ArmSimulator

from arm_variants import linear, pneumatic_loads_reference, variant  # noqa: F401

SIGMA = CHAMBER_ANGLES_RAD
NM_PER_STRAIN = 1550.0 * (1.0 - 0.21)
SETTLE_S = 3.0


# ------------------------------------------------------------------------------------------
# helpers
# ------------------------------------------------------------------------------------------








def settle(sim: ArmSimulator, pressures, seconds: float = SETTLE_S) -> None:
    """Reset at ``pressures`` (Pa) and let the arm come to rest."""
    sim.reset(pressure_pa=np.asarray(pressures, dtype=float))
    sim.step_physics(seconds)


def one_chamber(spec, chamber: int, pressure_pa: float) -> np.ndarray:
    p = np.zeros(spec.n_chambers)
    p[chamber] = pressure_pa
    return p


def read(sensor, sim, seed: int = 0):
    sensor.reset(sim, np.random.default_rng(seed))
    return sensor.read(sim, sim.time_s)


def analytic_fbg_nm(spec, pressures, layout: FBGLayout) -> np.ndarray:
    """wang2023 helix + (F1)-(F2) of docs/architecture.md, "FBG fiber", on a CC arc (nm)."""
    segment = spec.segments[0]
    axial, moment = pneumatic_loads_reference(spec, pressures)
    rigidity = segment.bending_rigidity_nm2
    kx, ky = moment[0, 1] / rigidity, -moment[0, 0] / rigidity
    kappa, phi = math.hypot(kx, ky), math.atan2(ky, kx)
    eps_axial = axial[0] / segment.axial_rigidity_n
    r = segment.outer_radius_m
    a = math.atan(2.0 * math.pi * r / layout.pitch_m)
    step = layout.spacing_m * math.cos(a)
    s0 = 0.5 * (segment.length_m - (layout.n_gratings - 1) * step)
    s = s0 + step * np.arange(layout.n_gratings)
    psi = layout.psi0_rad + 2.0 * np.pi * s / layout.pitch_m
    h = math.pi * layout.grating_length_m * math.cos(a) / layout.pitch_m
    average = math.sin(h) / h
    factor = math.cos(a) ** 2 - segment.poisson_ratio * math.sin(a) ** 2
    eps = (eps_axial - kappa * r * np.cos(psi - phi) * average) * factor
    return NM_PER_STRAIN * eps


def sinusoid_fit(psi: np.ndarray, y: np.ndarray) -> tuple[float, float, float]:
    """Fit ``y = A cos(psi - theta) + C``; returns (A, theta, R^2)."""
    design = np.stack([np.cos(psi), np.sin(psi), np.ones_like(psi)], axis=1)
    coefficients, *_ = np.linalg.lstsq(design, y, rcond=None)
    fit = design @ coefficients
    r2 = 1.0 - np.sum((y - fit) ** 2) / np.sum((y - y.mean()) ** 2)
    return math.hypot(coefficients[0], coefficients[1]), math.atan2(coefficients[1],
                                                                    coefficients[0]), r2


def wrap(angle: float) -> float:
    return (angle + math.pi) % (2.0 * math.pi) - math.pi


# ------------------------------------------------------------------------------------------
# FBG layout
# ------------------------------------------------------------------------------------------


def test_default_layout_fits_wang2023_body():
    """17 gratings, 20 mm apart along a 16.5 mm-pitch helix at r = 10 mm, fit on 90 mm."""
    spec = get_preset("wang2023")
    geometry = FBGLayout().resolve(spec)
    a = math.atan(2.0 * math.pi * 0.010 / 0.0165)
    assert geometry.n_gratings == 17
    np.testing.assert_allclose(np.diff(geometry.center_arc_m), 0.020 * math.cos(a), rtol=1e-12)
    np.testing.assert_allclose(geometry.center_arc_m.mean(), 0.045, rtol=1e-12)
    assert geometry.arc_m.min() > 0.0 and geometry.arc_m.max() < 0.090
    np.testing.assert_allclose(geometry.center_psi_rad,
                               2.0 * np.pi * geometry.center_arc_m / 0.0165, rtol=1e-12)


def test_layout_on_two_segments_and_one_segment():
    spec = get_preset("zhao2021")
    whole = FBGLayout().resolve(spec)
    second = FBGLayout(segments=(1,)).resolve(spec)
    first_length = spec.segments[0].length_m
    assert whole.covered_m == (0.0, pytest.approx(spec.length_m))
    assert second.arc_m.min() > first_length and second.arc_m.max() < spec.length_m


# ------------------------------------------------------------------------------------------
# FBG readings against the analytic constant-curvature arc
# ------------------------------------------------------------------------------------------


@pytest.mark.parametrize("chamber", [0, 1, 2])
def test_fbg_matches_analytic_arc(make_sim, chamber):
    spec = linear(get_preset("wang2023"))
    sim = make_sim(spec, gravity=False)
    pressures = one_chamber(spec, chamber, 60e3)
    settle(sim, pressures)
    fiber = FBGFiber(strain_transfer=1.0, noise_std_nm=0.0, rate_hz=None)
    measured = read(fiber, sim)
    expected = analytic_fbg_nm(spec, pressures, fiber.layout)
    peak = np.max(np.abs(expected))
    assert peak > 1.0
    np.testing.assert_allclose(measured, expected, atol=0.01 * peak)


def test_pure_function_matches_sensor(make_sim):
    spec = linear(get_preset("wang2023"), torsion=True)
    sim = make_sim(spec, gravity=False)
    settle(sim, [30e3, 70e3, 0.0], 0.3)  # mid-swing: curvature varies along the arm
    fiber = FBGFiber(strain_transfer=1.0, noise_std_nm=0.0, contact_strain_per_n=0.0, rate_hz=None)
    geometry = fiber.geometry(spec)
    _, curvature = sim.curvature_profile()
    direct = fbg_strain(rest_vertex_arcs(spec), curvature, sim.link_axial_strains(),
                        sim.link_twist_rates(), geometry)
    np.testing.assert_allclose(fiber.strain(sim), direct, rtol=1e-10, atol=1e-15)
    np.testing.assert_allclose(read(fiber, sim), NM_PER_STRAIN * direct, rtol=1e-5, atol=1e-5)


def test_outside_of_bend_is_stretched(make_sim):
    """A nearly axial fiber (huge pitch) on the pressurised chamber's side (the outside of the
    bend, the chamber lengthens) reads tension; on the opposite side compression."""
    spec = linear(get_preset("wang2023"))
    sim = make_sim(spec, gravity=False)
    settle(sim, one_chamber(spec, 0, 60e3))
    assert sim.chamber_lengths()[0] > sim.chamber_lengths()[1]
    outside = FBGFiber(FBGLayout(n_gratings=1, pitch_m=100.0, psi0_rad=SIGMA[0]),
                       strain_transfer=1.0, noise_std_nm=0.0)
    inside = FBGFiber(FBGLayout(n_gratings=1, pitch_m=100.0, psi0_rad=SIGMA[0] + np.pi),
                      strain_transfer=1.0, noise_std_nm=0.0)
    assert read(outside, sim)[0] > 1.0
    assert read(inside, sim)[0] < -1.0


@pytest.mark.smoke
def test_fbg_amplitude_linear_in_curvature_and_phase_follows_direction(make_sim):
    """wang2023 Fig. 3: amplitude grows with the bend, the phase follows its direction."""
    spec = linear(get_preset("wang2023"))
    fiber = FBGFiber(strain_transfer=1.0, noise_std_nm=0.0, rate_hz=None)
    psi = fiber.geometry(spec).center_psi_rad
    sim = make_sim(spec, gravity=False)
    kappas, amplitudes, phases = [], [], {}
    for pressure in (20e3, 40e3, 60e3, 80e3, 100e3):
        pressures = one_chamber(spec, 0, pressure)
        settle(sim, pressures)
        amplitude, theta, r2 = sinusoid_fit(psi, read(fiber, sim).astype(float))
        assert r2 > 0.999
        _, moment = pneumatic_loads_reference(spec, pressures)
        kappas.append(np.linalg.norm(moment[0]) / spec.segments[0].bending_rigidity_nm2)
        amplitudes.append(amplitude)
        phases[pressure] = theta
    slope, intercept = np.polyfit(kappas, amplitudes, 1)
    fit = slope * np.array(kappas) + intercept
    r2 = 1.0 - np.sum((amplitudes - fit) ** 2) / np.sum((amplitudes - np.mean(amplitudes)) ** 2)
    assert r2 > 0.999
    assert abs(intercept) < 0.01 * max(amplitudes)
    # same bend, chamber 1 instead of chamber 0: the pattern's phase moves by 120 deg
    settle(sim, one_chamber(spec, 1, 60e3))
    _, theta1, _ = sinusoid_fit(psi, read(fiber, sim).astype(float))
    assert abs(wrap(theta1 - phases[60e3]) - 2.0 * np.pi / 3.0) < math.radians(1.0)
    settle(sim, one_chamber(spec, 2, 60e3))
    _, theta2, _ = sinusoid_fit(psi, read(fiber, sim).astype(float))
    assert abs(wrap(theta2 - phases[60e3]) + 2.0 * np.pi / 3.0) < math.radians(1.0)


@pytest.mark.parametrize("right_handed", [True, False])
def test_twist_adds_the_formula_twist_term(make_sim, right_handed):
    spec = linear(get_preset("wang2023"), torsion=True)
    layout = FBGLayout(right_handed=right_handed)
    pressures = one_chamber(spec, 0, 50e3)
    plain, twisted = make_sim(spec, gravity=False), make_sim(spec, gravity=False)
    for sim in (plain, twisted):
        settle(sim, pressures)
    angle = 0.05  # rad per link
    for joint in twisted.arm.station_torsion_joint:
        twisted.client.resetJointState(twisted.arm.body_id, int(joint), angle)
    fiber = FBGFiber(layout, strain_transfer=1.0, noise_std_nm=0.0, rate_hz=None)
    base, turned = read(fiber, plain).astype(float), read(fiber, twisted).astype(float)
    segment = spec.segments[0]
    r = segment.outer_radius_m
    a = math.atan(2.0 * math.pi * r / layout.pitch_m)
    tau = angle / segment.link_length_m
    expected = NM_PER_STRAIN * (1.0 if right_handed else -1.0) * r * tau * math.sin(a) * math.cos(a)
    assert abs(expected) > 1.0
    np.testing.assert_allclose(turned - base, expected, rtol=1e-4)


def test_local_twist_changes_only_gratings_on_that_link(make_sim):
    spec = linear(get_preset("wang2023"), torsion=True)
    plain, twisted = make_sim(spec, gravity=False), make_sim(spec, gravity=False)
    for sim in (plain, twisted):
        settle(sim, one_chamber(spec, 0, 50e3))
    twisted.client.resetJointState(twisted.arm.body_id, int(twisted.arm.station_torsion_joint[2]),
                                   0.05)
    fiber = FBGFiber(strain_transfer=1.0, noise_std_nm=0.0, rate_hz=None)
    change = np.abs(read(fiber, twisted) - read(fiber, plain))
    geometry = fiber.geometry(spec)
    edges = rest_vertex_arcs(spec)
    on_link = np.all((geometry.arc_m > edges[2]) & (geometry.arc_m < edges[3]), axis=1)
    off_link = np.all((geometry.arc_m < edges[2]) | (geometry.arc_m > edges[3]), axis=1)
    assert on_link.sum() >= 3
    assert np.all(change[on_link] > 1.0)
    assert np.all(change[off_link] < 1e-4)


# ------------------------------------------------------------------------------------------
# loads and contact
# ------------------------------------------------------------------------------------------


def test_strain_gauges_match_surface_strain(make_sim):
    spec = linear(get_preset("wang2023"))
    sim = make_sim(spec, gravity=False)
    pressures = one_chamber(spec, 0, 60e3)
    settle(sim, pressures)
    gauges = StrainGauges(noise_std=0.0, rate_hz=None)
    segment = spec.segments[0]
    axial, moment = pneumatic_loads_reference(spec, pressures)
    kappa = np.linalg.norm(moment[0]) / segment.bending_rigidity_nm2
    expected = axial[0] / segment.axial_rigidity_n - kappa * segment.outer_radius_m * np.cos(
        SIGMA - np.pi)
    np.testing.assert_allclose(read(gauges, sim), expected, atol=0.01 * np.max(np.abs(expected)))
    assert read(gauges, sim)[0] > 0  # the pressurised chamber's side is stretched


def test_tip_load_changes_strain_gauges_at_equal_pressures(make_sim):
    """zhao2021 Fig. 3: at the same pressures a tip load gives different gauge readings."""
    spec = get_preset("zhao2021")
    pressures = np.array([40e3, 40e3, 0.0, 0.0, 0.0, 0.0])  # two chambers, as in Fig. 3
    free, loaded = make_sim(spec, gravity=True), make_sim(spec, gravity=True)
    loaded.add_load(TipMass(mass_kg=0.1))
    for sim in (free, loaded):
        settle(sim, pressures, 4.0)
    gauges = StrainGauges(noise_std=0.0, rate_hz=None)
    without, with_load = read(gauges, free), read(gauges, loaded)
    assert without.shape == (6,)
    assert np.max(np.abs(with_load - without)) > 50 * 1e-4  # 50x the default noise
    # and the pressures move them too (Fig. 3: readings follow P1, P2)
    settle(free, 0.5 * pressures, 4.0)
    assert np.max(np.abs(read(gauges, free) - without)) > 50 * 1e-4


def _tip_deflection_x(sim) -> float:
    return float(sim.tip_pose()[0][0])


def test_push_on_fiber_disturbs_fbg_more_than_tip_force(make_sim):
    """wang2023 Table III: pushing the fiber-covered body disturbs the FBG readings more than
    pushing the tip cap. The fiber covers the whole body here, so the fair comparison is a 0.2 N
    push on link 1 against a tip force giving the same tip deflection; the disturbance is the
    reading minus the reading of a contact-free fiber on the same shape."""
    spec = linear(get_preset("wang2023"))
    pushed = make_sim(spec, gravity=False)
    pushed.add_load(Push(force_n=(0.2, 0.0, 0.0), link=1, start_s=0.0, end_s=None, ramp_s=0.1))
    settle(pushed, np.zeros(3))
    target = _tip_deflection_x(pushed)
    assert target > 0.005

    tipped = make_sim(spec, gravity=False)
    tip_force = 0.04
    for _ in range(3):  # secant iterations on the (mildly nonlinear) deflection
        settle(tipped, np.zeros(3), 0.0)
        tipped.apply_tip_force([tip_force, 0.0, 0.0])
        tipped.step_physics(SETTLE_S)
        tip_force *= target / _tip_deflection_x(tipped)
    assert _tip_deflection_x(tipped) == pytest.approx(target, rel=0.02)

    fiber = FBGFiber(strain_transfer=1.0, noise_std_nm=0.0, rate_hz=None)
    shape_only = FBGFiber(strain_transfer=1.0, noise_std_nm=0.0, rate_hz=None, contact_strain_per_n=0.0)
    push_disturbance = read(fiber, pushed) - read(shape_only, pushed)
    tip_disturbance = read(fiber, tipped) - read(shape_only, tipped)
    assert np.max(np.abs(push_disturbance)) > 3.0 * np.max(np.abs(tip_disturbance))
    # the push acts locally: only gratings on link 1 are disturbed
    geometry = fiber.geometry(spec)
    edges = rest_vertex_arcs(spec)
    on_link = (geometry.center_arc_m >= edges[1]) & (geometry.center_arc_m < edges[2])
    assert np.all(push_disturbance[~on_link] == 0.0)
    assert np.count_nonzero(push_disturbance[on_link]) >= 1
    # 0.2 N on a grating facing the push: c * 0.2 N of strain, i.e. a few degrees of bending
    assert np.max(push_disturbance) <= NM_PER_STRAIN * 0.011 * 0.2 * 1.0001
    assert np.max(push_disturbance) > 0.5 * NM_PER_STRAIN * 0.011 * 0.2


# ------------------------------------------------------------------------------------------
# noise, rates, seeds, temperature
# ------------------------------------------------------------------------------------------


def test_fbg_noise_std_is_one_picometre(make_sim):
    spec = get_preset("wang2023")
    sim = make_sim(spec, gravity=False)
    settle(sim, one_chamber(spec, 0, 40e3), 1.0)
    fiber = FBGFiber(strain_transfer=1.0, rate_hz=None)
    truth = FBGFiber(strain_transfer=1.0, noise_std_nm=0.0, rate_hz=None)
    fiber.reset(sim, np.random.default_rng(3))
    clean = read(truth, sim).astype(float)
    errors = np.array([fiber.read(sim, 0.0) - clean for _ in range(600)])
    assert errors.std() == pytest.approx(1e-3, rel=0.05)
    assert abs(errors.mean()) < 1e-4


def test_em_tracker_noise(make_sim):
    spec = get_preset("wang2023")
    sim = make_sim(spec, gravity=False)
    settle(sim, one_chamber(spec, 1, 60e3), 1.0)
    position, quaternion = sim.tip_pose()
    tracker = EMTracker(rate_hz=None)
    tracker.reset(sim, np.random.default_rng(11))
    readings = np.array([tracker.read(sim, 0.0) for _ in range(3000)], dtype=float)
    assert readings.shape == (3000, 7)
    position_error = readings[:, :3] - position
    np.testing.assert_allclose(position_error.std(axis=0), 0.8e-3, rtol=0.06)
    np.testing.assert_allclose(np.linalg.norm(readings[:, 3:], axis=1), 1.0, atol=1e-6)
    # error rotation q_meas * q_true^-1 as a rotation vector, per axis
    x, y, z, w = quaternion
    qx, qy, qz, qw = readings[:, 3:].T
    ex = -qw * x + qx * w - qy * z + qz * y
    ey = -qw * y + qx * z + qy * w - qz * x
    ez = -qw * z - qx * y + qy * x + qz * w
    ew = qw * w + qx * x + qy * y + qz * z
    sign = np.sign(ew)
    vector = 2.0 * np.stack([ex, ey, ez], axis=1) * sign[:, None]
    np.testing.assert_allclose(np.degrees(vector.std(axis=0)), 0.7, rtol=0.06)
    noiseless = EMTracker(position_noise_m=0.0, orientation_noise_deg=0.0)
    clean = read(noiseless, sim)
    np.testing.assert_allclose(clean[:3], position, atol=1e-6)
    np.testing.assert_allclose(np.abs(clean[3:] @ quaternion), 1.0, atol=1e-6)


@pytest.mark.parametrize("make_sensor", [
    lambda: FBGFiber(rate_hz=40.0), lambda: StrainGauges(rate_hz=40.0),
    lambda: ChamberEncoders(rate_hz=40.0, resolution_m=1e-6), lambda: EMTracker(rate_hz=40.0)])
def test_sample_and_hold_seed_and_space(make_sim, make_sensor):
    spec = get_preset("wang2023")
    sim = make_sim(spec, gravity=False)
    settle(sim, one_chamber(spec, 2, 50e3), 0.5)
    sensor = make_sensor()
    sensor.reset(sim, np.random.default_rng(7))
    first = sensor.read(sim, 0.0)
    held = sensor.read(sim, 0.02)           # before the next 40 Hz sample: held
    fresh = sensor.read(sim, 0.025)         # due: a new noisy sample
    assert first.dtype == np.float32
    np.testing.assert_array_equal(first, held)
    assert not np.array_equal(first, fresh)
    again = make_sensor()
    again.reset(sim, np.random.default_rng(7))
    np.testing.assert_array_equal(again.read(sim, 0.0), first)
    space = sensor.space(sim)
    assert space.dtype == np.float32 and np.all(np.isfinite(space.low))
    assert np.all(np.isfinite(space.high)) and space.contains(first)


def test_temperature_schedule_and_drift(make_sim):
    spec = get_preset("wang2023")
    sim = make_sim(spec, gravity=False)
    settle(sim, np.zeros(3), 0.2)
    plain = read(FBGFiber(strain_transfer=1.0, noise_std_nm=0.0), sim).astype(float)
    heated = read(FBGFiber(strain_transfer=1.0, noise_std_nm=0.0, temperature_schedule=lambda t: 2.0), sim)
    np.testing.assert_allclose(heated - plain, 2.0 * 0.010, atol=1e-5)
    drifting = FBGFiber(strain_transfer=1.0, noise_std_nm=0.0, rate_hz=None, temperature_drift_c_per_sqrt_s=1.0)
    drifting.reset(sim, np.random.default_rng(0))
    start = drifting.read(sim, sim.time_s).astype(float)
    np.testing.assert_allclose(start, plain, atol=1e-5)  # no time has passed
    sim.step_physics(1.0)
    moved = drifting.read(sim, sim.time_s).astype(float) - read(FBGFiber(strain_transfer=1.0, noise_std_nm=0.0), sim)
    assert np.ptp(moved) < 1e-4 and abs(moved[0]) > 1e-4  # a common-mode shift


def test_encoders_read_quantised_chamber_lengths(make_sim):
    spec = get_preset("zou2022")
    sim = make_sim(spec, gravity=False)
    settle(sim, [100e3, 0.0, 50e3], 1.0)
    encoder = ChamberEncoders(rate_hz=None, resolution_m=1e-4, noise_std_m=0.0)
    reading = read(encoder, sim).astype(float)
    truth = sim.chamber_lengths()
    np.testing.assert_allclose(reading, truth, atol=0.5e-4 + 1e-7)
    np.testing.assert_allclose(reading / 1e-4, np.round(reading / 1e-4), atol=1e-3)
    noisy = ChamberEncoders(rate_hz=None, resolution_m=0.0, noise_std_m=1e-3)
    noisy.reset(sim, np.random.default_rng(1))
    errors = np.array([noisy.read(sim, 0.0) - truth for _ in range(500)])
    assert errors.std() == pytest.approx(1e-3, rel=0.08)


# ------------------------------------------------------------------------------------------
# bad configurations
# ------------------------------------------------------------------------------------------


@pytest.mark.parametrize("build, name", [
    (lambda: FBGLayout(n_gratings=0), "n_gratings"),
    (lambda: FBGLayout(grating_length_m=0.0), "grating_length_m"),
    (lambda: FBGLayout(spacing_m=-0.02), "spacing_m"),
    (lambda: FBGLayout(spacing_m=0.004), "spacing_m"),
    (lambda: FBGLayout(pitch_m=0.0), "pitch_m"),
    (lambda: FBGLayout(radius_m=-0.01), "radius_m"),
    (lambda: FBGLayout(segments=(0, 2)), "segments"),
    (lambda: FBGLayout(start_m=0.05).resolve(get_preset("wang2023")), "start_m"),
    (lambda: FBGLayout(start_m=0.2).resolve(get_preset("wang2023")), "start_m"),
    (lambda: FBGLayout(n_gratings=30).resolve(get_preset("wang2023")), "n_gratings"),
    (lambda: FBGLayout(segments=(1,)).resolve(get_preset("wang2023")), "segments"),
    (lambda: FBGFiber(FBGLayout(n_gratings=30), spec=get_preset("wang2023")), "n_gratings"),
    (lambda: FBGFiber(strain_transfer=1.0, noise_std_nm=-1e-3), "noise_std_nm"),
    (lambda: FBGFiber(rate_hz=-10.0), "rate_hz"),
    (lambda: FBGFiber(rate_hz=0.0), "rate_hz"),
    (lambda: FBGFiber(contact_strain_per_n=-1.0), "contact_strain_per_n"),
    (lambda: FBGFiber(strain_transfer=0.0), "strain_transfer"),
    (lambda: FBGFiber(photoelastic=1.5), "photoelastic"),
    (lambda: StrainGauges(noise_std=-1.0), "noise_std"),
    (lambda: StrainGauges(arc_fraction=1.2), "arc_fraction"),
    (lambda: StrainGauges(rate_hz=-1.0), "rate_hz"),
    (lambda: ChamberEncoders(resolution_m=-1e-4), "resolution_m"),
    (lambda: ChamberEncoders(noise_std_m=-1e-4), "noise_std_m"),
    (lambda: EMTracker(position_noise_m=-1e-3), "position_noise_m"),
    (lambda: EMTracker(orientation_noise_deg=-0.7), "orientation_noise_deg"),
    (lambda: EMTracker(rate_hz=-40.0), "rate_hz"),
])
def test_bad_configurations_raise(build, name):
    with pytest.raises(ValueError, match=name):
        build()


def test_gauge_beyond_segment_raises(make_sim):
    sim = make_sim(get_preset("wang2023"), gravity=False)
    gauges = StrainGauges(arc_fraction=0.99, gauge_length_m=0.01)
    with pytest.raises(ValueError, match="gauge_length_m"):
        gauges.space(sim)


def test_default_strain_transfer_gives_the_papers_wavelength_range(make_sim):
    """wang2023 Appendix: 0-0.158 nm over the spiral exploration; full one-chamber bending here
    should stay in that sub-nanometre range, far above the 1 pm noise."""
    spec = get_preset("wang2023")
    sim = make_sim(spec, gravity=False)
    settle(sim, one_chamber(spec, 0, spec.p_max_pa[0]))
    peak = np.abs(read(FBGFiber(noise_std_nm=0.0), sim)).max()
    assert 0.05 < peak < 0.5
