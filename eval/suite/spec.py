"""The suite spec: a YAML file read, checked for names and shapes, and held as a :class:`SuiteSpec`.

The schema is the package's (:mod:`eval.suite`, "Schema"). :func:`load_suite` reads a suite file or
a bundled suite (``eval/suites/<name>.yaml``), refusing an unknown key, preset, path, feedback
source, policy or policy parameter with a :class:`SuiteError` naming the file and the key (every
such mistake of the file at once, one line each), and keeps the text with its SHA-256;
:func:`eval.suite.check.check_suite` goes further and builds the envs.
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

MAX_ERRORS = 50
"""The most mistakes of one file a :class:`SuiteError` lists (a last line counts the rest)."""


class SuiteError(ValueError):
    """A suite file that cannot be run: names the file, the key and what is allowed (one line, at
    most :data:`MESSAGE_CHARS` characters).

    :func:`parse_suite` raises one for all the mistakes of a file (:meth:`combined`): one line
    each, in the file's order, listed in ``errors``; ``source`` and ``key`` are the first's.
    """

    def __init__(self, source: str, key: str, message: str) -> None:
        self.source, self.key = source, key
        text = " ".join((f"{source}: {key}: {message}" if key else f"{source}: {message}")
                        .split())  # one line
        if len(text) > MESSAGE_CHARS:
            text = text[:MESSAGE_CHARS - 3] + "..."
        super().__init__(text)
        self.errors: list[SuiteError] = [self]

    @classmethod
    def combined(cls, errors: Sequence["SuiteError"]) -> "SuiteError":
        """One error listing ``errors`` (at least one), one line each (at most
        :data:`MAX_ERRORS`, then a line counting the rest)."""
        if len(errors) == 1:
            return errors[0]
        lines = [str(error) for error in errors[:MAX_ERRORS]]
        if len(errors) > MAX_ERRORS:
            lines.append(f"{errors[0].source}: and {len(errors) - MAX_ERRORS} more mistake(s)")
        error = cls.__new__(cls)
        ValueError.__init__(error, "\n".join(lines))
        error.source, error.key = errors[0].source, errors[0].key
        error.errors = [item for each in errors for item in each.errors]
        return error


class _Errors:
    """The mistakes of one suite file, gathered so that all of them are reported at once."""

    def __init__(self, source: str) -> None:
        self.source = source
        self.found: list[SuiteError] = []

    def _covered(self, key: str) -> bool:
        """Whether a mistake at ``key``, or at a key holding it, is noted already."""
        return any(error.key == key or (error.key and key.startswith(error.key)
                                        and key[len(error.key)] in ".[")
                   for error in self.found)

    def add(self, key: str, message: str) -> None:
        """Note a mistake at ``key`` (one per key: a later one at a key already refused, or
        within it, adds nothing)."""
        if not self._covered(key):
            self.found.append(SuiteError(self.source, key, message))

    def check(self, function, *args, default: Any = None) -> Any:
        """``function(*args)``, noting the :class:`SuiteError` it raises (then ``default``)."""
        try:
            return function(*args)
        except SuiteError as error:
            for item in error.errors:
                if not self._covered(item.key):
                    self.found.append(item)
            return default

    def raise_any(self) -> None:
        """Raise every mistake noted, in one :class:`SuiteError`."""
        if self.found:
            raise SuiteError.combined(self.found)


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


def _check_plain(errors: _Errors, key: str, value: Any) -> None:
    """Refuse anything but JSON's types in the parsed suite (text keys; mappings, lists, text,
    integers, finite floats, booleans, null), naming the key: YAML's dates, ``!!binary``,
    ``!!set`` and the like, and ``.nan``/``.inf``, before anything is hashed."""
    if isinstance(value, dict):
        for name, item in value.items():
            if not isinstance(name, str):
                errors.add(key, f"keys must be text, got {_short(name)} "
                                f"({type(name).__name__})")
                continue
            _check_plain(errors, f"{key}.{name}" if key else name, item)
    elif isinstance(value, list):
        for i, item in enumerate(value):
            _check_plain(errors, f"{key}[{i}]", item)
    elif isinstance(value, float):
        if not math.isfinite(value):
            errors.add(key, f"must be a finite number, got {value!r}")
    elif not (value is None or isinstance(value, (str, int, bool))):
        errors.add(key, f"must be text, a number, true/false, null, a list or a "
                        f"mapping, got a {type(value).__name__} "
                        f"({_short(value)})")


def parse_suite(data: Any, source: str = "<suite>", text: str | None = None) -> SuiteSpec:
    """A :class:`SuiteSpec` from the parsed YAML ``data`` (``source`` names it in errors).

    Raises:
        ValueError: (:class:`SuiteError`) every mistake of the file, one line each naming the
            file and the key, in the file's order.
    """
    errors = _Errors(source)
    _check_plain(errors, "", data)
    errors.raise_any()  # a value YAML alone has (a date, a set) is reported before any other
    if text is None:
        text = yaml.safe_dump(data, sort_keys=False)
    if not _mapping(errors, "", data, TOP_KEYS, required=("name", "seeds", "arms")):
        errors.raise_any()
    name = data.get("name")
    if "name" in data and (not isinstance(name, str) or not _NAME.match(name)):
        errors.add("name", f"must be a non-empty name of letters, digits and "
                           f"'_.-', got {_short(name)}")
    description = data.get("description", "")
    if not isinstance(description, str):
        errors.add("description", f"must be text, got {_short(description)}")
    seeds = (errors.check(_check_seeds, source, "seeds", data["seeds"], default=())
             if "seeds" in data else ())
    cycles = errors.check(_check_cycles, source, "cycles", data.get("cycles", DEFAULT_CYCLES),
                          default=DEFAULT_CYCLES)
    arms_data = data.get("arms", {})
    if "arms" in data and (not isinstance(arms_data, dict) or not arms_data):
        errors.add("arms", f"must map preset names from {sorted(PRESETS)} to arm "
                           f"blocks, got {_short(arms_data)}")
        arms_data = {}
    arms = [_arm(errors, preset, block, cycles) for preset, block in arms_data.items()]
    errors.raise_any()
    return SuiteSpec(name=name, description=description, seeds=seeds, cycles=cycles,
                     arms=tuple(arms), source=source, text=text,
                     sha256=hashlib.sha256(text.encode("utf-8")).hexdigest())


def _arm(errors: _Errors, preset: Any, block: Any, cycles: int) -> ArmEntry | None:
    """The arm ``preset`` of the suite from its ``block``, noting every mistake in it (``None``
    when it has one)."""
    key = f"arms.{preset}"
    before = len(errors.found)
    if preset not in PRESETS:
        errors.add(key, f"unknown preset {_short(preset)}; allowed: {sorted(PRESETS)}")
    if not _mapping(errors, key, block, ARM_KEYS, required=("paths", "conditions", "policies")):
        return None
    paths = block.get("paths", [])
    allowed_paths = list(PATH_SHAPES) + ["waypoints"]
    if "paths" in block:
        if not isinstance(paths, list) or not paths:
            errors.add(f"{key}.paths", f"must be a non-empty list of path names from "
                                       f"{allowed_paths}, got {_short(paths)}")
            paths = []
        for i, path in enumerate(paths):
            if path not in allowed_paths:
                errors.add(f"{key}.paths[{i}]", f"unknown path {_short(path)}; allowed: "
                                                f"{allowed_paths}")
        if len(set(map(repr, paths))) != len(paths):
            errors.add(f"{key}.paths", f"paths repeat: {_short(paths)}")
    feedback = block.get("feedback")
    if feedback is not None and not (isinstance(feedback, str) and feedback in FEEDBACK_SOURCES):
        errors.add(f"{key}.feedback", f"unknown feedback source {_short(feedback)}; "
                                      f"allowed: {sorted(FEEDBACK_SOURCES)}")
    env = _env_block(errors, f"{key}.env", block.get("env", {}), allow_feedback=False)
    arm_cycles = errors.check(_check_cycles, errors.source, f"{key}.cycles",
                              block.get("cycles", cycles), default=cycles)
    conditions_data = block.get("conditions", {})
    if "conditions" in block and (not isinstance(conditions_data, dict) or not conditions_data):
        errors.add(f"{key}.conditions",
                   f"must map condition names to env keyword arguments (from "
                   f"{list(ENV_KEYS)}; {{}} for nominal), got {_short(conditions_data)}")
        conditions_data = {}
    conditions = {}
    for condition, kwargs in conditions_data.items():
        ckey = f"{key}.conditions.{condition}"
        if not isinstance(condition, str) or not _NAME.match(condition):
            errors.add(ckey, "condition names must be non-empty names of letters, digits and "
                             "'_.-' (they name table rows and plot files)")
        kwargs = _env_block(errors, ckey, {} if kwargs is None else kwargs, allow_feedback=True)
        feedback_here = kwargs.get("feedback")
        if feedback_here is not None and not (isinstance(feedback_here, str)
                                              and feedback_here in FEEDBACK_SOURCES):
            errors.add(f"{ckey}.feedback", f"unknown feedback source {_short(feedback_here)}; "
                                           f"allowed: {sorted(FEEDBACK_SOURCES)}")
        conditions[condition] = kwargs
    policies = (_policies(errors, f"{key}.policies", block["policies"], BASELINES)
                if "policies" in block else ())
    if len(errors.found) > before:
        return None
    return ArmEntry(preset=preset, paths=tuple(paths), feedback=feedback, env=env,
                    cycles=arm_cycles, conditions=conditions, policies=policies)


def _mapping(errors: _Errors, key: str, value: Any, allowed: Sequence[str],
             required: Sequence[str] = ()) -> bool:
    """Note ``value``'s unknown and missing keys; ``False`` when it is no mapping at all."""
    where = key or "top level"
    if not isinstance(value, dict):
        errors.add(key, f"{where} must be a mapping with keys from "
                        f"{list(allowed)}, got {_short(value)}")
        return False
    for unknown in (k for k in value if k not in allowed):
        errors.add(f"{key}.{unknown}" if key else str(unknown),
                   f"unknown key {_short(unknown)}; allowed at {where}: {list(allowed)}")
    for missing in (k for k in required if k not in value):
        errors.add(f"{key}.{missing}" if key else missing,
                   f"missing required key {_short(missing)} ({where} needs {list(required)})")
    return True


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


