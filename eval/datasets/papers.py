"""The papers' exploration and calibration data as Minari datasets (one collector per paper).

Each collector runs the procedure the paper's method learns from, through the procedure's own
function, on the arm and sensors of an env it makes (ground-truth feedback, so nothing
calibrates), and returns a :class:`Collection`: the episodes, the env to recover and what the
data card needs. :data:`PAPER_DATASETS` names them:

| paper    | id                                   | procedure                                          |
|----------|--------------------------------------|----------------------------------------------------|
| zhao2021 | ``soft-arm/zhao2021/exploration-v0`` | :func:`~soft_gym.procedures.zhao2021_exploration.cached_exploration` |
| zou2022  | ``soft-arm/zou2022/stereo-labels-v0``| :func:`~soft_gym.procedures.zou2022_dataset.cached_dataset` |
| wang2023 | ``soft-arm/wang2023/calibration-v0`` | :func:`~soft_gym.procedures.wang2023_calibration.calibrate_pipeline` |
| ho2018   | ``soft-arm/ho2018/pretraining-v0``   | ``lwpr_rwr``'s pre-training walk                   |

zhao2021, zou2022 and wang2023 hold commands to equilibrium on a private simulator, so their
samples are stored as :func:`~soft_gym.datasets.episodes.procedure_episode` (one episode); ho2018's
walk is a Gymnasium episode of a copy of the env and is recorded as it ran
(:class:`~soft_gym.datasets.episodes.EpisodeRecorder`, handed to the walk through its ``wrap_env``
seam), so replaying its actions in the recovered env gives its observations back bit for bit.
Each collection also stores ``match``, the settings its method checks before it trains from the
dataset (:mod:`soft_gym.datasets.training`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import gymnasium as gym
import numpy as np

from soft_gym._registry import Registry
from soft_gym._validation import require_integer, require_seed
from soft_gym.datasets.episodes import (EpisodeRecorder, box_dict_space, episode_buffer,
                                        procedure_episode)


@dataclass
class Collection:
    """What a collector returns.

    Attributes:
        episodes: episode arrays (:func:`~soft_gym.datasets.episodes.procedure_episode` or
            :meth:`~soft_gym.datasets.episodes.EpisodeRecorder.episode_arrays`).
        env_id, env_kwargs: the env ``recover_environment()`` makes.
        observation_space, action_space: the stored spaces.
        procedure: the function that collected the samples (dotted name).
        settings: the procedure's settings (sizes, seed, ...), for the metadata and the card.
        raw: what the procedure itself returned (for tests and further use).
        match: what the method that trains on the data checks before it does (its arm, sensor
            models, sizes, seed; :mod:`soft_gym.datasets.training`), stored as metadata.
    """

    episodes: list[dict[str, Any]]
    env_id: str
    env_kwargs: dict[str, Any]
    observation_space: gym.Space
    action_space: gym.Space
    procedure: str
    settings: dict[str, Any]
    raw: Any = None
    match: dict[str, Any] = field(default_factory=dict)

    def buffers(self) -> list:
        """The episodes as Minari episode buffers."""
        return [episode_buffer(arrays, i) for i, arrays in enumerate(self.episodes)]

    @property
    def n_samples(self) -> int:
        """Steps over all episodes."""
        return int(sum(len(arrays["rewards"]) for arrays in self.episodes))


@dataclass(frozen=True)
class PaperDataset:
    """One paper's dataset: its id, its collector and its sizes.

    Attributes:
        paper: the paper's key.
        dataset_id: the Minari id.
        collect: ``collect(size, seed, progress, use_cache) -> Collection``.
        paper_size: the paper's sample counts (the collector's ``size``).
        quick_size: small counts for a quick look and the tests.
        summary: one line on what is recorded.
    """

    paper: str
    dataset_id: str
    collect: Callable[..., Collection]
    paper_size: dict[str, int] = field(default_factory=dict)
    quick_size: dict[str, int] = field(default_factory=dict)
    summary: str = ""


def _private_context(env_id: str, env_kwargs: dict[str, Any]):
    """The calibration context (arm, fresh sensors as the env configures them) of the env
    ``env_id`` with ``env_kwargs``; the env is closed again."""
    import soft_gym  # noqa: F401 - registers the env ids

    env = gym.make(env_id, **env_kwargs)
    try:
        return env.unwrapped._calibration_context()
    finally:
        env.close()


def _actions(spec, command_pa: np.ndarray) -> np.ndarray:
    """The absolute-mode env actions of the commanded pressures ``(n, n_chambers)`` (Pa)."""
    from soft_gym.robots.actuation import Actuation

    actuation = Actuation(spec, "absolute")
    return np.array([actuation.action(row) for row in np.asarray(command_pa, dtype=float)],
                    dtype=np.float32)


def _action_space(spec) -> gym.spaces.Box:
    return gym.spaces.Box(-1.0, 1.0, (spec.n_chambers,), np.float32)


def _size(size: dict[str, Any], name: str, low: int) -> int:
    if name not in size:
        raise ValueError(f"size must give {name!r}, got {sorted(size)}")
    return require_integer(f"size[{name!r}]", size[name], low)


# ------------------------------------------------------------------------------------ zhao2021
ZHAO2021_ENV = ("SoftArmReachZhao2021-v0",
                {"feedback": "ground_truth", "obs": ["pose", "target", "strain", "pressure"]})


def collect_zhao2021(size: dict[str, int], seed: int = 0, progress: bool = True,
                     use_cache: bool = True) -> Collection:
    """zhao2021 Section VI-A's random exploration with the env's strain gauges.

    :param size: ``n_free`` and ``n_loaded`` samples (paper: 4000 and 2000).
    :param seed: seeds the walk and the gauges' noise (``strain_sr``'s default: 0).
    :param progress: show the procedure's progress bar.
    :param use_cache: take the exploration from the calibration cache where ``strain_sr`` or
        ``local_ik_asdm`` already ran it (the same record), and keep it there.
    """
    from soft_gym.procedures.zhao2021_exploration import exploration_key, exploration_of
    from soft_gym.sensing import make_feedback_source

    seed = require_seed("seed", seed)
    n_free, n_loaded = _size(size, "n_free", 0), _size(size, "n_loaded", 0)
    env_id, env_kwargs = ZHAO2021_ENV
    context = _private_context(env_id, env_kwargs)
    config = make_feedback_source("strain_sr", {"n_free": n_free, "n_loaded": n_loaded,
                                                "seed": seed}).config
    gauges = context.make_sensor("strain")
    data = exploration_of(context.spec, gauges, config, use_cache=use_cache, progress=progress)
    observations = {"strain": data.readings}
    episode = procedure_episode(
        _actions(context.spec, data.pressures_pa), observations,
        {"command_pa": data.pressures_pa, "tip_position_m": data.backbone_m[:, -1],
         "key_points_m": data.key_points_m, "backbone_m": data.backbone_m,
         "tip_load_kg": data.tip_load_kg}, seed=seed)
    return Collection([episode], env_id, env_kwargs, box_dict_space(observations),
                      _action_space(context.spec),
                      "soft_gym.procedures.zhao2021_exploration.collect_exploration",
                      {"n_free": n_free, "n_loaded": n_loaded, "load_kg": config.load_kg,
                       "seed": seed, "settle_s": 1.0}, raw=data,
                      match=exploration_key(context.spec, gauges, config.n_free, config.n_loaded,
                                            config.load_kg, config.seed))


# ------------------------------------------------------------------------------------- zou2022
ZOU2022_ENV = ("SoftArmReachZou2022-v0",
               {"feedback": "ground_truth", "obs": ["pose", "target", "encoder", "pressure"]})
SPLITS = ("train", "validation", "test")
"""``infos["split"]``: 0, 1, 2 for the DNN's training, validation and test sets."""


