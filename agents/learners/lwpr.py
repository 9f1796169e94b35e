"""Locally weighted projection regression (LWPR): incremental, local, piecewise-linear regression.

The algorithm of Vijayakumar, D'Souza and Schaal 2005, "Incremental online learning in high
dimensions", Neural Computation 17 (vijayakumar2005), with the update order, defaults and safety
heuristics of the reference library of Klanke, Vijayakumar and Schaal 2008, "A library for
locally weighted projection regression", JMLR 9 (klanke2008). Ho et al. 2018 (ho2018), eqs.
(1)-(6), learn the forward transition model of a soft continuum arm with it: the map
``(p_k, du_k, u_k) -> dp_k`` (eq. 1) is approximated by local linear models (eq. 3), each valid
inside a Gaussian receptive field (eq. 6), and blended by their normalised activations (eq. 5).

Model (one independent model per output dimension). Receptive field ``k`` has a centre ``c``,
a distance metric ``D = M^T M`` (``M`` upper triangular, or diagonal with ``diag_only``) and the
activation, ho2018 eq. (6) (printed there without the minus sign),

    w(x) = exp(-1/2 (x - c)^T D (x - c)).

Its local linear model is a partial-least-squares (PLS) regression with ``r`` projections on the
input centred on the field's weighted mean ``xbar``: with ``z_1 = x - xbar``,

    s_j = u_j^T z_j,   z_{j+1} = z_j - p_j s_j   (j = 1..r),   y_k(x) = beta0 + sum_j beta_j s_j,

a linear function of ``x`` (ho2018 eq. 3). The prediction blends the trustworthy fields with
``w > cutoff`` (ho2018 eq. 5):  ``y(x) = sum_k w_k y_k(x) / sum_k w_k``  (0 where none is).

Update with a sample ``(x, y)``, for every field with ``w > 0.001`` (``UPDATE_CUTOFF``), using
per-projection forgetting factors ``lambda`` (klanke2008 ``update_one``):

* means: ``W' = lambda W + w``; ``xbar <- (lambda W xbar + w x) / W'``, ``beta0`` likewise with
  ``y``; ``z = x - xbar``, ``e_0 = y - beta0``;
* PLS, scores ``s_j`` from the current projections, targets
  ``t_1 = e_0`` and ``t_{j+1} = e_j = e_0 - sum_{i<=j} beta_i s_i`` (leave-one-out residuals):
  ``a_zt,j <- (0.9 + 0.1 lambda) a_zt,j + w t_j z_j``, ``u_j = a_zt,j / |a_zt,j|``;
  ``a_ss,j <- lambda a_ss,j + w s_j^2``, ``a_st,j <- lambda a_st,j + w s_j t_j``,
  ``a_sz,j <- lambda a_sz,j + w s_j z_j``; ``beta_j = a_st,j / a_ss,j``, ``p_j = a_sz,j / a_ss,j``;
* distance metric: gradient descent ``M <- M - alpha dJ/dM`` on the penalised leave-one-out
  (PRESS) cost of vijayakumar2005,
  ``J = 1/W sum_i w_i |y_i - y_{i,-i}|^2 + gamma/n sum_ij D_ij^2``, with its incremental
  approximation ``dJ/dM = dJ1/dw dw/dM + w/W dJ2/dM`` where, with ``psi_j = s_j / a_ss,j``,
  ``e`` the residual after the update, ``e_cv`` the leave-one-out residual of the projections
  in use, ``E = sum w e_cv^2`` and the leverage ``h = w sum_j s_j psi_j``,

      dJ1/dw = (e_cv^2 - E/W - 2 sum_j (e psi_j H_j + psi_j^2 R_j)) / W,
      dw/dM_nm = -w (M dx)_n dx_m,    dJ2/dM = 4 gamma/n M D,
      H_j <- lambda H_j + w s_j e_cv / (1 - h),   R_j <- lambda R_j + w^2 s_j^2 e_cv^2 / (1 - h),

  (``gamma`` = ``penalty``, ``n`` the input dimension, ``dx = x - c``; the step and the trace
  updates are scaled by the damping factor below); with ``meta`` the learning rates
  ``alpha = exp(b)`` follow the incremental delta-bar-delta rule (Sutton 1992) with the second
  derivatives of klanke2008;
* a projection is added while ``r < max_projections`` when the leave-one-out error of the last
  one is below ``add_threshold`` times that of the one before (with klanke2008's data checks);
* forgetting: ``lambda <- tau_lambda lambda + final_lambda (1 - tau_lambda)`` after each update
  of a field, starting from ``init_lambda``.

Structure: if no field is activated above ``w_gen``, a new field is centred at ``x`` (with the
distance metric of the most activated field if that one is trustworthy and activated above
``w_gen / 10``, else ``init_d``); if two fields are activated above ``w_prune``, the one with the
larger ``trace(D)`` (the narrower one) is removed.

Safety heuristics as in klanke2008: a field is used for predictions once it has seen more than
``2 n`` (discounted) samples, and a projection once it has too; the metric gradient waits for
``n_data (1 - lambda) > 0.1`` and is damped by ``min(1, (sum e^2 / E)^4)``; a metric component
whose step exceeds ``0.1 max|M|`` is not changed and its rate halved.

With all ``n`` projections, a fixed ``D`` and no forgetting a field tends to the weighted
least-squares fit of its data (PLS with full rank is linear regression), but only as data
accumulate: the statistics are summed with running means and with projection directions that
move as data arrive, and earlier terms are not recomputed. A noise-free linear function is
reproduced exactly once the directions settle (always in 1-D) and old terms are forgotten.

Confidence (klanke2008 ``predict_conf``): per field ``sigma_k^2 = E_k / (W_k - SSp_k)
(1 + w_k sum_j s_j^2 / a_ss,j)``, where ``SSp`` accumulates ``w^2 sum_j s_j^2 / a_ss,j`` (the
leverage, so ``W - SSp`` counts the effective degrees of freedom), and

    conf(x) = sqrt(sum_k w_k sigma_k^2 + sum_k w_k y_k^2 - (sum_k w_k) y^2) / sum_k w_k,

which adds the spread of the local predictions to their error variances (``inf`` where no field
is used).

Units and conventions: inputs are divided by ``norm_in`` and outputs by ``norm_out`` before
learning, so centres, ``D`` (units 1/norm_in^2) and all statistics live in normalised units;
predictions and confidence bounds are returned in output units. ``D`` and the learning rates are
per field; every output dimension has its own fields. The fields of one output are stored as
stacked arrays (row ``k`` of every array is field ``k``): the activations of all fields come from
one vectorised computation, and the activated fields are updated together.
"""

