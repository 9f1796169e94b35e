"""zhao2021's dataset read back: the exploration ``strain_sr`` and ``local_ik_asdm`` learn from
(``soft-arm/zhao2021/exploration-v0``, written by ``python -m eval datasets zhao2021``)."""

from __future__ import annotations

from typing import Any

from soft_gym.datasets.training import DatasetRoot, paper_episode, procedure_rows


def read_exploration(dataset_id: str, root: DatasetRoot, expected: dict[str, Any]):
    """zhao2021's exploration (:class:`~soft_gym.papers.zhao2021.shape_exploration.ShapeDataset`)
    from its dataset.

    :param dataset_id: the dataset's id (``soft-arm/zhao2021/exploration-v0``).
    :param root: its datasets root (Minari's default when ``None``).
    :param expected: the method's collection settings
        (:func:`~soft_gym.papers.zhao2021.exploration.exploration_key`).
    :raises ValueError: see :func:`check_settings` and :func:`~soft_gym.datasets.store.load_dataset`.
    """
    from soft_gym.papers.zhao2021.shape_exploration import ShapeDataset

    episode, _ = paper_episode(dataset_id, root, "zhao2021", expected)
    infos = episode.infos
    return ShapeDataset(pressures_pa=procedure_rows(infos["command_pa"]),
                        readings=procedure_rows(episode.observations["strain"]),
                        key_points_m=procedure_rows(infos["key_points_m"]),
                        backbone_m=procedure_rows(infos["backbone_m"]),
                        tip_load_kg=procedure_rows(infos["tip_load_kg"]))
