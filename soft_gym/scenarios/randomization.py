"""Domain randomisation: a fresh draw of loads, faults, sensor noise and arm parameters per episode.

Off by default. ``gymnasium.make(..., randomization=True)`` turns it on with the ranges below;
a dict (or a YAML file's mapping, e.g. ``train/configs/randomization.yaml``) overrides any of them.
Every draw comes from the env's ``np_random``, so ``reset(seed=...)`` fixes it.

| field                          | default          | meaning                                             |
|--------------------------------|------------------|-----------------------------------------------------|
| ``load_weights``               | see below        | relative odds of each load kind per episode         |
| ``tip_mass_kg``                | (0.0, 0.010)     | static tip mass (kg), uniform                       |
| ``filling_added_kg``           | (0.002, 0.010)   | fluid a tip container gains (kg) from 14 g empty... |
| ``filling_rate_kg_s``          | (0.0003, 0.001)  | ...at this rate (kg/s), from a start in [0, 10] s   |
| ``swaying_mass_kg``            | (0.003, 0.010)   | ball hanging 20 mm under the tip (kg)               |
| ``push_force_n``               | (0.05, 0.25)     | lateral push on a random link (N), random direction |
| ``fault_weights``              | see below        | odds of each visual fault (camera envs only)        |
| ``fault_strength``             | (0.3, 0.9)       | strength of the drawn fault                         |
| ``sensor_noise_scale``         | (0.5, 2.0)       | factor on every sensor's noise std, log-uniform     |
| ``stiffness_scale``            | (0.85, 1.15)     | factor on the arm's bending and axial stiffness     |
| ``time_constant_scale``        | (0.7, 1.5)       | factor on the pneumatic time constant               |

Load kinds: ``none`` 0.3, ``tip_mass`` 0.35, ``filling_load`` 0.1, ``swaying_mass`` 0.1,
``push`` 0.15. Faults: ``none`` 0.5, ``moving_occluder`` (partial) 0.15, ``low_light`` 0.15,
``led_glare`` 0.1, ``motion_blur`` 0.1. The defaults keep the tip load at or below 10 g, so a
heavier load (e.g. 20 g) stays out of the training distribution for generalisation tests.

Every range is a finite ``(low, high)`` pair of real numbers with ``low <= high`` inside its
allowed interval (:data:`RANGE_LIMITS`): masses up to :data:`~soft_gym.scenarios.loads.MAX_MASS_KG`,
pushes up to :data:`~soft_gym.scenarios.loads.MAX_FORCE_N`, fill rates up to
:data:`~soft_gym.scenarios.loads.MAX_FILL_RATE_KG_S`, fault strengths within [0, 1], a noise
factor up to 10, a stiffness factor within [0.6, 5] (zou2022's arm under 95 % of its
``max_load_n`` and bang-bang pressures leaves its end stops at 0.5 and stays on them at 0.6; every
arm does from 0.6 to 10) and a time-constant factor within [0.1, 10]. The env further checks that
no draw loads the arm beyond :attr:`~soft_gym.robots.spec.ArmSpec.max_load_n`.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from soft_gym.robots.spec import GRAVITY_M_S2
from soft_gym.scenarios.loads import (MAX_FILL_RATE_KG_S, MAX_FORCE_N, MAX_MASS_KG,
                                      FillingLoad, Push, SwayingMass, TipMass)
from soft_gym.sensors.faults import make_faults

LOAD_KINDS = ("none", "tip_mass", "filling_load", "swaying_mass", "push")
FAULT_KINDS = ("none", "moving_occluder", "low_light", "led_glare", "motion_blur")

RANGE_LIMITS: dict[str, tuple[float, float, str]] = {
    "tip_mass_kg": (0.0, MAX_MASS_KG, "kg"),
    "filling_added_kg": (0.0, MAX_MASS_KG - FillingLoad.initial_mass_kg, "kg"),
    "filling_rate_kg_s": (1e-12, MAX_FILL_RATE_KG_S, "kg/s"),
    "swaying_mass_kg": (1e-12, MAX_MASS_KG, "kg"),
    "push_force_n": (0.0, MAX_FORCE_N, "N"),
    "fault_strength": (0.0, 1.0, "-"),
    "sensor_noise_scale": (1e-12, 10.0, "-"),
    "stiffness_scale": (0.6, 5.0, "-"),
    "time_constant_scale": (0.1, 10.0, "-"),
}
"""The interval each ``(low, high)`` range must lie in, and its unit (see the module docstring)."""


@dataclass(frozen=True)
class RandomizationConfig:
    """Ranges of the per-episode draws (see the module docstring for units and defaults)."""

    load_weights: dict = field(default_factory=lambda: {
        "none": 0.3, "tip_mass": 0.35, "filling_load": 0.1, "swaying_mass": 0.1, "push": 0.15})
    tip_mass_kg: tuple[float, float] = (0.0, 0.010)
    filling_added_kg: tuple[float, float] = (0.002, 0.010)
    filling_rate_kg_s: tuple[float, float] = (0.0003, 0.001)
    swaying_mass_kg: tuple[float, float] = (0.003, 0.010)
    push_force_n: tuple[float, float] = (0.05, 0.25)
    fault_weights: dict = field(default_factory=lambda: {
        "none": 0.5, "moving_occluder": 0.15, "low_light": 0.15, "led_glare": 0.1,
        "motion_blur": 0.1})
    fault_strength: tuple[float, float] = (0.3, 0.9)
    sensor_noise_scale: tuple[float, float] = (0.5, 2.0)
    stiffness_scale: tuple[float, float] = (0.85, 1.15)
    time_constant_scale: tuple[float, float] = (0.7, 1.5)

    def __post_init__(self) -> None:
        _check_weights("load_weights", self.load_weights, LOAD_KINDS)
        _check_weights("fault_weights", self.fault_weights, FAULT_KINDS)
        for name, (lowest, highest, unit) in RANGE_LIMITS.items():
            value = getattr(self, name)
            if not isinstance(value, (list, tuple, np.ndarray)) or len(value) != 2 or not all(
                    isinstance(v, (int, float, np.integer, np.floating))
                    and not isinstance(v, (bool, np.bool_)) for v in value):
                raise ValueError(f"{name} must be a (low, high) pair of real numbers ({unit}), "
                                 f"got {value!r}")
            low, high = (float(v) for v in value)
            if name == "fault_strength" and not 0.0 <= low <= high <= 1.0:
                raise ValueError(f"fault_strength must lie within [0, 1] with low <= high, "
                                 f"got {value!r}")
            if not (math.isfinite(low) and math.isfinite(high)) or low < lowest \
                    or high > highest or high < low:
                raise ValueError(f"{name} must be a finite range with {lowest:g} <= low <= high "
                                 f"<= {highest:g} ({unit}), got {value!r}")
            object.__setattr__(self, name, (low, high))

    @classmethod
    def from_any(cls, config: Any) -> "RandomizationConfig | None":
        """``None``/``False``: off; ``True``: defaults; a dict, a YAML path or a config: as given."""
        if config is None or config is False:
            return None
        if config is True:
            return cls()
        if isinstance(config, cls):
            return config
        if isinstance(config, (str, Path)):
            path = Path(config)
            if not path.is_file():
                raise ValueError(f"randomization file {str(path)!r} does not exist")
            try:
                config = yaml.safe_load(path.read_text()) or {}
            except (yaml.YAMLError, UnicodeDecodeError) as error:
                raise ValueError(f"randomization file {str(path)!r} is not valid YAML: "
                                 f"{error}") from error
        if not isinstance(config, dict):
            raise ValueError("randomization must be None, a bool, a dict of ranges, a YAML path "
                             f"or a RandomizationConfig, got {config!r}")
        known = {f.name for f in dataclasses.fields(cls)}
        unknown = sorted(set(config) - known)
        if unknown:
            raise ValueError(f"randomization keys must be among {sorted(known)}, got {unknown}")
        return cls(**config)


def _check_weights(name: str, weights: Any, kinds: tuple[str, ...]) -> None:
    if not isinstance(weights, dict) or not weights:
        raise ValueError(f"{name} must be a non-empty dict from {list(kinds)} to odds, "
                         f"got {weights!r}")
    unknown = sorted(set(weights) - set(kinds))
    if unknown:
        raise ValueError(f"{name} keys must be among {list(kinds)}, got {unknown}")
    bad = [v for v in weights.values() if isinstance(v, (bool, np.bool_))
           or not isinstance(v, (int, float, np.integer, np.floating))]
    if bad:
        raise ValueError(f"{name} must map kinds to real numbers (odds), got {weights!r}")
    values = np.array([float(v) for v in weights.values()])
    if not np.all(np.isfinite(values)) or np.any(values < 0) or values.sum() <= 0:
        raise ValueError(f"{name} must be finite odds >= 0 with a positive sum, got {weights!r}")


@dataclass(frozen=True)
class EpisodeDraw:
    """One episode's randomised conditions."""

    scenario: list
    faults: list
    sensor_noise_scale: float
    stiffness_scale: float
    time_constant_scale: float

    def describe(self) -> dict[str, Any]:
        """A JSON-friendly summary (for ``info["randomization"]``)."""
        return {"loads": [type(load).__name__ for load in self.scenario],
                "faults": [type(fault).__name__ for fault in self.faults],
                "sensor_noise_scale": self.sensor_noise_scale,
                "stiffness_scale": self.stiffness_scale,
                "time_constant_scale": self.time_constant_scale}


