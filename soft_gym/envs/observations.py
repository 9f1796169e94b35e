"""The observation parts: one table of what each part is, its space and its value.

``obs=`` of the env picks and orders parts from :data:`OBSERVATION_PARTS`; each
:class:`ObservationPart` gives the part's space (from the arm and the simulated sensors) and its
value at a step (from the step's measurement, the feedback estimate, the task and the pressures).
The env's docstring and the guide's table (docs/guide.md) are checked against this one
(``tests/test_readme.py``, ``tests/soft_gym/envs/test_env.py``).

| part       | size            | content                                                   | unit |
|------------|-----------------|-----------------------------------------------------------|------|
| `pose`     | 7               | feedback tip position (x, y, z) + quaternion (x, y, z, w) | m, - |
| `target`   | 6               | current target and next target positions                  | m    |
| `pressure` | 3 * n_segments  | chamber pressures over p_max                              | -    |
| `shape`    | 21              | feedback backbone points P_0..P_6 (sixths of rest length) | m    |
| `fbg`      | n_gratings      | FBG Bragg wavelength shifts (wang2023)                    | nm   |
| `strain`   | 3 * n_segments  | strain-gauge readings (zhao2021)                          | -    |
| `encoder`  | 3 * n_segments  | chamber lengths from cable encoders (zou2022)             | m    |
| `em`       | 7               | EM-tracked tip position + quaternion (ho2018)             | m, - |
| `image`    | H x W x 3 uint8 | eye-in-hand camera frame (wang2023), dict format only     | -    |
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable

import numpy as np
from gymnasium import spaces

from soft_gym._registry import Registry


@dataclass(frozen=True)
class ObservationPart:
    """One observation part.

    Attributes:
        name: the part's name in ``obs=``.
        content: what it holds, with units (the table above).
        value: ``value(env) -> np.ndarray`` at the env's current step (sensor parts read the
            step's measurement and need no function).
        bound: ``bound(env) -> (low, high)`` of a float part (sensor parts take the sensor's
            space).
        sensor: whether the part is a sensor's reading (its space and value are the sensor's).
    """

    name: str
    content: str
    value: Callable[[Any], np.ndarray] | None = None
    bound: Callable[[Any], tuple[np.ndarray, np.ndarray]] | None = None
    sensor: bool = False

    def space(self, env) -> spaces.Space:
        """The part's observation space in ``env``."""
        if self.sensor:
            return env.sensors[self.name].space(env.sim)
        low, high = self.bound(env)
        return spaces.Box(low.astype(np.float32), high.astype(np.float32), dtype=np.float32)

    def read(self, env) -> np.ndarray:
        """The part's value now (float32, or the sensor's own dtype)."""
        if self.sensor:
            return np.array(env.measurement[self.name])
        return np.asarray(self.value(env)).astype(np.float32)


def _reach(env) -> float:
    """A bound on any position the arm reaches (m): five times its longest extended length."""
    arm = env.arm
    return 5.0 * arm.length_m * max(s.max_extension_ratio for s in arm.segments)


def _pose(env) -> np.ndarray:
    position, quaternion = env.feedback_pose()
    return np.concatenate((position, quaternion))


def _targets(env) -> np.ndarray:
    current, upcoming = env.task.target(env.step_count)
    return np.concatenate((current, upcoming))


def _shape(env) -> np.ndarray:
    return np.asarray(env.feedback_source.shape_points(env.estimate), dtype=float).ravel()


def _pressure(env) -> np.ndarray:
    return env.sim.pressures_pa / env.arm.p_max_pa


def _positions(size: int) -> Callable[[Any], tuple[np.ndarray, np.ndarray]]:
    return lambda env: (np.full(size, -_reach(env)), np.full(size, _reach(env)))


def _pose_bound(env) -> tuple[np.ndarray, np.ndarray]:
    reach = _reach(env)
    return (np.concatenate((np.full(3, -reach), np.full(4, -1.0))),
            np.concatenate((np.full(3, reach), np.ones(4))))


def _pressure_bound(env) -> tuple[np.ndarray, np.ndarray]:
    return np.zeros(env.arm.n_chambers), np.ones(env.arm.n_chambers)


OBSERVATION_PARTS: Registry[ObservationPart] = Registry("obs part")
"""Every observation part by name, in the order of the table above."""
for _part in (
        ObservationPart("pose", "feedback tip position (m) + quaternion (x, y, z, w)", _pose,
                        _pose_bound),
        ObservationPart("target", "current and next target (m)", _targets, _positions(6)),
        ObservationPart("pressure", "chamber pressures over p_max", _pressure, _pressure_bound),
        ObservationPart("shape", "feedback backbone points P_0..P_6 (m)", _shape,
                        _positions(21)),
        ObservationPart("fbg", "FBG Bragg wavelength shifts (nm)", sensor=True),
        ObservationPart("strain", "strain-gauge readings", sensor=True),
        ObservationPart("encoder", "chamber lengths from cable encoders (m)",
                        sensor=True),
        ObservationPart("em", "EM-tracked tip position (m) + quaternion", sensor=True),
        ObservationPart("image", "eye-in-hand camera frame (uint8)", sensor=True)):
    OBSERVATION_PARTS.register(_part.name, _part)

STATE_PARTS = ("pose", "target", "pressure")
"""The default observation."""
