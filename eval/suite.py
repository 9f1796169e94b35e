"""The four-arm benchmark suite: a declarative grid of arms, paths, conditions, policies and seeds.

A suite is a YAML file (the bundled ones are ``eval/suites/<name>.yaml``: ``default``, ``small``).
It is loaded and checked (:func:`load_suite`, :func:`check_suite`), expanded into cells, one run
each (:func:`expand`), and run (:func:`run_suite`), every finished run written at once as one
record; :mod:`eval.suite_report` turns the records into the leaderboard, aggregate scores and plots.

Schema
------
Top level (every key other than these is refused):

========================= ======== ===================================================
key                       required meaning
========================= ======== ===================================================
``name``                  yes      suite name (letters, digits, ``_.-``)
``description``           no       free text
``seeds``                 yes      episode seeds, distinct integers >= 0
``cycles``                no       path cycles per run (default 2); an arm may override
``arms``                  yes      preset name -> arm block (below), run in file order
========================= ======== ===================================================

Arm block, ``arms.<preset>`` (a preset of :data:`soft_gym.robots.presets.PRESETS`):

========================= ======== ===================================================
key                       required meaning
========================= ======== ===================================================
``paths``                 yes      path names (``circle``, ``pentagram``, ``rectangle``, ...)
``feedback``              no       feedback source of every run on this arm (the env's
                                   ``feedback=``; default: the env's default, ``fused``)
``env``                   no       further env keyword arguments of every run on this arm
``cycles``                no       path cycles per run on this arm (default: the suite's)
``conditions``            yes      condition name -> env keyword arguments (``{}``: nominal)
``policies``              yes      list of policy entries (below)
========================= ======== ===================================================

A condition is a named bundle of keyword arguments of ``gymnasium.make("SoftArmTrack-v0", ...)``
(:class:`soft_gym.envs.soft_arm_env.SoftArmEnv`): ``scenario`` (loads, :mod:`soft_gym.scenarios`),
``faults`` (visual faults, :mod:`soft_gym.sensors.faults`), ``feedback``, ``sensing``,
``sensors``, ``sensor_config``, ``speed_m_s``, ... (:data:`ENV_KEYS`). ``preset``, ``path``,
``cycles`` and ``task`` are the suite's own and may not appear in ``env`` or a condition.

Policy entry: a string (a baseline of :data:`agents.policies.BASELINES`, ``sb3:PATH`` or
``sb3:<shipped agent>``) or a mapping:

========================= ======== ===================================================
key                       required meaning
========================= ======== ===================================================
``name``                  yes      as the string form
``label``                 no       name in tables (default: the baseline's name or the
                                   agent's directory name); distinct within an arm
``params``                no       keyword arguments of the baseline (e.g. ``kp: 0.06``)
``seed_params``           no       parameter names that receive the run's seed (e.g.
                                   ``[seed]`` for the pre-training of ``lwpr_rwr``)
``env``                   no       env keyword arguments this policy needs, applied last
                                   (``local_ik_asdm`` reads ``strain``: its ``obs`` default
                                   is :data:`POLICY_ENV_DEFAULTS`)
========================= ======== ===================================================

SB3 agents take no ``params``; their env gets the observation and action interface they were
trained with (:func:`eval.runner.build`).

Cells and keys
--------------
One cell per arm x path x condition x policy x seed, in that nesting order. Its resolved config
is ``{"env_id", "env_kwargs", "policy", "policy_params", "seed", "cycles"}`` with ``env_kwargs``
merged as ``preset, path, cycles, feedback`` < arm ``env`` < condition < policy ``env``. Its key
is the first 16 hex digits of the SHA-256 of the config as canonical JSON (sorted keys, no
spaces; ``1`` and ``1.0`` differ): the same config gives the same key in any suite, and changing
one keyword argument changes the keys of the cells that use it and no other. Labels (names in
tables) are not part of the key; two cells with equal configs are refused.

Validation
----------
:func:`check_suite` refuses, before any run, with a ``ValueError`` naming the file, the key
(``arms.wang2023.conditions.load_10g``) and what is allowed: an unknown key at any level, an
unknown preset, path, feedback source, policy or policy parameter, and every value the env
refuses. Each distinct env configuration is built once through the env's own checks (loads,
faults, feedback options, the arm's maximum load, ...) without calibrating its feedback source,
which is the expensive part (seconds to minutes, cached on disk) and is left to the runs; each
baseline is then made on it, once with the entry's parameters and once with its defaults: a
baseline refusing the arm with its defaults too is not a suite error but an ``n/a`` cell (below);
one refusing only the given parameters is. SB3 agents are loaded once each.

Running
-------
:func:`run_suite` runs every cell whose record is not there yet (all of them without
``resume``). A run that finishes writes ``out/records/<key>.json`` at once and, when it ran, the
per-step record ``out/records/<key>.npz`` (the arrays of :func:`eval.runner.run_episode`: m, s,
Pa), each to a temporary file renamed into place, the JSON last, so a killed suite leaves no
half record and ``resume`` redoes exactly the unfinished cells. The JSON record::

    {"key", "suite", "labels": {"preset", "path", "condition", "policy", "seed"},
     "config": resolved config, "status": "done" | "n/a", "reason": why n/a (else null),
     "metrics": {"last_cycle_error_mm", "mean_error_mm", "max_error_mm", "rmse_error_mm",
                 "final_error_mm", "last_cycle_max_error_mm", "path_deviation_mm",
                 "last_cycle_path_deviation_mm", "feedback_error_mm", "per_cycle_error_mm",
                 "per_cycle_path_deviation_mm", "n_steps", "n_cycles"} (null when n/a),
     "wall_s", "versions": {soft_arm_gym, gymnasium, stable_baselines3, torch, numpy,
     pybullet, python}, "git_revision", "steps_file"}

``n/a``: the policy could not be set up on the cell's env (a ``ValueError`` while the env and
policy are made and calibrated, e.g. ``cc_model`` and ``hybrid_gpr`` on a two-segment arm, an
agent on an arm whose observation it cannot read); the reason is the error's text. Any other
error leaves no record: the other runs go on, and :class:`SuiteRunError` lists the failed cells
at the end (their tracebacks in ``out/errors/<key>.txt``); ``resume`` retries them.

Backends. A backend is a function ``map(fn, items, workers)`` that applies ``fn`` to every item
and yields the results as they complete (:data:`MapFunction`). ``"process"`` (default) runs them
in ``workers`` spawned processes (in this process when ``workers == 1``), ``"serial"`` in this
process. Another backend (a cluster) is registered from its own module with
:func:`register_backend` and chosen by name, or passed as the function itself. Cells are
ordered round-robin over (arm, policy, seed) groups, so that the first run of each group, which
builds and caches its calibration or pre-training, starts before its siblings.
"""

