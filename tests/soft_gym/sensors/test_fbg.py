"""The FBG fiber of ``soft_gym.sensors.fbg`` on a stand-in simulator: the checks that mutation
testing found missing (docs/mutation_testing.md; the fiber on the simulated arm against beam
references is in test_sensors_strain.py).

Each test pins a documented behaviour of the FBG fiber (wang2023) that a surviving mutant changed
unnoticed. The fiber reads a stand-in simulator (known vertex curvatures, link strains and twist
rates, contact forces and link frames), so the references are the module docstring's formulas
written out here: (F1) ``eps_f = eps_z (cos^2 a - nu sin^2 a) + h r tau sin a cos a`` with
``eps_z = eps_axial - r (kx cos psi + ky sin psi)`` per quadrature point, (F2)
``l0 (1 - p_e) t eps + k_T dT + noise`` with the temperature a clipped random walk
``dT += D sqrt(dt) z`` plus the schedule, the contact strain ``c max(0, -F . n)``, the
reading bound from the joint limits, and the extrapolated arc range that a layout's error
reports (fiber per arc ``1 / cos a = sqrt(1 + (2 pi r / P)^2)``).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from soft_gym._quaternion import quaternion_to_matrix
from soft_gym.robots import get_preset
from soft_gym.sensors.fbg import FBGFiber, FBGLayout, fbg_strain
from arm_variants import vertex_arcs

WANG = get_preset("wang2023")    # one segment of 90 mm, four links of 22.5 mm, r = 10 mm
ZHAO = get_preset("zhao2021")    # two segments of 100.9 mm, r = 17.5 mm
L = ZHAO.segments[0].length_m    # a zhao2021 segment's rest length (m)
# zhao2021 with a thinner second segment of another material: the fiber per arc, the radius and
# the Poisson ratio differ between the segments
THIN = dataclasses.replace(ZHAO, segments=(ZHAO.segments[0], dataclasses.replace(
    ZHAO.segments[1], outer_radius_m=0.012, chamber_offset_m=0.007, poisson_ratio=0.45)))


class StandIn:
    """What the fiber reads from a simulator, all set by the test."""

    def __init__(self, spec, curvature=None, axial=None, twist=None, forces=None,
                 frames=None) -> None:
        n = sum(s.n_links for s in spec.segments)
        self.spec = spec
        self.time_s = 0.0
        self.curvature = np.zeros((n + 1, 2)) if curvature is None else np.asarray(curvature)
        self.axial = np.zeros(n) if axial is None else np.asarray(axial)
        self.twist = np.zeros(n) if twist is None else np.asarray(twist)
        self.forces = np.zeros((n, 3)) if forces is None else np.asarray(forces)
        self.frames = frames or {}              # link -> quaternion (x, y, z, w) of its frame

    def curvature_profile(self):
        return None, self.curvature.copy()

    def link_axial_strains(self):
        return self.axial.copy()

    def link_twist_rates(self):
        return self.twist.copy()

    def link_contact_forces(self):
        return self.forces.copy()

    def link_rotations(self, links):
        rest = (0.0, 0.0, 0.0, 1.0)
        return quaternion_to_matrix(np.array([self.frames.get(int(link), rest)
                                              for link in links]))


def _helix(spec, layout: FBGLayout):
    """Gratings of a default-centred layout on a one-segment arm, written out."""
    segment = spec.segments[0]
    r = segment.outer_radius_m if layout.radius_m is None else layout.radius_m
    a = math.atan(2.0 * math.pi * r / layout.pitch_m)
    step = layout.spacing_m * math.cos(a)
    s0 = 0.5 * (segment.length_m - (layout.n_gratings - 1) * step)
    return r, a, s0 + step * np.arange(layout.n_gratings)


def _read(fiber: FBGFiber, sim, seed: int = 0) -> np.ndarray:
    fiber.reset(sim, np.random.default_rng(seed))
    return fiber.read(sim, sim.time_s)


# ---------------------------------------------------------------------------------- (F1)
def _f1_reference(spec, geometry, curvature, axial, twist) -> np.ndarray:
    vertices = vertex_arcs(spec)
    out = []
    for j in range(geometry.n_gratings):
        total = 0.0
        for q, w in enumerate(geometry.weights):
            s, psi = geometry.arc_m[j, q], geometry.psi_rad[j, q]
            r, a = geometry.radius_m[j, q], geometry.helix_angle_rad[j, q]
            nu = geometry.poisson_ratio[j, q]
            kx = np.interp(s, vertices, curvature[:, 0])
            ky = np.interp(s, vertices, curvature[:, 1])
            link = min(int(np.searchsorted(vertices, s, side="right")) - 1, len(axial) - 1)
            eps_z = axial[link] - r * (kx * math.cos(psi) + ky * math.sin(psi))
            total += w * (eps_z * (math.cos(a) ** 2 - nu * math.sin(a) ** 2)
                          + geometry.handedness * r * twist[link] * math.sin(a) * math.cos(a))
        out.append(total)
    return np.array(out)


@pytest.mark.parametrize("right_handed", [True, False])
def test_fbg_strain_is_formula_f1_with_twist(right_handed: bool) -> None:
    rng = np.random.default_rng(1)
    geometry = FBGLayout(right_handed=right_handed).resolve(WANG)
    curvature, axial, twist = rng.normal(0, 5, (5, 2)), rng.normal(0, 0.05, 4), rng.normal(0, 3, 4)
    expected = _f1_reference(WANG, geometry, curvature, axial, twist)
    np.testing.assert_allclose(fbg_strain(vertex_arcs(WANG), curvature, axial, twist, geometry),
                               expected, rtol=1e-12, atol=1e-15)
    twist_only = fbg_strain(vertex_arcs(WANG), np.zeros((5, 2)), np.zeros(4), np.ones(4), geometry)
    r, a, _ = _helix(WANG, FBGLayout())
    np.testing.assert_allclose(twist_only, (1.0 if right_handed else -1.0) * r * math.sin(a)
                               * math.cos(a), rtol=1e-12)


def test_fbg_strain_on_a_single_link() -> None:
    """Two vertices are enough: one link."""
    geometry = FBGLayout(n_gratings=1, spacing_m=0.006, pitch_m=1.0).resolve(WANG)
    vertices = np.array([0.0, 0.09])
    curvature = np.array([[2.0, 0.0], [4.0, 0.0]])
    strain = fbg_strain(vertices, curvature, [0.01], [0.0], geometry)
    a = math.atan(2.0 * math.pi * 0.01 / 1.0)
    eps_z = 0.01 - 0.01 * 3.0 * math.cos(geometry.center_psi_rad[0])   # kx = 3 mid-arm
    # (psi turns by 0.04 rad along the grating: its average is the centre's to ~1e-4)
    assert strain[0] == pytest.approx(eps_z * (math.cos(a) ** 2 - 0.48 * math.sin(a) ** 2),
                                      rel=1e-3)


@pytest.mark.parametrize("args, message", [
    (([0.0], np.zeros((1, 2)), np.zeros(0), np.zeros(0)),
     r"^vertex_arc_m must be a strictly increasing 1-D array of >= 2 arc positions, got \[0.0\]"),
    ((np.zeros((2, 2)) + [[0.0, 0.1]], np.zeros((2, 2)), np.zeros(1), np.zeros(1)),
     r"^vertex_arc_m must be a strictly increasing 1-D array"),
    (([0.0, 0.05, 0.05], np.zeros((3, 2)), np.zeros(2), np.zeros(2)),
     r"^vertex_arc_m must be a strictly increasing 1-D array"),
    (([0.0, 0.09], np.zeros((2, 3)), np.zeros(1), np.zeros(1)),
     r"^curvatures must have shape \(2, 2\), got \(2, 3\)"),
    (([0.0, 0.09], np.zeros((2, 2)), np.zeros(2), np.zeros(1)),
     r"^axial_strains must have shape \(1,\), got \(2,\)"),
    (([0.0, 0.09], np.zeros((2, 2)), np.zeros(1), np.zeros(3)),
     r"^twist_rates must have shape \(1,\), got \(3,\)"),
])
def test_fbg_strain_refuses_bad_profiles_by_name(args, message) -> None:
    geometry = FBGLayout(n_gratings=1).resolve(WANG)
    with pytest.raises(ValueError, match=message):
        fbg_strain(*args, geometry)


# ---------------------------------------------------------------------------------- layout errors
def _span_message(spec, layout: FBGLayout, j: int, fiber_low: float, fiber_high: float,
                  arc_low: float, arc_high: float) -> str:
    return (rf"grating {j} would span fiber \[{fiber_low:.4g}, {fiber_high:.4g}\] m "
            rf"\(arc \[{arc_low:.4g}, {arc_high:.4g}\] m\)")


def _fiber_per_arc(r: float, pitch: float) -> float:
    return math.sqrt(1.0 + (2.0 * math.pi * r / pitch) ** 2)


def test_layout_error_reports_the_arc_range_before_the_start() -> None:
    """A grating centred at the start of the covered part sticks out by half its length along
    the fiber; the arc range continues the first segment's helix before the start."""
    for segments, start in ((None, 0.0), ((1,), L)):
        layout = FBGLayout(n_gratings=2, start_m=start, segments=segments)
        stretch = _fiber_per_arc(0.0175, 0.0165)
        half = 0.003
        message = _span_message(ZHAO, layout, 0, -half, half, start - half / stretch,
                                start + half / stretch)
        with pytest.raises(ValueError, match=message):
            layout.resolve(ZHAO)


