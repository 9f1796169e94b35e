"""The suite spec: a YAML file read, checked for names and shapes, and held as a :class:`SuiteSpec`.

The schema is the package's (:mod:`eval.suite`, "Schema"). :func:`load_suite` reads a suite file or
a bundled suite (``eval/suites/<name>.yaml``), refusing an unknown key, preset, path, feedback
source, policy or policy parameter with a :class:`SuiteError` naming the file and the key, and
keeps the text with its SHA-256; :func:`eval.suite.check.check_suite` goes further and builds the
envs.
"""

from __future__ import annotations

import copy
import difflib
import hashlib
import inspect
import math
import os
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import yaml

from agents.policies import BASELINES
from eval.palette import policy_label
from soft_gym._validation import SEED_MAX
from soft_gym.envs.config import CONFIG_FIELDS
from soft_gym.robots.presets import PRESETS
from soft_gym.sensing import FEEDBACK_SOURCES
from soft_gym.tasks.paths import PATH_SHAPES

SUITES_DIR = Path(__file__).resolve().parents[1] / "suites"
"""The bundled suites, ``<name>.yaml``."""

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
    return tuple(name for name in CONFIG_FIELDS
                 if name not in SUITE_ENV_KEYS and name not in _NOT_FOR_TRACKING)


ENV_KEYS: tuple[str, ...] = _env_keys()
"""Env keyword arguments a condition, an arm's ``env`` or a policy's ``env`` may set."""


MESSAGE_CHARS = 1500
"""The longest :class:`SuiteError` message (characters; a longer one is cut, marked ``...``)."""

VALUE_CHARS = 120
"""The longest quotation of a value in a message (characters)."""

MAX_ALIASES = 16
"""YAML aliases (``*name``) a suite file may use: more is refused before they are expanded (an
alias bomb, a few hundred bytes, expands to gigabytes)."""

MAX_DEPTH = 24
"""The deepest nesting of lists and mappings in a suite file."""


class SuiteError(ValueError):
    """A suite file that cannot be run: names the file, the key and what is allowed (one line, at
    most :data:`MESSAGE_CHARS` characters)."""

    def __init__(self, source: str, key: str, message: str) -> None:
        self.source, self.key = source, key
        text = " ".join((f"{source}: {key}: {message}" if key else f"{source}: {message}")
                        .split())  # one line
        if len(text) > MESSAGE_CHARS:
            text = text[:MESSAGE_CHARS - 3] + "..."
        super().__init__(text)


def _short(value: Any) -> str:
    """``repr(value)``, cut to :data:`VALUE_CHARS` characters (marked ``...``)."""
    text = repr(value)
    return text if len(text) <= VALUE_CHARS else text[:VALUE_CHARS - 3] + "..."


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
        """The same suite with other seeds (distinct integers in ``[0, SEED_MAX]``)."""
        return replace(self, seeds=_check_seeds(self.source, "seeds", list(seeds)))


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
    names = sorted(bundled)
    if path.is_dir():
        raise ValueError(f"suite {str(spec)!r} is a directory, not a YAML file or a bundled "
                         f"suite name from {names}")
    close = difflib.get_close_matches(path.stem, names, n=1)
    hint = f"; did you mean {close[0]!r}?" if close else ""
    if path.suffix in (".yaml", ".yml") or len(path.parts) > 1:
        raise ValueError(f"suite file {str(spec)!r} not found (no such file); the bundled "
                         f"suites are {names}{hint}")
    raise ValueError(f"suite {str(spec)!r} not found: no such file and no bundled suite of that "
                     f"name (the bundled ones are {names}){hint}")


class _UniqueKeyLoader(yaml.SafeLoader):
    """YAML's safe loader refusing a key repeated in one mapping (the later one would win), more
    than :data:`MAX_ALIASES` aliases and nesting deeper than :data:`MAX_DEPTH`."""

    def __init__(self, stream: str) -> None:
        super().__init__(stream)
        self._aliases = 0
        self._depth = 0

    def compose_node(self, parent, index):
        if self.check_event(yaml.AliasEvent):
            self._aliases += 1
            if self._aliases > MAX_ALIASES:
                raise yaml.composer.ComposerError(
                    None, None, f"more than {MAX_ALIASES} aliases (*name): refused before "
                                "they are expanded", self.peek_event().start_mark)
        self._depth += 1
        try:
            if self._depth > MAX_DEPTH:
                raise yaml.composer.ComposerError(
                    None, None, f"nesting deeper than {MAX_DEPTH} levels",
                    self.peek_event().start_mark)
            return super().compose_node(parent, index)
        finally:
            self._depth -= 1


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
    source = str(path)
    raw = path.read_bytes()
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as error:
        line = raw[:error.start].count(b"\n") + 1
        raise SuiteError(source, "", f"not UTF-8 text: byte {raw[error.start]:#04x} at line "
                                     f"{line} (offset {error.start}); save the file as "
                                     "UTF-8") from None
    try:
        data = yaml.load(text, Loader=_UniqueKeyLoader)  # noqa: S506 - a safe loader
    except yaml.YAMLError as error:
        raise SuiteError(source, "", f"not valid YAML: {error}") from None
    return parse_suite(data, source=source, text=text)


