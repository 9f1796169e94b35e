"""zhao2021 as one plug-in (:class:`~soft_gym.papers.paper.Paper`): its arm, the ``strain_sr``
feedback source and its calibration (the exploration and the SFE-PD networks, Section VI-A)."""

from __future__ import annotations

from soft_gym.papers.paper import Paper
from soft_gym.papers.zhao2021.arm import ZHAO2021
from soft_gym.papers.zhao2021.exploration import calibrate_zhao2021_reconstruction
from soft_gym.papers.zhao2021.feedback import StrainShapeFeedback

PAPER = Paper(
    key="zhao2021", citation="Zhao et al. 2021", arms=(ZHAO2021,),
    feedback_sources=(StrainShapeFeedback,),
    calibrations={StrainShapeFeedback.name: calibrate_zhao2021_reconstruction},
    evaluation="eval.papers.zhao2021")
