"""Minari episodes from env runs and from procedures' samples.

* :class:`EpisodeRecorder`: a Gymnasium wrapper that keeps every observation, action, reward,
  termination, truncation and the ground truth and estimates of ``info`` (:func:`info_row`) of
  one episode, and changes nothing the env returns (records of a run are the same with and
  without it).
* :func:`procedure_episode`: one procedure's samples (commands held to equilibrium, not a
  Gymnasium episode) as one episode: step ``i``'s action is sample ``i``'s command and its
  next observation the readings then; the first observation (before any command) and the
  first info row are NaN, rewards 0, no termination, truncated at the last sample.
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np

GROUND_TRUTH_KEYS = ("tip_position_m", "tip_quaternion", "target_m", "error_mm", "backbone_m",
                     "chamber_lengths_m", "pressures_pa", "time_s")
"""The env ``info`` entries a recorded episode keeps (SI units; ``error_mm`` in mm)."""


def info_row(info: dict[str, Any]) -> dict[str, Any]:
    """The ground truth (:data:`GROUND_TRUTH_KEYS`) and every numeric estimate of one env
    ``info`` (``info["estimates"]``, under ``estimate_<name>``), as float arrays."""
    row = {key: np.asarray(info[key], dtype=float) for key in GROUND_TRUTH_KEYS if key in info}
    for key, value in info.get("estimates", {}).items():
        try:
            array = np.asarray(value, dtype=float)
        except (TypeError, ValueError):  # not a number per step (SOM nodes, reasons)
            continue
        row[f"estimate_{key}"] = array
    return row


def stack_info_rows(rows: list[dict[str, Any]]) -> dict[str, Any]:
    """Per-step info rows as Minari's info columns: a key missing from a row is NaN there, a
    key whose shape changes between rows is left out; scalars become lists (Minari stores
    0-d columns as plain lists)."""
    shapes: dict[str, tuple] = {}
    for row in rows:
        for key, value in row.items():
            if shapes.setdefault(key, value.shape) != value.shape:
                shapes[key] = None  # type: ignore[assignment]
    columns: dict[str, Any] = {}
    for key, shape in shapes.items():
        if shape is None:
            continue
        column = np.stack([row.get(key, np.full(shape, np.nan)) for row in rows])
        columns[key] = column.tolist() if column.ndim == 1 else column
    return columns


def _copy_observation(observation: Any) -> Any:
    if isinstance(observation, dict):
        return {key: np.array(value) for key, value in observation.items()}
    return np.array(observation)


def _stack_observations(observations: list[Any]) -> Any:
    if isinstance(observations[0], dict):
        return {key: np.stack([o[key] for o in observations]) for key in observations[0]}
    return np.stack(observations)


class EpisodeRecorder(gym.Wrapper):
    """Keep the episodes an env runs, unchanged (see the module docstring).

    Every ``reset`` starts a new episode; :meth:`buffers` gives the finished and current ones
    as :class:`minari.data_collector.EpisodeBuffer` (id ``i``, the reset's seed).
    """

    def __init__(self, env: gym.Env) -> None:
        super().__init__(env)
        self.episodes: list[dict[str, Any]] = []

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        observation, info = self.env.reset(seed=seed, options=options)
        self.episodes.append({"seed": seed, "observations": [_copy_observation(observation)],
                              "actions": [], "rewards": [], "terminations": [],
                              "truncations": [], "infos": [info_row(info)]})
        return observation, info

    def step(self, action):
        observation, reward, terminated, truncated, info = self.env.step(action)
        if not self.episodes:
            raise ValueError("EpisodeRecorder: step() before reset()")
        episode = self.episodes[-1]
        episode["observations"].append(_copy_observation(observation))
        episode["actions"].append(np.array(action, dtype=self.action_space.dtype))
        episode["rewards"].append(float(reward))
        episode["terminations"].append(bool(terminated))
        episode["truncations"].append(bool(truncated))
        episode["infos"].append(info_row(info))
        return observation, reward, terminated, truncated, info

    def episode_arrays(self, index: int = -1) -> dict[str, Any]:
        """Episode ``index`` as arrays (picklable): ``seed``, ``observations`` (steps + 1),
        ``actions``, ``rewards``, ``terminations``, ``truncations`` (steps) and ``infos``
        (columns of steps + 1 rows, :func:`stack_info_rows`)."""
        episode = self.episodes[index]
        return {"seed": episode["seed"],
                "observations": _stack_observations(episode["observations"]),
                "actions": np.array(episode["actions"]).reshape(
                    (len(episode["actions"]),) + self.action_space.shape),
                "rewards": np.asarray(episode["rewards"], dtype=float),
                "terminations": np.asarray(episode["terminations"], dtype=bool),
                "truncations": np.asarray(episode["truncations"], dtype=bool),
                "infos": stack_info_rows(episode["infos"])}

    def buffers(self) -> list:
        """Every recorded episode with at least one step, as Minari episode buffers."""
        return [episode_buffer(self.episode_arrays(i), i)
                for i in range(len(self.episodes)) if self.episodes[i]["actions"]]


def episode_buffer(arrays: dict[str, Any], episode_id: int | None = None):
    """A :class:`minari.data_collector.EpisodeBuffer` of :meth:`EpisodeRecorder.episode_arrays`
    (or :func:`procedure_episode`'s) arrays."""
    from minari.data_collector import EpisodeBuffer

    return EpisodeBuffer(id=episode_id, seed=arrays.get("seed"),
                         observations=arrays["observations"], actions=arrays["actions"],
                         rewards=list(np.asarray(arrays["rewards"], dtype=float)),
                         terminations=list(np.asarray(arrays["terminations"], dtype=bool)),
                         truncations=list(np.asarray(arrays["truncations"], dtype=bool)),
                         infos=arrays["infos"])


def procedure_episode(actions: np.ndarray, observations: dict[str, np.ndarray],
                      infos: dict[str, np.ndarray], seed: int | None = None) -> dict[str, Any]:
    """A procedure's ``n`` samples as one episode's arrays (layout in the module docstring).

    Args:
        actions: ``(n, n_chambers)`` env actions of the commands held (absolute mode).
        observations: name -> ``(n, ...)`` raw readings after each command.
        infos: name -> ``(n, ...)`` ground truth and labels of each sample (numeric or
            boolean; booleans are stored as 0/1).
        seed: the procedure's seed (the episode's ``seed`` metadata).

    Returns:
        The episode's arrays, as :meth:`EpisodeRecorder.episode_arrays` gives them.

    Raises:
        ValueError: arrays of different lengths, or no sample.
    """
    n = len(actions)
    lengths = {name: len(value) for name, value in {**observations, **infos}.items()}
    if n < 1 or any(length != n for length in lengths.values()):
        raise ValueError(f"a procedure episode needs n >= 1 samples in every array, got "
                         f"{n} actions and lengths {lengths}")

    def with_nan_first(value: np.ndarray) -> np.ndarray:
        value = np.asarray(value, dtype=float)
        return np.concatenate([np.full((1,) + value.shape[1:], np.nan), value])

    columns = {}
    for name, value in infos.items():
        column = with_nan_first(value)
        columns[name] = column.tolist() if column.ndim == 1 else column
    truncations = np.zeros(n, dtype=bool)
    truncations[-1] = True
    return {"seed": seed,
            "observations": {name: with_nan_first(value) for name, value in observations.items()},
            "actions": np.asarray(actions, dtype=np.float32), "rewards": np.zeros(n),
            "terminations": np.zeros(n, dtype=bool), "truncations": truncations,
            "infos": columns}


def box_dict_space(observations: dict[str, np.ndarray]) -> gym.spaces.Dict:
    """An unbounded float64 ``Dict`` of ``Box`` spaces shaped like one row of each array."""
    return gym.spaces.Dict({name: gym.spaces.Box(-np.inf, np.inf, np.asarray(value).shape[1:],
                                                 np.float64)
                            for name, value in observations.items()})