from __future__ import annotations

import zipfile
import zlib
from pathlib import Path
from typing import Any, BinaryIO

import numpy as np

from soft_gym._validation import (as_finite_array, require_in_range, require_integer,
                                  require_non_negative, require_number, require_positive)

__all__ = ["LWPR", "UPDATE_CUTOFF"]

UPDATE_CUTOFF = 1e-3
"""Fields activated at or below this are not updated by a sample (klanke2008)."""

_FORMAT = "soft_arm_gym.LWPR/1"
_TINY = 1e-10   # initial weight sums and data counts, and the floor of error ratios (klanke2008)
_SETTINGS = ("input_dim", "output_dim", "w_gen", "w_prune", "init_lambda", "final_lambda",
             "tau_lambda", "penalty", "diag_only", "meta", "meta_rate", "update_d",
             "max_projections", "add_threshold", "init_s2")


def _require_bool(name: str, value: Any) -> bool:
    if not isinstance(value, (bool, np.bool_)):
        raise ValueError(f"{name} must be True or False, got {value!r} ({type(value).__name__})")
    return bool(value)


def _require_fraction(name: str, value: Any) -> float:
    """A number in (0, 1]."""
    number = require_number(name, value)
    if not 0.0 < number <= 1.0:
        raise ValueError(f"{name} must be within (0, 1], got {value!r}")
    return number


def _read_npz(handle: BinaryIO) -> dict[str, np.ndarray]:
    archive = np.load(handle, allow_pickle=False)
    if not isinstance(archive, np.lib.npyio.NpzFile):
        raise ValueError("not an .npz archive")
    with archive:
        return {name: archive[name] for name in archive.files}


def _positive_vector(name: str, value: Any, size: int) -> np.ndarray:
    """A number > 0 (repeated) or ``size`` numbers > 0; ``None`` means ones."""
    if value is None:
        return np.ones(size)
    if np.ndim(value) == 0:
        return np.full(size, require_positive(name, value))
    array = as_finite_array(name, value)
    if array.shape != (size,) or not np.all(array > 0):
        raise ValueError(f"{name} must be a number > 0 or {size} numbers > 0, got {value!r}")
    return array


def _distance_metric(value: Any, d: int, diag_only: bool) -> np.ndarray:
    """``init_d`` as a (d, d) symmetric positive definite matrix."""
    allowed = (f"a number > 0, {d} numbers > 0 (a diagonal) or a symmetric positive definite "
               f"({d}, {d}) matrix{' that is diagonal (diag_only=True)' if diag_only else ''}")
    if np.ndim(value) == 0:
        return require_positive("init_d", value) * np.eye(d)
    D = as_finite_array("init_d", value)
    if D.shape == (d,):
        if not np.all(D > 0):
            raise ValueError(f"init_d must be {allowed}, got {value!r}")
        return np.diag(D)
    if D.shape != (d, d) or not np.allclose(D, D.T, rtol=0.0, atol=1e-12 * np.abs(D).max()):
        raise ValueError(f"init_d must be {allowed}, got {value!r}")
    if diag_only and np.any(D[~np.eye(d, dtype=bool)] != 0):
        raise ValueError(f"init_d must be {allowed}, got {value!r}")
    if np.any(np.linalg.eigvalsh(D) <= 0):
        raise ValueError(f"init_d must be {allowed}, got {value!r}")
    return 0.5 * (D + D.T)


def _learning_rates(value: Any, d: int) -> np.ndarray:
    if np.ndim(value) == 0:
        return np.full((d, d), require_positive("init_alpha", value))
    alpha = as_finite_array("init_alpha", value)
    if alpha.shape != (d, d) or not np.all(alpha > 0):
        raise ValueError(f"init_alpha must be a number > 0 or a ({d}, {d}) array of numbers > 0, "
                         f"got {value!r}")
    return alpha


