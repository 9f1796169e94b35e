"""Localised online learning control of Ho et al. 2018 (ho2018): LWPR forward models, a
reward-weighted-regression inverse with a null-space attractor, and a P controller.

The method (ho2018 Sections 2.2-3.3, eqs. (1)-(14), Algorithm 1):

* **State and action.** ``p_k`` is the tip position from the env's feedback pose (the paper's EM
  coil; ``feedback="em"``), in mm; ``u_k`` the chamber commands as fractions of each chamber's
  range ``(p - p_pre) / (p_max - p_pre)`` (the paper's stepper positions, a proxy for volume).
* **Forward transition model** ``dp_k = f(p_k, u_k, du_k)`` (eqs. (1), (3)): an
  :class:`~agents.learners.lwpr.LWPR` per output coordinate on the input ``[p, u, du]``; its
  receptive fields decide how many local models there are and where (eq. (6) weighs them on
  ``[p, u]``).
* **Inverse** ``du = phi(dp_ref, p, u)`` (eqs. (2), (4)-(13)):
  :class:`~agents.learners.rwr_inverse.RewardWeightedInverse`, one local linear inverse per
  receptive field, fitted by reward-weighted regression whose reward favours the attractor
  ``du_0 = K_a (u_0 - u)`` towards a rest configuration (eq. (8)), which resolves the
  redundancy of the six chambers for the three task coordinates.
* **Controller** (eq. (14), resolved motion rate control): ``dp_ref = K_P (p_ref - p_k)``,
  limited to ``max_step_mm``; ``u_{k+1} = u_k + phi(dp_ref, p_k, u_k)``, kept within the
  chambers' range.
* **Online learning** (``online=True``, Fig. 6): every decision adds the transition it observed,
  ``(p_k, u_k, du_k) -> dp_k = p_{k+1} - p_k``, to the forward model and to the inverse's data
  window (first in, first out; the paper keeps 425 and 550 samples), and refits the local
  inverses it activates. ``online=False`` keeps the pre-trained model.

**Decisions.** The paper's loop ran at 7-23 Hz on the equilibria of volume-driven chambers;
here one decision spans ``hold_steps`` control steps (default 2, i.e. 10 Hz at the usual 20 Hz
env), so the measured ``dp`` covers the chambers' lag.

**Pre-training** (ho2018 Section 3.2): on a private copy of the env *without* its scenario loads
(the paper pre-trains the unloaded arm), random waypoints in actuator space are joined by
straight lines of ``leg_decisions`` decisions each (80 waypoints, or 320 for the varying-load
experiment); the transitions are split 80/20 into training and test sets; the forward LWPR is
trained epoch by epoch and the epoch with the lowest test RMSE is kept (Fig. 4; at most
``max_epochs``); the inverse is fitted on all pre-training transitions. The pre-trained model is
kept in the user's cache directory (``SOFT_GYM_CACHE=off`` disables it), keyed on everything
that changes it; a cached file that does not load is rebuilt with a warning, never used.
With ``dataset=`` (the id of ``python -m eval datasets``'s ``soft-arm/ho2018/pretraining-v0``,
``dataset_root=`` its root) the walk's observations are read from that recording instead of
driving the copy; the dataset must have been walked with this controller's arm, env settings,
``seed``, ``pretrain_waypoints``, ``leg_decisions``, ``hold_steps``, ``waypoint_range`` and
``rest_actuation`` (:meth:`LWPRRWRController.walk_key`; a ``ValueError`` names the one that
differs), so the transitions and the model equal those of the walk.

Works on any preset: two segments (ho2018, zhao2021) are redundant for the 3-D tip, one segment
(wang2023, zou2022) is not and the attractor then only biases the solution. Needs ``pose`` and
``target`` in the observation; any action mode (pressures become actions through the env's own
:class:`~soft_gym.robots.actuation.Actuation`).
"""

from __future__ import annotations

import copy
import functools
import hashlib
import io
import json
import os
from collections.abc import Callable
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
from tqdm.auto import tqdm

