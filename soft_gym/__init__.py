"""soft-arm-gym: Gymnasium environments of pneumatic soft continuum arms simulated in PyBullet.

Importing the package registers the environment ids (see :mod:`soft_gym.envs.registration`).
"""

# first: the package's first ``import pybullet`` happens there, without its banner on stdout
import soft_gym.engines.pybullet.quiet_import  # noqa: F401,I001
import soft_gym.papers  # noqa: F401  (registers the papers' arms and feedback sources)
from soft_gym.envs.registration import register_envs, registered_ids

register_envs()

__version__ = "0.2.0"
__all__ = ["register_envs", "registered_ids", "__version__"]
