"""Gymnasium ids: ``SoftArmReach-v0`` and ``SoftArmTrack-v0`` (taking ``preset=...``) and one
shorter alias per preset, e.g. ``SoftArmReachWang2023-v0``.

An alias fixes its preset: ``gym.make("SoftArmReachWang2023-v0", preset="ho2018")`` raises
``ValueError`` (the same preset passed again is accepted); the generic ids take any preset.
Every id refuses a keyword argument the env does not take with a ``ValueError`` naming it and
listing the ones it takes (rather than Python's ``TypeError``).

The entry points carry no ``metadata`` of their own, on purpose: ``gymnasium.make`` reads an entry
point's ``render_modes`` and, for ``render_mode="human"``, swaps in ``"rgb_array"`` behind its
``HumanRendering`` wrapper, which fails only at ``reset`` for want of pygame. Without them the
env itself sees ``"human"`` and refuses it at construction, naming the modes it has
(``SoftArmEnv.metadata["render_modes"]``, which the made env reports).
"""

from __future__ import annotations

from typing import Any

from gymnasium.envs.registration import register, registry

from soft_gym.envs.config import check_arguments
from soft_gym.envs.soft_arm_env import SoftArmEnv
from soft_gym.envs.vector import SoftArmVectorEnv
from soft_gym.robots.presets import PRESETS, get_preset
from soft_gym.robots.spec import ArmSpec

ENTRY_POINT = "soft_gym.envs.registration:make_env"
VECTOR_ENTRY_POINT = "soft_gym.envs.registration:make_vector_env"
ALIAS_ENTRY_POINT = "soft_gym.envs.registration:make_alias_env"
TASK_IDS = {"reach": "SoftArmReach-v0", "track": "SoftArmTrack-v0"}


def preset_env_id(task: str, preset: str) -> str:
    """Alias id of ``task`` on ``preset``, e.g. ``SoftArmTrackHo2018-v0``."""
    return f"SoftArm{task.capitalize()}{preset.capitalize()}-v0"


def registered_ids() -> list[str]:
    """Every id this package registers."""
    return list(TASK_IDS.values()) + [preset_env_id(t, p) for t in TASK_IDS for p in PRESETS]


def make_env(**kwargs: Any) -> SoftArmEnv:
    """The entry point of the generic ids: ``SoftArmEnv(**kwargs)``, refusing unknown keyword
    arguments with a ``ValueError`` that names them."""
    check_arguments(kwargs)
    return SoftArmEnv(**kwargs)



def make_alias_env(alias_preset: str, **kwargs: Any) -> SoftArmEnv:
    """The entry point of the alias ids: a :class:`SoftArmEnv` on the alias's preset.

    Args:
        alias_preset: the preset the alias id names (set at registration, e.g. ``"wang2023"``).
        **kwargs: the env's keyword arguments; a ``preset`` among them must be the alias's
            preset (its name, or an ``ArmSpec`` equal to it).

    Raises:
        ValueError: ``preset`` names another arm than the alias.
    """
    check_arguments(kwargs)
    return SoftArmEnv(**_with_alias_preset(alias_preset, kwargs))


def _with_alias_preset(alias_preset: str, kwargs: dict[str, Any]) -> dict[str, Any]:
    """``kwargs`` with the alias's preset, refusing another arm's."""
    kwargs = dict(kwargs)
    preset = kwargs.pop("preset", alias_preset)
    if not (isinstance(preset, (str, ArmSpec))
            and (preset == alias_preset or preset == get_preset(alias_preset))):
        task = kwargs.get("task", "reach")
        shown = (f"an ArmSpec named {preset.name!r}" if isinstance(preset, ArmSpec)
                 else repr(preset))
        raise ValueError(
            f"preset must be {alias_preset!r} on {preset_env_id(task, alias_preset)} (the id "
            f"names its arm), got {shown}: use {TASK_IDS.get(task, 'SoftArmReach-v0')} with "
            f"preset= for another arm")
    return {"preset": preset, **kwargs}


def make_vector_env(num_envs: int, alias_preset: str | None = None, *, threads: int = 1,
                    autoreset_mode: Any = "NextStep", per_env_kwargs: Any = None,
                    **kwargs: Any) -> SoftArmVectorEnv:
    """The vector entry point of every id (``gym.make_vec(id, num_envs=N,
    vectorization_mode="vector_entry_point", engine="mujoco", ...)``): a
    :class:`~soft_gym.envs.vector.SoftArmVectorEnv` of ``num_envs`` arms.

    Args:
        num_envs: arms in the batch.
        alias_preset: the preset an alias id names (set at registration), or ``None``.
        threads, autoreset_mode, per_env_kwargs: see
            :class:`~soft_gym.envs.vector.SoftArmVectorEnv`.
        **kwargs: the env's keyword arguments.
    """
    check_arguments(kwargs)
    if alias_preset is not None:
        kwargs = _with_alias_preset(alias_preset, kwargs)
        for own in per_env_kwargs if isinstance(per_env_kwargs, (list, tuple)) else []:
            if isinstance(own, dict) and "preset" in own:  # an arm of another preset: refused
                _with_alias_preset(alias_preset, {**kwargs, **own})
    return SoftArmVectorEnv(num_envs, threads=threads, autoreset_mode=autoreset_mode,
                            per_env_kwargs=per_env_kwargs, **kwargs)


def register_envs() -> None:
    """Register all ids (idempotent)."""
    for task, env_id in TASK_IDS.items():
        if env_id not in registry:
            register(id=env_id, entry_point=ENTRY_POINT, vector_entry_point=VECTOR_ENTRY_POINT,
                     kwargs={"task": task})
        for preset in PRESETS:
            alias = preset_env_id(task, preset)
            if alias not in registry:
                register(id=alias, entry_point=ALIAS_ENTRY_POINT,
                         vector_entry_point=VECTOR_ENTRY_POINT,
                         kwargs={"task": task, "alias_preset": preset})
