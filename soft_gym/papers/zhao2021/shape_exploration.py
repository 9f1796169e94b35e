"""The strain-gauge shape-sensing data set: zhao2021's random exploration (Section VI-A).

Zhao et al. 2021 teach their shape reconstruction and their local inverse-kinematics network from
one data set: the robot explores its workspace at random, "any two of the six chambers ... randomly
adjusted to increase or decrease the pressure by 0.05 bar" per step, pressures kept within
[0, 0.8 bar], and one second after each change the backbone's key points are measured (an RGB-D
camera on markers) together with the strain-gauge readings. 6000 samples: 4000 with the arm free,
then 2000 with a 75 g mass on the tip.

:func:`soft_gym.papers.zhao2021.exploration.collect_exploration` does the same on a private
simulator of the arm (no env, no episode), recording per sample the commanded pressures ``A_n``, the gauge readings ``S_n`` (the env's own
gauge model, noise included), the key points ``P_1..P_2N`` (material points at equal thirds of each
segment's rest length, as the paper's markers: :func:`~soft_gym.sensing.key_points.key_points_from_backbone`), the whole
simulated backbone and the tip load. A pressure step that would leave the range is reflected
(the chamber moves the other way), so the walk never sticks at a bound.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

GAUGE_SETTINGS = ("rate_hz", "arc_fraction", "angle_offset_rad", "radius_m", "gauge_length_m",
                  "gain", "offset", "noise_std", "n_points")
"""The strain-gauge settings that change the recorded readings (part of the cache key)."""


@dataclass
class ShapeDataset:
    """Exploration samples, in the order they were taken.

    Attributes:
        pressures_pa: commanded chamber pressures ``A_n`` (Pa), (n, n_chambers).
        readings: strain-gauge readings ``S_n`` (the sensor's units), (n, n_gauges).
        key_points_m: key points ``P_1..P_2N`` (m, base frame), (n, n_key_points, 3).
        backbone_m: the simulated backbone (m, base frame), (n, n_links + 1, 3).
        tip_load_kg: mass hanging on the tip during each sample (kg), (n,).
    """

    pressures_pa: np.ndarray
    readings: np.ndarray
    key_points_m: np.ndarray
    backbone_m: np.ndarray
    tip_load_kg: np.ndarray

    def __len__(self) -> int:
        return int(self.pressures_pa.shape[0])


