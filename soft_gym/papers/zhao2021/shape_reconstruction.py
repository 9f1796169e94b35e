"""zhao2021's shape reconstruction (SR): SFE-PD key points, then the 3-D backbone fit.

Zhao et al. 2021, Section III: the six SFE-PD networks (:mod:`soft_gym.papers.zhao2021.sfe_pd`, eqs. 1-6)
predict the key points ``P_1..P_6`` from the last ``w + 1`` actuations and strain readings, and
the backbone is fitted through ``O, P_1..P_6`` (:mod:`soft_gym.papers.zhao2021.backbone_fit`,
eqs. 7-10). The tip is ``P_6`` (Section IV: "robot's tip is the key point P_2N"), its orientation
the fitted backbone's tangent there.

:func:`fit_reconstruction` trains the networks on an exploration record; the paper's whole
recipe (the random exploration of 6000 samples, 4000 free and 2000 with a 75 g tip, then the
training, kept in the calibration cache so an env or a controller reuses it) drives a private
simulator and lives in :mod:`soft_gym.papers.zhao2021.exploration`.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from soft_gym._validation import (fields_from_options, require_choice, require_integer,
                                  require_learning_rate, require_non_negative, require_positive,
                                  require_seed)
from soft_gym.robots.spec import ArmSpec
from soft_gym.papers.zhao2021.backbone_fit import BACKBONE_CURVES, fit_backbone
from soft_gym.sensing.key_points import N_KEY_POINTS


@dataclass(frozen=True)
class ReconstructionConfig:
    """How the SR model is built (defaults: zhao2021 Section VI-A).

    Attributes:
        n_free: exploration samples with the arm free (4000).
        n_loaded: samples with ``load_kg`` on the tip after them (2000).
        load_kg: tip mass of the loaded samples (kg; 0.075).
        max_iterations: training iterations (epochs) at most (1000).
        target_rmse: training stops once every network's validation RMSE (normalised, eq. 5) is
            below this (0.001).
        batch_size: mini-batch size of an iteration (64).
        learning_rate: Adam's initial learning rate (0.01; after 300 iterations the paper's
            0.001 left the tip's validation error at 2.2 mm against 1.4 mm).
        dropout: between SFE and PD (0; the paper's 0.3, see :mod:`soft_gym.papers.zhao2021.sfe_pd`).
        n_points: backbone points returned by the fit (60, eq. 21's count).
        backbone_curve: the curve fitted through the key points, one of
            :data:`~soft_gym.papers.zhao2021.backbone_fit.BACKBONE_CURVES` (``"paper"``, eqs.
            7-10; it changes no training, so models are shared between curves).
        seed: seeds the exploration, the readings' noise and the training.
    """

    n_free: int = 4000
    n_loaded: int = 2000
    load_kg: float = 0.075
    max_iterations: int = 1000
    target_rmse: float = 1e-3
    batch_size: int = 64
    learning_rate: float = 1e-2
    dropout: float = 0.0
    n_points: int = 60
    backbone_curve: str = "paper"
    seed: int = 0

    def __post_init__(self) -> None:
        require_integer("n_free", self.n_free, 0)
        require_integer("n_loaded", self.n_loaded, 0)
        if self.n_free + self.n_loaded < 24:
            raise ValueError(f"n_free + n_loaded must be >= 24 (training and validation "
                             f"samples), got {self.n_free} + {self.n_loaded}")
        require_non_negative("load_kg", self.load_kg)
        require_integer("max_iterations", self.max_iterations, 1)
        require_positive("target_rmse", self.target_rmse)
        require_integer("batch_size", self.batch_size, 1)
        require_learning_rate("learning_rate", self.learning_rate)
        if not isinstance(self.dropout, (int, float)) or not 0.0 <= self.dropout < 1.0:
            raise ValueError(f"dropout must be a number in [0, 1), got {self.dropout!r}")
        require_integer("n_points", self.n_points, 2)
        require_choice("backbone_curve", self.backbone_curve, BACKBONE_CURVES)
        require_seed("seed", self.seed)

    @classmethod
    def from_options(cls, options: dict[str, Any]) -> "ReconstructionConfig":
        """From a dict of some of the fields; an unknown name is refused by name."""
        return cls(**fields_from_options(cls, options, "shape-reconstruction"))


@dataclass
class ShapeEstimate:
    """One reconstruction: key points ``P_1..P_6``, the fitted backbone and the tip pose."""

    key_points_m: np.ndarray      # (n_key_points, 3), m
    backbone_m: np.ndarray        # (n_points, 3), m, from the base to the tip
    tip_position_m: np.ndarray    # (3,), m
    tip_quaternion: np.ndarray    # (x, y, z, w)
    fit_methods: tuple[str, ...] = ()  # the curve of each subsegment ("isf" or "cubic")


class ShapeReconstructor:
    """Key-point predictor plus backbone fit (zhao2021 Section III).

    Args:
        predictor: a trained :class:`~soft_gym.papers.zhao2021.sfe_pd.SFEPDPredictor`.
        n_points: points of the returned backbone, evenly spaced by arc length.
        curve: the backbone fit's curve (:data:`~soft_gym.papers.zhao2021.backbone_fit.
            BACKBONE_CURVES`; ``"paper"``, eqs. 7-10).
    """

    def __init__(self, predictor, n_points: int = 60, curve: str = "paper") -> None:
        self.predictor = predictor
        self.n_points = require_integer("n_points", n_points, 2)
        self.curve = require_choice("curve", curve, BACKBONE_CURVES)

    @property
    def window(self) -> int:
        """``w`` of eq. (1): :meth:`reconstruct` takes ``w + 1`` steps."""
        return self.predictor.window

    def key_points(self, pressures_pa: np.ndarray, readings: np.ndarray) -> np.ndarray:
        """SFE-PD key points (m): ``(n_key_points, 3)``, or batched (see
        :meth:`SFEPDPredictor.predict`)."""
        return self.predictor.predict(pressures_pa, readings)

    def reconstruct(self, pressures_pa: np.ndarray, readings: np.ndarray) -> ShapeEstimate:
        """Key points and backbone from the last ``w + 1`` steps' pressures (Pa, ``(w + 1,
        n_chambers)``) and gauge readings (``(w + 1, n_gauges)``), oldest first."""
        points = self.key_points(pressures_pa, readings)
        fit = fit_backbone(np.vstack([np.zeros(3), points]), n_points=self.n_points,
                           curve=self.curve)
        return ShapeEstimate(points, fit.points_m, points[-1].copy(),
                             np.asarray(fit.tip_quaternion, dtype=float), fit.methods)

    def state(self) -> dict[str, Any]:
        return {"predictor": self.predictor.state(), "n_points": self.n_points}

    @classmethod
    def from_state(cls, state: dict[str, Any]) -> "ShapeReconstructor":
        from soft_gym.papers.zhao2021.sfe_pd import SFEPDPredictor  # imports PyTorch (+1.1 s)

        return cls(SFEPDPredictor.from_state(state["predictor"]), state["n_points"])

    def save(self, path: str | Path) -> None:
        """Write the networks and their normalisation (``n_points`` is a constructor option)."""
        self.predictor.save(path)

    @classmethod
    def load(cls, path: str | Path, n_points: int = 60) -> "ShapeReconstructor":
        """Read networks written by :meth:`save`; a corrupt file is refused by name."""
        from soft_gym.papers.zhao2021.sfe_pd import SFEPDPredictor  # imports PyTorch (+1.1 s)

        return cls(SFEPDPredictor.load(path), n_points)


def fit_reconstruction(spec: ArmSpec, data, config: ReconstructionConfig = ReconstructionConfig(),
                       progress: bool = True) -> tuple[ShapeReconstructor, dict[str, Any]]:
    """Train the SFE-PD networks on an exploration record (zhao2021 VI-A).

    Args:
        spec: the arm.
        data: the exploration (:class:`~soft_gym.papers.zhao2021.shape_exploration.ShapeDataset`).
        config: the training's settings.
        progress: show a progress bar.

    Returns the reconstructor and a report: the training's per-network validation RMSE
    (normalised) and its iterations.
    """
    import torch  # PyTorch: +1.1 s at import (-X importtime); the env needs it only to train

    from soft_gym.papers.zhao2021.sfe_pd import SFEPDPredictor  # imports PyTorch, as above

    predictor = SFEPDPredictor(N_KEY_POINTS, spec.n_chambers,
                               data.readings.shape[1], seed=config.seed, dropout=config.dropout)
    threads = torch.get_num_threads()
    torch.set_num_threads(1)  # the networks are tiny: more threads only add overhead
    try:
        report = predictor.fit(data.pressures_pa, data.readings, data.key_points_m,
                               max_iterations=config.max_iterations,
                               target_rmse=config.target_rmse, batch_size=config.batch_size,
                               learning_rate=config.learning_rate, progress=progress)
    finally:
        torch.set_num_threads(threads)
    return ShapeReconstructor(predictor, config.n_points, config.backbone_curve), {
        "iterations": report.iterations,
        "validation_rmse": report.validation_rmse.tolist(),
        "training_rmse": report.training_rmse.tolist()}
