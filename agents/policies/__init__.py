"""Policies with stable-baselines3's face: the baselines by name, and trained SB3 agents.

* :mod:`agents.policies.base`: the :class:`BaselinePolicy` protocol (``reset``, ``predict``,
  ``update``, ``save``, ``load``) and the checks of what a policy is given
  (:func:`check_observation`, :func:`require_soft_arm_env`);
* :mod:`agents.policies.registry`: :data:`BASELINES` (name -> class) and :func:`make_policy`;
* :mod:`agents.policies.sb3`: :class:`SB3Policy` (``sb3:PATH``) and the shipped agents
  (:data:`SHIPPED_DIR`, :func:`shipped_agents`);
* :mod:`agents.policies.run_dir`: the files of a trained agent's run directory (their names,
  writers and readers; :func:`normalization_file`).

Every baseline is registered here, by name, in :data:`BASELINES`; the controllers themselves live
in :mod:`agents.controllers` (docs/architecture.md, "Baselines").
"""

from agents.policies.base import (BaselinePolicy, PolicyRefusal, check_observation,
                                  require_soft_arm_env)
from agents.policies.registry import BASELINES, make_policy
from agents.policies.run_dir import normalization_file
from agents.policies.sb3 import (NORMALIZATION_MARK, SB3_ALGORITHMS, SB3_INTERFACE_KEYS,
                                 SHIPPED_DIR, SB3Policy, mark_model_file, mark_normalization,
                                 model_normalization_mark, resolve_sb3_path, shipped_agents)

# Every baseline is lazy ("module:Class", imported when make_policy first builds it), for two
# reasons. The controllers subclass BaselinePolicy, so importing one runs this package first: an
# import of it here would be circular. And importing them costs start-up time that users of one
# baseline, of an sb3 agent or of the names alone do not need (python -X importtime, after
# agents.policies): cc_model 80 ms (scipy.optimize), hybrid_gpr 90 ms and lwpr_rwr 85 ms (the
# same scipy, mostly), local_ik_asdm 1.1 s (PyTorch).
BASELINES.register("cc_model", "agents.controllers.cc_model:CCModelController", lazy=True)
BASELINES.register("hybrid_gpr", "agents.controllers.hybrid_gpr:HybridGPRController", lazy=True)
BASELINES.register("lwpr_rwr", "agents.controllers.lwpr_rwr:LWPRRWRController", lazy=True)
BASELINES.register("local_ik_asdm", "agents.controllers.local_ik_asdm:LocalIKASDMController",
                   lazy=True)

__all__ = ["BASELINES", "BaselinePolicy", "NORMALIZATION_MARK", "PolicyRefusal", "SB3Policy",
           "SB3_ALGORITHMS", "SB3_INTERFACE_KEYS", "SHIPPED_DIR", "check_observation",
           "make_policy", "mark_model_file", "mark_normalization", "model_normalization_mark",
           "normalization_file", "require_soft_arm_env", "resolve_sb3_path", "shipped_agents"]
