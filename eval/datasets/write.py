"""Writing one paper's dataset: check the target, collect, write, card (``python -m eval
datasets`` calls :func:`write_paper_dataset` once per paper)."""

from __future__ import annotations

import os
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from eval.datasets.cards import paper_card
from eval.datasets.papers import PAPER_DATASETS
from soft_gym.datasets.store import dataset_dir, write_dataset

SIZES = ("paper", "quick")
"""Named sizes of :func:`write_paper_dataset` (each paper's ``paper_size`` / ``quick_size``)."""


@dataclass
class Written:
    """One written dataset: its id, directory, samples, size on disk (bytes) and the seconds
    spent collecting and writing."""

    dataset_id: str
    path: Path
    n_samples: int
    size_bytes: int
    collect_s: float
    write_s: float


def resolve_size(paper: str, size: str | dict[str, int]) -> dict[str, int]:
    """``size`` as the paper's sample counts: ``"paper"``, ``"quick"`` or a dict of counts.

    Raises:
        ValueError: another name, or a dict naming counts the paper does not take.
    """
    recipe = PAPER_DATASETS[paper]
    if isinstance(size, str):
        if size not in SIZES:
            raise ValueError(f"size must be one of {list(SIZES)} or a dict of "
                             f"{sorted(recipe.paper_size)}, got {size!r}")
        return dict(recipe.paper_size if size == "paper" else recipe.quick_size)
    if not isinstance(size, dict) or not set(size) <= set(recipe.paper_size):
        raise ValueError(f"size of {paper} must be one of {list(SIZES)} or a dict of "
                         f"{sorted(recipe.paper_size)}, got {size!r}")
    return {**recipe.paper_size, **size}


def check_target(paper: str, root: str | os.PathLike | None, force: bool) -> Path:
    """The directory ``paper``'s dataset goes to, refused (``ValueError``) if a dataset is there
    and ``force`` is off (checked before any collection)."""
    recipe = PAPER_DATASETS[paper]
    target = dataset_dir(recipe.dataset_id, root)
    if target.exists() and not force:
        raise ValueError(f"dataset {recipe.dataset_id!r} already exists at {str(target)!r}: "
                         "give --force (force=True) to replace it")
    return target


def directory_size(path: Path) -> int:
    """Bytes of every file under ``path``."""
    return sum(p.stat().st_size for p in path.rglob("*") if p.is_file())


def write_paper_dataset(paper: str, root: str | os.PathLike | None = None,
                        size: str | dict[str, int] = "paper", seed: int = 0,
                        force: bool = False, progress: bool = True,
                        use_cache: bool = True) -> Written:
    """Collect ``paper``'s data (:data:`~eval.datasets.papers.PAPER_DATASETS`) and write it as
    its Minari dataset under ``root``.

    :param paper: a key of :data:`PAPER_DATASETS`.
    :param root: datasets root (Minari's default when ``None``).
    :param size: ``"paper"`` (the paper's sample counts), ``"quick"`` or a dict of counts.
    :param seed: the procedure's seed.
    :param force: replace an existing dataset.
    :param progress: show the procedure's progress bars.
    :param use_cache: reuse a collection the calibration cache already holds (zhao2021,
        zou2022) and keep a new one there.
    :raises ValueError: an unknown paper or size, or an existing dataset without ``force``
        (before any collection).
    """
    recipe = PAPER_DATASETS[paper]
    counts = resolve_size(paper, size)
    check_target(paper, root, force)
    start = time.perf_counter()
    collection = recipe.collect(counts, seed=seed, progress=progress, use_cache=use_cache)
    collect_s = time.perf_counter() - start
    settings = {**collection.settings, "procedure": collection.procedure}
    card = paper_card(paper, recipe.dataset_id, settings, collection.n_samples,
                      collection.env_id, collection.env_kwargs)
    path = write_dataset(
        recipe.dataset_id, collection.buffers(), env_id=collection.env_id,
        env_kwargs=collection.env_kwargs, observation_space=collection.observation_space,
        action_space=collection.action_space,
        description=f"{paper}: {recipe.summary} ({collection.n_samples} samples).",
        algorithm_name=collection.procedure, card=card,
        info={"paper": paper, "settings": collection.settings, "collect_s": collect_s,
              "match": collection.match},
        episode_metadata=[{"procedure": collection.procedure, "paper": paper, "seed": seed}
                          for _ in collection.episodes],
        root=root, force=force)
    write_s = time.perf_counter() - start - collect_s
    size_bytes = directory_size(path)
    (path / "card.md").write_text(paper_card(paper, recipe.dataset_id, settings,
                                             collection.n_samples, collection.env_id,
                                             collection.env_kwargs, size_bytes))
    return Written(recipe.dataset_id, path, collection.n_samples, size_bytes, collect_s,
                   write_s)


def written_summary(written: Written) -> dict[str, Any]:
    """A JSON-ready line of the summary table."""
    return {"dataset_id": written.dataset_id, "path": str(written.path),
            "samples": written.n_samples, "size_mb": round(written.size_bytes / 1e6, 3),
            "collect_s": round(written.collect_s, 2), "write_s": round(written.write_s, 2)}
