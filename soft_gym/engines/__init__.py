"""Physics engines behind :class:`soft_gym.simulator.Simulator`, by name.

| name       | class                                                  | features                 |
|------------|--------------------------------------------------------|--------------------------|
| `pybullet` | :class:`soft_gym.engines.pybullet.ArmSimulator`        | `bodies`, `rendering`    |
| `mujoco`   | :class:`soft_gym.engines.mujoco.MujocoArmSimulator`    | `batched`                |

`pybullet` is :data:`REFERENCE_ENGINE`, the default and the engine the papers' experiments run
on; `mujoco` integrates the same chain (:mod:`soft_gym.robots.chain`) with its springs native,
several times faster, and steps a batch of arms together (docs/architecture.md, "The MuJoCo
engine"). :func:`make_simulator` builds one; everything above the engines (env, sensors, loads,
tasks, procedures, baselines) uses only the interface (docs/architecture.md, "The simulator
interface") and asks what an engine can do by feature (:data:`ENGINE_FEATURES`,
:func:`engine_supports`, :func:`engines_supporting`), never by its name. What an engine lacks is
refused before any work by :func:`require_engine_features`, naming beside the engines that have
it what would run on the engine asked for (e.g. the feedback sources it runs).
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

REFERENCE_ENGINE = "pybullet"
"""The engine the papers' experiments run on, and every engine argument's default."""

FAST_ENGINE = "mujoco"
"""The engine for many short simulations of the bare arm (system identification's replays):
several times faster than the reference (docs/architecture.md, "The MuJoCo engine")."""

ENGINE_FEATURES: dict[str, str] = {
    "bodies": "rigid bodies beside the arm (a swaying mass, an obstacle rod) and their contacts",
    "rendering": "camera frames (the eye-in-hand camera, the stereo pair, render())",
    "batched": "arms stepped together as one batch (a vector env's arms in lockstep)",
}
"""What an engine may offer beyond the arm (each simulator class's ``features``), by name. A class
that offers ``"batched"`` has ``step_batch(sims, seconds, executor=None, n_threads=1)``, which
advances arms of that class together by ``seconds`` (s)."""


def _require_feature(feature: str) -> str:
    """``feature``, refused with a ``ValueError`` unless it is a name of :data:`ENGINE_FEATURES`."""
    if not isinstance(feature, str) or feature not in ENGINE_FEATURES:
        raise ValueError(f"feature must be one of {list(ENGINE_FEATURES)}, got {feature!r}")
    return feature


def engine_supports(engine: str, feature: str) -> bool:
    """Whether ``engine`` is a registered engine (:data:`ENGINES`) that offers ``feature``.

    Args:
        engine: an engine name; anything else (an unknown name, a non-string) offers nothing,
            and is left to the env to refuse by name.
        feature: a name from :data:`ENGINE_FEATURES`.

    Raises:
        ValueError: ``feature`` not a name of :data:`ENGINE_FEATURES`.
    """
    _require_feature(feature)
    return isinstance(engine, str) and engine in ENGINES and feature in ENGINES[engine].features


def engines_supporting(*features: str) -> list[str]:
    """The registered engines that offer every one of ``features`` (names from
    :data:`ENGINE_FEATURES`), in registration order.

    Raises:
        ValueError: a feature not a name of :data:`ENGINE_FEATURES`.
    """
    for feature in features:
        _require_feature(feature)
    return [name for name in ENGINES if set(features) <= ENGINES[name].features]


def make_simulator(spec: ArmSpec, engine: str = REFERENCE_ENGINE,
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
            able = engines_supporting(*need.features)
            remedy = f" or {need.remedy}" if need.remedy else ""
            raise EngineFeatureError(
                f"{need.what} needs {' and '.join(ENGINE_FEATURES[f] for f in missing)}, which "
                f"the {engine} engine does not have: use engine= one of {able}{remedy}",
                engine, need)


__all__ = ["ENGINES", "FAST_ENGINE", "REFERENCE_ENGINE", "ENGINE_FEATURES",
           "EngineFeatureError", "EngineNeed", "engine_supports", "engines_supporting",
           "make_simulator", "require_engine_features"]