def _project(z: np.ndarray, U: np.ndarray, P: np.ndarray, residuals: bool = False
             ) -> tuple[np.ndarray, np.ndarray | None]:
    """PLS scores ``s`` (k, R) of inputs ``z`` (k, d) through projections ``U``, ``P`` (k, R, d).

    ``s_j = u_j . z_j`` with ``z_{j+1} = z_j - p_j s_j``; unused projections hold ``u = p = 0``
    and give ``s = 0``. With ``residuals`` also returns the stacked ``z_j`` (k, R, d).
    """
    k, R, _ = U.shape
    s = np.empty((k, R))
    zres = np.empty(U.shape) if residuals else None
    current = z
    for j in range(R):
        if residuals:
            zres[:, j] = current
        s[:, j] = np.einsum("ki,ki->k", U[:, j], current)
        current = current - P[:, j] * s[:, j, None]
    return s, zres


class _Fields:
    """The receptive fields of one output dimension as stacked arrays (row k is field k).

    Names follow klanke2008: ``c`` centre, ``M``/``D`` metric, ``alpha``/``b``/``h`` learning
    rates, their logarithms and the meta-learning memory, ``beta0``/``mean_x``/``var_x`` weighted
    means, ``n_reg`` projections in use, per projection ``beta`` (slopes), ``SSs2`` (a_ss),
    ``SSYres`` (a_st), ``SSXres`` (a_sz), ``SXresYres`` (a_zt), ``U``/``P`` (projection and
    reduction directions), ``H``/``r`` (traces), ``sum_w``, ``sum_e_cv2``, ``n_data``, ``lam``
    (forgetting factors), ``s`` (last scores); ``sum_e2``, ``SSp``, ``trustworthy`` per field.
    """

    def __init__(self, d: int, R: int, capacity: int = 16) -> None:
        self.layout: dict[str, tuple[tuple[int, ...], type]] = {
            "c": ((d,), float), "M": ((d, d), float), "D": ((d, d), float),
            "alpha": ((d, d), float), "b": ((d, d), float), "h": ((d, d), float),
            "beta0": ((), float), "mean_x": ((d,), float), "var_x": ((d,), float),
            "n_reg": ((), np.int64), "trustworthy": ((), bool), "sum_e2": ((), float),
            "SSp": ((), float),
            **{name: ((R,), float) for name in ("beta", "SSs2", "SSYres", "H", "r", "sum_w",
                                                 "sum_e_cv2", "n_data", "lam", "s")},
            **{name: ((R, d), float) for name in ("U", "P", "SXresYres", "SSXres")},
        }
        self.n = 0
        self.n_pruned = 0
        self.a = {name: np.zeros((capacity,) + shape, dtype)
                  for name, (shape, dtype) in self.layout.items()}

    def append(self) -> int:
        """Index of a new all-zero row (the arrays grow by doubling)."""
        capacity = len(self.a["c"])
        if self.n == capacity:
            for name, old in self.a.items():
                grown = np.zeros((2 * capacity,) + old.shape[1:], old.dtype)
                grown[:capacity] = old
                self.a[name] = grown
        self.n += 1
        return self.n - 1

    def remove(self, index: int) -> None:
        """Drop field ``index``; the last field takes its place (as klanke2008)."""
        last = self.n - 1
        for array in self.a.values():
            array[index] = array[last]
            array[last] = 0
        self.n = last

    def gather(self, rows: np.ndarray) -> dict[str, np.ndarray]:
        return {name: array[rows] for name, array in self.a.items()}

    def scatter(self, rows: np.ndarray, values: dict[str, np.ndarray]) -> None:
        for name, array in self.a.items():
            array[rows] = values[name]


