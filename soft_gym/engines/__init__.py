"""Physics engines behind :class:`soft_gym.simulator.Simulator`, by name.

| name       | class                                                  | features                 |
|------------|--------------------------------------------------------|--------------------------|
| `pybullet` | :class:`soft_gym.engines.pybullet.ArmSimulator`        | `bodies`, `rendering`    |
| `mujoco`   | :class:`soft_gym.engines.mujoco.MujocoArmSimulator`    | (the arm alone)          |

`pybullet` is the default and the reference the papers' experiments run on; `mujoco` integrates
the same chain (:mod:`soft_gym.robots.chain`) with its springs native, several times faster
(docs/architecture.md, "The MuJoCo engine"). :func:`make_simulator` builds one; everything above
the engines (env, sensors, loads, tasks, procedures, baselines) uses only the interface
(docs/architecture.md, "The simulator interface"). What an engine lacks is refused before any
work by :func:`require_engine_features`.
"""

from __future__ import annotations

from typing import Iterable

from soft_gym._registry import Registry
from soft_gym.engines.mujoco import MujocoArmSimulator
from soft_gym.engines.pybullet import ArmSimulator
from soft_gym.robots.spec import ArmSpec
from soft_gym.simulator import Simulator

ENGINES: Registry[type] = Registry("engine")
"""Engine names and their simulator classes (each takes ``(spec, physics_dt_s=None)``)."""
ENGINES.register("pybullet", ArmSimulator)
ENGINES.register("mujoco", MujocoArmSimulator)

DEFAULT_ENGINE = "pybullet"

ENGINE_FEATURES: dict[str, str] = {
    "bodies": "rigid bodies beside the arm (a swaying mass, an obstacle rod) and their contacts",
    "rendering": "camera frames (the eye-in-hand camera, the stereo pair, render())",
}
"""What an engine may offer beyond the arm (each simulator class's ``features``)."""


def make_simulator(spec: ArmSpec, engine: str = DEFAULT_ENGINE,
                   physics_dt_s: float | None = None) -> Simulator:
    """A new simulator of the arm ``spec`` in ``engine`` (see :data:`ENGINES`).

    Args:
        spec: the arm.
        engine: an engine name from :data:`ENGINES`.
        physics_dt_s: override of ``spec.physics_dt_s`` (s), e.g. for accuracy references.
    """
    return ENGINES[engine](spec, physics_dt_s=physics_dt_s)


def require_engine_features(engine: str, needs: Iterable[tuple[str, Iterable[str]]]) -> None:
    """Refuse, before any work, a configuration that needs what ``engine`` lacks.

    Args:
        engine: an engine name from :data:`ENGINES`.
        needs: ``(what, features)`` pairs, e.g. ``("scenario element 'swaying_mass'",
            {"bodies"})``, features from :data:`ENGINE_FEATURES`.

    Raises:
        ValueError: naming the first thing whose features the engine lacks, the engine, and
            the engines that have them.
    """
    offered = ENGINES[engine].features
    for what, features in needs:
        missing = sorted(set(features) - offered)
        if missing:
            able = [name for name in ENGINES if set(features) <= ENGINES[name].features]
            raise ValueError(
                f"{what} needs {' and '.join(ENGINE_FEATURES[f] for f in missing)}, which the "
                f"{engine} engine does not have: use engine= one of {able}")


__all__ = ["ENGINES", "DEFAULT_ENGINE", "ENGINE_FEATURES", "make_simulator",
           "require_engine_features"]
