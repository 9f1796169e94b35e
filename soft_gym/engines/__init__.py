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
work by :func:`require_engine_features`, naming beside the engines that have it what would run on
the engine asked for (e.g. the feedback sources it runs).
"""

from __future__ import annotations

from dataclasses import dataclass
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


@dataclass(frozen=True)
class EngineNeed:
    """What of a configuration needs which engine features, and what would run without them.

    Attributes:
        what: the thing, e.g. ``"scenario element 'swaying_mass'"``.
        features: the features it needs, from :data:`ENGINE_FEATURES`.
        remedy: the change of the configuration that runs on the engine asked for, e.g.
            ``"pass render_mode=None"`` (empty: only another engine runs it).
        arguments: the env arguments ``remedy`` changes, e.g. ``("render_mode",)``.
    """

    what: str
    features: frozenset[str]
    remedy: str = ""
    arguments: tuple[str, ...] = ()


class EngineFeatureError(ValueError):
    """A configuration that needs what its engine lacks (:func:`require_engine_features`); its
    ``engine`` and ``need`` (:class:`EngineNeed`) say what and what would run."""

    def __init__(self, message: str, engine: str, need: EngineNeed) -> None:
        super().__init__(message)
        self.engine, self.need = engine, need


def require_engine_features(engine: str,
                            needs: Iterable[EngineNeed | tuple[str, Iterable[str]]]) -> None:
    """Refuse, before any work, a configuration that needs what ``engine`` lacks.

    Args:
        engine: an engine name from :data:`ENGINES`.
        needs: :class:`EngineNeed` s, or ``(what, features)`` pairs, e.g.
            ``("scenario element 'swaying_mass'", {"bodies"})``, features from
            :data:`ENGINE_FEATURES`.

    Raises:
        EngineFeatureError: (a ``ValueError``) on one line, naming the first thing whose
            features the engine lacks, the engine, the engines that have them and, where there
            is one, the change that runs on ``engine`` (the need's ``remedy``).
    """
    offered = ENGINES[engine].features
    for need in needs:
        if not isinstance(need, EngineNeed):
            need = EngineNeed(need[0], frozenset(need[1]))
        missing = sorted(set(need.features) - offered)
        if missing:
            able = [name for name in ENGINES if set(need.features) <= ENGINES[name].features]
            remedy = f" or {need.remedy}" if need.remedy else ""
            raise EngineFeatureError(
                f"{need.what} needs {' and '.join(ENGINE_FEATURES[f] for f in missing)}, which "
                f"the {engine} engine does not have: use engine= one of {able}{remedy}",
                engine, need)


__all__ = ["ENGINES", "DEFAULT_ENGINE", "ENGINE_FEATURES", "EngineFeatureError", "EngineNeed",
           "make_simulator", "require_engine_features"]
