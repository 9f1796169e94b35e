"""zhao2021's locally learned controller: the local inverse-kinematics network with a step
distance that is fixed or adapted by ASDM (Zhao et al. 2021, Section IV, eqs. 13-18).

One controller step ``n`` (Section IV-A):

* the tip ``Q_n`` comes from the env's feedback pose (the paper feeds back its shape
  reconstruction's tip, ``feedback="strain_sr"``; any source works);
* if ``||Q_d - Q_n|| <= E`` (``tolerance_mm``, paper 4 mm) the arm holds its actuation;
* else the temporary goal is ``Q_dn = Q_n + d_n (Q_d - Q_n) / ||Q_d - Q_n||`` (eq. 16) and the
  next actuation ``A_{n+1} = g(A_n, Q_n, Q_dn, S_n)`` (eq. 15,
  :class:`~agents.learners.local_ik.LocalIKNetwork`);
* with ``adaptive=True`` (ASDM) the step distance follows the error of the last step,
  ``e_n = ||Q_d(n-1) - Q_n||`` (eq. 17):
  ``d_n = d_{n-1} + sgn((Q_n - Q_{n-1}) . (Q_d(n-1) - Q_{n-1})) K e_n`` (eq. 18), kept in
  [2, 15] mm; with ``adaptive=False`` ``d_n = step_mm`` throughout.

The paper waits 1 s after each command before it measures (Section VI-A), so one controller step
is one command held for ``settle_s`` (1 s, 20 env steps at the usual 0.05 s control period):
:meth:`predict` returns the held command between decisions.

The network is trained on the same random exploration as the shape reconstruction
(:func:`soft_gym.papers.zhao2021.exploration.cached_reconstruction`, on a private copy of the arm
with the env's gauge model; cached on disk), from pairs of consecutive samples with the ground
truth tip of the exploration (the paper's RGB-D camera). With ``dataset=`` (the id of
``python -m eval datasets``'s ``soft-arm/zhao2021/exploration-v0``, ``dataset_root=`` its root)
the exploration is read from that dataset instead: it must have been collected with this arm, the
env's gauge model and the ``exploration`` sizes and seed (a ``ValueError`` names the setting that
differs), so the network is the one the collection gives.

Needs ``pose``, ``target``, ``strain`` and ``pressure`` in the env's observation (``pressure``
gives ``A_0`` where an episode starts from held pressures, e.g. ``start_m=``). Works on any preset
(the strain gauges exist on every arm); the actuation becomes actions through the env's own
:class:`~soft_gym.robots.actuation.Actuation`, in either action mode.
"""

from __future__ import annotations

import functools
import hashlib
import json
import os
from pathlib import Path
from typing import Any

import numpy as np

import agents.learners.local_ik
from agents.controllers.saturation import SaturationWatch
from agents.learners.local_ik import LocalIKNetwork
from agents.policies.base import BaselinePolicy, PolicyRefusal, require_soft_arm_env
from soft_gym.datasets.training import check_dataset_options
from soft_gym._model_files import read_model_state, write_model_state
from soft_gym._validation import (require_in_range, require_integer, require_learning_rate,
                                  require_positive, require_seed)
from soft_gym.robots.actuation import Actuation
from soft_gym.sensing.calibration_cache import cached, sensor_description
from soft_gym.papers.zhao2021.shape_exploration import GAUGE_SETTINGS
from soft_gym.papers.zhao2021.exploration import exploration_digest, exploration_of
from soft_gym.papers.zhao2021.shape_reconstruction import ReconstructionConfig
from soft_gym.sensors.strain_gauge import StrainGauges

_MM = 1000.0
_FORMAT = "soft-arm-gym local-ik-asdm 1"
MIN_STEP_MM, MAX_STEP_MM = 2.0, 15.0
"""ASDM's limits on the step distance (zhao2021 Section IV-B: 2 mm <= d_n <= 15 mm)."""

_REQUIRED_PARTS = ("pose", "target", "strain", "pressure")
_SETTINGS = ("step_mm", "adaptive", "gain", "tolerance_mm", "settle_s", "max_iterations",
             "batch_size", "learning_rate", "skip", "exploration", "seed", "cache")


