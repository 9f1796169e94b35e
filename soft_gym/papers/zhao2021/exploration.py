"""zhao2021's random exploration (Section VI-A) and the shape reconstruction trained on it.

The data collection drives a private simulator of the arm, so it lives here, above the
estimators: :func:`collect_exploration` records commands, gauge readings and key points
(:class:`~soft_gym.papers.zhao2021.shape_exploration.ShapeDataset`), :func:`cached_exploration` keeps the
record in the calibration cache, and :func:`cached_reconstruction` trains the SFE-PD networks on
it (:func:`~soft_gym.papers.zhao2021.shape_reconstruction.fit_reconstruction`) once per arm, gauge model
and recipe.
"""

from __future__ import annotations

import copy
from dataclasses import asdict
from typing import Any

import numpy as np
from tqdm.auto import tqdm

from soft_gym._validation import require_integer, require_non_negative, require_positive
from soft_gym.engines import make_simulator
from soft_gym.robots.spec import ArmSpec
from soft_gym.scenarios.loads import TipMass
from soft_gym.sensing.calibration_cache import cached, sensor_description
from soft_gym.papers.zhao2021.shape_exploration import GAUGE_SETTINGS, ShapeDataset
from soft_gym.sensing.key_points import key_points_from_backbone
from soft_gym.papers.zhao2021.shape_reconstruction import (ReconstructionConfig, ShapeReconstructor,
                                                   fit_reconstruction)
from soft_gym.sensors.fbg import rest_vertex_arcs
from soft_gym.procedures.calibration import dataset_options
from soft_gym.sensing.feedback_base import CalibrationContext, FeedbackSource


def collect_exploration(spec: ArmSpec, gauges, n_free: int = 4000, n_loaded: int = 2000,
                        load_kg: float = 0.075, step_pa: float | None = None,
                        max_pressure_pa: float | None = None, settle_s: float = 1.0,
                        chambers_per_step: int = 2, seed: int = 0,
                        progress: bool = True) -> ShapeDataset:
    """Random exploration as zhao2021 Section VI-A, on a private simulator of ``spec``.

    Args:
        spec: the arm.
        gauges: the strain-gauge sensor whose readings are recorded (a
            :class:`~soft_gym.sensors.strain_gauge.StrainGauges`; a private copy is used, with its
            own noise generator seeded from ``seed``).
        n_free: samples with the arm free (paper: 4000).
        n_loaded: samples after them with ``load_kg`` on the tip (paper: 2000).
        load_kg: the tip mass of the loaded samples (kg; paper: 75 g).
        step_pa: pressure change of each adjusted chamber per step (Pa); ``None`` = 1/16 of
            the arm's smallest ``p_max`` (zhao2021: 0.05 bar of 0.8 bar).
        max_pressure_pa: upper bound of the walk (Pa); ``None`` = the arm's ``p_max``
            (zhao2021: 0.8 bar).
        settle_s: time from a change to its measurement (s; paper: 1 s).
        chambers_per_step: chambers adjusted per step (paper: 2).
        seed: seeds the walk and the readings' noise.
        progress: show a progress bar.
    """
    n_free = require_integer("n_free", n_free, 0)
    n_loaded = require_integer("n_loaded", n_loaded, 0)
    if n_free + n_loaded < 1:
        raise ValueError(f"n_free + n_loaded must be >= 1, got {n_free} + {n_loaded}")
    require_non_negative("load_kg", load_kg)
    require_positive("settle_s", settle_s)
    p_max = float(spec.p_max_pa.min())
    step_pa = p_max / 16.0 if step_pa is None else require_positive("step_pa", step_pa)
    upper = p_max if max_pressure_pa is None else require_positive("max_pressure_pa",
                                                                   max_pressure_pa)
    if upper > p_max:
        raise ValueError(f"max_pressure_pa must be <= the arm's p_max {p_max} Pa, got {upper}")
    if step_pa > upper:
        raise ValueError(f"step_pa must be <= max_pressure_pa={upper} Pa, got {step_pa}")
    n_chambers = spec.n_chambers
    chambers_per_step = require_integer("chambers_per_step", chambers_per_step, 1)
    if chambers_per_step > n_chambers:
        raise ValueError(f"chambers_per_step must be in [1, {n_chambers}], got "
                         f"{chambers_per_step}")
    rng = np.random.default_rng(seed)
    sensor = copy.deepcopy(gauges)
    sensor.rng = np.random.default_rng([seed, 1])
    lower = spec.p_pre_pa
    sim = make_simulator(spec)
    total = n_free + n_loaded
    pressures = np.empty((total, n_chambers))
    readings, backbones, loads = [], np.empty((total, len(rest_vertex_arcs(spec)), 3)), []
    try:
        command = lower.copy()
        sim.reset(command, settle_s=settle_s)
        bar = tqdm(total=total, desc=f"{spec.name} exploration", disable=not progress,
                   leave=False)
        for n in range(total):
            if n == n_free and n_loaded:
                sim.add_load(TipMass(mass_kg=load_kg))
            chosen = rng.choice(n_chambers, size=chambers_per_step, replace=False)
            change = step_pa * rng.choice((-1.0, 1.0), size=chambers_per_step)
            proposed = command[chosen] + change
            outside = (proposed < lower[chosen] - 1e-9) | (proposed > upper + 1e-9)
            command[chosen] = np.where(outside, command[chosen] - change, proposed)
            sim.set_pressures(command)
            sim.step_physics(settle_s)
            pressures[n] = command
            readings.append(np.asarray(sensor.sample(sim), dtype=float))
            backbones[n] = sim.backbone()
            loads.append(load_kg if n >= n_free and n_loaded else 0.0)
            bar.update(1)
        bar.close()
    finally:
        sim.close()
    return ShapeDataset(pressures_pa=pressures, readings=np.array(readings),
                        key_points_m=key_points_from_backbone(spec, backbones),
                        backbone_m=backbones, tip_load_kg=np.array(loads))