def test_layout_error_reports_the_arc_range_beyond_the_end() -> None:
    """Past the end the arc range continues the *last* segment's helix (a thinner one here; a
    pitch of 30 mm keeps the whole fiber under 1 m)."""
    first, last = _fiber_per_arc(0.0175, 0.03), _fiber_per_arc(0.012, 0.03)
    total = L * first + L * last
    assert total < 1.0
    centre = total - 0.021                                   # 21 mm of fiber before the end
    start = L + (centre - L * first) / last
    layout = FBGLayout(n_gratings=3, spacing_m=0.02, start_m=start, pitch_m=0.03)
    j = 1                                                    # the first one past the end
    low, high = centre + 0.02 - 0.003, centre + 0.02 + 0.003
    assert L * first < low < total < high
    arc_low = L + (low - L * first) / last
    arc_high = 2 * L + (high - total) / last
    message = (_span_message(THIN, layout, j, low, high, arc_low, arc_high)
               + rf", beyond the fiber-covered part: fiber \[0, {total:.4g}\] m = arc "
               rf"\[0, {2 * L:.4g}\] m \(segments \(0, 1\)\)")
    with pytest.raises(ValueError, match=message):
        layout.resolve(THIN)
    # and before the start of a thin first segment followed by a thick one
    swapped = dataclasses.replace(THIN, segments=THIN.segments[::-1])
    layout = FBGLayout(n_gratings=2, start_m=0.0, pitch_m=0.03)
    message = _span_message(swapped, layout, 0, -0.003, 0.003, -0.003 / last, 0.003 / last)
    with pytest.raises(ValueError, match=message):
        layout.resolve(swapped)
    # three segments, a grating longer than one: its inner end lies on the middle segment
    three = dataclasses.replace(THIN, segments=THIN.segments + ZHAO.segments[:1])
    total = L * (first + last + first)
    centre = total - 0.1
    start = 2 * L + (centre - L * (first + last)) / first
    layout = FBGLayout(n_gratings=1, grating_length_m=1.0, spacing_m=1.0, start_m=start,
                       pitch_m=0.03)
    low, high = centre - 0.5, centre + 0.5
    assert L * first < low < L * (first + last)
    message = _span_message(three, layout, 0, low, high, L + (low - L * first) / last,
                            3 * L + (high - total) / first)
    with pytest.raises(ValueError, match=message):
        layout.resolve(three)
    # one segment of two: the covered part starts at the second
    layout = FBGLayout(n_gratings=1, start_m=2 * L, segments=(1,))
    with pytest.raises(ValueError, match=rf"^FBG layout does not fit: .* = arc \[{L:.4g}, {2 * L:.4g}\] m "
                                         r"\(segments \(1,\)\)"):
        layout.resolve(ZHAO)


