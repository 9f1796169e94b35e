"""A suite's runs as Minari datasets: one per arm and condition (``python -m eval suite SPEC
--record minari``).

``run_suite(..., record=True)`` keeps each run's episode under ``<out>/episodes``
(:func:`eval.suite.store.write_episode`); :func:`write_suite_datasets` groups them by arm and
condition and writes ``soft-arm/suite-<suite>/<arm>-<condition>-v0`` under
``<out>/datasets``. A dataset holds one observation and action space, so where the policies of
one arm and condition read different observation parts or act in another action mode (an
agent trained with its own interface), each layout is its own dataset, its id ending in the
observation parts (and the action mode where it is not absolute). Each episode's metadata
names its ``policy``, ``seed``, ``path``, the run's ``key``, ``env_id`` and ``env_kwargs``
(the env that ran it: ``gymnasium.make(env_id, **env_kwargs)`` and ``reset(seed=seed)`` replay
it). The datasets are rebuilt from the episodes on every call (they are the suite's own output,
like its report).
"""

from __future__ import annotations

import os
import pickle
import re
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from eval.datasets.cards import suite_card
from soft_gym.datasets.episodes import episode_buffer
from soft_gym.datasets.store import write_dataset
from eval.suite.grid import Cell
from eval.suite.store import episode_path, read_record

DATASETS_DIR = "datasets"
"""The datasets root under a suite's output directory."""


def _slug(text: Any) -> str:
    """``text`` in a dataset id's alphabet (lower case letters, digits, '.', '_', '-')."""
    return re.sub(r"[^a-z0-9_.-]+", "-", str(text).lower()).strip("-.") or "x"


def _layout(episode: dict[str, Any]) -> tuple:
    return (tuple(episode["obs_parts"]), episode["obs_format"], episode["action_mode"])


def _layout_suffix(layout: tuple) -> str:
    parts, obs_format, action_mode = layout
    suffix = "-".join(parts) + ("" if obs_format == "flat" else f"-{obs_format}")
    return suffix + ("" if action_mode == "absolute" else f"-{action_mode}")


def write_suite_datasets(suite: str, out: str | os.PathLike, cells: Sequence[Cell],
                         root: str | os.PathLike | None = None) -> dict[str, Any]:
    """Write the recorded episodes of ``cells`` as one dataset per arm, condition (and
    observation layout) under ``root`` (default ``<out>/datasets``).

    Args:
        suite: the suite's name (the ids' group ``suite-<name>``).
        out: the suite's output directory.
        cells: the suite's cells.
        root: the datasets root.

    Returns:
        ``{"datasets": {id: episodes}, "missing": [cell keys without an episode (runs n/a,
        failed, or finished before recording)], "root": path}``.
    """
    root = Path(out) / DATASETS_DIR if root is None else Path(root)
    groups: dict[tuple, list[tuple[Cell, dict[str, Any]]]] = {}
    missing = []
    for cell in cells:
        path = episode_path(out, cell.key)
        record = read_record(out, cell.key)
        if not path.is_file() or record is None or record.get("status") != "done":
            missing.append(cell.key)
            continue
        with path.open("rb") as file:
            episode = pickle.load(file)
        labels = cell.labels
        groups.setdefault((labels["preset"], labels["condition"], _layout(episode)),
                          []).append((cell, episode))
    layouts: dict[tuple, int] = {}
    for preset, condition, _ in groups:
        layouts[(preset, condition)] = layouts.get((preset, condition), 0) + 1
    written: dict[str, int] = {}
    for (preset, condition, layout), members in groups.items():
        name = f"{_slug(preset)}-{_slug(condition)}"
        if layouts[(preset, condition)] > 1:
            name += f"-{_slug(_layout_suffix(layout))}"
        dataset_id = f"soft-arm/suite-{_slug(suite)}/{name}-v0"
        first = members[0][1]
        observation_space, action_space = first["observation_space"], first["action_space"]
        metadata = [{"policy": cell.labels["policy"], "seed": cell.labels["seed"],
                     "path": cell.labels.get("path"), "key": cell.key,
                     "env_id": episode["env_id"], "env_kwargs": episode["env_kwargs"]}
                    for cell, episode in members]
        policies = sorted({str(cell.labels["policy"]) for cell, _ in members})
        steps = sum(len(episode["rewards"]) for _, episode in members)
        card = suite_card(dataset_id, suite, members[0][0].labels, policies, len(members),
                          steps, first["env_id"], first["env_kwargs"])
        write_dataset(dataset_id, [episode_buffer(episode, i)
                                   for i, (_, episode) in enumerate(members)],
                      env_id=first["env_id"], env_kwargs=first["env_kwargs"],
                      observation_space=observation_space, action_space=action_space,
                      description=f"suite {suite}: {preset}, {condition}: {', '.join(policies)}",
                      algorithm_name=", ".join(policies), card=card,
                      info={"suite": suite, "preset": preset, "condition": condition},
                      episode_metadata=metadata, root=root, force=True)
        written[dataset_id] = len(members)
    return {"datasets": written, "missing": missing, "root": root}
