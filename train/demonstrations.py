"""An off-policy agent that starts from a baseline's demonstrations (``python -m train --demos``).

Three steps before the agent's own online training, each on the training env itself, so the
demonstrations read the observations and act in the action space the agent will:

1. **Record** (:func:`record_demonstrations`): a baseline (``cc_model``, ``hybrid_gpr``,
   ``lwpr_rwr``, ...) runs ``episodes`` episodes of the training env (seeds ``seed``,
   ``seed + 1``, ...; online learners learn as in the suite) and they are written as a Minari
   dataset (``soft-arm/demos/<policy>-<env>-v0``); or :func:`load_demonstrations` reads any
   dataset of this package whose spaces are the training env's (a suite's ``--record
   minari`` output, for instance).
2. **Behaviour cloning** (:func:`clone_behaviour`): the actor's deterministic action is fitted
   to the demonstrated actions (mean squared error in the policy's [-1, 1] action scale,
   minibatch Adam) on observations normalised as the training will normalise them: the
   ``VecNormalize`` statistics start from the demonstrations' observations and discounted
   returns.
3. **Replay buffer and critic** (:func:`seed_replay_buffer`, :func:`warm_up_critic`): every
   demonstrated transition goes into the replay buffer (raw, as SB3 stores them under
   ``VecNormalize``), and the critic takes ``critic_warmup`` gradient steps on them while the
   actor is held, so the first actor updates follow a critic that has seen the demonstrated
   behaviour instead of pulling the cloned actor toward a random critic's maximum. The
   agent's ``learning_starts`` is then 0: it acts with the cloned actor from its first step
   instead of uniformly random actions.

The online env steps of such an agent are counted as any agent's (``--timesteps``); the
demonstrations' steps are reported beside them in ``training.yaml`` (``demo_steps``).
"""

from __future__ import annotations

import contextlib
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Iterator

import gymnasium as gym
import numpy as np
import torch
from tqdm import tqdm

from agents.policies import BASELINES, make_policy
from agents.policies.registry import constructor_parameters
from agents.rollout import run_episode
from soft_gym.datasets.episodes import EpisodeRecorder
from soft_gym.datasets.store import load_dataset, write_dataset

DEMO_GROUP = "demos"
"""The dataset ids' group of recorded demonstrations: ``soft-arm/demos/<name>-v0``."""


@dataclass
class Demonstrations:
    """Transitions of demonstrated episodes, in the training env's raw observation and action
    spaces.

    Attributes:
        observations, next_observations: (n, obs_dim) raw observations.
        actions: (n, action_dim) env actions.
        rewards: (n,) rewards.
        terminations, truncations: (n,) episode ends.
        episode_starts: (n,) whether transition ``i`` begins an episode.
        source: where they came from (the dataset id).
    """

    observations: np.ndarray
    actions: np.ndarray
    rewards: np.ndarray
    next_observations: np.ndarray
    terminations: np.ndarray
    truncations: np.ndarray
    episode_starts: np.ndarray
    source: str

    def __len__(self) -> int:
        return len(self.actions)


def demo_dataset_id(policy: str, env_id: str) -> str:
    """The id a recording of ``policy`` on ``env_id`` is written under."""
    slug = re.sub(r"[^a-z0-9_.-]+", "-", f"{policy}-{env_id.split('-v')[0]}".lower()).strip("-.")
    return f"soft-arm/{DEMO_GROUP}/{slug}-v0"


