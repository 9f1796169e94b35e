"""Surface strain gauges, three per segment (zhao2021, Section II-A/B, Figs. 1 and 3).

Zhao et al. 2021 set three strain gauges into grooves along each 150 mm segment (Section II-A,
Fig. 1(b)) and show in Fig. 3 that their readings follow the chamber pressures *and* change with a
tip load at the same pressures: a gauge reads the local deformation, whatever causes it. Here each
gauge reads the axial surface strain of the rod at its place (docs/architecture.md,
"Strain gauges"),

    eps(s, psi) = eps_axial(s) - r (kx(s) cos psi + ky(s) sin psi)                         (G1)

(``eps_axial - kappa r cos(psi - phi)`` without ``phi``; the curvature vector points toward the
bending direction, so a gauge on the outside of the bend is stretched), averaged over the gauge
length with Gauss-Legendre points and linear interpolation of the simulator's curvature profile
between backbone vertices (rest arc positions, see :mod:`soft_gym.sensors.fbg`). The reading is

    y = gain * eps + offset + noise                                                        (G2)

Placement: zhao2021 does not give the gauges' angles; by default gauge ``i`` of a segment sits at
the chamber angle ``sigma_i = 2 pi i / 3`` (``angle_offset_rad = 0``), so it is stretched when its
own chamber is pressurised (a lengthened chamber bends the arm away from itself) and sees the three
directions like the chambers; ``angle_offset_rad = pi / 3`` puts the gauges between chambers. The
arc position defaults to the middle of each segment. A gauge is aligned with the arm axis, so twist
(pure shear) does not change its reading. The gauge's own stiffness and the slippage in its TPU
housing are folded into ``gain``.
"""

from __future__ import annotations

import numpy as np
from gymnasium import spaces

from soft_gym._validation import require_non_negative, require_positive
from soft_gym.robots.actuation import CHAMBER_ANGLES_RAD
from soft_gym.robots.spec import ArmSpec
from soft_gym.sensors.base import Sensor
from soft_gym.sensors.fbg import (gauss_points, link_matrix, rest_vertex_arcs, segment_bounds,
                                  surface_bending_matrix)


def _per_gauge(name: str, value: float | np.ndarray, n: int) -> np.ndarray:
    """Broadcast a scalar or per-gauge array to shape (n,), checking it is finite."""
    array = np.asarray(value, dtype=float)
    try:
        array = np.broadcast_to(array, (n,)).astype(float)
    except ValueError as error:
        raise ValueError(f"{name} must be a number or an array of shape ({n},) (one per gauge), "
                         f"got shape {array.shape}") from error
    if not np.all(np.isfinite(array)):
        raise ValueError(f"{name} must be finite, got {array.tolist()}")
    return array


