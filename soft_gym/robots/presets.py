"""The arms by name (the env's ``preset=``): every paper's arm, registered with its paper
(:mod:`soft_gym.papers`), and any arm a user registers or loads from a file.

Each paper's arm is defined in its folder (``soft_gym/papers/<key>/arm.py``); dimensions come
from the paper (docs/architecture.md, "Presets"); values the paper does not state are chosen
there, written down in the preset's ``notes`` and calibrated against what the paper reports
(``python -m soft_gym.demo`` prints the figures).

Integration trade-off (``bench/integration_tradeoff.py``, ``bench/env_speed.py``). The joint
springs are integrated semi-implicitly in joint space (``ArmSimulator._update_implicit_gains``),
so they set no step limit, and substeps are split while the arm whips (``ArmSimulator.
_refinement_for``); the step is chosen for accuracy. Measured on wang2023 (physics only,
commands held 0.5 s, deviation from the same run at a 4x smaller step; static errors with gravity
and stiffening off):

    links  dt ms  control steps/s  dyn. dev. mm  arc err % L  F L^3/3EI err %
      3    2.5         1578           0.30          0.24           5.6
      4    1.25         847           0.15          0.13           3.1
      4    2.5         1392           0.30          0.13           3.1
      4    5.0         2256           0.59          0.13           3.1
      6    2.5         1091           0.31          0.06           1.4
      8    2.5          862           0.31          0.03           0.8

(``python bench/integration_tradeoff.py``, version 0.2.0 with the end stops, on the 2-core
development machine while another process ran: steps per second are a lower bound.)

Four links per segment at 2.5 ms meet the 0.5 mm accuracy bound with margin, keep the beam
errors well inside the 2 % (arc) and 15 % (deflection) tolerances, and leave time for the env.
zou2022 extends to 3.3 times its length and whips far; it runs at 1.25 ms (0.4 mm). An explicit
spring chain would need about 0.5 ms at four links (measured: it diverges at 1 ms for ho2018).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping

from soft_gym.robots.spec import ArmSpec, CylinderSpec

PRESETS: dict[str, ArmSpec] = {}
"""The arms by name, in registration order (:func:`register_preset`; read-only by convention)."""

CYLINDERS: dict[str, CylinderSpec] = {}
"""The presets whose papers drive chamber volumes, and their cylinders
(:func:`volume_actuated`)."""

CYLINDER_NOTES: dict[str, dict[str, str]] = {}
"""Where :data:`CYLINDERS`' numbers come from, merged into the volume-actuated arm's notes."""


def register_preset(spec: ArmSpec, cylinders: CylinderSpec | None = None,
                    cylinder_notes: Mapping[str, str] | None = None) -> None:
    """Add ``spec`` to :data:`PRESETS` under ``spec.name``, with the ``cylinders`` its paper
    drives the chamber volumes with (``actuation="volume"``) and where their numbers come from.

    Raises:
        ValueError: ``spec`` that is not an :class:`ArmSpec`, a name already registered, or
            ``cylinders`` that is not a :class:`CylinderSpec`.
    """
    if not isinstance(spec, ArmSpec):
        raise ValueError(f"spec must be an ArmSpec, got {type(spec).__name__}")
    if spec.name in PRESETS:
        raise ValueError(f"preset {spec.name!r} is already registered (registered: "
                         f"{list(PRESETS)})")
    if cylinders is not None and not isinstance(cylinders, CylinderSpec):
        raise ValueError(f"cylinders must be a CylinderSpec or None, got "
                         f"{type(cylinders).__name__}")
    PRESETS[spec.name] = spec
    if cylinders is not None:
        CYLINDERS[spec.name] = cylinders
        CYLINDER_NOTES[spec.name] = dict(cylinder_notes or {})


def unregister_preset(name: str) -> None:
    """Remove the preset ``name`` and its cylinders (a plug-in that is done, e.g. in a test)."""
    if name not in PRESETS:
        raise ValueError(f"preset must be one of {list(PRESETS)}, got {name!r}")
    del PRESETS[name]
    CYLINDERS.pop(name, None)
    CYLINDER_NOTES.pop(name, None)


def volume_actuated(spec: ArmSpec) -> ArmSpec:
    """``spec`` driven by cylinder volumes as its paper did (ho2018 Section 3.1): its preset's
    :data:`CYLINDERS` set as :attr:`ArmSpec.cylinders`, the notes told. A spec that already has
    cylinders is returned as it is.

    Raises:
        ValueError: a preset whose paper drives pressures (no entry in :data:`CYLINDERS`).
    """
    if spec.cylinders is not None:
        return spec
    if spec.name not in CYLINDERS:
        raise ValueError(f"actuation='volume' needs an arm with cylinders (ArmSpec.cylinders) or "
                         f"a preset whose paper drives volumes, one of {sorted(CYLINDERS)}, got "
                         f"{spec.name!r}")
    return dataclasses.replace(spec, cylinders=CYLINDERS[spec.name],
                               notes={**spec.notes, **CYLINDER_NOTES[spec.name]})


def get_preset(name: str) -> ArmSpec:
    """Return the preset called ``name`` (one of :data:`PRESETS`)."""
    if name not in PRESETS:
        raise ValueError(f"preset must be one of {sorted(PRESETS)}, got {name!r}")
    return PRESETS[name]
