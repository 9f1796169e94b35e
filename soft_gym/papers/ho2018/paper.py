"""ho2018 as one plug-in (:class:`~soft_gym.papers.paper.Paper`): its upright arm and the
stepper-driven cylinders that drive its chamber volumes (Section 3.1). Its EM tracker is a shared
sensor (``em``), read by the ``em`` feedback source of no paper in particular."""

from __future__ import annotations

from soft_gym.papers.ho2018.arm import HO2018, HO2018_CYLINDER_NOTES, HO2018_CYLINDERS
from soft_gym.papers.paper import Paper

PAPER = Paper(key="ho2018", citation="Ho et al. 2018", arms=(HO2018,),
              cylinders=HO2018_CYLINDERS, cylinder_notes=HO2018_CYLINDER_NOTES,
              evaluation="eval.papers.ho2018")
