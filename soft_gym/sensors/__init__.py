"""Sensors of the four papers' arms, each an observation part you can ask for by name.

| name      | class                | paper    | reading                                          |
|-----------|----------------------|----------|--------------------------------------------------|
| `fbg`     | `FBGFiber`           | wang2023 | Bragg wavelength shifts (nm), one per grating     |
| `strain`  | `StrainGauges`       | zhao2021 | surface strain, 3 gauges per segment              |
| `encoder` | `ChamberEncoders`    | zou2022  | chamber lengths (m)                              |
| `em`      | `EMTracker`          | ho2018   | tip position (m) + quaternion, with noise         |
| `image`   | `EyeInHandCamera`    | wang2023 | uint8 H x W x 3 frame from the tip camera         |
| `stereo`  | `StereoCamera`       | zou2022  | two uint8 frames and their projection matrices    |
| `truth`   | `TruthSensor`        | -        | the simulator's tip pose and backbone (privileged) |

A privileged sensor (``privileged = True``) exists only for the ``ground_truth`` feedback source:
no observation part or ``info["sensors"]`` entry shows it (:data:`PUBLIC_SENSORS` leaves it out).
"""

from __future__ import annotations

from typing import Any

from soft_gym._registry import Registry, build, parse_spec
from soft_gym.sensors.base import Sensor
from soft_gym.sensors.camera import EyeInHandCamera
from soft_gym.sensors.em_tracker import EMTracker
from soft_gym.sensors.encoder import ChamberEncoders
from soft_gym.sensors.fbg import FBGFiber
from soft_gym.sensors.stereo import StereoCamera
from soft_gym.sensors.strain_gauge import StrainGauges
from soft_gym.sensors.truth import TruthSensor

SENSORS: Registry[type[Sensor]] = Registry("sensor")
"""Sensor names and classes."""
SENSORS.register("fbg", FBGFiber)
SENSORS.register("strain", StrainGauges)
SENSORS.register("encoder", ChamberEncoders)
SENSORS.register("em", EMTracker)
SENSORS.register("image", EyeInHandCamera)
SENSORS.register("stereo", StereoCamera)
SENSORS.register("truth", TruthSensor)

PUBLIC_SENSORS: tuple[str, ...] = tuple(name for name in SENSORS
                                        if not getattr(SENSORS[name], "privileged", False))
"""The sensors a user may ask for (``sensors=``, observation parts): all but the privileged."""


def make_sensor(name: str, **kwargs: Any) -> Sensor:
    """Build the sensor called ``name`` (see :data:`SENSORS`) with its keyword arguments.

    ``name`` is parsed by :func:`soft_gym._registry.parse_spec` (a name string only).
    """
    (spec,) = parse_spec(name, "sensor", SENSORS, forms=("name",))
    return build("sensor", spec.name, SENSORS[spec.name], kwargs)


__all__ = ["Sensor", "SENSORS", "PUBLIC_SENSORS", "make_sensor"]
