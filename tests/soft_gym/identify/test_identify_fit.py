"""soft_gym/identify/fit.py: parameters hidden from the fit recovered from a simulated log with
sensor noise, their uncertainty, and the identifiability rule."""

from __future__ import annotations

import numpy as np
import pytest

from soft_gym.identify.fit import _relative_standard_errors, fit_arm, rms_tip_error_mm
from soft_gym.identify.parameters import parse_parameters, with_values
from soft_gym.identify.synthetic import random_commands, simulated_log
from soft_gym.robots.presets import get_preset

BASE = get_preset("wang2023")


def _log_of(true_arm, duration_s: float = 15.0, seed: int = 0):
    rng = np.random.default_rng(seed)
    times, commands = random_commands(BASE, duration_s, 0.5, rng)
    return simulated_log(true_arm, times, commands, 0.5e-3, rng)


def test_two_hidden_parameters_are_recovered_within_5_percent():
    """E +20 % and the pneumatic time constant -15 %, 15 s of random pressures held 0.5 s,
    0.5 mm noise on x, y, z: both found within 5 % from the base values, held-out RMS < 1 mm
    (the noise alone gives sqrt(3) 0.5 = 0.87 mm)."""
    parameters = parse_parameters(["youngs_modulus_pa", "pneumatic_time_constant_s"], BASE)
    truth = [1.2 * BASE.segments[0].youngs_modulus_pa, 0.85 * BASE.pneumatic_time_constant_s]
    log = _log_of(with_values(BASE, parameters, truth))
    result = fit_arm(BASE, log, parameters)
    for fitted, true in zip(result.parameters, truth):
        assert fitted.value == pytest.approx(true, rel=0.05), fitted
        assert fitted.identifiable and not fitted.at_bound
        assert 0 < fitted.relative_standard_error < 0.05
    assert result.held_out_rms_mm < 1.0
    assert result.fit_rms_mm < 1.0 < result.base_rms_mm
    assert result.spec.segments[0].youngs_modulus_pa == result.parameters[0].value
    assert result.simulated_m.shape == log.tip_positions_m.shape
    assert result.n_fit == int(0.75 * log.n_samples)


def test_a_parameter_the_log_does_not_move_is_unidentifiable():
    """The damping of a log that never moves the arm (every command 0) cannot be seen."""
    parameters = parse_parameters(["damping_ratio"], BASE)
    rng = np.random.default_rng(1)
    times = np.arange(40) * BASE.control_period_s
    log = simulated_log(BASE, times, np.zeros((40, 3)), 0.5e-3, rng)
    result = fit_arm(BASE, log, parameters)
    assert not result.parameters[0].identifiable


def test_the_standard_errors_follow_the_jacobian_and_a_null_direction_is_infinite():
    jacobian = np.array([[1.0, 0.0], [0.0, 2.0], [0.0, 0.0], [0.0, 0.0]])
    residuals = np.array([1.0, -1.0, 1.0, -1.0])  # s^2 = 4 / (4 - 2) = 2
    np.testing.assert_allclose(_relative_standard_errors(jacobian, residuals, 2),
                               [np.sqrt(2.0), np.sqrt(2.0) / 2.0])
    jacobian[:, 1] = 0.0
    errors = _relative_standard_errors(jacobian, residuals, 2)
    assert errors[0] == pytest.approx(np.sqrt(2.0)) and errors[1] == np.inf


def test_rms_tip_error_is_the_rms_distance_in_mm():
    assert rms_tip_error_mm(np.array([[0.003, 0.004, 0.0], [0.0, 0.0, 0.0]]),
                            np.zeros((2, 3))) == pytest.approx(np.sqrt(12.5))


def test_a_log_too_short_to_split_is_refused():
    rng = np.random.default_rng(2)
    log = simulated_log(BASE, np.arange(5) * 0.05, np.zeros((5, 3)), 0.0, rng)
    with pytest.raises(ValueError, match="5 samples: too few to fit 1 parameters"):
        fit_arm(BASE, log, parse_parameters(["damping_ratio"], BASE))


@pytest.mark.slow
def test_four_hidden_parameters_are_recovered_from_30_s():
    parameters = parse_parameters(["youngs_modulus_pa", "pneumatic_time_constant_s",
                                   "damping_ratio", "extra_tip_mass_kg"], BASE)
    truth = [p.value(BASE) * f for p, f in zip(parameters, (1.2, 0.85, 1.25, 0.8))]
    result = fit_arm(BASE, _log_of(with_values(BASE, parameters, truth), 30.0), parameters)
    for fitted, true in zip(result.parameters, truth):
        assert fitted.value == pytest.approx(true, rel=0.05), fitted
        assert fitted.identifiable
    assert result.held_out_rms_mm < 1.0
