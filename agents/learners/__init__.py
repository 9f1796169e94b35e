"""The learners of the baseline controllers (:mod:`agents.controllers`):

* :mod:`~agents.learners.sliding_gp`: :class:`SlidingWindowGP`, sliding-window Gaussian-process
  regression with an incrementally updated Cholesky factor (:func:`cholesky_rank1_update`),
  wang2023 Section III-B, the compensator of ``hybrid_gpr``;
* :mod:`~agents.learners.lwpr`: :class:`LWPR`, locally weighted projection regression
  (vijayakumar2005, klanke2008), ho2018's forward transition models, eqs. (1)-(6);
* :mod:`~agents.learners.rwr_inverse`: ``RewardWeightedInverse``, local linear inverses fitted
  by reward-weighted regression, ho2018 eqs. (4)-(13);
* :mod:`~agents.learners.local_ik`: ``LocalIKNetwork``, zhao2021's local inverse-kinematics
  network, eqs. (14)-(20). It is not imported here: it needs PyTorch, about 1.1 s of start-up
  (python -X importtime) that the other learners' users do not need.
"""

from agents.learners.lwpr import LWPR
from agents.learners.sliding_gp import SlidingWindowGP, cholesky_rank1_update

__all__ = ["LWPR", "SlidingWindowGP", "cholesky_rank1_update"]
