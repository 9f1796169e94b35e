"""The DNN correcting the CC shape with vision (Zou et al. 2022, Section 5.1, eqs. 17-19, Table 2).

Zou et al. 2022 learn the map from the encoders' chamber lengths ``q_1`` (3) to the vision
system's backbone ``Q^`` (7 points, 21 numbers), ``Q~ = g(q_1)`` (eq. 17), with a fully connected
network (eq. 18, Table 2) trained on a data set of their arm:

* **Data set** (Section 5.1 (1)): the three pressures swept over 0-3 bar in 0.1 bar steps
  (``31^3 = 29791`` samples, 35 h); per sample the encoders' ``q_1`` is the input and ASES's
  ``Q^`` (:mod:`soft_gym.papers.zou2022.stereo_shape`) the label. Samples where ASES fails (827, self
  occlusion) are removed and replaced by copies of good ones rotated about the arm's axis ("on
  account of the radial symmetrical distribution of PMAs"); the set is split at random into
  training (70 %), validation (15 %) and test (15 %) sets. Here :func:`collect_dataset` does the
  same on a private simulator: random points of the 0.1 bar grid (the random pressure
  exploration), ``settle_s`` after each change, the env's encoder model and a private stereo
  camera in a clear view, and also the true ``P_0 .. P_6`` for evaluation. A rotation by
  ``+120 deg`` about ``z`` maps chamber lengths ``l_i -> l_{i-1}`` (chamber ``i`` sits at
  ``2 pi i / 3``) and turns every point.
* **Network** (Table 2, eq. 18): eight linear layers, ``3 -> 15 -> 15 -> 15 -> 15 -> 45 -> 45 ->
  45 -> 21``, ReLU after all but the last (the table's input layer ``[3, 15]``, hidden layers 2-4
  of 15, 5 ``[15, 45]``, 6-7 of 45, output ``[45, 21]``).
* **Training** (eq. 19, Table 2): Adam, learning rate 0.001, batch 128, 500 epochs, MSE between
  ``Q~`` and ``Q^`` plus ``gamma ||beta||^2`` (``gamma = 0.01``, all weights and biases) inside
  eq. 19's ``1 / (N_tr N_out)``; the validation MSE after every epoch picks the weights kept
  (the paper "judge[s]" with it; Fig. 15 converges at ~500 epochs). Inputs are standardised per
  chamber; outputs are centred per coordinate and divided by one common scale, so the loss
  weighs every millimetre alike as eq. 19 does.

Inference runs in numpy on the stored weights (a forward pass of the tiny network is ~10 us,
torch's per-call overhead alone is several times that); it equals the torch forward pass up to
float32 rounding. Models save to one file with their normalisation and a SHA-256 digest; a
corrupt or foreign file is refused by name. The data set and the trained model live in the
calibration cache (:mod:`soft_gym.sensing.calibration_cache`) under their recipes.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from tqdm.auto import tqdm

from soft_gym._model_files import read_model_state, write_model_state
from soft_gym._validation import (fields_from_options, require_in_range, require_integer,
                                  require_learning_rate, require_non_negative, require_positive,
                                  require_seed)
from soft_gym.robots.spec import ArmSpec
from soft_gym.sensing.key_points import key_points_from_backbone
from soft_gym.sensors.stereo import StereoCamera

PAPER_SAMPLES = 31 ** 3
"""Section 5.1: 0-3 bar in 0.1 bar steps in each of three chambers."""

HIDDEN_WIDTHS = (15, 15, 15, 15, 45, 45, 45)
"""Outputs of the seven hidden linear layers of Table 2 (input layer ``[3, 15]`` included)."""

N_POINTS = 7
_FORMAT = "soft-arm-gym zou2022 shape-dnn 1"


@dataclass(frozen=True)
class ShapeDNNConfig:
    """How the DNN is built (defaults: zou2022 Section 5.1 and Table 2).

    Attributes:
        n_samples: exploration samples (29791, the paper's ``31^3``; build a few hundred on a
            busy machine).
        pressure_step_pa: grid step of the commanded pressures (Pa; 0.1 bar).
        settle_s: time from a pressure change to the measurement (s).
        augment: replace samples where ASES was lost by rotated copies of good ones (the
            paper's supplement); ``False`` drops them.
        train_fraction, validation_fraction: split of the samples (0.7, 0.15; the test set
            gets the rest).
        epochs: training epochs (500).
        batch_size: mini-batch size (128).
        learning_rate: Adam's learning rate (0.001).
        l2: ``gamma`` of eq. 19 (0.01).
        hidden_widths: widths of the hidden layers (Table 2).
        seed: seeds the exploration, the sensors' noise, the split and the training.
    """

    n_samples: int = PAPER_SAMPLES
    pressure_step_pa: float = 1e4
    settle_s: float = 2.0
    augment: bool = True
    train_fraction: float = 0.7
    validation_fraction: float = 0.15
    epochs: int = 500
    batch_size: int = 128
    learning_rate: float = 1e-3
    l2: float = 0.01
    hidden_widths: tuple[int, ...] = HIDDEN_WIDTHS
    seed: int = 0

    def __post_init__(self) -> None:
        require_integer("n_samples", self.n_samples, 20)
        require_positive("pressure_step_pa", self.pressure_step_pa)
        require_positive("settle_s", self.settle_s)
        if not isinstance(self.augment, (bool, np.bool_)):
            raise ValueError(f"augment must be True or False, got {self.augment!r}")
        require_in_range("train_fraction", self.train_fraction, 0.05, 0.95)
        require_in_range("validation_fraction", self.validation_fraction, 0.01, 0.9)
        if self.train_fraction + self.validation_fraction >= 1.0:
            raise ValueError("train_fraction + validation_fraction must be < 1 (samples left "
                             f"for the test set), got {self.train_fraction} + "
                             f"{self.validation_fraction}")
        require_integer("epochs", self.epochs, 1)
        require_integer("batch_size", self.batch_size, 1)
        require_learning_rate("learning_rate", self.learning_rate)
        require_non_negative("l2", self.l2)
        widths = self.hidden_widths
        if (not isinstance(widths, (tuple, list)) or not widths or not all(
                isinstance(w, (int, np.integer)) and not isinstance(w, bool) and w >= 1
                for w in widths)):
            raise ValueError(f"hidden_widths must be a non-empty sequence of integers >= 1, got "
                             f"{widths!r}")
        object.__setattr__(self, "hidden_widths", tuple(int(w) for w in widths))
        require_seed("seed", self.seed)

    @classmethod
    def from_options(cls, options: dict[str, Any]) -> "ShapeDNNConfig":
        """From a dict of some of the fields; an unknown name is refused by name."""
        return cls(**fields_from_options(cls, options, "shape-DNN"))

    def dataset_recipe(self) -> dict[str, Any]:
        """The fields that change the data set (a cache key)."""
        recipe = {name: getattr(self, name) for name in
                  ("n_samples", "pressure_step_pa", "settle_s", "augment", "train_fraction",
                   "validation_fraction", "seed")}
        # each grid command once, split by command (no test sample repeats a training command)
        recipe["sampling"] = "grid without replacement, split by command"
        return recipe


# ---------------------------------------------------------------------------------- data set
@dataclass
class ZouDataset:
    """Exploration samples and their split (zou2022 Section 5.1 (1)).

    Attributes:
        pressures_pa: commanded pressures (Pa), (n, n_chambers).
        lengths_m: the encoders' chamber lengths ``q_1`` (m), (n, n_chambers): the input.
        labels_m: ASES's ``Q^`` = ``P_0 .. P_6`` (m, base frame), (n, 7, 3): the label.
        truth_m: the simulator's ``P_0 .. P_6`` (m), (n, 7, 3): for evaluation only.
        augmented: the sample is a rotated copy replacing one where ASES was lost, (n,).
        n_lost: exploration samples where ASES was lost.
        train, validation, test: sample indices of the three sets.
    """

    pressures_pa: np.ndarray
    lengths_m: np.ndarray
    labels_m: np.ndarray
    truth_m: np.ndarray
    augmented: np.ndarray
    n_lost: int
    train: np.ndarray = field(default_factory=lambda: np.zeros(0, int))
    validation: np.ndarray = field(default_factory=lambda: np.zeros(0, int))
    test: np.ndarray = field(default_factory=lambda: np.zeros(0, int))

    def __len__(self) -> int:
        return int(self.lengths_m.shape[0])


def rotate_about_axis(lengths_m: np.ndarray, points_m: np.ndarray,
                      turns: int) -> tuple[np.ndarray, np.ndarray]:
    """The sample rotated by ``turns * 120 deg`` about the base ``z`` axis: chamber lengths
    ``l_i -> l_{i - turns}`` within each segment, points (..., 3) rotated."""
    lengths = np.asarray(lengths_m, dtype=float)
    per_segment = lengths.reshape(lengths.shape[:-1] + (-1, 3))
    rolled = np.roll(per_segment, turns, axis=-1).reshape(lengths.shape)
    angle = 2.0 * np.pi * turns / 3.0
    c, s = np.cos(angle), np.sin(angle)
    rotation = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    return rolled, np.asarray(points_m, dtype=float) @ rotation.T


def default_stereo():
    """The stereo camera of the data set and of the ``stereo`` source: a 320 x 180 pair (the
    ZED's 1280 x 720 aspect at a quarter size), 70 deg horizontal field, 12 cm baseline."""
    return StereoCamera(intrinsics=STEREO_INTRINSICS)


STEREO_INTRINSICS = {"width": 320, "height": 180, "hfov_deg": 70.0, "near_m": 0.05, "far_m": 5.0}
"""Default intrinsics of the zou2022 stereo pair here (see :func:`default_stereo`)."""


def true_shape_points(spec: ArmSpec, backbone_m: np.ndarray) -> np.ndarray:
    """``P_0 .. P_6`` (m, (7, 3)) of a simulated backbone: the base and the material points at
    sixths of the rest length (as the ``ground_truth`` source gives them)."""
    backbone = np.asarray(backbone_m, dtype=float)
    return np.concatenate([backbone[..., :1, :], key_points_from_backbone(spec, backbone)],
                          axis=-2)


# ---------------------------------------------------------------------------------- network
def build_network(hidden_widths: tuple[int, ...] = HIDDEN_WIDTHS, n_inputs: int = 3,
                  n_outputs: int = 3 * N_POINTS):
    """Table 2's network (eq. 18): linear layers through ``hidden_widths`` with ReLU, then a
    linear output layer."""
    from torch import nn  # +1.1 s at import (-X importtime): only to train or load

    layers: list[Any] = []
    width = n_inputs
    for hidden in hidden_widths:
        layers += [nn.Linear(width, hidden), nn.ReLU()]
        width = hidden
    layers.append(nn.Linear(width, n_outputs))
    return nn.Sequential(*layers)


@dataclass
class TrainingReport:
    """Per-epoch training and validation MSE (m^2, the labels' units) and the epoch kept."""

    training_mse: np.ndarray
    validation_mse: np.ndarray
    best_epoch: int


class ShapeDNN:
    """``Q~ = g(q_1)`` (eq. 17): chamber lengths (m) to ``P_0 .. P_6`` (m), with normalisation.

    Args:
        n_inputs: chamber lengths in (3 per segment).
        hidden_widths: Table 2's hidden widths.
        seed: seeds the weights and the mini-batch order.
    """

    def __init__(self, n_inputs: int = 3, hidden_widths: tuple[int, ...] = HIDDEN_WIDTHS,
                 seed: int = 0) -> None:
        import torch  # +1.1 s at import (-X importtime): only to train or load the DNN

        self.n_inputs = require_integer("n_inputs", n_inputs, 1)
        self.hidden_widths = ShapeDNNConfig(hidden_widths=hidden_widths).hidden_widths
        self.seed = require_seed("seed", seed)
        torch.manual_seed(self.seed)
        self.network = build_network(self.hidden_widths, self.n_inputs)
        self.input_mean: np.ndarray | None = None
        self.input_scale: np.ndarray | None = None
        self.output_mean: np.ndarray | None = None
        self.output_scale: float | None = None
        self.report: TrainingReport | None = None
        self._layers: list[tuple[np.ndarray, np.ndarray]] = []

    # ------------------------------------------------------------------ training
    def fit(self, lengths_m: np.ndarray, points_m: np.ndarray, train: np.ndarray,
            validation: np.ndarray, epochs: int = 500, batch_size: int = 128,
            learning_rate: float = 1e-3, l2: float = 0.01,
            progress: bool = True) -> TrainingReport:
        """Train on ``train`` rows, keep the weights of the epoch with the lowest validation
        MSE (eq. 19; Adam). Runs torch on one thread."""
        import torch  # +1.1 s at import (-X importtime): only to train or load the DNN

        lengths, points = self._check_data(lengths_m, points_m)
        train = self._check_index("train", train, len(lengths))
        validation = self._check_index("validation", validation, len(lengths))
        epochs = require_integer("epochs", epochs, 1)
        batch_size = require_integer("batch_size", batch_size, 1)
        require_learning_rate("learning_rate", learning_rate)
        require_non_negative("l2", l2)
        targets = points.reshape(len(points), -1)
        self.input_mean = lengths[train].mean(axis=0)
        self.input_scale = np.maximum(lengths[train].std(axis=0), 1e-9)
        self.output_mean = targets[train].mean(axis=0)
        self.output_scale = float(max(np.sqrt(((targets[train] - self.output_mean) ** 2).mean()),
                                      1e-9))
        x = torch.as_tensor((lengths - self.input_mean) / self.input_scale, dtype=torch.float32)
        y = torch.as_tensor((targets - self.output_mean) / self.output_scale, dtype=torch.float32)
        x_train, y_train = x[train], y[train]
        x_val, y_val = x[validation], y[validation]
        n_train, n_out = len(train), targets.shape[1]
        penalty = l2 / (n_train * n_out)  # eq. 19: gamma ||beta||^2 inside 1 / (N_tr N_out)
        threads = torch.get_num_threads()
        torch.set_num_threads(1)  # a tiny network: more threads only add overhead
        try:
            torch.manual_seed(self.seed)
            generator = torch.Generator().manual_seed(self.seed)
            optimiser = torch.optim.Adam(self.network.parameters(), lr=learning_rate)
            parameters = list(self.network.parameters())
            train_mse, val_mse = np.empty(epochs), np.empty(epochs)
            best, best_epoch = np.inf, 0
            best_state = copy.deepcopy(self.network.state_dict())
            bar = tqdm(range(epochs), desc="zou2022 DNN training", disable=not progress,
                       leave=False)
            for epoch in bar:
                self.network.train()
                order = torch.randperm(n_train, generator=generator)
                total = 0.0
                for start in range(0, n_train, batch_size):
                    batch = order[start:start + batch_size]
                    error = ((self.network(x_train[batch]) - y_train[batch]) ** 2).mean()
                    loss = error + penalty * sum((p ** 2).sum() for p in parameters)
                    optimiser.zero_grad()
                    loss.backward()
                    optimiser.step()
                    total += float(error.detach()) * len(batch)
                train_mse[epoch] = total / n_train * self.output_scale ** 2
                self.network.eval()
                with torch.no_grad():
                    val_mse[epoch] = float(((self.network(x_val) - y_val) ** 2).mean()) \
                        * self.output_scale ** 2
                if val_mse[epoch] < best:
                    best, best_epoch = val_mse[epoch], epoch
                    best_state = copy.deepcopy(self.network.state_dict())
                bar.set_postfix(val_rmse_mm=f"{np.sqrt(best) * 1e3:.2f}")
            bar.close()
        finally:
            torch.set_num_threads(threads)
        self.network.load_state_dict(best_state)
        self._cache_layers()
        self.report = TrainingReport(train_mse, val_mse, best_epoch)
        return self.report

    def _cache_layers(self) -> None:
        from torch import nn  # +1.1 s at import (-X importtime): only to train or load

        self._layers = [(m.weight.detach().numpy().astype(np.float64).T.copy(),
                         m.bias.detach().numpy().astype(np.float64).copy())
                        for m in self.network if isinstance(m, nn.Linear)]

    # ------------------------------------------------------------------ inference
    def predict(self, lengths_m: np.ndarray) -> np.ndarray:
        """``P_0 .. P_6`` (m) from chamber lengths (m): (n_inputs,) -> (7, 3), or batched
        (n, n_inputs) -> (n, 7, 3). numpy, float64, on the stored float32 weights."""
        if self.input_mean is None:
            raise ValueError("the DNN is not trained: call fit() or load() first")
        if lengths_m is None or np.iscomplexobj(lengths_m):
            raise ValueError(f"lengths_m must be real chamber lengths (m), got {lengths_m!r}")
        try:
            x = np.asarray(lengths_m, dtype=np.float64)
        except (TypeError, ValueError) as error:
            raise ValueError(f"lengths_m must be chamber lengths (m, numbers), got "
                             f"{lengths_m!r}") from error
        if x.shape[-1:] != (self.n_inputs,) or x.ndim not in (1, 2):
            raise ValueError(f"lengths_m must have shape ([n,] {self.n_inputs}) (chamber lengths "
                             f"in m), got {x.shape}")
        bad = ~(np.isfinite(x) & (x > 0.0))
        if bad.any():
            where = tuple(int(i) for i in np.argwhere(bad)[0])
            raise ValueError(f"lengths_m must be finite chamber lengths > 0 (m), got "
                             f"{float(x[where])!r} at index {where}")
        h = (x - self.input_mean) / self.input_scale
        last = len(self._layers) - 1
        for i, (weight, bias) in enumerate(self._layers):
            h = h @ weight + bias
            if i < last:
                np.maximum(h, 0.0, out=h)
        out = (self.output_mean + h * self.output_scale).reshape(h.shape[:-1] + (N_POINTS, 3))
        return out

    def predict_torch(self, lengths_m: np.ndarray) -> np.ndarray:
        """The same as :meth:`predict` through the torch module (float32): a reference."""
        import torch  # +1.1 s at import (-X importtime): only to train or load the DNN

        x = np.atleast_2d(np.asarray(lengths_m, dtype=np.float64))
        self.network.eval()
        with torch.no_grad():
            h = self.network(torch.as_tensor((x - self.input_mean) / self.input_scale,
                                             dtype=torch.float32)).numpy().astype(np.float64)
        out = (self.output_mean + h * self.output_scale).reshape(len(x), N_POINTS, 3)
        return out[0] if np.ndim(lengths_m) == 1 else out

    # ------------------------------------------------------------------ persistence
    def state(self) -> dict[str, Any]:
        """Everything :meth:`from_state` needs, as plain arrays and numbers."""
        if self.input_mean is None:
            raise ValueError("the DNN is not trained: nothing to save")
        return {"n_inputs": self.n_inputs, "hidden_widths": self.hidden_widths,
                "seed": self.seed,
                "weights": {k: v.detach().numpy().copy()
                            for k, v in self.network.state_dict().items()},
                "input_mean": self.input_mean, "input_scale": self.input_scale,
                "output_mean": self.output_mean, "output_scale": self.output_scale}

    @classmethod
    def from_state(cls, state: dict[str, Any]) -> "ShapeDNN":
        import torch  # +1.1 s at import (-X importtime): only to train or load the DNN

        dnn = cls(state["n_inputs"], tuple(state["hidden_widths"]), state["seed"])
        dnn.network.load_state_dict({k: torch.as_tensor(np.asarray(v))
                                     for k, v in state["weights"].items()})
        dnn.input_mean = np.asarray(state["input_mean"], dtype=float)
        dnn.input_scale = np.asarray(state["input_scale"], dtype=float)
        dnn.output_mean = np.asarray(state["output_mean"], dtype=float)
        dnn.output_scale = float(state["output_scale"])
        dnn._cache_layers()
        return dnn

    def save(self, path: str | Path) -> None:
        """Write the network and its normalisation to ``path`` (a digest-checked model file)."""
        write_model_state(path, _FORMAT, self.state())

    @classmethod
    def load(cls, path: str | Path) -> "ShapeDNN":
        """Read a file written by :meth:`save`; a corrupt or foreign file is refused by name."""
        return read_model_state(path, _FORMAT, "zou2022 shape-DNN", cls.from_state)

    # ------------------------------------------------------------------ checks
    def _check_data(self, lengths_m, points_m) -> tuple[np.ndarray, np.ndarray]:
        lengths = np.asarray(lengths_m, dtype=float)
        points = np.asarray(points_m, dtype=float)
        n = lengths.shape[0] if lengths.ndim else 0
        for name, array, shape in (("lengths_m", lengths, (n, self.n_inputs)),
                                   ("points_m", points, (n, N_POINTS, 3))):
            if array.shape != shape:
                raise ValueError(f"{name} must have shape {shape}, got {array.shape}")
            if not np.all(np.isfinite(array)):
                raise ValueError(f"{name} must be finite (no NaN: drop samples where ASES was "
                                 "lost)")
        return lengths, points

    @staticmethod
    def _check_index(name: str, index, n: int) -> np.ndarray:
        array = np.asarray(index)
        if (array.ndim != 1 or array.size == 0 or not np.issubdtype(array.dtype, np.integer)
                or array.min() < 0 or array.max() >= n):
            raise ValueError(f"{name} must be a non-empty array of sample indices in [0, {n}), "
                             f"got {index!r}")
        return array


def axis_errors_mm(estimate_m: np.ndarray, reference_m: np.ndarray) -> dict[str, np.ndarray]:
    """Table 3's criteria: per-axis MAE and RMSE (mm) of ``estimate_m`` against
    ``reference_m`` (both (..., 3), m), and the mean 3-D point distance (mm)."""
    difference = (np.asarray(estimate_m, float) - np.asarray(reference_m, float)) * 1e3
    flat = difference.reshape(-1, 3)
    return {"mae_mm": np.abs(flat).mean(axis=0), "rmse_mm": np.sqrt((flat ** 2).mean(axis=0)),
            "mean_distance_mm": float(np.linalg.norm(flat, axis=1).mean())}


__all__ = ["PAPER_SAMPLES", "HIDDEN_WIDTHS", "STEREO_INTRINSICS", "ShapeDNNConfig", "ZouDataset",
           "rotate_about_axis", "default_stereo", "true_shape_points", "build_network",
           "TrainingReport", "ShapeDNN", "axis_errors_mm"]
