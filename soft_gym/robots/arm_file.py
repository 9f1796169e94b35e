"""Arm files: an :class:`~soft_gym.robots.spec.ArmSpec` written to and read from YAML
(docs/architecture.md, "Your own arm").

This module is the one owner of the format. A file holds one mapping:

* ``format``: the format version, :data:`ARM_FILE_FORMAT`;
* the :class:`ArmSpec` fields (``name``, ``mount``, the timings, ``description``);
* ``segments``: a list of mappings of :class:`SegmentSpec` fields, base to tip (at least one);
* ``cylinders``: ``null`` or a mapping of :class:`CylinderSpec` fields (volume actuation);
* ``notes``: a mapping of strings (where the numbers come from).

Every field is written and every field is required: a file holds the whole arm, none of its
values comes from a default that a later version might change, and a file cut short or missing a
line is refused rather than completed. (A field added to the specs later comes with a new format
version, whose reader fills it for older files.) Floats are written with ``repr`` (the shortest
text that reads back as the same float), so a saved arm loads back equal, bit for bit. Reading
accepts YAML 1.2 numbers as well as YAML 1.1's: ``1.5e5`` and ``1e-3`` are numbers (YAML 1.1
reads both as strings).

A bad file is refused with one ``ValueError`` that names the file, the field (``segments[1].
length_m``) and what is allowed: unknown or missing fields, a value of the wrong type (a number
where a string belongs, a quoted number), a duplicated key, garbled YAML, a file that is not a
mapping, another format version. Values are checked by the specs' own validation
(``SegmentSpec.__post_init__`` and the like), its message prefixed with the file and the field;
nothing is clipped or coerced beyond an integer given for a float.

Where an arm is asked for by a value (the env's ``preset=``), :func:`arm_from_preset` decides
between a preset name and a file by :func:`is_arm_file`: an ``os.PathLike``, or a string that
ends in ``.yaml``/``.yml`` or holds a path separator, is a file; any other string is a preset
name.
"""

from __future__ import annotations

import dataclasses
import os
import re
import secrets
import types
import typing
from collections.abc import Hashable
from pathlib import Path
from typing import Any, Union

import yaml

from soft_gym.robots.presets import PRESETS
from soft_gym.robots.spec import ArmSpec, CylinderSpec, SegmentSpec

ARM_FILE_FORMAT = 1
"""The version of the arm-file format this code writes and reads (the file's ``format`` key)."""

ARM_FILE_SUFFIXES = (".yaml", ".yml")
"""Suffixes that mark a ``preset=`` string as an arm file (any case)."""

_HEADER = (f"# soft-arm-gym arm file (format {ARM_FILE_FORMAT}): an ArmSpec, SI units (m, kg, s, "
           f"Pa, rad).\n"
           "# Edit the values (and the name), then use it as preset='<this file>'; "
           "docs/architecture.md, \"Your own arm\".\n")

_SPEC_CLASSES = (ArmSpec, SegmentSpec, CylinderSpec)


# ------------------------------------------------------------------------------- the rule
def is_arm_file(preset: Any) -> bool:
    """Whether ``preset`` (a ``preset=`` value) names an arm file rather than a preset: an
    ``os.PathLike``, or a string ending in ``.yaml``/``.yml`` (any case) or holding a path
    separator (``/``, or the system's own)."""
    if isinstance(preset, os.PathLike):
        return True
    if not isinstance(preset, str):
        return False
    separators = {"/", os.sep} | ({os.altsep} if os.altsep else set())
    return preset.lower().endswith(ARM_FILE_SUFFIXES) or any(s in preset for s in separators)


