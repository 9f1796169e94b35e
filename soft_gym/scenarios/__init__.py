"""Loads and disturbances, selectable by name: ``gymnasium.make(..., scenario=...)``.

A scenario is ``None``, an element name (``"tip_mass"``), a dict with ``"name"`` and the element's
parameters (``{"name": "tip_mass", "mass_kg": 0.05}``), an element instance, or a list of these
(parsed by :func:`soft_gym._registry.parse_spec`).
"""

from __future__ import annotations

from typing import Any

from soft_gym._registry import FORMS, Registry, Spec, build, parse_spec
from soft_gym.scenarios.loads import (FillingLoad, Flick, ObstacleRod, Push, SwayingMass,
                                      TipMass)

SCENARIO_ELEMENTS: Registry[type] = Registry("scenario element")
"""Element names and classes."""
SCENARIO_ELEMENTS.register("tip_mass", TipMass)
SCENARIO_ELEMENTS.register("filling_load", FillingLoad)
SCENARIO_ELEMENTS.register("swaying_mass", SwayingMass)
SCENARIO_ELEMENTS.register("push", Push)
SCENARIO_ELEMENTS.register("flick", Flick)
SCENARIO_ELEMENTS.register("obstacle_rod", ObstacleRod)


def make_scenario(scenario: Any) -> list:
    """Turn a scenario description into a list of load elements (see module docstring): fresh
    ones for names and dicts, given instances as they are."""
    items = parse_spec(scenario, "scenario", SCENARIO_ELEMENTS, forms=FORMS,
                       instance_types=tuple(SCENARIO_ELEMENTS.values()))
    return [build("scenario", item.name, SCENARIO_ELEMENTS[item.name], item.params)
            if isinstance(item, Spec) else item for item in items]


__all__ = ["SCENARIO_ELEMENTS", "make_scenario", "TipMass", "FillingLoad", "SwayingMass", "Push",
           "Flick", "ObstacleRod"]
