"""The baseline controllers, each a :class:`agents.policies.BaselinePolicy` built by name with
:func:`agents.policies.make_policy` (registered in :mod:`agents.policies`):

* :mod:`~agents.controllers.cc_model` (``cc_model``): wang2023's constant-curvature model
  controller, eqs. (19)-(27), with start-up probes that calibrate its length-to-pressure map;
* :mod:`~agents.controllers.hybrid_gpr` (``hybrid_gpr``): the same compensated by an online
  sliding-window GP regressor, wang2023 eqs. (28)-(29);
* :mod:`~agents.controllers.lwpr_rwr` (``lwpr_rwr``): ho2018's LWPR forward models with a
  reward-weighted-regression inverse and a P controller, eqs. (1)-(14);
* :mod:`~agents.controllers.local_ik_asdm` (``local_ik_asdm``): zhao2021's local
  inverse-kinematics network with a fixed or adaptive (ASDM) step distance, eqs. (13)-(18);
* :mod:`~agents.controllers.modal_map`: not a controller but the length-to-pressure map with
  separate extension and bending gains that ``cc_model`` and ``hybrid_gpr`` use on zou2022's
  extensible arm in place of wang2023 eq. (27).
"""
