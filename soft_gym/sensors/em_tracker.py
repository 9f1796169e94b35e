"""Electromagnetic tip tracker (ho2018, Section 3.1 and Figure 3; wang2023, Section IV-B).

Ho et al. 2018 (Section 3.1) track the tip with an NDI Aurora 6-DoF coil: 0.80 mm position and
0.70 deg orientation accuracy at 40 Hz. wang2023 uses EM trackers on the tip as the pose ground
truth. The reading is the simulator's tip pose with

* per-axis Gaussian position noise of std ``position_noise_m`` (default 0.8 mm), and
* a small random rotation ``dR = exp([w]_x)``, ``w ~ N(0, sigma^2 I)`` per axis with
  ``sigma = orientation_noise_deg`` (default 0.7 deg), composed with the true orientation in the
  base frame: ``q_meas = q(dR) * q_true``. The total angle error ``|w|`` then has an RMS of
  ``sqrt(3) sigma`` (1.2 deg for the default).

Output: position (m, base frame, 3) and the unit quaternion ``(x, y, z, w)`` with ``w >= 0``
(the convention of :mod:`soft_gym.kinematics`), float32 (7,).
"""

from __future__ import annotations

import math

import numpy as np
from gymnasium import spaces

from soft_gym._quaternion import quaternion_multiply, rotation_vector_to_quaternion
from soft_gym._validation import require_non_negative
from soft_gym.robots.spec import ArmSpec
from soft_gym.sensors.base import Sensor


class EMTracker(Sensor):
    """Tip position (m) + orientation quaternion xyzw from an EM tracker (ho2018); float32 (7,).

    Args:
        rate_hz: samples per second; 40 Hz (ho2018, NDI Aurora).
        position_noise_m: per-axis position noise std (m, >= 0); 0.8 mm.
        orientation_noise_deg: per-axis std of the rotation-vector noise (deg, >= 0); 0.7 deg.
    """

    def __init__(self, rate_hz: float | None = 40.0, position_noise_m: float = 0.8e-3,
                 orientation_noise_deg: float = 0.7) -> None:
        super().__init__("em", rate_hz)
        self.position_noise_m = require_non_negative("position_noise_m", position_noise_m)
        self.orientation_noise_deg = require_non_negative("orientation_noise_deg",
                                                          orientation_noise_deg)
        self._spec: ArmSpec | None = None

    def _bind(self, spec: ArmSpec) -> None:
        if spec is self._spec:
            return
        reach = sum(s.length_m * s.max_extension_ratio for s in spec.segments)
        self._reach = np.float32(reach + 20.0 * self.position_noise_m + 0.01)
        self._spec = spec

    def sample(self, sim) -> np.ndarray:
        """Noisy tip pose: position (m, 3) then unit quaternion (x, y, z, w), float32 (7,)."""
        self._bind(sim.spec)
        position, quaternion = sim.tip_pose()
        position = np.asarray(position, dtype=float)
        quaternion = np.asarray(quaternion, dtype=float)
        if self.position_noise_m > 0.0:
            position = position + self.position_noise_m * self.rng.standard_normal(3)
        if self.orientation_noise_deg > 0.0:
            vector = math.radians(self.orientation_noise_deg) * self.rng.standard_normal(3)
            quaternion = quaternion_multiply(rotation_vector_to_quaternion(vector), quaternion)
        quaternion = quaternion / np.linalg.norm(quaternion)
        if quaternion[3] < 0.0:
            quaternion = -quaternion
        position = np.clip(position, -self._reach, self._reach)
        return np.concatenate([position, quaternion]).astype(np.float32)

    def space(self, sim) -> spaces.Box:
        """Box: position within the arm's reach (plus noise margin), quaternion in [-1, 1]."""
        self._bind(sim.spec)
        low = np.array([-self._reach] * 3 + [-1.0] * 4, dtype=np.float32)
        high = np.array([self._reach] * 3 + [1.0] * 4, dtype=np.float32)
        return spaces.Box(low, high, dtype=np.float32)