def _check_plain(source: str, key: str, value: Any) -> None:
    """Refuse anything but JSON's types in the parsed suite (text keys; mappings, lists, text,
    integers, finite floats, booleans, null), naming the key: YAML's dates, ``!!binary``,
    ``!!set`` and the like, and ``.nan``/``.inf``, before anything is hashed."""
    if isinstance(value, dict):
        for name, item in value.items():
            if not isinstance(name, str):
                raise SuiteError(source, key, f"keys must be text, got {_short(name)} "
                                              f"({type(name).__name__})")
            _check_plain(source, f"{key}.{name}" if key else name, item)
    elif isinstance(value, list):
        for i, item in enumerate(value):
            _check_plain(source, f"{key}[{i}]", item)
    elif isinstance(value, float):
        if not math.isfinite(value):
            raise SuiteError(source, key, f"must be a finite number, got {value!r}")
    elif not (value is None or isinstance(value, (str, int, bool))):
        raise SuiteError(source, key, f"must be text, a number, true/false, null, a list or a "
                                      f"mapping, got a {type(value).__name__} "
                                      f"({_short(value)})")


def parse_suite(data: Any, source: str = "<suite>", text: str | None = None) -> SuiteSpec:
    """A :class:`SuiteSpec` from the parsed YAML ``data`` (``source`` names it in errors)."""
    _check_plain(source, "", data)
    if text is None:
        text = yaml.safe_dump(data, sort_keys=False)
    _mapping(source, "", data, TOP_KEYS, required=("name", "seeds", "arms"))
    name = data["name"]
    if not isinstance(name, str) or not _NAME.match(name):
        raise SuiteError(source, "name", f"must be a non-empty name of letters, digits and "
                                         f"'_.-', got {_short(name)}")
    description = data.get("description", "")
    if not isinstance(description, str):
        raise SuiteError(source, "description", f"must be text, got {_short(description)}")
    seeds = _check_seeds(source, "seeds", data["seeds"])
    cycles = _check_cycles(source, "cycles", data.get("cycles", DEFAULT_CYCLES))
    arms_data = data["arms"]
    if not isinstance(arms_data, dict) or not arms_data:
        raise SuiteError(source, "arms", f"must map preset names from {sorted(PRESETS)} to arm "
                                         f"blocks, got {_short(arms_data)}")
    arms = []
    for preset, block in arms_data.items():
        key = f"arms.{preset}"
        if preset not in PRESETS:
            raise SuiteError(source, key, f"unknown preset {_short(preset)}; allowed: "
                                          f"{sorted(PRESETS)}")
        _mapping(source, key, block, ARM_KEYS, required=("paths", "conditions", "policies"))
        paths = block["paths"]
        allowed_paths = list(PATH_SHAPES) + ["waypoints"]
        if not isinstance(paths, list) or not paths:
            raise SuiteError(source, f"{key}.paths", f"must be a non-empty list of path names "
                                                     f"from {allowed_paths}, got {_short(paths)}")
        for i, path in enumerate(paths):
            if path not in allowed_paths:
                raise SuiteError(source, f"{key}.paths[{i}]", f"unknown path {_short(path)}; "
                                                              f"allowed: {allowed_paths}")
        if len(set(paths)) != len(paths):
            raise SuiteError(source, f"{key}.paths", f"paths repeat: {_short(paths)}")
        feedback = block.get("feedback")
        if feedback is not None and feedback not in FEEDBACK_SOURCES:
            raise SuiteError(source, f"{key}.feedback", f"unknown feedback source "
                                                        f"{_short(feedback)}; "
                                                        f"allowed: {sorted(FEEDBACK_SOURCES)}")
        env = _env_block(source, f"{key}.env", block.get("env", {}), allow_feedback=False)
        arm_cycles = _check_cycles(source, f"{key}.cycles", block.get("cycles", cycles))
        conditions_data = block["conditions"]
        if not isinstance(conditions_data, dict) or not conditions_data:
            raise SuiteError(source, f"{key}.conditions",
                             f"must map condition names to env keyword arguments (from "
                             f"{list(ENV_KEYS)}; {{}} for nominal), got {_short(conditions_data)}")
        conditions = {}
        for condition, kwargs in conditions_data.items():
            ckey = f"{key}.conditions.{condition}"
            if not isinstance(condition, str) or not _NAME.match(condition):
                raise SuiteError(source, ckey, "condition names must be non-empty names of "
                                               "letters, digits and '_.-' (they name table "
                                               "rows and plot files)")
            kwargs = _env_block(source, ckey, {} if kwargs is None else kwargs,
                                allow_feedback=True)
            feedback_here = kwargs.get("feedback")
            if feedback_here is not None and feedback_here not in FEEDBACK_SOURCES:
                raise SuiteError(source, f"{ckey}.feedback",
                                 f"unknown feedback source {_short(feedback_here)}; allowed: "
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
                                      f"{list(allowed)}, got {_short(value)}")
    unknown = [k for k in value if k not in allowed]
    if unknown:
        name = f"{key}.{unknown[0]}" if key else str(unknown[0])
        raise SuiteError(source, name, f"unknown key {_short(unknown[0])}; allowed at {where}: "
                                       f"{list(allowed)}")
    missing = [k for k in required if k not in value]
    if missing:
        name = f"{key}.{missing[0]}" if key else missing[0]
        raise SuiteError(source, name, f"missing required key {_short(missing[0])} ({where} needs "
                                       f"{list(required)})")


