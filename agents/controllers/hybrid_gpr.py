"""Hybrid controller of Wang et al. 2023 (wang2023, Section III-B): CC model + online GPR.

The CC model-based controller (:mod:`agents.controllers.cc_model`) is compensated by a Gaussian
process trained online on a sliding window (:class:`agents.learners.SlidingWindowGP`):

* after each step the pair ``x = [u(k-1), dz(k)]``, ``y = dp_e(k)`` is added, with ``u`` the
  actuation (pressures over p_max), ``dz`` the tip motion that step produced and
  ``dp_e = dp* - dp_r`` the difference between the displacement the CC model was asked for and
  the actual one (eq. (28)); queried with the *desired* motion, the GP predicts how much more
  must be asked for (a direct inverse model of the CC model's shortfall);
* once ``n_init`` samples are in (the paper's ``N_c``), the desired displacement is compensated
  before the CC model sees it, ``dp~* = dp* + dp_e_hat |dp*|`` (eq. (29));
* the window keeps the newest ``window`` samples (``N_r_max``); hyperparameters stay fixed online.

Eq. (29) multiplies the predicted error by ``|dp*|``, so the regression target here is the
*relative* error ``dp_e / |dz|`` (dimensionless), which makes eq. (29) consistent in units.
Inputs are scaled to comparable ranges: pressures over p_max, displacements in millimetres.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from agents.controllers.cc_model import (CCModelController, _build_from_file,
                                         read_json_object, read_settings)
from agents.learners.sliding_gp import SlidingWindowGP
from agents.policies.base import require_soft_arm_env
from soft_gym._validation import require_integer, require_number, require_positive

_MM = 1000.0


class HybridGPRController(CCModelController):
    """CC model + sliding-window GPR error compensator (wang2023 eqs. (25)-(29)).

    Args:
        env, kp, null_space_gain, probe_fraction, probe_steps, damping, controlled_axes,
            length_map: as for ``cc_model``.
        window: GP window ``N_r_max`` (samples).
        n_init: samples before compensation starts (``N_c``).
        length_scale: GP length scale in the scaled input units.
        signal_variance, noise_variance: GP kernel parameters (relative error units).
        min_displacement_m: steps whose tip moved less than this add no sample (the relative
            error is ill-defined there).
        learning_horizon: control steps over which motions are summed for one sample.
        max_effective_gain: cap on ``K_p (1 + e)``, the gain of eq. (26) once eq. (29) has scaled
            the command by ``1 + e``: the learned compensation may raise the loop gain only this
            far, which keeps the closed loop stable. The default (0.3) suits wang2023's arm; on an
            arm whose pneumatic lag is longer keep it within the largest ``K_p`` at which
            ``cc_model`` tracks (zhao2021: 0.12; docs/architecture.md, "Baselines").
        min_relative_error: floor of the predicted error along the desired motion (> -1): the
            compensation may shrink a command but never reverse it, however noisy the samples.
        max_turn_deg: largest angle by which the compensation may turn the command away from
            the desired motion.
    """

    name = "hybrid_gpr"

    def __init__(self, env, kp: float = 0.06, null_space_gain: float = 0.1,
                 probe_fraction: float = 0.3, probe_steps: int = 30, damping: float = 1e-4,
                 controlled_axes: tuple[int, ...] = (0, 1, 2), window: int = 300,
                 n_init: int = 20, length_scale: float = 1.0,
                 signal_variance: float = 1.0, noise_variance: float = 1e-2,
                 min_displacement_m: float = 1e-5, max_effective_gain: float = 0.3,
                 learning_horizon: int = 1, min_relative_error: float = -0.5,
                 max_turn_deg: float = 30.0, length_map: str | None = None) -> None:
        super().__init__(env, kp=kp, null_space_gain=null_space_gain,
                         probe_fraction=probe_fraction, probe_steps=probe_steps, damping=damping,
                         controlled_axes=controlled_axes, length_map=length_map)
        window = require_integer("window", window, 1)
        if isinstance(n_init, (bool, np.bool_)) or not isinstance(n_init, (int, np.integer)) \
                or not 1 <= n_init <= window:
            raise ValueError(f"n_init must be an integer in [1, window={window}], got {n_init!r}")
        self.n_init = int(n_init)
        self.min_displacement_m = require_positive("min_displacement_m", min_displacement_m)
        self.max_effective_gain = require_positive("max_effective_gain", max_effective_gain)
        if max_effective_gain <= kp:
            raise ValueError(f"max_effective_gain must exceed kp={kp}, got {max_effective_gain!r}")
        # eq. (29) scales the command by (1 + e): cap it so K_p (1 + e) <= max_effective_gain
        self.max_relative_error = max_effective_gain / kp - 1.0
        if not -1.0 < require_number("min_relative_error", min_relative_error) <= 0.0:
            raise ValueError(f"min_relative_error must be in (-1, 0], got {min_relative_error!r}")
        self.min_relative_error = float(min_relative_error)
        if not 0.0 <= require_number("max_turn_deg", max_turn_deg) < 90.0:
            raise ValueError(f"max_turn_deg must be in [0, 90), got {max_turn_deg!r}")
        self.max_turn_deg = float(max_turn_deg)
        self.learning_horizon = require_integer("learning_horizon", learning_horizon, 1)
        self._history: list[tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]] = []
        self.gp = SlidingWindowGP(window=window, length_scales=length_scale,
                                  signal_variance=signal_variance, noise_variance=noise_variance)
        self.samples = 0
        self._pending: tuple[np.ndarray, np.ndarray] | None = None

    @property
    def compensating(self) -> bool:
        return self.samples >= self.n_init

    def reset(self) -> None:
        super().reset()
        self._pending = None  # the GP's window persists: it is the robot's learned model
        self._history = []

    def compensate(self, position: np.ndarray, desired: np.ndarray) -> np.ndarray:
        """``dp~* = dp* + dp_e_hat |dp*|`` (eq. (29)) once ``n_init`` samples are in."""
        actuation = self.model_pressures(self.lengths) / self.p_high
        features = np.r_[actuation, desired * _MM]
        command = desired
        size = float(np.linalg.norm(desired))
        if self.compensating and size > 0.0:
            command = desired + self.bounded_error(self.gp.predict(features), desired / size) * size
        self._pending = (features, desired, command)
        return command

    def bounded_error(self, relative: np.ndarray, direction: np.ndarray) -> np.ndarray:
        """The predicted relative error, bounded so that eq. (29) neither reverses the command
        nor turns it by more than ``max_turn_deg``: its component along the desired direction is
        clipped to ``[min_relative_error, max_relative_error]``, the rest to
        ``tan(max_turn_deg) (1 + along)``."""
        along = float(np.clip(relative @ direction, self.min_relative_error,
                              self.max_relative_error))
        across = relative - (relative @ direction) * direction
        limit = np.tan(np.radians(self.max_turn_deg)) * (1.0 + along)
        norm = float(np.linalg.norm(across))
        if norm > limit:
            across = across * (limit / norm)
        return along * direction + across

    def update(self, observation, action, reward, next_observation, info) -> None:
        """Add a sample (eq. (28)): ``x = [u(k-1), dz(k)]`` with ``dz`` the desired motion and
        ``y = (dp_cmd - dp_r) / |dz|``, ``dp_cmd`` the displacement the CC model was asked for
        (after compensation) and ``dp_r`` the motion achieved; at the fixed point the
        compensated command makes the achieved motion equal the desired one (eq. (29)).

        With ``learning_horizon = h > 1`` the commands, desired and achieved motions are summed
        over ``h`` steps before the ratio is taken, so that the achieved motion outgrows the
        feedback's noise (one control step moves the tip a fraction of a millimetre).

        Malformed observations are refused (``ValueError``) before the window is touched."""
        observation = self.check_observation(observation)
        next_observation = self.check_observation(next_observation, "next_observation")
        if self._pending is None:
            return
        features, desired, command = self._pending
        self._pending = None
        self._history.append((features, desired, command, self._pose(observation)))
        if len(self._history) < self.learning_horizon:
            return
        oldest = self._history.pop(0)
        desired_sum = oldest[1] + sum(entry[1] for entry in self._history)
        command_sum = oldest[2] + sum(entry[2] for entry in self._history)
        size = np.linalg.norm(desired_sum)
        if size < self.min_displacement_m * self.learning_horizon:
            return
        achieved = self._pose(next_observation) - oldest[3]
        self.gp.add(oldest[0], (command_sum - achieved) / size)
        self.samples += 1

    def save(self, path: str | Path) -> None:
        """Write the controller to the directory ``path`` (settings, alpha and the GP window)."""
        directory = Path(path)
        directory.mkdir(parents=True, exist_ok=True)
        super().save(directory / "cc_model.json")
        self.gp.save(directory / "gp.npz")
        (directory / "hybrid.json").write_text(json.dumps({
            "n_init": self.n_init, "min_displacement_m": self.min_displacement_m,
            "max_effective_gain": self.max_effective_gain,
            "learning_horizon": self.learning_horizon,
            "min_relative_error": self.min_relative_error, "max_turn_deg": self.max_turn_deg,
            "samples": self.samples}, indent=2))

    @classmethod
    def load(cls, path: str | Path, env=None) -> "HybridGPRController":
        """Read a controller written by :meth:`save` (a directory) for ``env``; a missing
        directory or file, or a corrupt or foreign one, is refused with one ``ValueError``
        naming it and what is wrong."""
        require_soft_arm_env(env, cls.name)
        directory = Path(path)
        if not directory.is_dir():
            raise ValueError(f"{cls.name} controller directory {str(directory)!r} "
                             f"{'is a file, not' if directory.exists() else 'does not exist:'} "
                             "a directory written by save() (cc_model.json, hybrid.json, gp.npz)")
        base = read_settings(directory / "cc_model.json", cls.name)
        alpha, modal_map = base.pop("alpha"), base.pop("modal_map", None)
        extra = read_json_object(directory / "hybrid.json", cls.name)
        samples = extra.pop("samples", None)
        if isinstance(samples, bool) or not isinstance(samples, int) or samples < 0:
            raise ValueError(f"{cls.name} controller file {str(directory / 'hybrid.json')!r}: "
                             f"samples must be an integer >= 0, got {samples!r}")
        gp = SlidingWindowGP.load(directory / "gp.npz")
        controller = _build_from_file(directory, cls.name,
                                      lambda: cls(env, window=gp.window, **base, **extra))
        controller.gp = gp
        controller.samples = samples
        controller.restore_calibration(directory / "cc_model.json", alpha, modal_map)
        return controller
