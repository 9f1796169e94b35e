"""Reading every sensor once into one :class:`~soft_gym.sensors.measurement.Measurement`."""

from __future__ import annotations

from typing import Any, Mapping

import numpy as np

from soft_gym.sensors.measurement import Measurement


def measure(sensors: Mapping[str, Any], sim, command_pa: np.ndarray | None = None
            ) -> Measurement:
    """Read every sensor in ``sensors`` (name -> :class:`~soft_gym.sensors.base.Sensor`) once
    from the simulator ``sim``, with the chamber pressures last commanded (Pa; the estimators
    that read the commands, e.g. zhao2021's, take them from here, as a real controller keeps
    what it sent)."""
    time_s = sim.time_s
    readings, depth = {}, {}
    for name, sensor in sensors.items():
        readings[name] = sensor.read(sim, time_s)
        frame_depth = getattr(sensor, "last_depth", None)
        if frame_depth is not None:
            depth[name] = frame_depth
    return Measurement(time_s=time_s, readings=readings, depth_m=depth,
                       command_pa=None if command_pa is None else np.array(command_pa,
                                                                           dtype=float))
