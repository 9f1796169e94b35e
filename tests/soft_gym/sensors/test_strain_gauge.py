"""The strain gauges of ``soft_gym.sensors.strain_gauge`` on a stand-in simulator: the checks
that mutation testing found missing (docs/mutation_testing.md; the gauges on the simulated arm
against beam references are in test_sensors_strain.py).

Each test pins a documented behaviour of :class:`StrainGauges` that a surviving mutant changed
unnoticed. The gauges read a stand-in simulator (a known curvature profile and known link
strains), so the reference is (G1) of the module docstring written out here: the surface strain
``eps_axial - r (kx cos psi + ky sin psi)`` at the gauge's angle ``sigma_i + offset``, averaged
over the gauge length with Gauss-Legendre points (nodes and weights typed in from the tables),
the curvature interpolated linearly between the rest vertex arcs ``k * link_length``; then the
reading (G2) ``gain * eps + offset + noise`` and the space sized from the joint limits.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from soft_gym.robots import get_preset
from soft_gym.sensors.strain_gauge import StrainGauges
from arm_variants import vertex_arcs

ZHAO = get_preset("zhao2021")    # two segments of 100.9 mm, four links each, r = 17.5 mm
L = ZHAO.segments[0].length_m    # a zhao2021 segment's rest length (m)
WANG = get_preset("wang2023")    # one segment of 90 mm
SIGMA = 2.0 * np.pi * np.arange(3) / 3.0

GAUSS = {  # Gauss-Legendre nodes on [-1, 1] and weights summing to 1 (tables, halved)
    1: ([0.0], [1.0]),
    2: ([-1.0 / math.sqrt(3.0), 1.0 / math.sqrt(3.0)], [0.5, 0.5]),
    3: ([-math.sqrt(0.6), 0.0, math.sqrt(0.6)], [5.0 / 18.0, 8.0 / 18.0, 5.0 / 18.0]),
}


class StandIn:
    """What the gauges read from a simulator: the spec, the vertex curvatures, the link strains."""

    def __init__(self, spec, curvature: np.ndarray, axial: np.ndarray) -> None:
        self.spec = spec
        self.curvature = np.asarray(curvature, dtype=float)
        self.axial = np.asarray(axial, dtype=float)

    def curvature_profile(self):
        return None, self.curvature.copy()

    def link_axial_strains(self) -> np.ndarray:
        return self.axial.copy()


def _profile(spec, seed: int = 0) -> StandIn:
    rng = np.random.default_rng(seed)
    n_links = sum(s.n_links for s in spec.segments)
    return StandIn(spec, rng.uniform(-8.0, 8.0, (n_links + 1, 2)), rng.uniform(-0.05, 0.1, n_links))


def _reference(sim: StandIn, fractions, offset: float, radius: float | None, length: float,
               n_points: int) -> np.ndarray:
    """(G1) averaged over each gauge, written out gauge by gauge."""
    nodes, weights = GAUSS[n_points]
    vertices = vertex_arcs(sim.spec)
    out = []
    start = 0.0
    for k, segment in enumerate(sim.spec.segments):
        centre = start + fractions[k] * segment.length_m
        r = segment.outer_radius_m if radius is None else radius
        for i in range(3):
            psi = SIGMA[i] + offset
            total = 0.0
            for x, w in zip(nodes, weights):
                s = centre + 0.5 * length * x
                kx = np.interp(s, vertices, sim.curvature[:, 0])
                ky = np.interp(s, vertices, sim.curvature[:, 1])
                link = int(np.searchsorted(vertices, s, side="right")) - 1
                total += w * (sim.axial[link] - r * (kx * math.cos(psi) + ky * math.sin(psi)))
            out.append(total)
        start += segment.length_m
    return np.array(out)


def _read(gauges: StrainGauges, sim, seed: int = 0) -> np.ndarray:
    gauges.reset(sim, np.random.default_rng(seed))
    return gauges.read(sim, 0.0)


# ------------------------------------------------------------------------------------------
# (G1): the strain at each gauge
# ------------------------------------------------------------------------------------------


@pytest.mark.smoke
@pytest.mark.parametrize("n_points", [1, 2, 3])
def test_strain_is_the_gauss_average_of_the_surface_strain(n_points: int) -> None:
    """Gauges of 20 mm straddling a vertex (a kink of the profile and a jump of the link
    strain), at different places on the two segments, between the chambers, at a given
    radius."""
    sim = _profile(ZHAO)
    gauges = StrainGauges(arc_fraction=(0.3, 0.62), angle_offset_rad=math.pi / 3, radius_m=0.02,
                          gauge_length_m=0.02, noise_std=0.0, n_points=n_points, rate_hz=None)
    expected = _reference(sim, (0.3, 0.62), math.pi / 3, 0.02, 0.02, n_points)
    np.testing.assert_allclose(gauges.strain(sim), expected, rtol=1e-12, atol=1e-15)


def test_default_gauges_sit_mid_segment_over_the_chambers_at_the_outer_radius() -> None:
    """Defaults: arc fraction 0.5, offset 0, the segment's outer radius, 5 mm, three points."""
    sim = _profile(ZHAO, seed=1)
    gauges = StrainGauges(noise_std=0.0, rate_hz=None)
    expected = _reference(sim, (0.5, 0.5), 0.0, None, 5e-3, 3)
    np.testing.assert_allclose(gauges.strain(sim), expected, rtol=1e-12, atol=1e-15)
    # a wide default gauge over a kink: three points differ from two or four
    wide = StrainGauges(arc_fraction=(0.22, 0.3), gauge_length_m=0.03, noise_std=0.0)
    expected = _reference(sim, (0.22, 0.3), 0.0, None, 0.03, 3)
    np.testing.assert_allclose(wide.strain(sim), expected, rtol=1e-12, atol=1e-15)