from __future__ import annotations

import contextlib
import copy
import hashlib
import inspect
import json
import math
import os
import platform
import re
import subprocess
import tempfile
import time
import traceback
from collections.abc import Callable, Iterator, Mapping, Sequence
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np
import yaml

ENV_ID = "SoftArmTrack-v0"
"""Every suite run tracks a path (the last-cycle error is the figure of merit)."""

SUITES_DIR = Path(__file__).resolve().parent / "suites"
"""The bundled suites, ``<name>.yaml``."""

KEY_DIGITS = 16
"""Hex digits of a cell key (64 bits of the SHA-256)."""

TOP_KEYS = ("name", "description", "seeds", "cycles", "arms")
ARM_KEYS = ("paths", "feedback", "env", "cycles", "conditions", "policies")
POLICY_KEYS = ("name", "label", "params", "seed_params", "env")
SUITE_ENV_KEYS = ("preset", "path", "cycles", "task")
"""Env keyword arguments the suite sets itself."""
_NOT_FOR_TRACKING = ("render_mode", "render_size", "episode_steps", "target_m", "start_m",
                     "tolerance_mm")
DEFAULT_CYCLES = 2

POLICY_ENV_DEFAULTS: dict[str, dict[str, Any]] = {
    "local_ik_asdm": {"obs": ["pose", "target", "strain", "pressure"]},
}
"""Env keyword arguments a baseline needs, applied when its entry has no ``env`` of its own."""

_NAME = re.compile(r"^[A-Za-z0-9_.-]+$")


def _env_keys() -> tuple[str, ...]:
    from soft_gym.envs.config import CONFIG_FIELDS

    return tuple(name for name in CONFIG_FIELDS
                 if name not in SUITE_ENV_KEYS and name not in _NOT_FOR_TRACKING)


ENV_KEYS: tuple[str, ...] = _env_keys()
"""Env keyword arguments a condition, an arm's ``env`` or a policy's ``env`` may set."""


class SuiteError(ValueError):
    """A suite file that cannot be run: names the file, the key and what is allowed."""

    def __init__(self, source: str, key: str, message: str) -> None:
        self.source, self.key = source, key
        text = f"{source}: {key}: {message}" if key else f"{source}: {message}"
        super().__init__(" ".join(text.split()))  # one line


class SuiteRunError(RuntimeError):
    """Runs that failed with an error other than a refusal (no record was written for them)."""

    def __init__(self, failures: list[dict[str, Any]]) -> None:
        self.failures = failures
        names = ", ".join(f"{f['key']} ({_label_text(f['labels'])}: {f['error']})"
                          for f in failures[:5])
        more = f" and {len(failures) - 5} more" if len(failures) > 5 else ""
        super().__init__(f"{len(failures)} run(s) failed: {names}{more}; tracebacks in "
                         f"errors/<key>.txt; run again with resume to retry them")


# ---------------------------------------------------------------------------------- the spec
@dataclass(frozen=True)
class PolicyEntry:
    """One policy of an arm: ``name`` (baseline or ``sb3:PATH``), table ``label``, baseline
    ``params``, ``seed_params`` (parameters given the run's seed) and its ``env`` kwargs."""

    name: str
    label: str
    params: dict[str, Any] = field(default_factory=dict)
    seed_params: tuple[str, ...] = ()
    env: dict[str, Any] = field(default_factory=dict)

    @property
    def is_agent(self) -> bool:
        return self.name.startswith("sb3:")


@dataclass(frozen=True)
class ArmEntry:
    """One arm of a suite (see the module docstring's schema)."""

    preset: str
    paths: tuple[str, ...]
    feedback: str | None
    env: dict[str, Any]
    cycles: int
    conditions: dict[str, dict[str, Any]]
    policies: tuple[PolicyEntry, ...]


@dataclass(frozen=True)
class SuiteSpec:
    """A loaded suite: its entries, and the file it came from (``source``, its ``text`` and the
    SHA-256 of the text, ``sha256``)."""

    name: str
    description: str
    seeds: tuple[int, ...]
    cycles: int
    arms: tuple[ArmEntry, ...]
    source: str
    text: str
    sha256: str

    def with_seeds(self, seeds: Sequence[int]) -> "SuiteSpec":
        """The same suite with other seeds (distinct integers >= 0)."""
        return replace(self, seeds=_check_seeds(self.source, "seeds", list(seeds)))


