"""``SoftArmEnv``: a simulator, an arm preset, a task and a scenario composed into one Gymnasium env.

## Action space
``Box(-1, 1, (3 * n_segments,), float32)``: one entry per chamber (segment ``k`` owns chambers
``3k..3k+2`` at angles ``2 pi i / 3``).

* ``action_mode="absolute"`` (default): ``p = p_pre + (a + 1) / 2 (p_max - p_pre)`` (Pa).
* ``action_mode="delta"``: ``p_cmd <- clip(p_cmd + a * delta_fraction * p_max, p_pre, p_max)``.

Actions outside [-1, 1], non-finite or of the wrong shape raise ``ValueError``.

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

from soft_gym._validation import require_integer, require_non_negative
from soft_gym.envs.rendering import SceneRenderer
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
from soft_gym.sim import ArmSimulator
from soft_gym.tasks import ReachTask, TrackTask
from soft_gym.tasks.positioning import drive_tip_to
from soft_gym.tasks.tasks import within_reach
from soft_gym.tasks.workspace import reachable_tips

START_TOLERANCE_MM = 2.0
"""How close ``reset`` must bring the tip to ``start_m`` (mm)."""

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
        action_rate_weight: weight of the action-rate penalty.
        episode_steps: reach episode length in control steps.
        settle_s: simulated time the arm rests before each episode (s).
        target_m: reach only: a fixed goal (m, base frame) instead of a random reachable one.
        start_m: reach only: the tip is driven there during ``reset`` (the episode's loads in
            place, steps not counted; :func:`soft_gym.tasks.positioning.drive_tip_to`), and the
            command starts at the pressures found; ``reset`` raises ``ValueError`` if the arm
            cannot get within 2 mm of it.
        tolerance_mm: reach only: the episode terminates when the tip is this close to the
            target (mm); ``info["step"]`` then gives the steps taken.
        render_mode: ``None`` or ``"rgb_array"``.
        render_size: (width, height) of rendered frames in pixels.
    """

    metadata = {"render_modes": ["rgb_array"], "render_fps": 20}

    def __init__(self, preset: str | ArmSpec = "wang2023", task: str = "reach",
                 path: str = "circle", cycles: int = 1, speed_m_s: float | None = None,
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
        if not isinstance(preset, (str, ArmSpec)):
            raise ValueError(f"preset must be a preset name or an ArmSpec, got {preset!r}")
        self.spec_arm = preset if isinstance(preset, ArmSpec) else get_preset(preset)
        if task not in TASKS:
            raise ValueError(f"task must be one of {list(TASKS)}, got {task!r}")
        if not isinstance(obs, (str, list, tuple)) or not all(isinstance(p, str) for p in obs):
            raise ValueError(f"obs must be a part name or a sequence of them from "
                             f"{list(OBSERVATION_PARTS)}, got {obs!r}")
        obs = (obs,) if isinstance(obs, str) else tuple(obs)
        unknown = [part for part in obs if part not in OBSERVATION_PARTS]
        if unknown or not obs or len(set(obs)) != len(obs):
            raise ValueError(
                f"obs must be a non-empty tuple of distinct parts from {list(OBSERVATION_PARTS)}, "
                f"got {obs!r}")
        if obs_format not in OBS_FORMATS:
            raise ValueError(f"obs_format must be one of {list(OBS_FORMATS)}, got {obs_format!r}")
        sensors = (sensors,) if isinstance(sensors, str) else tuple(sensors)
        unknown = [name for name in sensors if name not in SENSORS]
        if unknown:
            raise ValueError(f"sensors must be names from {sorted(SENSORS)}, got {sensors!r}")
        sensor_config = dict(sensor_config or {})
        unknown = [name for name in sensor_config if name not in SENSORS]
        if unknown:
            raise ValueError(f"sensor_config keys must be sensor names from {sorted(SENSORS)}, "
                             f"got {sorted(sensor_config)!r}")
        self.feedback_source = make_feedback_source(feedback, sensing)
        if "shape" in obs and not self.feedback_source.estimates_shape:
            raise ValueError(f"obs part 'shape' needs a feedback source that estimates the "
                             f"backbone ('ground_truth' or 'strain_sr'), got feedback "
                             f"{feedback!r}")
        if render_mode not in (None, "rgb_array"):
            raise ValueError(f"render_mode must be None or 'rgb_array', got {render_mode!r}")
        action_rate_weight = require_non_negative("action_rate_weight", action_rate_weight)
        episode_steps = require_integer("episode_steps", episode_steps, 1)
        settle_s = require_non_negative("settle_s", settle_s)
        if (not isinstance(render_size, (tuple, list)) or len(render_size) != 2
                or not all(isinstance(v, (int, np.integer)) and not isinstance(v, bool)
                           and 1 <= v <= 4096 for v in render_size)):
            raise ValueError("render_size must be (width, height) in pixels, each an integer in "
                             f"[1, 4096], got {render_size!r}")
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
        self.sim = ArmSimulator(self.spec_arm)
        for load in self.loads:
            self.sim.add_load(load)
        self.obs_parts = obs
        self.obs_format = obs_format
        self.feedback = feedback
        wanted = ([part for part in obs if part in SENSORS] + list(sensors)
                  + list(self.feedback_source.sensors))
        self._faults = self._route_faults(faults, wanted, feedback, obs, sensors)
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
            config, n_links=len(self.sim.arm.station_link), with_camera="image" in self.sensors,
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
        self.sim.supply.set_time_constant_scale(draw.time_constant_scale)
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

    # ------------------------------------------------------------------ helpers
    def _check_action(self, action) -> np.ndarray:
        if np.iscomplexobj(action):
            raise ValueError(f"action must be real, got complex values {action!r}")
        try:
            array = np.asarray(action, dtype=np.float64)
        except (TypeError, ValueError) as error:
            raise ValueError(f"action must be numeric, got {action!r}") from error
        if array.shape != self.action_space.shape:
            raise ValueError(f"action must have shape {self.action_space.shape}, got {array.shape}")
        if not np.all(np.isfinite(array)):
            raise ValueError(f"action must be finite, got {array.tolist()}")
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
            value = np.r_[position, quaternion]
        elif part == "target":
            current, upcoming = self.task.target(self._step)
            value = np.r_[current, upcoming]
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