def test_gratings_may_touch_the_ends_of_the_covered_part() -> None:
    """All gratings within the covered range, the ends included (to rounding)."""
    stretch = _fiber_per_arc(0.01, 0.0165)
    touching_start = FBGLayout(n_gratings=1, start_m=0.003 / stretch).resolve(WANG)
    touching_end = FBGLayout(n_gratings=1, start_m=0.09 - 0.003 / stretch).resolve(WANG)
    assert touching_start.arc_m.min() > 0.0 and touching_end.arc_m.max() < 0.09


def test_start_must_lie_on_the_covered_part() -> None:
    with pytest.raises(ValueError, match=r"^start_m must lie on the fiber-covered part "
                                         rf"\[{L:.4g}, {2 * L:.4g}\] m of the arm \(segments \(1,\)\), "
                                         r"got 0.05$"):
        FBGLayout(start_m=0.05, segments=(1,)).resolve(ZHAO)
    # at the very end the start is on the arm, but the grating is not
    with pytest.raises(ValueError, match=r"^FBG layout does not fit"):
        FBGLayout(n_gratings=1, start_m=0.09).resolve(WANG)
    with pytest.raises(ValueError, match=r"^segments must index this arm's 2 segment\(s\) "
                                         r"\(0\.\.1\), got \(0, 1, 2\)"):
        FBGLayout(segments=(0, 1, 2)).resolve(ZHAO)


