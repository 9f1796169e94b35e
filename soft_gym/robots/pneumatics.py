"""Pneumatic actuation: first-order pressure lag and the pressure -> force/moment map.

docs/architecture.md, "Pneumatic actuation": chamber ``i`` at gauge pressure ``p_i`` over area
``A_c`` pushes
``F_i = p_i A_c``; its segment receives the axial force ``sum_i F_i`` and the bending moment
``sum_i F_i d (sin sigma_i, -cos sigma_i)`` about the local x and y axes. Equal pressures give no
moment, so pre-pressure only lengthens the arm.

A chamber whose bore widens with pressure (:attr:`soft_gym.robots.spec.SegmentSpec.chamber_area_growth`
``g`` and ``chamber_area_growth_exponent`` ``n``, zhao2021's thread-wrapped chambers) pushes
``F_i = p_i A_c (1 + g (p_i / p_max)^n)``: the map stays linear in the *effective pressure*
``p_i (1 + g (p_i / p_max)^n)`` (:func:`effective_pressure_pa`, :class:`BoreGrowth`), which is
what the simulators feed their linear load matrix.
"""

from __future__ import annotations

import math
import warnings
from typing import Callable

import numpy as np

from soft_gym._validation import as_finite_array, require_positive
from soft_gym.robots.actuation import CHAMBER_ANGLES_RAD
from soft_gym.robots.spec import ArmSpec


def check_pressures(spec: ArmSpec, pressure_pa: np.ndarray) -> np.ndarray:
    """Chamber pressures (Pa) checked: shape (n_chambers,), finite, within ``[0, p_max]``."""
    command = as_finite_array("pressures_pa", pressure_pa, shape=(spec.n_chambers,))
    if (command < 0).any() or (command > spec.p_max_pa * (1 + 1e-9)).any():
        raise ValueError(
            f"pressures_pa must lie within [0, p_max_pa={spec.p_max_pa.tolist()}], "
            f"got {command.tolist()}")
    return np.minimum(command, spec.p_max_pa)


class PneumaticSupply:
    """Chamber pressures following their commands with a first-order lag, within [0, p_max].

    The lag is integrated exactly over each update interval:
    ``p <- p + (p_cmd - p) (1 - exp(-dt / tau))``.
    """

    def __init__(self, spec: ArmSpec) -> None:
        self.spec = spec
        self.p_max_pa = spec.p_max_pa
        self.pressure_pa = spec.p_pre_pa.copy()
        self.command_pa = spec.p_pre_pa.copy()
        self.time_constant_s = spec.pneumatic_time_constant_s

    def reset(self, pressure_pa: np.ndarray | None = None) -> None:
        """Set pressures and commands to ``pressure_pa`` (default: the pre-pressure)."""
        start = self.spec.p_pre_pa if pressure_pa is None else self.check_command(pressure_pa)
        self.pressure_pa = np.array(start, dtype=float)
        self.command_pa = self.pressure_pa.copy()

    def check_command(self, pressure_pa: np.ndarray) -> np.ndarray:
        """Validate a pressure command: shape (n_chambers,), finite, within [0, p_max]."""
        return check_pressures(self.spec, pressure_pa)

    def set_time_constant_scale(self, scale: float) -> None:
        """Make the lag ``scale`` times the arm's nominal time constant (domain randomisation)."""
        scale = require_positive("scale", scale)
        self.time_constant_s = self.spec.pneumatic_time_constant_s * scale

    def command(self, pressure_pa: np.ndarray) -> None:
        """Set the commanded pressures (Pa)."""
        self.command_pa = self.check_command(pressure_pa)

    def advance(self, dt_s: float) -> np.ndarray:
        """Advance the lag by ``dt_s`` seconds and return the chamber pressures (Pa)."""
        alpha = 1.0 - math.exp(-dt_s / self.time_constant_s)
        self.pressure_pa = self.pressure_pa + (self.command_pa - self.pressure_pa) * alpha
        return self.pressure_pa

    def advance_many(self, dt_s: float, updates: int) -> np.ndarray:
        """:meth:`advance` ``updates`` times; returns the pressures after each (Pa,
        (updates, n_chambers)), the same bits as the calls one by one."""
        pressures = np.empty((updates, len(self.pressure_pa)))
        for k in range(updates):
            pressures[k] = self.advance(dt_s)
        return pressures


