"""Logs simulated from a known arm: random piecewise-constant pressures, tip positions with
sensor noise. What a fit can recover is checked on them before an experiment is logged."""

from __future__ import annotations

import numpy as np

from soft_gym.engines import FAST_ENGINE
from soft_gym.identify.log import ArmLog, check_log
from soft_gym.identify.replay import replay
from soft_gym.robots.spec import ArmSpec


def random_commands(spec: ArmSpec, duration_s: float, hold_s: float, rng: np.random.Generator,
                    sample_period_s: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Sample times and piecewise-constant random pressure commands.

    Args:
        spec: the arm (its chamber count and ``p_max_pa``).
        duration_s: the log's length (s), > 0.
        hold_s: how long each random command is held (s), > 0.
        rng: the random generator.
        sample_period_s: time between samples (s); ``None``: ``spec.control_period_s``.

    Returns:
        times (s, (n,)) and commands (Pa, (n, n_chambers)), each uniform in ``[0, p_max_pa]``.

    Raises:
        ValueError: a duration, hold or sample period that is not positive, or a log of fewer
            than three samples.
    """
    period = spec.control_period_s if sample_period_s is None else sample_period_s
    for name, value in (("duration_s", duration_s), ("hold_s", hold_s),
                        ("sample_period_s", period)):
        if not (np.isfinite(value) and value > 0):
            raise ValueError(f"{name} must be a positive number of seconds, got {value!r}")
    times = np.arange(int(round(duration_s / period)) + 1) * period
    if times.size < 3:
        raise ValueError(f"duration_s={duration_s!r} holds fewer than 3 samples of "
                         f"{period!r} s")
    n_holds = int(np.floor(times[-1] / hold_s)) + 1
    levels = rng.uniform(0.0, 1.0, size=(n_holds, spec.n_chambers)) * spec.p_max_pa
    commands = levels[np.minimum((times / hold_s).astype(int), n_holds - 1)]
    return times, commands


def simulated_log(spec: ArmSpec, times_s: np.ndarray, commands_pa: np.ndarray,
                  noise_std_m: float, rng: np.random.Generator,
                  engine: str = FAST_ENGINE) -> ArmLog:
    """The log ``spec`` would give under ``commands_pa``, with Gaussian noise on every
    coordinate of the tip position.

    Args:
        spec: the arm that "records" the log.
        times_s: sample times (s, (n,)).
        commands_pa: commands (Pa, (n, n_chambers)).
        noise_std_m: standard deviation of the noise on x, y and z (m), >= 0.
        rng: the random generator of the noise.
        engine: the engine simulating it.

    Raises:
        ValueError: a negative noise, or arrays :func:`~soft_gym.identify.log.check_log` refuses.
    """
    if not (np.isfinite(noise_std_m) and noise_std_m >= 0):
        raise ValueError(f"noise_std_m must be a number >= 0 (m), got {noise_std_m!r}")
    clean = check_log(times_s, commands_pa, np.zeros((len(times_s), 3)), None, spec)
    tips = replay(spec, clean, engine)
    noisy = tips + rng.normal(0.0, noise_std_m, size=tips.shape)
    return check_log(clean.times_s, clean.commands_pa, noisy, None, spec)