def test_geometry_takes_radius_and_poisson_ratio_of_the_segment_under_each_point() -> None:
    geometry = FBGLayout(pitch_m=0.03).resolve(THIN)
    on_second = geometry.arc_m >= L
    assert on_second.any() and (~on_second).any()
    np.testing.assert_array_equal(geometry.radius_m, np.where(on_second, 0.012, 0.0175))
    np.testing.assert_array_equal(geometry.poisson_ratio, np.where(on_second, 0.45, 0.48))
    np.testing.assert_allclose(geometry.helix_angle_rad,
                               np.arctan(2.0 * np.pi * geometry.radius_m / 0.03), rtol=1e-12)
    # a given radius is used everywhere
    fixed = FBGLayout(radius_m=0.012, n_gratings=5).resolve(WANG)
    np.testing.assert_array_equal(fixed.radius_m, 0.012)


def test_default_layout_is_centred_on_the_covered_part() -> None:
    """On two equal segments the array is centred at the middle of the arm; on the first
    segment alone, at the middle of that segment."""
    both = FBGLayout(n_gratings=20).resolve(ZHAO)
    assert both.center_arc_m.mean() == pytest.approx(L, rel=1e-12)
    assert both.covered_m == (0.0, 2 * L)
    first = FBGLayout(segments=(0,)).resolve(ZHAO)
    assert first.covered_m == (0.0, L)
    assert first.center_arc_m.mean() == pytest.approx(L / 2, rel=1e-12)