def arm_from_preset(preset: Any) -> ArmSpec:
    """The arm a ``preset=`` value stands for: an :class:`ArmSpec` as it is, an arm file
    (:func:`is_arm_file`) loaded by :func:`load_preset`, or a preset name from :data:`PRESETS`.

    Raises:
        ValueError: a value of another type, an unknown name (listing the names) or a bad file
            (naming it).
    """
    if isinstance(preset, ArmSpec):
        return preset
    if is_arm_file(preset):
        return load_preset(preset)
    if not isinstance(preset, str) or preset not in PRESETS:
        shown = repr(preset) if isinstance(preset, str) else (
            f"{preset!r} ({type(preset).__name__})")
        raise ValueError(f"preset must be one of {sorted(PRESETS)}, an ArmSpec or a path to an "
                         f"arm file (ending in .yaml or .yml, or holding a path separator; "
                         f"soft_gym.robots.save_preset writes one), got {shown}")
    return PRESETS[preset]


# ------------------------------------------------------------------------------- writing
def save_preset(name_or_spec: str | ArmSpec, path: str | os.PathLike) -> Path:
    """Write an arm (a preset's name or an :class:`ArmSpec`) to the YAML file ``path``, every
    field included; an existing file is replaced whole (written beside it, then renamed).

    Returns:
        the path written.

    Raises:
        ValueError: an unknown preset name, or an arm holding a value no arm file can hold
            (``notes`` other than strings).
    """
    if isinstance(name_or_spec, ArmSpec):
        spec = name_or_spec
    elif isinstance(name_or_spec, str) and name_or_spec in PRESETS:
        spec = PRESETS[name_or_spec]
    else:
        raise ValueError(f"name_or_spec must be one of {sorted(PRESETS)} or an ArmSpec, got "
                         f"{name_or_spec!r}")
    document = {"format": ARM_FILE_FORMAT, **_plain_fields(spec)}
    text = _HEADER + yaml.dump(document, Dumper=_Dumper, sort_keys=False, allow_unicode=True,
                               default_flow_style=False, width=100)
    path = Path(path)
    loaded = _spec_of(_parse(text, path), path)  # what a reader gets: the same arm, notes too
    if loaded != spec or loaded.notes != spec.notes:
        raise AssertionError(f"the arm file of {spec.name!r} does not read back as the arm")
    _write_replacing(path, text)
    return path


class _Dumper(yaml.SafeDumper):
    """The safe dumper, never writing anchors and aliases (every segment in full)."""

    def ignore_aliases(self, data: Any) -> bool:
        return True


_LAST = ("segments", "cylinders", "notes")
"""Fields written after the others, in this order (the long ones)."""


def _plain_fields(spec: Any, where: str = "") -> dict[str, Any]:
    """The dataclass ``spec``'s fields as plain YAML values (floats, ints, bools, strings, lists
    and mappings): the scalars in field order, then :data:`_LAST`."""
    hints = typing.get_type_hints(type(spec))
    names = [field.name for field in dataclasses.fields(spec)]
    names = ([name for name in names if name not in _LAST]
             + [name for name in _LAST if name in names])
    return {name: _plain(hints[name], getattr(spec, name), _join(where, name)) for name in names}


def _plain(hint: Any, value: Any, where: str) -> Any:
    if value is None:
        return None
    hint = _without_none(hint)
    if hint is str and isinstance(value, str):
        return str(value)
    if hint is float and not isinstance(value, (bool, str)):
        return float(value)  # numpy's floats as Python's, exactly
    if hint is int and not isinstance(value, (bool, str)):
        return int(value)
    if hint is bool and not isinstance(value, str):
        return bool(value)
    if hint in _SPEC_CLASSES:
        return _plain_fields(value, where)
    if typing.get_origin(hint) is tuple:  # segments
        (item_hint, _) = typing.get_args(hint)
        return [_plain(item_hint, item, f"{where}[{i}]") for i, item in enumerate(value)]
    if hint is dict:  # notes
        if not all(isinstance(k, str) and isinstance(v, str) for k, v in value.items()):
            raise ValueError(f"{where} must map strings to strings to be written to an arm file, "
                             f"got {value!r}")
        return dict(value)
    if hint in (str, float, int, bool):
        raise ValueError(f"{where} must be a {hint.__name__} to be written to an arm file, got "
                         f"{value!r} ({type(value).__name__})")
    raise TypeError(f"no arm-file form for {where} ({hint!r})")  # a new field type: add it here


