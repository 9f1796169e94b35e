"""zou2022's shape data set (Section 5.1 (1)) and the DNN trained on it (Section 5).

The data set drives a private simulator of the arm, labelled by ASES on a private stereo pair, so
it lives here, above the estimators: :func:`collect_dataset` records commands, encoder lengths,
ASES labels and the true key points (:class:`~soft_gym.papers.zou2022.shape_dnn.ZouDataset`),
:func:`cached_dataset` keeps it in the calibration cache, and :func:`cached_shape_dnn` trains
:class:`~soft_gym.papers.zou2022.shape_dnn.ShapeDNN` on it once per arm, sensors and recipe.
"""

from __future__ import annotations

import copy
from dataclasses import asdict
from typing import Any

import numpy as np
from tqdm.auto import tqdm

from soft_gym.engines import make_simulator
from soft_gym.robots.spec import ArmSpec
from soft_gym.sensing.calibration_cache import cached, sensor_description
from soft_gym.papers.zou2022.shape_dnn import (N_POINTS, ShapeDNN, ShapeDNNConfig, ZouDataset,
                                        default_stereo, rotate_about_axis, true_shape_points)
from soft_gym.papers.zou2022.stereo_shape import ASESConfig, estimate_stereo_shape
from soft_gym.sensors.stereo import StereoCamera
from soft_gym.procedures.calibration import dataset_options
from soft_gym.sensing.feedback_base import CalibrationContext, FeedbackSource


def collect_dataset(spec: ArmSpec, encoders, stereo=None,
                    config: ShapeDNNConfig = ShapeDNNConfig(), ases_config=None,
                    progress: bool = True) -> ZouDataset:
    """Random pressure exploration of ``spec`` labelled by ASES (zou2022 Section 5.1 (1)).

    Args:
        spec: the arm (one or more three-chamber segments).
        encoders: the :class:`~soft_gym.sensors.encoder.ChamberEncoders` model whose readings
            are the inputs (a private copy is used, its noise seeded from ``config.seed``).
        stereo: the :class:`~soft_gym.sensors.stereo.StereoCamera` labelling the samples (a
            private copy, in a clear view); ``None``: :func:`default_stereo`.
        config: samples, grid, settling, augmentation, split and seed.
        ases_config: :class:`~soft_gym.papers.zou2022.stereo_shape.ASESConfig` (``None``: defaults).
        progress: show a progress bar.
    """
    if not isinstance(spec, ArmSpec):
        raise ValueError(f"spec must be an ArmSpec, got {spec!r}")
    if not isinstance(config, ShapeDNNConfig):
        raise ValueError(f"config must be a ShapeDNNConfig, got {config!r}")
    ases_config = ASESConfig() if ases_config is None else ases_config
    rng = np.random.default_rng(config.seed)
    encoder = copy.copy(encoders)
    encoder.rng, encoder._last = np.random.default_rng([config.seed, 1]), None
    camera = _private_camera(default_stereo() if stereo is None else stereo, config.seed)
    commands = grid_commands(spec, config, rng)
    n = config.n_samples
    pressures = np.empty((n, spec.n_chambers))
    lengths = np.empty((n, spec.n_chambers))
    labels = np.full((n, N_POINTS, 3), np.nan)
    truth = np.empty((n, N_POINTS, 3))
    lost = np.zeros(n, dtype=bool)
    sim = make_simulator(spec)
    try:
        sim.reset(settle_s=config.settle_s)
        for i in tqdm(range(n), desc=f"{spec.name} exploration", disable=not progress,
                      leave=False):
            command = commands[i]
            sim.set_pressures(command)
            sim.step_physics(config.settle_s)
            pressures[i] = command
            lengths[i] = encoder.sample(sim)
            truth[i] = true_shape_points(spec, sim.backbone())
            reading = camera.sample(sim)
            shape = estimate_stereo_shape(reading["left"], reading["right"], reading["P_left"],
                                          reading["P_right"], ases_config)
            lost[i] = shape.lost
            labels[i] = shape.points_m
    finally:
        sim.close()
    good = np.flatnonzero(~lost)
    if good.size < 10:
        raise ValueError(f"ASES lost the arm in {int(lost.sum())} of {n} samples: too few left "
                         "to train (check the stereo camera and the ASES settings)")
    augmented = np.zeros(n, dtype=bool)
    if config.augment:
        for i in np.flatnonzero(lost):  # the paper's supplement: a good sample, turned
            source, turns = int(rng.choice(good)), int(rng.choice((1, 2)))
            lengths[i], labels[i] = rotate_about_axis(lengths[source], labels[source], turns)
            _, truth[i] = rotate_about_axis(lengths[source], truth[source], turns)
            pressures[i] = rotate_about_axis(pressures[source], np.zeros(3), turns)[0]
            augmented[i] = True
        keep = np.arange(n)
    else:
        keep = good
    data = ZouDataset(pressures[keep], lengths[keep], labels[keep], truth[keep],
                      augmented[keep], int(lost.sum()))
    data.train, data.validation, data.test = split_by_command(
        data.pressures_pa, config.train_fraction, config.validation_fraction, rng)
    return data


