"""Online sequential extreme learning machine with RBF nodes and exponential forgetting.

Wang et al. 2023 (wang2023), Section II-C:

* hidden layer of ``N`` radial basis nodes ``phi_i(x) = exp(-||x - a_i||^2 / b_i)`` (eq. (3))
  with random centres ``a_i`` and widths ``b_i`` (inputs are standardised first);
* batch initialisation ``beta = (Phi^T Phi)^-1 Phi^T Z`` (eqs. (5)-(9)), ridge-regularised here:
  ``beta = (Phi^T Phi + lambda I)^-1 Phi^T Z``;
* recursive update per sample with forgetting factor ``w`` on old data (eqs. (10)-(17)); the
  paper's eq. (17) recursion is of ``H = K^-1`` (docs/architecture.md, "Errata").

Exactly, after ``k`` updates the weights minimise

    sum_j w^(k - t_j) ||z_j - phi(x_j)^T beta||^2 + lambda ||beta||^2

(initial samples carry ``w^k``; the ridge term is kept at ``lambda`` by adding ``(1 - w) lambda I``
to the information matrix each step, so forgetting never erodes the regularisation). The
information matrix ``K`` is updated exactly (``K <- w K + phi phi^T + (1 - w) lambda I``), its
inverse ``H`` by the Sherman-Morrison rank-one step of eq. (17) (symmetrised), and every
``refactor_every`` samples ``H`` and ``beta`` are recomputed from ``K`` by Cholesky, which removes
the rounding drift and folds in the ridge top-ups.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import scipy.linalg

from soft_gym._validation import as_finite_array, require_in_range, require_positive
from soft_gym.sensing._blas import one_blas_thread


class OSELM:
    """FOS-ELM regressor (wang2023 eqs. (1)-(17)).

    Args:
        n_hidden: hidden RBF nodes ``N`` (paper: 200).
        forgetting: weight ``w`` in (0, 1] of old data per update (1 = no forgetting).
        ridge: ``lambda`` of the ridge term (in units of standardised features).
        width_scale: RBF width ``b_i`` as a multiple of the mean squared distance between
            standardised training inputs.
        refactor_every: samples between exact re-solves of ``H`` and ``beta`` from ``K``.
        seed: seed of the random centres (drawn from the initial inputs) and widths.
    """

    def __init__(self, n_hidden: int = 200, forgetting: float = 0.999, ridge: float = 1e-3,
                 width_scale: float = 1.0, refactor_every: int = 50, seed: int = 0) -> None:
        if not isinstance(n_hidden, (int, np.integer)) or n_hidden < 1:
            raise ValueError(f"n_hidden must be an integer >= 1, got {n_hidden!r}")
        require_in_range("forgetting", forgetting, 1e-6, 1.0)
        require_positive("ridge", ridge)
        require_positive("width_scale", width_scale)
        if not isinstance(refactor_every, (int, np.integer)) or refactor_every < 1:
            raise ValueError(f"refactor_every must be an integer >= 1, got {refactor_every!r}")
        self.n_hidden = int(n_hidden)
        self.forgetting = float(forgetting)
        self.ridge = float(ridge)
        self.width_scale = float(width_scale)
        self.refactor_every = int(refactor_every)
        self.seed = int(seed)
        self.centres: np.ndarray | None = None
        self.widths: np.ndarray | None = None
        self.input_mean: np.ndarray | None = None
        self.input_scale: np.ndarray | None = None
        self.beta: np.ndarray | None = None
        self.information: np.ndarray | None = None   # K
        self.inverse: np.ndarray | None = None       # H = K^-1
        self.moment: np.ndarray | None = None        # Phi^T Z, weighted
        self.samples_since_refactor = 0
        self.updates = 0

    # ------------------------------------------------------------------ features
    @property
    def is_fitted(self) -> bool:
        return self.beta is not None

    def features(self, inputs: np.ndarray) -> np.ndarray:
        """Hidden-layer outputs ``phi`` (eq. (3)) for inputs (n, l) or (l,)."""
        self._require_fitted()
        x = np.atleast_2d(np.asarray(inputs, dtype=float))
        return self._features_standard((x - self.input_mean) / self.input_scale)

    # ------------------------------------------------------------------ training
    @one_blas_thread  # 200 x 200 matrices: one thread (see soft_gym.sensing._blas)
    def fit(self, inputs: np.ndarray, targets: np.ndarray) -> "OSELM":
        """Batch initialisation on ``N0`` samples (eqs. (5)-(9), ridge-regularised)."""
        x = as_finite_array("inputs", inputs)
        z = as_finite_array("targets", targets)
        if x.ndim != 2 or z.ndim != 2 or len(x) != len(z):
            raise ValueError(f"inputs (n, l) and targets (n, m) must have matching rows, got "
                             f"shapes {x.shape} and {z.shape}")
        if len(x) < 2:
            raise ValueError(f"inputs must hold at least 2 samples, got {len(x)}")
        rng = np.random.default_rng(self.seed)
        self.input_mean = x.mean(axis=0)
        self.input_scale = np.where(x.std(axis=0) > 1e-12, x.std(axis=0), 1.0)
        standard = (x - self.input_mean) / self.input_scale
        picks = rng.choice(len(x), size=self.n_hidden, replace=len(x) < self.n_hidden)
        jitter = 0.05 * rng.standard_normal((self.n_hidden, x.shape[1]))
        self.centres = standard[picks] + jitter
        spread = np.mean(np.sum((standard - standard.mean(axis=0)) ** 2, axis=1))
        self.widths = self.width_scale * max(spread, 1e-12) * rng.uniform(0.5, 1.5, self.n_hidden)
        phi = self._features_standard(standard)
        self.information = phi.T @ phi + self.ridge * np.eye(self.n_hidden)
        self.moment = phi.T @ z
        self._refactor()
        self.updates = 0
        return self

    @one_blas_thread
    def update(self, inputs: np.ndarray, target: np.ndarray) -> None:
        """Recursive update with one sample (eqs. (10)-(17) with forgetting ``w``)."""
        self._require_fitted()
        x = as_finite_array("inputs", inputs).reshape(-1)
        z = as_finite_array("target", target).reshape(-1)
        if z.shape[0] != self.beta.shape[1]:
            raise ValueError(f"target must have {self.beta.shape[1]} values, got {z.shape[0]}")
        phi = self.features(x)[0]
        w = self.forgetting
        self.information *= w
        self.information += np.outer(phi, phi)
        self.information.flat[:: self.n_hidden + 1] += (1.0 - w) * self.ridge
        self.moment *= w
        self.moment += np.outer(phi, z)
        # eq. (17): H <- (H / w) - (H phi)(H phi)^T / (w (w + phi^T H phi)), symmetrised
        hphi = self.inverse @ phi
        self.inverse = (self.inverse - np.outer(hphi, hphi) / (w + phi @ hphi)) / w
        self.inverse = 0.5 * (self.inverse + self.inverse.T)
        # eq. (11): beta <- beta + H phi (z - phi^T beta)
        self.beta += np.outer(self.inverse @ phi, z - phi @ self.beta)
        self.updates += 1
        self.samples_since_refactor += 1
        if self.samples_since_refactor >= self.refactor_every:
            self._refactor()

    def predict(self, inputs: np.ndarray) -> np.ndarray:
        """Outputs ``phi^T beta`` (eq. (8)) for inputs (n, l) -> (n, m), or (l,) -> (m,)."""
        x = np.asarray(inputs, dtype=float)
        out = self.features(x) @ self.beta
        return out[0] if x.ndim == 1 else out

    # ------------------------------------------------------------------ persistence
    def save(self, path: str | Path) -> None:
        """Write the model to ``path`` (``.npz``); :meth:`load` restores it exactly."""
        self._require_fitted()
        np.savez(path, n_hidden=self.n_hidden, forgetting=self.forgetting, ridge=self.ridge,
                 width_scale=self.width_scale, refactor_every=self.refactor_every, seed=self.seed,
                 centres=self.centres, widths=self.widths, input_mean=self.input_mean,
                 input_scale=self.input_scale, beta=self.beta, information=self.information,
                 inverse=self.inverse, moment=self.moment,
                 samples_since_refactor=self.samples_since_refactor, updates=self.updates)

    @classmethod
    def load(cls, path: str | Path) -> "OSELM":
        """Read a model written by :meth:`save`."""
        with np.load(path) as data:
            model = cls(int(data["n_hidden"]), float(data["forgetting"]), float(data["ridge"]),
                        float(data["width_scale"]), int(data["refactor_every"]),
                        int(data["seed"]))
            for name in ("centres", "widths", "input_mean", "input_scale", "beta",
                         "information", "inverse", "moment"):
                setattr(model, name, data[name].copy())
            model.samples_since_refactor = int(data["samples_since_refactor"])
            model.updates = int(data["updates"])
        return model

    # ------------------------------------------------------------------ internals
    def _features_standard(self, standard: np.ndarray) -> np.ndarray:
        squared = (np.sum(standard**2, axis=1)[:, None] - 2.0 * standard @ self.centres.T
                   + np.sum(self.centres**2, axis=1)[None, :])
        return np.exp(-np.maximum(squared, 0.0) / self.widths[None, :])

    def _refactor(self) -> None:
        """Exact ``H = K^-1`` and ``beta = H M`` by Cholesky (removes recursion drift)."""
        factor = scipy.linalg.cho_factor(self.information, lower=True, check_finite=False)
        self.inverse = scipy.linalg.cho_solve(factor, np.eye(self.n_hidden), check_finite=False)
        self.inverse = np.ascontiguousarray(0.5 * (self.inverse + self.inverse.T))
        self.beta = np.ascontiguousarray(
            scipy.linalg.cho_solve(factor, self.moment, check_finite=False))
        self.samples_since_refactor = 0

    def _require_fitted(self) -> None:
        if self.centres is None:
            raise ValueError("the OSELM model is not initialised: call fit(inputs, targets) first")
