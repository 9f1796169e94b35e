"""Sliding-window Gaussian-process regression with an incrementally maintained Cholesky factor.

Wang et al. 2023 (wang2023), Section III-B, eqs. (28)-(29): the constant-curvature model
controller is compensated by an online GP regressor with inputs ``x = [u(k-1), dz(k)]``
(previous actuation and desired tip displacement) and output ``dp_e`` (actuation error). It is
trained on the most recent ``N_r^max`` samples (the oldest is discarded when a new one arrives)
and retrained at every control step; its hyperparameters stay fixed online.

Model. Independent outputs that share one squared-exponential (ARD) kernel

    k(a, b) = s_f^2 exp(-1/2 sum_i (a_i - b_i)^2 / l_i^2)

and Gaussian observation noise ``s_n^2``. With ``K`` the kernel matrix of the window inputs
``X``, ``L L^T = K + s_n^2 I`` and ``mu`` the prior mean (zero, or the mean of the window
targets per output), the predictions at ``x*`` are

    mean(x*) = mu + k*^T alpha,   alpha = L^-T L^-1 (Y - mu)
    var(x*)  = s_f^2 - |L^-1 k*|^2

(the variance of the latent function, without the observation noise; it is the same for every
output). ``alpha`` is cached and recomputed on demand after the window changes.

Incremental factor. Only ``L`` is carried from step to step:

* appending a sample adds one row ``[l^T, d]`` with ``L l = k(X, x)`` (a triangular solve) and
  ``d = sqrt(s_f^2 + s_n^2 - l^T l)``: O(n^2);
* dropping the oldest sample removes the first row and column. Writing
  ``L = [[l11, 0], [l21, L22]]``, the remaining kernel matrix is ``L22 L22^T + l21 l21^T``, so
  its factor is the rank-one *update* of ``L22`` by ``l21``: the classic LINPACK ``dchud`` /
  ``cholupdate`` recurrence, O(n^2) and free of hyperbolic rotations. For ``k = 1..n``:
  ``r = hypot(L_kk, x_k)``, ``c = L_kk / r``, ``s = x_k / r``, ``L_kk = r`` and the plane
  rotation ``(L_{k+1:,k}, x_{k+1:}) <- (c L + s x, c x - s L)``, applied by BLAS ``drot``.

The factor lives in a preallocated ``window x window`` array (stored as ``R = L^T``, row-major,
so that a column of ``L`` is a contiguous row); positions beyond the current window are kept as
the identity, which lets every triangular solve run on the whole, contiguous array without
copies. Dropping the oldest sample shifts the stored factor up-left by one in place (a single
contiguous move). Every ``refactor_every`` added samples the factor is recomputed from scratch,
which bounds the rounding drift of the updates.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import scipy.linalg
import scipy.optimize
from scipy.linalg.blas import drot, dtrsm, dtrsv
from scipy.spatial.distance import cdist

from soft_gym._model_files import read_npz, write_npz
from soft_gym._validation import as_finite_array, require_choice, require_positive

__all__ = ["SlidingWindowGP", "cholesky_rank1_update"]

_MEAN_CHOICES = ("zero", "window_mean")


def _require_int(name: str, value: Any, low: int) -> int:
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)) \
            or value < low:
        raise ValueError(f"{name} must be an integer >= {low}, got {value!r}")
    return int(value)


def _as_length_scales(value: Any) -> tuple[np.ndarray, bool]:
    """Validated length scales as a 1-D float array and whether they are per input dimension."""
    message = ("length_scales must be a finite number > 0 or a 1-D sequence of finite numbers "
               f"> 0 (one per input dimension), got {value!r}")
    try:
        array = np.array(value, dtype=np.float64)
    except (TypeError, ValueError) as error:
        raise ValueError(message) from error
    if array.ndim > 1 or array.size == 0 or not np.all(np.isfinite(array)) \
            or not np.all(array > 0):
        raise ValueError(message)
    return array.reshape(-1), array.ndim == 1


def _rotate_out_first(flat: np.ndarray, ld: int, n: int, work: np.ndarray) -> None:
    """Rank-one update of the trailing block of an upper factor by its own first row.

    ``flat`` is the row-major storage (leading dimension ``ld``) of an upper triangular ``R``
    whose leading ``n x n`` block is the factor. On return ``R[1:n, 1:n]`` holds the upper factor
    of ``R22^T R22 + r r^T`` with ``r = R[0, 1:n]`` (``work`` is overwritten).
    """
    work[:n] = flat[:n]
    for k in range(1, n):
        diag = k * ld + k
        rkk = float(flat[diag])
        xk = float(work[k])
        r = math.hypot(rkk, xk)
        c = rkk / r
        s = xk / r
        flat[diag] = r
        if k + 1 < n:
            # (R[k, k+1:n], x[k+1:n]) <- (c R + s x, c x - s R), in place
            drot(flat, work, c, s, n - k - 1, diag + 1, 1, k + 1, 1, 1, 1)


def cholesky_rank1_update(lower: np.ndarray, x: np.ndarray) -> np.ndarray:
    """Cholesky factor of ``L L^T + x x^T`` from the lower factor ``L`` in O(n^2).

    The classic ``cholupdate`` recurrence (see the module docstring); returns a new lower
    triangular array with a positive diagonal, ``lower`` and ``x`` are left unchanged.
    """
    lower = as_finite_array("lower", lower)
    x = as_finite_array("x", x)
    if lower.ndim != 2 or lower.shape[0] != lower.shape[1] or x.shape != (lower.shape[0],):
        raise ValueError(f"lower must be square (n, n) and x of shape (n,), got shapes "
                         f"{lower.shape} and {x.shape}")
    n = lower.shape[0]
    if n and np.any(np.diag(lower) <= 0):
        raise ValueError("lower must have a positive diagonal")
    stacked = np.zeros((n + 1, n + 1))
    stacked[0, 1:] = x
    stacked[0, 0] = 1.0
    stacked[1:, 1:] = np.triu(lower.T)
    _rotate_out_first(stacked.reshape(-1), n + 1, n + 1, np.empty(n + 1))
    return np.ascontiguousarray(stacked[1:, 1:].T)


class SlidingWindowGP:
    """Multi-output GP regressor on a sliding window of the most recent samples.

    Args:
        window: most samples kept (``N_r^max``); adding to a full window drops the oldest.
        length_scales: squared-exponential length scale ``l``, a number (the same for every
            input dimension) or one per input dimension (ARD).
        signal_variance: kernel amplitude ``s_f^2`` (the prior variance of each output).
        noise_variance: observation noise variance ``s_n^2``.
        mean: prior mean, ``"zero"`` or ``"window_mean"`` (per output, the mean of the targets in
            the window, recomputed whenever the window changes).
        refactor_every: added samples between refactorisations of the Cholesky factor from
            scratch (1 refactors at every step, a large value keeps it purely incremental).

    Input and output dimensions are fixed by the first :meth:`add` (or by per-dimension
    ``length_scales``) and kept by :meth:`clear`.
    """

    def __init__(self, window: int = 300, length_scales: float | np.ndarray = 1.0,
                 signal_variance: float = 1.0, noise_variance: float = 1e-4,
                 mean: str = "window_mean", refactor_every: int = 200) -> None:
        self.window = _require_int("window", window, 1)
        self._length_scales, self._ard = _as_length_scales(length_scales)
        self._signal_variance = require_positive("signal_variance", signal_variance)
        self._noise_variance = require_positive("noise_variance", noise_variance)
        self.mean = require_choice("mean", mean, _MEAN_CHOICES)
        self.refactor_every = _require_int("refactor_every", refactor_every, 1)
        self.input_dim: int | None = self._length_scales.size if self._ard else None
        self.output_dim: int | None = None
        self.adds_since_refactor = 0
        self.samples_seen = 0
        self._n = 0
        self._X: np.ndarray | None = None       # (window, d) raw inputs, oldest first
        self._Xs: np.ndarray | None = None      # (window, d) inputs / length scales
        self._Y: np.ndarray | None = None       # (window, m) targets
        self._R: np.ndarray | None = None       # (window, window) R = L^T, identity-padded
        self._work: np.ndarray | None = None    # (window,) scratch vector
        self._alpha: np.ndarray | None = None   # (n, m) cached K^-1 (Y - mu)
        self._mu: np.ndarray | None = None      # (m,) prior mean used for _alpha

    # ------------------------------------------------------------------ properties
    @property
    def length_scales(self) -> float | np.ndarray:
        """The length scale (a float) or the per-dimension length scales (a copy)."""
        return self._length_scales.copy() if self._ard else float(self._length_scales[0])

    @property
    def signal_variance(self) -> float:
        return self._signal_variance

    @property
    def noise_variance(self) -> float:
        return self._noise_variance

    @property
    def cholesky_factor(self) -> np.ndarray:
        """Lower Cholesky factor ``L`` of ``K + s_n^2 I`` on the current window (a copy)."""
        n = self._n
        if n == 0:
            return np.zeros((0, 0))
        return np.ascontiguousarray(np.triu(self._R[:n, :n]).T)

    @property
    def window_inputs(self) -> np.ndarray:
        """Inputs in the window, oldest first (a copy, shape (n, d))."""
        return np.zeros((0, self.input_dim or 0)) if self._X is None else self._X[:self._n].copy()

    @property
    def window_targets(self) -> np.ndarray:
        """Targets in the window, oldest first (a copy, shape (n, m))."""
        return (np.zeros((0, self.output_dim or 0)) if self._Y is None
                else self._Y[:self._n].copy())

    def __len__(self) -> int:
        return self._n

    def __repr__(self) -> str:
        return (f"SlidingWindowGP(window={self.window}, length_scales={self.length_scales!r}, "
                f"signal_variance={self._signal_variance!r}, "
                f"noise_variance={self._noise_variance!r}, mean={self.mean!r}, "
                f"refactor_every={self.refactor_every}, samples={self._n})")

    # ------------------------------------------------------------------ online use
    def add(self, x: np.ndarray, y: np.ndarray | float) -> None:
        """Append one sample (input ``x`` (d,), target ``y`` (m,) or a number).

        When the window is full the oldest sample is dropped first. O(window^2).
        """
        x = self._check_sample_input(x)
        y = as_finite_array("y", y)
        if y.ndim > 1:
            raise ValueError(f"y must be a number or a 1-D array, got shape {y.shape}")
        y = y.reshape(-1)
        if self.output_dim is None:
            if y.size == 0:
                raise ValueError("y must hold at least one value, got an empty array")
            self.output_dim = y.size
        elif y.size != self.output_dim:
            raise ValueError(f"y must have {self.output_dim} values, got {y.size}")
        if self.input_dim is None:
            self.input_dim = x.size
        if self._R is None:
            self._allocate()
        refactor_now = self.adds_since_refactor + 1 >= self.refactor_every
        if self._n == self.window:
            self._drop_oldest(update_factor=not refactor_now)
        n = self._n
        self._X[n] = x
        np.divide(x, self._length_scales, out=self._Xs[n])
        self._Y[n] = y
        self._alpha = None
        self.samples_seen += 1
        if refactor_now:
            self._n = n + 1
            self._refactor()
        else:
            self._append_factor()
            self.adds_since_refactor += 1

    def predict(self, x: np.ndarray, return_std: bool = False
                ) -> np.ndarray | tuple[np.ndarray, np.ndarray]:
        """Predictive mean (and standard deviation) at one input (d,) or a batch (k, d).

        Returns the mean of shape (m,) for one input or (k, m) for a batch; with
        ``return_std`` also the latent standard deviation with the same shape (equal across
        outputs). With an empty window this is the prior: mean 0 and std ``sqrt(s_f^2)``; if
        the output dimension is not known yet, ``m`` is 1 (which broadcasts).
        """
        x = as_finite_array("x", x)
        single = x.ndim <= 1
        if x.ndim == 0:
            x = x.reshape(1, 1)
        elif x.ndim == 1:
            x = x[None, :]
        elif x.ndim != 2:
            raise ValueError(f"x must have shape (d,) or (k, d), got shape {x.shape}")
        if self.input_dim is not None and x.shape[1] != self.input_dim:
            raise ValueError(f"x must have {self.input_dim} input dimensions, got shape "
                             f"{x.shape if not single else x.shape[1:]}")
        m = self.output_dim or 1
        k = x.shape[0]
        n = self._n
        if n == 0:
            mean = np.zeros((k, m))
            std = np.full((k, m), math.sqrt(self._signal_variance))
        else:
            self._ensure_alpha()
            cross = self._kernel(x / self._length_scales, self._Xs[:n])   # (k, n)
            mean = cross @ self._alpha + self._mu
            if return_std:
                rhs = np.zeros((self.window, k), order="F")
                rhs[:n] = cross.T
                v = dtrsm(1.0, self._R.T, rhs, lower=1, overwrite_b=1)
                var = self._signal_variance - np.einsum("ij,ij->j", v[:n], v[:n])
                std = np.repeat(np.sqrt(np.maximum(var, 0.0))[:, None], m, axis=1)
        if single:
            mean = mean[0]
            if return_std:
                std = std[0]
        return (mean, std) if return_std else mean

    def clear(self) -> None:
        """Empty the window (hyperparameters and dimensions are kept)."""
        self._n = 0
        self.adds_since_refactor = 0
        self._alpha = None
        self._mu = None
        if self._R is not None:
            self._R[...] = 0.0
            self._R.flat[:: self.window + 1] = 1.0

    def set_hyperparameters(self, length_scales: float | np.ndarray | None = None,
                            signal_variance: float | None = None,
                            noise_variance: float | None = None) -> None:
        """Change hyperparameters (those given) and refactorise the current window."""
        if length_scales is not None:
            scales, ard = _as_length_scales(length_scales)
            if ard and self.input_dim is not None and scales.size != self.input_dim:
                raise ValueError(f"length_scales must have {self.input_dim} values (one per "
                                 f"input dimension), got {scales.size}")
        if signal_variance is not None:
            signal_variance = require_positive("signal_variance", signal_variance)
        if noise_variance is not None:
            noise_variance = require_positive("noise_variance", noise_variance)
        if length_scales is not None:
            self._length_scales, self._ard = scales, ard
            if ard:
                self.input_dim = scales.size
        if signal_variance is not None:
            self._signal_variance = signal_variance
        if noise_variance is not None:
            self._noise_variance = noise_variance
        if self._n:
            n = self._n
            np.divide(self._X[:n], self._length_scales, out=self._Xs[:n])
            self._refactor()
        self._alpha = None

    # ------------------------------------------------------------------ offline fitting
    def log_marginal_likelihood(self, X: np.ndarray, Y: np.ndarray) -> float:
        """Log marginal likelihood of a batch under the current hyperparameters.

        The targets are centred as the ``mean`` option says (``"window_mean"``: by their mean
        over the batch); the outputs are independent, so their terms add up.
        """
        X, Y = self._check_batch(X, Y)
        Yc = Y - Y.mean(axis=0) if self.mean == "window_mean" else Y
        theta = np.concatenate([np.log(self._length_scales),
                                [math.log(self._signal_variance), math.log(self._noise_variance)]])
        value, _ = _negative_lml(theta, _squared_differences(X, self._ard), Yc, fit_noise=True,
                                 noise_variance=self._noise_variance, gradient=False)
        return -value

    def fit_hyperparameters(self, X: np.ndarray, Y: np.ndarray, *, ard: bool | None = None,
                            fit_noise: bool = True, n_restarts: int = 3, seed: int = 0,
                            length_scale_bounds: tuple[float, float] | None = None,
                            signal_variance_bounds: tuple[float, float] | None = None,
                            noise_variance_bounds: tuple[float, float] | None = None,
                            ) -> dict[str, Any]:
        """Maximise the log marginal likelihood on a batch and adopt the result (offline).

        L-BFGS-B on the log hyperparameters with the analytic gradient, started from the
        current values and from ``n_restarts`` log-uniform draws within the bounds; the best
        optimum is kept. The targets are centred as the ``mean`` option says. Default bounds are
        relative to the data: length scales ``[1e-2, 1e2]`` times each input's standard
        deviation, signal variance ``[1e-4, 1e4]`` and noise variance ``[1e-8, 1e1]`` times the
        (centred) target variance; absolute bounds can be given instead.

        Args:
            X: inputs (n, d); Y: targets (n, m) or (n,).
            ard: one length scale per input dimension (default: keep the current kind, i.e.
                True if the model was built with per-dimension length scales).
            fit_noise: also fit the noise variance (otherwise it is kept).

        Returns:
            A dict with the fitted ``length_scales``, ``signal_variance``, ``noise_variance``,
            ``log_marginal_likelihood``, ``success`` and ``message`` of the best run.
            The current window, if any, is refactorised with the new values.
        """
        X, Y = self._check_batch(X, Y)
        n_restarts = _require_int("n_restarts", n_restarts, 0)
        n, d = X.shape
        if n < 2:
            raise ValueError(f"X must hold at least 2 samples, got {n}")
        if ard is None:
            ard = self._ard
        Yc = Y - Y.mean(axis=0) if self.mean == "window_mean" else Y
        p = d if ard else 1
        x_scale = X.std(axis=0)
        x_scale = np.where(x_scale > 0, x_scale, 1.0)
        if not ard:
            x_scale = np.array([float(np.sqrt(np.mean(x_scale**2)))])
        y_var = float(np.mean(Yc**2)) if np.any(Yc) else 1.0

        def bounds_of(given, name, default_low, default_high, scale):
            if given is None:
                low, high = default_low * scale, default_high * scale
            else:
                low, high = given
                if not (np.isfinite(low) and np.isfinite(high) and 0 < low < high):
                    raise ValueError(f"{name} must be (low, high) with 0 < low < high, "
                                     f"got {given!r}")
                low, high = np.full_like(scale, low), np.full_like(scale, high)
            return np.log(low), np.log(high)

        ls_lo, ls_hi = bounds_of(length_scale_bounds, "length_scale_bounds", 1e-2, 1e2, x_scale)
        sv_lo, sv_hi = bounds_of(signal_variance_bounds, "signal_variance_bounds", 1e-4, 1e4,
                                 np.array([y_var]))
        nv_lo, nv_hi = bounds_of(noise_variance_bounds, "noise_variance_bounds", 1e-8, 1e1,
                                 np.array([y_var]))
        low = np.concatenate([ls_lo, sv_lo] + ([nv_lo] if fit_noise else []))
        high = np.concatenate([ls_hi, sv_hi] + ([nv_hi] if fit_noise else []))
        current = np.log(np.broadcast_to(
            self._length_scales if self._length_scales.size == p
            else np.full(p, float(np.exp(np.mean(np.log(self._length_scales))))), (p,)))
        start = np.concatenate([current, [math.log(self._signal_variance)]]
                               + ([[math.log(self._noise_variance)]] if fit_noise else []))
        rng = np.random.default_rng(seed)
        starts = [np.clip(start, low, high)] + [rng.uniform(low, high)
                                                for _ in range(n_restarts)]
        differences = _squared_differences(X, ard)
        fixed_noise = self._noise_variance

        def objective(theta):
            full = theta if fit_noise else np.append(theta, math.log(fixed_noise))
            value, grad = _negative_lml(full, differences, Yc, fit_noise=fit_noise,
                                        noise_variance=fixed_noise, gradient=True)
            return value, (grad if fit_noise else grad[:-1])

        best = None
        for theta0 in starts:
            result = scipy.optimize.minimize(objective, theta0, jac=True, method="L-BFGS-B",
                                             bounds=list(zip(low, high)))
            if np.isfinite(result.fun) and (best is None or result.fun < best.fun):
                best = result
        if best is None:
            raise ValueError("fit_hyperparameters failed: the kernel matrix was not positive "
                             "definite at any start; give larger noise_variance_bounds")
        theta = np.exp(best.x)
        scales = theta[:p]
        self.set_hyperparameters(length_scales=scales if ard else float(scales[0]),
                                 signal_variance=float(theta[p]),
                                 noise_variance=float(theta[p + 1]) if fit_noise else None)
        return {"length_scales": self.length_scales, "signal_variance": self._signal_variance,
                "noise_variance": self._noise_variance,
                "log_marginal_likelihood": -float(best.fun), "success": bool(best.success),
                "message": str(best.message)}

    # ------------------------------------------------------------------ persistence
    def save(self, path: str | Path) -> None:
        """Write the model and its window to ``path`` (``.npz`` format, exactly that name);
        :meth:`load` restores it."""
        n = self._n
        arrays = {
            "window": self.window, "length_scales": self._length_scales, "ard": self._ard,
            "signal_variance": self._signal_variance, "noise_variance": self._noise_variance,
            "mean": self.mean, "refactor_every": self.refactor_every,
            "input_dim": -1 if self.input_dim is None else self.input_dim,
            "output_dim": -1 if self.output_dim is None else self.output_dim,
            "adds_since_refactor": self.adds_since_refactor, "samples_seen": self.samples_seen,
            "n": n, "X": self.window_inputs, "Y": self.window_targets,
            "R": np.zeros((0, 0)) if n == 0 else self._R[:n, :n].copy(),
            "has_alpha": self._alpha is not None,
        }
        if self._alpha is not None:
            arrays["alpha"] = self._alpha
            arrays["mu"] = self._mu
        write_npz(path, arrays)

    @classmethod
    def load(cls, path: str | Path) -> "SlidingWindowGP":
        """Read a model written by :meth:`save`; its predictions equal the saved model's.

        A missing, corrupt or foreign file (or one whose arrays do not fit together) raises one
        ``ValueError`` naming ``path``.
        """
        data = read_npz(path, "sliding-window GP")
        try:
            return cls._from_arrays(data)
        except (KeyError, IndexError, TypeError, ValueError) as error:
            raise ValueError(f"sliding-window GP file {str(path)!r} does not hold a model saved "
                             f"by SlidingWindowGP.save ({type(error).__name__}: {error})") from None

    @classmethod
    def _from_arrays(cls, data: dict[str, np.ndarray]) -> "SlidingWindowGP":
        """The model :meth:`save` wrote as ``data``, every array checked."""
        def integer(name: str, low: int) -> int:
            value = data[name]
            if value.shape != () or value.dtype.kind not in "iu" or int(value) < low:
                raise ValueError(f"{name} must be an integer >= {low}, got {value!r}")
            return int(value)

        def array(name: str, shape: tuple[int, ...]) -> np.ndarray:
            value = as_finite_array(name, data[name])
            if value.shape != shape:
                raise ValueError(f"{name} must have shape {shape}, got shape {value.shape}")
            return value

        scales = as_finite_array("length_scales", data["length_scales"])
        ard = data["ard"]
        if ard.shape != () or ard.dtype.kind != "b" or scales.ndim != 1 or scales.size == 0:
            raise ValueError(f"ard and length_scales are inconsistent: {ard!r}, {scales!r}")
        model = cls(window=integer("window", 1),
                    length_scales=scales.copy() if bool(ard) else float(scales[0]),
                    signal_variance=float(data["signal_variance"]),
                    noise_variance=float(data["noise_variance"]), mean=str(data["mean"]),
                    refactor_every=integer("refactor_every", 1))
        input_dim, output_dim = integer("input_dim", -1), integer("output_dim", -1)
        model.input_dim = None if input_dim < 0 else input_dim
        model.output_dim = None if output_dim < 0 else output_dim
        if model._ard and model.input_dim != scales.size:
            raise ValueError(f"input_dim {input_dim} does not match {scales.size} length scales")
        model.adds_since_refactor = integer("adds_since_refactor", 0)
        model.samples_seen = integer("samples_seen", 0)
        n = integer("n", 0)
        if n > model.window or n > model.samples_seen:
            raise ValueError(f"n = {n} exceeds the window ({model.window}) or the samples seen "
                             f"({model.samples_seen})")
        if model.input_dim is not None and model.output_dim is not None:
            model._allocate()
        elif n:
            raise ValueError(f"n = {n} samples but no input_dim/output_dim")
        if n:
            d, m = model.input_dim, model.output_dim
            model._X[:n] = array("X", (n, d))
            np.divide(model._X[:n], model._length_scales, out=model._Xs[:n])
            model._Y[:n] = array("Y", (n, m))
            model._R[:n, :n] = array("R", (n, n))
            model._n = n
            has_alpha = data["has_alpha"]
            if has_alpha.shape != () or has_alpha.dtype.kind != "b":
                raise ValueError(f"has_alpha must be a bool, got {has_alpha!r}")
            if bool(has_alpha):
                model._alpha = array("alpha", (n, m)).copy()
                model._mu = array("mu", (m,)).copy()
        return model

    # ------------------------------------------------------------------ internals
    def _allocate(self) -> None:
        N, d, m = self.window, self.input_dim, self.output_dim
        self._X = np.zeros((N, d))
        self._Xs = np.zeros((N, d))
        self._Y = np.zeros((N, m))
        self._R = np.eye(N)
        self._work = np.zeros(N)

    def _kernel(self, a_scaled: np.ndarray, b_scaled: np.ndarray) -> np.ndarray:
        squared = cdist(a_scaled, b_scaled, "sqeuclidean")
        np.multiply(squared, -0.5, out=squared)
        np.exp(squared, out=squared)
        squared *= self._signal_variance
        return squared

    def _append_factor(self) -> None:
        """Add the row of the sample stored at index ``n`` to the factor (O(n^2))."""
        n = self._n
        R = self._R
        diagonal = self._signal_variance + self._noise_variance
        if n == 0:
            R[0, 0] = math.sqrt(diagonal)
            self._n = 1
            return
        rhs = self._work
        rhs[:n] = self._kernel(self._Xs[n:n + 1], self._Xs[:n])[0]
        rhs[n:] = 0.0
        solved = dtrsv(R.T, rhs, lower=1, overwrite_x=1)      # L l = k (padding gives 0)
        row = solved[:n]
        d2 = diagonal - float(row @ row)
        if not (d2 > 0.0 and math.isfinite(d2)):
            # lost positive definiteness to rounding: rebuild from scratch
            self._n = n + 1
            self._refactor()
            return
        R[:n, n] = row
        R[n, :n] = 0.0
        R[n, n] = math.sqrt(d2)
        self._n = n + 1

    def _drop_oldest(self, update_factor: bool) -> None:
        """Remove sample 0 from the window (and, if asked, from the factor, O(n^2))."""
        n, N = self._n, self.window
        if update_factor:
            flat = self._R.reshape(-1)
            _rotate_out_first(flat, N, n, self._work)
            count = (N - 2) * N + (N - 1)
            if count > 0:
                flat[:count] = flat[N + 1:N + 1 + count]   # R[i, j] <- R[i + 1, j + 1]
            if N >= 2:
                self._R[N - 2, N - 1] = 0.0
            self._R[N - 1, N - 1] = 1.0                     # identity padding
        if n > 1:
            self._X[:n - 1] = self._X[1:n]
            self._Xs[:n - 1] = self._Xs[1:n]
            self._Y[:n - 1] = self._Y[1:n]
        self._n = n - 1

    def _refactor(self) -> None:
        """Recompute the factor of the current window from scratch."""
        n = self._n
        R = self._R
        R[...] = 0.0
        R.flat[:: self.window + 1] = 1.0
        if n:
            K = self._kernel(self._Xs[:n], self._Xs[:n])
            K.flat[:: n + 1] += self._noise_variance
            try:
                R[:n, :n] = scipy.linalg.cholesky(K, lower=False, check_finite=False)
            except np.linalg.LinAlgError as error:
                raise np.linalg.LinAlgError(
                    "the kernel matrix of the window is not numerically positive definite; "
                    f"increase noise_variance (now {self._noise_variance!r})") from error
        self.adds_since_refactor = 0
        self._alpha = None

    def _ensure_alpha(self) -> None:
        if self._alpha is not None:
            return
        n = self._n
        Y = self._Y[:n]
        mu = Y.mean(axis=0) if self.mean == "window_mean" else np.zeros(self.output_dim)
        rhs = np.zeros((self.window, self.output_dim), order="F")
        rhs[:n] = Y - mu
        rhs = dtrsm(1.0, self._R.T, rhs, lower=1, overwrite_b=1)              # L z = Y - mu
        rhs = dtrsm(1.0, self._R.T, rhs, lower=1, trans_a=1, overwrite_b=1)   # L^T a = z
        self._alpha = np.ascontiguousarray(rhs[:n])
        self._mu = mu

    def _check_sample_input(self, x: Any) -> np.ndarray:
        x = as_finite_array("x", x)
        if x.ndim > 1:
            raise ValueError(f"x must be a number or a 1-D array, got shape {x.shape}")
        x = x.reshape(-1)
        if x.size == 0:
            raise ValueError("x must hold at least one value, got an empty array")
        if self.input_dim is not None and x.size != self.input_dim:
            raise ValueError(f"x must have {self.input_dim} values, got {x.size}")
        return x

    def _check_batch(self, X: Any, Y: Any) -> tuple[np.ndarray, np.ndarray]:
        X = as_finite_array("X", X)
        Y = as_finite_array("Y", Y)
        if X.ndim == 1:
            X = X[:, None]
        if Y.ndim == 1:
            Y = Y[:, None]
        if X.ndim != 2 or Y.ndim != 2 or len(X) != len(Y):
            raise ValueError(f"X (n, d) and Y (n, m) must have matching rows, got shapes "
                             f"{X.shape} and {Y.shape}")
        if self.input_dim is not None and X.shape[1] != self.input_dim:
            raise ValueError(f"X must have {self.input_dim} columns, got {X.shape[1]}")
        if self.output_dim is not None and Y.shape[1] != self.output_dim:
            raise ValueError(f"Y must have {self.output_dim} columns, got {Y.shape[1]}")
        return X, Y


def _squared_differences(X: np.ndarray, per_dimension: bool) -> np.ndarray:
    """Pairwise squared differences, (d, n, n) per input dimension or (1, n, n) summed."""
    diffs = (X[:, None, :] - X[None, :, :]) ** 2
    diffs = np.moveaxis(diffs, 2, 0)
    return np.ascontiguousarray(diffs) if per_dimension else diffs.sum(axis=0)[None]


def _negative_lml(theta: np.ndarray, differences: np.ndarray, Yc: np.ndarray, *,
                  fit_noise: bool, noise_variance: float, gradient: bool
                  ) -> tuple[float, np.ndarray | None]:
    """Negative log marginal likelihood (summed over outputs) and its gradient.

    ``theta`` = log of [length scales (p), signal variance, noise variance]; ``differences``
    holds the (p, n, n) squared differences matching the length scales.
    """
    p = differences.shape[0]
    inv_sq = np.exp(-2.0 * theta[:p])
    signal = math.exp(theta[p])
    noise = math.exp(theta[p + 1]) if fit_noise else noise_variance
    n, m = Yc.shape
    scaled = np.tensordot(inv_sq, differences, axes=1)
    kf = signal * np.exp(-0.5 * scaled)
    K = kf.copy()
    K.flat[:: n + 1] += noise
    try:
        factor = scipy.linalg.cho_factor(K, lower=True, check_finite=False)
    except np.linalg.LinAlgError:
        return np.inf, (np.zeros_like(theta) if gradient else None)
    alpha = scipy.linalg.cho_solve(factor, Yc, check_finite=False)
    log_det = 2.0 * float(np.sum(np.log(np.diag(factor[0]))))
    lml = -0.5 * float(np.sum(Yc * alpha)) - 0.5 * m * log_det - 0.5 * m * n * math.log(2 * math.pi)
    if not gradient:
        return -lml, None
    K_inv = scipy.linalg.cho_solve(factor, np.eye(n), check_finite=False)
    W = alpha @ alpha.T - m * K_inv          # d lml / dtheta_j = 1/2 tr(W dK/dtheta_j)
    Wk = W * kf
    grad = np.empty_like(theta)
    for i in range(p):                       # dK/dlog l_i = kf * (x_i - x_i')^2 / l_i^2
        grad[i] = 0.5 * inv_sq[i] * float(np.sum(Wk * differences[i]))
    grad[p] = 0.5 * float(np.sum(Wk))        # dK/dlog s_f^2 = kf
    grad[p + 1] = 0.5 * noise * float(np.trace(W))
    return -lml, -grad
