"""The parts of the claims ledger: a claim, the experiment that tests it, and a verdict.

A :class:`Claim` is one headline finding of one paper, written down before any run: where the
paper states it, the claim in one sentence, the paper's own figures, and the criterion for
"reproduced", taken from those figures. Its ``check`` reads the summary an experiment wrote for
one seed and returns an :class:`Outcome`: the verdict on that seed and the numbers that decided
it. Over several seeds, :func:`combine` gives the claim's verdict: *reproduced* where every seed
reproduced it, *not reproduced* where none reproduced any of it, *partly* otherwise.

A :class:`ClaimExperiment` runs one of the papers' experiments for one seed, in full (the
paper's protocol) or ``quick`` (a small version of it, minutes), and returns a JSON-able summary
of the numbers the claims read; several claims may share one experiment.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable, Literal, Sequence

Verdict = Literal["reproduced", "partly", "not reproduced"]
VERDICTS: tuple[Verdict, ...] = ("reproduced", "partly", "not reproduced")
"""The verdicts, best first."""
NOT_RUN = "not run"
"""A claim's place in a report when no seed of its experiment is on record."""


@dataclass(frozen=True)
class Outcome:
    """A claim's verdict on one seed.

    Attributes:
        verdict: one of :data:`VERDICTS`.
        measured: the numbers that decided it, in one line with units
            (``"online 4.61, 2.70, 2.59 mm: cycle 3 / cycle 1 = 0.56"``).
    """

    verdict: Verdict
    measured: str

    def __post_init__(self) -> None:
        if self.verdict not in VERDICTS:
            raise ValueError(f"verdict must be one of {list(VERDICTS)}, got {self.verdict!r}")
        if not isinstance(self.measured, str) or not self.measured:
            raise ValueError(f"measured must be a non-empty string, got {self.measured!r}")


def graded(full: bool, part: bool, measured: str) -> Outcome:
    """The outcome of a criterion with a partial level: ``full`` -> reproduced, else ``part``
    -> partly, else not reproduced."""
    verdict: Verdict = "reproduced" if full else ("partly" if part else "not reproduced")
    return Outcome(verdict, measured)


def combine(outcomes: Sequence[Outcome]) -> Verdict:
    """The verdict over seeds: reproduced on every seed -> reproduced; not reproduced on
    every seed -> not reproduced; anything else -> partly."""
    if not outcomes:
        raise ValueError("combine needs the outcome of at least one seed, got none")
    verdicts = {outcome.verdict for outcome in outcomes}
    if verdicts == {"reproduced"}:
        return "reproduced"
    if verdicts == {"not reproduced"}:
        return "not reproduced"
    return "partly"


@dataclass(frozen=True)
class ClaimExperiment:
    """One experiment the claims read, run once per seed.

    Attributes:
        name: registry name, ``<paper>.<experiment>`` (``"ho2018.static"``).
        paper: the paper's key.
        description: what runs, in full (the paper's protocol).
        quick_description: what ``quick`` shortens.
        run: ``run(seed, quick, workers, progress) -> summary``: a dict of JSON-able numbers
            (lists, floats, ints, strings, ``None``) that the claims' checks read.
        shares: experiments of one paper with the same ``shares`` build the same calibration,
            data set or model (cached after the first), so a parallel ledger runs them in one
            job, in registry order, and builds it once; ``""`` (default): a job of its own.
        cpu_minutes: roughly how long one seed takes on one core, ``(quick, full)`` (minutes,
            measured: the records' ``cpu_seconds``). A parallel ledger starts the longest jobs
            first; nothing else reads it.
    """

    name: str
    paper: str
    description: str
    quick_description: str
    run: Callable[[int, bool, int, bool], dict[str, Any]]
    shares: str = ""
    cpu_minutes: tuple[float, float] = (1.0, 1.0)

    def __post_init__(self) -> None:
        minutes = self.cpu_minutes
        if (not isinstance(minutes, tuple) or len(minutes) != 2
                or not all(isinstance(m, (int, float)) and not isinstance(m, bool) and m > 0
                           for m in minutes)):
            raise ValueError(f"cpu_minutes must be a (quick, full) pair of positive minutes, "
                             f"got {minutes!r}")
        if not isinstance(self.shares, str):
            raise ValueError(f"shares must be a string, got {self.shares!r}")


@dataclass(frozen=True)
class Claim:
    """One headline finding of one paper.

    Attributes:
        key: registry name, ``<paper>.<finding>`` (``"ho2018.table1_online_learns"``).
        paper: the paper's key (``wang2023``, ``ho2018``, ``zhao2021``, ``zou2022``).
        where: the table, figure or section stating it (``"Table 1"``).
        statement: the claim in one sentence.
        paper_figures: the paper's own numbers behind it.
        criterion: when it counts as reproduced (and partly), from the paper's figures.
        experiment: the :class:`ClaimExperiment` it reads.
        check: ``check(summary) -> Outcome`` on one seed's summary of ``experiment``.
        cause: where the claim is not reproduced on the paper's protocol (full runs, seeds
            0-2), the measured cause in one line (or ``"unknown"``); ``None`` where it is.
            The slow tests mark such a claim ``xfail(strict=True)`` with this reason.
    """

    key: str
    paper: str
    where: str
    statement: str
    paper_figures: str
    criterion: str
    experiment: str
    check: Callable[[dict[str, Any]], Outcome]
    cause: str | None = None

    def judge(self, summary: dict[str, Any]) -> Outcome:
        """``check(summary)``, refusing anything but an :class:`Outcome`."""
        outcome = self.check(summary)
        if not isinstance(outcome, Outcome):
            raise TypeError(f"claim {self.key}: check must return an Outcome, got "
                            f"{type(outcome).__name__}")
        return outcome


def numbers(values: Sequence[float], digits: int = 2) -> str:
    """``(4.42, 3.33)`` -> ``"4.42, 3.33"`` (``None`` -> ``"n/a"``)."""
    return ", ".join("n/a" if v is None else f"{v:.{digits}f}" for v in values)