# ---------------------------------------------------------------------------------- layout settings
@pytest.mark.parametrize("kwargs, message", [
    ({"n_gratings": True}, r"^n_gratings must be an integer >= 1, got True"),
    ({"n_gratings": 2.5}, r"^n_gratings must be an integer >= 1, got 2.5"),
    ({"grating_length_m": 0.0}, r"^grating_length_m must be a finite number > 0"),
    ({"spacing_m": 0.0}, r"^spacing_m must be a finite number > 0"),
    ({"pitch_m": -1.0}, r"^pitch_m must be a finite number > 0"),
    ({"radius_m": 0.0}, r"^radius_m must be a finite number > 0"),
    ({"psi0_rad": math.nan}, r"^psi0_rad must be a finite number, got nan"),
    ({"start_m": -0.01}, r"^start_m must be a finite number >= 0"),
    ({"segments": ()}, r"^segments must be None or a non-empty run of consecutive segment "
                       r"indices >= 0 \(e.g. \(0, 1\)\), got \(\)"),
    ({"segments": (-1,)}, r"^segments must be None or a non-empty run"),
    ({"segments": (True,)}, r"^segments must be None or a non-empty run"),
    ({"segments": (0, 2)}, r"^segments must be None or a non-empty run"),
    ({"n_points": 0}, r"^n_points must be an integer in \[1, 16\], got 0"),
    ({"n_points": 17}, r"^n_points must be an integer in \[1, 16\], got 17"),
    ({"n_points": 2.0}, r"^n_points must be an integer in \[1, 16\], got 2.0"),
    ({"n_points": True}, r"^n_points must be an integer in \[1, 16\], got True"),
])
def test_bad_layouts_are_refused_by_name(kwargs, message) -> None:
    with pytest.raises(ValueError, match=message):
        FBGLayout(**kwargs)


def test_layout_limits_are_accepted_and_segments_normalised() -> None:
    for n_points in (1, 16):
        assert FBGLayout(n_points=n_points).resolve(WANG).weights.shape == (n_points,)
    assert FBGLayout(spacing_m=0.006, grating_length_m=0.006).spacing_m == 0.006
    layout = FBGLayout(segments=[np.int64(0)])
    assert layout.segments == (0,) and type(layout.segments[0]) is int
    assert FBGLayout(radius_m=0.012, start_m=0.0).start_m == 0.0


def test_locate_clamps_to_the_first_and_last_link() -> None:
    from soft_gym.sensors.fbg import locate

    vertices = np.array([0.0, 0.02, 0.05, 0.09])
    link, fraction = locate(vertices, np.array([-0.01, 0.0, 0.01, 0.02, 0.035, 0.09, 0.1]))
    np.testing.assert_array_equal(link, [0, 0, 0, 1, 1, 2, 2])
    np.testing.assert_allclose(fraction, [0.0, 0.0, 0.5, 0.0, 0.5, 1.0, 1.0], rtol=1e-12)


# ---------------------------------------------------------------------------------- the sensor
@pytest.mark.parametrize("kwargs, message", [
    ({"layout": "wang2023"}, r"^layout must be an FBGLayout or None, got str$"),
    ({"noise_std_nm": -1e-3}, r"^noise_std_nm must be a finite number >= 0"),
    ({"strain_transfer": 0.0}, r"^strain_transfer must be a finite number > 0"),
    ({"contact_strain_per_n": -0.01}, r"^contact_strain_per_n must be a finite number >= 0"),
    ({"temperature_coefficient_nm_per_c": -0.01},
     r"^temperature_coefficient_nm_per_c must be a finite number >= 0"),
    ({"temperature_drift_c_per_sqrt_s": -1.0},
     r"^temperature_drift_c_per_sqrt_s must be a finite number >= 0"),
    ({"temperature_schedule": 2.0},
     r"^temperature_schedule must be None or a callable time_s -> degC, got 2.0"),
    ({"lambda0_nm": 0.0}, r"^lambda0_nm must be a finite number > 0"),
    ({"photoelastic": 1.0}, r"^photoelastic must be within \[0, 1\), got 1.0"),
])
def test_bad_fiber_settings_are_refused_by_name(kwargs, message) -> None:
    with pytest.raises(ValueError, match=message):
        FBGFiber(**kwargs)


