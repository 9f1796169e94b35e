"""A suite on another physics engine (``python -m eval suite SPEC --engine mujoco``).

:func:`on_engine` sets ``engine`` in every arm's env keyword arguments, and in place of any
engine a condition or a policy entry names, and leaves out what that engine cannot run: an arm whose own env it refuses (wang2023's
fused feedback needs the eye-in-hand camera, which the MuJoCo engine lacks) and each condition
it refuses on an arm (a swaying mass, the stereo pair). Only refusals the engine causes are
left out, each with the engine's own message (:func:`soft_gym.engines.require_engine_features`):
an arm or condition the env refuses on its file's own engine stays, so that
:func:`eval.suite.check_suite` reports it against the file's key as it would without
``--engine``. The suite's description then says which engine ran it and what was left out, so
the report (``leaderboard.md``, ``suite.json``) carries it.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any

from eval.suite.check import EnvChecker
from eval.suite.grid import arm_env
from eval.suite.spec import ArmEntry, SuiteSpec
from soft_gym.engines import ENGINES


@dataclass(frozen=True)
class LeftOut:
    """An arm (``condition`` ``None``) or one of its conditions that ``engine`` cannot run, and
    the engine's refusal."""

    preset: str
    condition: str | None
    reason: str

    def label(self) -> str:
        """``preset`` or ``preset/condition``."""
        return self.preset if self.condition is None else f"{self.preset}/{self.condition}"


def on_engine(spec: SuiteSpec, engine: str, checker: EnvChecker | None = None
              ) -> tuple[SuiteSpec, list[LeftOut]]:
    """``spec`` with every arm on ``engine``, less the arms and conditions the engine cannot run.

    :param spec: a loaded suite.
    :param engine: an engine name (:data:`soft_gym.engines.ENGINES`).
    :param checker: builds the envs (uncalibrated) to ask them; a new one by default.
    :return: the suite on ``engine`` and what it left out, in the file's order.
    :raises ValueError: ``engine`` is not an engine's name, naming the allowed ones; the engine
        can run nothing of the suite.
    """
    if not isinstance(engine, str) or engine not in ENGINES:
        raise ValueError(f"engine must be one of {list(ENGINES)}, got {engine!r}")
    checker = checker or EnvChecker()
    arms, left_out = [], []
    for arm in spec.arms:
        moved = replace(arm, env={**arm.env, "engine": engine},
                        conditions={name: _on_engine(kwargs, engine)
                                    for name, kwargs in arm.conditions.items()},
                        policies=tuple(replace(entry, env=_on_engine(entry.env, engine))
                                       for entry in arm.policies))
        refusal = _engine_refusal(checker, arm, moved)
        if refusal is not None:
            left_out.append(LeftOut(arm.preset, None, refusal))
            continue
        conditions = {}
        for name in arm.conditions:
            refusal = _engine_refusal(checker, arm, moved, name)
            if refusal is None:
                conditions[name] = moved.conditions[name]
            else:
                left_out.append(LeftOut(arm.preset, name, refusal))
        if conditions:
            arms.append(replace(moved, conditions=conditions))
        else:  # every condition refused: the arm goes with them
            left_out.append(LeftOut(arm.preset, None, f"every condition is left out on {engine}"))
    if not arms:
        raise ValueError(f"engine {engine!r} can run none of suite {spec.name!r}: "
                         + "; ".join(f"{item.label()}: {item.reason}" for item in left_out))
    return replace(spec, arms=tuple(arms),
                   description=_description(spec.description, engine, left_out)), left_out


def _on_engine(kwargs: dict[str, Any], engine: str) -> dict[str, Any]:
    """Env keyword arguments of a condition or policy entry with ``engine`` in place of the
    engine they name (as they are where they name none: the arm's ``env`` gives it)."""
    return {**kwargs, "engine": engine} if "engine" in kwargs else kwargs


def _engine_refusal(checker: EnvChecker, arm: ArmEntry, moved: ArmEntry,
                    condition: str | None = None) -> str | None:
    """The first refusal, over the arm's paths, of ``moved``'s env (with ``condition``'s
    keyword arguments) where ``arm``'s own is accepted: what the engine alone refuses
    (``None`` when it runs them all)."""
    own = arm.conditions[condition] if condition is not None else {}
    on_engine_kwargs = moved.conditions[condition] if condition is not None else {}
    for path in arm.paths:
        refusal = checker.error({**arm_env(moved, path), **on_engine_kwargs})
        if refusal is not None and checker.error({**arm_env(arm, path), **own}) is None:
            return refusal
    return None


def _description(description: str, engine: str, left_out: list[LeftOut]) -> str:
    """The suite's description with the engine that ran it and what it left out."""
    text = f"Run on the {engine} engine (--engine {engine})"
    if left_out:
        text += "; left out, as the engine cannot run them: " + ", ".join(
            item.label() for item in left_out)
    return f"{description.strip()} {text}.".strip()