class StrainGauges(Sensor):
    """Three surface strain gauges per segment (zhao2021); reading (G2), float32 (3 n_segments,).

    Gauges are ordered segment by segment, gauge ``i`` of a segment at angle
    ``sigma_i + angle_offset_rad``.

    Args:
        rate_hz: samples per second (zhao2021 reads them with an Arduino; 100 Hz assumed).
        arc_fraction: where along each segment the gauges' centres sit, as a fraction of the
            segment length, in (0, 1); 0.5 = mid-segment. A number or one per segment.
        angle_offset_rad: angle of gauge ``i`` relative to chamber ``i`` (rad); 0 = over the
            chambers, ``pi / 3`` = between them.
        radius_m: gauge distance from the axis (m, > 0); ``None`` uses each segment's outer radius.
        gauge_length_m: active length of a gauge along the arm (m, > 0); 5 mm.
        gain: reading per unit strain (a number or one per gauge); 1 reads strain itself.
        offset: reading at zero strain (a number or one per gauge).
        noise_std: white Gaussian noise of the reading, in reading units (>= 0); 1e-4 (100
            microstrain at unit gain, an assumed bridge + 10-bit ADC resolution).
        n_points: Gauss-Legendre points over the gauge length (1-16).
    """

    def __init__(self, rate_hz: float | None = 100.0,
                 arc_fraction: float | tuple[float, ...] = 0.5, angle_offset_rad: float = 0.0,
                 radius_m: float | None = None, gauge_length_m: float = 5e-3,
                 gain: float | np.ndarray = 1.0, offset: float | np.ndarray = 0.0,
                 noise_std: float = 1e-4, n_points: int = 3) -> None:
        super().__init__("strain", rate_hz)
        fractions = np.atleast_1d(np.asarray(arc_fraction, dtype=float))
        if fractions.ndim != 1 or not np.all(np.isfinite(fractions)) or np.any(
                (fractions <= 0.0) | (fractions >= 1.0)):
            raise ValueError(f"arc_fraction must lie in (0, 1) (a number or one per segment), "
                             f"got {arc_fraction!r}")
        self.arc_fraction = fractions
        if not np.isfinite(angle_offset_rad):
            raise ValueError(f"angle_offset_rad must be a finite number, got {angle_offset_rad!r}")
        self.angle_offset_rad = float(angle_offset_rad)
        self.radius_m = None if radius_m is None else require_positive("radius_m", radius_m)
        self.gauge_length_m = require_positive("gauge_length_m", gauge_length_m)
        self.gain = np.asarray(gain, dtype=float)
        self.offset = np.asarray(offset, dtype=float)
        if not np.all(np.isfinite(self.gain)) or not np.all(np.isfinite(self.offset)):
            raise ValueError(
                f"gain and offset must be finite, got gain={gain!r}, offset={offset!r}")
        self.noise_std = require_non_negative("noise_std", noise_std)
        if not isinstance(n_points, (int, np.integer)) or not 1 <= n_points <= 16:
            raise ValueError(f"n_points must be an integer in [1, 16], got {n_points!r}")
        self.n_points = int(n_points)
        self._spec: ArmSpec | None = None

    def _bind(self, spec: ArmSpec) -> None:
        """Place the gauges on ``spec`` and precompute the linear strain maps."""
        if spec is self._spec:
            return
        n_seg = spec.n_segments
        if self.arc_fraction.shape[0] not in (1, n_seg):
            raise ValueError(f"arc_fraction must be a number or have one value per segment "
                             f"({n_seg}), got {self.arc_fraction.tolist()}")
        fractions = np.broadcast_to(self.arc_fraction, (n_seg,))
        bounds = segment_bounds(spec)
        lengths = np.diff(bounds)
        centers = bounds[:-1] + fractions * lengths
        half = 0.5 * self.gauge_length_m
        if np.any(centers - half < bounds[:-1]) or np.any(centers + half > bounds[1:]):
            raise ValueError(
                f"gauge_length_m={self.gauge_length_m} with arc_fraction="
                f"{self.arc_fraction.tolist()} puts a gauge beyond its segment (lengths "
                f"{lengths.tolist()} m); allowed: each gauge within its segment")
        nodes, weights = gauss_points(self.n_points)
        center_arc = np.repeat(centers, 3)
        arc = center_arc[:, None] + half * nodes[None, :]
        angles = CHAMBER_ANGLES_RAD + self.angle_offset_rad
        psi = np.broadcast_to(np.tile(angles, n_seg)[:, None], arc.shape)
        radii = np.array([self.radius_m if self.radius_m is not None else s.outer_radius_m
                          for s in spec.segments])
        radius = np.broadcast_to(np.repeat(radii, 3)[:, None], arc.shape)
        vertices = rest_vertex_arcs(spec)
        n = 3 * n_seg
        self._gain = _per_gauge("gain", self.gain, n)
        self._offset = _per_gauge("offset", self.offset, n)
        self._bend = surface_bending_matrix(vertices, arc, psi, -radius, weights)
        self._axial = link_matrix(vertices, arc, np.ones_like(arc), weights)
        self.center_arc_m = center_arc
        self.angles_rad = psi[:, 0].copy()
        self.radii_m = radius[:, 0].copy()
        extension = max(max(s.max_extension_ratio - 1.0, 0.4) for s in spec.segments)
        kappa = max(s.max_bend_per_m_rad for s in spec.segments)
        strain = 1.5 * (extension + kappa * float(radii.max()))
        self._low = (self._offset - np.abs(self._gain) * strain - 10.0 * self.noise_std
                     - 1e-6).astype(np.float32)
        self._high = (self._offset + np.abs(self._gain) * strain + 10.0 * self.noise_std
                      + 1e-6).astype(np.float32)
        self._spec = spec

    def strain(self, sim) -> np.ndarray:
        """Noise-free surface strain (G1) at every gauge, float64 (3 n_segments,)."""
        self._bind(sim.spec)
        _, curvature = sim.curvature_profile()
        return self._bend @ curvature.ravel() + self._axial @ sim.link_axial_strains()

    def sample(self, sim) -> np.ndarray:
        """Gauge readings (G2), float32 (3 n_segments,)."""
        strain = self.strain(sim)
        reading = self._gain * strain + self._offset
        if self.noise_std > 0.0:
            reading = reading + self.noise_std * self.rng.standard_normal(reading.shape[0])
        return np.clip(reading, self._low, self._high).astype(np.float32)

    def space(self, sim) -> spaces.Box:
        """Box of the readings, sized from the joint limits (strain up to 1.5x the largest)."""
        self._bind(sim.spec)
        return spaces.Box(self._low, self._high, dtype=np.float32)