def _write_replacing(path: Path, text: str) -> None:
    """``text`` written to ``path`` through a temporary file beside it: a reader never sees a
    half-written file."""
    temporary = path.with_name(f".{path.name}.{os.getpid()}.{secrets.token_hex(4)}.tmp")
    # created as open() creates files (0o666 less the umask), not mkstemp's owner-only 0o600
    handle = os.open(temporary, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666)
    try:
        with os.fdopen(handle, "w", encoding="utf-8") as file:
            file.write(text)
        os.replace(temporary, path)
    except BaseException:
        if os.path.exists(temporary):
            os.unlink(temporary)
        raise


# ------------------------------------------------------------------------------- reading
def load_preset(path: str | os.PathLike) -> ArmSpec:
    """The arm of the arm file ``path`` (written by :func:`save_preset`, or by hand).

    Raises:
        ValueError: one, naming the file, the field and what is allowed, for a file that cannot
            be read, is not YAML, not a mapping, of another format, or lacks a field or holds an
            unknown, duplicated or wrong-typed one or a value the arm's validation refuses.
    """
    if not isinstance(path, (str, os.PathLike)):
        raise ValueError(f"path must be a str or os.PathLike naming an arm file, got {path!r} "
                         f"({type(path).__name__})")
    path = Path(path)
    if not path.is_file():
        state = "is a directory" if path.is_dir() else "does not exist"
        raise ValueError(f"arm file {str(path)!r} {state}: give a YAML arm file "
                         f"(soft_gym.robots.save_preset writes one)")
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as error:
        raise ValueError(f"arm file {str(path)!r} cannot be read as UTF-8 text: "
                         f"{_one_line(error)}") from error
    return _spec_of(_parse(text, path), path)


class _Loader(yaml.SafeLoader):
    """The safe loader, reading YAML 1.2's exponent floats (``1e-3``, ``1.5e5``) as numbers and
    refusing a key given twice in one mapping (YAML 1.1's loaders keep the last silently)."""

    def construct_mapping(self, node: yaml.MappingNode, deep: bool = False) -> dict:
        seen: set = set()
        for key_node, _ in node.value:
            key = self.construct_object(key_node, deep=deep)
            if isinstance(key, Hashable) and key in seen:
                raise yaml.constructor.ConstructorError(
                    "while constructing a mapping", node.start_mark,
                    f"found duplicate key {key!r}", key_node.start_mark)
            seen.add(key)
        return super().construct_mapping(node, deep=deep)


_Loader.add_implicit_resolver(
    "tag:yaml.org,2002:float",
    re.compile(r"^[-+]?(?:[0-9][0-9_]*(?:\.[0-9_]*)?|\.[0-9][0-9_]*)[eE][-+]?[0-9]+$"),
    list("-+0123456789."))


def _parse(text: str, path: Path) -> Any:
    try:
        return yaml.load(text, Loader=_Loader)  # noqa: S506 - a SafeLoader subclass
    except yaml.YAMLError as error:
        raise ValueError(f"arm file {str(path)!r} is not valid YAML: {_yaml_problem(error)}") \
            from error


def _spec_of(document: Any, path: Path) -> ArmSpec:
    file = f"arm file {str(path)!r}"
    if not isinstance(document, dict):
        got = "an empty file" if document is None else f"{type(document).__name__} {document!r}"
        raise ValueError(f"{file} must hold a mapping of the arm's fields (format, name, "
                         f"segments, ...), got {_short(got)}")
    document = dict(document)
    if "format" not in document:
        raise ValueError(f"{file}: field 'format' is missing: an arm file starts with "
                         f"format: {ARM_FILE_FORMAT}")
    version = document.pop("format")
    if type(version) is not int or version != ARM_FILE_FORMAT:
        raise ValueError(f"{file}: format must be {ARM_FILE_FORMAT} (the arm-file format this "
                         f"soft_gym reads), got {version!r}")
    return _build(ArmSpec, document, file, "")


