"""The MuJoCo engine: the PyBullet arm's chain with its springs, stiffening, damping and end
stops native, integrated in C between actuation updates (docs/architecture.md, "The MuJoCo
engine").

- :mod:`.model`: the chain as an MJCF model, with the end stops' tendons or without.
- :mod:`.stepping`: one arm or a batch of arms advanced in lockstep.
- :mod:`.simulator`: :class:`MujocoArmSimulator`, the :class:`soft_gym.simulator.Simulator`.
- :mod:`.world`: :class:`MujocoWorld`, which has no bodies beside the arm and no cameras.
"""

from soft_gym.engines.mujoco.simulator import MujocoArmSimulator
from soft_gym.engines.mujoco.world import MujocoWorld

__all__ = ["MujocoArmSimulator", "MujocoWorld"]
