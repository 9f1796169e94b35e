"""The batched MuJoCo vector env as a stable-baselines3 ``VecEnv``.

:class:`Sb3VectorEnv` runs a :class:`soft_gym.envs.vector.SoftArmVectorEnv` in Gymnasium's
``SameStep`` autoreset mode, which is SB3's: a finished arm is reset within the step, its last
observation in ``info["terminal_observation"]``, ``info["TimeLimit.truncated"]`` set for a
truncation, and ``info["episode"]`` (return, length, wall time) as SB3's ``Monitor`` gives it.
``python -m train --vec batched --n-envs N`` trains on it (one process, N arms).
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any, Sequence

import gymnasium as gym
import numpy as np
from stable_baselines3.common.monitor import ResultsWriter
from stable_baselines3.common.vec_env import VecEnv

from soft_gym.envs.registration import registered_ids
from soft_gym.envs.vector import SoftArmVectorEnv


class Sb3VectorEnv(VecEnv):
    """``num_envs`` MuJoCo arms stepped as one batch, for SB3.

    :param env_id: a soft-arm Gymnasium id (its vector entry point builds the batch).
    :param num_envs: arms in the batch.
    :param threads: threads the arms' physics runs on.
    :param monitor_dir: where to write ``batched.monitor.csv`` (SB3's ``Monitor`` format: one
        row per finished episode of any arm), or ``None``.
    :param env_kwargs: every arm's env keyword arguments (``engine="mujoco"``).
    """

    def __init__(self, env_id: str, num_envs: int, threads: int = 1,
                 monitor_dir: str | None = None, **env_kwargs: Any) -> None:
        if env_id not in registered_ids():  # before any argument only a soft-arm id takes
            raise ValueError(f"env_id must be a soft-arm id, one of {registered_ids()}, got "
                             f"{env_id!r}")
        vector = gym.make_vec(env_id, num_envs=num_envs, vectorization_mode="vector_entry_point",
                              threads=threads, autoreset_mode="SameStep", **env_kwargs)
        self.vector: SoftArmVectorEnv = vector.unwrapped
        self._writer = None if monitor_dir is None else ResultsWriter(
            str(Path(monitor_dir) / "batched"), header={"t_start": time.time(), "env_id": env_id})
        super().__init__(num_envs, self.vector.single_observation_space,
                         self.vector.single_action_space)
        self._actions: np.ndarray | None = None
        self._returns = np.zeros(num_envs)
        self._lengths = np.zeros(num_envs, dtype=int)
        self._started = time.time()

    @property
    def envs(self) -> list:
        return self.vector.envs

    def reset(self):
        observations = []
        for i, env in enumerate(self.envs):
            options = self._options[i] if self._options else None
            observation, self.reset_infos[i] = env.reset(seed=self._seeds[i],
                                                         options=options or None)
            observations.append(observation)
        self._reset_seeds()
        self._reset_options()
        self._returns[:] = 0.0
        self._lengths[:] = 0
        return self.vector.stack_observations(observations)

    def step_async(self, actions: np.ndarray) -> None:
        self._actions = self.vector.actions_array(actions)

    def step_wait(self):
        observations, rewards, terminated, truncated, infos = self.vector.step_arms(self._actions)
        dones = np.logical_or(terminated, truncated)
        self._returns += rewards
        self._lengths += 1
        for i in np.flatnonzero(dones):
            reset_info = infos[i]
            info = dict(reset_info.pop("final_info"))
            info["terminal_observation"] = reset_info.pop("final_obs")
            info["TimeLimit.truncated"] = bool(truncated[i] and not terminated[i])
            info["episode"] = {"r": float(self._returns[i]), "l": int(self._lengths[i]),
                               "t": round(time.time() - self._started, 6)}
            infos[i], self.reset_infos[i] = info, reset_info
            if self._writer is not None:
                self._writer.write_row(info["episode"])
            self._returns[i], self._lengths[i] = 0.0, 0
        return (self.vector.stack_observations(observations),
                np.array(rewards, dtype=np.float32), dones, infos)

    def close(self) -> None:
        self.vector.close()
        if self._writer is not None:
            self._writer.close()

    def get_attr(self, attr_name: str, indices=None) -> list:
        return [getattr(self.envs[i], attr_name) for i in self._indices(indices)]

    def set_attr(self, attr_name: str, value: Any, indices=None) -> None:
        for i in self._indices(indices):
            setattr(self.envs[i], attr_name, value)

    def env_method(self, method_name: str, *method_args, indices=None, **method_kwargs) -> list:
        return [getattr(self.envs[i], method_name)(*method_args, **method_kwargs)
                for i in self._indices(indices)]

    def env_is_wrapped(self, wrapper_class: type, indices=None) -> list[bool]:
        return [isinstance(self.envs[i], wrapper_class) for i in self._indices(indices)]

    def _indices(self, indices) -> Sequence[int]:
        """The arms ``indices`` names (``None``: all, an index, or an iterable of indices).

        Raises:
            ValueError: an index that is not an integer in [0, ``num_envs`` - 1], naming it.
        """
        if indices is None:
            return range(self.num_envs)
        chosen = (list(indices) if isinstance(indices, (list, tuple, range, np.ndarray))
                  else [indices])
        for index in chosen:
            if (isinstance(index, (bool, np.bool_)) or not isinstance(index, (int, np.integer))
                    or not 0 <= index < self.num_envs):
                raise ValueError(f"indices must be arm indices in [0, {self.num_envs - 1}] (this "
                                 f"batch has {self.num_envs} arms), got {index!r} in {indices!r}")
        return chosen
