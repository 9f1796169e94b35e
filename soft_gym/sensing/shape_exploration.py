"""The strain-gauge shape-sensing data set: zhao2021's random exploration (Section VI-A).

Zhao et al. 2021 teach their shape reconstruction and their local inverse-kinematics network from
one data set: the robot explores its workspace at random, "any two of the six chambers ... randomly
adjusted to increase or decrease the pressure by 0.05 bar" per step, pressures kept within
[0, 0.8 bar], and one second after each change the backbone's key points are measured (an RGB-D
camera on markers) together with the strain-gauge readings. 6000 samples: 4000 with the arm free,
then 2000 with a 75 g mass on the tip.

:func:`collect_exploration` does the same on a private simulator of the arm (no env, no episode),
recording per sample the commanded pressures ``A_n``, the gauge readings ``S_n`` (the env's own
gauge model, noise included), the key points ``P_1..P_2N`` (material points at equal thirds of each
segment's rest length, as the paper's markers: :func:`key_points_from_backbone`), the whole
simulated backbone and the tip load. A pressure step that would leave the range is reflected
(the chamber moves the other way), so the walk never sticks at a bound.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass

import numpy as np
from tqdm.auto import tqdm

from soft_gym._validation import require_integer, require_non_negative, require_positive
from soft_gym.robots.spec import ArmSpec
from soft_gym.sensors.fbg import locate, rest_vertex_arcs, segment_bounds

N_SUBSEGMENTS = 3
"""zhao2021 Section III: the backbone is cut into ``N = 3`` subsegments, each carried by three
key points, so ``2N = 6`` key points ``P_1..P_6`` at sixths of the arm's rest length (on the
paper's two equal segments: thirds of each segment). Any arm gets the same six."""

N_KEY_POINTS = 2 * N_SUBSEGMENTS

GAUGE_SETTINGS = ("rate_hz", "arc_fraction", "angle_offset_rad", "radius_m", "gauge_length_m",
                  "gain", "offset", "noise_std", "n_points")
"""The strain-gauge settings that change the recorded readings (part of the cache key)."""


@dataclass
class ShapeDataset:
    """Exploration samples, in the order they were taken.

    Attributes:
        pressures_pa: commanded chamber pressures ``A_n`` (Pa), (n, n_chambers).
        readings: strain-gauge readings ``S_n`` (the sensor's units), (n, n_gauges).
        key_points_m: key points ``P_1..P_2N`` (m, base frame), (n, n_key_points, 3).
        backbone_m: the simulated backbone (m, base frame), (n, n_links + 1, 3).
        tip_load_kg: mass hanging on the tip during each sample (kg), (n,).
    """

    pressures_pa: np.ndarray
    readings: np.ndarray
    key_points_m: np.ndarray
    backbone_m: np.ndarray
    tip_load_kg: np.ndarray

    def __len__(self) -> int:
        return int(self.pressures_pa.shape[0])


def key_point_arcs(spec: ArmSpec) -> np.ndarray:
    """Rest arc position (m from the base) of each key point: sixths of the rest length."""
    return segment_bounds(spec)[-1] * np.arange(1, N_KEY_POINTS + 1) / N_KEY_POINTS


def key_points_from_backbone(spec: ArmSpec, backbone_m: np.ndarray) -> np.ndarray:
    """The key points (m) on a simulated backbone ``(..., n_links + 1, 3)``: the material points
    at :func:`key_point_arcs`, linearly interpolated between backbone vertices (the paper's
    markers move with the body). Returns ``(..., n_key_points, 3)``."""
    backbone = np.asarray(backbone_m, dtype=float)
    vertices = rest_vertex_arcs(spec)
    if backbone.shape[-2:] != (len(vertices), 3):
        raise ValueError(f"backbone_m must have shape (..., {len(vertices)}, 3) for arm "
                         f"{spec.name!r}, got {backbone.shape}")
    link, fraction = locate(vertices, key_point_arcs(spec))
    start, end = backbone[..., link, :], backbone[..., link + 1, :]
    return start + fraction[:, None] * (end - start)


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
    from soft_gym.scenarios.loads import TipMass
    from soft_gym.engines.pybullet.simulator import ArmSimulator

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
    sim = ArmSimulator(spec)
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
    from soft_gym.sensing.calibration_cache import cached, sensor_description

    parts = {"what": "zhao2021 exploration", "arm": repr(spec),
             "gauges": sensor_description(gauges, GAUGE_SETTINGS), "n_free": n_free,
             "n_loaded": n_loaded, "load_kg": load_kg, "seed": seed}
    return cached(parts, lambda: collect_exploration(spec, gauges, n_free=n_free,
                                                     n_loaded=n_loaded, load_kg=load_kg,
                                                     seed=seed, progress=progress),
                  use_cache=use_cache)