@pytest.mark.smoke
def test_reading_is_f2_of_the_strain_with_seeded_noise() -> None:
    rng = np.random.default_rng(2)
    sim = StandIn(WANG, rng.normal(0, 5, (5, 2)), rng.normal(0, 0.05, 4), rng.normal(0, 3, 4))
    fiber = FBGFiber(strain_transfer=0.01, noise_std_nm=0.002, contact_strain_per_n=0.0,
                     lambda0_nm=1300.0, photoelastic=0.2, rate_hz=None)
    geometry = fiber.geometry(WANG)
    strain = _f1_reference(WANG, geometry, sim.curvature, sim.axial, sim.twist)
    noise = 0.002 * np.random.default_rng(4).standard_normal(17)
    expected = 1300.0 * 0.8 * 0.01 * strain + noise
    np.testing.assert_allclose(_read(fiber, sim, seed=4), expected.astype(np.float32), rtol=1e-6,
                               atol=1e-7)


def test_name_default_rate_and_no_drift_by_default() -> None:
    """The ``fbg`` part, 100 Hz sample and hold, and no temperature change unless asked for."""
    rng = np.random.default_rng(3)
    sim = StandIn(WANG, rng.normal(0, 5, (5, 2)))
    fiber = FBGFiber(noise_std_nm=0.0)
    assert fiber.name == "fbg"
    fiber.reset(sim, np.random.default_rng(0))
    first = fiber.read(sim, 0.0).copy()
    sim.curvature = sim.curvature * 2.0
    np.testing.assert_array_equal(fiber.read(sim, 0.00995), first)       # held
    sim.curvature = sim.curvature / 2.0
    sim.time_s = 5.0
    np.testing.assert_array_equal(fiber.read(sim, 5.0), first)           # no drift after 5 s


def test_space_is_sized_from_the_joint_limits_contact_and_heat() -> None:
    """``1.5 l0 (1 - p_e) t max(|A| (ext + kappa r) + |T| tau) + c 10 N ...`` with the axial and
    twist factors A, T of the helix, ext = max(ratio - 1, 0.4), tau = 0.5 rad per link, plus
    ``k_T 50 degC + 10 noise + 1 pm``."""
    fiber = FBGFiber(strain_transfer=0.01, noise_std_nm=0.002, contact_strain_per_n=0.02,
                     temperature_coefficient_nm_per_c=0.02, lambda0_nm=1300.0, photoelastic=0.2)
    r, a, _ = _helix(WANG, FBGLayout())
    axial = abs(math.cos(a) ** 2 - 0.48 * math.sin(a) ** 2)
    twist = r * math.sin(a) * math.cos(a)
    strain = axial * (0.6 + 40.0 * r) + twist * 0.5 / 0.0225 + 0.02 * 10.0
    bound = 1.5 * 1300.0 * 0.8 * 0.01 * strain + 0.02 * 50.0 + 10.0 * 0.002 + 1e-3
    space = fiber.space(StandIn(WANG))
    assert space.shape == (17,) and space.dtype == np.float32
    np.testing.assert_allclose(space.high, bound, rtol=1e-6)
    np.testing.assert_allclose(space.low, -bound, rtol=1e-6)
    # zhao2021, two segments: extension ratio 2.0 (1.0 counts, above the floor of 0.4)
    zhao = FBGFiber(strain_transfer=0.01, noise_std_nm=0.0, contact_strain_per_n=0.0,
                    temperature_coefficient_nm_per_c=0.0)
    r, a = 0.0175, math.atan(2.0 * math.pi * 0.0175 / 0.0165)
    axial = abs(math.cos(a) ** 2 - 0.48 * math.sin(a) ** 2)
    strain = axial * (1.0 + 40.0 * r) + r * math.sin(a) * math.cos(a) * 0.5 / (L / 4)
    np.testing.assert_allclose(zhao.space(StandIn(ZHAO)).high,
                               1.5 * 1550.0 * 0.79 * 0.01 * strain + 1e-3, rtol=1e-6)