@dataclass(frozen=True)
class Cell:
    """One run: its ``key`` (hash of ``config``), ``labels`` for tables and resolved ``config``."""

    key: str
    labels: dict[str, Any]
    config: dict[str, Any]


def bundled_suites() -> dict[str, Path]:
    """Name -> file of every bundled suite (``eval/suites/*.yaml``)."""
    return {path.stem: path for path in sorted(SUITES_DIR.glob("*.yaml"))}


def resolve_suite_path(spec: str | os.PathLike) -> Path:
    """A suite file: ``spec`` itself when it is a file, else the bundled suite of that name.

    Raises:
        ValueError: neither (the message lists the bundled names).
    """
    path = Path(spec)
    if path.is_file():
        return path
    bundled = bundled_suites()
    if str(spec) in bundled:
        return bundled[str(spec)]
    raise ValueError(f"suite must be a YAML file or a bundled suite name from "
                     f"{sorted(bundled)}, got {str(spec)!r}")


class _UniqueKeyLoader(yaml.SafeLoader):
    """YAML's safe loader refusing a key repeated in one mapping (the later one would win)."""


def _construct_mapping(loader: _UniqueKeyLoader, node: yaml.MappingNode, deep: bool = False):
    seen = set()
    for key_node, _ in node.value:
        key = loader.construct_object(key_node, deep=deep)
        if key in seen:
            raise yaml.constructor.ConstructorError(
                None, None, f"duplicate key {key!r}", key_node.start_mark)
        seen.add(key)
    return loader.construct_mapping(node, deep=deep)


_UniqueKeyLoader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_MAPPING_TAG,
                                 _construct_mapping)


def load_suite(spec: str | os.PathLike) -> SuiteSpec:
    """Read and check the structure of a suite (a file or a bundled name; see the schema).

    Only names and shapes are checked here; :func:`check_suite` also builds the envs.

    Raises:
        ValueError: (:class:`SuiteError`) naming the file, the key and what is allowed.
    """
    path = resolve_suite_path(spec)
    text = path.read_text(encoding="utf-8")
    source = str(path)
    try:
        data = yaml.load(text, Loader=_UniqueKeyLoader)  # noqa: S506 - a safe loader
    except yaml.YAMLError as error:
        raise SuiteError(source, "", f"not valid YAML: {error}") from None
    return parse_suite(data, source=source, text=text)


def parse_suite(data: Any, source: str = "<suite>", text: str | None = None) -> SuiteSpec:
    """A :class:`SuiteSpec` from the parsed YAML ``data`` (``source`` names it in errors)."""
    from agents.policies import BASELINES
    from soft_gym.robots.presets import PRESETS
    from soft_gym.sensing import FEEDBACK_SOURCES
    from soft_gym.tasks.paths import PATH_SHAPES
    import soft_gym.sensing.feedback  # noqa: F401  (registers the feedback sources)

    if text is None:
        text = yaml.safe_dump(data, sort_keys=False)
    _mapping(source, "", data, TOP_KEYS, required=("name", "seeds", "arms"))
    name = data["name"]
    if not isinstance(name, str) or not _NAME.match(name):
        raise SuiteError(source, "name", f"must be a non-empty name of letters, digits and "
                                         f"'_.-', got {name!r}")
    description = data.get("description", "")
    if not isinstance(description, str):
        raise SuiteError(source, "description", f"must be text, got {description!r}")
    seeds = _check_seeds(source, "seeds", data["seeds"])
    cycles = _check_cycles(source, "cycles", data.get("cycles", DEFAULT_CYCLES))
    arms_data = data["arms"]
    if not isinstance(arms_data, dict) or not arms_data:
        raise SuiteError(source, "arms", f"must map preset names from {sorted(PRESETS)} to arm "
                                         f"blocks, got {arms_data!r}")
    arms = []
    for preset, block in arms_data.items():
        key = f"arms.{preset}"
        if preset not in PRESETS:
            raise SuiteError(source, key, f"unknown preset {preset!r}; allowed: "
                                          f"{sorted(PRESETS)}")
        _mapping(source, key, block, ARM_KEYS, required=("paths", "conditions", "policies"))
        paths = block["paths"]
        allowed_paths = list(PATH_SHAPES) + ["waypoints"]
        if not isinstance(paths, list) or not paths:
            raise SuiteError(source, f"{key}.paths", f"must be a non-empty list of path names "
                                                     f"from {allowed_paths}, got {paths!r}")
        for i, path in enumerate(paths):
            if path not in allowed_paths:
                raise SuiteError(source, f"{key}.paths[{i}]", f"unknown path {path!r}; "
                                                              f"allowed: {allowed_paths}")
        if len(set(paths)) != len(paths):
            raise SuiteError(source, f"{key}.paths", f"paths repeat: {paths!r}")
        feedback = block.get("feedback")
        if feedback is not None and feedback not in FEEDBACK_SOURCES:
            raise SuiteError(source, f"{key}.feedback", f"unknown feedback source {feedback!r}; "
                                                        f"allowed: {sorted(FEEDBACK_SOURCES)}")
        env = _env_block(source, f"{key}.env", block.get("env", {}), allow_feedback=False)
        arm_cycles = _check_cycles(source, f"{key}.cycles", block.get("cycles", cycles))
        conditions_data = block["conditions"]
        if not isinstance(conditions_data, dict) or not conditions_data:
            raise SuiteError(source, f"{key}.conditions",
                             f"must map condition names to env keyword arguments (from "
                             f"{list(ENV_KEYS)}; {{}} for nominal), got {conditions_data!r}")
        conditions = {}
        for condition, kwargs in conditions_data.items():
            ckey = f"{key}.conditions.{condition}"
            if not isinstance(condition, str) or not condition.strip():
                raise SuiteError(source, ckey, "condition names must be non-empty text")
            kwargs = _env_block(source, ckey, {} if kwargs is None else kwargs,
                                allow_feedback=True)
            feedback_here = kwargs.get("feedback")
            if feedback_here is not None and feedback_here not in FEEDBACK_SOURCES:
                raise SuiteError(source, f"{ckey}.feedback",
                                 f"unknown feedback source {feedback_here!r}; allowed: "
                                 f"{sorted(FEEDBACK_SOURCES)}")
            conditions[condition] = kwargs
        policies = _policies(source, f"{key}.policies", block["policies"], BASELINES)
        arms.append(ArmEntry(preset=preset, paths=tuple(paths), feedback=feedback, env=env,
                             cycles=arm_cycles, conditions=conditions, policies=policies))
    return SuiteSpec(name=name, description=description, seeds=seeds, cycles=cycles,
                     arms=tuple(arms), source=source, text=text,
                     sha256=hashlib.sha256(text.encode("utf-8")).hexdigest())


