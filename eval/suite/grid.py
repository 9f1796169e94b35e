"""The grid of a suite: its spec expanded into cells, one run each, every cell keyed by the hash of
its resolved config (:mod:`eval.suite`, "Cells and keys")."""

from __future__ import annotations

import copy
import hashlib
import json
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from eval.suite.spec import ArmEntry, SuiteError, SuiteSpec

ENV_ID = "SoftArmTrack-v0"
"""Every suite run tracks a path (the last-cycle error is the figure of merit)."""

KEY_DIGITS = 16
"""Hex digits of a cell key (64 bits of the SHA-256)."""


@dataclass(frozen=True)
class Cell:
    """One run: its ``key`` (hash of ``config``), ``labels`` for tables and resolved ``config``."""

    key: str
    labels: dict[str, Any]
    config: dict[str, Any]


def canonical_json(value: Any) -> str:
    """``value`` as canonical JSON: sorted keys, no spaces, ASCII, tuples as lists."""
    return json.dumps(value, sort_keys=True, separators=(",", ":"), ensure_ascii=True,
                      allow_nan=False)


def cell_key(config: Mapping[str, Any]) -> str:
    """The key of a resolved config: the first :data:`KEY_DIGITS` hex digits of the SHA-256 of
    its canonical JSON."""
    return hashlib.sha256(canonical_json(config).encode("ascii")).hexdigest()[:KEY_DIGITS]


def arm_env(arm: ArmEntry, path: str) -> dict[str, Any]:
    """The env keyword arguments of every run of ``arm`` on ``path``: the suite's own
    (preset, path, cycles, feedback), then the arm's ``env``."""
    kwargs: dict[str, Any] = {"preset": arm.preset, "path": path, "cycles": arm.cycles}
    if arm.feedback is not None:
        kwargs["feedback"] = arm.feedback
    kwargs.update(copy.deepcopy(arm.env))
    return kwargs


def expand(spec: SuiteSpec) -> list[Cell]:
    """The cells of ``spec`` (arm x path x condition x policy x seed, in that nesting order).

    Raises:
        ValueError: two cells have the same resolved config.
    """
    cells, seen = [], {}
    for arm in spec.arms:
        for path in arm.paths:
            for condition, condition_kwargs in arm.conditions.items():
                for entry in arm.policies:
                    for seed in spec.seeds:
                        env_kwargs = {**arm_env(arm, path), **copy.deepcopy(condition_kwargs),
                                      **copy.deepcopy(entry.env)}
                        params = copy.deepcopy(entry.params)
                        params.update({name: seed for name in entry.seed_params})
                        config = {"env_id": ENV_ID, "env_kwargs": env_kwargs,
                                  "policy": entry.name, "policy_params": params, "seed": seed,
                                  "cycles": arm.cycles}
                        labels = {"preset": arm.preset, "path": path, "condition": condition,
                                  "policy": entry.label, "seed": seed}
                        key = cell_key(config)
                        if key in seen:
                            raise SuiteError(spec.source, f"arms.{arm.preset}",
                                             f"runs {label_text(seen[key])} and "
                                             f"{label_text(labels)} have the same config: "
                                             f"make their conditions or policies differ")
                        seen[key] = labels
                        cells.append(Cell(key=key, labels=labels, config=config))
    return cells


def label_text(labels: Mapping[str, Any]) -> str:
    """A cell's labels as ``preset/path/condition/policy/seed`` (progress and error messages)."""
    return "/".join(str(labels.get(k)) for k in ("preset", "path", "condition", "policy", "seed"))

