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
that order; ``obs_format="dict"``: a ``Dict`` of the parts (needed for image parts).

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
``feedback=`` names the feedback source (:mod:`soft_gym.sensing.feedback`) that fills the ``pose``
part: ``"fused"`` (default; camera and F-emp fused by wang2023 eq. (18)), ``"camera"`` (the vision
tracker), ``"fbg"`` (F-emp), ``"em"`` (EM tracker), ``"strain_sr"`` (zhao2021's shape
reconstruction from the strain gauges, which also fills the ``shape`` part) or
``"ground_truth"``. The first three run the
sensing pipeline (:mod:`soft_gym.sensing.pipeline`): it is calibrated when the env is created
(vision map at rest, F-emp from ``n_init`` spiral exploration steps labelled by the camera; the
result is cached in memory and on disk, :mod:`soft_gym.sensing.calibration_cache`) and on
``reset(options={"recalibrate": True})``. It keeps learning across
``reset()`` calls; ``reset(seed=...)`` returns it to its calibrated state, so that a seed fixes an
episode exactly. ``faults=`` puts visual faults (:mod:`soft_gym.sensors.faults`) on the cameras
the env simulates: the eye-in-hand camera (``image``: the ``image`` part or camera-based
feedback) and the stereo pair (``stereo``: feedback ``"stereo"`` or ``sensors=("stereo",)``).
One description goes to every simulated camera, each with its own fault instances (the same
darkness for both; an occluder in front of each); a dict keyed by sensor name, e.g.
``{"stereo": "low_light", "image": None}``, gives each camera its own. An env that simulates
neither camera refuses them, as it does a dict naming a camera it does not simulate.

Every sensor the env simulates is read once per control step into one
:class:`~soft_gym.sensing.measurement.Measurement`; the observation, ``info`` and the feedback
source all read it.

## Domain randomisation
``randomization=True`` (or a dict of ranges, or a YAML path) draws, at every reset and from the
env's seed, a load (tip mass, filling container, swaying mass or push), a visual fault (camera
envs), a sensor-noise factor and the arm's stiffness and pneumatic time constant
(:mod:`soft_gym.scenarios.randomization`). They add to ``scenario=`` and ``faults=``; ``info``
holds the draw under ``randomization``. Off by default.

## Reward
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
``start_m``, ``tolerance_mm``) on the track task, and ``sensor_config`` for a sensor the env does
not simulate. ``reset`` takes ``seed`` (``None`` or an integer >= 0) and ``options`` (``None`` or a
dict with the only key ``"recalibrate"``, a bool).

## Copies
``pickle`` and ``copy.deepcopy`` make an independent env of the same configuration, rebuilt from
the constructor's arguments (its own simulator: closing either leaves the other running). The copy
starts as a freshly made env, un-reset: call ``reset()`` on it before stepping. Arguments that
cannot be copied (e.g. an object without copy support in ``scenario=``) make pickling raise a
``ValueError`` naming them.

## Info
Ground truth: ``tip_position_m``, ``tip_quaternion``, ``target_m``, ``error_mm``, ``backbone_m``,
``chamber_lengths_m``, ``pressures_pa``, ``time_s``; ``sensors``: every active sensor's raw
reading by name; ``estimates`` (with the sensing pipeline): ``camera``, ``femp``, ``fused``
positions (m), ``em`` when an EM tracker runs, ``reprojection_error_px`` (``e_S``), ``lost``.
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from soft_gym._validation import (as_finite_array, require_bool, require_choice,
                                  require_integer, require_names, require_non_negative)
from soft_gym.envs.rendering import SceneRenderer, check_render_size
from soft_gym.robots.actuation import Actuation
from soft_gym.robots.presets import get_preset
from soft_gym.robots.spec import ArmSpec
from soft_gym.scenarios import make_scenario
from soft_gym.sensors.faults import FAULT_SENSORS, copy_faults, faults_per_sensor, make_faults
from soft_gym.scenarios.loads import SwayingMass, heaviest_total_load_n
from soft_gym.scenarios.randomization import DomainRandomizer, RandomizationConfig
from soft_gym.sensing.feedback import (CalibrationContext, FeedbackEstimate,
                                       make_feedback_source)
from soft_gym.sensing.measurement import Measurement, measure
from soft_gym.sensors import SENSORS, make_sensor
from soft_gym.engines import make_simulator
from soft_gym.tasks import ReachTask, TrackTask
from soft_gym.tasks.positioning import drive_tip_to
from soft_gym.tasks.tasks import within_reach
from soft_gym.tasks.workspace import reachable_tips