def cached_exploration(spec: ArmSpec, gauges, n_free: int = 4000, n_loaded: int = 2000,
                       load_kg: float = 0.075, seed: int = 0, use_cache: bool = True,
                       progress: bool = True) -> ShapeDataset:
    """:func:`collect_exploration`, run once per arm, gauge model and recipe and kept in the
    calibration cache: the shape reconstruction and the local-IK controller learn from the same
    record."""
    parts = {"what": "zhao2021 exploration", "arm": repr(spec),
             **exploration_key(spec, gauges, n_free, n_loaded, load_kg, seed)}
    del parts["preset"]  # the cache key as it always was
    return cached(parts, lambda: collect_exploration(spec, gauges, n_free=n_free,
                                                     n_loaded=n_loaded, load_kg=load_kg,
                                                     seed=seed, progress=progress),
                  use_cache=use_cache)
def exploration_key(spec: ArmSpec, gauges, n_free: int, n_loaded: int, load_kg: float,
                    seed: int) -> dict[str, Any]:
    """What the exploration's record depends on: the arm (its ``preset`` name and the whole
    spec), the gauge model, the sample counts, the tip mass (kg) and the seed. The calibration
    cache keys on it, and a dataset of the exploration must match it
    (:func:`soft_gym.papers.zhao2021.readers.read_exploration`)."""
    return {"preset": spec.name, "arm": repr(spec),
            "gauges": sensor_description(gauges, GAUGE_SETTINGS), "n_free": n_free,
            "n_loaded": n_loaded, "load_kg": load_kg, "seed": seed}


