"""Fit an arm's physical parameters to a log of commanded pressures and measured tip positions.

The residual is the simulated minus the logged tip position at every sample (mm, x, y and z of
each row, :func:`soft_gym.identify.replay.replay`); ``scipy.optimize.least_squares`` minimises
its robust ``soft_l1`` loss (quadratic up to ``F_SCALE_MM``, linear beyond, so a few outliers do
not pull the fit) over the parameters in log-scale, ``theta = ln(value / base)``, bounded to
``[ln LOWER_FACTOR, ln UPPER_FACTOR]``, with finite-difference derivatives. The fit sees the
first ``FIT_FRACTION`` of the log; the rest is held out and scored with the fitted arm.

Uncertainty: ``cov(theta) = s^2 (J^T J)^-1`` with ``J`` the residuals' Jacobian in log-scale at
the solution and ``s^2 = sum(r^2) / (m - n)`` the residual variance (``m`` residuals, ``n``
parameters). In log-scale a standard error is a relative one: ``SE(value) = value SE(theta)``.
A parameter is *unidentifiable* when its relative standard error exceeds
``UNIDENTIFIABLE_RELATIVE_SE`` (50 %) or ``J^T J`` is singular along it (the log does not move
the tip when it changes, or another parameter's change does the same).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import numpy as np
from scipy.optimize import least_squares

from soft_gym.engines import FAST_ENGINE
from soft_gym.identify.log import MIN_ROWS, ArmLog
from soft_gym.identify.parameters import (LOWER_FACTOR, UPPER_FACTOR, Parameter,
                                          default_parameters, with_values)
from soft_gym.identify.replay import replay
from soft_gym.robots.spec import ArmSpec

FIT_FRACTION = 0.75
"""Share of the log's samples (from its start) the fit sees; the rest is held out."""
UNIDENTIFIABLE_RELATIVE_SE = 0.5
"""Relative standard error above which a parameter is reported unidentifiable."""
F_SCALE_MM = 1.0
"""Residual (mm) where the ``soft_l1`` loss turns from quadratic to linear."""
DIFF_STEP = 1e-3
"""Finite-difference step in log-scale (0.1 % of each value): far above the simulation's
rounding, small against the parameters' spread."""
MAX_EVALUATIONS = 200
"""Most simulations one fit may run (the Jacobian's included)."""
_SINGULAR = 1e-10
"""Singular values of ``J`` below this share of the largest are taken for zero."""


@dataclass(frozen=True)
class FittedParameter:
    """One parameter's result.

    Attributes:
        name: ``field`` or ``field[segment]``.
        base: the base arm's value (SI units of the field).
        value: the fitted value (same units).
        standard_error: its standard error (same units; ``inf`` where ``J^T J`` is singular).
        identifiable: whether the relative standard error is at most
            :data:`UNIDENTIFIABLE_RELATIVE_SE`.
        at_bound: whether the fit stopped at a bound (the value may lie beyond it).
    """

    name: str
    base: float
    value: float
    standard_error: float
    identifiable: bool
    at_bound: bool

    @property
    def relative_standard_error(self) -> float:
        """``standard_error / value``."""
        return self.standard_error / self.value


@dataclass(frozen=True)
class FitResult:
    """What :func:`fit_arm` found.

    Attributes:
        spec: the fitted arm.
        parameters: each fitted parameter, in the order asked.
        fit_rms_mm: RMS tip distance (mm) between simulation and log over the fitted samples.
        held_out_rms_mm: the same over the held-out samples, with the fitted arm.
        base_rms_mm: the base arm's RMS tip distance over the whole log (mm).
        evaluations: simulations run by the optimiser.
        simulated_m: the fitted arm's tip positions over the whole log (m, (n, 3)).
        n_fit: samples the fit saw (the log's first ``n_fit``).
    """

    spec: ArmSpec
    parameters: tuple[FittedParameter, ...]
    fit_rms_mm: float
    held_out_rms_mm: float
    base_rms_mm: float
    evaluations: int
    simulated_m: np.ndarray
    n_fit: int


def rms_tip_error_mm(simulated_m: np.ndarray, measured_m: np.ndarray) -> float:
    """Root mean square of the tip distances (mm) between two (n, 3) position arrays (m)."""
    distances = np.linalg.norm(np.asarray(simulated_m) - np.asarray(measured_m), axis=1)
    return float(np.sqrt(np.mean(distances**2)) * 1e3)


def fit_split(n_samples: int, n_parameters: int) -> int:
    """How many of a log's ``n_samples`` the fit sees (the first :data:`FIT_FRACTION`).

    Raises:
        ValueError: a log too short to keep more samples than ``n_parameters`` (and at least
            :data:`soft_gym.identify.log.MIN_ROWS`) in the fit and ``MIN_ROWS`` held out.
    """
    n_fit = int(math.floor(FIT_FRACTION * n_samples))
    if n_fit < max(MIN_ROWS, n_parameters + 1) or n_samples - n_fit < MIN_ROWS:
        raise ValueError(f"log has {n_samples} samples: too few to fit {n_parameters} "
                         f"parameters on the first {FIT_FRACTION:.0%} and score the rest")
    return n_fit