def test_readings_beyond_the_space_are_clipped_to_it() -> None:
    n = 4
    sim = StandIn(WANG, np.tile([0.0, 0.0], (n + 1, 1)), np.full(n, 50.0))
    fiber = FBGFiber(noise_std_nm=0.0)
    high = fiber.space(sim).high
    np.testing.assert_array_equal(_read(fiber, sim), -high)    # factor -0.385: compressed
    sim.axial = np.full(n, -50.0)
    np.testing.assert_array_equal(_read(fiber, sim), high)


# ---------------------------------------------------------------------------------- contact
def test_contact_presses_the_gratings_facing_the_force() -> None:
    """``c max(0, -F . n)`` on the gratings of the loaded link, the normal in that link's
    (current) frame; a force with no zero component, and one of exactly (1, 1, 1) N."""
    fiber = FBGFiber(strain_transfer=1.0, noise_std_nm=0.0, contact_strain_per_n=0.05,
                     rate_hz=None)
    geometry = fiber.geometry(WANG)
    turn = (0.0, 0.0, math.sin(math.pi / 4), math.cos(math.pi / 4))    # 90 deg about z
    for force in ((-0.3, 0.2, 0.1), (1.0, 1.0, 1.0)):
        forces = np.zeros((4, 3))
        forces[2] = force
        sim = StandIn(WANG, forces=forces, frames={2: turn})
        plain = FBGFiber(strain_transfer=1.0, noise_std_nm=0.0, contact_strain_per_n=0.0)
        extra = (_read(fiber, sim).astype(float) - _read(plain, sim)) / (1550.0 * 0.79)
        vertices = vertex_arcs(WANG)
        psi = geometry.center_psi_rad
        normals = np.stack([-np.sin(psi), np.cos(psi), np.zeros_like(psi)], axis=1)  # turned
        on_link = (geometry.center_arc_m >= vertices[2]) & (geometry.center_arc_m < vertices[3])
        expected = np.where(on_link, 0.05 * np.maximum(0.0, -(normals @ np.array(force))), 0.0)
        assert np.count_nonzero(expected) >= 1
        np.testing.assert_allclose(extra, expected, rtol=1e-5, atol=1e-9)


# ---------------------------------------------------------------------------------- temperature
def _walk_reference(times, drift, schedule, seed, n_noise, noise):
    """Temperature changes and noise draws of successive samples, in the fiber's order:
    the walk's draw (when time has passed) before the sample's noise."""
    rng = np.random.default_rng(seed)
    walk, last, changes, noises = 0.0, None, [], []
    for t in times:
        if drift > 0.0:
            if last is None or t < last:
                last = t
            if t - last > 0.0:
                walk = min(50.0, max(-50.0, walk + drift * math.sqrt(t - last)
                                     * rng.standard_normal()))
            last = t
        change = walk + (schedule(t) if schedule else 0.0)
        changes.append(min(50.0, max(-50.0, change)))
        noises.append(noise * rng.standard_normal(n_noise) if noise > 0.0 else np.zeros(n_noise))
    return np.array(changes), np.array(noises)


def _temperature_readings(fiber, sim, times, seed):
    fiber.reset(sim, np.random.default_rng(seed))
    out = []
    for t in times:
        sim.time_s = t
        out.append(fiber.read(sim, t).astype(float))
    return np.array(out)


def test_temperature_random_walk_is_clipped_at_fifty_degrees() -> None:
    """A strong drift (200 degC/sqrt(s)) hits both limits; the walk itself stays clipped, so a
    schedule of -+30 degC moves the reading off the limit."""
    sim = StandIn(WANG)
    times = [0.0, 0.0, 0.3, 1.0, 1.0, 2.5, 3.0, 4.0, 6.0, 7.0, 9.0, 10.0, 12.0, 12.5]

    def schedule(t):
        return 30.0 * math.cos(2.0 * t)

    fiber = FBGFiber(noise_std_nm=0.0, temperature_drift_c_per_sqrt_s=200.0,
                     temperature_schedule=schedule, temperature_coefficient_nm_per_c=0.02,
                     rate_hz=None)
    changes, _ = _walk_reference(times, 200.0, schedule, 5, 17, 0.0)
    readings = _temperature_readings(fiber, sim, times, 5)
    walks = changes - [schedule(t) for t in times]
    assert walks.max() > 45.0 and walks.min() < -45.0               # both limits reached
    np.testing.assert_allclose(readings, 0.02 * np.repeat(changes[:, None], 17, axis=1),
                               rtol=1e-6, atol=1e-6)


