"""Sensors of the four papers' arms, each an observation part you can ask for by name.

| name      | class                | paper    | reading                                          |
|-----------|----------------------|----------|--------------------------------------------------|
| `fbg`     | `FBGFiber`           | wang2023 | Bragg wavelength shifts (nm), one per grating     |
| `strain`  | `StrainGauges`       | zhao2021 | surface strain, 3 gauges per segment              |
| `encoder` | `ChamberEncoders`    | zou2022  | chamber lengths (m)                              |
| `em`      | `EMTracker`          | ho2018   | tip position (m) + quaternion, with noise         |
| `image`   | `EyeInHandCamera`    | wang2023 | uint8 H x W x 3 frame from the tip camera         |
| `stereo`  | `StereoCamera`       | zou2022  | two uint8 frames and their projection matrices    |
"""

from __future__ import annotations

import importlib
from typing import Any

from soft_gym._registry import build, parse_spec
from soft_gym.sensors.base import Sensor

SENSORS: dict[str, str] = {
    "fbg": "soft_gym.sensors.fbg:FBGFiber",
    "strain": "soft_gym.sensors.strain_gauge:StrainGauges",
    "encoder": "soft_gym.sensors.encoder:ChamberEncoders",
    "em": "soft_gym.sensors.em_tracker:EMTracker",
    "image": "soft_gym.sensors.camera:EyeInHandCamera",
    "stereo": "soft_gym.sensors.stereo:StereoCamera",
}
"""Sensor names and where their classes live (imported only when asked for)."""


def make_sensor(name: str, **kwargs: Any) -> Sensor:
    """Build the sensor called ``name`` (see :data:`SENSORS`) with its keyword arguments.

    ``name`` is parsed by :func:`soft_gym._registry.parse_spec` (a name string only).
    """
    (spec,) = parse_spec(name, "sensor", SENSORS, forms=("name",))
    module_name, class_name = SENSORS[spec.name].split(":")
    return build("sensor", spec.name, getattr(importlib.import_module(module_name), class_name),
                 kwargs)


__all__ = ["Sensor", "SENSORS", "make_sensor"]
