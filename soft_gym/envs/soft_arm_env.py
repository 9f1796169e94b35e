"""``SoftArmEnv``: a simulator, an arm preset, a task and a scenario composed into one Gymnasium env.

## Action space
``Box(-1, 1, (3 * n_segments,), float32)``: one entry per chamber (segment ``k`` owns chambers
``3k..3k+2`` at angles ``2 pi i / 3``).

* ``action_mode="absolute"`` (default): ``p = p_pre + (a + 1) / 2 (p_max - p_pre)`` (Pa).
* ``action_mode="delta"``: ``p_cmd <- clip(p_cmd + a * delta_fraction * p_max, p_pre, p_max)``.

Actions outside [-1, 1], non-finite, complex, boolean, non-numeric or of the wrong shape raise
``ValueError``.

## Observation space
``obs_format="flat"`` (default): a ``Box(float32)`` concatenating the parts named in ``obs`` in
that order; ``obs_format="dict"``: a ``Dict`` of the parts (needed for image parts). The parts
are the table of :mod:`soft_gym.envs.observations` (``OBSERVATION_PARTS``):

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

Sensors are simulated only when an observation part or ``sensors=`` asks for them; each keeps its
own rate (sample and hold) and noise (:mod:`soft_gym.sensors`).

## Feedback pose
``feedback=`` names the feedback source that fills the ``pose`` part, one of
``soft_gym.sensing.FEEDBACK_SOURCES`` (the table in :mod:`soft_gym.sensing.feedback`; default
``"fused"``: camera and F-emp fused by wang2023 eq. (18)). A source estimates from each step's
measurement alone. A source that calibrates (``calibrates``: the camera/F-emp pipeline of
``"fused"``, ``"camera"`` and ``"fbg"``, zhao2021's ``"strain_sr"``, zou2022's ``"encoder_dnn"``)
is calibrated when the env is created, by its procedure on a private simulator of the arm with
the env's fixed loads (:mod:`soft_gym.procedures.calibration`; the result is cached in memory
and on disk, :mod:`soft_gym.sensing.calibration_cache`), and again on
``reset(options={"recalibrate": True})``. It keeps learning across ``reset()`` calls;
``reset(seed=...)`` returns it to its calibrated state, and every reset gives it the episode's
generator for its own random draws (wang2023's RANSAC), so that a seed fixes an episode
exactly. ``faults=`` puts visual faults (:mod:`soft_gym.sensors.faults`) on the cameras
the env simulates: the eye-in-hand camera (``image``: the ``image`` part or camera-based
feedback) and the stereo pair (``stereo``: feedback ``"stereo"`` or ``sensors=("stereo",)``).
One description goes to every simulated camera, each with its own fault instances (the same
darkness for both; an occluder in front of each); a dict keyed by sensor name, e.g.
``{"stereo": "low_light", "image": None}``, gives each camera its own. An env that simulates
neither camera refuses them, as it does a dict naming a camera it does not simulate.

Every sensor the env simulates is read once per control step into one
:class:`~soft_gym.sensors.measurement.Measurement`; the observation, ``info`` and the feedback
source all read it.

## Domain randomisation
``randomization=True`` (or a dict of ranges, or a YAML path) draws, at every reset and from the
env's seed, a load (tip mass, filling container, swaying mass or push), a visual fault (camera
envs), a sensor-noise factor and the arm's stiffness and pneumatic time constant
(:mod:`soft_gym.scenarios.randomization`). They add to ``scenario=`` and ``faults=``; ``info``
holds the draw under ``randomization``. Off by default.

## Reward
The task's (:class:`~soft_gym.tasks.tasks.Task`):
``-||tip - target|| (m) - action_rate_weight * ||a_t - a_{t-1}||^2``.

## Episode end
Reach: truncated after ``episode_steps`` (default 100, 5 s). Track: truncated when the path's
last target has been presented.

## Bad input
Every argument is checked when the env is made: a wrong type or value raises ``ValueError``
naming the argument, the value and what is allowed (never a ``TypeError`` from deep inside, a
silent truncation or clip, a NaN reward, a hang or a runaway). Beyond types, the physical bounds:
``settle_s`` at most :data:`MAX_SETTLE_S`, ``action_rate_weight`` at most
:data:`MAX_ACTION_RATE_WEIGHT`, track episodes at most
:data:`~soft_gym.tasks.tasks.MAX_TRACK_STEPS` steps, targets, starts and waypoints within the arm's
reach (:attr:`~soft_gym.robots.spec.ArmSpec.max_reach_m`), loads within
:mod:`soft_gym.scenarios.loads`' bounds and the arm's
:attr:`~soft_gym.robots.spec.ArmSpec.max_load_n`. The track-only arguments (``path``, ``cycles``,
``speed_m_s``, ``waypoints_m``) are refused on the reach task, the reach-only ones (``target_m``,
``start_m``, ``tolerance_mm``, ``episode_steps``: a track episode's length is its path's) on the
track task, and ``sensor_config`` for a sensor the env does not simulate. ``reset`` takes
``seed`` (``None`` or an integer >= 0) and ``options`` (``None`` or a dict with the only key
``"recalibrate"``, a bool).

## Lifecycle
``step()`` needs a ``reset()`` first: a new env, and a copy (below), refuses it with
:class:`ResetNeededError` (gymnasium's ``ResetNeeded``, a ``RuntimeError`` too), whether it came
from ``gymnasium.make`` or was made directly. After ``close()``, ``step()`` and ``reset()`` raise
:class:`ClosedEnvError` (gymnasium's ``ClosedEnvironmentError``, a ``RuntimeError`` too): make a
new env; ``close()`` again does nothing. A ``reset`` refused for a bad argument changes nothing (the
episode goes on); one that fails on the way (a ``start_m`` out of reach) leaves the env un-reset.

## Copies
``pickle`` and ``copy.deepcopy`` make an independent env of the same configuration, rebuilt from
its :class:`~soft_gym.envs.config.EnvConfig` (its own simulator: closing either leaves the other running). The copy
starts as a freshly made env, un-reset: call ``reset()`` on it before stepping. Arguments that
cannot be copied (e.g. an object without copy support in ``scenario=``) make pickling raise a
``ValueError`` naming them; so does, for pickling only, a class or function defined inside a
function (e.g. a scenario element's class): pickle needs it defined at a module's top level,
``copy.deepcopy`` copies it as it is.

## Info
Ground truth: ``tip_position_m``, ``tip_quaternion``, ``target_m``, ``error_mm``, ``backbone_m``,
``chamber_lengths_m``, ``pressures_pa``, ``time_s``; ``sensors``: every active sensor's raw
reading by name; ``estimates`` (with the sensing pipeline): ``camera``, ``femp``, ``fused``
positions (m), ``em`` when an EM tracker runs, ``reprojection_error_px`` (``e_S``), ``lost``.
"""

