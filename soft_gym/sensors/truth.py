"""The simulator's own tip pose and backbone, as a sensor: what the ``ground_truth`` source reads.

No real arm has this sensor. It exists so that every feedback source, ground truth included,
estimates from a :class:`~soft_gym.sensors.measurement.Measurement` alone and never holds the
simulator. It is :attr:`~TruthSensor.privileged`: no observation part or ``info["sensors"]``
entry shows it (``info`` carries the ground truth under its own keys).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from gymnasium import spaces

from soft_gym.sensors.base import Sensor


class TruthSensor(Sensor):
    """The exact tip pose and backbone every control step (no noise, no lag).

    Reading: a dict with ``position_m`` (3,), ``quaternion`` (x, y, z, w) and ``backbone_m``
    (the base and every link's distal end, m, (n_links + 1, 3)), in the base frame.
    """

    privileged = True

    def __init__(self) -> None:
        super().__init__("truth", None)

    def sample(self, sim) -> dict[str, Any]:
        position, quaternion = sim.tip_pose()
        return {"position_m": position, "quaternion": quaternion, "backbone_m": sim.backbone()}

    def space(self, sim) -> spaces.Dict:
        reach = 5.0 * sim.spec.length_m
        return spaces.Dict({
            "position_m": spaces.Box(-reach, reach, (3,), np.float64),
            "quaternion": spaces.Box(-1.0, 1.0, (4,), np.float64),
            "backbone_m": spaces.Box(-reach, reach, (sim.n_links + 1, 3), np.float64)})
