"""Environments and their registration with Gymnasium.

:class:`SoftArmEnv` is made of an :class:`EnvConfig` (:mod:`soft_gym.envs.config`), the
observation-part table (:mod:`soft_gym.envs.observations`) and a task
(:mod:`soft_gym.tasks`); :mod:`soft_gym.envs.rendering` draws it.
"""

from soft_gym.envs.config import EnvConfig
from soft_gym.envs.soft_arm_env import SoftArmEnv

__all__ = ["EnvConfig", "SoftArmEnv"]