from __future__ import annotations

import copy
import inspect
import os
from dataclasses import fields
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from soft_gym._validation import as_finite_array, require_bool, require_integer
from soft_gym.engines import ENGINES, EngineNeed, make_simulator, require_engine_features
from soft_gym.envs.config import EnvConfig, check_arguments
from soft_gym.envs.observations import OBSERVATION_PARTS
from soft_gym.envs.rendering import SceneRenderer
from soft_gym.papers import DEFAULT_PRESET
from soft_gym.procedures.calibration import calibrate, calibration_key
from soft_gym.procedures.positioning import drive_tip_to
from soft_gym.procedures.workspace import reachable_tips
from soft_gym.robots.actuation import Actuation
from soft_gym.robots.spec import ArmSpec
from soft_gym.scenarios import make_scenario
from soft_gym.scenarios.loads import SwayingMass, heaviest_total_load_n
from soft_gym.scenarios.randomization import DomainRandomizer, RandomizationConfig
from soft_gym.sensing import FEEDBACK_SOURCES, make_feedback_source
from soft_gym.sensing.feedback_base import CalibrationContext, FeedbackEstimate
from soft_gym.sensors import SENSORS, make_sensor
from soft_gym.sensors.faults import FAULT_SENSORS, copy_faults, faults_per_sensor, make_faults
from soft_gym.sensors.measurement import Measurement
from soft_gym.sensors.reading import measure
from soft_gym.tasks import ReachTask, Task, TrackTask
from soft_gym.tasks.tasks import within_reach

START_TOLERANCE_MM = 2.0
"""How close ``reset`` must bring the tip to ``start_m`` (mm)."""

RESET_OPTIONS = ("recalibrate",)
"""The keys ``reset(options=...)`` understands."""


class ResetNeededError(gym.error.ResetNeeded, RuntimeError):
    """``step()`` on an env (or a batch) that has not been reset since it was made or copied."""


class ClosedEnvError(gym.error.ClosedEnvironmentError, RuntimeError):
    """``step()`` or ``reset()`` on a closed env (or a batch, or a batch with a closed arm)."""


