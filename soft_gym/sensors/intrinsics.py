"""Pinhole intrinsics of the simulated cameras, as PyBullet's TinyRenderer samples them.

Shared by the eye-in-hand camera (:mod:`soft_gym.sensors.camera`), the stereo rig
(:mod:`soft_gym.sensors.stereo`) and the visual faults (:mod:`soft_gym.sensors.faults`), which
need the field of view but not the camera itself. Conventions (OpenCV): x right, y down,
z forward; :meth:`CameraIntrinsics.K` matches TinyRenderer's sampling exactly (pixel (u, v)
samples the image plane at ``u = cx + fx x/z``, ``v = cy + fy y/z`` with ``cx = W / 2``,
``cy = H / 2 - 1``; measured by sweeping a straight edge through the image, 0.01 px).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from soft_gym._validation import require_positive


@dataclass(frozen=True)
class CameraIntrinsics:
    """A pinhole camera with square pixels as PyBullet renders it.

    Args:
        width: image width (px).
        height: image height (px).
        hfov_deg: horizontal field of view (deg); endoscope cameras are wide, 90-120 deg.
        near_m: near clipping distance (m), before anything the camera must see (wang2023's
            camera is sharp from 8 mm).
        far_m: far clipping distance (m).
    """

    width: int = 160
    height: int = 120
    hfov_deg: float = 95.0
    near_m: float = 0.004
    far_m: float = 2.0

    def __post_init__(self) -> None:
        for name in ("width", "height"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or not (
                    8 <= value <= 4096):
                raise ValueError(f"{name} must be an integer in [8, 4096], got {value!r}")
        if not (np.isfinite(self.hfov_deg) and 1.0 <= self.hfov_deg <= 170.0):
            raise ValueError(f"hfov_deg must be within [1, 170], got {self.hfov_deg!r}")
        require_positive("near_m", self.near_m)
        require_positive("far_m", self.far_m)
        if self.far_m <= self.near_m:
            raise ValueError(f"far_m must be > near_m={self.near_m}, got {self.far_m!r}")

    @property
    def fx(self) -> float:
        """Focal length in pixels along x."""
        return 0.5 * self.width / math.tan(0.5 * math.radians(self.hfov_deg))

    @property
    def fy(self) -> float:
        """Focal length in pixels along y (square pixels)."""
        return self.fx

    @property
    def vfov_deg(self) -> float:
        """Vertical field of view (deg)."""
        return math.degrees(2.0 * math.atan(0.5 * self.height / self.fy))

    def K(self) -> np.ndarray:
        """OpenCV camera matrix (3, 3) consistent with TinyRenderer's images.

        ``cx = W / 2``, ``cy = H / 2 - 1``: TinyRenderer samples pixel column ``j`` at the
        left edge of the OpenGL pixel and stores rows bottom-up, so row ``i`` samples one
        pixel below the usual centre convention.
        """
        return np.array([[self.fx, 0.0, 0.5 * self.width],
                         [0.0, self.fy, 0.5 * self.height - 1.0],
                         [0.0, 0.0, 1.0]])

    def projection_matrix(self) -> list[float]:
        """OpenGL projection matrix for ``getCameraImage`` (16 floats, column-major)."""
        n, f = self.near_m, self.far_m
        matrix = np.array([[2.0 * self.fx / self.width, 0.0, 0.0, 0.0],
                           [0.0, 2.0 * self.fy / self.height, 0.0, 0.0],
                           [0.0, 0.0, -(f + n) / (f - n), -2.0 * f * n / (f - n)],
                           [0.0, 0.0, -1.0, 0.0]])
        return matrix.T.reshape(-1).tolist()

    def depth_from_buffer(self, buffer: np.ndarray) -> np.ndarray:
        """Metric depth along the optical axis (m) from PyBullet's [0, 1] depth buffer."""
        n, f = self.near_m, self.far_m
        buffer = np.asarray(buffer, dtype=np.float64)
        return f * n / (f - (f - n) * buffer)


def as_intrinsics(intrinsics: Any, default: CameraIntrinsics) -> CameraIntrinsics:
    """``intrinsics`` as a :class:`CameraIntrinsics`: ``None`` gives ``default``, a dict its
    fields; anything else raises ``ValueError``."""
    if intrinsics is None:
        return default
    if isinstance(intrinsics, CameraIntrinsics):
        return intrinsics
    if isinstance(intrinsics, dict):
        try:
            return CameraIntrinsics(**intrinsics)
        except TypeError as error:
            raise ValueError(f"intrinsics got invalid parameters {intrinsics}: {error}") from error
    raise ValueError(f"intrinsics must be None, a CameraIntrinsics or a dict, got {intrinsics!r}")


__all__ = ["CameraIntrinsics", "as_intrinsics"]
