"""Chamber layout and the action <-> pressure maps of the env's two action modes.

Chambers. Segment ``k`` owns chambers ``3k, 3k+1, 3k+2``; chamber ``i`` of a segment sits at
``sigma_i = 2 pi i / 3`` (rad, counter-clockwise from the segment base's ``+x``) at distance ``d``
from the axis (wang2023 eqs. (19)-(24), zou2022 eqs. (2)-(10)). :data:`CHAMBER_ANGLES_RAD` is the
one copy of these angles; the kinematics, the simulator, the pneumatics, the arm description and
the strain gauges all read it.

Actions. An action holds one value in [-1, 1] per chamber; pressures are gauge pressures (Pa),
per chamber between the pre-pressure ``p_pre`` and ``p_max`` of the arm
(:attr:`~soft_gym.robots.spec.ArmSpec.p_pre_pa`, :attr:`~soft_gym.robots.spec.ArmSpec.p_max_pa`):

* ``"absolute"``: ``p = p_pre + (a + 1) / 2 (p_max - p_pre)``;
* ``"delta"``: ``p_cmd <- clip(p_cmd + a * delta_fraction * p_max, p_pre, p_max)``, the
  command moving from the previous one (which starts at ``p_pre`` every episode).

Each map has its inverse: the action that gives (or, in delta mode, moves the previous command
towards) a wanted pressure, saturated to [-1, 1]. :class:`Actuation` bundles one arm's maps in
one mode; controllers use it to turn the pressures they want into actions, whatever the mode.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from soft_gym._validation import require_choice

from soft_gym.robots.chambers import CHAMBER_ANGLES_RAD, CHAMBER_COS, CHAMBER_SIN
from soft_gym.robots.spec import ArmSpec

__all__ = ["CHAMBER_ANGLES_RAD", "CHAMBER_COS", "CHAMBER_SIN", "ACTION_MODES",
           "chamber_angles", "pressure_at_fraction", "absolute_pressure", "absolute_action",
           "delta_pressure", "delta_action", "Actuation"]


ACTION_MODES = ("absolute", "delta")
"""The env's action modes (see the module docstring)."""


def chamber_angles(n_segments: int) -> np.ndarray:
    """Angle (rad) of every chamber of an ``n_segments`` arm, shape (3 n_segments,)."""
    if isinstance(n_segments, bool) or not isinstance(n_segments, (int, np.integer)) \
            or n_segments < 1:
        raise ValueError(f"n_segments must be an integer >= 1, got {n_segments!r}")
    return np.tile(CHAMBER_ANGLES_RAD, int(n_segments))


def _limits(spec: ArmSpec) -> tuple[np.ndarray, np.ndarray]:
    return spec.p_pre_pa, spec.p_max_pa


def pressure_at_fraction(spec: ArmSpec, fraction: Any) -> np.ndarray:
    """``p = p_pre + f (p_max - p_pre)`` (Pa): ``f`` (0..1, per chamber or one for all) of the
    way from the pre-pressure to ``p_max``; the absolute mode's action is ``a = 2 f - 1``."""
    low, high = _limits(spec)
    return low + np.asarray(fraction, dtype=float) * (high - low)


def absolute_pressure(spec: ArmSpec, action: Any) -> np.ndarray:
    """Absolute mode: ``p = p_pre + (a + 1) / 2 (p_max - p_pre)`` (Pa), shape (n_chambers,).

    Args:
        spec: the arm (its per-chamber ``p_pre_pa`` and ``p_max_pa``).
        action: one value in [-1, 1] per chamber (not checked here; the env checks it).
    """
    return pressure_at_fraction(spec, (np.asarray(action, dtype=float) + 1.0) / 2.0)


def absolute_action(spec: ArmSpec, pressure_pa: Any) -> np.ndarray:
    """Inverse of :func:`absolute_pressure`: ``a = 2 (p - p_pre) / (p_max - p_pre) - 1``,
    clipped to [-1, 1] (pressures outside ``[p_pre, p_max]`` saturate). Chambers whose
    ``p_pre = p_max`` give -1 (every action gives the same pressure there)."""
    low, high = _limits(spec)
    span = high - low
    offset = np.asarray(pressure_pa, dtype=float) - low
    fraction = np.divide(offset, span, out=np.zeros(np.broadcast(offset, span).shape),
                         where=span > 0)
    return np.clip(2.0 * fraction - 1.0, -1.0, 1.0)


