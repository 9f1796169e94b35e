"""Loads and disturbances, selectable by name: ``gymnasium.make(..., scenario=...)``.

A scenario is ``None``, an element name (``"tip_mass"``), a dict with ``"name"`` and the element's
parameters (``{"name": "tip_mass", "mass_kg": 0.05}``), an element instance, or a list of these.
"""

from __future__ import annotations

from typing import Any

from soft_gym.scenarios.loads import (FillingLoad, Flick, ObstacleRod, Push, SwayingMass,
                                      TipMass)

SCENARIO_ELEMENTS: dict[str, type] = {
    "tip_mass": TipMass,
    "filling_load": FillingLoad,
    "swaying_mass": SwayingMass,
    "push": Push,
    "flick": Flick,
    "obstacle_rod": ObstacleRod,
}
"""Element names and classes."""


def make_scenario(scenario: Any) -> list:
    """Turn a scenario description into a list of fresh load elements (see module docstring)."""
    if scenario is None:
        return []
    if isinstance(scenario, (list, tuple)):
        return [element for item in scenario for element in make_scenario(item)]
    if isinstance(scenario, tuple(SCENARIO_ELEMENTS.values())):
        return [scenario]
    if isinstance(scenario, str):
        scenario = {"name": scenario}
    if not isinstance(scenario, dict) or "name" not in scenario:
        raise ValueError(
            "scenario must be None, a name, a dict with 'name', an element or a list of these, "
            f"got {scenario!r}")
    params = dict(scenario)
    name = params.pop("name")
    if name not in SCENARIO_ELEMENTS:
        raise ValueError(f"scenario name must be one of {sorted(SCENARIO_ELEMENTS)}, got {name!r}")
    try:
        return [SCENARIO_ELEMENTS[name](**params)]
    except TypeError as error:
        raise ValueError(f"scenario {name!r} got invalid parameters {params}: {error}") from error


__all__ = ["SCENARIO_ELEMENTS", "make_scenario", "TipMass", "FillingLoad", "SwayingMass", "Push",
           "Flick", "ObstacleRod"]
