"""zou2022's dataset read back: the ASES-labelled data set ``encoder_dnn`` learns from
(``soft-arm/zou2022/stereo-labels-v0``, written by ``python -m eval datasets zou2022``)."""

from __future__ import annotations

from typing import Any

import numpy as np

from soft_gym.datasets.training import DatasetRoot, paper_episode, procedure_rows


def read_zou_dataset(dataset_id: str, root: DatasetRoot, expected: dict[str, Any]):
    """zou2022's data set (:class:`~soft_gym.papers.zou2022.shape_dnn.ZouDataset`, its split
    included) from its dataset.

    :param dataset_id: the dataset's id (``soft-arm/zou2022/stereo-labels-v0``).
    :param root: its datasets root (Minari's default when ``None``).
    :param expected: the method's collection settings
        (:func:`~soft_gym.papers.zou2022.dataset.dataset_key`).
    :raises ValueError: see :func:`check_settings` and :func:`~soft_gym.datasets.store.load_dataset`.
    """
    from soft_gym.papers.zou2022.shape_dnn import ZouDataset

    episode, info = paper_episode(dataset_id, root, "zou2022", expected)
    infos = episode.infos
    split = procedure_rows(infos["split"])
    data = ZouDataset(procedure_rows(infos["command_pa"]), procedure_rows(episode.observations["encoder"]),
                      procedure_rows(infos["stereo_labels_m"]), procedure_rows(infos["true_points_m"]),
                      procedure_rows(infos["augmented"]) == 1.0, int(info["settings"]["n_lost"]))
    data.train, data.validation, data.test = (np.flatnonzero(split == index)
                                              for index in range(3))
    return data
