"""zou2022 as one plug-in (:class:`~soft_gym.papers.paper.Paper`): its arm, the ``encoder_cc``,
``stereo`` and ``encoder_dnn`` feedback sources and the DNN's calibration (the ASES-labelled
data set and the training, Section 4)."""

from __future__ import annotations

from soft_gym.papers.paper import Paper
from soft_gym.papers.zou2022.arm import ZOU2022
from soft_gym.papers.zou2022.dataset import calibrate_zou2022_dnn
from soft_gym.papers.zou2022.feedback import EncoderCCFeedback, EncoderDNNFeedback, StereoFeedback

PAPER = Paper(
    key="zou2022", citation="Zou et al. 2022", arms=(ZOU2022,),
    feedback_sources=(EncoderCCFeedback, StereoFeedback, EncoderDNNFeedback),
    calibrations={EncoderDNNFeedback.name: calibrate_zou2022_dnn},
    evaluation="eval.papers.zou2022")
