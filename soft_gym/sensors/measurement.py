"""One control step's measurement: every active sensor read once, at one simulated time.

The env takes a :class:`Measurement` after the physics of each control step (and at reset) with
:func:`soft_gym.sensors.reading.measure`; the observation, ``info`` and the feedback source all
read that object, so a camera frame is rendered
once per step and every consumer sees the same noisy sample. See docs/architecture.md, "One env
step".
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Mapping

import numpy as np


@dataclass(frozen=True)
class Measurement:
    """Readings by sensor name at ``time_s``, plus the metric depth of camera frames.

    Attributes:
        time_s: simulated time of the measurement (s).
        readings: sensor name -> reading (see :data:`soft_gym.sensors.SENSORS`).
        depth_m: camera sensor name -> metric depth (m, H x W) of the same frame, for the map
            building of the vision tracker (wang2023 scales its monocular map with the EM
            tracker; the simulated depth buffer gives the metric scale directly).
        command_pa: the chamber pressures last commanded (Pa, (n_chambers,)), what the
            controller sent; ``None`` where no command was recorded.
    """

    time_s: float
    readings: Mapping[str, Any]
    depth_m: Mapping[str, np.ndarray] = field(default_factory=dict)
    command_pa: np.ndarray | None = None

    def __getitem__(self, name: str) -> Any:
        try:
            return self.readings[name]
        except KeyError:
            raise ValueError(f"sensor must be one of the measured {sorted(self.readings)}, "
                             f"got {name!r}") from None
