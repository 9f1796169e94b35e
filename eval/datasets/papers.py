"""The papers' exploration and calibration data as Minari datasets: what every paper's collector
shares (:class:`Collection`, :class:`PaperDataset`, the env helpers) and :data:`PAPER_DATASETS`.

Each paper's collector lives in its evaluation folder (``eval/papers/<key>/dataset.py``, its
``DATASET``). Each collector runs the procedure the paper's method learns from, through the procedure's own
function, on the arm and sensors of an env it makes (ground-truth feedback, so nothing
calibrates), and returns a :class:`Collection`: the episodes, the env to recover and what the
data card needs. :data:`PAPER_DATASETS` names them:

| paper    | id                                   | procedure                                          |
|----------|--------------------------------------|----------------------------------------------------|
| zhao2021 | ``soft-arm/zhao2021/exploration-v0`` | :func:`~soft_gym.papers.zhao2021.exploration.cached_exploration` |
| zou2022  | ``soft-arm/zou2022/stereo-labels-v0``| :func:`~soft_gym.papers.zou2022.dataset.cached_dataset` |
| wang2023 | ``soft-arm/wang2023/calibration-v0`` | :func:`~soft_gym.papers.wang2023.calibration.calibrate_pipeline` |
| ho2018   | ``soft-arm/ho2018/pretraining-v0``   | ``lwpr_rwr``'s pre-training walk                   |

zhao2021, zou2022 and wang2023 hold commands to equilibrium on a private simulator, so their
samples are stored as :func:`~soft_gym.datasets.episodes.procedure_episode` (one episode); ho2018's
walk is a Gymnasium episode of a copy of the env and is recorded as it ran
(:class:`~soft_gym.datasets.episodes.EpisodeRecorder`, handed to the walk through its ``wrap_env``
seam), so replaying its actions in the recovered env gives its observations back bit for bit.
Each collection also stores ``match``, the settings its method checks before it trains from the
dataset (:mod:`soft_gym.datasets.training`).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

import gymnasium as gym
import numpy as np

from eval.papers import PaperParts
from soft_gym._validation import require_integer
from soft_gym.datasets.episodes import episode_buffer


@dataclass
class Collection:
    """What a collector returns.

    Attributes:
        episodes: episode arrays (:func:`~soft_gym.datasets.episodes.procedure_episode` or
            :meth:`~soft_gym.datasets.episodes.EpisodeRecorder.episode_arrays`).
        env_id, env_kwargs: the env ``recover_environment()`` makes.
        observation_space, action_space: the stored spaces.
        procedure: the function that collected the samples (dotted name).
        settings: the procedure's settings (sizes, seed, ...), for the metadata and the card.
        raw: what the procedure itself returned (for tests and further use).
        match: what the method that trains on the data checks before it does (its arm, sensor
            models, sizes, seed; :mod:`soft_gym.datasets.training`), stored as metadata.
    """

    episodes: list[dict[str, Any]]
    env_id: str
    env_kwargs: dict[str, Any]
    observation_space: gym.Space
    action_space: gym.Space
    procedure: str
    settings: dict[str, Any]
    raw: Any = None
    match: dict[str, Any] = field(default_factory=dict)

    def buffers(self) -> list:
        """The episodes as Minari episode buffers."""
        return [episode_buffer(arrays, i) for i, arrays in enumerate(self.episodes)]

    @property
    def n_samples(self) -> int:
        """Steps over all episodes."""
        return int(sum(len(arrays["rewards"]) for arrays in self.episodes))


@dataclass(frozen=True)
class PaperDataset:
    """One paper's dataset: its id, its collector and its sizes.

    Attributes:
        paper: the paper's key.
        dataset_id: the Minari id.
        collect: ``collect(size, seed, progress, use_cache) -> Collection``.
        paper_size: the paper's sample counts (the collector's ``size``).
        quick_size: small counts for a quick look and the tests.
        summary: one line on what is recorded.
        card: the data card's text: ``title``, ``how``, ``observations``, ``infos``,
            ``biases`` and optionally ``layout`` (:func:`~eval.datasets.cards.paper_card`).
    """

    paper: str
    dataset_id: str
    collect: Callable[..., Collection]
    paper_size: dict[str, int] = field(default_factory=dict)
    quick_size: dict[str, int] = field(default_factory=dict)
    summary: str = ""
    card: Mapping[str, str] = field(default_factory=dict)


def env_calibration_context(env_id: str, env_kwargs: dict[str, Any]):
    """The calibration context (arm, fresh sensors as the env configures them) of the env
    ``env_id`` with ``env_kwargs``; the env is closed again."""
    import soft_gym  # noqa: F401 - registers the env ids

    env = gym.make(env_id, **env_kwargs)
    try:
        return env.unwrapped._calibration_context()
    finally:
        env.close()


def absolute_actions(spec, command_pa: np.ndarray) -> np.ndarray:
    """The absolute-mode env actions of the commanded pressures ``(n, n_chambers)`` (Pa)."""
    from soft_gym.robots.actuation import Actuation

    actuation = Actuation(spec, "absolute")
    return np.array([actuation.action(row) for row in np.asarray(command_pa, dtype=float)],
                    dtype=np.float32)


def pressure_action_space(spec) -> gym.spaces.Box:
    return gym.spaces.Box(-1.0, 1.0, (spec.n_chambers,), np.float32)


def sample_count(size: dict[str, Any], name: str, low: int) -> int:
    if name not in size:
        raise ValueError(f"size must give {name!r}, got {sorted(size)}")
    return require_integer(f"size[{name!r}]", size[name], low)


PAPER_DATASETS: Mapping[str, PaperDataset] = PaperParts("paper dataset", "DATASET", single=True)
"""The papers' datasets by paper key (each defined in ``eval/papers/<key>/dataset.py``)."""
