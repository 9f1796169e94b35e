"""Gymnasium ids: ``SoftArmReach-v0`` and ``SoftArmTrack-v0`` (taking ``preset=...``) and one
shorter alias per preset, e.g. ``SoftArmReachWang2023-v0``.
"""

from __future__ import annotations

from gymnasium.envs.registration import register, registry

from soft_gym.robots.presets import PRESETS

ENTRY_POINT = "soft_gym.envs.soft_arm_env:SoftArmEnv"
TASK_IDS = {"reach": "SoftArmReach-v0", "track": "SoftArmTrack-v0"}


def preset_env_id(task: str, preset: str) -> str:
    """Alias id of ``task`` on ``preset``, e.g. ``SoftArmTrackHo2018-v0``."""
    return f"SoftArm{task.capitalize()}{preset.capitalize()}-v0"


def registered_ids() -> list[str]:
    """Every id this package registers."""
    return list(TASK_IDS.values()) + [preset_env_id(t, p) for t in TASK_IDS for p in PRESETS]


def register_envs() -> None:
    """Register all ids (idempotent)."""
    for task, env_id in TASK_IDS.items():
        if env_id not in registry:
            register(id=env_id, entry_point=ENTRY_POINT, kwargs={"task": task})
        for preset in PRESETS:
            alias = preset_env_id(task, preset)
            if alias not in registry:
                register(id=alias, entry_point=ENTRY_POINT, kwargs={"task": task, "preset": preset})
