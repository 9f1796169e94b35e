"""Local linear inverse models by reward-weighted regression, blended into one global inverse.

Ho et al. 2018 (ho2018), Section 2.4, eqs. (4)-(13) and Algorithm 1, after Peters and Schaal's
reward-weighted regression for redundant inverse kinematics. A redundant arm has many chamber
changes ``du`` that give the same tip change ``dp``; averaging such solutions across the data
gives an invalid one. Each receptive field ``i`` of the forward model (its centre ``c_i`` and
metric ``D_i`` in the configuration space ``z = [p, u]``) gets a linear inverse

    du = x^T beta_i,    x = [dp_ref, p - c_p,i, u - c_u,i, 1]                    (eq. (4))

fitted by weighted least squares in which each sample ``k`` counts with its field weight
``w_ik = exp(-1/2 (z_k - c_i)^T D_i (z_k - c_i))`` (eq. (6)) times a reward ``r_ik`` that favours
samples moving the actuators towards a rest configuration ``u_0``:

    du_0,k = K_a (u_0 - u_k)                                  (attractor, eq. (8))
    C_k = (du_k - du_0,k)^T N (du_k - du_0,k)                 (cost, eq. (7))
    sigma_i^2 = sum_k w_ik C_k / sum_k w_ik                   (mean cost of the field, eq. (11))
    r_ik = exp(-1/2 C_k / sigma_i^2)                          (reward, eq. (10))
    beta_i = (X^T W_i X + lambda S)^-1 (X^T W_i Y + lambda S beta_prior,i),
    W_i = diag(r_ik w_ik)                                     (eq. (13))

The global inverse blends the local ones by their weights at the current configuration,
``du = sum_i w_i(z) x_i^T beta_i / sum_i w_i(z)`` (eq. (5)).

Choices the paper leaves open, and corrections of its printed equations (docs/architecture.md,
"Errata"), written down here:

* eq. (10) as printed, ``sigma_i exp(-0.5 sigma_i^2 C_k)``, multiplies by the mean cost where the
  reward-weighted regression it follows divides by it (the reward's temperature is the mean
  cost, so that the reward is dimensionless); the constant factor ``sigma_i`` cancels in
  eq. (13). The division is used.
* eq. (8) as printed, ``du_0 = K_a (u - u_0)``, would make the attractor reward moving away
  from the rest configuration; the code uses ``du_0 = K_a (u_0 - u)``, towards rest, as the
  text's "attractor" says. tests/agents/controllers/test_lwpr_rwr.py
  (``test_inverse_of_a_redundant_linear_map_reaches_the_task_and_pulls_to_rest``) shows it:
  on a redundant linear map the inverse's null-space motion points along ``u_0 - u``.
* the regression is centred on the field (``p - c_p``, ``u - c_u``) and has a bias column, so a
  field's inverse is a local linearisation about its centre; columns are scaled to comparable
  sizes (``task_scale``, ``actuation_scale``) and a ridge ``lambda`` pulls each field towards
  its prior parameters: zero before pre-training, the pre-trained ones afterwards. Online, only
  the most recent ``window`` samples are kept (first in, first out; the paper keeps 425 and 550),
  so a field the recent data do not reach keeps what pre-training gave it, and the ridge acts as
  pre-training's weight against the window's.

Units: the caller's (the controller passes tip positions in mm and actuation as fractions of
the chamber pressure range).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from soft_gym._model_files import read_npz, write_npz
from soft_gym._validation import (as_finite_array, require_integer, require_non_negative,
                                  require_positive)

__all__ = ["RewardWeightedInverse"]

_LOG_WEIGHT_FLOOR = -30.0
"""Fields whose log-weight is below this are ignored in an update (``w < 1e-13``)."""

_FORMAT = "reward-weighted-inverse/1"


class RewardWeightedInverse:
    """Locally linear inverse ``du = phi(dp_ref, p, u)`` over receptive fields (ho2018 eq. (5)).

    Args:
        task_dim: size of ``p`` and ``dp`` (3 for a tip position).
        actuator_dim: size of ``u`` and ``du`` (chambers).
        rest_actuation: ``u_0`` of the attractor (eq. (8)), a scalar or one value per actuator.
        attractor_gain: ``K_a`` of eq. (8) (per update, dimensionless).
        cost_weights: the diagonal of ``N`` in eq. (7) (positive), scalar or per actuator.
        window: samples kept for online refits (first in, first out).
        ridge: ``lambda``, the weight (in weighted samples) of a field's prior parameters.
        task_scale: typical size of ``dp`` and of ``p - c`` (caller's units): columns are scaled
            by it so the ridge treats every column alike.
        actuation_scale: typical size of ``u - c`` (caller's units).
        refit_weight: a new sample refits the fields whose weight for it is at least this.
    """

    def __init__(self, task_dim: int = 3, actuator_dim: int = 6, *,
                 rest_actuation: float | np.ndarray = 0.2, attractor_gain: float = 0.05,
                 cost_weights: float | np.ndarray = 1.0, window: int = 425, ridge: float = 1.0,
                 task_scale: float = 1.0, actuation_scale: float = 0.1,
                 refit_weight: float = 1e-3) -> None:
        self.task_dim = require_integer("task_dim", task_dim, 1)
        self.actuator_dim = require_integer("actuator_dim", actuator_dim, 1)
        self.rest_actuation = _per_actuator("rest_actuation", rest_actuation, self.actuator_dim,
                                            positive=False)
        self.attractor_gain = require_non_negative("attractor_gain", attractor_gain)
        self.cost_weights = _per_actuator("cost_weights", cost_weights, self.actuator_dim,
                                          positive=True)
        self.window = require_integer("window", window, 1)
        self.ridge = require_positive("ridge", ridge)
        self.task_scale = require_positive("task_scale", task_scale)
        self.actuation_scale = require_positive("actuation_scale", actuation_scale)
        self.refit_weight = require_positive("refit_weight", refit_weight)
        self.config_dim = self.task_dim + self.actuator_dim
        self.regressor_dim = self.task_dim + self.config_dim + 1
        self.centres = np.zeros((0, self.config_dim))
        self.metrics = np.zeros((0, self.config_dim, self.config_dim))
        self._diagonal = True  # every metric diagonal (set with the fields)
        self.betas = np.zeros((0, self.regressor_dim, self.actuator_dim))
        self.prior_betas = np.zeros_like(self.betas)
        self._data = np.zeros((0, self.task_dim + self.config_dim + self.actuator_dim))

    # ------------------------------------------------------------------ fields
    @property
    def n_fields(self) -> int:
        return len(self.centres)

    @property
    def window_size(self) -> int:
        """Samples now in the online window."""
        return len(self._data)

    def set_fields(self, centres: np.ndarray, metrics: np.ndarray) -> None:
        """Take the receptive fields (centres ``(n, task_dim + actuator_dim)`` in ``[p, u]``,
        positive semi-definite metrics ``(n, d, d)``) of the forward model. Fields kept from
        before (same centre) keep their parameters; new ones start from the prediction of the
        field nearest to them."""
        centres = as_finite_array("centres", centres)
        metrics = as_finite_array("metrics", metrics)
        d = self.config_dim
        if (centres.ndim != 2 or centres.shape[1] != d or metrics.shape[1:] != (d, d)
                or len(metrics) != len(centres)):
            raise ValueError(f"centres must be (n, {d}) and metrics (n, {d}, {d}), got "
                             f"{centres.shape} and {metrics.shape}")
        if len(centres) == 0:
            raise ValueError("centres must hold at least one receptive field, got none")
        betas = np.zeros((len(centres), self.regressor_dim, self.actuator_dim))
        priors = np.zeros_like(betas)
        if self.n_fields:
            old = {centre.tobytes(): i for i, centre in enumerate(self.centres)}
            for j, centre in enumerate(centres):
                i = old.get(centre.tobytes())
                if i is None:  # nearest old field by its own metric
                    i = int(np.argmax(self._log_weights(centre[None], self.centres,
                                                        self.metrics)[:, 0]))
                betas[j], priors[j] = self.betas[i], self.prior_betas[i]
        self.centres, self.metrics = centres.copy(), metrics.copy()
        self._diagonal = _all_diagonal(self.metrics)
        self.betas, self.prior_betas = betas, priors

    # ------------------------------------------------------------------ learning
    def fit(self, positions: np.ndarray, actuations: np.ndarray, actuation_changes: np.ndarray,
            position_changes: np.ndarray) -> None:
        """Batch reward-weighted regression of every field on the given samples (eq. (13));
        the result becomes the fields' prior (pre-training). The online window is emptied.

        Args:
            positions: ``p_k`` (n, task_dim).
            actuations: ``u_k`` (n, actuator_dim).
            actuation_changes: ``du_k`` (n, actuator_dim).
            position_changes: ``dp_k = p_{k+1} - p_k`` (n, task_dim): what ``du_k`` achieved,
                the regression's ``dp_ref`` (Algorithm 1, line 1).
        """
        data = self._samples(positions, actuations, actuation_changes, position_changes)
        if not self.n_fields:
            raise ValueError("set_fields must be called before fit")
        self.prior_betas = np.zeros_like(self.betas)
        self.betas = self._solve(np.arange(self.n_fields), data)
        self.prior_betas = self.betas.copy()
        self._data = data[:0]

    def add(self, position: np.ndarray, actuation: np.ndarray, actuation_change: np.ndarray,
            position_change: np.ndarray) -> int:
        """One online sample (Algorithm 1): appended to the window (the oldest dropped beyond
        ``window``), then every field it activates by at least ``refit_weight`` is refitted on
        the window, pulled towards its prior. Returns how many fields were refitted."""
        sample = self._samples(position[None], actuation[None], actuation_change[None],
                               position_change[None])
        self._data = np.concatenate([self._data[-(self.window - 1):] if self.window > 1
                                     else self._data[:0], sample])
        if not self.n_fields:
            return 0
        z = sample[:, self.task_dim:self.task_dim + self.config_dim]
        log_w = self._log_weights(z, self.centres, self.metrics, self._diagonal)[:, 0]
        fields = np.flatnonzero(log_w >= np.log(self.refit_weight))
        if len(fields):
            self.betas[fields] = self._solve(fields, self._data)
        return len(fields)

    # ------------------------------------------------------------------ prediction
    def predict(self, position_change: np.ndarray, position: np.ndarray,
                actuation: np.ndarray) -> np.ndarray:
        """``du`` for the wanted ``dp_ref`` at configuration ``(p, u)``, eq. (5)."""
        if not self.n_fields:
            raise ValueError("the inverse has no receptive fields yet: call set_fields and fit")
        dp = as_finite_array("position_change", position_change, shape=(self.task_dim,))
        p = as_finite_array("position", position, shape=(self.task_dim,))
        u = as_finite_array("actuation", actuation, shape=(self.actuator_dim,))
        z = np.concatenate([p, u])
        log_w = self._log_weights(z[None], self.centres, self.metrics, self._diagonal)[:, 0]
        weights = np.exp(log_w - log_w.max())  # normalised in eq. (5); far from every field the
        weights /= weights.sum()               # nearest one still decides
        x = self._regressors(dp[None], z[None], np.arange(self.n_fields))[:, 0]  # (fields, R)
        local = (x[:, None, :] @ self.betas)[:, 0, :]
        return weights @ local

    # ------------------------------------------------------------------ persistence
    def state(self) -> dict[str, np.ndarray]:
        """Everything :meth:`from_state` needs, as arrays."""
        return {"format": np.array(_FORMAT), "task_dim": np.array(self.task_dim),
                "actuator_dim": np.array(self.actuator_dim),
                "rest_actuation": self.rest_actuation, "attractor_gain": np.array(self.attractor_gain),
                "cost_weights": self.cost_weights, "window": np.array(self.window),
                "ridge": np.array(self.ridge), "task_scale": np.array(self.task_scale),
                "actuation_scale": np.array(self.actuation_scale),
                "refit_weight": np.array(self.refit_weight), "centres": self.centres,
                "metrics": self.metrics, "betas": self.betas, "prior_betas": self.prior_betas,
                "data": self._data}

    @classmethod
    def from_state(cls, state: dict[str, np.ndarray], source: str = "state"
                   ) -> "RewardWeightedInverse":
        """Rebuild from :meth:`state`; a foreign or inconsistent one raises ``ValueError``
        naming ``source``."""
        try:
            if str(state["format"]) != _FORMAT:
                raise ValueError(f"format {str(state['format'])!r}")
            model = cls(int(state["task_dim"]), int(state["actuator_dim"]),
                        rest_actuation=np.array(state["rest_actuation"], dtype=float),
                        attractor_gain=float(state["attractor_gain"]),
                        cost_weights=np.array(state["cost_weights"], dtype=float),
                        window=int(state["window"]), ridge=float(state["ridge"]),
                        task_scale=float(state["task_scale"]),
                        actuation_scale=float(state["actuation_scale"]),
                        refit_weight=float(state["refit_weight"]))
            model.centres = np.array(state["centres"], dtype=float)
            model.metrics = np.array(state["metrics"], dtype=float)
            model._diagonal = _all_diagonal(model.metrics) if len(model.metrics) else True
            model.betas = np.array(state["betas"], dtype=float)
            model.prior_betas = np.array(state["prior_betas"], dtype=float)
            model._data = np.array(state["data"], dtype=float)
            n, d, r, a = model.n_fields, model.config_dim, model.regressor_dim, model.actuator_dim
            if (model.centres.shape != (n, d) or model.metrics.shape != (n, d, d)
                    or model.betas.shape != (n, r, a)
                    or model.prior_betas.shape != (n, r, a)
                    or model._data.ndim != 2 or model._data.shape[1] != model.task_dim + d + a
                    or not all(np.isfinite(arr).all() for arr in (
                        model.centres, model.metrics, model.betas, model.prior_betas,
                        model._data))):
                raise ValueError("inconsistent arrays")
        except (KeyError, IndexError, TypeError, ValueError, AttributeError) as error:
            raise ValueError(f"{source} is not a saved reward-weighted inverse ({error})") from None
        return model

    def save(self, path: str | Path) -> None:
        """Write the model to ``path`` (``.npz`` format, exactly that name)."""
        write_npz(path, self.state())

    @classmethod
    def load(cls, path: str | Path) -> "RewardWeightedInverse":
        """Read a model written by :meth:`save`; a missing, corrupt or foreign file raises one
        ``ValueError`` naming the path."""
        state = read_npz(path, "reward-weighted inverse")
        return cls.from_state(state, source=f"path {str(path)!r}")

    # ------------------------------------------------------------------ internals
    def _samples(self, positions, actuations, actuation_changes, position_changes) -> np.ndarray:
        p = as_finite_array("positions", positions)
        u = as_finite_array("actuations", actuations)
        du = as_finite_array("actuation_changes", actuation_changes)
        dp = as_finite_array("position_changes", position_changes)
        n = len(p) if p.ndim else 0
        for name, array, width in (("positions", p, self.task_dim),
                                   ("actuations", u, self.actuator_dim),
                                   ("actuation_changes", du, self.actuator_dim),
                                   ("position_changes", dp, self.task_dim)):
            if array.shape != (n, width):
                raise ValueError(f"{name} must have shape ({n}, {width}), got {array.shape}")
        return np.concatenate([dp, p, u, du], axis=1)

    @staticmethod
    def _log_weights(z: np.ndarray, centres: np.ndarray, metrics: np.ndarray,
                     diagonal: bool | None = None) -> np.ndarray:
        """``log w`` of eq. (6), shape (fields, samples). Diagonal metrics (LWPR's default;
        ``diagonal=None`` checks) expand ``sum_i D_ii (z_i - c_i)^2`` into three matrix
        products."""
        diagonals = np.diagonal(metrics, axis1=1, axis2=2)
        if diagonal is None:
            diagonal = _all_diagonal(metrics)
        if diagonal:
            quadratic = (diagonals @ (z * z).T - 2.0 * (diagonals * centres) @ z.T
                         + np.sum(diagonals * centres * centres, axis=1)[:, None])
            return -0.5 * np.maximum(quadratic, 0.0)
        diff = z[None, :, :] - centres[:, None, :]
        return -0.5 * np.sum((diff @ metrics) * diff, axis=2)

    def _scale(self) -> np.ndarray:
        t = self.task_dim
        return np.concatenate([np.full(2 * t, self.task_scale),
                               np.full(self.actuator_dim, self.actuation_scale)])

    def _regressors(self, dp: np.ndarray, z: np.ndarray, fields: np.ndarray) -> np.ndarray:
        """Scaled, field-centred regressors ``x``, shape (fields, samples, R)."""
        t = self.task_dim
        centred = z[None, :, :] - self.centres[fields][:, None, :]
        x = np.empty((len(fields), len(z), self.regressor_dim))
        x[:, :, :t] = dp[None]
        x[:, :, t:-1] = centred
        x[:, :, :-1] /= self._scale()
        x[:, :, -1] = 1.0
        return x

    def _solve(self, fields: np.ndarray, data: np.ndarray) -> np.ndarray:
        """Reward-weighted ridge regression of the given fields on ``data`` (eqs. (7)-(13)).

        With ``x_fs = a_s - b_f`` (``a_s = [dp_s, z_s, 1]`` scaled, ``b_f = [0, c_f, 0]``
        scaled), the weighted sums ``sum_s W_fs x_fs x_fs^T`` and ``sum_s W_fs x_fs du_s^T`` are
        expanded into products of the (fields x samples) weights with per-sample outer
        products, so no (fields x samples x R) array is formed."""
        t, d = self.task_dim, self.config_dim
        dp, z, du = data[:, :t], data[:, t:t + d], data[:, t + d:]
        u = z[:, t:]
        attractor = self.attractor_gain * (self.rest_actuation - u)
        cost = ((du - attractor) ** 2) @ self.cost_weights
        weights = np.exp(np.maximum(self._log_weights(z, self.centres[fields],
                                                      self.metrics[fields], self._diagonal),
                                    _LOG_WEIGHT_FLOOR))
        mean_cost = (weights @ cost) / np.maximum(weights.sum(axis=1), 1e-300)
        reward = np.exp(-0.5 * cost[None, :] / np.maximum(mean_cost[:, None], 1e-300))
        combined = reward * weights  # W_fs, (fields, samples)
        r, n = self.regressor_dim, len(data)
        scale = self._scale()
        a = np.empty((n, r))
        a[:, :t] = dp
        a[:, t:-1] = z
        a[:, :-1] /= scale
        a[:, -1] = 1.0
        b = np.zeros((len(fields), r))
        b[:, t:-1] = self.centres[fields] / scale[t:]
        total = combined.sum(axis=1)                                   # sum_s W
        first = combined @ a                                           # sum_s W a
        second = (combined @ (a[:, :, None] * a[:, None, :]).reshape(n, r * r)).reshape(-1, r, r)
        gram = (second - first[:, :, None] * b[:, None, :] - b[:, :, None] * first[:, None, :]
                + total[:, None, None] * b[:, :, None] * b[:, None, :])
        a_du = (combined @ (a[:, :, None] * du[:, None, :]).reshape(n, -1)).reshape(
            len(fields), r, -1)
        moment = a_du - b[:, :, None] * (combined @ du)[:, None, :]
        gram += self.ridge * np.eye(r)[None]
        moment += self.ridge * self.prior_betas[fields]
        return np.linalg.solve(gram, moment)


def _all_diagonal(metrics: np.ndarray) -> bool:
    """Whether every metric in the stack ``(n, d, d)`` is diagonal."""
    diagonals = np.diagonal(metrics, axis1=1, axis2=2)
    return bool(np.array_equal(metrics, diagonals[:, :, None] * np.eye(metrics.shape[1])[None]))


def _per_actuator(name: str, value: Any, size: int, positive: bool) -> np.ndarray:
    array = np.broadcast_to(as_finite_array(name, value), (size,)).astype(float) \
        if np.ndim(value) == 0 else as_finite_array(name, value, shape=(size,)).astype(float)
    if positive and np.any(array <= 0):
        raise ValueError(f"{name} must be positive, got {value!r}")
    return array.copy()
