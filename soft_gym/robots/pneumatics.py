"""Pneumatic actuation: first-order pressure lag and the pressure -> force/moment map.

docs/architecture.md, "Pneumatic actuation": chamber ``i`` at gauge pressure ``p_i`` over area
``A_c`` pushes
``F_i = p_i A_c``; its segment receives the axial force ``sum_i F_i`` and the bending moment
``sum_i F_i d (sin sigma_i, -cos sigma_i)`` about the local x and y axes. Equal pressures give no
moment, so pre-pressure only lengthens the arm.

A chamber whose bore widens with pressure (:attr:`soft_gym.robots.spec.SegmentSpec.chamber_area_growth`
``g``, zhao2021's thread-wrapped chambers) pushes ``F_i = p_i A_c (1 + g p_i / p_max)``: the map
stays linear in the *effective pressure* ``p_i (1 + g p_i / p_max)``
(:func:`effective_pressure_pa`), which is what the simulator feeds its linear load matrix.
"""

from __future__ import annotations

import math

import numpy as np

from soft_gym._validation import as_finite_array, require_positive
from soft_gym.robots.actuation import CHAMBER_ANGLES_RAD
from soft_gym.robots.spec import ArmSpec


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
        n = self.spec.n_chambers
        command = as_finite_array("pressures_pa", pressure_pa, shape=(n,))
        if np.any(command < 0) or np.any(command > self.p_max_pa * (1 + 1e-9)):
            raise ValueError(
                f"pressures_pa must lie within [0, p_max_pa={self.p_max_pa.tolist()}], "
                f"got {command.tolist()}")
        return np.minimum(command, self.p_max_pa)

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


def chamber_area_growth(spec: ArmSpec) -> np.ndarray:
    """Per-chamber area growth ``g`` (dimensionless), shape (n_chambers,)."""
    return np.repeat([segment.chamber_area_growth for segment in spec.segments], 3).astype(float)


def effective_pressure_pa(spec: ArmSpec, pressure_pa: np.ndarray) -> np.ndarray:
    """Chamber pressures (Pa) scaled by their bores' growth: ``p (1 + g p / p_max)`` (Pa).

    ``p A_c`` of the effective pressure is the chamber's force ``p A_c(p)`` with
    ``A_c(p) = A_c (1 + g p / p_max)`` (:attr:`soft_gym.robots.spec.SegmentSpec.chamber_area_growth`);
    equal to ``pressure_pa`` where ``g = 0``. Works on ``(..., n_chambers)`` arrays.
    """
    pressure = np.asarray(pressure_pa, dtype=float)
    growth = chamber_area_growth(spec)
    if not np.any(growth):
        return pressure
    return pressure * (1.0 + growth * pressure / spec.p_max_pa)


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
