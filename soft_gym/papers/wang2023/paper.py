"""wang2023 as one plug-in (:class:`~soft_gym.papers.paper.Paper`): its arm, the ``camera``,
``fbg`` and ``fused`` feedback sources and their calibration (Section IV-B), and the visual
disturbances of Figs. 6-7 as fault presets."""

from __future__ import annotations

from soft_gym.papers.paper import Paper
from soft_gym.papers.wang2023.arm import WANG2023
from soft_gym.papers.wang2023.calibration import calibrate_wang2023_pipeline
from soft_gym.papers.wang2023.faults import wang2023_lighting, wang2023_occlusion
from soft_gym.papers.wang2023.feedback import CameraFeedback, FEmpFeedback, FusedFeedback

PAPER = Paper(
    key="wang2023", citation="Wang et al. 2023", arms=(WANG2023,),
    feedback_sources=(CameraFeedback, FEmpFeedback, FusedFeedback),
    calibrations={source.name: calibrate_wang2023_pipeline
                  for source in (FusedFeedback, CameraFeedback, FEmpFeedback)},
    fault_presets={"wang2023_occlusion": wang2023_occlusion,
                   "wang2023_lighting": wang2023_lighting},
    evaluation="eval.papers.wang2023")