import agents.learners.lwpr
import agents.learners.rwr_inverse
from agents.learners.lwpr import LWPR
from agents.controllers.saturation import SaturationWatch
from agents.learners.rwr_inverse import RewardWeightedInverse
from agents.policies.base import BaselinePolicy, PolicyRefusal, require_soft_arm_env
from soft_gym.datasets.training import check_dataset_options
from soft_gym._model_files import read_npz, write_npz
from soft_gym._validation import (as_finite_array, require_in_range, require_integer,
                                  require_non_negative, require_positive, require_seed)
from soft_gym.robots.actuation import Actuation
from soft_gym.sensing.calibration_cache import cached

_MM = 1000.0
MIN_RIDGE, MAX_RIDGE = 1e-3, 1e6
"""The range of ``ridge`` (weighted samples): below it a field's normal equations go singular
online (1e-30 failed at step 12), above it no field learns."""
MIN_PRETRAIN_SAMPLES = 5
"""Fewest pre-training transitions: the epochs need a test set (20 %) of at least one."""
_FORMAT = "lwpr-rwr/1"
_PRETRAINING_SETTINGS = ("pretrain_waypoints", "leg_decisions", "max_epochs", "init_d", "w_gen",
                         "waypoint_range", "seed", "hold_steps", "attractor_gain", "rest_actuation",
                         "ridge")
"""Settings that change the pre-trained model (and so its cache entry)."""
_WALK_SETTINGS = ("pretrain_waypoints", "leg_decisions", "waypoint_range", "seed", "hold_steps",
                  "rest_actuation")
"""Settings that change the pre-training walk (what a recorded walk must match)."""
SETTLE_STEPS = 20
"""Control steps at the rest actuation before the walk's first decision."""


@functools.lru_cache(maxsize=1)
def _learner_source_digest() -> str:
    """SHA-256 of this module and the learners it uses (edited code gets a new cache key)."""
    digest = hashlib.sha256()
    for module in (agents.learners.lwpr, agents.learners.rwr_inverse):
        digest.update(Path(module.__file__).read_bytes())
    digest.update(Path(__file__).read_bytes())
    return digest.hexdigest()