def _env_block(errors: _Errors, key: str, value: Any, allow_feedback: bool) -> dict[str, Any]:
    """The env keyword arguments of ``value``, noting each one not allowed here (``{}`` when
    ``value`` is no mapping)."""
    allowed = [k for k in ENV_KEYS if allow_feedback or k != "feedback"]
    if not isinstance(value, dict):
        errors.add(key, f"must be a mapping of env keyword arguments from "
                        f"{allowed}, got {_short(value)}")
        return {}
    for name in value:
        if name not in allowed:
            hint = ""
            if name in SUITE_ENV_KEYS:
                hint = " (the suite sets it: use the arm's key or paths)"
            elif name == "feedback":
                hint = " (set the arm's feedback key instead)"
            errors.add(f"{key}.{name}", f"unknown env keyword {_short(name)}{hint}; "
                                        f"allowed: {allowed}")
    return copy.deepcopy(dict(value))


def _baseline_parameters(name: str, baselines: Mapping[str, type]) -> list[str]:
    return [p for p in inspect.signature(baselines[name].__init__).parameters
            if p not in ("self", "env")]


def _policies(errors: _Errors, key: str, value: Any,
              baselines: Mapping[str, str]) -> tuple[PolicyEntry, ...]:
    """The policy entries of ``value``, noting every mistake in them."""
    if not isinstance(value, list) or not value:
        errors.add(key, f"must be a non-empty list of policies: names from "
                        f"{sorted(baselines)}, sb3:PATH, or mappings with keys "
                        f"{list(POLICY_KEYS)}; got {_short(value)}")
        return ()
    entries, labels = [], {}
    for i, item in enumerate(value):
        pkey = f"{key}[{i}]"
        if isinstance(item, str):
            item = {"name": item}
        if not _mapping(errors, pkey, item, POLICY_KEYS, required=("name",)):
            continue
        name = item.get("name")
        known = isinstance(name, str) and (name in baselines
                                           or (name.startswith("sb3:") and len(name) > 4))
        if "name" in item and not known:
            errors.add(f"{pkey}.name", f"unknown policy {_short(name)}; allowed: "
                                       f"{sorted(baselines)} or sb3:PATH")
        params = item.get("params", {}) or {}
        seed_params = item.get("seed_params", []) or []
        if not isinstance(params, dict):
            errors.add(f"{pkey}.params", f"must be a mapping of the policy's "
                                         f"keyword arguments, got {_short(params)}")
            params = {}
        if not isinstance(seed_params, list) or not all(isinstance(p, str) for p in seed_params):
            errors.add(f"{pkey}.seed_params", f"must be a list of parameter "
                                              f"names, got {_short(seed_params)}")
            seed_params = []
        if not known:
            pass
        elif name.startswith("sb3:"):
            if params or seed_params:
                errors.add(f"{pkey}.params", "an sb3 agent takes no params or seed_params")
        else:
            allowed = _baseline_parameters(name, baselines)
            for pname in list(params) + list(seed_params):
                if pname not in allowed:
                    where = "params" if pname in params else "seed_params"
                    errors.add(f"{pkey}.{where}.{pname}",
                               f"unknown parameter {_short(pname)} of {name}; allowed: "
                               f"{allowed}")
            for both in sorted(set(params) & set(seed_params)):
                errors.add(f"{pkey}.params.{both}",
                           f"{_short(both)} is in both params and seed_params")
        env = _env_block(errors, f"{pkey}.env",
                         item.get("env", POLICY_ENV_DEFAULTS.get(name, {}) if known else {}),
                         allow_feedback=True)
        label = item.get("label", policy_label(name) if known else f"policy{i}")
        if not isinstance(label, str) or not _NAME.match(label):
            errors.add(f"{pkey}.label", f"must be a name of letters, digits and "
                                        f"'_.-', got {_short(label)}")
        elif label in labels:
            errors.add(f"{pkey}.label",
                       f"label {_short(label)} is also {key}[{labels[label]}]'s: give each "
                       f"entry its own label")
        else:
            labels[label] = i
        if known:
            entries.append(PolicyEntry(name=name, label=label, params=copy.deepcopy(params),
                                       seed_params=tuple(seed_params), env=env))
    return tuple(entries)