def _check_seeds(source: str, key: str, seeds: Any) -> tuple[int, ...]:
    if (not isinstance(seeds, (list, tuple)) or not seeds
            or not all(isinstance(s, int) and not isinstance(s, bool) and 0 <= s <= SEED_MAX
                       for s in seeds)
            or len(set(seeds)) != len(seeds)):
        raise SuiteError(source, key, f"must be a non-empty list of distinct integers >= 0 and "
                                      f"<= {SEED_MAX}, got {_short(seeds)}")
    return tuple(int(s) for s in seeds)


def _check_cycles(source: str, key: str, cycles: Any) -> int:
    if not isinstance(cycles, int) or isinstance(cycles, bool) or cycles < 1:
        raise SuiteError(source, key, f"must be an integer >= 1, got {_short(cycles)}")
    return int(cycles)


def _env_block(source: str, key: str, value: Any, allow_feedback: bool) -> dict[str, Any]:
    allowed = [k for k in ENV_KEYS if allow_feedback or k != "feedback"]
    if not isinstance(value, dict):
        raise SuiteError(source, key, f"must be a mapping of env keyword arguments from "
                                      f"{allowed}, got {_short(value)}")
    for name in value:
        if name not in allowed:
            hint = ""
            if name in SUITE_ENV_KEYS:
                hint = " (the suite sets it: use the arm's key or paths)"
            elif name == "feedback":
                hint = " (set the arm's feedback key instead)"
            raise SuiteError(source, f"{key}.{name}", f"unknown env keyword {_short(name)}{hint}; "
                                                      f"allowed: {allowed}")
    return copy.deepcopy(dict(value))


def _baseline_parameters(name: str, baselines: Mapping[str, type]) -> list[str]:
    return [p for p in inspect.signature(baselines[name].__init__).parameters
            if p not in ("self", "env")]


def _policies(source: str, key: str, value: Any,
              baselines: Mapping[str, str]) -> tuple[PolicyEntry, ...]:
    if not isinstance(value, list) or not value:
        raise SuiteError(source, key, f"must be a non-empty list of policies: names from "
                                      f"{sorted(baselines)}, sb3:PATH, or mappings with keys "
                                      f"{list(POLICY_KEYS)}; got {_short(value)}")
    entries, labels = [], {}
    for i, item in enumerate(value):
        pkey = f"{key}[{i}]"
        if isinstance(item, str):
            item = {"name": item}
        _mapping(source, pkey, item, POLICY_KEYS, required=("name",))
        name = item["name"]
        if not isinstance(name, str) or not (name in baselines or
                                             (name.startswith("sb3:") and len(name) > 4)):
            raise SuiteError(source, f"{pkey}.name", f"unknown policy {_short(name)}; allowed: "
                                                     f"{sorted(baselines)} or sb3:PATH")
        params = item.get("params", {}) or {}
        seed_params = item.get("seed_params", []) or []
        if not isinstance(params, dict):
            raise SuiteError(source, f"{pkey}.params", f"must be a mapping of the policy's "
                                                       f"keyword arguments, got {_short(params)}")
        if not isinstance(seed_params, list) or not all(isinstance(p, str) for p in seed_params):
            raise SuiteError(source, f"{pkey}.seed_params", f"must be a list of parameter "
                                                            f"names, got {_short(seed_params)}")
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
                                     f"unknown parameter {_short(pname)} of {name}; allowed: "
                                     f"{allowed}")
            both = sorted(set(params) & set(seed_params))
            if both:
                raise SuiteError(source, f"{pkey}.params.{both[0]}",
                                 f"{_short(both[0])} is in both params and seed_params")
        env = _env_block(source, f"{pkey}.env",
                         item.get("env", POLICY_ENV_DEFAULTS.get(name, {})), allow_feedback=True)
        label = item.get("label", policy_label(name))
        if not isinstance(label, str) or not _NAME.match(label):
            raise SuiteError(source, f"{pkey}.label", f"must be a name of letters, digits and "
                                                      f"'_.-', got {_short(label)}")
        if label in labels:
            raise SuiteError(source, f"{pkey}.label",
                             f"label {_short(label)} is also {key}[{labels[label]}]'s: give each "
                             f"entry its own label")
        labels[label] = i
        entries.append(PolicyEntry(name=name, label=label, params=copy.deepcopy(params),
                                   seed_params=tuple(seed_params), env=env))
    return tuple(entries)

