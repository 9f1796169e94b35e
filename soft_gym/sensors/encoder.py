"""Cable encoders on the chamber lengths (zou2022, Section 2 and Fig. 3; Section 3.1, Fig. 4).

Zou et al. 2022 run three cable encoders parallel to the backbone at the baseplate radius ``d``,
120 deg apart, reading the actuator lengths ``q = [l_1, l_2, l_3]`` (their eqs. (2)-(5) map these
to the arc parameters). The simulator's :meth:`ArmSimulator.chamber_lengths` gives the same
quantity, ``l_i = s + d (theta_x sin sigma_i - theta_y cos sigma_i)``. The reading adds white
Gaussian noise and is quantised to the encoder resolution:

    y_i = res * round((l_i + noise) / res)                                                  (E1)
"""

from __future__ import annotations

import numpy as np
from gymnasium import spaces

from soft_gym._validation import require_non_negative
from soft_gym.robots.spec import ArmSpec
from soft_gym.sensors.base import Sensor


class ChamberEncoders(Sensor):
    """Chamber lengths (m) from cable encoders (zou2022); float32 (n_chambers,).

    Args:
        rate_hz: samples per second (50 Hz assumed; zou2022 streams them over Bluetooth).
        resolution_m: quantisation step (m, >= 0; 0 disables it); 0.1 mm assumed.
        noise_std_m: white Gaussian noise before quantisation (m, >= 0); 0.05 mm assumed.
    """

    def __init__(self, rate_hz: float | None = 50.0, resolution_m: float = 1e-4,
                 noise_std_m: float = 5e-5) -> None:
        super().__init__("encoder", rate_hz)
        self.resolution_m = require_non_negative("resolution_m", resolution_m)
        self.noise_std_m = require_non_negative("noise_std_m", noise_std_m)
        self._spec: ArmSpec | None = None

    def _bind(self, spec: ArmSpec) -> None:
        if spec is self._spec:
            return
        # longest chamber: the longest arc plus d times the largest total bend the joint limits
        # allow (half a link more for the tip joint), with a margin
        high = []
        for segment in spec.segments:
            arc = segment.length_m * segment.max_extension_ratio
            bend = segment.max_bend_per_m_rad * (segment.length_m + segment.link_length_m)
            high += [1.25 * (arc + segment.chamber_offset_m * bend)] * 3
        self._high = np.array(high, dtype=np.float32)
        self._spec = spec

    def sample(self, sim) -> np.ndarray:
        """Chamber lengths (m), eq. (E1), float32 (n_chambers,)."""
        self._bind(sim.spec)
        lengths = sim.chamber_lengths()
        if self.noise_std_m > 0.0:
            lengths = lengths + self.noise_std_m * self.rng.standard_normal(lengths.shape[0])
        if self.resolution_m > 0.0:
            lengths = self.resolution_m * np.round(lengths / self.resolution_m)
        return np.clip(lengths, 0.0, self._high).astype(np.float32)

    def space(self, sim) -> spaces.Box:
        """Box ``[0, l_max]`` per chamber (m), ``l_max`` from the joint limits with a margin."""
        self._bind(sim.spec)
        return spaces.Box(np.zeros_like(self._high), self._high, dtype=np.float32)