def collect_zou2022(size: dict[str, int], seed: int = 0, progress: bool = True,
                    use_cache: bool = True) -> Collection:
    """zou2022 Section 5.1 (1)'s pressure sweep, labelled by ASES on the stereo pair.

    :param size: ``n_samples`` commands of the 0.1 bar grid (paper: 29791, each once).
    :param seed: seeds the sweep's order, the sensors' noise and the split (``encoder_dnn``'s
        default: 0).
    :param progress: show the procedure's progress bar.
    :param use_cache: take the data set from the calibration cache where ``encoder_dnn``
        already built it, and keep it there.
    """
    from soft_gym.procedures.zou2022_dataset import cached_dataset, dataset_key
    from soft_gym.sensing import make_feedback_source
    from soft_gym.sensors.stereo import StereoCamera

    seed = require_seed("seed", seed)
    n_samples = _size(size, "n_samples", 10)
    env_id, env_kwargs = ZOU2022_ENV
    context = _private_context(env_id, env_kwargs)
    source = make_feedback_source("encoder_dnn", {"n_samples": n_samples, "seed": seed})
    stereo = StereoCamera(**source.labelling_stereo_options())
    encoders = context.make_sensor("encoder")
    data = cached_dataset(context.spec, encoders, stereo, source.config, use_cache=use_cache,
                          progress=progress)
    split = np.full(len(data), -1.0)
    for index, name in enumerate(SPLITS):
        split[getattr(data, name)] = index
    observations = {"encoder": data.lengths_m}
    episode = procedure_episode(
        _actions(context.spec, data.pressures_pa), observations,
        {"command_pa": data.pressures_pa, "stereo_labels_m": data.labels_m,
         "true_points_m": data.truth_m, "tip_position_m": data.truth_m[:, -1],
         "augmented": data.augmented.astype(float), "split": split}, seed=seed)
    return Collection([episode], env_id, env_kwargs, box_dict_space(observations),
                      _action_space(context.spec),
                      "soft_gym.procedures.zou2022_dataset.collect_dataset",
                      {"n_samples": n_samples, "seed": seed, "n_lost": int(data.n_lost),
                       "settle_s": source.config.settle_s,
                       "pressure_step_pa": source.config.pressure_step_pa}, raw=data,
                      match=dataset_key(context.spec, encoders, stereo, source.config))