def grid_commands(spec: ArmSpec, config: ShapeDNNConfig,
                  rng: np.random.Generator) -> np.ndarray:
    """``config.n_samples`` distinct commands of the pressure grid, in random order (Pa).

    The grid is every chamber's ``p_pre .. p_max`` in ``pressure_step_pa`` steps: zou2022's
    ``31^3 = 29791`` commands (0-3 bar in 0.1 bar steps), swept once each by the paper
    (Section 5.1). Drawing them without replacement keeps any command out of two samples, so
    no test sample repeats a training sample's command.

    Raises:
        ValueError: ``n_samples`` larger than the grid.
    """
    levels = np.floor((spec.p_max_pa - spec.p_pre_pa) / config.pressure_step_pa
                      + 1e-9).astype(int) + 1
    size = int(np.prod(levels))
    if config.n_samples > size:
        raise ValueError(f"n_samples must be at most the pressure grid's {size} commands "
                         f"({' x '.join(str(int(v)) for v in levels)} levels at "
                         f"pressure_step_pa={config.pressure_step_pa:g}), got {config.n_samples}")
    chosen = rng.choice(size, config.n_samples, replace=False)
    indices = np.stack(np.unravel_index(chosen, tuple(int(v) for v in levels)), axis=1)
    return spec.p_pre_pa + config.pressure_step_pa * indices