@functools.lru_cache(maxsize=1)
def _learner_source_digest() -> str:
    return hashlib.sha256(Path(agents.learners.local_ik.__file__).read_bytes()).hexdigest()


class LocalIKASDMController(BaselinePolicy):
    """zhao2021's local-IK controller with fixed or adaptive step distance.

    Args:
        env: the env to control (see the module docstring for the obs parts it needs).
        step_mm: the step distance ``d`` (mm, in [2, 15]); with ``adaptive`` its start ``d_1``.
        adaptive: adapt ``d`` by ASDM (eqs. 17-18).
        gain: ASDM's ``K`` (paper: 0.12).
        tolerance_mm: ``E``, the distance at which the arm stops (mm; paper: 4).
        settle_s: seconds one command is held (a controller step; paper: 1 s).
        max_iterations, batch_size, learning_rate: the network's training (eq. 20; paper: at
            most 1000 iterations, Adam at 0.001).
        skip: the network adds ``A_n`` to its output layer (:class:`LocalIKNetwork`).
        exploration: options of the exploration data set
            (:class:`~soft_gym.papers.zhao2021.shape_reconstruction.ReconstructionConfig`, e.g.
            ``{"n_free": 400, "n_loaded": 200}`` for a quick model); default the paper's 6000.
        seed: seeds the network's training.
        cache: keep the trained network on disk and reuse it.
        progress: show tqdm bars while the first build explores and trains (about 9 minutes
            for the paper's exploration on zhao2021 on 2 busy cores, seconds with a quick
            ``exploration``; nothing when the network comes from the cache). Not saved.
        dataset: id of a dataset of zhao2021's exploration (``python -m eval datasets``) to
            train on instead of exploring (see the module docstring); ``None`` explores. Not
            saved.
        dataset_root: the datasets root of ``dataset`` (Minari's when ``None``).
    """

    name = "local_ik_asdm"

    def __init__(self, env, step_mm: float = 8.0, adaptive: bool = True, gain: float = 0.12,
                 tolerance_mm: float = 4.0, settle_s: float = 1.0, max_iterations: int = 1000,
                 batch_size: int = 64, learning_rate: float = 1e-2, skip: bool = True,
                 exploration: dict | None = None, seed: int = 0, cache: bool = True,
                 progress: bool = True, dataset: str | None = None,
                 dataset_root: str | os.PathLike | None = None) -> None:
        unwrapped = require_soft_arm_env(env, self.name)
        self.step_mm = require_in_range("step_mm", step_mm, MIN_STEP_MM, MAX_STEP_MM)
        for name, value in (("adaptive", adaptive), ("skip", skip), ("cache", cache),
                            ("progress", progress)):
            if not isinstance(value, (bool, np.bool_)):
                raise ValueError(f"{name} must be True or False, got {value!r}")
        self.adaptive, self.skip, self.cache = bool(adaptive), bool(skip), bool(cache)
        self.progress = bool(progress)
        self.gain = require_positive("gain", gain)
        self.tolerance_mm = require_positive("tolerance_mm", tolerance_mm)
        self.settle_s = require_positive("settle_s", settle_s)
        self.max_iterations = require_integer("max_iterations", max_iterations, 1)
        self.batch_size = require_integer("batch_size", batch_size, 1)
        self.learning_rate = require_learning_rate("learning_rate", learning_rate)
        self.seed = require_seed("seed", seed)
        if exploration is not None and not isinstance(exploration, dict):
            raise ValueError(f"exploration must be None or a dict of options, got "
                             f"{exploration!r}")
        self.exploration = dict(exploration or {})
        self._config = ReconstructionConfig.from_options(self.exploration)
        self.dataset, self.dataset_root = check_dataset_options(dataset, dataset_root)
        self.env = unwrapped
        missing = [part for part in _REQUIRED_PARTS if part not in self.env.obs_parts]
        if missing:
            raise PolicyRefusal(f"the env's obs must include {list(_REQUIRED_PARTS)} for "
                                f"{self.name}; missing {missing} in {self.env.obs_parts!r}")
        spec = self.env.arm
        self.actuation = Actuation.of_env(self.env)
        self.p_low, self.p_high = spec.p_pre_pa, spec.p_max_pa
        self.hold_steps = max(1, int(round(self.settle_s / spec.control_period_s)))
        self.network: LocalIKNetwork | None = None
        self.training: dict[str, Any] = {}
        # three decisions (3 s at the paper's settle time) with every chamber beyond its range
        self.saturation = SaturationWatch(self.name, self.p_low, self.p_high, steps=3)
        self.reset()

    # ------------------------------------------------------------------ episode
    def reset(self) -> None:
        """Start of an episode: ``d`` back to ``step_mm``, no step taken yet."""
        self._step = 0
        self._command: np.ndarray | None = None      # A_n: the actuation decided (Pa)
        self._env_command: np.ndarray | None = None  # what the env holds (delta mode ramps)
        self._previous: tuple[np.ndarray, np.ndarray] | None = None  # (Q_{n-1}, Q_d(n-1))
        self.step_distance_mm = self.step_mm
        self.history: list[dict[str, Any]] = []
        self.saturation.reset()

    def predict(self, observation, state=None, episode_start=None, deterministic: bool = True):
        """The action for ``observation``: a new command every ``settle_s``, else the held one
        (a malformed observation is refused before anything, training included)."""
        observation = self.check_observation(observation)
        if self.network is None:
            self.pretrain()
        env = self.env
        if self._command is None:  # A_0: the pressures the episode starts from
            self._command = np.asarray(env.observation_part(observation, "pressure"),
                                       dtype=float) * self.p_high
            self._env_command = self._command.copy()
        if self._step % self.hold_steps == 0:
            position = np.asarray(env.observation_part(observation, "pose"), dtype=float)[:3]
            goal = np.asarray(env.observation_part(observation, "target"), dtype=float)[:3]
            readings = np.asarray(env.observation_part(observation, "strain"), dtype=float)
            self._command = self.decide(self._command, position, goal, readings)
        self._step += 1
        action = self.actuation.action(self._command, self._env_command)
        self._env_command = self.actuation.pressure(action, self._env_command)
        return action, state

    def decide(self, pressures_pa: np.ndarray, position_m: np.ndarray, goal_m: np.ndarray,
               readings: np.ndarray) -> np.ndarray:
        """One controller step (eqs. 15-18): the next actuation ``A_{n+1}`` (Pa) from ``A_n``
        (Pa), ``Q_n`` and ``Q_d`` (m) and ``S_n``; recorded in :attr:`history`."""
        q = np.asarray(position_m, dtype=float) * _MM
        goal = np.asarray(goal_m, dtype=float) * _MM
        if not (np.all(np.isfinite(q)) and np.all(np.isfinite(goal))):
            raise ValueError(f"position_m and goal_m must be finite, got {position_m!r}, "
                             f"{goal_m!r}")
        error_mm = 0.0
        if self._previous is not None:
            q_previous, planned = self._previous
            error_mm = float(np.linalg.norm(planned - q))                          # eq. (17)
            if self.adaptive:
                direction = np.sign(np.dot(q - q_previous, planned - q_previous))
                self.step_distance_mm = float(np.clip(                              # eq. (18)
                    self.step_distance_mm + direction * self.gain * error_mm,
                    MIN_STEP_MM, MAX_STEP_MM))
        distance = float(np.linalg.norm(goal - q))
        record = {"position_mm": q, "goal_mm": goal, "distance_mm": distance,
                  "step_mm": self.step_distance_mm, "error_mm": error_mm,
                  "reached": distance <= self.tolerance_mm}
        if record["reached"]:
            planned, command = q, np.asarray(pressures_pa, dtype=float)
        else:
            planned = q + self.step_distance_mm * (goal - q) / distance            # eq. (16)
            command = self.network.predict(pressures_pa, q / _MM, planned / _MM, readings)
            self.saturation.observe(command, goal / _MM)
            command = np.clip(command, self.p_low, self.p_high)  # the regulators' range
        record.update(planned_mm=planned, pressures_pa=command)
        self.history.append(record)
        self._previous = (q, planned)
        return command

    # ------------------------------------------------------------------ training
    def pretrain(self) -> dict[str, Any]:
        """Train the network on the exploration data (or take it from the cache); returns the
        training report."""
        spec = self.env.arm
        gauges = self._gauges()
        recorded = None if self.dataset is None else exploration_of(
            spec, gauges, self._config, self.cache, self.progress, self.dataset,
            self.dataset_root)

        def compute() -> dict[str, Any]:
            data = recorded if recorded is not None else exploration_of(
                spec, gauges, self._config, self.cache, progress=self.progress)
            network = LocalIKNetwork(spec.n_chambers, data.readings.shape[1], spec.p_max_pa,
                                     skip=self.skip, seed=self.seed)
            training = network.fit(data.pressures_pa, data.key_points_m[:, -1], data.readings,
                                   max_iterations=self.max_iterations,
                                   batch_size=self.batch_size,
                                   learning_rate=self.learning_rate,
                                   progress=self.progress)
            return {"network": network.state(), "training": training}

        parts = {"kind": f"{self.name} network", "arm": repr(spec),
                 "gauges": sensor_description(gauges, GAUGE_SETTINGS),
                 "exploration": {k: getattr(self._config, k)
                                 for k in ("n_free", "n_loaded", "load_kg", "seed")},
                 "settings": {k: getattr(self, k) for k in ("max_iterations", "batch_size",
                                                             "learning_rate", "skip", "seed")},
                 "learner": _learner_source_digest()}
        if recorded is not None:  # keyed on the data read; without a dataset the key is as was
            parts["exploration data"] = exploration_digest(recorded)
        self.network, self.training = cached(
            parts, compute, use_cache=self.cache,
            use=lambda result: (LocalIKNetwork.from_state(result["network"]), result["training"]))
        return self.training

    def _gauges(self):
        sensors = getattr(self.env, "sensors", {})
        return sensors.get("strain", StrainGauges())

    # ------------------------------------------------------------------ persistence
    def save(self, path: str | Path) -> None:
        """Write the settings and the network (a digest-checked model file); :meth:`load`
        restores a controller that predicts identically."""
        if self.network is None:
            raise ValueError(f"{self.name} has no network to save yet: call pretrain() first")
        settings = {k: getattr(self, k) for k in _SETTINGS}
        write_model_state(path, _FORMAT, {"settings": json.dumps(settings),
                                          "training": json.dumps(self.training),
                                          "network": self.network.state()})

    @classmethod
    def load(cls, path: str | Path, env=None) -> "LocalIKASDMController":
        """Read a controller written by :meth:`save` for ``env``; a corrupt or foreign file is
        refused with a ``ValueError`` naming the path."""
        require_soft_arm_env(env, cls.name)
        settings, training, network = read_model_state(
            path, _FORMAT, f"{cls.name} controller",
            lambda state: (_json_object("settings", state["settings"]),
                           _json_object("training", state["training"]),
                           LocalIKNetwork.from_state(state["network"])))
        try:
            controller = cls(env, **settings)
        except (TypeError, ValueError) as error:
            raise ValueError(f"{cls.name} controller file {str(path)!r} holds invalid settings "
                             f"({type(error).__name__}: {error})") from None
        if network.n_chambers != controller.env.arm.n_chambers:
            raise ValueError(f"path {str(path)!r} holds a {cls.name} controller for another arm "
                             f"({network.n_chambers} chambers, this env has "
                             f"{controller.env.arm.n_chambers})")
        controller.network, controller.training = network, training
        return controller


def _json_object(name: str, text: Any) -> dict:
    """The JSON object ``text`` (a saved file's ``name`` entry); ``ValueError`` otherwise."""
    value = json.loads(str(text))
    if not isinstance(value, dict):
        raise ValueError(f"{name} must be a JSON object, got {type(value).__name__}")
    return value