def chamber_area_growth(spec: ArmSpec) -> np.ndarray:
    """Per-chamber area growth ``g`` (dimensionless), shape (n_chambers,)."""
    return np.repeat([segment.chamber_area_growth for segment in spec.segments], 3).astype(float)


class BoreGrowth:
    """The chambers' bores widening with pressure: ``A_c(p) = A_c (1 + g (p / p_max)^n)`` per
    chamber (:attr:`~soft_gym.robots.spec.SegmentSpec.chamber_area_growth` ``g``,
    :attr:`~soft_gym.robots.spec.SegmentSpec.chamber_area_growth_exponent` ``n``), looked up once
    for a simulator's every actuation update.

    Attributes:
        grows: whether any bore grows (else the effective pressure is the pressure).
    """

    def __init__(self, spec: ArmSpec) -> None:
        self.growth = chamber_area_growth(spec)
        exponent = np.repeat([s.chamber_area_growth_exponent for s in spec.segments], 3)
        self.exponent = exponent.astype(float)
        self._linear = bool(np.all(self.exponent == 1.0))
        self.p_max_pa = spec.p_max_pa
        self.grows = bool(np.any(self.growth))

    def effective(self, pressure_pa: np.ndarray) -> np.ndarray:
        """``p (1 + g (p / p_max)^n)`` (Pa) of pressures ``(..., n_chambers)`` (Pa)."""
        pressure = np.asarray(pressure_pa, dtype=float)
        if not self.grows:
            return pressure
        if self._linear:  # the exponent-1 law, evaluated as it always was (bit for bit)
            return pressure * (1.0 + self.growth * pressure / self.p_max_pa)
        return pressure * (1.0 + self.growth * (pressure / self.p_max_pa) ** self.exponent)

    def key(self) -> bytes:
        """Bytes equal for equal growth laws (arms that can share an actuation update)."""
        return self.growth.tobytes() + self.exponent.tobytes()


def effective_pressure_pa(spec: ArmSpec, pressure_pa: np.ndarray) -> np.ndarray:
    """Chamber pressures (Pa) scaled by their bores' growth: ``p (1 + g (p / p_max)^n)`` (Pa).

    ``p A_c`` of the effective pressure is the chamber's force ``p A_c(p)`` with
    ``A_c(p) = A_c (1 + g (p / p_max)^n)`` (:class:`BoreGrowth`); equal to ``pressure_pa`` where
    ``g = 0``. Works on ``(..., n_chambers)`` arrays.
    """
    return BoreGrowth(spec).effective(pressure_pa)


