"""Physics engines behind :class:`soft_gym.simulator.Simulator`, by name.

| name       | class                                        | notes                               |
|------------|----------------------------------------------|-------------------------------------|
| `pybullet` | :class:`soft_gym.engines.pybullet.ArmSimulator` | the default and the reference    |

:func:`make_simulator` builds one; everything above the engines (env, sensors, loads, tasks,
procedures, baselines) uses only the interface (docs/architecture.md, "The simulator
interface").
"""

from __future__ import annotations

from soft_gym._registry import Registry
from soft_gym.engines.pybullet import ArmSimulator
from soft_gym.robots.spec import ArmSpec
from soft_gym.simulator import Simulator

ENGINES: Registry[type] = Registry("engine")
"""Engine names and their simulator classes (each takes ``(spec, physics_dt_s=None)``)."""
ENGINES.register("pybullet", ArmSimulator)

DEFAULT_ENGINE = "pybullet"


def make_simulator(spec: ArmSpec, engine: str = DEFAULT_ENGINE,
                   physics_dt_s: float | None = None) -> Simulator:
    """A new simulator of the arm ``spec`` in ``engine`` (see :data:`ENGINES`).

    Args:
        spec: the arm.
        engine: an engine name from :data:`ENGINES`.
        physics_dt_s: override of ``spec.physics_dt_s`` (s), e.g. for accuracy references.
    """
    return ENGINES[engine](spec, physics_dt_s=physics_dt_s)


__all__ = ["ENGINES", "DEFAULT_ENGINE", "make_simulator"]
