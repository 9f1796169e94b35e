"""zhao2021's chamber numbering and key-point frame against ours: its six regulators as our
chambers, and points in its frame (Table III, Section VI) as points in our base frame.
"""

from __future__ import annotations

import numpy as np

ZHAO2021_PAPER_CHAMBERS = (0, 2, 1, 5, 3, 4)
"""Paper regulator (0-based: zhao2021's chambers 1-6 are 0-5) that drives each of our chambers.

Our chamber ``i`` of a segment sits at ``sigma_i = 2 pi i / 3`` counter-clockwise from +x (seen
from the base looking along +z, towards the tip). The assignment best reproducing Table III is:
segment 1 ours (0, 1, 2) = paper (1, 3, 2), segment 2 ours (0, 1, 2) = paper (6, 4, 5), i.e.
the paper numbers clockwise, and its segment 2 starts one chamber further round than its
segment 1: on the arm fitted to Table III alone, turning segment 2's numbering by another
120 deg either way raised the key points' RMS error from ~7 mm to 20-25 mm, and two other
assignments fitted as well as this one (RMS 7.24, 7.24 and 7.26 mm with the frame angle fitted
to each): the data cannot tell them apart, and the first is kept."""

ZHAO2021_PAPER_FRAME_DEG = 172.4
"""The paper's x axis is our x axis turned by this angle about +z (deg), fitted to Table III."""

ZHAO2021_PAPER_ORIGIN_Z_M = 0.0099
"""Our base (the first silicone station) lies this far along the paper's +z below its origin O
(m): the base ring. The paper's arm is 310 mm long with its rings (zhao2021 Section VI-E) where
the threads allow 300 mm, so up to 10 mm of rigid ring; 9.9 mm are put at the base, fitted with
the arm (soft_gym.papers.zhao2021.arm_fit) within that range (Section VI-C's start point
(40, 20, 300) mm is 303 mm from O, and Section VI-C's disturbed tip (19.8, 10.2, 303.6) mm
304 mm, beyond 300 mm of threads alone)."""


def paper_pressures_to_chambers(paper_pa: np.ndarray) -> np.ndarray:
    """zhao2021's six regulator pressures (its order, Pa) as our chamber pressures (Pa)."""
    paper = np.asarray(paper_pa, dtype=float)
    if paper.shape != (6,):
        raise ValueError(f"paper_pa must have shape (6,), got {paper.shape}")
    return paper[list(ZHAO2021_PAPER_CHAMBERS)]


def paper_point_from_base(point_m: np.ndarray, frame_deg: float = ZHAO2021_PAPER_FRAME_DEG,
                          origin_z_m: float = ZHAO2021_PAPER_ORIGIN_Z_M) -> np.ndarray:
    """A point in our zhao2021 base frame (m) in the paper's key-point frame (m).

    Both z axes run from the base towards the tip (the paper's key points have z = 0 at O and
    248.5 mm at the tip); the paper's x axis is ours turned by ``frame_deg`` (default
    ``ZHAO2021_PAPER_FRAME_DEG``) about z, and its origin lies ``origin_z_m`` (default
    ``ZHAO2021_PAPER_ORIGIN_Z_M``) before our base along z. Works on ``(..., 3)`` arrays.
    """
    angle = np.radians(frame_deg)
    c, s = np.cos(angle), np.sin(angle)
    p = np.asarray(point_m, dtype=float)
    x, y, z = p[..., 0], p[..., 1], p[..., 2]
    return np.stack([c * x - s * y, s * x + c * y, z + origin_z_m], axis=-1)


def base_point_from_paper(point_m: np.ndarray, frame_deg: float = ZHAO2021_PAPER_FRAME_DEG,
                          origin_z_m: float = ZHAO2021_PAPER_ORIGIN_Z_M) -> np.ndarray:
    """A point in the paper's key-point frame (m) in our zhao2021 base frame (m) (the inverse of
    :func:`paper_point_from_base`)."""
    angle = np.radians(frame_deg)
    c, s = np.cos(angle), np.sin(angle)
    p = np.asarray(point_m, dtype=float)
    x, y, z = p[..., 0], p[..., 1], p[..., 2]
    return np.stack([c * x + s * y, -s * x + c * y, z - origin_z_m], axis=-1)
