"""Environments and their registration with Gymnasium."""

from soft_gym.envs.soft_arm_env import SoftArmEnv

__all__ = ["SoftArmEnv"]