class SoftArmEnv(gym.Env):
    """Pneumatic soft continuum arm (see the module docstring for the spaces).

    The env composes a simulator (:mod:`soft_gym.engines`), the arm's sensors, a feedback
    source (:mod:`soft_gym.sensing`), loads (:mod:`soft_gym.scenarios`) and a task that owns
    the reward and the episode's end (:mod:`soft_gym.tasks`); it keeps ``reset`` and ``step``.

    Args:
        preset: arm preset name (``wang2023``, ``zhao2021``, ``zou2022``, ``ho2018``), an
            ArmSpec, or a path to an arm file (a ``str`` ending in ``.yaml``/``.yml`` or holding a
            path separator, or any ``os.PathLike``; :func:`soft_gym.robots.save_preset` writes
            one; docs/architecture.md, "Your own arm").
        engine: physics engine (:data:`soft_gym.engines.ENGINES`): ``"pybullet"`` (the default,
            the reference) or ``"mujoco"`` (the same arm, several times faster; no bodies beside
            the arm and no cameras, so no swaying mass, obstacle rod, camera-based feedback or
            ``render()``: refused here). Calibrations run on the reference engine.
        task: ``"reach"`` or ``"track"``.
        path: tracking path (``circle``, ``pentagram``, ``rectangle``, ``spiral``, ``star``,
            ``waypoints``), or a list of them to draw one per episode; track only.
        cycles: path repetitions; track only.
        speed_m_s: target speed (m/s); track only (default: a circle cycle in 20 s).
        waypoints_m: user path points (m), with ``path="waypoints"``.
        scenario: loads and disturbances (see :mod:`soft_gym.scenarios`).
        obs: observation parts (see the table above), in the order wanted.
        obs_format: ``"flat"`` (a float32 Box) or ``"dict"`` (a Dict of parts).
        sensors: further sensors to simulate for ``info["sensors"]`` only (e.g. ``("stereo",)``).
        sensor_config: keyword arguments per sensor name, e.g. ``{"fbg": {"noise_std_nm": 2e-3}}``.
        feedback: source of the ``pose`` part (see "Feedback pose" above).
        faults: visual faults on the simulated cameras (eye-in-hand ``image``, ``stereo`` pair):
            one description for all, or a dict keyed by sensor name (see "Feedback pose").
        randomization: domain randomisation per episode (``None``/``False`` off, ``True``
            defaults, a dict of ranges or a YAML path; see "Domain randomisation" above).
        sensing: options of the feedback source: the camera/F-emp pipeline's (``n_init``,
            ``femp``, ``fusion``, ``vision``, ``exploration``, ``map_steps``, ``femp_prior``),
            ``strain_sr``'s (:class:`~soft_gym.sensing.feedback.StrainShapeFeedback`), ``stereo``'s
            or ``encoder_dnn``'s (:mod:`soft_gym.papers.zou2022.feedback`).
        action_mode: ``"absolute"`` or ``"delta"``.
        delta_fraction: pressure change per unit action in delta mode, as a fraction of p_max.
        actuation: ``"pressure"`` (default) or ``"volume"``: each action drives a cylinder's
            stroke, ``s = (a + 1) / 2 max_stroke_m``, and the chamber pressure follows from the
            gas law with the chamber's present length (ho2018 Section 3.1, the paper's mode;
            :func:`soft_gym.robots.presets.volume_actuated`). Volume actuation takes
            ``action_mode="absolute"`` and no ``start_m``; ``pressure`` observations still
            report the chamber pressures, and the measurement carries no pressure command.
        action_rate_weight: weight of the action-rate penalty, in [0, ``MAX_ACTION_RATE_WEIGHT``].
        episode_steps: reach only: episode length in control steps (an integer >= 1; a track
            episode lasts until its path's last target, set by ``path``, ``cycles`` and
            ``speed_m_s``).
        settle_s: simulated time the arm rests before each episode (s, in [0, ``MAX_SETTLE_S``]).
        target_m: reach only: a fixed goal (m, base frame) instead of a random reachable one.
        start_m: reach only: the tip is driven there during ``reset`` (the episode's loads in
            place, steps not counted; :func:`soft_gym.procedures.positioning.drive_tip_to`), and
            the command starts at the pressures found; ``reset`` raises ``ValueError`` if the arm
            cannot get within 2 mm of it.
        tolerance_mm: reach only: the episode terminates when the tip is this close to the
            target (mm); ``info["step"]`` then gives the steps taken.
        render_mode: ``None`` or ``"rgb_array"``.
        render_size: (width, height) of rendered frames in pixels.

    Attributes:
        config: the checked arguments (:class:`~soft_gym.envs.config.EnvConfig`).
        arm: the arm (:class:`~soft_gym.robots.spec.ArmSpec`).
        sim: the simulator (:class:`~soft_gym.simulator.Simulator`).
        measurement: the last step's :class:`~soft_gym.sensors.measurement.Measurement`.
        estimate: the feedback source's last :class:`FeedbackEstimate`.
        step_count: control steps taken in the episode.
        closed: whether :meth:`close` has been called.
        ready: whether :meth:`step` may be called (reset since made or copied, not closed).

    Raises:
        ValueError: for any argument of a wrong type or value (see "Bad input" above), naming it.
    """

    metadata = {"render_modes": ["rgb_array"], "render_fps": 20}
    closed = False
    """Whether :meth:`close` has been called (``step`` and ``reset`` are then refused)."""
    _ready = False  # reset since made or copied, and not closed: step() may run

    def __init__(self, preset: str | os.PathLike | ArmSpec = DEFAULT_PRESET,
                 **kwargs: Any) -> None:
        config = kwargs.pop("config", None)
        if config is None:
            check_arguments(kwargs)
            config = EnvConfig(preset=preset, **kwargs)
        elif kwargs or preset != DEFAULT_PRESET:
            raise ValueError("config takes the place of every other argument: give either "
                             "config=EnvConfig(...) or keyword arguments")
        self._config_copy = config.copied()  # to rebuild from (see "Copies")
        self.config = config
        self.arm: ArmSpec = config.arm
        self.feedback_source = _make_feedback_source(config.feedback, config.sensing)
        config.check_feedback_needs(self.feedback_source.estimates_shape)
        self.loads = make_scenario(config.scenario)
        paths = config.paths()
        self.start_m = None if config.start_m is None else within_reach(self.arm, "start_m",
                                                                        config.start_m)
        self.tasks: list[Task] = self._make_tasks(paths)
        self.task = self.tasks[0]
        self.obs_parts = config.obs
        self.obs_format = config.obs_format
        self.feedback = config.feedback
        self.sensors = self._make_sensors()
        self._shown_sensors = {name for name, sensor in self.sensors.items()
                               if not getattr(sensor, "privileged", False)}
        randomization = RandomizationConfig.from_any(config.randomization)
        require_engine_features(config.engine, self._engine_needs(randomization))
        self.engine = config.engine
        self.sim = make_simulator(self.arm, config.engine)
        for load in self.loads:
            self.sim.add_load(load)
        gravity = float(np.linalg.norm(self.arm.gravity_base))
        fixed_load_n = heaviest_total_load_n(self.loads, gravity)
        self.randomizer = None if randomization is None else DomainRandomizer(
            randomization, n_links=self.sim.n_links, with_camera="image" in self.sensors,
            max_load_n=self.arm.max_load_n - fixed_load_n)
        self._draw = None
        self.actuation = Actuation(self.arm, config.action_mode, config.delta_fraction)
        self.action_mode = self.actuation.mode
        self.delta_fraction = self.actuation.delta_fraction
        self.action_rate_weight = config.action_rate_weight
        self.settle_s = config.settle_s
        self.render_mode = config.render_mode
        self.render_size = config.render_size
        # Gymnasium's metadata is a class attribute: this env's frame rate is its control rate
        self.metadata = {**self.metadata, "render_fps": 1.0 / self.arm.control_period_s}
        self._renderer: SceneRenderer | None = None  # built on the first render()

        n = self.arm.n_chambers
        self.action_space = spaces.Box(-1.0, 1.0, shape=(n,), dtype=np.float32)
        self._build_observation_space()
        self.step_count = 0
        self._last_action = np.zeros(n)
        self._command = self.actuation.initial_command_pa.copy()
        self.measurement: Measurement | None = None
        self.estimate: FeedbackEstimate | None = None
        self.feedback_source.prepare(self._calibration_context())
        self._calibrate(use_cache=True)

    # ------------------------------------------------------------------ composition
    def _engine_needs(self, randomization: RandomizationConfig | None) -> list[EngineNeed]:
        """What of this env needs which engine features (:func:`~soft_gym.engines.
        require_engine_features`): its loads, sensors, drawn loads and ``render()``, each with
        the change of arguments that runs without them (a scenario element has none)."""
        config = self.config
        needs = [EngineNeed(f"scenario element {load!r}",
                            frozenset(getattr(load, "engine_features", frozenset())))
                 for load in self.loads]
        for name, sensor in self.sensors.items():
            remedies, arguments = [], []
            if name in self.feedback_source.sensors:
                able = feedback_sources_on(config.engine, shape="shape" in config.obs)
                if able:
                    remedies.append(f"pass feedback= one of {able}")
                    arguments.append("feedback")
            if name in config.obs:
                remedies.append(f"leave {name!r} out of obs=")
                arguments.append("obs")
            if name in config.sensors:
                remedies.append(f"leave {name!r} out of sensors=")
                arguments.append("sensors")
            needs.append(EngineNeed(f"sensor {name!r} (feedback {config.feedback!r}, obs "
                                    f"{config.obs!r})", frozenset(sensor.engine_features),
                                    " and ".join(remedies), tuple(arguments)))
        if randomization is not None and randomization.load_weights.get("swaying_mass", 0) > 0:
            needs.append(EngineNeed(
                "randomization drawing swaying_mass loads (load_weights['swaying_mass'] = "
                f"{randomization.load_weights['swaying_mass']!r})", SwayingMass.engine_features,
                "set RandomizationConfig.load_weights['swaying_mass'] (randomization=) to 0 to "
                "draw none", ("randomization",)))
        if config.render_mode is not None:
            needs.append(EngineNeed(f"render_mode={config.render_mode!r}",
                                    frozenset({"rendering"}), "pass render_mode=None",
                                    ("render_mode",)))
        return needs

    def _make_tasks(self, paths: list[str]) -> list[Task]:
        """One task per path (the reach task has one), sharing the arm's reachable tips."""
        config = self.config
        needs_tips = config.task == "track" or config.target_m is None
        # a volume-driven arm's targets: its pressure-driven twin's workspace
        tips = reachable_tips(self.config.pressure_arm) if needs_tips else None
        if config.task == "reach":
            return [ReachTask(self.arm, config.episode_steps, target_m=config.target_m,
                              tolerance_mm=config.tolerance_mm, reachable_tips_m=tips,
                              action_rate_weight=config.action_rate_weight)]
        return [TrackTask(self.arm, tips, path=name, cycles=config.cycles,
                          speed_m_s=config.speed_m_s, waypoints_m=config.waypoints_m,
                          action_rate_weight=config.action_rate_weight) for name in paths]

    def _make_sensors(self) -> dict[str, Any]:
        """Every sensor an observation part, ``sensors=`` or the feedback source needs, with the
        user's configuration and the faults routed to its camera."""
        config = self.config
        wanted = ([part for part in config.obs if OBSERVATION_PARTS[part].sensor]
                  + list(config.sensors) + list(self.feedback_source.sensors))
        self._faults = self._route_faults(config.faults, wanted, config.feedback, config.obs,
                                          config.sensors)
        absent = [name for name in config.sensor_config if name not in wanted]
        if absent:
            raise ValueError(
                f"sensor_config[{absent[0]!r}] configures a sensor this env does not simulate "
                f"(it simulates {list(dict.fromkeys(wanted)) or 'none'}; feedback "
                f"{config.feedback!r}, obs {config.obs!r}, sensors {config.sensors!r}): add it "
                f"to sensors= or obs=")
        sensors = {}
        for name in dict.fromkeys(wanted):
            options = self._sensor_options(name)
            if name in self._faults:
                options["faults"] = self._faults[name]
            sensors[name] = make_sensor(name, **options)
        return sensors

    def _sensor_options(self, name: str) -> dict[str, Any]:
        """The keyword arguments of sensor ``name``: the source's defaults, then the user's."""
        defaults = self.feedback_source.sensor_options()
        return {**defaults.get(name, {}), **self.config.sensor_config.get(name, {})}

    def _build_observation_space(self) -> None:
        self._parts = [OBSERVATION_PARTS[part] for part in self.obs_parts]
        obs, part_spaces = self.obs_parts, {part.name: part.space(self) for part in self._parts}
        ends = np.cumsum([int(np.prod(part_spaces[part].shape)) for part in obs])
        self._part_slices = {part: slice(end - int(np.prod(part_spaces[part].shape)), end)
                             for part, end in zip(obs, ends)}
        if self.obs_format == "dict":
            self.observation_space = spaces.Dict(part_spaces)
            return
        not_flat = [part for part, space in part_spaces.items()
                    if not (isinstance(space, spaces.Box) and space.dtype == np.float32
                            and len(space.shape) == 1)]
        if not_flat:
            raise ValueError(f"obs parts {not_flat} are not flat float vectors: use "
                             f"obs_format='dict' for them (obs={obs!r})")
        self.observation_space = spaces.Box(
            np.concatenate([part_spaces[p].low for p in obs]),
            np.concatenate([part_spaces[p].high for p in obs]), dtype=np.float32)

    @staticmethod
    def _route_faults(faults: Any, wanted: list[str], feedback: str, obs: tuple[str, ...],
                      sensors: tuple[str, ...]) -> dict[str, Any]:
        """The fault description of each simulated camera (see "Feedback pose")."""
        cameras = [name for name in FAULT_SENSORS if name in wanted]
        per_sensor = faults_per_sensor(faults)
        if per_sensor is not None:
            absent = [name for name, value in per_sensor.items()
                      if value is not None and name not in cameras]
            if absent:
                raise ValueError(f"faults[{absent[0]!r}] is for a camera this env does not "
                                 f"simulate (it simulates {cameras or 'no camera'}; feedback "
                                 f"{feedback!r}, obs {obs!r}, sensors {sensors!r})")
            return {name: value for name, value in per_sensor.items() if value is not None}
        if faults is None:
            return {}
        if not cameras:
            raise ValueError(
                f"faults act on the eye-in-hand camera ('image') and the stereo pair ('stereo'), "
                f"and this env simulates neither (feedback {feedback!r}, obs {obs!r}, sensors "
                f"{sensors!r}): use feedback 'fused', 'camera' or 'fbg' or the 'image' part for "
                f"the eye-in-hand camera, feedback 'stereo' or sensors=('stereo',) for the "
                f"stereo pair")
        # the first camera takes the description itself, the others fresh copies: a fault
        # instance (its bodies, its episode draws) serves one camera
        return {name: faults if i == 0 else copy_faults(faults)
                for i, name in enumerate(cameras)}

    def observation_part(self, observation, part: str) -> np.ndarray:
        """The ``part`` of an observation from this env, flat or dict (what baselines read)."""
        if part not in self.obs_parts:
            raise ValueError(f"part must be one of this env's obs parts {list(self.obs_parts)}, "
                             f"got {part!r}")
        if isinstance(observation, dict):
            return np.asarray(observation[part])
        return np.asarray(observation)[self._part_slices[part]]

    @property
    def part_slices(self) -> dict[str, slice] | None:
        """Each observation part's slice of a flat observation (``obs_format="flat"``), in
        ``obs`` order; ``None`` for dict observations."""
        return None if self.obs_format == "dict" else dict(self._part_slices)

    @property
    def pipeline(self):
        """The camera/F-emp sensing pipeline of a ``fused``/``camera``/``fbg`` env, else None."""
        return getattr(self.feedback_source, "pipeline", None)

    def feedback_pose(self) -> tuple[np.ndarray, np.ndarray]:
        """Tip position (m) and quaternion from the feedback source, as of the last step."""
        return self.estimate.position_m.copy(), self.estimate.quaternion.copy()

    def _calibration_context(self) -> CalibrationContext:
        """What the feedback source and its calibration procedure know of this env: the arm,
        the rest before calibrating, the cache key, fresh sensors as this env configures them
        (without faults) and fresh copies of its fixed loads."""
        key = calibration_key(self.arm, self.loads, self.settle_s,
                              {name: self.config.sensor_config.get(name) for name in self.sensors})
        return CalibrationContext(
            spec=self.arm, settle_s=self.settle_s, key=key,
            make_sensor=lambda name: make_sensor(name, **self._sensor_options(name)),
            make_loads=self._copy_fixed_loads)

    def _copy_fixed_loads(self) -> list:
        """Fresh copies of the fixed loads (from the config copied before any was attached), for
        a calibration's private simulator."""
        if self._config_copy is None:
            raise ValueError(f"this env's arguments cannot be copied (scenario="
                             f"{self.config.scenario!r}), and feedback {self.feedback!r} "
                             f"calibrates on a private simulator with copies of the env's loads: "
                             f"give arguments that support copy.deepcopy")
        return make_scenario(copy.deepcopy(self._config_copy.scenario))

    def _calibrate(self, use_cache: bool) -> None:
        """Calibrate the feedback source (on a private simulator), or take its cached
        calibration."""
        calibrate(self.feedback_source, self._calibration_context(), use_cache=use_cache)

    def _sense(self) -> None:
        """Read every sensor once and let the feedback source estimate from that measurement."""
        self.measurement = measure(self.sensors, self.sim, self._command)
        self.estimate = self.feedback_source.estimate(self.measurement)

    # ------------------------------------------------------------------ gymnasium API
    def reset(self, *, seed: int | None = None, options: dict | None = None):
        """Start an episode (see the module docstring).

        Args:
            seed: ``None`` or an integer >= 0: seeds the env's random draws (targets, noise,
                randomisation) and returns the feedback source to its calibrated state.
            options: ``None`` or a dict; ``{"recalibrate": True}`` recalibrates the feedback
                source (``fused``, ``camera`` or ``fbg``).

        Raises:
            ValueError: a ``seed`` or ``options`` of a wrong type or value, naming it (the env
                is left as it was).
            ClosedEnvError: the env is closed.
        """
        if self.closed:
            raise self._not_ready_error("reset")
        if seed is not None:
            seed = require_integer("seed", seed, 0)  # a Python int, as gymnasium wants
        if options is not None:
            if not isinstance(options, dict):
                raise ValueError(f"options must be None or a dict with keys from "
                                 f"{list(RESET_OPTIONS)}, got {options!r} "
                                 f"({type(options).__name__})")
            unknown = [key for key in options if key not in RESET_OPTIONS]
            if unknown:
                raise ValueError(f"options keys must be among {list(RESET_OPTIONS)}, got "
                                 f"{unknown!r}")
            if "recalibrate" in options:
                require_bool("options['recalibrate']", options["recalibrate"])
            if options.get("recalibrate") and not self.feedback_source.calibrates:
                calibrating = [name for name in FEEDBACK_SOURCES
                               if FEEDBACK_SOURCES[name].calibrates]
                raise ValueError("options['recalibrate'] needs a feedback source that "
                                 f"calibrates (feedback one of {calibrating}), this env has "
                                 f"{self.feedback!r}")
        self._ready = False  # until this reset is through (a start_m out of reach stops it)
        super().reset(seed=seed)
        if options and options.get("recalibrate"):
            self._calibrate(use_cache=False)
        elif seed is not None:
            self.feedback_source.restore()
        self.feedback_source.reset(self.np_random)  # e.g. wang2023's RANSAC: seeded per episode
        if self.randomizer is not None:
            self._apply_draw(self.randomizer.sample(self.np_random))
        self.sim.reset(settle_s=self.settle_s)
        start_pressures = self._drive_to_start() if self.start_m is not None else None
        if len(self.tasks) > 1:
            self.task = self.tasks[int(self.np_random.integers(len(self.tasks)))]
        self.task.reset(self.np_random)
        for sensor in self.sensors.values():
            sensor.reset(self.sim, self.np_random)
        self._command = (self.actuation.initial_command_pa.copy() if start_pressures is None
                         else start_pressures)
        if self.arm.cylinders is not None:  # strokes, not pressures, are commanded
            self._command = None
        self._sense()
        self.step_count = 0
        self._last_action = np.zeros(self.arm.n_chambers)
        self._ready = True
        return self._observation(), self._info()

    def _drive_to_start(self) -> np.ndarray:
        """Hold the pressures that put the tip at ``start_m`` (found on the simulator with the
        episode's loads); the episode's clock starts at 0 from there."""
        pressures, _ = drive_tip_to(self.sim, self.start_m)
        self.sim.step_physics(max(self.settle_s, 1.0))
        self.sim.restart_clock()
        self.sim.restart_loads()  # timed loads start with the episode, as after a reset
        distance_mm = float(np.linalg.norm(self.sim.tip_pose()[0] - self.start_m)) * 1e3
        if distance_mm > START_TOLERANCE_MM:
            raise ValueError(
                f"start_m={np.round(self.start_m, 4).tolist()} is out of the {self.arm.name} "
                f"arm's reach with this episode's loads: the closest tip position found is "
                f"{distance_mm:.1f} mm away (at most {START_TOLERANCE_MM:g} mm allowed)")
        return pressures

    def _apply_draw(self, draw) -> None:
        """Put one episode's randomised loads, faults, noise and arm parameters in place."""
        self._draw = draw
        self.sim.clear_loads()
        for load in self.loads + draw.scenario:
            self.sim.add_load(load)
        self.sim.set_stiffness_scale(draw.stiffness_scale)
        self.sim.set_time_constant_scale(draw.time_constant_scale)
        for sensor in self.sensors.values():
            sensor.set_noise_scale(draw.sensor_noise_scale)
        if "image" in self.sensors:
            self.sensors["image"].set_faults(make_faults(self._faults.get("image")) + draw.faults)

    def step(self, action):
        if not self._ready:
            raise self._not_ready_error("step")
        action = self.check_action(action)
        self.command(action)
        self.sim.step_physics(self.arm.control_period_s)
        return self.finish_step(action)

    def command(self, action: np.ndarray) -> None:
        """The first half of :meth:`step`: command the pressures of an action checked by
        :meth:`check_action`; the physics (one ``control_period_s``) comes next, then
        :meth:`finish_step`. A batch of envs (:class:`~soft_gym.envs.vector.SoftArmVectorEnv`)
        steps their arms' physics together in between (and checks :attr:`ready` first)."""
        if self.arm.cylinders is not None:  # volume actuation: a stroke per chamber
            self._command = None
            self.sim.set_cylinder_strokes((action + 1.0) / 2.0 * self.arm.cylinders.max_stroke_m)
            return
        self._command = self.actuation.pressure(action, self._command)
        self.sim.set_pressures(self._command)

    def finish_step(self, action: np.ndarray):
        """The second half of :meth:`step`, after the physics: sense, reward, observation and
        info for the checked ``action``."""
        self.step_count += 1
        self._sense()
        tip, _ = self.sim.tip_pose()
        target, _ = self.task.target(self.step_count - 1)
        reward, error_m = self.task.reward(tip, target, action, self._last_action)
        self._last_action = action
        terminated = self.task.is_reached(error_m)
        truncated = not terminated and self.task.is_over(self.step_count)
        info = self._info(tip_target=(tip, target))
        return self._observation(), reward, terminated, truncated, info

    def render(self) -> np.ndarray | None:
        """An (H, W, 3) ``uint8`` frame of ``render_size`` in ``"rgb_array"`` mode, else None.

        The camera frames the preset's workspace, image up against gravity; over the PyBullet
        scene it draws a floor grid, the base plate, the targets and path, the loads and the
        ground-truth tip (ring) next to the feedback estimate (cross); see
        :mod:`soft_gym.envs.rendering`. Rendering never touches the physics.
        """
        if self.render_mode != "rgb_array":
            return None
        if self._renderer is None:
            self._renderer = self.make_renderer()
        target, upcoming = self.task.target(self.step_count)
        return self._renderer.render(
            self.sim, target_m=target, next_target_m=upcoming, path_m=self.task.path_m,
            estimate_m=None if self.estimate is None else self.feedback_pose()[0])

    def make_renderer(self, overlays: bool = True) -> SceneRenderer:
        """A :class:`~soft_gym.envs.rendering.SceneRenderer` of ``render_size`` framing this
        arm's reachable tips and every task's targets and path (``overlays=False``: the scene,
        floor and grid only)."""
        points = [reachable_tips(self.config.pressure_arm)]
        down = self.arm.gravity_base / max(np.linalg.norm(self.arm.gravity_base), 1e-9)
        for load in self.sim.loads:  # a swaying mass hangs below the tip
            if isinstance(load, SwayingMass):
                points.append(points[0] + down * (load.length_m + load.radius_m))
        for task in self.tasks:
            path = task.target(0)[0] if task.path_m is None else task.path_m
            points.append(np.asarray(path).reshape(-1, 3))
        return SceneRenderer(self.arm, self.render_size, np.vstack(points),
                             overlays=overlays)

    def close(self):
        """Release the simulator; ``step`` and ``reset`` are refused from then on
        (:class:`ClosedEnvError`). Closing again does nothing."""
        if self.closed:
            return
        self.closed, self._ready = True, False
        sim = getattr(self, "sim", None)  # None: the constructor stopped before making it
        if sim is not None:
            sim.close()

    @property
    def ready(self) -> bool:
        """Whether :meth:`step` may be called: reset since the env was made or copied, and not
        closed."""
        return self._ready

    def _not_ready_error(self, call: str) -> RuntimeError:
        """Why ``call`` (``"step"`` or ``"reset"``) cannot run now, as the error to raise."""
        if self.closed:
            return ClosedEnvError(f"{call}() on a closed {type(self).__name__}: the env is closed "
                                  f"(close() was called): make a new one")
        return ResetNeededError(f"call reset() before step(): this {type(self).__name__} has not "
                                f"been reset since it was made (a pickled or copied env starts "
                                f"un-reset too)")

    def __reduce__(self):
        """Pickle and deep-copy as a new env of the same configuration (see "Copies")."""
        if self._config_copy is None:
            raise ValueError(
                f"this {type(self).__name__} cannot be copied or pickled: one of its constructor "
                "arguments cannot be copied; make a new env with gymnasium.make(...) instead")
        state = {"spec": self.spec} if getattr(self, "spec", None) is not None else None
        return _rebuild_env, (type(self), self._config_copy), state

    # ------------------------------------------------------------------ helpers
    def check_action(self, action) -> np.ndarray:
        """``action`` as a float array of the action space's shape in [-1, 1], or a
        ``ValueError`` naming what is wrong."""
        if _is_boolean(action):
            raise ValueError(f"action must be real numbers (float), got booleans {action!r}")
        if _is_ragged(action):
            raise ValueError(f"action must have shape {self.action_space.shape} (one number per "
                             f"chamber), got a ragged sequence {action!r}")
        array = as_finite_array("action", action)
        if array.shape != self.action_space.shape:
            raise ValueError(f"action must have shape {self.action_space.shape}, got {array.shape}")
        if (np.abs(array) > 1.0 + 1e-6).any():
            raise ValueError(f"action must lie in [-1, 1], got {array.tolist()}")
        return array.clip(-1.0, 1.0)  # only float32 rounding beyond +-1 reaches here

    def _observation(self):
        parts = {part.name: part.read(self) for part in self._parts}
        if self.obs_format == "dict":
            return parts
        return np.concatenate([parts[p] for p in self.obs_parts]).astype(np.float32)

    def _info(self, tip_target: tuple[np.ndarray, np.ndarray] | None = None) -> dict:
        position, quaternion = self.sim.tip_pose()
        target = self.task.target(self.step_count)[0] if tip_target is None else tip_target[1]
        return {
            "tip_position_m": position, "tip_quaternion": quaternion,
            "target_m": np.array(target, dtype=float),
            "error_mm": float(np.linalg.norm(position - target) * 1000.0),
            "backbone_m": self.sim.backbone(), "chamber_lengths_m": self.sim.chamber_lengths(),
            "pressures_pa": self.sim.pressures_pa, "time_s": self.sim.time_s,
            "step": self.step_count,
            "sensors": {name: self._copy(reading)
                        for name, reading in self.measurement.readings.items()
                        if name in self._shown_sensors},
            **({"estimates": self._estimate_info()} if self.estimate.details else {}),
            **({"randomization": self._draw.describe()} if self._draw is not None else {}),
        }

    def _estimate_info(self) -> dict:
        info = dict(self.estimate.details)
        if "em" in self.measurement.readings:
            info["em"] = np.asarray(self.measurement["em"][:3], dtype=float)
        return info

    @staticmethod
    def _copy(reading):
        if isinstance(reading, dict):
            return {key: np.array(value) for key, value in reading.items()}
        return np.array(reading)