def _mapping(source: str, key: str, value: Any, allowed: Sequence[str],
             required: Sequence[str] = ()) -> None:
    where = key or "top level"
    if not isinstance(value, dict):
        raise SuiteError(source, key, f"{where} must be a mapping with keys from "
                                      f"{list(allowed)}, got {value!r}")
    unknown = [k for k in value if k not in allowed]
    if unknown:
        name = f"{key}.{unknown[0]}" if key else str(unknown[0])
        raise SuiteError(source, name, f"unknown key {unknown[0]!r}; allowed at {where}: "
                                       f"{list(allowed)}")
    missing = [k for k in required if k not in value]
    if missing:
        name = f"{key}.{missing[0]}" if key else missing[0]
        raise SuiteError(source, name, f"missing required key {missing[0]!r} ({where} needs "
                                       f"{list(required)})")


def _check_seeds(source: str, key: str, seeds: Any) -> tuple[int, ...]:
    if (not isinstance(seeds, (list, tuple)) or not seeds
            or not all(isinstance(s, int) and not isinstance(s, bool) and s >= 0 for s in seeds)
            or len(set(seeds)) != len(seeds)):
        raise SuiteError(source, key, f"must be a non-empty list of distinct integers >= 0, "
                                      f"got {seeds!r}")
    return tuple(int(s) for s in seeds)


def _check_cycles(source: str, key: str, cycles: Any) -> int:
    if not isinstance(cycles, int) or isinstance(cycles, bool) or cycles < 1:
        raise SuiteError(source, key, f"must be an integer >= 1, got {cycles!r}")
    return int(cycles)


def _env_block(source: str, key: str, value: Any, allow_feedback: bool) -> dict[str, Any]:
    allowed = [k for k in ENV_KEYS if allow_feedback or k != "feedback"]
    if not isinstance(value, dict):
        raise SuiteError(source, key, f"must be a mapping of env keyword arguments from "
                                      f"{allowed}, got {value!r}")
    for name in value:
        if name not in allowed:
            hint = ""
            if name in SUITE_ENV_KEYS:
                hint = " (the suite sets it: use the arm's key or paths)"
            elif name == "feedback":
                hint = " (set the arm's feedback key instead)"
            raise SuiteError(source, f"{key}.{name}", f"unknown env keyword {name!r}{hint}; "
                                                      f"allowed: {allowed}")
    return copy.deepcopy(dict(value))


def _baseline_parameters(name: str, baselines: Mapping[str, str]) -> list[str]:
    import importlib

    module_name, class_name = baselines[name].split(":")
    cls = getattr(importlib.import_module(module_name), class_name)
    return [p for p in inspect.signature(cls.__init__).parameters if p not in ("self", "env")]