def split_by_command(pressures_pa: np.ndarray, train_fraction: float,
                     validation_fraction: float,
                     rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Train / validation / test sample indices with every distinct command in one set only.

    The commands are shuffled and dealt out whole until each set holds its share of the
    samples (a rotated copy standing in for a lost sample shares its command with the sample it
    copies, so the two always land in the same set)."""
    _, group = np.unique(pressures_pa, axis=0, return_inverse=True)
    group = group.ravel()
    order = rng.permutation(int(group.max()) + 1)
    ends = np.empty(len(order), dtype=int)  # samples dealt out once each command is
    ends[order] = np.cumsum(np.bincount(group)[order])
    n = len(group)
    n_train = int(round(train_fraction * n))
    n_validation = max(1, int(round(validation_fraction * n)))
    position = ends[group]
    train = position <= n_train
    validation = ~train & (position <= n_train + n_validation)
    test = ~train & ~validation
    return (np.flatnonzero(train), np.flatnonzero(validation), np.flatnonzero(test))


def _private_camera(stereo, seed: int):
    """A copy of ``stereo`` for a private simulator: unbound, its noise seeded."""
    if not isinstance(stereo, StereoCamera):
        raise ValueError(f"stereo must be a StereoCamera, got {stereo!r}")
    camera = copy.copy(stereo)
    camera._world, camera.backdrop_id, camera.poses = None, -1, {}
    camera.rng, camera._last = np.random.default_rng([seed, 2]), None
    return camera


_STEREO_SETTINGS = ("intrinsics", "baseline_m", "distance_m", "target_m", "backdrop",
                    "backdrop_distance_m", "backdrop_rgba", "light_direction", "noise_std_dn")
_ENCODER_SETTINGS = ("resolution_m", "noise_std_m")


def dataset_key(spec: ArmSpec, encoders, stereo=None, config: ShapeDNNConfig = ShapeDNNConfig(),
                ases_config=None) -> dict[str, Any]:
    """What the data set depends on: the arm (its ``preset`` name and the whole spec), the
    encoder and stereo models, ASES's settings and the recipe (samples, grid step, settling,
    augmentation, split, seed). The calibration cache keys on it, and a dataset of the data set
    must match it (:func:`soft_gym.papers.zou2022.readers.read_zou_dataset`)."""
    stereo = default_stereo() if stereo is None else stereo
    ases_config = ASESConfig() if ases_config is None else ases_config
    return {"preset": spec.name, "arm": repr(spec),
            "encoders": sensor_description(encoders, _ENCODER_SETTINGS),
            "stereo": sensor_description(stereo, _STEREO_SETTINGS),
            "ases": ases_config.describe(), "recipe": config.dataset_recipe()}


def cached_dataset(spec: ArmSpec, encoders, stereo=None,
                   config: ShapeDNNConfig = ShapeDNNConfig(), ases_config=None,
                   use_cache: bool = True, progress: bool = True) -> ZouDataset:
    """:func:`collect_dataset`, built once per recipe and kept in the calibration cache."""
    stereo = default_stereo() if stereo is None else stereo
    ases_config = ASESConfig() if ases_config is None else ases_config
    parts = {"what": "zou2022 shape data set",
             **dataset_key(spec, encoders, stereo, config, ases_config)}
    del parts["preset"]  # the cache key as it always was
    return cached(parts, lambda: collect_dataset(spec, encoders, stereo, config, ases_config,
                                                 progress), use_cache=use_cache)


def dataset_of(spec: ArmSpec, encoders, stereo=None, config: ShapeDNNConfig = ShapeDNNConfig(),
               ases_config=None, use_cache: bool = True, progress: bool = True,
               dataset: str | None = None, dataset_root=None) -> ZouDataset:
    """The data set ``config`` asks for: :func:`cached_dataset`, or, given ``dataset`` (an id
    written by ``python -m eval datasets``, under ``dataset_root``, Minari's root when
    ``None``), that dataset's samples and split, which must have been collected with the same
    arm, sensors, ASES settings and recipe (equal bit for bit to the collection; ``ValueError``
    naming the dataset and the setting otherwise)."""
    if dataset is not None:
        from soft_gym.papers.zou2022.readers import read_zou_dataset

        return read_zou_dataset(dataset, dataset_root,
                                dataset_key(spec, encoders, stereo, config, ases_config))
    return cached_dataset(spec, encoders, stereo, config, ases_config, use_cache, progress)


def data_set_digest(data: ZouDataset) -> str:
    """SHA-256 of a data set's arrays and split (the cache key of a DNN trained on data read
    from a dataset)."""
    from soft_gym.datasets.training import data_digest

    return data_digest(data.pressures_pa, data.lengths_m, data.labels_m, data.truth_m,
                       data.augmented, np.array(data.n_lost), data.train, data.validation,
                       data.test)


def train_shape_dnn(spec: ArmSpec, encoders, stereo=None,
                    config: ShapeDNNConfig = ShapeDNNConfig(), ases_config=None,
                    use_cache: bool = True, progress: bool = True,
                    data: ZouDataset | None = None) -> tuple[ShapeDNN, dict[str, Any]]:
    """The data set (from the cache where built before, or ``data`` where given, e.g. read
    from a dataset by :func:`dataset_of`) and the DNN trained on it.

    Returns the DNN and a report: the data set (:class:`ZouDataset`), the training's
    per-epoch MSE (m^2) and the epoch kept.
    """
    if data is None:
        data = cached_dataset(spec, encoders, stereo, config, ases_config, use_cache, progress)
    dnn = ShapeDNN(spec.n_chambers, config.hidden_widths, config.seed)
    report = dnn.fit(data.lengths_m, data.labels_m, data.train, data.validation,
                     epochs=config.epochs, batch_size=config.batch_size,
                     learning_rate=config.learning_rate, l2=config.l2, progress=progress)
    return dnn, {"data": data, "training_mse": report.training_mse,
                 "validation_mse": report.validation_mse, "best_epoch": report.best_epoch}


def cached_shape_dnn(spec: ArmSpec, encoders, stereo=None,
                     config: ShapeDNNConfig = ShapeDNNConfig(), ases_config=None,
                     use_cache: bool = True, progress: bool = True,
                     dataset: str | None = None,
                     dataset_root=None) -> tuple[ShapeDNN, dict[str, Any]]:
    """:func:`train_shape_dnn`, from the calibration cache where run before with the same arm,
    sensors and configuration.

    With ``dataset`` (an id of ``python -m eval datasets``, under ``dataset_root``) the data
    set is that dataset's (:func:`dataset_of`: checked against the arm, sensors and recipe),
    not collected; the cache key then holds the data's digest."""
    stereo = default_stereo() if stereo is None else stereo
    ases_config = ASESConfig() if ases_config is None else ases_config
    data = None if dataset is None else dataset_of(spec, encoders, stereo, config, ases_config,
                                                   use_cache, progress, dataset, dataset_root)

    def compute() -> dict[str, Any]:
        dnn, report = train_shape_dnn(spec, encoders, stereo, config, ases_config, use_cache,
                                      progress, data)
        return {"state": dnn.state(), "report": report}

    parts = {"what": "zou2022 shape DNN", "arm": repr(spec),
             "encoders": sensor_description(encoders, _ENCODER_SETTINGS),
             "stereo": sensor_description(stereo, _STEREO_SETTINGS),
             "ases": ases_config.describe(), "config": asdict(config),
             "recipe": config.dataset_recipe()}
    if data is not None:
        parts["data set"] = data_set_digest(data)
    return cached(parts, compute, use_cache=use_cache,
                  use=lambda result: (ShapeDNN.from_state(result["state"]), result["report"]))


def calibrate_zou2022_dnn(source: FeedbackSource, context: CalibrationContext,
                          use_cache: bool = True) -> None:
    """``encoder_dnn``: zou2022's ASES-labelled data set, then the DNN's training."""
    options = source.labelling_stereo_options()
    try:
        stereo = StereoCamera(**options)
    except TypeError as error:
        raise ValueError(f"stereo must hold StereoCamera keyword arguments, got "
                         f"{sorted(source.stereo_options)} ({error})") from None
    # the paper-sized data set takes ~25 minutes on one core: show the bars (nothing is
    # shown when the data set and network come from the cache)
    source.set_calibration(cached_shape_dnn(context.spec, context.make_sensor("encoder"), stereo,
                                            source.config, use_cache=use_cache, progress=True,
                                            **dataset_options(source)))