def chamber_loads(spec: ArmSpec, pressure_pa: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per-segment axial force (N) and bending moment (N m) from chamber pressures.

    Args:
        spec: the arm.
        pressure_pa: chamber gauge pressures, shape (n_chambers,).

    Returns:
        ``(axial_force_n, moment_nm)`` with shapes (n_segments,) and (n_segments, 2); the moment
        is about the segment's local x and y axes (docs/architecture.md, "Pneumatic actuation").
        A growing bore (``chamber_area_growth``) enters through :func:`effective_pressure_pa`.
    """
    return loads_of_effective_pressure(spec, effective_pressure_pa(spec, pressure_pa))


def loads_of_effective_pressure(spec: ArmSpec, effective_pa: np.ndarray
                                ) -> tuple[np.ndarray, np.ndarray]:
    """:func:`chamber_loads` of already effective pressures (:func:`effective_pressure_pa`):
    linear in ``effective_pa``, the simulator's load matrix."""
    pressure = np.asarray(effective_pa, dtype=float).reshape(spec.n_segments, 3)
    area = np.array([segment.chamber_area_m2 for segment in spec.segments])[:, None]
    offset = spec.chamber_offset_m[:, None]
    sigma = CHAMBER_ANGLES_RAD
    force = pressure * area
    axial = force.sum(axis=1)
    moment = np.stack([(force * offset * np.sin(sigma)).sum(axis=1),
                       (-force * offset * np.cos(sigma)).sum(axis=1)], axis=1)
    return axial, moment


def twist_of_effective_pressure(spec: ArmSpec, effective_pa: np.ndarray) -> np.ndarray:
    """Torsion moment (N m) of every segment, (n_segments,), of already effective pressures:
    ``sum_i r_t p_i A_c`` with ``r_t`` = :attr:`~soft_gym.robots.spec.SegmentSpec.braid_twist_m`
    (zero for balanced braids); linear in ``effective_pa``."""
    pressure = np.asarray(effective_pa, dtype=float).reshape(spec.n_segments, 3)
    lever = np.array([segment.braid_twist_m * segment.chamber_area_m2
                      for segment in spec.segments])
    return lever * pressure.sum(axis=1)


class VolumeSupply:
    """Chambers driven by cylinder strokes (ho2018 Section 3.1), each a closed gas volume.

    Chamber ``i``, its cylinder and the dead volume hold a fixed amount of gas at one temperature
    (isothermal ideal gas; docs/architecture.md, "Volume actuation"):

        (p_i + p_atm) (A_c L_i + A_b (S - s_i) + V_d) = K_i
        K_i = (p_pre + p_atm) (A_c L_rest_i + A_b S + V_d)

    with ``p_i`` the gauge pressure (Pa), ``L_i`` the chamber's current length (m, from the arm's
    deformation), ``s_i`` the piston's stroke (m, 0 at rest), ``A_b``, ``S``, ``V_d`` and
    ``p_atm`` from :class:`~soft_gym.robots.spec.CylinderSpec` and ``L_rest`` the chamber's length
    with the arm at rest at the pre-pressure (weightless equilibrium). A load that shortens a
    chamber raises its pressure, so the arm is stiffer against it than at a held pressure.

    The stroke follows its command with the first-order lag of :class:`PneumaticSupply` (the
    stepper's motion), integrated exactly over each update; the pressure is then the gas law's at
    the chamber lengths of that update. Strokes outside ``[0, S]`` are refused; a pressure the gas
    law puts outside ``[0, p_max]`` (a chamber crushed at a long stroke, or stretched far at a
    short one) is held at the bound, counted in :attr:`saturated_updates` and warned about once
    per episode.

    It answers what the simulators ask of :class:`PneumaticSupply` (``pressure_pa``,
    ``time_constant_s``, ``set_time_constant_scale``) and takes strokes instead of pressures.

    Args:
        spec: the arm; ``spec.cylinders`` must be set.
        rest_lengths_m: every chamber's length at rest at the pre-pressure (m), (n_chambers,).

    Raises:
        ValueError: ``spec.cylinders`` missing, or a full stroke that would put a chamber at rest
            above its ``p_max_pa``.
    """

    def __init__(self, spec: ArmSpec, rest_lengths_m: np.ndarray) -> None:
        if spec.cylinders is None:
            raise ValueError(f"spec.cylinders must be a CylinderSpec for volume actuation, got "
                             f"None on the {spec.name} arm")
        self.spec = spec
        self.cylinders = cylinders = spec.cylinders
        n = spec.n_chambers
        self.p_max_pa = spec.p_max_pa
        self.chamber_area_m2 = np.repeat([s.chamber_area_m2 for s in spec.segments], 3).astype(float)
        self.rest_lengths_m = as_finite_array("rest_lengths_m", rest_lengths_m, shape=(n,)).copy()
        self.max_stroke_m = float(cylinders.max_stroke_m)
        self.atmospheric_pa = float(cylinders.atmospheric_pa)
        # the gas amount of each chamber, as (absolute pressure) x (volume) (Pa m^3 = J)
        self.gas_pa_m3 = (spec.p_pre_pa + self.atmospheric_pa) * self.volume_m3(
            self.rest_lengths_m, np.zeros(n))
        full = self.pressure_at(self.rest_lengths_m, np.full(n, self.max_stroke_m))
        if np.any(full > self.p_max_pa * (1 + 1e-9)):
            raise ValueError(
                f"max_stroke_m={self.max_stroke_m} would put chambers at rest at "
                f"{np.round(full).tolist()} Pa, above p_max_pa={self.p_max_pa.tolist()}: "
                f"allowed max_stroke_m <= {self.stroke_for(self.p_max_pa, self.rest_lengths_m).min():.6g}"
                f" m for these cylinders")
        self.time_constant_s = spec.pneumatic_time_constant_s
        self.saturated_updates = 0
        self._warned = False
        self.reset()

    # ------------------------------------------------------------------ the gas law
    def volume_m3(self, lengths_m: np.ndarray, strokes_m: np.ndarray) -> np.ndarray:
        """Gas volume of chamber + cylinder + dead volume (m^3):
        ``A_c L + A_b (S - s) + V_d``."""
        c = self.cylinders
        return (self.chamber_area_m2 * np.asarray(lengths_m, dtype=float)
                + c.bore_area_m2 * (self.max_stroke_m - np.asarray(strokes_m, dtype=float))
                + c.dead_volume_m3)

    def pressure_at(self, lengths_m: np.ndarray, strokes_m: np.ndarray) -> np.ndarray:
        """Gauge pressure (Pa) the gas law gives at chamber lengths (m) and strokes (m),
        ``K / V - p_atm``, not limited to ``[0, p_max]``."""
        return self.gas_pa_m3 / self.volume_m3(lengths_m, strokes_m) - self.atmospheric_pa

    def stroke_for(self, pressure_pa: np.ndarray, lengths_m: np.ndarray) -> np.ndarray:
        """Stroke (m) that holds gauge ``pressure_pa`` (Pa) at chamber lengths ``lengths_m``
        (m): ``S - (K / (p + p_atm) - A_c L - V_d) / A_b``, the inverse of
        :meth:`pressure_at`; not limited to the cylinder's range."""
        c = self.cylinders
        gas_volume = self.gas_pa_m3 / (np.asarray(pressure_pa, dtype=float) + self.atmospheric_pa)
        cylinder = (gas_volume - self.chamber_area_m2 * np.asarray(lengths_m, dtype=float)
                    - c.dead_volume_m3)
        return self.max_stroke_m - cylinder / c.bore_area_m2

    # ------------------------------------------------------------------ commands
    def check_strokes(self, strokes_m: np.ndarray, name: str = "strokes_m") -> np.ndarray:
        """Validate a stroke command: shape (n_chambers,), finite, within ``[0, max_stroke_m]``
        (m)."""
        strokes = as_finite_array(name, strokes_m, shape=(self.spec.n_chambers,))
        if np.any(strokes < 0) or np.any(strokes > self.max_stroke_m * (1 + 1e-9)):
            raise ValueError(
                f"{name} must lie within the cylinders' range [0, max_stroke_m="
                f"{self.max_stroke_m:.6g}] m, got {strokes.tolist()}")
        return np.minimum(strokes, self.max_stroke_m)

    def command_strokes(self, strokes_m: np.ndarray) -> None:
        """Set the commanded strokes (m)."""
        self.command_stroke_m = self.check_strokes(strokes_m)

    def command(self, pressure_pa: np.ndarray) -> None:
        """Refused: a volume-driven arm takes strokes (:meth:`command_strokes`)."""
        raise ValueError(
            f"pressures_pa cannot be commanded on the volume-actuated {self.spec.name} arm "
            f"(ArmSpec.cylinders is set): command cylinder strokes with "
            f"set_cylinder_strokes(strokes_m), in [0, {self.max_stroke_m:.6g}] m")

    def set_time_constant_scale(self, scale: float) -> None:
        """Make the stroke's lag ``scale`` times the arm's nominal time constant."""
        scale = require_positive("scale", scale)
        self.time_constant_s = self.spec.pneumatic_time_constant_s * scale

    def check_pressures(self, pressure_pa: np.ndarray) -> np.ndarray:
        """Validate pressures (Pa) to start from: shape (n_chambers,), finite, within
        ``[0, p_max]``."""
        return check_pressures(self.spec, pressure_pa)

    def reset(self, pressure_pa: np.ndarray | None = None,
              lengths_m: np.ndarray | None = None) -> None:
        """Strokes and their commands at rest (0; the pressures the gas law gives at chamber
        lengths ``lengths_m``, m, default the pre-pressure), or at the strokes that hold
        ``pressure_pa`` (Pa, each in ``[0, p_max]``) at chamber lengths ``lengths_m`` (m).

        Raises:
            ValueError: pressures out of ``[0, p_max]``, or ones that need a stroke outside the
                cylinders' range.
        """
        n = self.spec.n_chambers
        self.saturated_updates = 0
        self._warned = False
        if pressure_pa is None:
            self.stroke_m = np.zeros(n)
            self.pressure_pa = (self.spec.p_pre_pa.copy() if lengths_m is None else np.clip(
                self.pressure_at(lengths_m, self.stroke_m), 0.0, self.p_max_pa))
        else:
            pressure = self.check_pressures(pressure_pa)
            lengths = as_finite_array("lengths_m", lengths_m, shape=(n,))
            strokes = self.stroke_for(pressure, lengths)
            tolerance = 1e-9 * self.max_stroke_m
            if np.any(strokes < -tolerance) or np.any(strokes > self.max_stroke_m + tolerance):
                raise ValueError(
                    f"pressure_pa={pressure.tolist()} needs strokes {strokes.tolist()} m, outside "
                    f"the cylinders' range [0, max_stroke_m={self.max_stroke_m:.6g}] m, at the "
                    f"chamber lengths of that shape")
            self.stroke_m = np.clip(strokes, 0.0, self.max_stroke_m)
            self.pressure_pa = np.array(pressure, dtype=float)
        self.command_stroke_m = self.stroke_m.copy()

    def advance(self, dt_s: float, lengths_m: np.ndarray) -> np.ndarray:
        """Advance the strokes' lag by ``dt_s`` seconds and return the chamber pressures (Pa)
        the gas law gives at chamber lengths ``lengths_m`` (m)."""
        alpha = 1.0 - math.exp(-dt_s / self.time_constant_s)
        self.stroke_m = self.stroke_m + (self.command_stroke_m - self.stroke_m) * alpha
        pressure = self.pressure_at(lengths_m, self.stroke_m)
        outside = (pressure < 0.0) | (pressure > self.p_max_pa)
        if np.any(outside):
            self.saturated_updates += 1
            if not self._warned:
                self._warned = True
                warnings.warn(
                    f"the gas law puts chambers {np.flatnonzero(outside).tolist()} of the "
                    f"{self.spec.name} arm at {np.round(pressure[outside]).tolist()} Pa, outside "
                    f"[0, p_max]; held at the bound (counted in saturated_updates)",
                    RuntimeWarning, stacklevel=2)
            pressure = np.clip(pressure, 0.0, self.p_max_pa)
        self.pressure_pa = pressure
        return pressure


def make_supply(spec: ArmSpec, rest_lengths_m: Callable[[], np.ndarray]
                ) -> PneumaticSupply | VolumeSupply:
    """The arm's supply: :class:`PneumaticSupply` for pressure actuation, :class:`VolumeSupply`
    (with the chambers' rest lengths, m, from ``rest_lengths_m()``) where ``spec.cylinders`` is
    set."""
    if spec.cylinders is None:
        return PneumaticSupply(spec)
    return VolumeSupply(spec, rest_lengths_m())