def _policies(source: str, key: str, value: Any,
              baselines: Mapping[str, str]) -> tuple[PolicyEntry, ...]:
    from eval.compare import policy_label

    if not isinstance(value, list) or not value:
        raise SuiteError(source, key, f"must be a non-empty list of policies: names from "
                                      f"{sorted(baselines)}, sb3:PATH, or mappings with keys "
                                      f"{list(POLICY_KEYS)}; got {value!r}")
    entries, labels = [], {}
    for i, item in enumerate(value):
        pkey = f"{key}[{i}]"
        if isinstance(item, str):
            item = {"name": item}
        _mapping(source, pkey, item, POLICY_KEYS, required=("name",))
        name = item["name"]
        if not isinstance(name, str) or not (name in baselines or
                                             (name.startswith("sb3:") and len(name) > 4)):
            raise SuiteError(source, f"{pkey}.name", f"unknown policy {name!r}; allowed: "
                                                     f"{sorted(baselines)} or sb3:PATH")
        params = item.get("params", {}) or {}
        seed_params = item.get("seed_params", []) or []
        if not isinstance(params, dict):
            raise SuiteError(source, f"{pkey}.params", f"must be a mapping of the policy's "
                                                       f"keyword arguments, got {params!r}")
        if not isinstance(seed_params, list) or not all(isinstance(p, str) for p in seed_params):
            raise SuiteError(source, f"{pkey}.seed_params", f"must be a list of parameter "
                                                            f"names, got {seed_params!r}")
        if name.startswith("sb3:"):
            if params or seed_params:
                raise SuiteError(source, f"{pkey}.params", "an sb3 agent takes no params or "
                                                           "seed_params")
        else:
            allowed = _baseline_parameters(name, baselines)
            for pname in list(params) + list(seed_params):
                if pname not in allowed:
                    where = "params" if pname in params else "seed_params"
                    raise SuiteError(source, f"{pkey}.{where}.{pname}",
                                     f"unknown parameter {pname!r} of {name}; allowed: "
                                     f"{allowed}")
            both = sorted(set(params) & set(seed_params))
            if both:
                raise SuiteError(source, f"{pkey}.params.{both[0]}",
                                 f"{both[0]!r} is in both params and seed_params")
        env = _env_block(source, f"{pkey}.env",
                         item.get("env", POLICY_ENV_DEFAULTS.get(name, {})), allow_feedback=True)
        label = item.get("label", policy_label(name))
        if not isinstance(label, str) or not _NAME.match(label):
            raise SuiteError(source, f"{pkey}.label", f"must be a name of letters, digits and "
                                                      f"'_.-', got {label!r}")
        if label in labels:
            raise SuiteError(source, f"{pkey}.label",
                             f"label {label!r} is also {key}[{labels[label]}]'s: give each "
                             f"entry its own label")
        labels[label] = i
        entries.append(PolicyEntry(name=name, label=label, params=copy.deepcopy(params),
                                   seed_params=tuple(seed_params), env=env))
    return tuple(entries)


# ----------------------------------------------------------------------------- expansion
def canonical_json(value: Any) -> str:
    """``value`` as canonical JSON: sorted keys, no spaces, ASCII, tuples as lists."""
    return json.dumps(value, sort_keys=True, separators=(",", ":"), ensure_ascii=True,
                      allow_nan=False)


def cell_key(config: Mapping[str, Any]) -> str:
    """The key of a resolved config: the first :data:`KEY_DIGITS` hex digits of the SHA-256 of
    its canonical JSON."""
    return hashlib.sha256(canonical_json(config).encode("ascii")).hexdigest()[:KEY_DIGITS]


def _arm_env(arm: ArmEntry, path: str) -> dict[str, Any]:
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
                        env_kwargs = {**_arm_env(arm, path), **copy.deepcopy(condition_kwargs),
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
                                             f"runs {_label_text(seen[key])} and "
                                             f"{_label_text(labels)} have the same config: "
                                             f"make their conditions or policies differ")
                        seen[key] = labels
                        cells.append(Cell(key=key, labels=labels, config=config))
    return cells


def _label_text(labels: Mapping[str, Any]) -> str:
    return "/".join(str(labels.get(k)) for k in ("preset", "path", "condition", "policy", "seed"))


# ---------------------------------------------------------------------------- validation
class _EnvChecker:
    """Builds each distinct env configuration once (uncalibrated) and remembers the outcome."""

    def __init__(self) -> None:
        from eval.runner import uncalibrated_env_class

        self.env_class = uncalibrated_env_class()
        self.errors: dict[str, str | None] = {}
        self.builds = 0

    def make(self, kwargs: Mapping[str, Any]):
        self.builds += 1
        return self.env_class(task="track", **copy.deepcopy(dict(kwargs)))

    def error(self, kwargs: Mapping[str, Any]) -> str | None:
        """The env's refusal of ``kwargs`` (its message), or ``None``."""
        text = canonical_json(kwargs)
        if text not in self.errors:
            try:
                env = self.make(kwargs)
            except (ValueError, TypeError) as error:
                self.errors[text] = str(error)
            else:
                env.close()
                self.errors[text] = None
        return self.errors[text]


def check_suite(spec: SuiteSpec, progress: bool = False) -> list[Cell]:
    """Check ``spec`` as far as possible without running it and return its cells.

    Builds every distinct env configuration once, without calibrating its feedback source, and
    makes every baseline on it (see the module docstring, "Validation"); loads every SB3 agent
    once.

    Raises:
        ValueError: (:class:`SuiteError`) naming the file, the key and the env's or policy's
            message.
    """
    from tqdm import tqdm

    cells = expand(spec)
    checker = _EnvChecker()
    source = spec.source
    agents: dict[str, str | None] = {}
    # full env config -> (its kwargs, [(key, entry)]) of the baselines to make on it
    baselines: dict[str, tuple[dict[str, Any], list[tuple[str, PolicyEntry]]]] = {}
    for arm in tqdm(spec.arms, desc="checking the suite envs", disable=not progress,
                    leave=False):
        akey = f"arms.{arm.preset}"
        base_key = f"{akey}.env" if arm.env else f"{akey}.feedback"
        _raise_if(source, base_key, checker.error(_arm_env(arm, arm.paths[0])))
        for i, path in enumerate(arm.paths):
            _raise_if(source, f"{akey}.paths[{i}]", checker.error(_arm_env(arm, path)))
        for path in arm.paths:
            for condition, kwargs in arm.conditions.items():
                merged = {**_arm_env(arm, path), **kwargs}
                _raise_if(source, f"{akey}.conditions.{condition}", checker.error(merged))
                for j, entry in enumerate(arm.policies):
                    pkey = f"{akey}.policies[{j}]"
                    full = {**merged, **entry.env}
                    if entry.env:
                        _raise_if(source, f"{pkey}.env", checker.error(full))
                    if entry.is_agent:
                        if entry.name not in agents:
                            agents[entry.name] = _agent_error(entry.name)
                        _raise_if(source, f"{pkey}.name", agents[entry.name])
                        continue
                    group = baselines.setdefault(canonical_json(full), (full, []))[1]
                    if all(canonical_json([e.name, e.params, e.seed_params]) !=
                           canonical_json([entry.name, entry.params, entry.seed_params])
                           for _, e in group):
                        group.append((f"{pkey}.params", entry))
    for full, entries in tqdm(baselines.values(), desc="checking the suite policies",
                              disable=not progress, leave=False):
        env = checker.make(full)
        try:
            for key, entry in entries:
                _raise_if(source, key, _policy_error(env, entry, spec.seeds[0]))
        finally:
            env.close()
    return cells