def _signature() -> inspect.Signature:
    """``SoftArmEnv(preset, *, task=..., ...)``: the arguments of :class:`EnvConfig` with their
    defaults (what ``help()``, IDEs and ``inspect`` show), and ``config=`` in their place."""
    positional, keyword = inspect.Parameter.POSITIONAL_OR_KEYWORD, inspect.Parameter.KEYWORD_ONLY
    parameters = [inspect.Parameter("self", positional)]
    parameters += [inspect.Parameter(field.name, positional if field.name == "preset" else keyword,
                                     default=field.default, annotation=field.type)
                   for field in fields(EnvConfig)]
    parameters.append(inspect.Parameter("config", keyword, default=None,
                                        annotation="EnvConfig | None"))
    return inspect.Signature(parameters)


SoftArmEnv.__init__.__signature__ = _signature()


def _is_boolean(value: Any) -> bool:
    """Whether ``value`` is a bool or an array of bools (which NumPy would take as 0 and 1)."""
    try:
        return np.asarray(value).dtype == np.bool_
    except (TypeError, ValueError):  # ragged: as_finite_array says what is wrong
        return False


def _is_ragged(value: Any) -> bool:
    """Whether ``value`` nests sequences of unequal lengths (NumPy makes no array of it)."""
    if isinstance(value, np.ndarray):
        return False
    try:
        np.asarray(value)
    except ValueError:
        return True
    except TypeError:  # not numbers at all: as_finite_array says what is wrong
        return False
    return False


