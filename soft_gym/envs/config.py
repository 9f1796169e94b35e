"""``EnvConfig``: every argument of :class:`~soft_gym.envs.soft_arm_env.SoftArmEnv`, checked once.

The env is made of its config: ``SoftArmEnv(**kwargs)`` builds ``EnvConfig(**kwargs)``, which
refuses a wrong type or value with a ``ValueError`` naming the argument, the value and what is
allowed (the checks that need built parts, such as a sensor configuration for a sensor the env
does not simulate, follow when the env composes them). A pickled or copied env is rebuilt from a
deep copy of its config.
"""

from __future__ import annotations

import copy
import dataclasses
import inspect
import os
from dataclasses import dataclass, fields
from typing import Any

from soft_gym._validation import (require_choice, require_integer, require_names,
                                  require_non_negative)
from soft_gym.engines import ENGINES, REFERENCE_ENGINE
from soft_gym.envs.observations import OBSERVATION_PARTS, STATE_PARTS
from soft_gym.envs.rendering import check_render_size
from soft_gym.papers import DEFAULT_PRESET
from soft_gym.robots.arm_file import arm_from_preset
from soft_gym.robots.presets import volume_actuated
from soft_gym.robots.spec import ArmSpec
from soft_gym.sensing import FEEDBACK_SOURCES
from soft_gym.sensors import PUBLIC_SENSORS

MAX_SETTLE_S = 60.0
"""Longest rest before an episode (s): every preset settles within a few seconds, and each reset
simulates ``settle_s`` (an hour of rest would take minutes per reset)."""

MAX_ACTION_RATE_WEIGHT = 1000.0
"""Largest ``action_rate_weight``: its penalty for a full swing of every chamber (4 per chamber)
is then 10^4-10^5 times a 10 mm tracking error; larger weights only swamp the reward."""

OBS_FORMATS = ("flat", "dict")
TASKS = ("reach", "track")
ACTUATIONS = ("pressure", "volume")
"""How actions drive the chambers: pressures (every preset's default) or cylinder strokes (the
papers that drive volumes, :data:`soft_gym.robots.presets.CYLINDERS`)."""
_TRACK_ONLY = (("path", "circle"), ("cycles", 1), ("speed_m_s", None), ("waypoints_m", None))


class _DefaultEpisodeSteps(int):
    """``episode_steps`` left at its default: an ``int`` of its own type, so that a track env
    (whose episode length its path sets) can refuse any value given, 100 included."""


REACH_EPISODE_STEPS = _DefaultEpisodeSteps(100)
"""A reach episode's default length (control steps, 5 s)."""