def _raise_if(source: str, key: str, message: str | None) -> None:
    if message is not None:
        raise SuiteError(source, key, message)


def _agent_error(name: str) -> str | None:
    from agents.policies import SB3Policy

    try:
        SB3Policy.load(name[4:])
    except (ValueError, OSError) as error:
        return str(error)
    return None


def _policy_error(env, entry: PolicyEntry, seed: int) -> str | None:
    """A baseline's refusal of the entry's parameters on ``env``; ``None`` when it accepts them
    or refuses the arm itself (with its defaults too: an ``n/a`` run, not a suite error)."""
    from agents.policies import make_policy

    params = {**entry.params, **{name: seed for name in entry.seed_params}}
    try:
        make_policy(entry.name, env=env, **params)
    except ValueError as error:
        given = str(error)
    else:
        return None
    try:
        make_policy(entry.name, env=env)
    except ValueError:
        return None
    return given


# ------------------------------------------------------------------------------- running
def library_versions() -> dict[str, str]:
    """Versions of the package and the libraries a record depends on (``"unknown"`` where a
    package is not installed)."""
    from importlib import metadata

    versions = {}
    for key, dist in (("soft_arm_gym", "soft-arm-gym"), ("gymnasium", "gymnasium"),
                      ("stable_baselines3", "stable-baselines3"), ("torch", "torch"),
                      ("numpy", "numpy"), ("pybullet", "pybullet")):
        try:
            versions[key] = metadata.version(dist)
        except metadata.PackageNotFoundError:
            versions[key] = "unknown"
    versions["python"] = platform.python_version()
    return versions


def git_revision(root: Path | None = None) -> str | None:
    """The checkout's commit (``-dirty`` appended when tracked files differ from it), or
    ``None`` outside a git checkout. Reads only (no index refresh)."""
    root = Path(__file__).resolve().parents[1] if root is None else root
    try:
        head = subprocess.run(["git", "-C", str(root), "rev-parse", "HEAD"], capture_output=True,
                              text=True, timeout=20)
        if head.returncode != 0:
            return None
        status = subprocess.run(["git", "--no-optional-locks", "-C", str(root), "status",
                                 "--porcelain", "--untracked-files=no"], capture_output=True,
                                text=True, timeout=60)
    except (OSError, subprocess.SubprocessError):
        return None
    revision = head.stdout.strip()
    return revision + ("-dirty" if status.returncode == 0 and status.stdout.strip() else "")


def cell_metrics(record: Mapping[str, np.ndarray]) -> dict[str, Any]:
    """The summary metrics of one run's per-step record (mm; see the module docstring)."""
    from eval.metrics import MM_PER_M, summarize

    summary = summarize(record)
    track, deviation = summary["tracking"], summary["deviation"]
    feedback = np.linalg.norm(np.asarray(record["feedback_m"]) - np.asarray(record["tip_m"]),
                              axis=1) * MM_PER_M
    finite = feedback[np.isfinite(feedback)]
    return {
        "last_cycle_error_mm": track["per_cycle"]["mean_mm"][-1],
        "mean_error_mm": track["mean_mm"],
        "max_error_mm": track["max_mm"],
        "rmse_error_mm": track["rmse_mm"],
        "final_error_mm": track["final_mm"],
        "last_cycle_max_error_mm": track["per_cycle"]["max_mm"][-1],
        "path_deviation_mm": deviation["mean_mm"],
        "last_cycle_path_deviation_mm": deviation["per_cycle"]["mean_mm"][-1],
        "feedback_error_mm": float(np.mean(finite)) if finite.size else math.nan,
        "per_cycle_error_mm": list(track["per_cycle"]["mean_mm"]),
        "per_cycle_path_deviation_mm": list(deviation["per_cycle"]["mean_mm"]),
        "n_steps": summary["n_steps"],
        "n_cycles": summary["n_cycles"],
    }


@contextlib.contextmanager
def one_compute_thread() -> Iterator[None]:
    """Run the block with BLAS, OpenMP and torch on one thread each, restoring them after.

    A cell's numbers must not depend on where it runs: a Ray task starts with
    ``OMP_NUM_THREADS=1``, a pool worker with every core, and a sum split over threads rounds
    differently (lwpr_rwr and hybrid_gpr records differed in the tenth digit). On one thread a
    record is the same on every backend, worker count and machine.
    """
    import torch
    from threadpoolctl import threadpool_limits

    torch_threads = torch.get_num_threads()
    torch.set_num_threads(1)
    try:
        with threadpool_limits(limits=1):
            yield
    finally:
        torch.set_num_threads(torch_threads)


