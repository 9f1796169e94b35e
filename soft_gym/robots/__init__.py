"""Arm descriptions, presets, arm files, the PyBullet builder and the pneumatics."""

from soft_gym.robots.arm_file import load_preset, save_preset
from soft_gym.robots.presets import PRESETS, get_preset
from soft_gym.robots.spec import ArmSpec, SegmentSpec

__all__ = ["ArmSpec", "SegmentSpec", "PRESETS", "get_preset", "load_preset", "save_preset"]