def fit_arm(base: ArmSpec, log: ArmLog, parameters: list[Parameter] | None = None,
            engine: str = FAST_ENGINE,
            on_evaluation: Callable[[], None] | None = None) -> FitResult:
    """Fit ``parameters`` of the arm ``base`` to ``log`` (method in the module docstring).

    Args:
        base: the arm to start from; its values are the starting point and set the bounds.
        log: the checked log (:func:`soft_gym.identify.log.read_log`).
        parameters: what to fit (:func:`soft_gym.identify.parameters.parse_parameters`);
            ``None``: :func:`~soft_gym.identify.parameters.default_parameters`.
        engine: the engine simulating each candidate arm.
        on_evaluation: called after every simulation (a progress bar's update).

    Returns:
        the fitted arm, each parameter's value, standard error and identifiability, and the
        RMS tip errors of the fit, the held-out part and the base arm.

    Raises:
        ValueError: a log too short to keep :data:`soft_gym.identify.log.MIN_ROWS` samples on
            both sides of the split.
    """
    if parameters is None:
        parameters = default_parameters(base)
    n_fit = fit_split(log.n_samples, len(parameters))
    fit_log = log.head(n_fit)
    starts = np.array([parameter.value(base) for parameter in parameters])
    measured_mm = fit_log.tip_positions_m * 1e3
    evaluations = 0

    def residuals(theta: np.ndarray) -> np.ndarray:
        nonlocal evaluations
        spec = with_values(base, parameters, list(starts * np.exp(theta)))
        simulated = replay(spec, fit_log, engine)
        evaluations += 1
        if on_evaluation is not None:
            on_evaluation()
        return (simulated * 1e3 - measured_mm).ravel()

    low, high = math.log(LOWER_FACTOR), math.log(UPPER_FACTOR)
    solution = least_squares(residuals, np.zeros(len(parameters)), bounds=(low, high),
                             loss="soft_l1", f_scale=F_SCALE_MM, diff_step=DIFF_STEP,
                             x_scale=1.0, max_nfev=MAX_EVALUATIONS)
    theta = solution.x
    values = starts * np.exp(theta)
    jacobian = _raw_jacobian(residuals, theta, solution.fun, low, high)
    relative_se = _relative_standard_errors(jacobian, solution.fun, len(parameters))
    results = tuple(
        FittedParameter(name=parameter.name, base=float(start), value=float(value),
                        standard_error=float(value * se),
                        identifiable=bool(se <= UNIDENTIFIABLE_RELATIVE_SE),
                        at_bound=bool(min(t - low, high - t) < 1e-6))
        for parameter, start, value, se, t in zip(parameters, starts, values, relative_se, theta))
    fitted = with_values(base, parameters, list(values))
    simulated = replay(fitted, log, engine)
    base_simulated = replay(base, log, engine)
    return FitResult(
        spec=fitted, parameters=results,
        fit_rms_mm=rms_tip_error_mm(simulated[:n_fit], log.tip_positions_m[:n_fit]),
        held_out_rms_mm=rms_tip_error_mm(simulated[n_fit:], log.tip_positions_m[n_fit:]),
        base_rms_mm=rms_tip_error_mm(base_simulated, log.tip_positions_m),
        evaluations=evaluations, simulated_m=simulated, n_fit=n_fit)


def _raw_jacobian(residuals: Callable[[np.ndarray], np.ndarray], theta: np.ndarray,
                  at_theta: np.ndarray, low: float, high: float) -> np.ndarray:
    """Forward differences (backward at the upper bound) of the plain residuals at ``theta``
    (the optimiser's own ``jac`` is weighted by the robust loss)."""
    jacobian = np.empty((at_theta.size, theta.size))
    for column in range(theta.size):
        step = DIFF_STEP if theta[column] + DIFF_STEP <= high else -DIFF_STEP
        moved = theta.copy()
        moved[column] = np.clip(theta[column] + step, low, high)
        jacobian[:, column] = (residuals(moved) - at_theta) / (moved[column] - theta[column])
    return jacobian


def _relative_standard_errors(jacobian: np.ndarray, residuals: np.ndarray,
                              n_parameters: int) -> np.ndarray:
    """Standard errors in log-scale (relative ones) from ``s^2 (J^T J)^-1``; ``inf`` for a
    parameter with weight in ``J``'s null space."""
    jacobian = np.asarray(jacobian, dtype=float)
    m = residuals.size
    variance = float(np.sum(residuals**2)) / max(m - n_parameters, 1)
    _, singular, vt = np.linalg.svd(jacobian, full_matrices=False)
    kept = singular > _SINGULAR * max(float(singular[0]), np.finfo(float).tiny)
    covariance = (vt[kept].T / singular[kept]**2) @ vt[kept] * variance
    errors = np.sqrt(np.clip(np.diag(covariance), 0.0, None))
    if not kept.all():
        null = np.abs(vt[~kept]).max(axis=0) > 1e-3
        errors[null] = np.inf
    return errors