@dataclass
class EnvConfig:
    """The arguments of :class:`~soft_gym.envs.soft_arm_env.SoftArmEnv` (see its docstring for
    each one's meaning and units), checked on construction and normalised (``obs`` and
    ``sensors`` as tuples, numbers as floats).

    Raises:
        ValueError: naming the argument, the value and what is allowed.
    """

    preset: str | os.PathLike | ArmSpec = DEFAULT_PRESET
    engine: str = REFERENCE_ENGINE
    task: str = "reach"
    path: str | list[str] = "circle"
    cycles: int = 1
    speed_m_s: float | None = None
    waypoints_m: Any = None
    scenario: Any = None
    obs: tuple[str, ...] = STATE_PARTS
    obs_format: str = "flat"
    sensors: tuple[str, ...] = ()
    sensor_config: dict | None = None
    feedback: str = "fused"
    faults: Any = None
    sensing: dict | None = None
    randomization: Any = None
    action_mode: str = "absolute"
    delta_fraction: float = 0.1
    actuation: str = "pressure"
    action_rate_weight: float = 0.001
    episode_steps: int = REACH_EPISODE_STEPS
    settle_s: float = 0.5
    target_m: Any = None
    start_m: Any = None
    tolerance_mm: float | None = None
    render_mode: str | None = None
    render_size: tuple[int, int] = (320, 240)

    def __post_init__(self) -> None:
        if not isinstance(self.preset, (str, os.PathLike, ArmSpec)):
            raise ValueError(f"preset must be a preset name, a path to an arm file or an "
                             f"ArmSpec, got {self.preset!r} ({type(self.preset).__name__})")
        self.arm = arm_from_preset(self.preset)
        require_choice("actuation", self.actuation, ACTUATIONS)
        # the same arm driven by pressures: its workspace stands for the volume-driven arm's
        self.pressure_arm = (self.arm if self.arm.cylinders is None
                             else dataclasses.replace(self.arm, cylinders=None))
        if self.actuation == "volume":
            self.arm = volume_actuated(self.arm)
            for name, default in (("action_mode", "absolute"), ("start_m", None)):
                if not _is_default(getattr(self, name), default):
                    raise ValueError(f"{name}={getattr(self, name)!r} needs pressure actuation: "
                                     f"actuation='volume' takes {name}={default!r}")
        elif self.arm.cylinders is not None:
            raise ValueError(f"actuation='pressure' needs an arm without cylinders; the "
                             f"{self.arm.name} arm given has ArmSpec.cylinders set: pass "
                             f"actuation='volume'")
        require_choice("engine", self.engine, ENGINES)
        require_choice("task", self.task, TASKS)
        if self.task == "reach":
            track_only = [f"{name}={getattr(self, name)!r}" for name, default in _TRACK_ONLY
                          if not _is_default(getattr(self, name), default)]
            if track_only:
                raise ValueError(f"path, cycles, speed_m_s and waypoints_m belong to the track "
                                 f"task (a reach env has no path), got {', '.join(track_only)} "
                                 f"with task='reach'")
        self.obs = _check_obs(self.obs)
        require_choice("obs_format", self.obs_format, OBS_FORMATS)
        self.sensors = require_names("sensors", self.sensors, PUBLIC_SENSORS)
        self.sensor_config = _check_sensor_config(self.sensor_config)
        if not (self.render_mode is None or isinstance(self.render_mode, str)
                and self.render_mode == "rgb_array"):
            raise ValueError(f"render_mode must be None or 'rgb_array', got {self.render_mode!r}")
        self.action_rate_weight = float(require_non_negative(
            "action_rate_weight", self.action_rate_weight, maximum=MAX_ACTION_RATE_WEIGHT))
        if self.task == "track" and not isinstance(self.episode_steps, _DefaultEpisodeSteps):
            raise ValueError(f"episode_steps belongs to the reach task: a track episode ends "
                             f"when its path's last target has been presented (its length set "
                             f"by path, cycles and speed_m_s), got "
                             f"episode_steps={self.episode_steps!r} with task='track'")
        if self.task == "reach":
            self.episode_steps = require_integer("episode_steps", self.episode_steps, 1)
        self.settle_s = float(require_non_negative("settle_s", self.settle_s,
                                                   maximum=MAX_SETTLE_S, unit="seconds"))
        self.render_size = tuple(check_render_size(self.render_size))

    def check_feedback_needs(self, estimates_shape: bool) -> None:
        """Refuse a ``shape`` part when the feedback source does not estimate the backbone."""
        if "shape" in self.obs and not estimates_shape:
            shaped = [name for name in FEEDBACK_SOURCES
                      if FEEDBACK_SOURCES[name].estimates_shape]
            raise ValueError(f"obs part 'shape' needs a feedback source that estimates the "
                             f"backbone (one of {shaped}), got feedback {self.feedback!r}")

    def paths(self) -> list[str]:
        """The track task's path names (one drawn per episode), checked."""
        paths = [self.path] if isinstance(self.path, str) or self.task == "reach" else self.path
        if (not isinstance(paths, (list, tuple)) or not paths
                or not all(isinstance(name, str) for name in paths)):
            raise ValueError(f"path must be a path name or a non-empty list of them, got "
                             f"{self.path!r}")
        if self.task != "reach" and any(value is not None for value in (
                self.target_m, self.start_m, self.tolerance_mm)):
            raise ValueError("target_m, start_m and tolerance_mm belong to the reach task, got "
                             f"task={self.task!r}")
        return list(paths)

    def __deepcopy__(self, memo: dict) -> "EnvConfig":
        """A deep copy, as ``copy.deepcopy`` makes of any object (it copies objects defined
        inside a function as they are, which pickling, below, cannot)."""
        twin = object.__new__(type(self))
        memo[id(self)] = twin
        twin.__dict__.update(copy.deepcopy(self.__dict__, memo))
        return twin

    def __reduce_ex__(self, protocol: Any):
        """Pickle as any object, after refusing an argument that holds a class or function
        defined inside a function (pickle finds classes by module and name, and fails there
        with an ``AttributeError`` that names neither the argument nor the element).

        Raises:
            ValueError: naming the argument, the object and where it must be defined.
        """
        for field in fields(self):
            local = _local_definition(getattr(self, field.name), set())
            if local is not None:
                is_definition = isinstance(local, type) or inspect.isfunction(local)
                kind, defined = ("", local) if is_definition else ("an instance of ", type(local))
                raise ValueError(
                    f"{field.name} holds {local!r}, {kind}{defined.__module__}."
                    f"{defined.__qualname__} defined inside a function: an env is pickled "
                    f"(pickle, a subprocess vector env) only with classes and functions defined "
                    f"at a module's top level; define it there (copy.deepcopy copies the env as "
                    f"it is)")
        return super().__reduce_ex__(protocol)

    def copied(self) -> "EnvConfig | None":
        """A deep copy to rebuild an env from, or ``None`` if an argument cannot be copied
        (e.g. an object without copy support in ``scenario=``)."""
        try:
            return copy.deepcopy(self)
        except Exception:  # noqa: BLE001 - any object without copy support
            return None


