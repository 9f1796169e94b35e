"""A length-to-pressure map with separate extension and bending gains, scheduled over the
extension: the generalisation of wang2023 eq. (27) that an extensible arm needs.

Eq. (27), ``p_i = p_pre + alpha_i (u_i - u0_i)``, gives each chamber one gain, so it ties the
pressure that *extends* the segment (all chambers together) to the pressure that *bends* it (one
chamber against the others) through the same stiffness. That holds for wang2023's arm, which
barely extends. It fails on zou2022's pressurised artificial muscles: their axial stiffness is a
small fraction of their bending stiffness (the preset: 15 kPa against 250 kPa), and both stiffen
as the muscles extend from 77 mm towards 250 mm. Probed at rest, eq. (27)'s gains are right for
extension and about ten times too small for bending where the arm works (its circle ~110 mm
below the rest tip): the loop's bending gain is a seventh of what ``K_p`` sets, the tip lags on a
circle of 60 % of the path's radius (K_p 0.06: 24 mm mean error on the 71 mm circle, ground
truth), and a larger ``K_p`` saturates the extension (0.12: 77 mm). With this map: 7.7 and
3.5 mm, and ``hybrid_gpr`` 0.75 mm (74 mm with eq. (27)) at K_p 0.06.

The map here splits the chamber lengths ``u`` of one segment into their mean ``u_bar`` (the
extension) and the differences ``u - u_bar`` (the bending), and gives each its own gain, both
functions of the extension, measured at a few extension levels (:meth:`CCModelController.
calibrate` with ``length_map="modal"``):

    ``p_i = P(u_bar) + a_b(u_bar) (u_i - u_bar)``

``P`` is the common pressure that holds the segment at mean length ``u_bar`` (piecewise linear
through the levels, extended linearly beyond the last), ``a_b`` the bending gain (Pa/m of
differential length; piecewise linear, held constant beyond the end levels). With three chambers
at 120 degrees the differences sum to zero, so ``mean(p) = P(u_bar)`` and the map inverts exactly
(:meth:`ModalLengthMap.lengths`), which the controller's anti-windup needs.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class ModalLengthMap:
    """Chamber lengths <-> pressures of one three-chamber segment, scheduled over its extension.

    Attributes:
        mean_lengths_m: mean chamber length at each probed extension level (m), increasing;
            the first is the rest length.
        common_pressures_pa: pressure in every chamber that holds each level (Pa), increasing;
            the first is the pre-pressure.
        bending_gains_pa_m: differential pressure per differential chamber length at each level
            (Pa/m), > 0.
    """

    mean_lengths_m: np.ndarray
    common_pressures_pa: np.ndarray
    bending_gains_pa_m: np.ndarray

    def __post_init__(self) -> None:
        for name in ("mean_lengths_m", "common_pressures_pa", "bending_gains_pa_m"):
            value = np.asarray(getattr(self, name), dtype=float)
            if value.ndim != 1 or len(value) < 2 or not np.all(np.isfinite(value)):
                raise ValueError(f"{name} must be at least two finite numbers, got {value!r}")
            object.__setattr__(self, name, value)
        if not (len(self.mean_lengths_m) == len(self.common_pressures_pa)
                == len(self.bending_gains_pa_m)):
            raise ValueError("mean_lengths_m, common_pressures_pa and bending_gains_pa_m must have "
                             "one entry per level each")
        for name in ("mean_lengths_m", "common_pressures_pa"):
            if not np.all(np.diff(getattr(self, name)) > 0.0):
                raise ValueError(f"{name} must increase from level to level, got "
                                 f"{getattr(self, name)!r}")
        if not np.all(self.bending_gains_pa_m > 0.0):
            raise ValueError(f"bending_gains_pa_m must be > 0, got {self.bending_gains_pa_m!r}")

    def pressures(self, lengths_m: np.ndarray) -> np.ndarray:
        """The chamber pressures (Pa, not clipped) that the map gives chamber lengths (m)."""
        lengths = np.asarray(lengths_m, dtype=float)
        mean = float(lengths.mean())
        common = _extended_interp(mean, self.mean_lengths_m, self.common_pressures_pa)
        return common + self.bending_gain(mean) * (lengths - mean)

    def lengths(self, pressures_pa: np.ndarray) -> np.ndarray:
        """The chamber lengths (m) that :meth:`pressures` maps onto ``pressures_pa`` (Pa)."""
        pressures = np.asarray(pressures_pa, dtype=float)
        common = float(pressures.mean())
        mean = _extended_interp(common, self.common_pressures_pa, self.mean_lengths_m)
        return mean + (pressures - common) / self.bending_gain(mean)

    def bending_gain(self, mean_length_m: float) -> float:
        """``a_b`` (Pa/m) at mean chamber length ``mean_length_m`` (m)."""
        return float(np.interp(mean_length_m, self.mean_lengths_m, self.bending_gains_pa_m))

    def to_dict(self) -> dict[str, list[float]]:
        return {"mean_lengths_m": self.mean_lengths_m.tolist(),
                "common_pressures_pa": self.common_pressures_pa.tolist(),
                "bending_gains_pa_m": self.bending_gains_pa_m.tolist()}

    @classmethod
    def from_dict(cls, data: object) -> "ModalLengthMap":
        """The map :meth:`to_dict` wrote; ``ValueError`` for anything else."""
        keys = {"mean_lengths_m", "common_pressures_pa", "bending_gains_pa_m"}
        if not isinstance(data, dict) or set(data) != keys:
            raise ValueError(f"a modal length map must be an object with exactly the keys "
                             f"{sorted(keys)}, got {data!r}")
        for key, value in data.items():
            if not isinstance(value, list) or not all(
                    isinstance(v, (int, float)) and not isinstance(v, bool) for v in value):
                raise ValueError(f"{key} must be a list of numbers, got {value!r}")
        return cls(**{key: np.array(value, dtype=float) for key, value in data.items()})


def _extended_interp(x: float, xs: np.ndarray, ys: np.ndarray) -> float:
    """Piecewise-linear ``y(x)`` through increasing ``xs``, extended linearly beyond both ends."""
    if x < xs[0]:
        return float(ys[0] + (x - xs[0]) * (ys[1] - ys[0]) / (xs[1] - xs[0]))
    if x > xs[-1]:
        return float(ys[-1] + (x - xs[-1]) * (ys[-1] - ys[-2]) / (xs[-1] - xs[-2]))
    return float(np.interp(x, xs, ys))
