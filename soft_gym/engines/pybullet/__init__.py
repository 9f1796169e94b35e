"""The PyBullet engine: the reference implementation of :class:`soft_gym.simulator.Simulator`.

The arm is a chain of rigid links joined by spring joints (:mod:`.builder`), driven by Python
every physics substep (:mod:`.simulator`, with the semi-implicit spring gains of
:mod:`.springs`, the mass-matrix correction of :mod:`.mass_matrix`, the held forces and tip
payloads of :mod:`.external_loads` and the contact-detection switch of :mod:`.contacts`);
:mod:`.world` makes the bodies around it and renders the cameras with TinyRenderer,
:mod:`.scene` builds the eye-in-hand camera's textured surroundings. :mod:`.quiet_import`
imports PyBullet without its banner (it comes first).
"""

from soft_gym.engines.pybullet.quiet_import import pybullet  # noqa: F401,I001  (first: no banner)
from soft_gym.engines.pybullet.simulator import ArmSimulator, PhysicsDivergedError
from soft_gym.engines.pybullet.world import PyBulletWorld

__all__ = ["ArmSimulator", "PhysicsDivergedError", "PyBulletWorld"]