# ------------------------------------------------------------------------------------ wang2023
WANG2023_ENV = ("SoftArmReachWang2023-v0",
                {"feedback": "ground_truth", "obs": ["pose", "target", "fbg", "pressure"]})


class _CommandLog:
    """A simulator that remembers the last pressures commanded (Pa); otherwise the simulator."""

    def __init__(self, sim) -> None:
        self._sim = sim
        self.last_command_pa = np.asarray(sim.pressures_pa, dtype=float).copy()

    def set_pressures(self, pressures_pa) -> None:
        self.last_command_pa = np.array(pressures_pa, dtype=float)
        self._sim.set_pressures(pressures_pa)

    def __getattr__(self, name: str) -> Any:
        return getattr(self._sim, name)


class _SampleLog:
    """A sensing pipeline that keeps every calibration step's readings, its camera label and
    the arm's ground truth; otherwise the pipeline."""

    def __init__(self, pipeline, sim: _CommandLog) -> None:
        self._pipeline, self._sim = pipeline, sim
        self.rows: list[dict[str, np.ndarray]] = []

    def calibration_sample(self, step: int, measurement):
        sample = self._pipeline.calibration_sample(step, measurement)
        position, quaternion = self._sim.tip_pose()
        label_p, label_q = ((np.full(3, np.nan), np.full(4, np.nan)) if sample is None
                            else (np.asarray(sample[1], float), np.asarray(sample[2], float)))
        self.rows.append({
            "fbg": np.array(measurement["fbg"], dtype=float),
            "command_pa": self._sim.last_command_pa.copy(),
            "pressures_pa": np.array(self._sim.pressures_pa, dtype=float),
            "tip_position_m": np.array(position, dtype=float),
            "tip_quaternion": np.array(quaternion, dtype=float),
            "backbone_m": np.array(self._sim.backbone(), dtype=float),
            "camera_label_position_m": label_p, "camera_label_quaternion": label_q,
            "labelled": np.array(float(sample is not None))})
        return sample

    def __getattr__(self, name: str) -> Any:
        return getattr(self._pipeline, name)


def collect_wang2023(size: dict[str, int], seed: int = 0, progress: bool = True,
                     use_cache: bool = True) -> Collection:
    """wang2023 Section IV-B's sensing calibration: the spiral exploration whose camera-labelled
    FBG shifts initialise F-emp, as ``fused`` feedback calibrates.

    :param size: ``n_init`` exploration steps (paper: 450).
    :param seed: seeds the sensors' noise (the calibration's own: 0).
    :param progress: show the procedure's progress bar.
    :param use_cache: unused (the calibration caches its model, not its steps).
    """
    from soft_gym.procedures.calibration import private_simulator
    from soft_gym.procedures.wang2023_calibration import calibrate_pipeline
    from soft_gym.sensing import make_feedback_source
    from soft_gym.sensing.wang2023.pipeline import SensingPipeline

    seed = require_seed("seed", seed)
    n_init = _size(size, "n_init", 10)
    env_id, env_kwargs = WANG2023_ENV
    context = _private_context(env_id, env_kwargs)
    source = make_feedback_source("fused", {"n_init": n_init})
    pipeline = SensingPipeline(context.make_sensor("image"), context.make_sensor("fbg"),
                               **source.options)
    sim = private_simulator(context)
    try:
        sim.reset(settle_s=context.settle_s)
        logged_sim = _CommandLog(sim)
        log = _SampleLog(pipeline, logged_sim)
        labelled = calibrate_pipeline(log, logged_sim, np.random.default_rng(seed),
                                      progress=progress)
    finally:
        sim.close()
    columns = {key: np.stack([row[key] for row in log.rows]) for key in log.rows[0]}
    observations = {"fbg": columns.pop("fbg")}
    command = columns["command_pa"]
    episode = procedure_episode(_actions(context.spec, command), observations, columns,
                                seed=seed)
    return Collection([episode], env_id, env_kwargs, box_dict_space(observations),
                      _action_space(context.spec),
                      "soft_gym.procedures.wang2023_calibration.calibrate_pipeline",
                      {"n_init": n_init, "map_steps": pipeline.map_steps, "seed": seed,
                       "labelled_samples": int(labelled),
                       "control_period_s": context.spec.control_period_s},
                      raw=pipeline)


