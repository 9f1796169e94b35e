"""zou2022 (Zou et al. 2022): the CC shape of the chamber lengths (RSES), the stereo centreline
(ASES) and the DNN trained on it; the ``encoder_cc``, ``stereo`` and ``encoder_dnn`` feedback
sources."""
