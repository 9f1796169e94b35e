"""Start a training run from a trained agent (rl-baselines3-zoo's ``--trained-agent``).

``python -m train --trained-agent AGENT ...`` makes a new run whose model starts from ``AGENT``'s
weights and VecNormalize statistics and trains on the new run's env and hyperparameters: an agent
trained fast on one env (e.g. the MuJoCo engine's batched arms with EM feedback) fine-tuned on
another that is slower to simulate (the PyBullet arm with the camera's fused feedback and visual
faults). The new run's ``training.yaml`` starts with the agent's own training segments, each
marked with the agent it came from (``trained_agent``) and the engine and feedback it trained
on, so an agent's budget (:func:`agents.policies.sb3.training_budget`) counts every step that
made it.

The agent must be of the run's algorithm, read the run's observations and write its actions;
where the run normalises observations the agent must carry its statistics (and the other way
round). Each mismatch is one ``ValueError`` naming ``trained_agent``.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

from agents.policies.run_dir import normalization_file
from agents.policies.sb3 import ALGORITHM_CLASSES, SB3Policy, training_segments
from soft_gym.engines import REFERENCE_ENGINE

TRAINED_AGENT_KEY = "trained_agent"
"""The key marking a ``training.yaml`` segment inherited from the agent a run started from."""


@dataclass(frozen=True)
class TrainedAgent:
    """A trained agent's files, checked (:func:`find_trained_agent`).

    Attributes:
        name: as given (a shipped agent's name, or a path).
        model_path: its model ``.zip``.
        normalization_path: its VecNormalize statistics, ``None`` where it trained without.
        algo: its algorithm (``python -m train``'s ``--algo`` name).
        config: its run's ``config.yaml`` (empty where there is none).
        segments: its ``training.yaml`` segments (empty where there is none).
        policy: the agent, loaded (what it reads and writes).
    """

    name: str
    model_path: Path
    normalization_path: Path | None
    algo: str
    config: dict
    segments: list
    policy: SB3Policy


def find_trained_agent(agent: str | Path, algo: str) -> TrainedAgent:
    """The files of ``agent`` (a run directory of ``python -m train``, a model ``.zip`` beside
    its statistics, or a shipped agent's name), loaded once to check them (a damaged model,
    missing statistics: :meth:`agents.policies.sb3.SB3Policy.load`'s ``ValueError``).

    Args:
        agent: the agent to start from.
        algo: the run's algorithm (``python -m train``'s ``--algo`` name).

    Returns:
        The agent's files, checked, and the agent loaded.

    Raises:
        ValueError: naming ``trained_agent``, where the agent does not load, its training
            record is malformed, or its algorithm is not ``algo``.
    """
    try:
        policy = SB3Policy.load(agent)
    except ValueError as error:
        raise ValueError(f"trained_agent {str(agent)!r}: {error}") from None
    model_path = Path(policy.model_path)
    config = policy.config or {}
    agent_algo = str(config.get("algo", "")).lower()
    if not agent_algo:  # a model without its run's config: the class it was saved as
        agent_algo = next(name for name, cls in ALGORITHM_CLASSES.items()
                          if cls == type(policy.model).__name__)
    if agent_algo != algo:
        raise ValueError(f"trained_agent {str(agent)!r} is a {agent_algo} agent, the run trains "
                         f"{algo}: give --algo {agent_algo} or an agent of {algo}")
    normalization_path = None
    if policy.normalization is not None:
        normalization_path = normalization_file(model_path)
    try:
        segments = training_segments(agent) or []
    except ValueError as error:
        raise ValueError(f"trained_agent {str(agent)!r}: {error}") from None
    return TrainedAgent(str(agent), model_path, normalization_path, agent_algo, config, segments,
                        policy)


def check_fits(agent: TrainedAgent, env, normalized: bool) -> None:
    """``ValueError`` naming ``trained_agent`` unless the agent reads the observations ``env``
    gives (the run's, vectorised or not) and writes the actions it takes
    (:meth:`~agents.policies.sb3.SB3Policy.check_env`), and trained with normalised
    observations where the run normalises them (``normalized``) and only there."""
    try:
        agent.policy.check_env(env)
    except ValueError as error:
        refusal = ValueError(f"trained_agent {agent.name!r} reads and writes other observations "
                             f"or actions than this run's env: {error}")
        refusal.trained_preset = getattr(error, "trained_preset", None)  # another arm's agent
        raise refusal from None
    if normalized != (agent.normalization_path is not None):
        trained = "with" if agent.normalization_path else "without"
        raise ValueError(
            f"trained_agent {agent.name!r} trained {trained} normalised observations and this run "
            f"{'normalises' if normalized else 'does not'}: its weights expect the other scale "
            f"(set the recipe's normalize to match)")


def inherited_segments(agent: TrainedAgent) -> list[dict[str, Any]]:
    """The agent's training segments, each marked with the agent (``trained_agent``) and the
    engine and feedback it trained on, to open the new run's ``training.yaml`` (a segment marked
    already, from an agent the agent was itself fine-tuned from, keeps its marks)."""
    env_kwargs = agent.config.get("env_kwargs") or {}
    marks = {TRAINED_AGENT_KEY: Path(agent.name).name if Path(agent.name).exists() else agent.name,
             "engine": str(env_kwargs.get("engine", REFERENCE_ENGINE)),
             "feedback": env_kwargs.get("feedback")}
    # a segment the agent itself inherited keeps the marks of the agent it came from
    return [{**segment, **{key: value for key, value in marks.items() if key not in segment}}
            for segment in agent.segments]


def load_trained_model(agent: TrainedAgent, algo_cls, env, algo_kwargs: dict, seed: int):
    """The agent's model on ``env`` (:func:`check_fits`; wrapped in the agent's statistics
    where the run normalises), with the run's hyperparameters (``algo_kwargs``, action noise
    built) over the saved ones and ``seed``; ``ValueError`` naming ``trained_agent`` where the
    network differs (``policy_kwargs``)."""
    try:
        model = algo_cls.load(str(agent.model_path), env=env, device="cpu", **algo_kwargs)
    except (ValueError, KeyError) as error:  # spaces or policy_kwargs unlike the agent's
        raise ValueError(f"trained_agent {agent.name!r} does not fit this run: {error}") from None
    model.set_random_seed(seed)
    return model