def record_demonstrations(env_id: str, env_kwargs: dict[str, Any], policy: str, *,
                          episodes: int, seed: int, root: str | Path,
                          policy_params: dict[str, Any] | None = None,
                          progress: bool = False) -> str:
    """Run baseline ``policy`` for ``episodes`` episodes of ``gym.make(env_id, **env_kwargs)``
    and write them as a Minari dataset under ``root``; returns its id.

    Args:
        env_id: the training env's id.
        env_kwargs: its keyword arguments.
        policy: a baseline name of :func:`agents.policies.make_policy` (not ``sb3:``).
        episodes: episodes to record (>= 1), reset with seeds ``seed``, ``seed + 1``, ...
        seed: the first episode's reset seed.
        root: the datasets root the recording is written under.
        policy_params: the baseline's keyword arguments.
        progress: show progress bars (the episodes', and the baseline's own build's where it
            has one).

    Returns:
        The dataset's id.

    Raises:
        ValueError: an unknown baseline or one that cannot control this env (from
            :func:`~agents.policies.make_policy`), or ``episodes`` < 1.
    """
    if isinstance(episodes, bool) or not isinstance(episodes, int) or episodes < 1:
        raise ValueError(f"episodes must be an integer >= 1, got {episodes!r}")
    if policy.startswith("sb3:"):
        raise ValueError(f"policy must be a baseline (the demonstrations seed an SB3 agent), got "
                         f"{policy!r}")
    env = EpisodeRecorder(gym.make(env_id, **env_kwargs))
    try:
        params = dict(policy_params or {})
        if "progress" in constructor_parameters(BASELINES[policy]):  # its own build's bars
            params.setdefault("progress", progress)
        baseline = make_policy(policy, env=env, **params)
        if hasattr(baseline, "calibrate"):
            baseline.calibrate()
        errors = []
        for episode in tqdm(range(episodes), desc=f"{policy} demonstrations",
                            disable=not progress, leave=False):
            record = run_episode(env, baseline, seed=seed + episode)
            errors.append(float(np.mean(record["error_mm"])))
        dataset_id = demo_dataset_id(policy, env_id)
        steps = sum(len(episode["actions"]) for episode in env.episodes)
        card = (f"# {dataset_id}\n\nDemonstrations for an SB3 agent: the baseline `{policy}` "
                f"({policy_params or {}}) ran {episodes} episodes of `{env_id}` with "
                f"{env_kwargs} (reset seeds {seed}-{seed + episodes - 1}; online learners "
                f"learned as in the suite), {steps} steps; mean tracking error per episode "
                f"{', '.join(f'{e:.2f}' for e in errors)} mm. Written by "
                f"`python -m train --demos {policy}` (train/demonstrations.py).\n")
        write_dataset(dataset_id, env.buffers(), env_id=env_id, env_kwargs=env_kwargs,
                      observation_space=env.observation_space, action_space=env.action_space,
                      description=f"{episodes} episodes of {policy} on {env_id}",
                      algorithm_name=policy, card=card,
                      info={"policy": policy, "policy_params": policy_params or {},
                            "seed": seed, "mean_error_mm": errors},
                      root=root, force=True)
        return dataset_id
    finally:
        env.close()


def load_demonstrations(dataset_id: str, root: str | Path | None,
                        env: gym.Env) -> Demonstrations:
    """The transitions of dataset ``dataset_id`` (under ``root``), checked against ``env``'s
    observation and action spaces.

    Raises:
        ValueError: a dataset that does not load
            (:func:`soft_gym.datasets.store.load_dataset`), observations that are not a flat
            ``Box`` of ``env``'s shape, or actions not of ``env``'s action space.
    """
    dataset = load_dataset(dataset_id, root)
    obs_space, action_space = dataset.observation_space, dataset.action_space
    if not isinstance(env.observation_space, gym.spaces.Box) \
            or not isinstance(obs_space, gym.spaces.Box) \
            or obs_space.shape != env.observation_space.shape:
        raise ValueError(f"dataset {dataset_id!r} holds observations of {obs_space}; the "
                         f"training env's are {env.observation_space} (demonstrations need the "
                         "same flat observation)")
    if not isinstance(action_space, gym.spaces.Box) or action_space != env.action_space:
        raise ValueError(f"dataset {dataset_id!r} holds actions of {action_space}; the training "
                         f"env's are {env.action_space}")
    parts: dict[str, list] = {key: [] for key in ("obs", "next", "act", "rew", "term", "trunc",
                                                   "start")}
    for episode in dataset.iterate_episodes():
        observations = np.asarray(episode.observations, dtype=float)
        n = len(episode.actions)
        parts["obs"].append(observations[:n])
        parts["next"].append(observations[1:n + 1])
        parts["act"].append(np.asarray(episode.actions, dtype=float))
        parts["rew"].append(np.asarray(episode.rewards, dtype=float))
        parts["term"].append(np.asarray(episode.terminations, dtype=bool))
        parts["trunc"].append(np.asarray(episode.truncations, dtype=bool))
        start = np.zeros(n, dtype=bool)
        start[:1] = True
        parts["start"].append(start)
    stacked = {key: np.concatenate(value) for key, value in parts.items()}
    if not np.all(np.isfinite(stacked["obs"])) or not np.all(np.isfinite(stacked["next"])):
        raise ValueError(f"dataset {dataset_id!r} holds non-finite observations (a procedure's "
                         "samples, not env episodes?)")
    return Demonstrations(stacked["obs"], stacked["act"], stacked["rew"], stacked["next"],
                          stacked["term"], stacked["trunc"], stacked["start"], dataset_id)


def prime_normalization(model, demos: Demonstrations) -> None:
    """Start the model's ``VecNormalize`` statistics (if any) from the demonstrations: the
    observation mean and variance, and the discounted returns' variance, as ``VecNormalize``
    would have gathered them running the demonstrations itself."""
    normalization = model.get_vec_normalize_env()
    if normalization is None:
        return
    if normalization.norm_obs:
        normalization.obs_rms.update(demos.observations)
    if normalization.norm_reward:
        returns, discounted = np.empty(len(demos)), 0.0
        for i, (reward, start) in enumerate(zip(demos.rewards, demos.episode_starts)):
            discounted = reward + (0.0 if start else normalization.gamma * discounted)
            returns[i] = discounted
        normalization.ret_rms.update(returns)