def _rebuild_env(cls: type, config: EnvConfig) -> "SoftArmEnv":
    """A new ``cls(config=config)`` (the target of :meth:`SoftArmEnv.__reduce__`)."""
    return cls(config=config)


def feedback_sources_on(engine: str, shape: bool = False) -> list[str]:
    """The feedback sources (:data:`~soft_gym.sensing.FEEDBACK_SOURCES`) whose sensors the
    engine ``engine`` simulates (each sensor's ``engine_features`` among the engine's), sorted;
    with ``shape``, only those that estimate the backbone (for a ``shape`` part)."""
    offered = ENGINES[engine].features
    return sorted(name for name in FEEDBACK_SOURCES
                  if all(SENSORS[sensor].engine_features <= offered
                         for sensor in FEEDBACK_SOURCES[name].sensors)
                  and (FEEDBACK_SOURCES[name].estimates_shape or not shape))


def _make_feedback_source(feedback: Any, sensing: Any):
    """:func:`~soft_gym.sensing.make_feedback_source`, with a bad ``sensing`` option refused by
    name (the source's own message says which option and what is allowed)."""
    if not isinstance(feedback, str) or feedback not in FEEDBACK_SOURCES:
        raise ValueError(f"feedback must be one of {sorted(FEEDBACK_SOURCES)}, got {feedback!r}")
    if sensing is None:
        return make_feedback_source(feedback, None)
    try:
        return make_feedback_source(feedback, sensing)
    except ValueError as error:
        if str(error).startswith("sensing"):
            raise
        raise ValueError(f"sensing (options of feedback {feedback!r}): {error}") from error