class DomainRandomizer:
    """Draws :class:`EpisodeDraw` s from a :class:`RandomizationConfig`.

    Args:
        config: the ranges.
        n_links: number of arm links (pushes pick one).
        with_camera: whether visual faults apply (the env has an eye-in-hand camera).
        max_load_n: the heaviest load a draw may add (N), e.g. the arm's
            :attr:`~soft_gym.robots.spec.ArmSpec.max_load_n` less the fixed scenario's loads;
            ``None`` checks nothing.

    Raises:
        ValueError: if a range with non-zero odds can draw a load heavier than ``max_load_n``.
    """

    def __init__(self, config: RandomizationConfig, n_links: int, with_camera: bool,
                 max_load_n: float | None = None) -> None:
        self.config = config
        self.n_links = int(n_links)
        self.with_camera = bool(with_camera)
        if max_load_n is not None:
            for name, heaviest_n in self.heaviest_loads_n().items():
                if heaviest_n > max_load_n * (1 + 1e-9):
                    raise ValueError(
                        f"randomization {name} can draw a load of {heaviest_n:.3g} N, more than "
                        f"the {max_load_n:.3g} N the arm bears beside the fixed scenario "
                        "(ArmSpec.max_load_n): lower its upper bound")

    def heaviest_loads_n(self, gravity_m_s2: float = GRAVITY_M_S2) -> dict[str, float]:
        """Heaviest weight or force (N) each load kind with non-zero odds can draw, by range."""
        c, odds = self.config, self.config.load_weights
        heaviest = {("tip_mass", "tip_mass_kg"): TipMass(mass_kg=c.tip_mass_kg[1]),
                    ("filling_load", "filling_added_kg"):
                        FillingLoad(added_mass_kg=c.filling_added_kg[1]),
                    ("swaying_mass", "swaying_mass_kg"): SwayingMass(mass_kg=c.swaying_mass_kg[1]),
                    ("push", "push_force_n"): Push(force_n=(c.push_force_n[1], 0.0, 0.0))}
        loads_n = {name: load.peak_load_n(gravity_m_s2)
                   for (kind, name), load in heaviest.items() if odds.get(kind, 0) > 0}
        return {name: value for name, value in loads_n.items() if value > 0}

    def sample(self, rng: np.random.Generator) -> EpisodeDraw:
        c = self.config
        uniform = lambda bounds: float(rng.uniform(*bounds))  # noqa: E731
        load = _choose(rng, c.load_weights)
        scenario: list = []
        if load == "tip_mass":
            scenario.append(TipMass(mass_kg=uniform(c.tip_mass_kg)))
        elif load == "filling_load":
            scenario.append(FillingLoad(added_mass_kg=uniform(c.filling_added_kg),
                                        rate_kg_s=uniform(c.filling_rate_kg_s),
                                        start_s=float(rng.uniform(0.0, 10.0))))
        elif load == "swaying_mass":
            scenario.append(SwayingMass(mass_kg=uniform(c.swaying_mass_kg)))
        elif load == "push":
            angle = rng.uniform(0.0, 2.0 * np.pi)
            magnitude = uniform(c.push_force_n)
            start = float(rng.uniform(1.0, 10.0))
            scenario.append(Push(force_n=(magnitude * np.cos(angle), magnitude * np.sin(angle), 0.0),
                                 link=int(rng.integers(self.n_links)), ramp_s=1.0,
                                 start_s=start, end_s=start + float(rng.uniform(2.0, 6.0))))
        faults: list = []
        fault = _choose(rng, c.fault_weights) if self.with_camera else "none"
        if fault != "none":
            params: dict[str, Any] = {"name": fault, "strength": uniform(c.fault_strength)}
            if fault == "moving_occluder":
                params["mode"] = "partial"
            faults = make_faults(params)
        low, high = np.log(c.sensor_noise_scale)
        return EpisodeDraw(scenario=scenario, faults=faults,
                           sensor_noise_scale=float(np.exp(rng.uniform(low, high))),
                           stiffness_scale=uniform(c.stiffness_scale),
                           time_constant_scale=uniform(c.time_constant_scale))


def _choose(rng: np.random.Generator, weights: dict) -> str:
    names = list(weights)
    odds = np.array([float(weights[name]) for name in names])
    return names[int(rng.choice(len(names), p=odds / odds.sum()))]
