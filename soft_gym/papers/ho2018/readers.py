"""ho2018's dataset read back: the observations of ``lwpr_rwr``'s pre-training walk
(``soft-arm/ho2018/pretraining-v0``, written by ``python -m eval datasets ho2018``)."""

from __future__ import annotations

from typing import Any

import numpy as np

from soft_gym.datasets.training import DatasetRoot, paper_episode


def read_pretraining_walk(dataset_id: str, root: DatasetRoot,
                          expected: dict[str, Any]) -> np.ndarray:
    """The observations of ``lwpr_rwr``'s pre-training walk, as the env returned them (the
    reset's first), from ho2018's dataset.

    :param dataset_id: the dataset's id (``soft-arm/ho2018/pretraining-v0``).
    :param root: its datasets root (Minari's default when ``None``).
    :param expected: the controller's walk settings
        (:meth:`~agents.controllers.lwpr_rwr.LWPRRWRController.walk_key`).
    :returns: ``(steps + 1, n_obs)`` flat observations in the env's dtype.
    :raises ValueError: see :func:`check_settings` and :func:`~soft_gym.datasets.store.load_dataset`.
    """
    episode, _ = paper_episode(dataset_id, root, "ho2018", expected)
    return np.asarray(episode.observations)
