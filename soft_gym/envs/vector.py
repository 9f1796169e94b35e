"""A batch of MuJoCo arms as one Gymnasium vector env, their physics stepped together.

``gym.make_vec(id, num_envs=N, vectorization_mode="vector_entry_point", engine="mujoco", ...)``
builds a :class:`SoftArmVectorEnv`: N :class:`~soft_gym.envs.soft_arm_env.SoftArmEnv` of the same
keyword arguments (each with its own tasks, sensors, loads, randomisation and random stream), whose
arms advance in lockstep through :func:`soft_gym.engines.mujoco.stepping.step_arms` (one NumPy
actuation update for all arms every 10 ms, each arm's substeps in C, on ``threads`` threads). An
arm in the batch moves bit for bit as the same env stepped alone (``tests/soft_gym/envs/
test_vector.py``).

Autoreset as Gymnasium 1.x: ``autoreset_mode="NextStep"`` (the default) resets an arm on the step
after its episode ended (that step's action is ignored, its reward is 0), ``"SameStep"`` resets it
at once and returns the last observation and info in ``info["final_obs"]`` /
``info["final_info"]``. ``reset(seed=s)`` seeds arm ``i`` with ``s + i`` (or takes one seed per
arm). :class:`train.batched.Sb3VectorEnv` adapts it to stable-baselines3.

As a single env, the batch refuses ``step`` before its arms are reset
(:class:`~soft_gym.envs.soft_arm_env.ResetNeededError`), and ``step`` and ``reset`` once it or one
of its arms is closed (:class:`~soft_gym.envs.soft_arm_env.ClosedEnvError`, naming the arm),
before any arm moves; ``close()`` again does nothing.
"""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor
from typing import Any, Mapping, Sequence

import gymnasium as gym
import numpy as np
from gymnasium.vector import AutoresetMode
from gymnasium.vector.utils import batch_space, concatenate, create_empty_array

from soft_gym._validation import require_integer
from soft_gym.engines import REFERENCE_ENGINE, engine_supports, engines_supporting
from soft_gym.envs.soft_arm_env import ClosedEnvError, ResetNeededError, SoftArmEnv
from soft_gym.envs.space_difference import space_difference

MAX_NUM_ENVS = 4096
"""The most arms one vector env holds (each a MuJoCo model of ~1 MB and an env)."""

MAX_THREADS = 64
"""The most threads a vector env steps its arms on."""

AUTORESET_MODES = (AutoresetMode.NEXT_STEP, AutoresetMode.SAME_STEP)


def _autoreset_mode(value: Any) -> AutoresetMode:
    names = [mode.value for mode in AUTORESET_MODES]
    try:
        mode = AutoresetMode(value)
    except ValueError:
        mode = None
    if mode not in AUTORESET_MODES:
        raise ValueError(f"autoreset_mode must be one of {names}, got {value!r}")
    return mode


def _per_env_kwargs(value: Any, num_envs: int) -> list[dict[str, Any]]:
    """``per_env_kwargs`` checked: ``None`` (every arm alike) or ``num_envs`` mappings."""
    if value is None:
        return [{}] * num_envs
    if (not isinstance(value, (list, tuple)) or len(value) != num_envs
            or not all(isinstance(own, Mapping) for own in value)):
        raise ValueError(f"per_env_kwargs must be None or a list of num_envs ({num_envs}) dicts "
                         f"of env keyword arguments, one per arm, got {value!r}")
    return [dict(own) for own in value]


def _check_alike(envs: list[SoftArmEnv]) -> None:
    """Every arm with the first's observation and action spaces and control period (what one
    batch's arrays and lockstep clock need); a refusal names the first difference and the two
    values (:func:`~soft_gym.envs.space_difference.space_difference`)."""
    first = envs[0]
    for i, env in enumerate(envs[1:], start=1):
        for name, mine, theirs, parts in (
                ("observation space", env.observation_space, first.observation_space,
                 (env.part_slices, first.part_slices)),
                ("action space", env.action_space, first.action_space, (None, None))):
            difference = space_difference(mine, theirs, *parts)
            if difference is not None:
                _refuse_unlike(envs, i, f"the {name} whose {difference.what} is "
                                        f"{difference.mine}, arm 0's is {difference.theirs}")
        period, first_period = env.arm.control_period_s, first.arm.control_period_s
        if period != first_period:
            _refuse_unlike(envs, i, f"the control period (s) {period}, arm 0 has {first_period}")


def _refuse_unlike(envs: list[SoftArmEnv], i: int, difference: str) -> None:
    """Close every arm and refuse arm ``i``, unlike arm 0 in ``difference``."""
    _close_all(envs)
    raise ValueError(f"per_env_kwargs[{i}] gives arm {i} {difference}: the arms of one batch "
                     f"must share it (another preset, feedback source or observation parts needs "
                     f"a batch of its own)")


def _close_all(envs: list[SoftArmEnv]) -> None:
    """Close every env of ``envs`` (an arm refused after others were built)."""
    for env in envs:
        env.close()


