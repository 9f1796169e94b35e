"""Each paper's evaluation, one folder per paper: ``eval/papers/<key>/`` holds its experiments
(``python -m eval <command>``), its claims (``python -m eval claims``) and its dataset
collector (``python -m eval datasets``).

A folder's ``__init__`` is the paper's evaluation plug-in, named by its
:attr:`soft_gym.papers.Paper.evaluation`; it may define

* ``EXPERIMENTS`` and ``CLAIMS``: its :class:`~eval.claims.ledger.ClaimExperiment` and
  :class:`~eval.claims.ledger.Claim` tuples (the claims ledger);
* ``DATASET``: its :class:`~eval.datasets.papers.PaperDataset`;
* ``COMMANDS``: its subcommands of ``python -m eval``, by name.

The shared layers (the suite, the ledger's machinery, metrics, reports) stay in ``eval/``.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Iterator, Mapping
from types import ModuleType
from typing import Any, Generic, TypeVar

from soft_gym._registry import Registry
from soft_gym.papers import PAPERS

T = TypeVar("T")


def evaluations() -> dict[str, ModuleType]:
    """The evaluation module of every registered paper that names one, by paper key, in
    registration order (each imported on first use).

    Raises:
        ValueError: a paper whose ``evaluation`` module cannot be imported (naming the paper and
            the module).
    """
    modules = {}
    for key, paper in PAPERS.items():
        if paper.evaluation is None:
            continue
        try:
            modules[key] = importlib.import_module(paper.evaluation)
        except ModuleNotFoundError as error:
            if error.name is None or not paper.evaluation.startswith(error.name):
                raise
            raise ValueError(f"Paper.evaluation of {key!r} must name an importable module, got "
                             f"{paper.evaluation!r} ({error})") from None
    return modules


class PaperParts(Mapping[str, T], Generic[T]):
    """One kind of part every paper's evaluation module defines, by name: its ``attribute`` (a
    tuple of parts, or one part with ``single=True``), keyed by ``key_of(part)`` (with
    ``single=True``, by the paper's key), then any part registered here by hand
    (:meth:`register`).

    Looked up on every access, so a paper registered after import joins; read like a
    :class:`~soft_gym._registry.Registry` (an unknown name raises ``ValueError`` naming the
    names; a name defined twice raises ``ValueError`` naming both owners).
    """

    def __init__(self, kind: str, attribute: str, key_of: Callable[[T], str] | None = None,
                 single: bool = False) -> None:
        self.kind, self.attribute, self.single = kind, attribute, single
        self.key_of = key_of
        self._by_hand: Registry[T] = Registry(kind)

    def _entries(self) -> dict[str, T]:
        entries: dict[str, T] = {}
        owners: dict[str, str] = {}
        for paper, module in evaluations().items():
            found = getattr(module, self.attribute, None)
            if found is None:
                continue
            parts = {paper: found} if self.single else {self.key_of(part): part for part in found}
            for name, part in parts.items():
                if name in entries:
                    raise ValueError(f"{self.kind} {name!r} is defined by both {owners[name]!r} "
                                     f"and {paper!r}")
                entries[name], owners[name] = part, paper
        for name in self._by_hand:
            if name in entries:
                raise ValueError(f"{self.kind} {name!r} is registered by hand and defined by "
                                 f"{owners[name]!r}")
            entries[name] = self._by_hand[name]
        return entries

    def register(self, name: str, part: T) -> None:
        """Add ``part`` under ``name`` outside any paper (a test's own part)."""
        if name in self._entries():
            raise ValueError(f"{self.kind} name must be new, got {name!r}")
        self._by_hand.register(name, part)

    def unregister(self, name: str) -> None:
        """Remove a part registered by hand."""
        self._by_hand.unregister(name)

    def __getitem__(self, name: str) -> T:
        entries = self._entries()
        if not isinstance(name, str) or name not in entries:
            raise ValueError(f"{self.kind} must be one of {list(entries)}, got {name!r}")
        return entries[name]

    def get(self, name: str, default: Any = None) -> Any:
        """The part ``name``, or ``default`` when there is none."""
        return self._entries().get(name, default)

    def __contains__(self, name: object) -> bool:
        return name in self._entries()

    def __iter__(self) -> Iterator[str]:
        return iter(self._entries())

    def __len__(self) -> int:
        return len(self._entries())

    def __repr__(self) -> str:
        return f"PaperParts({self.kind!r}, {list(self._entries())})"
