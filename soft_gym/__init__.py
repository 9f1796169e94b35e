"""soft-arm-gym: Gymnasium environments of pneumatic soft continuum arms simulated in PyBullet.

Importing the package registers the environment ids (see :mod:`soft_gym.envs.registration`).
"""

from soft_gym.envs.registration import register_envs, registered_ids

register_envs()

__version__ = "0.2.0"
__all__ = ["register_envs", "registered_ids", "__version__"]
