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
    """Build the sensor called ``name`` (see :data:`SENSORS`) with its keyword arguments."""
    if name not in SENSORS:
        raise ValueError(f"sensor must be one of {sorted(SENSORS)}, got {name!r}")
    module_name, class_name = SENSORS[name].split(":")
    cls = getattr(importlib.import_module(module_name), class_name)
    try:
        return cls(**kwargs)
    except TypeError as error:
        raise ValueError(f"sensor {name!r} got invalid parameters {kwargs}: {error}") from error


__all__ = ["Sensor", "SENSORS", "make_sensor"]