def test_placement_reported_per_gauge() -> None:
    """Gauge ``i`` of a segment at ``sigma_i + offset``, centred at the arc fraction, at the
    radius used (segment by segment)."""
    gauges = StrainGauges(arc_fraction=(0.25, 0.75), angle_offset_rad=0.4)
    gauges.space(_profile(ZHAO))
    np.testing.assert_allclose(gauges.angles_rad, np.tile(SIGMA + 0.4, 2), rtol=0, atol=1e-15)
    np.testing.assert_allclose(gauges.center_arc_m,
                               np.repeat([0.25 * L, L + 0.75 * L], 3), rtol=1e-12)
    np.testing.assert_allclose(gauges.radii_m, 0.0175, rtol=1e-12)


def test_outside_of_the_bend_is_stretched() -> None:
    """A constant curvature towards +x: the gauge on the other side (psi = pi, the outside of
    the bend) reads ``+kappa r``, one at psi = 0 reads ``-kappa r``."""
    n = sum(s.n_links for s in WANG.segments)
    sim = StandIn(WANG, np.tile([5.0, 0.0], (n + 1, 1)), np.zeros(n))
    outside = StrainGauges(angle_offset_rad=math.pi, noise_std=0.0)
    inside = StrainGauges(noise_std=0.0)
    assert outside.strain(sim)[0] == pytest.approx(5.0 * 0.01, rel=1e-12)
    assert inside.strain(sim)[0] == pytest.approx(-5.0 * 0.01, rel=1e-12)


# ------------------------------------------------------------------------------------------
# (G2): gain, offset, noise, clipping, space, name, rate
# ------------------------------------------------------------------------------------------


def test_reading_is_gain_times_strain_plus_offset_plus_seeded_noise() -> None:
    sim = _profile(ZHAO, seed=2)
    gain = np.array([1.0, -2.0, 0.5, 3.0, 1.5, -1.0])
    offset = np.array([0.01, -0.02, 0.0, 0.03, 0.005, -0.01])
    clean = StrainGauges(gain=gain, offset=offset, noise_std=0.0, rate_hz=None)
    noisy = StrainGauges(gain=gain, offset=offset, noise_std=3e-3, rate_hz=None)
    strain = _reference(sim, (0.5, 0.5), 0.0, None, 5e-3, 3)
    expected = gain * strain + offset
    np.testing.assert_allclose(_read(clean, sim), expected.astype(np.float32), rtol=1e-6,
                               atol=1e-8)
    noise = 3e-3 * np.random.default_rng(5).standard_normal(6)
    np.testing.assert_allclose(_read(noisy, sim, seed=5), (expected + noise).astype(np.float32),
                               rtol=1e-6, atol=1e-8)


def test_default_noise_is_one_hundred_microstrain() -> None:
    sim = _profile(WANG, seed=3)
    strain = _reference(sim, (0.5,), 0.0, None, 5e-3, 3)
    noise = 1e-4 * np.random.default_rng(9).standard_normal(3)
    np.testing.assert_allclose(_read(StrainGauges(rate_hz=None), sim, seed=9),
                               (strain + noise).astype(np.float32), rtol=1e-6, atol=1e-9)


def test_space_is_sized_from_the_joint_limits() -> None:
    """``offset -+ (|gain| 1.5 (max(ext - 1, 0.4) + kappa_max r_max) + 10 noise + 1e-6)``;
    zhao2021: extension ratio 2.0, 40 rad/m; at r = 20 mm: 1.5 (1.0 + 0.8) = 2.7."""
    gain = np.array([1.0, -2.0, 0.5, 3.0, 1.5, -1.0])
    offset = np.array([0.01, -0.02, 0.0, 0.03, 0.005, -0.01])
    gauges = StrainGauges(gain=gain, offset=offset, radius_m=0.02, noise_std=2e-3)
    space = gauges.space(_profile(ZHAO))
    bound = np.abs(gain) * 2.7 + 10.0 * 2e-3 + 1e-6
    assert space.dtype == np.float32
    np.testing.assert_array_equal(space.low, (offset - bound).astype(np.float32))
    np.testing.assert_array_equal(space.high, (offset + bound).astype(np.float32))
    # wang2023: extension ratio 1.6, 40 rad/m, r = 10 mm, the default noise 1e-4
    wang = StrainGauges().space(_profile(WANG))
    np.testing.assert_array_equal(wang.high, np.float32(1.5 * (0.6 + 40.0 * 0.01) + 1e-3 + 1e-6))


