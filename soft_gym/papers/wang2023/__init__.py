"""wang2023 (Wang et al. 2023): the eye-in-hand camera's ORB + PnP tracker, OS-ELM, F-emp on the
FBG fiber, the camera/F-emp fusion of eq. (18), the spiral exploration and the pipeline that
joins them; the ``camera``, ``fbg`` and ``fused`` feedback sources."""