START_TOLERANCE_MM = 2.0
"""How close ``reset`` must bring the tip to ``start_m`` (mm)."""

MAX_SETTLE_S = 60.0
"""Longest rest before an episode (s): every preset settles within a few seconds, and each reset
simulates ``settle_s`` (an hour of rest would take minutes per reset)."""

MAX_ACTION_RATE_WEIGHT = 1000.0
"""Largest ``action_rate_weight``: its penalty for a full swing of every chamber (4 per chamber)
is then 10^4-10^5 times a 10 mm tracking error; larger weights only swamp the reward."""

RESET_OPTIONS = ("recalibrate",)
"""The keys ``reset(options=...)`` understands."""

STATE_PARTS = ("pose", "target", "pressure")
"""The default observation."""
OBSERVATION_PARTS = STATE_PARTS + ("shape",) + tuple(name for name in SENSORS
                                                     if name != "stereo")
OBS_FORMATS = ("flat", "dict")
TASKS = ("reach", "track")


class SoftArmEnv(gym.Env):
    """Pneumatic soft continuum arm in PyBullet (see the module docstring for the spaces).

    Args:
        preset: arm preset name (``wang2023``, ``zhao2021``, ``zou2022``, ``ho2018``) or an ArmSpec.
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
            ``femp``, ``fusion``, ``vision``, ``exploration``, ``map_steps``, ``femp_prior``) or
            ``strain_sr``'s (:class:`~soft_gym.sensing.feedback.StrainShapeFeedback`).
        action_mode: ``"absolute"`` or ``"delta"``.
        delta_fraction: pressure change per unit action in delta mode, as a fraction of p_max.
        action_rate_weight: weight of the action-rate penalty, in [0, ``MAX_ACTION_RATE_WEIGHT``].
        episode_steps: reach episode length in control steps (an integer >= 1).
        settle_s: simulated time the arm rests before each episode (s, in [0, ``MAX_SETTLE_S``]).
        target_m: reach only: a fixed goal (m, base frame) instead of a random reachable one.
        start_m: reach only: the tip is driven there during ``reset`` (the episode's loads in
            place, steps not counted; :func:`soft_gym.tasks.positioning.drive_tip_to`), and the
            command starts at the pressures found; ``reset`` raises ``ValueError`` if the arm
            cannot get within 2 mm of it.
        tolerance_mm: reach only: the episode terminates when the tip is this close to the
            target (mm); ``info["step"]`` then gives the steps taken.
        render_mode: ``None`` or ``"rgb_array"``.
        render_size: (width, height) of rendered frames in pixels.

    Raises:
        ValueError: for any argument of a wrong type or value (see "Bad input" above), naming it.
    """

    metadata = {"render_modes": ["rgb_array"], "render_fps": 20}

    def __init__(self, preset: str | ArmSpec = "wang2023", task: str = "reach",
                 path: str | list[str] = "circle", cycles: int = 1,
                 speed_m_s: float | None = None,
                 waypoints_m: Any = None, scenario: Any = None,
                 obs: tuple[str, ...] = STATE_PARTS, obs_format: str = "flat",
                 sensors: tuple[str, ...] = (), sensor_config: dict | None = None,
                 feedback: str = "fused", faults: Any = None, sensing: dict | None = None,
                 randomization: Any = None,
                 action_mode: str = "absolute",
                 delta_fraction: float = 0.1, action_rate_weight: float = 0.001,
                 episode_steps: int = 100, settle_s: float = 0.5, target_m: Any = None,
                 start_m: Any = None, tolerance_mm: float | None = None,
                 render_mode: str | None = None, render_size: tuple[int, int] = (320, 240)) -> None:
        self._init_kwargs = _snapshot(locals())
        if not isinstance(preset, (str, ArmSpec)):
            raise ValueError(f"preset must be a preset name or an ArmSpec, got {preset!r} "
                             f"({type(preset).__name__})")
        self.spec_arm = preset if isinstance(preset, ArmSpec) else get_preset(preset)
        require_choice("task", task, TASKS)
        if task == "reach":
            track_only = [f"{name}={value!r}" for name, value, default in (
                ("path", path, "circle"), ("cycles", cycles, 1), ("speed_m_s", speed_m_s, None),
                ("waypoints_m", waypoints_m, None)) if not _is_default(value, default)]
            if track_only:
                raise ValueError(f"path, cycles, speed_m_s and waypoints_m belong to the track "
                                 f"task (a reach env has no path), got {', '.join(track_only)} "
                                 f"with task='reach'")
        if not isinstance(obs, (str, list, tuple)) or not all(isinstance(p, str) for p in obs):
            raise ValueError(f"obs must be a part name or a sequence of them from "
                             f"{list(OBSERVATION_PARTS)}, got {obs!r}")
        obs = (obs,) if isinstance(obs, str) else tuple(obs)
        unknown = [part for part in obs if part not in OBSERVATION_PARTS]
        if unknown or not obs or len(set(obs)) != len(obs):
            raise ValueError(
                f"obs must be a non-empty tuple of distinct parts from {list(OBSERVATION_PARTS)}, "
                f"got {obs!r}")
        require_choice("obs_format", obs_format, OBS_FORMATS)
        sensors = require_names("sensors", sensors, SENSORS)
        sensor_config = _check_sensor_config(sensor_config)
        self.feedback_source = _make_feedback_source(feedback, sensing)
        if "shape" in obs and not self.feedback_source.estimates_shape:
            raise ValueError(f"obs part 'shape' needs a feedback source that estimates the "
                             f"backbone ('ground_truth' or 'strain_sr'), got feedback "
                             f"{feedback!r}")
        if not (render_mode is None or isinstance(render_mode, str) and render_mode == "rgb_array"):
            raise ValueError(f"render_mode must be None or 'rgb_array', got {render_mode!r}")
        action_rate_weight = require_non_negative("action_rate_weight", action_rate_weight,
                                                  maximum=MAX_ACTION_RATE_WEIGHT)
        episode_steps = require_integer("episode_steps", episode_steps, 1)
        settle_s = require_non_negative("settle_s", settle_s, maximum=MAX_SETTLE_S,
                                        unit="seconds")
        render_size = check_render_size(render_size)
        self.loads = make_scenario(scenario)
        paths = [path] if isinstance(path, str) or task == "reach" else path
        if (not isinstance(paths, (list, tuple)) or not paths
                or not all(isinstance(name, str) for name in paths)):
            raise ValueError(f"path must be a path name or a non-empty list of them, got {path!r}")
        if task != "reach" and any(value is not None for value in (target_m, start_m,
                                                                     tolerance_mm)):
            raise ValueError("target_m, start_m and tolerance_mm belong to the reach task, got "
                             f"task={task!r}")
        self.start_m = None if start_m is None else within_reach(self.spec_arm, "start_m",
                                                                 start_m)
        self.tasks = [ReachTask(self.spec_arm, episode_steps, target_m=target_m,
                                tolerance_mm=tolerance_mm) if task == "reach" else
                      TrackTask(self.spec_arm, path=name, cycles=cycles, speed_m_s=speed_m_s,
                                waypoints_m=waypoints_m) for name in paths]
        self.task = self.tasks[0]
        self.sim = make_simulator(self.spec_arm)
        for load in self.loads:
            self.sim.add_load(load)
        self.obs_parts = obs
        self.obs_format = obs_format
        self.feedback = feedback
        wanted = ([part for part in obs if part in SENSORS] + list(sensors)
                  + list(self.feedback_source.sensors))
        self._faults = self._route_faults(faults, wanted, feedback, obs, sensors)
        absent = [name for name in sensor_config if name not in wanted]
        if absent:
            raise ValueError(
                f"sensor_config[{absent[0]!r}] configures a sensor this env does not simulate "
                f"(it simulates {list(dict.fromkeys(wanted)) or 'none'}; feedback {feedback!r}, "
                f"obs {obs!r}, sensors {sensors!r}): add it to sensors= or obs=")
        defaults = self.feedback_source.sensor_options()
        self.sensors = {}
        for name in dict.fromkeys(wanted):
            options = {**defaults.get(name, {}), **sensor_config.get(name, {})}
            if name in self._faults:
                options["faults"] = self._faults[name]
            self.sensors[name] = make_sensor(name, **options)
        config = RandomizationConfig.from_any(randomization)
        gravity = float(np.linalg.norm(self.spec_arm.gravity_base))
        fixed_load_n = heaviest_total_load_n(self.loads, gravity)
        self.randomizer = None if config is None else DomainRandomizer(
            config, n_links=self.sim.n_links, with_camera="image" in self.sensors,
            max_load_n=self.spec_arm.max_load_n - fixed_load_n)
        self._draw = None
        self._sensor_config = sensor_config
        self.actuation = Actuation(self.spec_arm, action_mode, delta_fraction)
        self.action_mode = self.actuation.mode
        self.delta_fraction = self.actuation.delta_fraction
        self.action_rate_weight = float(action_rate_weight)
        self.settle_s = float(settle_s)
        self.render_mode = render_mode
        self.render_size = tuple(render_size)
        # Gymnasium's metadata is a class attribute: this env's frame rate is its control rate
        self.metadata = {**self.metadata, "render_fps": 1.0 / self.spec_arm.control_period_s}
        self._renderer: SceneRenderer | None = None  # built on the first render()

        n = self.spec_arm.n_chambers
        self.action_space = spaces.Box(-1.0, 1.0, shape=(n,), dtype=np.float32)
        part_spaces = {part: self._part_space(part) for part in obs}
        ends = np.cumsum([int(np.prod(part_spaces[part].shape)) for part in obs])
        self._part_slices = {part: slice(end - int(np.prod(part_spaces[part].shape)), end)
                             for part, end in zip(obs, ends)}
        if obs_format == "dict":
            self.observation_space = spaces.Dict(part_spaces)
        else:
            not_flat = [part for part, space in part_spaces.items()
                        if not (isinstance(space, spaces.Box) and space.dtype == np.float32
                                and len(space.shape) == 1)]
            if not_flat:
                raise ValueError(f"obs parts {not_flat} are not flat float vectors: use "
                                 f"obs_format='dict' for them (obs={obs!r})")
            self.observation_space = spaces.Box(
                np.concatenate([part_spaces[p].low for p in obs]),
                np.concatenate([part_spaces[p].high for p in obs]), dtype=np.float32)
        self._p_high = self.spec_arm.p_max_pa
        self._step = 0
        self._last_action = np.zeros(n)
        self._command = self.actuation.initial_command_pa.copy()
        self._measurement: Measurement | None = None
        self._estimate: FeedbackEstimate | None = None
        self._calibrate(use_cache=True)

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
    def pipeline(self):
        """The camera/F-emp sensing pipeline of a ``fused``/``camera``/``fbg`` env, else None."""
        return getattr(self.feedback_source, "pipeline", None)

    def feedback_pose(self) -> tuple[np.ndarray, np.ndarray]:
        """Tip position (m) and quaternion from the feedback source, as of the last step."""
        return self._estimate.position_m.copy(), self._estimate.quaternion.copy()

    def _calibrate(self, use_cache: bool) -> None:
        """Calibrate the feedback source at rest, or take its cached calibration."""
        key = {"arm": repr(self.spec_arm), "scenario": repr(self.loads),
               "settle_s": self.settle_s,
               "sensors": repr(sorted((name, repr(self._sensor_config.get(name)))
                                      for name in self.sensors))}
        self.feedback_source.calibrate(
            CalibrationContext(self.sim, self.sensors, self.settle_s, key), use_cache=use_cache)

    def _sense(self) -> None:
        """Read every sensor once and let the feedback source estimate from that measurement."""
        self._measurement = measure(self.sensors, self.sim)
        self._estimate = self.feedback_source.estimate(self._measurement, self.sim)

    def _part_space(self, part: str) -> spaces.Space:
        if part in self.sensors:
            return self.sensors[part].space(self.sim)
        reach = 5.0 * self.spec_arm.length_m * max(
            s.max_extension_ratio for s in self.spec_arm.segments)
        if part == "pose":
            low, high = np.r_[np.full(3, -reach), np.full(4, -1.0)], np.r_[np.full(3, reach), np.ones(4)]
        elif part == "target":
            low, high = np.full(6, -reach), np.full(6, reach)
        elif part == "shape":
            low, high = np.full(21, -reach), np.full(21, reach)
        else:
            low, high = np.zeros(self.spec_arm.n_chambers), np.ones(self.spec_arm.n_chambers)
        return spaces.Box(low.astype(np.float32), high.astype(np.float32), dtype=np.float32)

    # ------------------------------------------------------------------ gymnasium API
    def reset(self, *, seed: int | None = None, options: dict | None = None):
        """Start an episode (see the module docstring).

        Args:
            seed: ``None`` or an integer >= 0: seeds the env's random draws (targets, noise,
                randomisation) and returns the feedback source to its calibrated state.
            options: ``None`` or a dict; ``{"recalibrate": True}`` recalibrates the feedback
                source (``fused``, ``camera`` or ``fbg``).

        Raises:
            ValueError: a ``seed`` or ``options`` of a wrong type or value, naming it.
        """
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
        super().reset(seed=seed)
        if options and options.get("recalibrate"):
            if not self.feedback_source.calibrates:
                raise ValueError("options['recalibrate'] needs a feedback source that "
                                 "calibrates (feedback 'fused', 'camera' or 'fbg'), this env has "
                                 f"{self.feedback!r}")
            self._calibrate(use_cache=False)
        elif seed is not None:
            self.feedback_source.restore()
        if self.randomizer is not None:
            self._apply_draw(self.randomizer.sample(self.np_random))
        self.sim.reset(settle_s=self.settle_s)
        start_pressures = self._drive_to_start() if self.start_m is not None else None
        if len(self.tasks) > 1:
            self.task = self.tasks[int(self.np_random.integers(len(self.tasks)))]
        self.task.reset(self.np_random)
        for sensor in self.sensors.values():
            sensor.reset(self.sim, self.np_random)
        self._sense()
        self._step = 0
        self._last_action = np.zeros(self.spec_arm.n_chambers)
        self._command = (self.actuation.initial_command_pa.copy() if start_pressures is None
                         else start_pressures)
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
                f"start_m={np.round(self.start_m, 4).tolist()} is out of the {self.spec_arm.name} "
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
        action = self._check_action(action)
        self._command = self.actuation.pressure(action, self._command)
        self.sim.set_pressures(self._command)
        self.sim.step_physics(self.spec_arm.control_period_s)
        self._step += 1
        self._sense()
        tip, _ = self.sim.tip_pose()
        target, _ = self.task.target(self._step - 1)
        error_m = float(np.linalg.norm(tip - target))
        rate = float(np.sum((action - self._last_action) ** 2))
        reward = -error_m - self.action_rate_weight * rate
        self._last_action = action
        terminated = self.task.is_reached(error_m)
        truncated = not terminated and self.task.is_over(self._step)
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
        target, upcoming = self.task.target(self._step)
        return self._renderer.render(
            self.sim, target_m=target, next_target_m=upcoming,
            path_m=getattr(self.task, "polyline_m", None),
            estimate_m=None if self._estimate is None else self.feedback_pose()[0])

    def make_renderer(self, overlays: bool = True) -> SceneRenderer:
        """A :class:`~soft_gym.envs.rendering.SceneRenderer` of ``render_size`` framing this
        arm's reachable tips and every task's targets and path (``overlays=False``: the scene,
        floor and grid only)."""
        points = [reachable_tips(self.spec_arm)]
        down = self.spec_arm.gravity_base / max(np.linalg.norm(self.spec_arm.gravity_base), 1e-9)
        for load in self.sim.loads:  # a swaying mass hangs below the tip
            if isinstance(load, SwayingMass):
                points.append(points[0] + down * (load.length_m + load.radius_m))
        for task in self.tasks:
            path = getattr(task, "polyline_m", task.target(0)[0])
            points.append(np.asarray(path).reshape(-1, 3))
        return SceneRenderer(self.spec_arm, self.render_size, np.vstack(points),
                             overlays=overlays)

    def close(self):
        self.sim.close()

    def __reduce__(self):
        """Pickle and deep-copy as a new env of the same configuration (see "Copies")."""
        if self._init_kwargs is None:
            raise ValueError(
                f"this {type(self).__name__} cannot be copied or pickled: one of its constructor "
                "arguments cannot be copied; make a new env with gymnasium.make(...) instead")
        state = {"spec": self.spec} if getattr(self, "spec", None) is not None else None
        return _rebuild_env, (type(self), self._init_kwargs), state

    # ------------------------------------------------------------------ helpers
    def _check_action(self, action) -> np.ndarray:
        if _is_boolean(action):
            raise ValueError(f"action must be real numbers (float), got booleans {action!r}")
        array = as_finite_array("action", action)
        if array.shape != self.action_space.shape:
            raise ValueError(f"action must have shape {self.action_space.shape}, got {array.shape}")
        if np.any(np.abs(array) > 1.0 + 1e-6):
            raise ValueError(f"action must lie in [-1, 1], got {array.tolist()}")
        return np.clip(array, -1.0, 1.0)  # only float32 rounding beyond +-1 reaches here

    def _observation(self):
        parts = {part: self._part(part) for part in self.obs_parts}
        if self.obs_format == "dict":
            return parts
        return np.concatenate([parts[p] for p in self.obs_parts]).astype(np.float32)

    def _part(self, part: str) -> np.ndarray:
        if part in self.sensors:
            return np.array(self._measurement[part])
        if part == "pose":
            position, quaternion = self.feedback_pose()
            value = np.concatenate((position, quaternion))
        elif part == "target":
            current, upcoming = self.task.target(self._step)
            value = np.concatenate((current, upcoming))
        elif part == "shape":
            value = np.asarray(self.feedback_source.shape_points(self._estimate, self.sim),
                               dtype=float).ravel()
        else:
            value = self.sim.pressures_pa / self._p_high
        return value.astype(np.float32)

    def _info(self, tip_target: tuple[np.ndarray, np.ndarray] | None = None) -> dict:
        position, quaternion = self.sim.tip_pose()
        target = self.task.target(self._step)[0] if tip_target is None else tip_target[1]
        return {
            "tip_position_m": position, "tip_quaternion": quaternion,
            "target_m": np.array(target, dtype=float),
            "error_mm": float(np.linalg.norm(position - target) * 1000.0),
            "backbone_m": self.sim.backbone(), "chamber_lengths_m": self.sim.chamber_lengths(),
            "pressures_pa": self.sim.pressures_pa, "time_s": self.sim.time_s,
            "step": self._step,
            "sensors": {name: self._copy(reading)
                        for name, reading in self._measurement.readings.items()},
            **({"estimates": self._estimate_info()} if self._estimate.details else {}),
            **({"randomization": self._draw.describe()} if self._draw is not None else {}),
        }

    def _estimate_info(self) -> dict:
        info = dict(self._estimate.details)
        if "em" in self._measurement.readings:
            info["em"] = np.asarray(self._measurement["em"][:3], dtype=float)
        return info

    @staticmethod
    def _copy(reading):
        if isinstance(reading, dict):
            return {key: np.array(value) for key, value in reading.items()}
        return np.array(reading)