def exploration_of(spec: ArmSpec, gauges, config: ReconstructionConfig, use_cache: bool = True,
                   progress: bool = True, dataset: str | None = None, dataset_root=None):
    """The exploration record ``config`` asks for: :func:`cached_exploration`, or, given
    ``dataset`` (an id written by ``python -m eval datasets``, under ``dataset_root``, Minari's
    root when ``None``), that dataset's record, which must have been collected with the same
    arm, gauge model, sizes and seed (equal bit for bit to the collection; ``ValueError``
    naming the dataset and the setting otherwise)."""
    if dataset is not None:
        from soft_gym.papers.zhao2021.readers import read_exploration

        return read_exploration(dataset, dataset_root, exploration_key(
            spec, gauges, config.n_free, config.n_loaded, config.load_kg, config.seed))
    return cached_exploration(spec, gauges, n_free=config.n_free, n_loaded=config.n_loaded,
                              load_kg=config.load_kg, seed=config.seed, use_cache=use_cache,
                              progress=progress)


def train_reconstruction(spec: ArmSpec, gauges, config: ReconstructionConfig = ReconstructionConfig(),
                         use_cache: bool = True, progress: bool = True,
                         data: ShapeDataset | None = None,
                         ) -> tuple[ShapeReconstructor, dict[str, Any]]:
    """Explore ``spec`` with ``gauges`` on (or take the cached exploration, or ``data`` where
    given, e.g. read from a dataset by :func:`exploration_of`) and train the SFE-PD networks
    (zhao2021 VI-A; :func:`~soft_gym.papers.zhao2021.shape_reconstruction.fit_reconstruction`).
    """
    if data is None:
        data = exploration_of(spec, gauges, config, use_cache, progress)
    return fit_reconstruction(spec, data, config, progress)


def exploration_digest(data: ShapeDataset) -> str:
    """SHA-256 of an exploration record's arrays (the cache key of a model trained on data read
    from a dataset)."""
    from soft_gym.datasets.training import data_digest

    return data_digest(data.pressures_pa, data.readings, data.key_points_m, data.backbone_m,
                       data.tip_load_kg)


def cached_reconstruction(spec: ArmSpec, gauges, config: ReconstructionConfig,
                          key: dict[str, Any] | None = None, use_cache: bool = True,
                          progress: bool = True, dataset: str | None = None,
                          dataset_root=None) -> tuple[ShapeReconstructor, dict[str, Any]]:
    """:func:`train_reconstruction`, from the calibration cache where it has been run before
    with the same arm, gauges, configuration and ``key`` (anything else that matters).

    With ``dataset`` (an id of ``python -m eval datasets``, under ``dataset_root``) the
    exploration is that dataset's (:func:`exploration_of`: checked against the arm, gauges,
    sizes and seed), not collected; the cache key then holds the record's digest."""
    data = None if dataset is None else exploration_of(spec, gauges, config, use_cache, progress,
                                                       dataset, dataset_root)

    def compute() -> dict[str, Any]:
        reconstructor, report = train_reconstruction(spec, gauges, config, use_cache, progress,
                                                     data)
        return {"state": reconstructor.state(), "report": report}

    settings = asdict(config)
    del settings["backbone_curve"]  # fitted after the networks: the cache key as it was
    parts = {"what": "zhao2021 shape reconstruction", "arm": repr(spec),
             "gauges": sensor_description(gauges, GAUGE_SETTINGS), "config": settings,
             **(key or {})}
    if data is not None:
        parts["exploration"] = exploration_digest(data)

    def use(result: dict[str, Any]) -> tuple[ShapeReconstructor, dict[str, Any]]:
        reconstructor = ShapeReconstructor.from_state(result["state"])
        reconstructor.curve = config.backbone_curve
        return reconstructor, result["report"]

    return cached(parts, compute, use_cache=use_cache, use=use)


def calibrate_zhao2021_reconstruction(source: FeedbackSource, context: CalibrationContext,
                                      use_cache: bool = True) -> None:
    """``strain_sr``: zhao2021's exploration with the env's gauge model, then the networks."""
    # the paper's exploration and training take ~10 minutes on one core: show their bars
    # (nothing is shown when the model comes from the cache)
    source.set_calibration(cached_reconstruction(context.spec, context.make_sensor("strain"),
                                                 source.config, use_cache=use_cache,
                                                 progress=True, **dataset_options(source)))