def _normalized_observations(model, observations: np.ndarray) -> np.ndarray:
    normalization = model.get_vec_normalize_env()
    if normalization is None:
        return observations
    return normalization.normalize_obs(observations)


def clone_behaviour(model, demos: Demonstrations, *, epochs: int, batch_size: int = 256,
                    learning_rate: float = 1e-3, seed: int = 0,
                    progress: bool = False) -> list[float]:
    """Fit the actor's deterministic action to the demonstrated actions (MSE in the policy's
    [-1, 1] scale) for ``epochs`` passes of minibatch Adam; returns each epoch's mean loss.

    For TD3 and DDPG the target actor is set to the cloned actor."""
    policy = model.policy
    observations = torch.as_tensor(_normalized_observations(model, demos.observations),
                                   dtype=torch.float32, device=policy.device)
    targets = torch.as_tensor(policy.scale_action(demos.actions), dtype=torch.float32,
                              device=policy.device)
    optimizer = torch.optim.Adam(model.actor.parameters(), lr=learning_rate)
    generator = torch.Generator().manual_seed(seed)
    policy.set_training_mode(True)
    losses = []
    for _ in tqdm(range(epochs), desc="behaviour cloning", disable=not progress, leave=False):
        order = torch.randperm(len(demos), generator=generator)
        total = 0.0
        for start in range(0, len(demos), batch_size):
            batch = order[start:start + batch_size]
            predicted = policy._predict(observations[batch], deterministic=True)
            loss = torch.nn.functional.mse_loss(predicted, targets[batch])
            optimizer.zero_grad()
            loss.backward()
            optimizer.step()
            total += loss.item() * len(batch)
        losses.append(total / len(demos))
    policy.set_training_mode(False)
    if getattr(model, "actor_target", None) is not None:
        model.actor_target.load_state_dict(model.actor.state_dict())
    return losses


def seed_replay_buffer(model, demos: Demonstrations) -> None:
    """Add every demonstrated transition to the model's replay buffer (raw observations and
    rewards, actions in the policy's scale, truncations marked as timeouts)."""
    buffer = model.replay_buffer
    if len(demos) > buffer.buffer_size:
        raise ValueError(f"the demonstrations' {len(demos)} transitions exceed the replay "
                         f"buffer's buffer_size {buffer.buffer_size}: record fewer episodes or "
                         "raise buffer_size")
    scaled = model.policy.scale_action(demos.actions)
    for i in range(len(demos)):
        done = bool(demos.terminations[i] or demos.truncations[i])
        timeout = bool(demos.truncations[i] and not demos.terminations[i])
        buffer.add(demos.observations[i][None], demos.next_observations[i][None],
                   scaled[i][None], np.array([demos.rewards[i]]), np.array([done]),
                   [{"TimeLimit.truncated": timeout}])


@contextlib.contextmanager
def _actor_held(model) -> Iterator[None]:
    """The actor's optimizer makes no step while inside (its gradients are still computed)."""
    optimizer = model.actor.optimizer
    optimizer.step = lambda *args, **kwargs: None
    try:
        yield
    finally:
        del optimizer.step  # the class's own method again


def warm_up_critic(model, gradient_steps: int) -> None:
    """``gradient_steps`` of the algorithm's own update on the replay buffer with the actor
    held (the critic, its target and SAC's entropy coefficient learn)."""
    if gradient_steps <= 0:
        return
    with _actor_held(model):
        model.train(gradient_steps=gradient_steps, batch_size=model.batch_size)


def start_from_demonstrations(model, demos: Demonstrations, *, bc_epochs: int,
                              critic_warmup: int, seed: int,
                              progress: bool = False) -> dict[str, Any]:
    """Steps 2-3 of the module docstring on ``model`` (an off-policy SB3 model on the training
    env); returns the report kept in ``training.yaml``."""
    prime_normalization(model, demos)
    losses = clone_behaviour(model, demos, epochs=bc_epochs, seed=seed, progress=progress)
    seed_replay_buffer(model, demos)
    warm_up_critic(model, critic_warmup)
    model.learning_starts = 0
    return {"demonstrations": demos.source, "demo_steps": len(demos),
            "demo_episodes": int(np.sum(demos.episode_starts)),
            "bc_epochs": bc_epochs, "bc_loss_first": round(losses[0], 6) if losses else None,
            "bc_loss_last": round(losses[-1], 6) if losses else None,
            "critic_warmup_steps": critic_warmup}