def test_readings_beyond_the_space_are_clipped_to_it() -> None:
    n = sum(s.n_links for s in WANG.segments)
    sim = StandIn(WANG, np.tile([500.0, 0.0], (n + 1, 1)), np.zeros(n))
    gauges = StrainGauges(noise_std=0.0)
    space = gauges.space(sim)
    reading = _read(gauges, sim)
    assert reading[0] == space.low[0] and reading[1] == space.high[1] == reading[2]


def test_name_and_default_rate() -> None:
    """The ``strain`` observation part, sampled at 100 Hz (held in between)."""
    sim = _profile(WANG, seed=4)
    gauges = StrainGauges()
    assert gauges.name == "strain"
    gauges.reset(sim, np.random.default_rng(0))
    first = gauges.read(sim, 0.0)
    np.testing.assert_array_equal(gauges.read(sim, 0.00995), first)
    assert not np.array_equal(gauges.read(sim, 0.01), first)


# ------------------------------------------------------------------------------------------
# configurations refused (and the limits accepted)
# ------------------------------------------------------------------------------------------


@pytest.mark.parametrize("kwargs, message", [
    ({"arc_fraction": 0.0}, r"^arc_fraction must lie in \(0, 1\)"),
    ({"arc_fraction": 1.0}, r"^arc_fraction must lie in \(0, 1\)"),
    ({"arc_fraction": [[0.5], [0.5]]}, r"^arc_fraction must lie in \(0, 1\)"),
    ({"arc_fraction": math.nan}, r"^arc_fraction must lie in \(0, 1\)"),
    ({"angle_offset_rad": math.inf}, r"^angle_offset_rad must be a finite number"),
    ({"radius_m": -0.01}, r"^radius_m must be a finite number > 0"),
    ({"gauge_length_m": 0.0}, r"^gauge_length_m must be a finite number > 0"),
    ({"noise_std": -1e-4}, r"^noise_std must be a finite number >= 0"),
    ({"gain": math.inf}, r"^gain and offset must be finite"),
    ({"offset": [0.0, math.nan, 0.0]}, r"^gain and offset must be finite"),
    ({"n_points": 0}, r"^n_points must be an integer in \[1, 16\]"),
    ({"n_points": 17}, r"^n_points must be an integer in \[1, 16\]"),
    ({"n_points": 2.0}, r"^n_points must be an integer in \[1, 16\]"),
])
def test_bad_configurations_are_refused_by_name(kwargs: dict, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        StrainGauges(**kwargs)


@pytest.mark.parametrize("n_points", [1, 16])
def test_point_counts_at_the_limits_are_accepted(n_points: int) -> None:
    sim = _profile(WANG, seed=6)
    gauges = StrainGauges(n_points=n_points, noise_std=0.0)
    assert np.all(np.isfinite(gauges.strain(sim)))


@pytest.mark.parametrize("spec, kwargs, message", [
    (ZHAO, {"arc_fraction": (0.5, 0.5, 0.5)},
     r"^arc_fraction must be a number or have one value per segment \(2\)"),
    (ZHAO, {"gain": [1.0, 1.0, 1.0]}, r"^gain must be a number or an array of shape \(6,\)"),
    (ZHAO, {"offset": np.zeros(4)}, r"^offset must be a number or an array of shape \(6,\)"),
    (WANG, {"arc_fraction": 0.1, "gauge_length_m": 0.02}, r"^gauge_length_m=0.02"),
    (WANG, {"arc_fraction": 0.9, "gauge_length_m": 0.02}, r"^gauge_length_m=0.02"),
    (ZHAO, {"arc_fraction": (0.5, 0.05), "gauge_length_m": 0.012}, r"^gauge_length_m=0.012"),
])
def test_configurations_that_do_not_fit_the_arm_are_refused(spec, kwargs, message) -> None:
    with pytest.raises(ValueError, match=message):
        StrainGauges(**kwargs).space(_profile(spec))


def test_a_gauge_may_fill_its_segment_exactly() -> None:
    """Each gauge within its segment, the ends included: a gauge as long as the segment."""
    sim = _profile(WANG, seed=7)
    gauges = StrainGauges(arc_fraction=0.5, gauge_length_m=WANG.segments[0].length_m,
                          noise_std=0.0)
    expected = _reference(sim, (0.5,), 0.0, None, WANG.segments[0].length_m, 3)
    np.testing.assert_allclose(gauges.strain(sim), expected, rtol=1e-12, atol=1e-15)
