"""The registries of named parts, and one parser for "name plus parameters" descriptions.

Every family of named parts (sensors, loads, visual faults, feedback sources, baselines) is one
:class:`Registry`, filled by explicit :meth:`Registry.register` calls in its package's
``__init__`` (so ``import soft_gym.sensors`` is all it takes to see every sensor, and no module
registers itself as a side effect of being imported). Error messages and docs take their name
lists from the registry, never from a hand-kept list.

The factories :func:`soft_gym.scenarios.make_scenario`, :func:`soft_gym.sensors.faults.make_faults`,
:func:`soft_gym.sensors.make_sensor` and :func:`agents.policies.make_policy` take something by
name. Each accepts some of these forms (its ``forms``):

* ``"none"``: ``None`` (nothing);
* ``"name"``: a name string, ``"tip_mass"``;
* ``"dict"``: a dict with ``"name"`` and keyword parameters,
  ``{"name": "tip_mass", "mass_kg": 0.05}``;
* ``"instance"``: an already built object of one of ``instance_types``;
* ``"list"``: a list or tuple of the other accepted forms (nested lists are flattened).

:func:`parse_spec` turns any of them into a flat list of :class:`Spec` (name and parameters, in
order) and instances, and raises one clear ``ValueError`` for every malformed input, naming the
parameter (``kind``, with the list index where there is one), the value and what is allowed.
:func:`build` then calls the named class or function, turning a bad keyword into a
``ValueError`` too.
"""

from __future__ import annotations

import importlib
from collections.abc import Iterator, Mapping
from typing import Any, Callable, Generic, Iterable, NamedTuple, Sequence, TypeVar

T = TypeVar("T")

FORMS = ("none", "name", "dict", "instance", "list")
"""Every form a description may take (see the module docstring)."""


class Registry(Mapping[str, T], Generic[T]):
    """Named parts of one kind, in registration order: a read-only mapping name -> part.

    A part is registered as the object itself or, where importing it costs start-up time that
    most users never need (PyTorch, OpenCV's stereo code), as a ``"module:attribute"`` string
    that is imported on first access (``lazy=True``). Either way ``registry[name]`` gives the
    object; an unknown name raises ``ValueError`` naming the kind, the name and the registered
    names.

    Args:
        kind: what a part is, for error messages (``"sensor"``, ``"feedback source"``).
    """

    def __init__(self, kind: str) -> None:
        self.kind = kind
        self._entries: dict[str, Any] = {}
        self._lazy: set[str] = set()

    def register(self, name: str, part: T | str, *, lazy: bool = False) -> None:
        """Add ``part`` under ``name`` (``lazy=True``: ``part`` is ``"module:attribute"``).

        Raises:
            ValueError: an empty or already registered ``name``, or a lazy part that is not a
                ``"module:attribute"`` string.
        """
        if not isinstance(name, str) or not name or name in self._entries:
            raise ValueError(f"{self.kind} name must be a new non-empty string, got {name!r} "
                             f"(registered: {list(self._entries)})")
        if lazy and not (isinstance(part, str) and part.count(":") == 1):
            raise ValueError(f"a lazy {self.kind} must be given as 'module:attribute', got "
                             f"{part!r}")
        self._entries[name] = part
        if lazy:
            self._lazy.add(name)

    def unregister(self, name: str) -> None:
        """Remove ``name`` (a plug-in that is done, e.g. in a test)."""
        if name not in self._entries:
            raise ValueError(f"{self.kind} must be one of {list(self._entries)}, got {name!r}")
        del self._entries[name]
        self._lazy.discard(name)

    def __getitem__(self, name: str) -> T:
        if not isinstance(name, str) or name not in self._entries:
            raise ValueError(f"{self.kind} must be one of {list(self._entries)}, got {name!r}")
        if name in self._lazy:
            module_name, attribute = self._entries[name].split(":")
            self._entries[name] = getattr(importlib.import_module(module_name), attribute)
            self._lazy.discard(name)
        return self._entries[name]

    def get(self, name: str, default: Any = None) -> Any:
        """The part ``name``, or ``default`` when nothing is registered under it."""
        return self[name] if name in self._entries else default

    def __contains__(self, name: object) -> bool:
        return name in self._entries

    def __iter__(self) -> Iterator[str]:
        return iter(self._entries)

    def __len__(self) -> int:
        return len(self._entries)

    def __repr__(self) -> str:
        return f"Registry({self.kind!r}, {list(self._entries)})"