def run_cell(task: Mapping[str, Any]) -> dict[str, Any]:
    """Run one cell (a worker's job; picklable): ``task`` holds ``key``, ``suite``, ``labels``,
    ``config``, ``versions`` and ``git_revision``.

    Returns the JSON record (see the module docstring) with the per-step arrays under
    ``"steps"`` (``None`` when n/a), or, for an error other than a refusal, ``status`` ``"error"``
    with the ``error`` and its ``traceback``.
    """
    from eval.runner import RunConfig, build, run_episode

    start = time.perf_counter()
    config = task["config"]
    result = {"key": task["key"], "suite": task["suite"], "labels": dict(task["labels"]),
              "config": config, "status": "done", "reason": None, "metrics": None,
              "wall_s": None, "versions": task["versions"],
              "git_revision": task["git_revision"], "steps": None}
    run_config = RunConfig(policy=config["policy"], env_kwargs=copy.deepcopy(config["env_kwargs"]),
                           policy_params=copy.deepcopy(config["policy_params"]),
                           env_id=config["env_id"], seed=config["seed"])
    try:
        with one_compute_thread():
            try:
                env, policy = build(run_config)
            except ValueError as error:  # the policy cannot drive this arm or env
                result.update(status="n/a", reason=" ".join(str(error).split()))
            else:
                try:
                    steps = run_episode(env, policy, seed=config["seed"], progress=False)
                finally:
                    env.close()
                result.update(metrics=cell_metrics(steps), steps=steps)
    except Exception as error:  # noqa: BLE001 - reported, the other runs go on
        result.update(status="error", error=f"{type(error).__name__}: {error}",
                      traceback=traceback.format_exc())
    result["wall_s"] = time.perf_counter() - start
    return result


MapFunction = Callable[[Callable[[Any], Any], Sequence[Any], int], Iterator[Any]]
"""A backend: ``map(fn, items, workers)`` yields ``fn(item)`` for every item, as each completes
(in any order)."""


def serial_map(fn: Callable[[Any], Any], items: Sequence[Any], workers: int = 1) -> Iterator[Any]:
    """Run ``fn`` on every item in this process, in order."""
    for item in items:
        yield fn(item)


def process_map(fn: Callable[[Any], Any], items: Sequence[Any],
                workers: int = 1) -> Iterator[Any]:
    """Run ``fn`` on every item in ``workers`` spawned processes (in this process when
    ``workers == 1`` or there is one item), yielding results as they complete.

    At most ``2 * workers`` items are submitted ahead, so a stopped iteration leaves little
    work behind, which is cancelled.
    """
    if workers == 1 or len(items) <= 1:
        yield from serial_map(fn, items)
        return
    import multiprocessing

    context = multiprocessing.get_context("spawn")
    pending_items = iter(items)
    with ProcessPoolExecutor(max_workers=min(workers, len(items)), mp_context=context) as pool:
        running = set()
        try:
            for item in pending_items:
                running.add(pool.submit(fn, item))
                if len(running) >= 2 * workers:
                    break
            while running:
                done, running = wait(running, return_when=FIRST_COMPLETED)
                for future in done:
                    for item in pending_items:
                        running.add(pool.submit(fn, item))
                        break
                    yield future.result()
        finally:
            for future in running:
                future.cancel()


BACKENDS: dict[str, MapFunction] = {"process": process_map, "serial": serial_map}
"""Backend name -> map function (see :data:`MapFunction`)."""


def register_backend(name: str, map_function: MapFunction) -> None:
    """Make ``map_function`` available as ``run_suite(..., backend=name)``."""
    if not isinstance(name, str) or not name:
        raise ValueError(f"backend name must be non-empty text, got {name!r}")
    if not callable(map_function):
        raise ValueError(f"map_function must be callable, got {map_function!r}")
    BACKENDS[name] = map_function


def order_cells(cells: Sequence[Cell]) -> list[Cell]:
    """Cells round-robin over their (arm, policy, seed) groups, in first-seen group order."""
    groups: dict[tuple, list[Cell]] = {}
    for cell in cells:
        labels = cell.labels
        groups.setdefault((labels["preset"], labels["policy"], labels["seed"]), []).append(cell)
    ordered, depth = [], max((len(g) for g in groups.values()), default=0)
    for i in range(depth):
        ordered += [group[i] for group in groups.values() if i < len(group)]
    return ordered


def records_dir(out: str | os.PathLike) -> Path:
    return Path(out) / "records"


def record_path(out: str | os.PathLike, key: str) -> Path:
    """The JSON record of cell ``key`` under the output directory ``out``."""
    return records_dir(out) / f"{key}.json"


def steps_path(out: str | os.PathLike, key: str) -> Path:
    """The per-step record (``.npz``) of cell ``key``."""
    return records_dir(out) / f"{key}.npz"


def read_record(out: str | os.PathLike, key: str) -> dict[str, Any] | None:
    """The JSON record of cell ``key``, or ``None`` when it is not there."""
    path = record_path(out, key)
    if not path.is_file():
        return None
    return json.loads(path.read_text(encoding="utf-8"))


def read_steps(out: str | os.PathLike, key: str) -> dict[str, np.ndarray] | None:
    """The per-step arrays of cell ``key``, or ``None`` when there are none."""
    path = steps_path(out, key)
    if not path.is_file():
        return None
    with np.load(path) as data:
        return {name: data[name] for name in data.files}