def test_temperature_walk_and_noise_share_the_generator_in_order() -> None:
    """Drift on, noise on: per sample, the walk's draw (only when time has passed) then the
    noise; the clock going back starts the walk's timing afresh."""
    rng = np.random.default_rng(6)
    sim = StandIn(WANG, rng.normal(0, 2, (5, 2)))
    times = [0.0, 0.5, 0.5, 2.0, 1.0, 1.5]
    fiber = FBGFiber(noise_std_nm=0.003, temperature_drift_c_per_sqrt_s=1.5,
                     temperature_coefficient_nm_per_c=0.01, strain_transfer=0.01, rate_hz=None)
    strain = _f1_reference(WANG, fiber.geometry(WANG), sim.curvature, sim.axial, sim.twist)
    changes, noises = _walk_reference(times, 1.5, None, 8, 17, 0.003)
    expected = 1550.0 * 0.79 * 0.01 * strain + 0.01 * changes[:, None] + noises
    np.testing.assert_allclose(_temperature_readings(fiber, sim, times, 8), expected,
                               rtol=1e-6, atol=1e-6)


@pytest.mark.parametrize("coefficient, drift", [(0.0, 1.0), (0.01, 0.0)])
def test_no_temperature_draw_when_it_cannot_change_the_reading(coefficient, drift) -> None:
    """With ``k_T = 0`` (or no drift) the noise is the generator's plain sequence."""
    sim = StandIn(WANG)
    times = [0.0, 0.5, 1.0]
    fiber = FBGFiber(noise_std_nm=0.003, temperature_drift_c_per_sqrt_s=drift,
                     temperature_coefficient_nm_per_c=coefficient,
                     temperature_schedule=lambda t: 0.0, rate_hz=None)
    rng = np.random.default_rng(9)
    expected = np.array([0.003 * rng.standard_normal(17) for _ in times])
    np.testing.assert_allclose(_temperature_readings(fiber, sim, times, 9), expected,
                               rtol=1e-6, atol=1e-9)


def test_schedule_adds_to_the_walk_and_the_sum_is_clipped() -> None:
    sim = StandIn(WANG)
    times = [0.0, 1.0, 2.0, 3.0]
    readings = _temperature_readings(
        FBGFiber(noise_std_nm=0.0, temperature_schedule=lambda t: [5.0, 80.0, -80.0, -7.5][int(t)],
                 rate_hz=None), sim, times, 0)
    np.testing.assert_allclose(readings[:, 0], 0.010 * np.array([5.0, 50.0, -50.0, -7.5]),
                               rtol=1e-6)


def test_a_fiber_read_before_any_reset_starts_at_the_reference_temperature() -> None:
    """A new fiber (no ``reset``) has no drift yet and the schedule alone at its first read;
    with zero photo-elastic coefficient the shift per strain is ``l0``."""
    sim = StandIn(WANG, axial=np.full(4, 0.01))
    fiber = FBGFiber(noise_std_nm=0.0, strain_transfer=0.01, photoelastic=0.0,
                     temperature_schedule=lambda t: 3.0, temperature_drift_c_per_sqrt_s=2.0,
                     rate_hz=None)
    geometry = fiber.geometry(WANG)
    strain = _f1_reference(WANG, geometry, sim.curvature, sim.axial, sim.twist)
    np.testing.assert_allclose(fiber.read(sim, 0.0), 1550.0 * 0.01 * strain + 0.010 * 3.0,
                               rtol=1e-6)
