"""Checking a suite before any run: every distinct env configuration built once without
calibration, every baseline made on it, every SB3 agent loaded (:mod:`eval.suite`,
"Validation")."""

from __future__ import annotations

import copy
from collections.abc import Mapping
from typing import Any

from tqdm import tqdm

from agents.policies import PolicyRefusal, SB3Policy, make_policy
from eval.suite.grid import Cell, arm_env, canonical_json, expand
from eval.suite.spec import PolicyEntry, SuiteError, SuiteSpec
from soft_gym.envs.uncalibrated import uncalibrated_env_class


class EnvChecker:
    """Builds each distinct env configuration once (uncalibrated) and remembers the outcome
    (its refusal's message, or ``None``)."""

    def __init__(self) -> None:
        self.env_class = uncalibrated_env_class()
        self.errors: dict[str, str | None] = {}
        self.builds = 0

    def make(self, kwargs: Mapping[str, Any]):
        self.builds += 1
        return self.env_class(task="track", **copy.deepcopy(dict(kwargs)))

    def error(self, kwargs: Mapping[str, Any]) -> str | None:
        """The env's refusal of ``kwargs`` (its message), or ``None``."""
        text = canonical_json(kwargs)
        if text not in self.errors:
            try:
                env = self.make(kwargs)
            except (ValueError, TypeError) as error:
                self.errors[text] = str(error)
            except Exception as error:  # noqa: BLE001 - reported naming the suite's key
                self.errors[text] = f"{type(error).__name__}: {error}"
            else:
                env.close()
                self.errors[text] = None
        return self.errors[text]


def check_suite(spec: SuiteSpec, progress: bool = False, checker: EnvChecker | None = None
                ) -> list[Cell]:
    """Check ``spec`` as far as possible without running it and return its cells.

    Builds every distinct env configuration once, without calibrating its feedback source, and
    makes every baseline on it (see the module docstring, "Validation"); loads every SB3 agent
    once.

    Args:
        spec: the suite's spec.
        progress: show a progress bar over the arms.
        checker: builds the envs; one that has built some already
            (:func:`eval.suite.engine.on_engine`) does not build them again.

    Returns:
        The suite's cells (:func:`eval.suite.grid.expand`).

    Raises:
        ValueError: (:class:`SuiteError`) naming the file, the key and the env's or policy's
            message.
    """
    cells = expand(spec)
    checker = checker or EnvChecker()
    source = spec.source
    agents: dict[str, str | None] = {}
    # full env config -> (its kwargs, [(key, entry)]) of the baselines to make on it
    baselines: dict[str, tuple[dict[str, Any], list[tuple[str, PolicyEntry]]]] = {}
    for arm in tqdm(spec.arms, desc="checking the suite envs", disable=not progress,
                    leave=False):
        akey = f"arms.{arm.preset}"
        cycles_key = f"{akey}.cycles" if arm.cycles != spec.cycles else "cycles"
        names = {"preset": akey, "path": f"{akey}.paths[0]", "cycles": cycles_key,
                 "feedback": f"{akey}.feedback", **{k: f"{akey}.env.{k}" for k in arm.env}}
        _raise_if(source, *_blame(checker, {}, arm_env(arm, arm.paths[0]), names))
        for i, path in enumerate(arm.paths):
            _raise_if(source, f"{akey}.paths[{i}]", checker.error(arm_env(arm, path)))
        for path in arm.paths:
            for condition, kwargs in arm.conditions.items():
                ckey = f"{akey}.conditions.{condition}"
                _raise_if(source, *_blame(checker, arm_env(arm, path), kwargs,
                                          {k: f"{ckey}.{k}" for k in kwargs}, ckey))
                merged = {**arm_env(arm, path), **kwargs}
                for j, entry in enumerate(arm.policies):
                    pkey = f"{akey}.policies[{j}]"
                    full = {**merged, **entry.env}
                    if entry.env:
                        _raise_if(source, f"{pkey}.env", checker.error(full))
                    if entry.is_agent:
                        if entry.name not in agents:
                            agents[entry.name] = _agent_error(entry.name)
                        _raise_if(source, f"{pkey}.name", agents[entry.name])
                        continue
                    group = baselines.setdefault(canonical_json(full), (full, []))[1]
                    if all(canonical_json([e.name, e.params, e.seed_params]) !=
                           canonical_json([entry.name, entry.params, entry.seed_params])
                           for _, e in group):
                        group.append((f"{pkey}.params", entry))
    for full, entries in tqdm(baselines.values(), desc="checking the suite policies",
                              disable=not progress, leave=False):
        env = checker.make(full)
        try:
            for key, entry in entries:
                _raise_if(source, key, _policy_error(env, entry, spec.seeds[0]))
        finally:
            env.close()
    return cells


def _blame(checker: EnvChecker, base: Mapping[str, Any], added: Mapping[str, Any],
           names: Mapping[str, str], fallback: str = "") -> tuple[str, str | None]:
    """``(key, refusal)`` when the env refuses ``added`` on top of ``base``: ``key`` is the suite
    key (from ``names``) of the first of the ``added`` keyword arguments, in their order, whose
    addition the env refuses, with that refusal (``fallback`` and the whole set's refusal if no
    partial set is refused); ``(fallback, None)`` when the env accepts them all. The whole set
    is judged first, so arguments that only work together (``path="waypoints"`` and its
    ``waypoints_m``) are never blamed for a partial set's refusal."""
    message = checker.error({**base, **added})
    if message is None:
        return fallback, None
    partial = dict(base)
    for name, value in added.items():
        partial[name] = value
        refusal = checker.error(partial)
        if refusal is not None:
            return names.get(name, fallback), refusal
    return fallback, message


def _raise_if(source: str, key: str, message: str | None) -> None:
    if message is not None:
        raise SuiteError(source, key, message)


def _agent_error(name: str) -> str | None:
    try:
        SB3Policy.load(name[4:])
    except (ValueError, OSError) as error:
        return str(error)
    return None


def _policy_error(env, entry: PolicyEntry, seed: int) -> str | None:
    """A baseline's refusal of the entry's parameters on ``env``; ``None`` when it accepts them
    or declines the arm itself (a :class:`~agents.policies.PolicyRefusal` with its defaults too:
    an ``n/a`` run, not a suite error). Any other error is the entry's."""
    params = {**entry.params, **{name: seed for name in entry.seed_params}}
    try:
        make_policy(entry.name, env=env, **params)
    except (ValueError, TypeError) as error:
        if not isinstance(error, PolicyRefusal):
            return str(error)
        given = str(error)
    else:
        return None
    try:
        make_policy(entry.name, env=env)
    except PolicyRefusal:
        return None
    except (ValueError, TypeError):
        pass
    return given