def _build(cls: type, mapping: Any, file: str, where: str) -> Any:
    """``cls`` (a spec dataclass) from ``mapping``, every field checked."""
    what = where or "the arm"
    if not isinstance(mapping, dict):
        raise ValueError(f"{file}: {what} must be a mapping of {cls.__name__} fields, got "
                         f"{_short(repr(mapping))} ({type(mapping).__name__})")
    known = [field.name for field in dataclasses.fields(cls)]
    unknown = [key for key in mapping if key not in known]
    if unknown:
        key = unknown[0]
        raise ValueError(f"{file}: unknown field {_join(where, str(key))!r}: the fields of "
                         f"{cls.__name__} are {known}")
    missing = [name for name in known if name not in mapping]
    if missing:  # a file cut short, or a field deleted: never a default in its place
        raise ValueError(f"{file}: field {_join(where, missing[0])!r} is missing: an arm file "
                         f"gives every field of {cls.__name__} ({len(known)}; python -m soft_gym "
                         f"preset export writes a complete one)")
    hints = typing.get_type_hints(cls)
    values = {name: _value(hints[name], value, file, _join(where, name))
              for name, value in mapping.items()}
    try:
        return cls(**values)
    except ValueError as error:
        message = str(error)
        lead = re.match(r"\w+", message)
        field = _join(where, lead.group()) if lead and lead.group() in known else what
        raise ValueError(f"{file}: {field}: {message}") from error


def _value(hint: Any, value: Any, file: str, where: str) -> Any:
    """``value`` of the field ``where`` as the type ``hint`` wants it, or a ``ValueError``."""
    optional = _without_none(hint) is not hint
    if value is None and optional:
        return None
    hint = _without_none(hint)
    wanted = None
    if hint is float:
        if isinstance(value, (int, float)) and not isinstance(value, bool):
            try:
                return float(value)
            except OverflowError:
                pass
        wanted = "a number"
    elif hint is int:
        if isinstance(value, int) and not isinstance(value, bool):
            return value
        wanted = "an integer"
    elif hint is bool:
        if isinstance(value, bool):
            return value
        wanted = "true or false"
    elif hint is str:
        if isinstance(value, str):
            return value
        wanted = "a string"
    elif hint in _SPEC_CLASSES:
        if isinstance(value, dict):
            return _build(hint, value, file, where)
        wanted = f"a mapping of {hint.__name__} fields"
    elif typing.get_origin(hint) is tuple:  # segments
        (item_hint, _) = typing.get_args(hint)
        if isinstance(value, list):
            return tuple(_value(item_hint, item, file, f"{where}[{i}]")
                         for i, item in enumerate(value))
        wanted = f"a list of mappings of {item_hint.__name__} fields"
    elif hint is dict:  # notes: each one a string
        if isinstance(value, dict):
            return {_value(str, key, file, f"{where} key"): _value(str, note, file,
                                                                    f"{where}.{key}")
                    for key, note in value.items()}
        wanted = "a mapping of strings to strings"
    else:
        raise TypeError(f"no arm-file form for {where} ({hint!r})")  # a new field type: add it
    if optional:
        wanted += " or null"
    raise ValueError(f"{file}: {where} must be {wanted}, got {_short(repr(value))} "
                     f"({type(value).__name__})")


def _without_none(hint: Any) -> Any:
    """``X`` for ``X | None``; any other hint as it is."""
    if typing.get_origin(hint) in (Union, types.UnionType):
        others = [arg for arg in typing.get_args(hint) if arg is not type(None)]
        if len(others) == 1:
            return others[0]
    return hint


def _yaml_problem(error: yaml.YAMLError) -> str:
    """What is wrong and where (line and column, from 1), on one line."""
    if isinstance(error, yaml.MarkedYAMLError) and error.problem:
        mark = error.problem_mark
        place = "" if mark is None else f" at line {mark.line + 1}, column {mark.column + 1}"
        return " ".join(f"{error.problem}{place}".split())
    return _one_line(error)


def _join(where: str, name: str) -> str:
    return f"{where}.{name}" if where else name


def _one_line(error: BaseException) -> str:
    return " ".join(str(error).split())


def _short(text: str, limit: int = 80) -> str:
    return text if len(text) <= limit else text[:limit - 3] + "..."

