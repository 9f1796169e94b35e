"""F-emp: the FBG-empowered tip-pose estimator of Wang et al. 2023 (wang2023, Section II-C).

An :class:`~soft_gym.papers.wang2023.elm.OSELM` maps the FBG wavelength shifts ``lambda(k)`` to the tip
pose ``z = [position, quaternion]`` (eq. (1)). It is initialised from ``N0`` calibration steps of a
predefined exploration labelled by the *camera* pose (eqs. (5)-(9)), then updated online with every
step whose camera reprojection error ``e_S`` is below ``update_threshold_px`` (1.4 px in the paper:
selective update, eqs. (10)-(17)); it never sees ground truth. The quaternion output is
normalised; quaternion labels are kept in one hemisphere so the regression target is continuous.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from soft_gym._validation import as_finite_array, require_positive
from soft_gym.papers.wang2023.elm import OSELM


class FEmpEstimator:
    """Wavelength shifts (nm) -> tip position (m) and unit quaternion (x, y, z, w).

    Args:
        n_hidden: ELM hidden nodes (paper: 200).
        forgetting: ELM forgetting factor per update.
        ridge: ELM ridge term.
        update_threshold_px: selective-update bound on ``e_S`` (paper: 1.4 px).
        seed: seed of the ELM's random hidden layer.
    """

    def __init__(self, n_hidden: int = 200, forgetting: float = 0.999, ridge: float = 1e-3,
                 update_threshold_px: float = 1.4, seed: int = 0) -> None:
        self.update_threshold_px = require_positive("update_threshold_px", update_threshold_px)
        self.elm = OSELM(n_hidden=n_hidden, forgetting=forgetting, ridge=ridge, seed=seed)
        self.output_mean: np.ndarray | None = None
        self.output_scale: np.ndarray | None = None
        self.reference_quaternion: np.ndarray | None = None
        self.updates = 0

    @property
    def is_ready(self) -> bool:
        return self.output_mean is not None

    def initialize(self, shifts_nm: np.ndarray, positions_m: np.ndarray,
                   quaternions: np.ndarray) -> None:
        """Batch initialisation on ``N0`` labelled samples (wang2023 eqs. (5)-(9))."""
        shifts = as_finite_array("shifts_nm", shifts_nm)
        positions = as_finite_array("positions_m", positions_m)
        quaternions = as_finite_array("quaternions", quaternions)
        if not (shifts.ndim == 2 and positions.shape == (len(shifts), 3)
                and quaternions.shape == (len(shifts), 4)):
            raise ValueError(
                f"shifts_nm (n, l), positions_m (n, 3) and quaternions (n, 4) must match, got "
                f"{shifts.shape}, {positions.shape}, {quaternions.shape}")
        reference = quaternions.mean(axis=0)
        self.reference_quaternion = reference / np.linalg.norm(reference)
        targets = np.hstack([positions, self._hemisphere(quaternions)])
        self.output_mean = targets.mean(axis=0)
        self.output_scale = np.where(targets.std(axis=0) > 1e-12, targets.std(axis=0), 1.0)
        self.elm.fit(shifts, (targets - self.output_mean) / self.output_scale)
        self.updates = 0

    def update(self, shifts_nm: np.ndarray, position_m: np.ndarray, quaternion: np.ndarray,
               reprojection_error_px: float, lost: bool = False) -> bool:
        """Online update from one camera-labelled step if ``e_S`` is good enough; returns whether
        the model was updated (wang2023 selective update)."""
        self._require_ready()
        if lost or not np.isfinite(reprojection_error_px) or (
                reprojection_error_px >= self.update_threshold_px):
            return False
        target = np.r_[position_m, self._hemisphere(np.asarray(quaternion, dtype=float)[None])[0]]
        self.elm.update(shifts_nm, (target - self.output_mean) / self.output_scale)
        self.updates += 1
        return True

    def predict(self, shifts_nm: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Tip position (m) and unit quaternion from one reading of wavelength shifts (nm)."""
        self._require_ready()
        out = self.elm.predict(np.asarray(shifts_nm, dtype=float)) * self.output_scale + self.output_mean
        quaternion = out[3:] / max(np.linalg.norm(out[3:]), 1e-12)
        return out[:3], quaternion

    def save(self, path: str | Path) -> None:
        """Write the estimator to ``path`` (a directory is created with two ``.npz`` files)."""
        self._require_ready()
        directory = Path(path)
        directory.mkdir(parents=True, exist_ok=True)
        self.elm.save(directory / "elm.npz")
        np.savez(directory / "femp.npz", output_mean=self.output_mean,
                 output_scale=self.output_scale, reference_quaternion=self.reference_quaternion,
                 update_threshold_px=self.update_threshold_px, updates=self.updates)

    @classmethod
    def load(cls, path: str | Path) -> "FEmpEstimator":
        """Read an estimator written by :meth:`save`."""
        directory = Path(path)
        with np.load(directory / "femp.npz") as data:
            estimator = cls(update_threshold_px=float(data["update_threshold_px"]))
            estimator.output_mean = data["output_mean"].copy()
            estimator.output_scale = data["output_scale"].copy()
            estimator.reference_quaternion = data["reference_quaternion"].copy()
            estimator.updates = int(data["updates"])
        estimator.elm = OSELM.load(directory / "elm.npz")
        return estimator

    def _hemisphere(self, quaternions: np.ndarray) -> np.ndarray:
        signs = np.where(quaternions @ self.reference_quaternion < 0, -1.0, 1.0)
        return quaternions * signs[:, None]

    def _require_ready(self) -> None:
        if not self.is_ready:
            raise ValueError("the F-emp estimator is not initialised: call initialize() first")