class LWPR:
    """Locally weighted projection regression, updated one sample at a time.

    Parameters (defaults of klanke2008):
        input_dim, output_dim: sizes of ``x`` and ``y``.
        init_d: distance metric of new fields, in (normalised input units)^-2: a number (times
            the identity), a diagonal, or a symmetric positive definite matrix.
        init_alpha: learning rate of the metric (number or (d, d) array, > 0).
        w_gen: a sample activating no field above this creates one, in (0, 1).
        w_prune: two fields both activated above this: the narrower is removed (> w_gen; the
            default 1.0 never prunes).
        init_lambda, final_lambda, tau_lambda: forgetting factor of new projections, its limit,
            and the annealing rate (lambda <- tau lambda + final (1 - tau)), in (0, 1], (0, 1],
            [0, 1].
        penalty: weight ``gamma`` of the smoothness penalty on ``D`` (>= 0).
        diag_only: adapt a diagonal ``D`` only.
        meta: adapt the learning rates (delta-bar-delta) with step ``meta_rate`` (> 0).
        update_d: adapt the distance metric at all.
        max_projections: most PLS projections per field, 1..input_dim (default input_dim).
        add_threshold: relative error drop that adds a projection, in (0, 1].
        init_s2: initial ``a_ss`` of a projection (a ridge on its slope, > 0).
        norm_in, norm_out: typical scale of each input and output (numbers > 0, default 1).
    """

    def __init__(self, input_dim: int, output_dim: int = 1, *,
                 init_d: float | np.ndarray = 25.0, init_alpha: float | np.ndarray = 50.0,
                 w_gen: float = 0.1, w_prune: float = 1.0, init_lambda: float = 0.999,
                 final_lambda: float = 0.99999, tau_lambda: float = 0.9999,
                 penalty: float = 1e-6, diag_only: bool = True, meta: bool = False,
                 meta_rate: float = 250.0, update_d: bool = True,
                 max_projections: int | None = None, add_threshold: float = 0.5,
                 init_s2: float = 1e-10, norm_in: float | np.ndarray | None = None,
                 norm_out: float | np.ndarray | None = None) -> None:
        self.input_dim = require_integer("input_dim", input_dim, 1)
        self.output_dim = require_integer("output_dim", output_dim, 1)
        d = self.input_dim
        self.w_gen = require_positive("w_gen", w_gen)
        if self.w_gen >= 1.0:
            raise ValueError(f"w_gen must be in (0, 1), got {w_gen!r}")
        self.w_prune = require_positive("w_prune", w_prune)
        if self.w_prune <= self.w_gen:
            raise ValueError(f"w_prune must be > w_gen = {self.w_gen}, got {w_prune!r}")
        self.init_lambda = _require_fraction("init_lambda", init_lambda)
        self.final_lambda = _require_fraction("final_lambda", final_lambda)
        self.tau_lambda = require_in_range("tau_lambda", tau_lambda, 0.0, 1.0)
        self.penalty = require_non_negative("penalty", penalty)
        self.diag_only = _require_bool("diag_only", diag_only)
        self.meta = _require_bool("meta", meta)
        self.meta_rate = require_positive("meta_rate", meta_rate)
        self.update_d = _require_bool("update_d", update_d)
        if max_projections is None:
            max_projections = d
        self.max_projections = require_integer("max_projections", max_projections, 1)
        if self.max_projections > d:
            raise ValueError(f"max_projections must be an integer in [1, input_dim={d}], got "
                             f"{max_projections!r}")
        self.add_threshold = _require_fraction("add_threshold", add_threshold)
        self.init_s2 = require_positive("init_s2", init_s2)
        self.init_d = _distance_metric(init_d, d, self.diag_only)
        self._init_M = np.linalg.cholesky(self.init_d).T          # D = M^T M, M upper
        self.init_alpha = _learning_rates(init_alpha, d)
        self.norm_in = _positive_vector("norm_in", norm_in, d)
        self.norm_out = _positive_vector("norm_out", norm_out, self.output_dim)
        self._mask = np.eye(d, dtype=bool) if self.diag_only else np.triu(np.ones((d, d), bool))
        self._outputs = [_Fields(d, self.max_projections) for _ in range(self.output_dim)]
        self.samples_seen = 0

    # ------------------------------------------------------------------ public API
    @property
    def n_receptive_fields(self) -> int:
        """Number of receptive fields, summed over the output dimensions."""
        return sum(fields.n for fields in self._outputs)

    @property
    def fields_per_output(self) -> tuple[int, ...]:
        """Number of receptive fields of each output dimension."""
        return tuple(fields.n for fields in self._outputs)

    @property
    def n_pruned(self) -> int:
        """Receptive fields removed by pruning so far, summed over the outputs."""
        return sum(fields.n_pruned for fields in self._outputs)

    def receptive_fields(self, output: int | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Centres (K, d) and distance metrics (K, d, d) of the fields, in input units.

        ``D`` is in 1/input units squared, so that ``w = exp(-1/2 (x - c)^T D (x - c))`` for raw
        ``x``: the local regions of ho2018 eq. (6), which eqs. (4)-(5) reuse for the local
        inverse controllers. ``output`` selects one output dimension; ``None`` stacks the fields
        of all outputs, in output order (``fields_per_output`` gives the split). Copies.
        """
        if output is None:
            chosen = self._outputs
        elif isinstance(output, (bool, np.bool_)) or not isinstance(output, (int, np.integer)) \
                or not 0 <= output < self.output_dim:
            raise ValueError(f"output must be None or an integer in [0, {self.output_dim - 1}], "
                             f"got {output!r}")
        else:
            chosen = [self._outputs[output]]
        centres = np.concatenate([fields.a["c"][:fields.n] for fields in chosen])
        D = np.concatenate([fields.a["D"][:fields.n] for fields in chosen])
        return centres * self.norm_in, D / np.outer(self.norm_in, self.norm_in)

    def update(self, x: Any, y: Any) -> np.ndarray:
        """Learn from one sample; returns the prediction at ``x`` made during the update.

        ``x``: ``input_dim`` values (a number if 1-D); ``y``: ``output_dim`` values. As in
        klanke2008 the returned prediction (shape ``(output_dim,)``, output units) blends the
        just-updated local models of the trustworthy activated fields with their activations
        before the update; it is 0 where no field was trustworthy.
        """
        x = self._check_vector("x", x, self.input_dim)
        y = self._check_vector("y", y, self.output_dim)
        xn = x / self.norm_in
        yn = y / self.norm_out
        prediction = np.array([self._update_output(fields, xn, float(yn[i]))
                               for i, fields in enumerate(self._outputs)])
        self.samples_seen += 1
        return prediction * self.norm_out

    def predict(self, x: Any, return_confidence: bool = False, cutoff: float = UPDATE_CUTOFF
                ) -> np.ndarray | tuple[np.ndarray, np.ndarray]:
        """Prediction at ``x`` (shape ``(output_dim,)``), and the confidence bound if asked.

        Fields activated at or below ``cutoff`` are ignored. Where no field is used the mean is
        0 and the bound ``inf``.
        """
        x = self._check_vector("x", x, self.input_dim)
        result = self._predict(x[None, :], return_confidence, cutoff)
        if return_confidence:
            return result[0][0], result[1][0]
        return result[0][0]

    def predict_batch(self, X: Any, return_confidence: bool = False,
                      cutoff: float = UPDATE_CUTOFF) -> np.ndarray | tuple[np.ndarray, np.ndarray]:
        """:meth:`predict` at the rows of ``X`` (k, input_dim); arrays of shape (k, output_dim)."""
        X = as_finite_array("X", X)
        if self.input_dim == 1 and X.ndim == 1:
            X = X[:, None]
        if X.ndim != 2 or X.shape[1] != self.input_dim:
            raise ValueError(f"X must have shape (k, {self.input_dim}), got shape {X.shape}")
        mean, conf = self._predict(X, return_confidence, cutoff)
        return (mean, conf) if return_confidence else mean

    def save(self, path: str | Path | BinaryIO) -> None:
        """Write the model to ``path`` (``.npz`` format, exactly that name, or an open binary
        file); :meth:`load` restores it."""
        arrays: dict[str, Any] = {"format": np.array(_FORMAT), "samples_seen": self.samples_seen,
                                  "init_d": self.init_d, "init_M": self._init_M,
                                  "init_alpha": self.init_alpha, "norm_in": self.norm_in,
                                  "norm_out": self.norm_out}
        arrays.update({name: getattr(self, name) for name in _SETTINGS})
        for i, fields in enumerate(self._outputs):
            arrays[f"out{i}/n_pruned"] = fields.n_pruned
            for name, array in fields.a.items():
                arrays[f"out{i}/{name}"] = array[:fields.n]
        if hasattr(path, "write"):
            np.savez(path, **arrays)
        else:
            with open(path, "wb") as handle:
                np.savez(handle, **arrays)

    @classmethod
    def load(cls, path: str | Path | BinaryIO) -> "LWPR":
        """Read a model written by :meth:`save` (a path or an open binary file); its
        predictions and updates equal the saved model's.

        A file that is not such a model raises ``ValueError`` naming ``path``.
        """
        try:
            if hasattr(path, "read"):
                data = _read_npz(path)
            else:
                with open(path, "rb") as handle:
                    data = _read_npz(handle)
        except (OSError, ValueError, EOFError, KeyError, zipfile.BadZipFile, zlib.error) as error:
            raise ValueError(f"cannot read an LWPR model from {str(path)!r}: {error}") from error
        if "format" not in data or str(data["format"]) != _FORMAT:
            raise ValueError(f"{str(path)!r} is not an LWPR model file (no {_FORMAT!r} marker)")
        try:
            settings = {name: data[name].item() for name in _SETTINGS}
            model = cls(**settings, init_d=data["init_d"], init_alpha=data["init_alpha"],
                        norm_in=data["norm_in"], norm_out=data["norm_out"])
            model._init_M = np.array(data["init_M"], dtype=float)
            model.samples_seen = int(data["samples_seen"])
            for i, fields in enumerate(model._outputs):
                fields.n_pruned = int(data[f"out{i}/n_pruned"])
                stored = {name: data[f"out{i}/{name}"] for name in fields.layout}
                n = len(stored["c"])
                for name, (shape, dtype) in fields.layout.items():
                    if stored[name].shape != (n,) + shape:
                        raise ValueError(f"out{i}/{name} has shape {stored[name].shape}, "
                                         f"expected {(n,) + shape}")
                    if dtype is float and not np.all(np.isfinite(stored[name])):
                        raise ValueError(f"out{i}/{name} holds non-finite values")
                if np.any(stored["n_reg"] < 1) or np.any(stored["n_reg"] > model.max_projections):
                    raise ValueError(f"out{i}/n_reg out of range")
                for _ in range(n):
                    fields.append()
                for name, array in stored.items():
                    fields.a[name][:n] = array
        except (KeyError, IndexError, ValueError, TypeError, AttributeError) as error:
            raise ValueError(f"{str(path)!r} is not a valid LWPR model file: {error}") from error
        return model

    # ------------------------------------------------------------------ update
    def _update_output(self, fields: _Fields, xn: np.ndarray, yn: float) -> float:
        """One sample for the fields of one output (normalised units); returns its prediction."""
        n = fields.n
        if n == 0:
            self._new_field(fields, xn, yn, None)
            return 0.0
        w = self._activations(xn[None, :], fields.a["c"][:n], fields.a["D"][:n])[0]
        i_max = int(np.argmax(w))
        w_max = float(w[i_max])
        i_sec, w_sec = -1, 0.0
        if n > 1:
            others = w.copy()
            others[i_max] = -1.0
            i_sec = int(np.argmax(others))
            w_sec = float(others[i_sec])

        prediction = 0.0
        rows = np.flatnonzero(w > UPDATE_CUTOFF)
        if rows.size:
            f = fields.gather(rows)
            w_rows = w[rows]
            y_local = self._update_fields(f, w_rows, xn, yn)
            fields.scatter(rows, f)
            trusted = f["trustworthy"]
            total = float(np.sum(w_rows[trusted]))
            if total > 0.0:
                prediction = float(np.dot(w_rows[trusted], y_local[trusted])) / total

        if w_max <= self.w_gen:
            template = i_max if (w_max > 0.1 * self.w_gen
                                 and fields.a["trustworthy"][i_max]) else None
            self._new_field(fields, xn, yn, template)
        elif w_sec > self.w_prune:
            D = fields.a["D"]
            narrower = i_max if np.trace(D[i_max]) > np.trace(D[i_sec]) else i_sec
            fields.remove(narrower)
            fields.n_pruned += 1
        return prediction

    def _update_fields(self, f: dict[str, np.ndarray], w: np.ndarray, xn: np.ndarray,
                       yn: float) -> np.ndarray:
        """Update the gathered fields ``f`` (activations ``w``) in place; local predictions."""
        d, R = self.input_dim, self.max_projections
        rows = np.arange(len(w))
        n_reg = f["n_reg"]
        on = np.arange(R) < n_reg[:, None]
        last = n_reg - 1
        lam = f["lam"]

        # weighted means, with the forgetting of the first projection
        memory = f["sum_w"][:, 0] * lam[:, 0]
        total = memory + w
        mean_x = (memory[:, None] * f["mean_x"] + w[:, None] * xn) / total[:, None]
        z = xn - mean_x
        f["mean_x"] = mean_x
        f["var_x"] = (memory[:, None] * f["var_x"] + w[:, None] * z**2) / total[:, None]
        f["beta0"] = (memory * f["beta0"] + w * yn) / total
        e0 = yn - f["beta0"]

        # PLS: scores with the current projections, leave-one-out residuals per stage
        s, zres = _project(z, f["U"], f["P"], residuals=True)
        e_cv = e0[:, None] - np.cumsum(f["beta"] * s, axis=1)
        target = np.concatenate([e0[:, None], e_cv[:, :-1]], axis=1)
        f["sum_w"] = np.where(on, f["sum_w"] * lam + w[:, None], f["sum_w"])
        slow = 0.9 + 0.1 * lam
        szt = np.where(on[..., None], f["SXresYres"] * slow[..., None]
                       + (w[:, None] * target)[..., None] * zres, f["SXresYres"])
        f["SXresYres"] = szt
        norm2 = np.einsum("krd,krd->kr", szt, szt)
        renew = on & (norm2 > 1e-24)
        f["U"] = np.where(renew[..., None],
                          szt / np.sqrt(np.where(renew, norm2, 1.0))[..., None], f["U"])
        ws = w[:, None] * s
        SSs2 = np.where(on, lam * f["SSs2"] + ws * s, f["SSs2"])
        f["SSYres"] = np.where(on, lam * f["SSYres"] + ws * target, f["SSYres"])
        f["SSXres"] = np.where(on[..., None], lam[..., None] * f["SSXres"]
                               + ws[..., None] * zres, f["SSXres"])
        f["beta"] = np.where(on, f["SSYres"] / SSs2, f["beta"])
        f["P"] = np.where(on[..., None], f["SSXres"] / SSs2[..., None], f["P"])
        f["SSs2"] = SSs2
        f["SSp"] = lam[rows, last] * f["SSp"] + np.sum(np.where(on, ws * ws / SSs2, 0.0), axis=1)

        # the updated local model at x; the last projection only once it has enough data
        s = _project(z, f["U"], f["P"])[0]
        f["s"] = s
        n_data = f["n_data"]
        n_used = np.where(n_data[rows, last] > 2 * d, n_reg, n_reg - 1)
        y_fit = np.sum(np.where(np.arange(R) < n_used[:, None], f["beta"] * s, 0.0), axis=1)
        e = e0 - y_fit
        e_cv_used = np.where(n_used > 0, e_cv[rows, np.maximum(n_used - 1, 0)], e0)
        ready = n_data[:, 0] * (1.0 - lam[:, 0]) > 0.1
        f["sum_e2"] = np.where(ready, f["sum_e2"] * lam[rows, last] + w * e * e, f["sum_e2"])
        f["sum_e_cv2"] = np.where(ready[:, None] & on,
                                  f["sum_e_cv2"] * lam + w[:, None] * e_cv**2, f["sum_e_cv2"])
        f["trustworthy"] = f["trustworthy"] | (n_data[:, 0] > 2 * d)
        y_local = y_fit + f["beta0"]

        if self.update_d:
            self._update_metric(f, w, xn, e, e_cv_used, on)
        self._add_projections(f)

        on = np.arange(R) < f["n_reg"][:, None]
        lam = f["lam"]
        f["n_data"] = np.where(on, f["n_data"] * lam + 1.0, f["n_data"])
        f["lam"] = np.where(on, self.tau_lambda * lam
                            + self.final_lambda * (1.0 - self.tau_lambda), lam)
        return y_local

    def _update_metric(self, f: dict[str, np.ndarray], w: np.ndarray, xn: np.ndarray,
                       e: np.ndarray, e_cv: np.ndarray, on: np.ndarray) -> None:
        """Gradient step on M of the penalised leave-one-out cost (see the module docstring)."""
        d = self.input_dim
        rows = np.arange(len(w))
        lam, n_data, n_reg = f["lam"], f["n_data"], f["n_reg"]
        ok = on & (n_data * (1.0 - lam[:, :1]) > 0.1)
        go = ok[:, 0]
        if not np.any(go):
            return
        s, H, r = f["s"], f["H"], f["r"]
        psi = np.where(ok, s / f["SSs2"], 0.0)
        h = w * np.sum(psi * s, axis=1)
        W = f["sum_w"][:, 0]
        last = n_reg - 1
        use_last = (n_reg == 1) | (n_data[rows, last] > 2 * d)
        E = f["sum_e_cv2"][rows, np.where(use_last, last, last - 1)]
        damping = np.where(go, np.minimum(1.0, (f["sum_e2"] / (E + _TINY))**4), 0.0)
        e_cv2 = e_cv**2
        dJ1dw = (e_cv2 - E / W - 2.0 * np.sum(psi * e[:, None] * H + psi**2 * r, axis=1)) / W

        M, D = f["M"], f["D"]
        dx = xn - f["c"]
        dqdM = 2.0 * np.einsum("kij,kj->ki", M, dx)[:, :, None] * dx[:, None, :]
        dwdq = -0.5 * w
        dwdM = dwdq[:, None, None] * dqdM
        gamma = self.penalty / d
        dJ2dM = 4.0 * gamma * np.matmul(M, D)
        mask = self._mask
        dJdM = np.where(mask, (w / W)[:, None, None] * dJ2dM + dJ1dw[:, None, None] * dwdM, 0.0)
        step = damping[:, None, None]
        active = mask & go[:, None, None]
        alpha = f["alpha"]

        if self.meta:
            Pse = psi * e[:, None]
            sPse = np.sum(s * Pse, axis=1)
            ddJ1dwdw = (2.0 * (e**2 * h / w - e_cv2 / W) + E / W**2
                        + 4.0 * np.sum((Pse / W[:, None] + psi * sPse[:, None]) * H, axis=1)) / W
            ddwdMdM = (0.25 * w)[:, None, None] * dqdM**2 \
                + 2.0 * dwdq[:, None, None] * (dx**2)[:, None, :]
            ddJ2dMdM = 4.0 * gamma * (np.diagonal(D, axis1=1, axis2=2)[:, None, :] + M**2
                                      + np.sum(M**2, axis=2)[:, :, None])
            ddJdMdM = (w / W)[:, None, None] * ddJ2dMdM + dJ1dw[:, None, None] * ddwdMdM \
                + ddJ1dwdw[:, None, None] * dwdM**2
            memory = f["h"]
            b = np.clip(f["b"] - np.clip(self.meta_rate * step * dJdM * memory, -0.1, 0.1),
                        -10.0, 10.0)
            b = np.where(active, b, f["b"])
            alpha = np.where(active, np.exp(b), alpha)
            decay = np.maximum(0.0, 1.0 - alpha * ddJdMdM * step)
            f["h"] = np.where(active, memory * decay - alpha * step * dJdM, memory)
            f["b"] = b

        largest = np.max(np.abs(np.where(mask, M, 0.0)), axis=(1, 2))
        delta = alpha * step * dJdM
        too_large = active & (delta > 0.1 * largest[:, None, None])
        f["alpha"] = np.where(too_large, 0.5 * alpha, alpha)
        M = np.where(active & ~too_large, M - delta, M)
        f["M"] = M
        f["D"] = np.matmul(np.swapaxes(M, 1, 2), M)

        traced = ok & go[:, None]
        gain = w / (1.0 - h) * damping
        f["H"] = np.where(traced, lam * H + (gain * e_cv)[:, None] * s, H)
        f["r"] = np.where(traced, lam * r + (gain * w * e_cv2)[:, None] * s**2, r)

    def _add_projections(self, f: dict[str, np.ndarray]) -> None:
        """Add a PLS projection where the last one reduced the error enough (klanke2008)."""
        n_reg = f["n_reg"]
        rows = np.flatnonzero((n_reg < self.max_projections) & (n_reg >= 2))
        if rows.size == 0:
            return
        j = n_reg[rows]
        sum_e_cv2, sum_w, n_data, lam = f["sum_e_cv2"], f["sum_w"], f["n_data"], f["lam"]
        mse = sum_e_cv2[rows, j - 1] / sum_w[rows, j - 1] + _TINY
        mse_before = sum_e_cv2[rows, j - 2] / sum_w[rows, j - 2] + _TINY
        add = ((mse < self.add_threshold * mse_before)
               & (n_data[rows, j - 1] > 0.99 * n_data[rows, 0])
               & (n_data[rows, j - 1] * (1.0 - lam[rows, j - 1]) > 0.5))
        rows, j = rows[add], j[add]
        # the new projection's statistics still hold their initial values (never updated)
        f["U"][rows, j, j] = 1.0
        f["P"][rows, j, j] = 1.0
        f["SSp"][rows] = 0.0
        f["n_reg"][rows] = j + 1

    def _new_field(self, fields: _Fields, xn: np.ndarray, yn: float, template: int | None
                   ) -> None:
        """Centre a new field at ``xn``; metric and offset from ``template`` if given."""
        if template is None:
            M, D, alpha, beta0 = self._init_M, self.init_d, self.init_alpha, yn
            n_reg = min(2, self.max_projections)
        else:
            a = fields.a
            M, D, alpha = a["M"][template].copy(), a["D"][template].copy(), \
                a["alpha"][template].copy()
            beta0, n_reg = float(a["beta0"][template]), int(a["n_reg"][template])
        k = fields.append()
        a = fields.a
        a["c"][k] = xn
        a["M"][k] = M
        a["D"][k] = D
        a["alpha"][k] = alpha
        a["b"][k] = np.where(self._mask, np.log(alpha + _TINY), 0.0)
        a["beta0"][k] = beta0
        a["n_reg"][k] = n_reg
        a["SSs2"][k] = self.init_s2
        a["sum_w"][k] = _TINY
        a["lam"][k] = self.init_lambda
        a["n_data"][k, :n_reg] = _TINY
        j = np.arange(n_reg)
        a["U"][k, j, j] = 1.0
        a["P"][k, j, j] = 1.0

    # ------------------------------------------------------------------ prediction
    def _activations(self, X: np.ndarray, c: np.ndarray, D: np.ndarray) -> np.ndarray:
        """Activations (k, n) of n fields at the rows of X (k, d), normalised units."""
        dx = X[:, None, :] - c[None, :, :]
        if self.diag_only:
            q = np.einsum("knd,nd->kn", dx * dx, np.diagonal(D, axis1=1, axis2=2))
        else:
            q = np.einsum("knd,knd->kn", dx, np.einsum("nij,knj->kni", D, dx))
        return np.exp(-0.5 * q)

    def _predict(self, X: np.ndarray, with_confidence: bool, cutoff: float
                 ) -> tuple[np.ndarray, np.ndarray | None]:
        cutoff = require_non_negative("cutoff", cutoff)
        Xn = X / self.norm_in
        k = len(Xn)
        mean = np.zeros((k, self.output_dim))
        conf = np.full((k, self.output_dim), np.inf) if with_confidence else None
        # rows per chunk, bounding the (rows, fields, d) temporaries of the activations
        chunk = max(1, 2_000_000 // (self.input_dim * max(1, max(self.fields_per_output))))
        for start in range(0, k, chunk):
            part = slice(start, start + chunk)
            for i, fields in enumerate(self._outputs):
                m, c = self._predict_output(fields, Xn[part], with_confidence, cutoff)
                mean[part, i] = m
                if with_confidence:
                    conf[part, i] = c
        mean *= self.norm_out
        if with_confidence:
            conf *= self.norm_out
        return mean, conf

    def _predict_output(self, fields: _Fields, Xn: np.ndarray, with_confidence: bool,
                        cutoff: float) -> tuple[np.ndarray, np.ndarray]:
        """Blended local predictions (and bounds) of one output at the rows of ``Xn``."""
        k, n, d = len(Xn), fields.n, self.input_dim
        mean, conf = np.zeros(k), np.full(k, np.inf)
        if n == 0:
            return mean, conf
        a = fields.a
        w_all = self._activations(Xn, a["c"][:n], a["D"][:n])
        point, field = np.nonzero((w_all > cutoff) & a["trustworthy"][:n][None, :])
        if point.size == 0:
            return mean, conf
        w = w_all[point, field]
        n_reg = a["n_reg"][field]
        n_used = np.where(a["n_data"][field, n_reg - 1] > 2 * d, n_reg, n_reg - 1)
        s = _project(Xn[point] - a["mean_x"][field], a["U"][field], a["P"][field])[0]
        s = np.where(np.arange(self.max_projections) < n_used[:, None], s, 0.0)
        y_local = a["beta0"][field] + np.sum(a["beta"][field] * s, axis=1)
        sum_w = np.bincount(point, w, k)
        sum_wy = np.bincount(point, w * y_local, k)
        used = sum_w > 0
        mean[used] = sum_wy[used] / sum_w[used]
        if with_confidence:
            j = np.maximum(n_used - 1, 0)
            sigma2 = a["sum_e_cv2"][field, j] / (a["sum_w"][field, j] - a["SSp"][field]) \
                * (1.0 + w * np.sum(s * s / a["SSs2"][field], axis=1))
            spread = np.bincount(point, w * sigma2, k) + np.bincount(point, w * y_local**2, k) \
                - sum_wy * mean
            conf[used] = np.sqrt(np.abs(spread[used])) / sum_w[used]
        return mean, conf

    # ------------------------------------------------------------------ checks
    @staticmethod
    def _check_vector(name: str, value: Any, size: int) -> np.ndarray:
        array = as_finite_array(name, value)
        if array.ndim == 0 and size == 1:
            array = array.reshape(1)
        if array.shape != (size,):
            raise ValueError(f"{name} must hold {size} values (shape ({size},)), got shape "
                             f"{array.shape}")
        return array