class Spec(NamedTuple):
    """A described element: its registered ``name`` and keyword ``params``."""

    name: str
    params: dict[str, Any]


def _allowed(forms: Sequence[str], names: Sequence[str], instance_types: tuple[type, ...],
             also: Sequence[str]) -> str:
    """What a description may be, in words, for the error messages."""
    parts = []
    if "none" in forms:
        parts.append("None")
    if "name" in forms:
        parts.append(f"a name from {list(names) + list(also)}")
    if "dict" in forms:
        parts.append("a dict {'name': NAME, **parameters}")
    if "instance" in forms and instance_types:
        parts.append("a " + " / ".join(t.__name__ for t in instance_types) + " instance")
    text = ", ".join(parts[:-1]) + (" or " if len(parts) > 1 else "") + parts[-1]
    return text + (", or a list of these" if "list" in forms else "")


def _check_name(label: str, name: Any, names: Sequence[str], also: Sequence[str]) -> str:
    if not isinstance(name, str) or name not in names:
        raise ValueError(f"{label} name must be one of {list(names) + list(also)}, "
                         f"got {name!r}")
    return name


def parse_spec(value: Any, kind: str, known_names: Iterable[str], *,
               forms: Sequence[str] = ("none", "name", "dict", "list"),
               instance_types: Sequence[type] = (), also: Sequence[str] = ()) -> list:
    """Parse a name-plus-parameters description (see the module docstring).

    Args:
        value: the description.
        kind: the parameter's name, used in error messages (``"scenario"``, ``"faults"``, ...).
        known_names: the registered names.
        forms: the accepted forms, a subset of :data:`FORMS`.
        instance_types: the classes passed through as built objects (form ``"instance"``).
        also: further allowed values described in the name list of error messages (e.g.
            ``"sb3:PATH"``, which the caller handles before parsing).

    Returns:
        A flat list, in order, of :class:`Spec` for names and dicts and of the instances
        passed through; ``None`` (also inside lists) contributes nothing.

    Raises:
        ValueError: naming ``kind`` (and the list index), the value and what is allowed, for a
            form not accepted, a dict without a string ``"name"``, an unknown name or parameter
            names that are not strings.
    """
    unknown_forms = [form for form in forms if form not in FORMS]
    if unknown_forms or not forms:
        raise ValueError(f"forms must be a non-empty subset of {list(FORMS)}, got {forms!r}")
    names = sorted(known_names)
    types = tuple(instance_types) if "instance" in forms else ()
    allowed = _allowed(forms, names, types, also)
    result: list = []

    def parse(item: Any, label: str) -> None:
        if item is None and "none" in forms:
            return
        if types and isinstance(item, types):
            result.append(item)
            return
        if isinstance(item, (list, tuple)) and "list" in forms:
            for index, element in enumerate(item):
                parse(element, f"{label}[{index}]")
            return
        if isinstance(item, str) and "name" in forms:
            result.append(Spec(_check_name(label, item, names, also), {}))
            return
        if isinstance(item, dict) and "dict" in forms:
            if "name" not in item:
                raise ValueError(f"{label} must have a 'name' key (one of {names}), got "
                                 f"{item!r}")
            params = dict(item)
            name = _check_name(label, params.pop("name"), names, ())
            bad = [key for key in params if not isinstance(key, str)]
            if bad:
                raise ValueError(f"{label} {name!r} parameter names must be strings, got "
                                 f"{bad!r} in {item!r}")
            result.append(Spec(name, params))
            return
        raise ValueError(f"{label} must be {allowed}, got {item!r}")

    parse(value, kind)
    return result


def build(kind: str, name: str, factory: Callable[..., Any], params: dict[str, Any]) -> Any:
    """``factory(**params)``, with a wrong or missing keyword raised as ``ValueError`` naming
    ``kind``, ``name`` and the parameters given."""
    try:
        return factory(**params)
    except TypeError as error:
        raise ValueError(f"{kind} {name!r} got invalid parameters {params}: {error}") from error
