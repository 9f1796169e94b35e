"""What every sensor shares: its own sample rate (sample and hold), seeded noise, and a space.

The env reads every sensor once per control step with :meth:`Sensor.read` (into one
:class:`~soft_gym.sensors.measurement.Measurement`); a sensor takes a fresh sample when one is due
at its ``rate_hz`` and otherwise repeats the last one, as a slower real sensor would.
All randomness comes from the generator given to :meth:`Sensor.reset` (the env's ``np_random``),
so a seed fixes every reading.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from gymnasium import spaces

from soft_gym._validation import require_positive

NOISE_ATTRIBUTES = ("noise_std_nm", "noise_std_m", "position_noise_m", "orientation_noise_deg",
                    "noise_std_dn", "noise_std")
"""Sensor attributes holding a noise standard deviation (scaled by :meth:`Sensor.set_noise_scale`)."""


class Sensor:
    """Base class: subclasses implement :meth:`sample` and :meth:`space`.

    Args:
        name: the observation part / info key this sensor fills (e.g. ``"fbg"``).
        rate_hz: samples per second; ``None`` samples at every read.
    """

    engine_features: frozenset[str] = frozenset()
    """What the sensor needs of the physics engine beyond the arm
    (:data:`soft_gym.engines.ENGINE_FEATURES`); a camera needs ``"rendering"``."""

    def __init__(self, name: str, rate_hz: float | None = None) -> None:
        if rate_hz is not None:
            require_positive("rate_hz", rate_hz)
        self.name = name
        self.rate_hz = rate_hz
        self.rng = np.random.default_rng(0)
        self._last: Any = None
        self._next_sample_s = 0.0

    def reset(self, sim, rng: np.random.Generator) -> None:
        """Start an episode: take the noise generator and forget the held sample."""
        self.rng = rng
        self._last = None
        self._next_sample_s = 0.0

    def read(self, sim, time_s: float) -> Any:
        """The current reading: a fresh sample if one is due at ``time_s`` (s), else the last."""
        if self._last is None or self.rate_hz is None or time_s + 1e-9 >= self._next_sample_s:
            self._last = self.sample(sim)
            if self.rate_hz is not None:
                self._next_sample_s = time_s + 1.0 / self.rate_hz
        return self._last

    def set_noise_scale(self, scale: float) -> None:
        """Make every noise standard deviation of the sensor ``scale`` times the one it was built
        with (domain randomisation's sensor-noise factor)."""
        scale = require_positive("scale", scale)
        if not hasattr(self, "_nominal_noise"):
            self._nominal_noise = {name: float(getattr(self, name)) for name in NOISE_ATTRIBUTES
                                   if isinstance(getattr(self, name, None), (int, float))}
        for name, value in self._nominal_noise.items():
            setattr(self, name, value * scale)

    def sample(self, sim) -> Any:
        """Measure now from the simulator ``sim`` (an ``ArmSimulator``), noise included."""
        raise NotImplementedError

    def space(self, sim) -> spaces.Space:
        """Observation space of one reading."""
        raise NotImplementedError