class LWPRRWRController(BaselinePolicy):
    """LWPR forward models + reward-weighted-regression inverse + P controller (ho2018).

    Args:
        env: the environment it controls (its obs must include ``pose`` and ``target``).
        online: learn during the run (Algorithm 1) or keep the pre-trained model.
        window: online data window of the inverse (samples; paper 425 and 550).
        kp: ``K_P`` of eq. (14), per decision.
        max_step_mm: largest ``|dp_ref|`` one decision asks for (mm).
        hold_steps: control steps per decision.
        attractor_gain: ``K_a`` of eq. (8) (per decision).
        rest_actuation: ``u_0`` of eq. (8), as a fraction of the chamber range.
        ridge: weight of a local inverse's pre-trained parameters against the window's data.
        pretrain_waypoints: random actuator-space waypoints of pre-training (paper: 80 or 320).
        leg_decisions: decisions along each straight line between two waypoints.
        max_epochs: most LWPR training epochs (paper: 15, best at 11).
        init_d: LWPR distance metric of new receptive fields (normalised input units^-2).
        w_gen: LWPR field-creation threshold.
        waypoint_range: pre-training waypoints are uniform in ``[0, waypoint_range]`` of every
            chamber's range (the region the tasks use; the paper samples "the workspace").
        min_step_mm: online, transitions whose tip moved less than this (mm) are not learnt:
            they are mostly tracker noise.
        seed: seed of the waypoints and of the pre-training env's reset.
        cache: keep the pre-trained model on disk and reuse it.
        progress: show tqdm bars while pre-training drives the waypoints and trains the LWPR
            epochs (about 30 s for 80 waypoints; nothing when the model comes from the cache).
            Not saved.
        dataset: id of a recorded pre-training walk (``python -m eval datasets``, ho2018) to
            pre-train on instead of walking (see the module docstring); ``None`` walks. Not
            saved.
        dataset_root: the datasets root of ``dataset`` (Minari's when ``None``).
    """

    name = "lwpr_rwr"

    def __init__(self, env, online: bool = True, window: int = 425, kp: float = 0.5,
                 max_step_mm: float = 4.0, hold_steps: int = 2, attractor_gain: float = 0.05,
                 rest_actuation: float = 0.2, ridge: float = 20.0, pretrain_waypoints: int = 80,
                 leg_decisions: int = 30, max_epochs: int = 15, init_d: float = 0.25,
                 w_gen: float = 0.2, waypoint_range: float = 0.6, min_step_mm: float = 1.0,
                 seed: int = 0, cache: bool = True, progress: bool = True,
                 dataset: str | None = None,
                 dataset_root: str | os.PathLike | None = None) -> None:
        unwrapped = require_soft_arm_env(env, self.name)
        for name, value in (("online", online), ("progress", progress)):
            if not isinstance(value, (bool, np.bool_)):
                raise ValueError(f"{name} must be True or False, got {value!r}")
        self.online, self.progress = bool(online), bool(progress)
        self.window = require_integer("window", window, 1)
        self.kp = require_positive("kp", kp)
        self.max_step_mm = require_positive("max_step_mm", max_step_mm)
        self.hold_steps = require_integer("hold_steps", hold_steps, 1)
        self.attractor_gain = require_in_range("attractor_gain", attractor_gain, 0.0, 1.0)
        self.rest_actuation = require_in_range("rest_actuation", rest_actuation, 0.0, 1.0)
        self.ridge = require_in_range("ridge", ridge, MIN_RIDGE, MAX_RIDGE)
        self.pretrain_waypoints = require_integer("pretrain_waypoints", pretrain_waypoints, 2)
        self.leg_decisions = require_integer("leg_decisions", leg_decisions, 1)
        if self.pretrain_waypoints * self.leg_decisions < MIN_PRETRAIN_SAMPLES:
            raise ValueError(f"pretrain_waypoints * leg_decisions (the pre-training's "
                             f"transitions) must be >= {MIN_PRETRAIN_SAMPLES} for its 80/20 "
                             f"train/test split, got {self.pretrain_waypoints} * "
                             f"{self.leg_decisions}")
        self.max_epochs = require_integer("max_epochs", max_epochs, 1)
        self.init_d = require_positive("init_d", init_d)
        self.w_gen = require_in_range("w_gen", w_gen, 0.0, 1.0)
        if self.w_gen in (0.0, 1.0):  # LWPR's own range, checked here rather than pre-training
            raise ValueError(f"w_gen must be in (0, 1) (LWPR's field-creation threshold), got "
                             f"{w_gen!r}")
        self.waypoint_range = require_in_range("waypoint_range", waypoint_range, 0.0, 1.0)
        self.min_step_mm = require_non_negative("min_step_mm", min_step_mm)
        if self.waypoint_range == 0.0:
            raise ValueError("waypoint_range must be in (0, 1], got 0.0")
        self.seed = require_seed("seed", seed)
        if not isinstance(cache, (bool, np.bool_)):
            raise ValueError(f"cache must be True or False, got {cache!r}")
        self.cache = bool(cache)
        self.dataset, self.dataset_root = check_dataset_options(dataset, dataset_root)
        self.env = unwrapped
        for part in ("pose", "target"):
            if part not in self.env.obs_parts:
                raise PolicyRefusal(f"the env's obs must include {part!r} for {self.name}, got "
                                    f"{self.env.obs_parts!r}")
        spec = self.env.arm
        if spec.n_chambers != 3 * spec.n_segments:
            raise PolicyRefusal(f"{self.name} drives three chambers per segment; the env's arm has "
                                f"{spec.n_chambers} chambers on {spec.n_segments} segments")
        self.actuation = Actuation.of_env(self.env)
        self.n_chambers = spec.n_chambers
        self.p_low, self.p_high = spec.p_pre_pa, spec.p_max_pa
        self.forward: LWPR | None = None
        self.inverse: RewardWeightedInverse | None = None
        self.pretraining: dict[str, Any] = {}
        self.learnt_transitions = 0
        """Transitions online learning has taken so far (those past the minimum step)."""
        # one second of decisions with every chamber beyond its range: the target is out of reach
        self.saturation = SaturationWatch(self.name, self.p_low, self.p_high, steps=max(
            1, round(1.0 / (self.hold_steps * spec.control_period_s))))
        self.reset()

    # ------------------------------------------------------------------ episode
    def reset(self) -> None:
        """Start of an episode (after the env's reset): the chambers are commanded to the
        attractor's rest configuration ``u_0`` (a straight arm, every chamber inside its range
        so that it can move both ways)."""
        self._command = self.actuation.initial_command_pa.copy()
        self._u = np.full(self.n_chambers, self.rest_actuation)
        self._step = 0
        self._last_decision: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None
        self._pending: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None
        self.saturation.reset()

    def predict(self, observation, state=None, episode_start=None, deterministic: bool = True):
        """The action for ``observation`` (SB3's signature); pre-trains first if it has not
        been (on a private copy of the env, see the module docstring)."""
        observation = self.check_observation(observation)  # before any state changes
        position = self._pose(observation)
        target = self._next_target(observation)
        return self.action_for(position, target), state

    def action_for(self, position_m: np.ndarray, target_m: np.ndarray) -> np.ndarray:
        """The action that moves the tip from ``position_m`` towards ``target_m`` (m, base
        frame): a new decision every ``hold_steps`` calls, the held command between them."""
        position_m = as_finite_array("position_m", position_m, shape=(3,))
        target_m = as_finite_array("target_m", target_m, shape=(3,))
        if self.inverse is None:
            self.pretrain()
        if self._step % self.hold_steps == 0:
            p = position_m * _MM
            if self._last_decision is not None:
                self._pending = (*self._last_decision, p - self._last_decision[0])
            wanted = self.kp * (target_m * _MM - p)
            size = np.linalg.norm(wanted)
            if size > self.max_step_mm:
                wanted *= self.max_step_mm / size
            du = self.inverse.predict(wanted, p, self._u)
            self.saturation.observe(self.p_low + (self._u + du) * (self.p_high - self.p_low),
                                    target_m)
            u_next = np.clip(self._u + du, 0.0, 1.0)
            self._last_decision = (p, self._u.copy(), u_next - self._u)
            self._u = u_next
        self._step += 1
        pressures = self.p_low + self._u * (self.p_high - self.p_low)
        action = self.actuation.action(pressures, self._command)
        self._command = self.actuation.pressure(action, self._command)
        return action

    def update(self, observation, action, reward, next_observation, info) -> None:
        """Online learning (``online=True``): the transition completed at the latest decision
        goes into the forward model and the inverse (Algorithm 1)."""
        if self.online:
            self.learn_pending()

    def learn_pending(self) -> None:
        """Learn the last completed transition, if there is one not yet learnt."""
        if self._pending is None or self.inverse is None:
            return
        p, u, du, dp = self._pending
        self._pending = None
        if np.linalg.norm(dp) < self.min_step_mm:
            return  # mostly the tracker's noise (0.8 mm per axis for the EM coil)
        self.forward.update(np.concatenate([p, u, du]), dp)
        self.learnt_transitions += 1
        if self.forward.fields_per_output != self._fields_seen:
            self.inverse.set_fields(*self._inverse_fields())
        self.inverse.add(p, u, du, dp)

    # ------------------------------------------------------------------ pre-training
    def pretrain(self) -> dict[str, Any]:
        """Pre-train (or take the cached pre-training) as the module docstring describes;
        returns its report (samples, test RMSE per epoch, best epoch, receptive fields)."""
        recorded = None if self.dataset is None else self._read_pretraining_data()

        def compute() -> dict[str, Any]:
            data = self._collect_pretraining_data() if recorded is None else recorded
            forward, report = self._train_forward(data)
            self.forward = forward
            inverse = self._fit_inverse(data)
            return {"forward": forward, "inverse": inverse, "report": report, "tips_mm": data[0]}

        def use(result: dict[str, Any]) -> tuple:
            forward, inverse = result["forward"], result["inverse"]
            if not (isinstance(forward, LWPR) and isinstance(inverse, RewardWeightedInverse)):
                raise TypeError(f"holds a {type(forward).__name__} and a "
                                f"{type(inverse).__name__}, not an LWPR model and its inverse")
            return forward, inverse, result["report"], result["tips_mm"]

        parts = self._cache_parts()
        if recorded is not None:  # keyed on the data read; without a dataset the key is as was
            parts["recorded walk"] = hashlib.sha256(b"".join(
                np.ascontiguousarray(array).tobytes() for array in recorded)).hexdigest()
        self.forward, self.inverse, self.pretraining, self._pretraining_tips_mm = cached(
            parts, compute, use_cache=self.cache, use=use)
        self.inverse.window = self.window  # the window plays no part in pre-training
        self._fields_seen = self.forward.fields_per_output
        return self.pretraining

    def pretraining_tips_mm(self) -> np.ndarray:
        """Tip positions (mm) visited during pre-training: the workspace the model knows."""
        if self.inverse is None:
            self.pretrain()
        return self._pretraining_tips_mm.copy()

    def _collect_pretraining_data(
            self, wrap_env: Callable[[gym.Env], gym.Env] | None = None,
    ) -> tuple[np.ndarray, ...]:
        """Transitions ``(p, u, du, dp)`` (mm, fractions of the range) along straight lines
        between random actuator-space waypoints, on an unloaded, fault-free copy of the env.

        Args:
            wrap_env: applied to the copy once made, before its reset (e.g. a recorder of the
                walk, :class:`soft_gym.datasets.episodes.EpisodeRecorder`); it must pass
                observations and actions through unchanged. The wrapped env is closed after the
                walk.
        """
        env = self.pretraining_env()
        if wrap_env is not None:
            env = wrap_env(env)
        schedule = self._actuation_schedule()
        try:
            actuation = Actuation.of_env(env.unwrapped)
            observation, _ = env.reset(seed=self.seed)
            u = schedule[0]
            for _ in range(SETTLE_STEPS):  # settle at the rest configuration first
                observation, *_ = env.step(actuation.action(self.p_low + u * (self.p_high
                                                                              - self.p_low)))
            poses = [env.unwrapped.observation_part(observation, "pose")[:3] * _MM]
            bar = tqdm(total=self.pretrain_waypoints, desc=f"{self.name} pre-training waypoints",
                       disable=not self.progress, leave=False)
            for k, u_next in enumerate(schedule[1:], start=1):
                pressures = self.p_low + u_next * (self.p_high - self.p_low)
                for _ in range(self.hold_steps):
                    observation, *_ = env.step(actuation.action(pressures))
                poses.append(env.unwrapped.observation_part(observation, "pose")[:3] * _MM)
                if k % self.leg_decisions == 0:
                    bar.update(1)
            bar.close()
        finally:
            env.close()
        return self._transitions(poses, schedule)

    def pretraining_env(self) -> gym.Env:
        """A new unloaded, fault-free copy of the env that the pre-training walks (reach task,
        flat ``pose`` + ``target`` observation, absolute actions)."""
        if self.env.spec is None:
            raise ValueError("env has no spec (it was not made by gymnasium.make), so "
                             f"{self.name} cannot pre-train on a copy of it")
        kwargs = dict(self.env.spec.kwargs)
        # pre-training is the lab's calibration: no loads, no visual faults
        kwargs.update(scenario=None, randomization=None, faults=None, task="reach",
                      episode_steps=10**7, obs=("pose", "target"), obs_format="flat",
                      action_mode="absolute")
        for key in ("path", "cycles", "speed_m_s", "waypoints_m"):
            kwargs.pop(key, None)
        return gym.make(self.env.spec.id, **kwargs)

    def _actuation_schedule(self) -> list[np.ndarray]:
        """``u`` at the rest configuration, then after each of the walk's decisions (fractions
        of each chamber's range): ``pretrain_waypoints * leg_decisions + 1`` rows."""
        rng = np.random.default_rng(self.seed)
        waypoints = rng.uniform(0.0, self.waypoint_range,
                                (self.pretrain_waypoints, self.n_chambers))
        u = np.full(self.n_chambers, self.rest_actuation)
        schedule = [u]
        for waypoint in waypoints:
            start = u.copy()
            for j in range(1, self.leg_decisions + 1):
                u = start + (waypoint - start) * j / self.leg_decisions
                schedule.append(u)
        return schedule

    def _transitions(self, poses_mm: list[np.ndarray],
                     schedule: list[np.ndarray]) -> tuple[np.ndarray, ...]:
        """The transitions ``(p, u, du, dp)`` of the tip positions (mm) read after the settling
        and after each decision, and the actuation schedule."""
        samples = np.array([np.concatenate([poses_mm[k], schedule[k],
                                            schedule[k + 1] - schedule[k],
                                            poses_mm[k + 1] - poses_mm[k]])
                            for k in range(len(schedule) - 1)])
        c = self.n_chambers
        return samples[:, :3], samples[:, 3:3 + c], samples[:, 3 + c:3 + 2 * c], samples[:, -3:]

    def walk_key(self) -> dict[str, Any]:
        """What the pre-training walk depends on: the arm (``preset`` and the whole spec), the
        env's settings the copy keeps (not the preset's spelling) and the walk's settings. A
        recorded walk (``dataset=``) must match it."""
        parts = self._cache_parts()
        env = {key: value for key, value in parts["env"].items()
               if key not in ("preset", "alias_preset")}
        return {"preset": self.env.arm.name, "arm": repr(self.env.arm), "env": env,
                **{key: getattr(self, key) for key in _WALK_SETTINGS}}

    def _read_pretraining_data(self) -> tuple[np.ndarray, ...]:
        """The transitions of the walk recorded in :attr:`dataset` (checked against
        :meth:`walk_key`), equal to those :meth:`_collect_pretraining_data` takes."""
        from soft_gym.papers.ho2018.readers import read_pretraining_walk

        observations = read_pretraining_walk(self.dataset, self.dataset_root, self.walk_key())
        schedule = self._actuation_schedule()
        steps = SETTLE_STEPS + self.hold_steps * np.arange(len(schedule))
        if len(observations) <= steps[-1]:
            raise ValueError(f"dataset {self.dataset!r} holds {len(observations) - 1} steps; "
                             f"the walk takes {steps[-1]}")
        # the copy's flat observation starts with the pose (obs=("pose", "target"))
        poses = [observations[step][:3] * _MM for step in steps]
        return self._transitions(poses, schedule)

    def _train_forward(
            self, data,
            on_epoch: Callable[[LWPR, np.ndarray, np.ndarray], None] | None = None,
    ) -> tuple[LWPR, dict[str, Any]]:
        """LWPR epochs on 80 % of the transitions; the epoch with the lowest RMSE on the other
        20 % is kept (ho2018 Fig. 4).

        Args:
            on_epoch: called after each epoch with the model and the indices of the training
                and test transitions (e.g. :func:`eval.papers.ho2018.experiments.run_pretraining_check`);
                it must not change the model.
        """
        p, u, du, dp = data
        inputs = np.concatenate([p, u, du], axis=1)
        rng = np.random.default_rng(self.seed)
        order = rng.permutation(len(inputs))
        split = int(round(0.8 * len(inputs)))
        train, test = order[:split], order[split:]
        scale_p = max(float(np.std(p)), 1.0)
        scale_du = max(float(np.std(du)), 1e-3)
        c = self.n_chambers
        norm_in = np.concatenate([np.full(3, scale_p), np.full(c, 0.3), np.full(c, scale_du)])
        # fields localise on the configuration [p, u] (eq. (6)); along du the local models are
        # linear (eq. (3)), so the kernel is made broad there
        init_d = np.concatenate([np.full(3 + c, self.init_d), np.full(c, 1e-3 * self.init_d)])
        model = LWPR(inputs.shape[1], 3, init_d=init_d, w_gen=self.w_gen,
                     norm_in=norm_in, norm_out=np.full(3, max(float(np.std(dp)), 1e-3)))
        best, best_rmse, history = None, np.inf, []
        for epoch in tqdm(range(self.max_epochs), desc=f"{self.name} LWPR epochs",
                          disable=not self.progress, leave=False):
            for index in rng.permutation(train):
                model.update(inputs[index], dp[index])
            if on_epoch is not None:
                on_epoch(model, train, test)
            predicted = model.predict_batch(inputs[test])
            rmse = float(np.sqrt(np.mean(np.sum((predicted - dp[test]) ** 2, axis=1))))
            history.append(rmse)
            if rmse < best_rmse:
                best, best_rmse = copy.deepcopy(model), rmse
            elif epoch >= 2 and rmse > best_rmse:
                break  # the test error stopped falling
        report = {"samples": int(len(inputs)), "test_rmse_mm": history,
                  "best_epoch": int(np.argmin(history)) + 1, "best_test_rmse_mm": best_rmse,
                  "receptive_fields": list(best.fields_per_output)}
        return best, report

    def _new_inverse(self) -> RewardWeightedInverse:
        return RewardWeightedInverse(3, self.n_chambers, rest_actuation=self.rest_actuation,
                                     attractor_gain=self.attractor_gain, window=self.window,
                                     ridge=self.ridge, task_scale=1.0, actuation_scale=0.1)

    def _fit_inverse(self, data) -> RewardWeightedInverse:
        """A new inverse on the receptive fields of :attr:`forward`, fitted on the transitions
        ``data`` (``(p, u, du, dp)``)."""
        inverse = self._new_inverse()
        inverse.set_fields(*self._inverse_fields())
        inverse.fit(*data)
        return inverse

    def _inverse_fields(self) -> tuple[np.ndarray, np.ndarray]:
        """The forward model's receptive fields of all outputs, on ``[p, u]`` (eq. (6))."""
        centres, metrics = self.forward.receptive_fields()
        d = 3 + self.n_chambers
        self._fields_seen = self.forward.fields_per_output
        return centres[:, :d], metrics[:, :d, :d]

    # ------------------------------------------------------------------ cache
    def _cache_parts(self) -> dict[str, Any]:
        """Everything the pre-training depends on (the key of its cache entry)."""
        ignored = ("scenario", "randomization", "faults", "path", "cycles", "speed_m_s",
                   "waypoints_m", "episode_steps", "task", "obs", "obs_format", "action_mode",
                   "delta_fraction")
        env_kwargs = {} if self.env.spec is None else {
            key: value for key, value in self.env.spec.kwargs.items() if key not in ignored}
        return {"kind": f"{self.name} pre-training", "format": _FORMAT,
                "arm": self.env.arm, "env": env_kwargs,
                "settings": {key: getattr(self, key) for key in _PRETRAINING_SETTINGS},
                "learners": _learner_source_digest()}

    # ------------------------------------------------------------------ persistence
    def save(self, path: str | Path) -> None:
        """Write the settings, the forward LWPR and the inverse (with its window) to ``path``
        (``.npz`` format, exactly that name); :meth:`load` restores a controller that predicts
        identically."""
        if self.forward is None or self.inverse is None:
            raise ValueError(f"{self.name} has no model to save yet: call pretrain() first")
        buffer = io.BytesIO()
        self.forward.save(buffer)
        settings = {key: getattr(self, key) for key in (
            "online", "window", "kp", "max_step_mm", "hold_steps", "attractor_gain",
            "rest_actuation", "ridge", "pretrain_waypoints", "leg_decisions", "max_epochs",
            "init_d", "w_gen", "waypoint_range", "min_step_mm", "seed", "cache")}
        arrays = {f"inverse_{k}": v for k, v in self.inverse.state().items()}
        write_npz(path, dict(format=np.array(_FORMAT), settings=np.array(json.dumps(settings)),
                             pretraining=np.array(json.dumps(self.pretraining)),
                             pretraining_tips_mm=self._pretraining_tips_mm,
                             forward=np.frombuffer(buffer.getvalue(), dtype=np.uint8), **arrays))

    @classmethod
    def load(cls, path: str | Path, env=None) -> "LWPRRWRController":
        """Read a controller written by :meth:`save` for ``env``; a missing, corrupt or foreign
        file raises one ``ValueError`` naming the path and what is wrong."""
        require_soft_arm_env(env, cls.name)
        data = _read_saved(path, cls.name)
        try:
            settings = json.loads(str(data["settings"]))
            if not isinstance(settings, dict):
                raise ValueError(f"settings must be a JSON object, got {type(settings).__name__}")
            controller = cls(env, **settings)
        except (KeyError, TypeError, ValueError) as error:
            raise ValueError(f"{cls.name} controller file {str(path)!r} holds invalid settings "
                             f"({type(error).__name__}: {error})") from None
        controller._restore(path, data)
        return controller

    def _restore(self, path: str | Path, data: dict[str, np.ndarray] | None = None) -> None:
        """Take the models of the file ``path`` (its arrays ``data``, read if not given)."""
        data = _read_saved(path, self.name) if data is None else data
        what = f"{self.name} controller file {str(path)!r}"
        try:
            forward_bytes = io.BytesIO(data["forward"].tobytes())
        except KeyError as error:
            raise ValueError(f"{what} is not a saved {self.name} controller (no {error} entry)") \
                from None
        try:
            forward = LWPR.load(forward_bytes)
        except ValueError as error:
            raise ValueError(f"{what}: its 'forward' entry is not a readable LWPR model "
                             f"({str(error).rsplit(': ', 1)[-1]})") from None
        try:
            inverse_state = {key[len("inverse_"):]: value for key, value in data.items()
                             if key.startswith("inverse_")}
            pretraining = json.loads(str(data["pretraining"]))
            tips = as_finite_array("pretraining_tips_mm", data["pretraining_tips_mm"])
            if tips.ndim != 2 or tips.shape[1] != 3:
                raise ValueError(f"pretraining_tips_mm must have shape (n, 3), got {tips.shape}")
            if not isinstance(pretraining, dict):
                raise ValueError("pretraining must be a JSON object")
        except (KeyError, TypeError, ValueError) as error:
            raise ValueError(f"{what} is not a saved {self.name} controller "
                             f"({type(error).__name__}: {error})") from None
        inverse = RewardWeightedInverse.from_state(inverse_state, source=what)
        if forward.input_dim != 3 + 2 * self.n_chambers or inverse.actuator_dim != self.n_chambers:
            raise ValueError(f"path {str(path)!r} holds a {self.name} controller for another arm "
                             f"({inverse.actuator_dim} chambers, this env has {self.n_chambers})")
        self.forward, self.inverse, self.pretraining = forward, inverse, pretraining
        self._pretraining_tips_mm = tips
        self._fields_seen = forward.fields_per_output

    # ------------------------------------------------------------------ helpers
    def _pose(self, observation) -> np.ndarray:
        return np.asarray(self.env.observation_part(observation, "pose"), dtype=float)[:3]

    def _next_target(self, observation) -> np.ndarray:
        return np.asarray(self.env.observation_part(observation, "target"), dtype=float)[3:6]


def _read_saved(path: str | Path, name: str) -> dict[str, np.ndarray]:
    """The arrays of a file :meth:`LWPRRWRController.save` wrote, its format marker checked;
    ``ValueError`` naming the file otherwise."""
    data = read_npz(path, f"{name} controller")
    marker = data.get("format")
    if marker is None or marker.shape != () or str(marker) != _FORMAT:
        raise ValueError(f"{name} controller file {str(path)!r} is not a saved {name} controller "
                         f"(format marker {None if marker is None else str(marker)!r}, expected "
                         f"{_FORMAT!r}): a foreign or truncated .npz")
    return data
