"""The registry of baselines by name, and :func:`make_policy`, which builds one (or loads an
``sb3:PATH`` agent).

:data:`BASELINES` is filled by the registration calls in :mod:`agents.policies` (its
``__init__``), so every name is known as soon as ``agents.policies`` is imported.
"""

from __future__ import annotations

import inspect
from typing import Any

from agents.policies.base import BaselinePolicy, require_soft_arm_env
from agents.policies.sb3 import SB3Policy
from soft_gym._registry import Registry, build, parse_spec

BASELINES: Registry[type[BaselinePolicy]] = Registry("policy")
"""Baseline names and the classes implementing them (registered in :mod:`agents.policies`)."""


def constructor_parameters(cls: type) -> list[str]:
    """The keyword parameters a baseline class takes besides ``env``."""
    return [name for name, parameter in inspect.signature(cls.__init__).parameters.items()
            if name not in ("self", "env") and parameter.kind in (
                inspect.Parameter.POSITIONAL_OR_KEYWORD, inspect.Parameter.KEYWORD_ONLY)]


def make_policy(name: str, env=None, **params: Any) -> BaselinePolicy:
    """Build a baseline by name (see :data:`BASELINES`), or load ``"sb3:PATH"``.

    ``name`` is parsed by :func:`soft_gym._registry.parse_spec` (a name string only). A baseline
    needs ``env``, the soft-arm env it controls; ``params`` are its constructor's keyword
    arguments (unknown ones are refused, listing the known ones). An ``sb3:`` agent takes no
    ``params`` (it acts as trained); with ``env`` its interface is checked against the env's.

    Raises:
        ValueError: naming the parameter, the value and what is allowed.
    """
    if isinstance(name, str) and name.startswith("sb3:"):
        if params:
            raise ValueError(f"policy {name!r} takes no parameters (an sb3 agent acts as it was "
                             f"trained), got {sorted(params)}")
        return SB3Policy.load(name[4:], env=env)
    (spec,) = parse_spec(name, "policy", BASELINES, forms=("name",), also=("sb3:PATH",))
    cls = BASELINES[spec.name]
    require_soft_arm_env(env, f"policy {spec.name!r}")
    known = constructor_parameters(cls)
    unknown = sorted(key for key in params if key not in known)
    if unknown:
        raise ValueError(f"policy {spec.name!r} parameters must be among {known}, got unknown "
                         f"{unknown}")
    return build("policy", spec.name, lambda **kwargs: cls(env, **kwargs), params)