# -------------------------------------------------------------------------------------- ho2018
HO2018_ENV = ("SoftArmTrackHo2018-v0", {"feedback": "em"})


def collect_ho2018(size: dict[str, int], seed: int = 0, progress: bool = True,
                   use_cache: bool = True) -> Collection:
    """ho2018 Section 3.2's pre-training walk of ``lwpr_rwr``: straight lines between random
    actuator-space waypoints on an unloaded copy of the env, EM-tracked.

    :param size: ``pretrain_waypoints`` (paper: 80; 320 for the varying-load experiment).
    :param seed: ``lwpr_rwr``'s seed: the waypoints and the copy's reset (default: 0).
    :param progress: show the walk's progress bar.
    :param use_cache: unused (the pre-training caches its model, not its walk).
    """
    from agents.policies import make_policy

    import soft_gym  # noqa: F401 - registers the env ids

    seed = require_seed("seed", seed)
    waypoints = _size(size, "pretrain_waypoints", 2)
    env_id, env_kwargs = HO2018_ENV
    env = gym.make(env_id, **env_kwargs)
    sink: list[EpisodeRecorder] = []
    try:
        controller = make_policy("lwpr_rwr", env=env, pretrain_waypoints=waypoints, seed=seed,
                                 cache=False, progress=progress)
        transitions = controller._collect_pretraining_data(
            wrap_env=lambda walk_env: sink.append(EpisodeRecorder(walk_env)) or sink[-1])
        match = controller.walk_key()
    finally:
        env.close()
    recorder = sink[0]
    walk_spec = recorder.env.spec
    episode = recorder.episode_arrays(0)
    return Collection([episode], walk_spec.id, dict(walk_spec.kwargs),
                      recorder.observation_space, recorder.action_space,
                      "agents.controllers.lwpr_rwr.LWPRRWRController._collect_pretraining_data",
                      {"pretrain_waypoints": waypoints, "seed": seed,
                       "leg_decisions": controller.leg_decisions,
                       "hold_steps": controller.hold_steps,
                       "waypoint_range": controller.waypoint_range,
                       "rest_actuation": controller.rest_actuation,
                       "transitions": int(len(transitions[0]))},
                      raw=transitions, match=match)


PAPER_DATASETS: Registry[PaperDataset] = Registry("paper dataset")
"""The papers' datasets by paper key."""
PAPER_DATASETS.register("zhao2021", PaperDataset(
    "zhao2021", "soft-arm/zhao2021/exploration-v0", collect_zhao2021,
    {"n_free": 4000, "n_loaded": 2000}, {"n_free": 40, "n_loaded": 20},
    "random exploration: commands, strain-gauge readings, key points, backbone, tip load"))
PAPER_DATASETS.register("zou2022", PaperDataset(
    "zou2022", "soft-arm/zou2022/stereo-labels-v0", collect_zou2022,
    {"n_samples": 29791}, {"n_samples": 30},
    "pressure sweep: commands, encoder lengths, ASES stereo labels, true points, split"))
PAPER_DATASETS.register("wang2023", PaperDataset(
    "wang2023", "soft-arm/wang2023/calibration-v0", collect_wang2023,
    {"n_init": 450}, {"n_init": 20},
    "spiral calibration: commands, FBG shifts, camera labels, true tip pose and backbone"))
PAPER_DATASETS.register("ho2018", PaperDataset(
    "ho2018", "soft-arm/ho2018/pretraining-v0", collect_ho2018,
    {"pretrain_waypoints": 80}, {"pretrain_waypoints": 2},
    "pre-training walk: env actions, EM-feedback observations, true tip and backbone"))