def _ragged_rows(actions: Any, row_shape: tuple[int, ...]) -> str:
    """What a ragged ``actions`` holds: its first row not of ``row_shape``."""
    for i, row in enumerate(actions):
        try:
            shape = np.shape(row)
        except ValueError:
            return f"a ragged sequence whose row {i} is itself ragged: {row!r}"
        if shape != row_shape:
            return f"a ragged sequence whose row {i} has shape {shape}"
    return f"a ragged sequence {actions!r}"


class SoftArmVectorEnv(gym.vector.VectorEnv):
    """``num_envs`` soft-arm envs on the MuJoCo engine, stepped as one batch.

    Args:
        num_envs: arms in the batch, an integer in [1, ``MAX_NUM_ENVS``].
        threads: threads the arms' physics runs on, in [1, ``MAX_THREADS``] (MuJoCo releases
            the GIL while it steps; more threads than cores only adds switching).
        autoreset_mode: ``"NextStep"`` or ``"SameStep"`` (see the module).
        per_env_kwargs: ``None``, or one mapping per arm of keyword arguments over
            ``env_kwargs`` for that arm alone (e.g. its own path, scenario, faults or
            randomisation); every arm must keep the first's observation and action spaces,
            engine and control period. Arms whose actuation differs are stepped one after another
            instead of in lockstep, with the same result.
        **env_kwargs: the keyword arguments of every arm's
            :class:`~soft_gym.envs.soft_arm_env.SoftArmEnv`; ``engine`` must be one that
            offers ``"batched"`` (:func:`soft_gym.engines.engine_supports`): MuJoCo.

    Attributes:
        envs: the arms' envs (``envs[i].sim`` is arm ``i``'s simulator).

    Raises:
        ValueError: naming the argument, for a bad ``num_envs``, ``threads`` or
            ``autoreset_mode``, an engine without ``"batched"``, or any bad env argument.
    """

    def __init__(self, num_envs: int, *, threads: int = 1,
                 autoreset_mode: str | AutoresetMode = AutoresetMode.NEXT_STEP,
                 per_env_kwargs: Sequence[Mapping[str, Any]] | None = None,
                 **env_kwargs: Any) -> None:
        self.num_envs = require_integer("num_envs", num_envs, 1, MAX_NUM_ENVS)
        self.threads = require_integer("threads", threads, 1, MAX_THREADS)
        self.autoreset_mode = _autoreset_mode(autoreset_mode)
        arm_kwargs = _per_env_kwargs(per_env_kwargs, self.num_envs)
        for i, own in enumerate(arm_kwargs):
            engine = {**env_kwargs, **own}.get("engine", REFERENCE_ENGINE)
            if not engine_supports(engine, "batched"):
                where = f" (per_env_kwargs[{i}])" if "engine" in own else ""
                able = " or ".join(repr(name) for name in engines_supporting("batched"))
                raise ValueError(f"engine must be {able} for a batched vector env (an engine "
                                 f"that steps arms together as one batch), got {engine!r}{where}; "
                                 "for arms on another engine use gym.make_vec(..., "
                                 "vectorization_mode='sync' or 'async')")
        if per_env_kwargs is None:
            self.envs = [SoftArmEnv(**env_kwargs)]
            for _ in range(self.num_envs - 1):  # each arm its own copy of the arguments
                config = self.envs[0].config.copied()
                self.envs.append(SoftArmEnv(**env_kwargs) if config is None
                                 else SoftArmEnv(config=config))
        else:
            self.envs = []
            for i, own in enumerate(arm_kwargs):
                try:
                    self.envs.append(SoftArmEnv(**{**env_kwargs, **own}))
                except ValueError as error:
                    _close_all(self.envs)
                    raise ValueError(f"per_env_kwargs[{i}]: {error}") from error
            _check_alike(self.envs)
        first = self.envs[0]
        self.metadata = {**first.metadata, "autoreset_mode": self.autoreset_mode}
        self.render_mode = None
        self.single_observation_space = first.observation_space
        self.single_action_space = first.action_space
        self.observation_space = batch_space(first.observation_space, self.num_envs)
        self.action_space = batch_space(first.action_space, self.num_envs)
        self._observations = create_empty_array(first.observation_space, self.num_envs)
        self._needs_reset = np.zeros(self.num_envs, dtype=bool)
        self._executor = ThreadPoolExecutor(self.threads) if self.threads > 1 else None

    # ------------------------------------------------------------------ gymnasium's API
    def reset(self, *, seed: int | Sequence[int] | None = None, options: dict | None = None):
        """Reset every arm; ``seed`` an integer (arm ``i`` gets ``seed + i``) or one per arm."""
        if self.closed or any(env.closed for env in self.envs):
            raise self._not_ready_error("reset")
        seeds = self._seeds(seed)
        observations, infos = [], {}
        for i, (env, arm_seed) in enumerate(zip(self.envs, seeds)):
            observation, info = env.reset(seed=arm_seed, options=options)
            observations.append(observation)
            infos = self._add_info(infos, info, i)
        self._needs_reset[:] = False
        return self.stack_observations(observations), infos

    def step(self, actions):
        """Step every arm with its row of ``actions`` (shape ``(num_envs, n_chambers)``)."""
        observations, rewards, terminated, truncated, infos = self.step_arms(actions)
        merged: dict = {}
        for i, info in enumerate(infos):
            merged = self._add_info(merged, info, i)
        return (self.stack_observations(observations), np.array(rewards, dtype=np.float64),
                np.array(terminated, dtype=bool), np.array(truncated, dtype=bool), merged)

    def close_extras(self, **kwargs: Any) -> None:
        for env in self.envs:
            env.close()
        if self._executor is not None:
            self._executor.shutdown()

    # ------------------------------------------------------------------ per-arm results
    def step_arms(self, actions) -> tuple[list, list[float], list[bool], list[bool], list[dict]]:
        """One step of every arm, as per-arm lists (observations, rewards, terminated,
        truncated, infos), with this env's autoreset; what :meth:`step` stacks and
        :class:`train.batched.Sb3VectorEnv` reads (it resets the arms itself)."""
        if self.closed or not all(env.ready for env in self.envs):
            raise self._not_ready_error("step")
        actions = self.actions_array(actions)
        resetting = self._needs_reset.copy()
        # every action checked before any arm is commanded
        checked = {i: env.check_action(actions[i]) for i, env in enumerate(self.envs)
                   if not resetting[i]}
        for i, action in checked.items():
            self.envs[i].command(action)
        type(self.envs[0].sim).step_batch([self.envs[i].sim for i in checked],
                                          self.envs[0].arm.control_period_s, self._executor,
                                          self.threads)
        results: list = [None] * self.num_envs
        for i, env in enumerate(self.envs):
            if resetting[i]:  # NextStep: this step resets the arm, its action unused
                observation, info = env.reset()
                results[i] = (observation, 0.0, False, False, info)
                continue
            observation, reward, term, trunc, info = env.finish_step(checked[i])
            if (term or trunc) and self.autoreset_mode == AutoresetMode.SAME_STEP:
                final_observation, final_info = observation, info
                observation, info = env.reset()
                info = {**info, "final_obs": final_observation, "final_info": final_info}
            results[i] = (observation, reward, term, trunc, info)
        self._needs_reset[:] = [(r[2] or r[3]) and self.autoreset_mode == AutoresetMode.NEXT_STEP
                                for r in results]
        return tuple(list(column) for column in zip(*results))  # type: ignore[return-value]

    # ------------------------------------------------------------------ helpers
    def actions_array(self, actions) -> np.ndarray:
        """``actions`` as an array of shape ``(num_envs, n_chambers)`` (each row checked when
        its arm steps).

        Raises:
            ValueError: ``actions`` of another shape, or ragged (rows of unequal lengths),
                naming the shape expected and the row that is not.
        """
        try:
            array = np.asarray(actions)
        except ValueError:  # ragged: NumPy makes no array of it
            given = _ragged_rows(actions, self.single_action_space.shape)
            raise ValueError(f"actions must have shape {self.action_space.shape} (num_envs, "
                             f"n_chambers), got {given}") from None
        if array.shape != self.action_space.shape:
            raise ValueError(f"actions must have shape {self.action_space.shape} "
                             f"(num_envs, n_chambers), got {array.shape}")
        return array

    def _not_ready_error(self, call: str) -> RuntimeError:
        """Why ``call`` (``"step"`` or ``"reset"``) cannot run now, as the error to raise."""
        if self.closed:
            return ClosedEnvError(f"{call}() on a closed {type(self).__name__}: the env is closed "
                                  f"(close() was called): make a new one")
        for i, env in enumerate(self.envs):
            if env.closed:
                return ClosedEnvError(f"{call}() on a {type(self).__name__} whose arm {i} is "
                                      f"closed (envs[{i}].close() was called): make a new one")
        unset = [i for i, env in enumerate(self.envs) if not env.ready]
        return ResetNeededError(f"call reset() before step(): arms {unset} of this "
                                f"{type(self).__name__} have not been reset since it was made")

    def _seeds(self, seed: int | Sequence[int] | None) -> list[int | None]:
        if seed is None:
            return [None] * self.num_envs
        if isinstance(seed, (list, tuple)):
            if len(seed) != self.num_envs:
                raise ValueError(f"seed must be an integer or {self.num_envs} seeds (one per "
                                 f"arm), got {len(seed)}")
            return [require_integer(f"seed[{i}]", s, 0) for i, s in enumerate(seed)]
        return [require_integer("seed", seed, 0) + i for i in range(self.num_envs)]

    def stack_observations(self, observations: list):
        """One observation per arm as the batch's observation (a copy)."""
        return concatenate(self.single_observation_space, observations, self._observations).copy()