def delta_pressure(spec: ArmSpec, action: Any, previous_command_pa: Any,
                   delta_fraction: float) -> np.ndarray:
    """Delta mode: ``p_cmd <- clip(p_cmd + a * delta_fraction * p_max, p_pre, p_max)`` (Pa).

    Args:
        spec: the arm.
        action: one value in [-1, 1] per chamber.
        previous_command_pa: the command before this step (Pa); ``p_pre`` after a reset.
        delta_fraction: pressure change per unit action, as a fraction of ``p_max``.
    """
    low, high = _limits(spec)
    previous = np.asarray(previous_command_pa, dtype=float)
    return np.clip(previous + np.asarray(action, dtype=float) * delta_fraction * high, low, high)


def delta_action(spec: ArmSpec, pressure_pa: Any, previous_command_pa: Any,
                 delta_fraction: float) -> np.ndarray:
    """Inverse of :func:`delta_pressure`: the action that moves the previous command (Pa) to
    ``pressure_pa`` (clipped to ``[p_pre, p_max]``), ``a = (p - p_cmd) / (delta_fraction p_max)``,
    clipped to [-1, 1]: a wanted pressure farther than one step away is reached over several."""
    low, high = _limits(spec)
    wanted = np.clip(np.asarray(pressure_pa, dtype=float), low, high)
    step = (wanted - np.asarray(previous_command_pa, dtype=float)) / (delta_fraction * high)
    return np.clip(step, -1.0, 1.0)


@dataclass(frozen=True)
class Actuation:
    """One arm's action <-> pressure maps in one action mode.

    Args:
        spec: the arm (``p_pre_pa``, ``p_max_pa`` per chamber, Pa).
        mode: ``"absolute"`` or ``"delta"`` (:data:`ACTION_MODES`).
        delta_fraction: pressure change per unit action in delta mode, as a fraction of
            ``p_max``, in (0, 1].
    """

    spec: ArmSpec
    mode: str = "absolute"
    delta_fraction: float = 0.1

    def __post_init__(self) -> None:
        require_choice("action_mode", self.mode, ACTION_MODES)
        fraction = self.delta_fraction
        if isinstance(fraction, bool) or not isinstance(fraction, (int, float, np.integer,
                                                                   np.floating)) \
                or not np.isfinite(fraction) or not 0 < fraction <= 1:
            raise ValueError(f"delta_fraction must be a number in (0, 1], got {fraction!r}")
        object.__setattr__(self, "delta_fraction", float(fraction))

    @classmethod
    def of_env(cls, env: Any) -> "Actuation":
        """The maps of a :class:`~soft_gym.envs.SoftArmEnv` (wrapped or not): its arm,
        ``action_mode`` and ``delta_fraction``."""
        base = env.unwrapped
        return cls(base.arm, base.action_mode, base.delta_fraction)

    @property
    def initial_command_pa(self) -> np.ndarray:
        """The command an episode starts from (Pa): the pre-pressure."""
        return self.spec.p_pre_pa

    def pressure(self, action: Any, previous_command_pa: Any = None) -> np.ndarray:
        """The commanded pressures (Pa, float64, (n_chambers,)) for ``action``.

        ``previous_command_pa`` (Pa) is needed in delta mode and ignored in absolute mode.
        """
        if self.mode == "absolute":
            return absolute_pressure(self.spec, action)
        return delta_pressure(self.spec, action, self._previous(previous_command_pa),
                              self.delta_fraction)

    def action(self, pressure_pa: Any, previous_command_pa: Any = None) -> np.ndarray:
        """The action (float32, in [-1, 1]) that commands ``pressure_pa`` (Pa), or in delta
        mode moves ``previous_command_pa`` (Pa) as far towards it as one step can."""
        if self.mode == "absolute":
            action = absolute_action(self.spec, pressure_pa)
        else:
            action = delta_action(self.spec, pressure_pa, self._previous(previous_command_pa),
                                  self.delta_fraction)
        return action.astype(np.float32)

    def _previous(self, previous_command_pa: Any) -> np.ndarray:
        if previous_command_pa is None:
            raise ValueError("previous_command_pa must be the last pressure command (Pa) in "
                             "action_mode 'delta', got None")
        return np.asarray(previous_command_pa, dtype=float)
