"""zhao2021's local inverse-kinematics network ``g`` (eqs. 14-15, Section IV-C).

``A_{n+1} = g(A_n, Q_n, Q_dn, S_n)``: from the present actuation ``A_n`` (six chamber pressures),
tip position ``Q_n``, a nearby desired tip position ``Q_dn`` and the strain readings ``S_n``, the
next actuation. A multilayer perceptron with 18 inputs, two sigmoid hidden layers of 7 and 5
nodes and six ReLU outputs (eq. 19: the regulators' pressures are never negative), trained with
Adam on the RMSE of eq. (20), at most 1000 iterations or until the RMSE falls below 0.001, on the
random-exploration data of the shape reconstruction (Section VI-A): consecutive samples ``n`` and
``n + 1`` give the input ``(A_n, Q_n, Q_{n+1}, S_n)`` and the target ``A_{n+1}``.

Inputs are normalised to [-1, 1] over the training data (Section VI-A); outputs are pressures as
fractions of ``p_max``, so that the ReLU's floor is the regulators' zero. Two choices the paper
leaves open, measured on the 6000-sample zhao2021 exploration (200 iterations, learning rate
0.01, batches of 64):

* **Skip.** Six pressures cannot pass through a 5-node layer, so the plain 7-5 network cannot
  even return ``A_n`` when the tip should stay: it ended at an RMSE of 0.34 of ``p_max`` on its
  training pairs, no better than a constant. With ``skip=True`` (default) the output layer adds
  ``A_n`` before the ReLU, so the hidden layers carry only the change ``A_{n+1} - A_n``: RMSE
  0.027 (2.2 kPa), with predicted changes correlated 0.66 with the exploration's (a change of two
  random chambers is only partly predictable from the tip's motion; 64-64 hidden nodes did no
  better, 0.65).
* **Displacement.** ``Q_dn`` enters as ``Q_dn - Q_n``: a linear recombination of the paper's
  inputs, which the first layer could learn, but after the [-1, 1] normalisation a few-mm step
  would be a difference of two large, nearly equal inputs.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import torch
from torch import nn
from tqdm.auto import tqdm

from soft_gym._model_files import read_model_state, write_model_state
from soft_gym._validation import require_integer, require_learning_rate, require_positive
from soft_gym.papers.zhao2021.sfe_pd import Normaliser

_FORMAT = "soft-arm-gym local-ik 1"
HIDDEN_LAYERS = (7, 5)
"""zhao2021 Section IV-C: two hidden layers of 7 and 5 sigmoid nodes."""


class _MLP(nn.Module):
    """Sigmoid hidden layers, a linear output layer and the ReLU (eq. 19); with ``skip`` the
    present actuation (the first ``n_outputs`` raw inputs) is added before the ReLU."""

    def __init__(self, n_inputs: int, n_outputs: int, hidden: tuple[int, ...],
                 skip: bool) -> None:
        super().__init__()
        layers: list[nn.Module] = []
        width = n_inputs
        for size in hidden:
            layers += [nn.Linear(width, size), nn.Sigmoid()]
            width = size
        layers.append(nn.Linear(width, n_outputs))
        self.layers = nn.Sequential(*layers)
        self.skip = skip
        self.n_outputs = n_outputs

    def forward(self, x: torch.Tensor, present: torch.Tensor) -> torch.Tensor:
        out = self.layers(x)
        return torch.relu(out + present if self.skip else out)


class LocalIKNetwork:
    """The MLP ``g`` with its normalisation (zhao2021 eqs. 14-15, 19-20).

    Args:
        n_chambers: size of ``A`` (six for the two-segment arm).
        n_gauges: size of ``S``.
        p_max_pa: each chamber's largest pressure (Pa), the output scale.
        hidden: hidden layer sizes.
        skip: add the present actuation ``A_n`` to the output layer before the ReLU, so the
            hidden layers learn the change ``A_{n+1} - A_n`` (see the module docstring).
        seed: seeds the weights and the mini-batch order.
    """

    def __init__(self, n_chambers: int, n_gauges: int, p_max_pa: np.ndarray,
                 hidden: tuple[int, ...] = HIDDEN_LAYERS, skip: bool = True,
                 seed: int = 0) -> None:
        self.n_chambers = require_integer("n_chambers", n_chambers, 1)
        self.n_gauges = require_integer("n_gauges", n_gauges, 1)
        self.p_max_pa = np.broadcast_to(np.asarray(p_max_pa, dtype=float),
                                        (self.n_chambers,)).copy()
        if not np.all(self.p_max_pa > 0):
            raise ValueError(f"p_max_pa must be > 0, got {self.p_max_pa.tolist()}")
        self.hidden = tuple(require_integer("hidden", h, 1) for h in hidden)
        if not isinstance(skip, (bool, np.bool_)):
            raise ValueError(f"skip must be True or False, got {skip!r}")
        self.skip = bool(skip)
        self.seed = int(seed)
        torch.manual_seed(self.seed)
        self.network = _MLP(self.n_inputs, self.n_chambers, self.hidden, self.skip)
        self.input_norm: Normaliser | None = None
        self.report: dict[str, Any] = {}

    @property
    def n_inputs(self) -> int:
        return self.n_chambers + 6 + self.n_gauges

    def _inputs(self, pressures_pa, position_m, desired_m, readings) -> np.ndarray:
        position_mm = np.asarray(position_m, dtype=float) * 1000.0
        return np.concatenate([np.asarray(pressures_pa, dtype=float) / self.p_max_pa,
                               position_mm,
                               np.asarray(desired_m, dtype=float) * 1000.0 - position_mm,
                               np.asarray(readings, dtype=float)], axis=-1)

    def fit(self, pressures_pa: np.ndarray, tips_m: np.ndarray, readings: np.ndarray,
            n_train: int | None = None, max_iterations: int = 1000, target_rmse: float = 1e-3,
            batch_size: int = 256, learning_rate: float = 1e-3,
            progress: bool = True) -> dict[str, Any]:
        """Train on one exploration record in time order (``pressures_pa`` (n, n_chambers) Pa,
        ``tips_m`` (n, 3) m, ``readings`` (n, n_gauges)): pairs of consecutive samples, the first
        ``n_train`` pairs (default 11/12, the paper's 5500 of 6000) for training, the rest for
        validation; the iteration with the lowest validation RMSE is kept."""
        pressures = np.asarray(pressures_pa, dtype=float)
        tips = np.asarray(tips_m, dtype=float)
        gauges = np.asarray(readings, dtype=float)
        n = len(pressures)
        for name, array, shape in (("pressures_pa", pressures, (n, self.n_chambers)),
                                   ("tips_m", tips, (n, 3)),
                                   ("readings", gauges, (n, self.n_gauges))):
            if array.shape != shape:
                raise ValueError(f"{name} must have shape {shape}, got {array.shape}")
            if not np.all(np.isfinite(array)):
                raise ValueError(f"{name} must be finite")
        if n < 3:
            raise ValueError(f"need at least 3 samples (2 pairs), got {n}")
        pairs = n - 1
        n_train = int(round(pairs * 5500 / 6000)) if n_train is None else require_integer(
            "n_train", n_train, 1)
        if not 1 <= n_train < pairs:
            raise ValueError(f"n_train must be in [1, {pairs - 1}], got {n_train}")
        max_iterations = require_integer("max_iterations", max_iterations, 1)
        require_positive("target_rmse", target_rmse)
        batch_size = require_integer("batch_size", batch_size, 1)
        require_learning_rate("learning_rate", learning_rate)
        x = self._inputs(pressures[:-1], tips[:-1], tips[1:], gauges[:-1])
        y = pressures[1:] / self.p_max_pa
        self.input_norm = Normaliser.fit(x[:n_train])
        x_all = torch.as_tensor(self.input_norm.forward(x), dtype=torch.float32)
        a_all = torch.as_tensor(pressures[:-1] / self.p_max_pa, dtype=torch.float32)
        y_all = torch.as_tensor(y, dtype=torch.float32)
        x_train, a_train, y_train = x_all[:n_train], a_all[:n_train], y_all[:n_train]
        x_val, a_val, y_val = x_all[n_train:], a_all[n_train:], y_all[n_train:]
        generator = torch.Generator().manual_seed(self.seed)
        optimiser = torch.optim.Adam(self.network.parameters(), lr=learning_rate)
        best, best_iteration = np.inf, 0
        best_state = {k: v.detach().clone() for k, v in self.network.state_dict().items()}
        threads = torch.get_num_threads()
        torch.set_num_threads(1)
        iteration = 0
        try:
            bar = tqdm(range(1, max_iterations + 1), desc="local IK training",
                       disable=not progress, leave=False)
            for iteration in bar:
                self.network.train()
                order = torch.randperm(n_train, generator=generator)
                for start in range(0, n_train, batch_size):
                    batch = order[start:start + batch_size]
                    loss = _rmse(self.network(x_train[batch], a_train[batch]), y_train[batch])
                    optimiser.zero_grad()
                    loss.backward()
                    optimiser.step()
                with torch.no_grad():
                    validation = float(_rmse(self.network(x_val, a_val), y_val))
                if validation < best:
                    best, best_iteration = validation, iteration
                    best_state = {k: v.detach().clone()
                                  for k, v in self.network.state_dict().items()}
                bar.set_postfix(rmse=f"{best:.4f}")
                if best < target_rmse:
                    break
            bar.close()
        finally:
            torch.set_num_threads(threads)
        self.network.load_state_dict(best_state)
        with torch.no_grad():
            training = float(_rmse(self.network(x_train, a_train), y_train))
        self.report = {"iterations": iteration, "validation_rmse": best,
                       "best_iteration": best_iteration, "training_rmse": training,
                       "pairs": pairs}
        return self.report

    def predict(self, pressures_pa: np.ndarray, position_m: np.ndarray, desired_m: np.ndarray,
                readings: np.ndarray) -> np.ndarray:
        """``A_{n+1}`` (Pa, (n_chambers,)) for one state (eq. 15)."""
        if self.input_norm is None:
            raise ValueError("the network is not trained: call fit() or load() first")
        for name, value, size in (("pressures_pa", pressures_pa, self.n_chambers),
                                  ("position_m", position_m, 3), ("desired_m", desired_m, 3),
                                  ("readings", readings, self.n_gauges)):
            array = np.asarray(value, dtype=float)
            if array.shape != (size,):
                raise ValueError(f"{name} must have shape ({size},), got {array.shape}")
            if not np.all(np.isfinite(array)):
                raise ValueError(f"{name} must be finite, got {array.tolist()}")
        x = self.input_norm.forward(self._inputs(pressures_pa, position_m, desired_m, readings))
        present = np.asarray(pressures_pa, dtype=float) / self.p_max_pa
        self.network.eval()
        with torch.no_grad():
            out = self.network(torch.as_tensor(x[None], dtype=torch.float32),
                               torch.as_tensor(present[None], dtype=torch.float32))[0].numpy()
        return out.astype(float) * self.p_max_pa

    # ------------------------------------------------------------------ persistence
    def state(self) -> dict[str, Any]:
        if self.input_norm is None:
            raise ValueError("the network is not trained: nothing to save")
        return {"n_chambers": self.n_chambers, "n_gauges": self.n_gauges,
                "p_max_pa": self.p_max_pa.copy(), "hidden": list(self.hidden),
                "skip": self.skip, "seed": self.seed,
                "weights": {k: v.detach().numpy().copy()
                            for k, v in self.network.state_dict().items()},
                "input_norm": (self.input_norm.low.copy(), self.input_norm.high.copy())}

    @classmethod
    def from_state(cls, state: dict[str, Any]) -> "LocalIKNetwork":
        network = cls(state["n_chambers"], state["n_gauges"], state["p_max_pa"],
                      tuple(state["hidden"]), bool(state["skip"]), state["seed"])
        network.network.load_state_dict({k: torch.as_tensor(v)
                                         for k, v in state["weights"].items()})
        network.input_norm = Normaliser(*map(np.asarray, state["input_norm"]))
        return network

    def save(self, path: str | Path) -> None:
        """Write the network and its normalisation to ``path`` (a digest-checked model file)."""
        write_model_state(path, _FORMAT, self.state())

    @classmethod
    def load(cls, path: str | Path) -> "LocalIKNetwork":
        """Read a file written by :meth:`save`; a corrupt or foreign file is refused by name."""
        return read_model_state(path, _FORMAT, "local-IK network", cls.from_state)


def _rmse(predicted: torch.Tensor, target: torch.Tensor) -> torch.Tensor:
    """Eq. (20): root mean square over samples and chambers."""
    return torch.sqrt(((predicted - target) ** 2).mean())