def is_finished(out: str | os.PathLike, key: str) -> bool:
    """Whether cell ``key`` has its record (and, for a run that ran, its per-step record)."""
    try:
        record = read_record(out, key)
    except (OSError, ValueError):
        return False
    if record is None or record.get("key") != key:
        return False
    return record.get("status") == "n/a" or steps_path(out, key).is_file()


def _atomic_write(path: Path, write: Callable[[Any], None], binary: bool) -> None:
    """Write through ``write(handle)`` into a temporary file beside ``path``, then rename."""
    path.parent.mkdir(parents=True, exist_ok=True)
    handle, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(handle, "wb" if binary else "w", **({} if binary else
                                                            {"encoding": "utf-8"})) as stream:
            write(stream)
            stream.flush()
            os.fsync(stream.fileno())
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def write_record(out: str | os.PathLike, result: Mapping[str, Any]) -> Path:
    """Write one finished run: its per-step arrays (if any) and then its JSON record, each
    atomically. Returns the JSON record's path."""
    from eval.report import to_jsonable

    key = result["key"]
    steps = result.get("steps")
    record = {k: v for k, v in result.items() if k not in ("steps", "error", "traceback")}
    record["steps_file"] = None
    if steps is not None:
        arrays = {name: np.asarray(value) for name, value in steps.items()}
        _atomic_write(steps_path(out, key), lambda f: np.savez_compressed(f, **arrays),
                      binary=True)
        record["steps_file"] = steps_path(out, key).name
    text = json.dumps(to_jsonable(record), indent=2, allow_nan=False) + "\n"
    path = record_path(out, key)
    _atomic_write(path, lambda f: f.write(text), binary=False)
    return path


def run_suite(spec: SuiteSpec | str | os.PathLike, out: str | os.PathLike, workers: int = 1,
              resume: bool = False, backend: str | MapFunction = "process",
              progress: bool = True, check: bool = True) -> dict[str, Any]:
    """Run the suite's cells and write one record per run as it finishes.

    Args:
        spec: a loaded suite, a suite file or a bundled suite name.
        out: output directory (records under ``out/records``).
        workers: parallel runs (>= 1).
        resume: skip the cells whose record is there; without it every cell runs again.
        backend: a name from :data:`BACKENDS` or a map function (:data:`MapFunction`);
            ``"ray"`` is there once :mod:`eval.suite_ray` is imported (it imports this module).
        progress: show a progress bar over the runs.
        check: run :func:`check_suite` first (the command line has already done so).

    Returns:
        ``{"cells", "skipped", "done", "n/a", "wall_s"}``: counts and the wall time (s).

    Raises:
        ValueError: a bad argument or suite (before any run).
        SuiteRunError: some runs failed with an error other than a refusal (after the others).
    """
    from tqdm import tqdm

    if not isinstance(workers, int) or isinstance(workers, bool) or workers < 1:
        raise ValueError(f"workers must be an integer >= 1, got {workers!r}")
    if isinstance(backend, str):
        if backend not in BACKENDS:
            raise ValueError(f"backend must be one of {sorted(BACKENDS)} or a map function, "
                             f"got {backend!r}")
        map_function = BACKENDS[backend]
    elif callable(backend):
        map_function = backend
    else:
        raise ValueError(f"backend must be one of {sorted(BACKENDS)} or a map function, got "
                         f"{backend!r}")
    if not isinstance(spec, SuiteSpec):
        spec = load_suite(spec)
    cells = check_suite(spec, progress=progress) if check else expand(spec)
    start = time.perf_counter()
    todo = [cell for cell in cells if not (resume and is_finished(out, cell.key))]
    records_dir(out).mkdir(parents=True, exist_ok=True)
    versions, revision = library_versions(), git_revision()
    tasks = [{"key": cell.key, "suite": spec.name, "labels": cell.labels, "config": cell.config,
              "versions": versions, "git_revision": revision} for cell in order_cells(todo)]
    counts = {"cells": len(cells), "skipped": len(cells) - len(todo), "done": 0, "n/a": 0}
    failures = []
    bar = tqdm(total=len(tasks), desc=f"suite {spec.name}", unit="run", disable=not progress)
    for result in map_function(run_cell, tasks, workers):
        if result["status"] == "error":
            failures.append(result)
            errors = Path(out) / "errors"
            errors.mkdir(parents=True, exist_ok=True)
            (errors / f"{result['key']}.txt").write_text(
                f"{_label_text(result['labels'])}\n{result['traceback']}", encoding="utf-8")
        else:
            write_record(out, result)
            counts[result["status"]] += 1
        bar.set_postfix_str(_label_text(result["labels"]), refresh=False)
        bar.update(1)
    bar.close()
    counts["wall_s"] = time.perf_counter() - start
    if failures:
        raise SuiteRunError(failures)
    return counts


__all__ = ["BACKENDS", "ENV_ID", "ENV_KEYS", "POLICY_ENV_DEFAULTS", "ArmEntry", "Cell",
           "MapFunction", "PolicyEntry", "SuiteError", "SuiteRunError", "SuiteSpec",
           "bundled_suites", "canonical_json", "cell_key", "cell_metrics", "check_suite",
           "expand", "git_revision", "is_finished", "library_versions", "load_suite",
           "order_cells", "parse_suite", "process_map", "read_record", "read_steps",
           "record_path", "register_backend", "resolve_suite_path", "run_cell", "run_suite",
           "serial_map", "steps_path", "write_record"]

