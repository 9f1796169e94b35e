"""ho2018 (Ho et al. 2018): the upright two-segment arm on stepper-driven cylinders, tracked by
an EM coil; its learners are in :mod:`agents.learners` (LWPR, RWR)."""