CONFIG_FIELDS = tuple(field.name for field in fields(EnvConfig))
"""The env's arguments, in order."""


def check_arguments(kwargs: dict[str, Any]) -> None:
    """Refuse keyword arguments the env does not take, naming them and listing the ones it
    takes (rather than Python's ``TypeError``)."""
    unknown = sorted(name for name in kwargs if name not in CONFIG_FIELDS)
    if unknown:
        raise ValueError(f"unknown env keyword argument(s) {unknown}: the env takes "
                         f"{list(CONFIG_FIELDS)}")


def _local_definition(value: Any, seen: set[int]) -> Any:
    """The first object in ``value`` (itself, a container's items, a dataclass's fields) that is,
    or whose class is, a class or function defined inside a function; ``None`` if none."""
    if id(value) in seen:
        return None
    seen.add(id(value))
    defined = value if isinstance(value, type) or inspect.isfunction(value) else type(value)
    if "<locals>" in getattr(defined, "__qualname__", ""):
        return value
    if isinstance(value, dict):
        items = [*value.keys(), *value.values()]
    elif isinstance(value, (list, tuple, set, frozenset)):
        items = list(value)
    elif dataclasses.is_dataclass(value) and not isinstance(value, type):
        items = [getattr(value, field.name) for field in fields(value)]
    else:
        return None
    for item in items:
        found = _local_definition(item, seen)
        if found is not None:
            return found
    return None


def _is_default(value: Any, default: Any) -> bool:
    """Whether ``value`` is ``default`` itself (same type and value; ``True`` is not ``1``)."""
    return value is default or (type(value) is type(default) and value == default)


def _check_obs(obs: Any) -> tuple[str, ...]:
    """``obs`` as a non-empty tuple of distinct part names from :data:`OBSERVATION_PARTS`."""
    names = list(OBSERVATION_PARTS)
    if not isinstance(obs, (str, list, tuple)) or not all(isinstance(p, str) for p in obs):
        raise ValueError(f"obs must be a part name or a sequence of them from {names}, got "
                         f"{obs!r}")
    obs = (obs,) if isinstance(obs, str) else tuple(obs)
    unknown = [part for part in obs if part not in OBSERVATION_PARTS]
    if unknown or not obs or len(set(obs)) != len(obs):
        raise ValueError(f"obs must be a non-empty tuple of distinct parts from {names}, got "
                         f"{obs!r}")
    return obs


def _check_sensor_config(sensor_config: Any) -> dict[str, dict]:
    """``sensor_config`` as a dict from sensor names to dicts of keyword arguments."""
    if sensor_config is None:
        return {}
    if not isinstance(sensor_config, dict):
        raise ValueError(f"sensor_config must be None or a dict from sensor names to dicts of "
                         f"keyword arguments, got {sensor_config!r} "
                         f"({type(sensor_config).__name__})")
    unknown = [name for name in sensor_config
               if not isinstance(name, str) or name not in PUBLIC_SENSORS]
    if unknown:
        raise ValueError(f"sensor_config keys must be sensor names from "
                         f"{sorted(PUBLIC_SENSORS)}, got {sorted(map(str, sensor_config))!r}")
    for name, options in sensor_config.items():
        if not isinstance(options, dict) or not all(isinstance(key, str) for key in options):
            raise ValueError(f"sensor_config[{name!r}] must be a dict of keyword arguments of the "
                             f"{name} sensor, got {options!r}")
    return {name: dict(options) for name, options in sensor_config.items()}
