"""The baselines of the four papers with stable-baselines3's face, and trained SB3 agents.

* :mod:`agents.policies`: the protocol every policy follows, the registry of baselines by name
  (``BASELINES``, ``make_policy``) and the adapter of trained stable-baselines3 models
  (``sb3:PATH``, the shipped agents);
* :mod:`agents.controllers`: the baseline controllers of wang2023, ho2018 and zhao2021 (and
  wang2023's adapted to zou2022's extensible arm);
* :mod:`agents.learners`: the online and offline learners the controllers use;
* :mod:`agents.rollout`: one episode of a policy on an env, recorded step by step, and
  :mod:`agents.tracking_error`: its tracking error (what evaluation and training's tracking
  curve both use);
* ``agents/trained/``: the SB3 agents kept in the repository (``sb3:<name>``).

Agents use :mod:`soft_gym`, never the reverse (docs/architecture.md, "Layers and packages").
"""