def _snapshot(arguments: dict[str, Any]) -> dict[str, Any] | None:
    """The constructor's arguments (``locals()`` on entry) deep-copied as given, to rebuild the env
    from when it is pickled or copied; ``None`` if one cannot be copied (pickling then raises)."""
    import copy

    kwargs = {name: value for name, value in arguments.items()
              if name not in ("self", "__class__")}
    try:
        return copy.deepcopy(kwargs)
    except Exception:  # noqa: BLE001 - any object without copy support
        return None


def _is_default(value: Any, default: Any) -> bool:
    """Whether ``value`` is ``default`` itself (same type and value; ``True`` is not ``1``)."""
    return value is default or (type(value) is type(default) and value == default)


def _is_boolean(value: Any) -> bool:
    """Whether ``value`` is a bool or an array of bools (which NumPy would take as 0 and 1)."""
    try:
        return np.asarray(value).dtype == np.bool_
    except (TypeError, ValueError):  # ragged: as_finite_array says what is wrong
        return False


def _rebuild_env(cls: type, kwargs: dict[str, Any]) -> "SoftArmEnv":
    """A new ``cls(**kwargs)`` (the target of :meth:`SoftArmEnv.__reduce__`)."""
    return cls(**kwargs)


def _check_sensor_config(sensor_config: Any) -> dict[str, dict]:
    """``sensor_config`` as a dict from sensor names to dicts of keyword arguments."""
    if sensor_config is None:
        return {}
    if not isinstance(sensor_config, dict):
        raise ValueError(f"sensor_config must be None or a dict from sensor names to dicts of "
                         f"keyword arguments, got {sensor_config!r} "
                         f"({type(sensor_config).__name__})")
    unknown = [name for name in sensor_config if not isinstance(name, str) or name not in SENSORS]
    if unknown:
        raise ValueError(f"sensor_config keys must be sensor names from {sorted(SENSORS)}, "
                         f"got {sorted(map(str, sensor_config))!r}")
    for name, options in sensor_config.items():
        if not isinstance(options, dict) or not all(isinstance(key, str) for key in options):
            raise ValueError(f"sensor_config[{name!r}] must be a dict of keyword arguments of the "
                             f"{name} sensor, got {options!r}")
    return {name: dict(options) for name, options in sensor_config.items()}


def _make_feedback_source(feedback: Any, sensing: Any):
    """:func:`~soft_gym.sensing.feedback.make_feedback_source`, with a bad ``sensing`` option
    refused by name (the source's own message says which option and what is allowed)."""
    from soft_gym.sensing.feedback_base import FEEDBACK_SOURCES

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
