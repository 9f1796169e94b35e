"""The parts of the claims ledger: a claim, the experiment that tests it, and a verdict.

A :class:`Claim` is one headline finding of one paper, written down before any run: where the
paper states it, the claim in one sentence, the paper's own figures, and the criterion for
"reproduced", taken from those figures. Its ``check`` reads the summary an experiment wrote for
one seed and returns an :class:`Outcome`: the verdict on that seed and the numbers that decided
it. Over several seeds, :func:`combine` gives the claim's verdict: *reproduced* where every seed
reproduced it, *not reproduced* where most seeds did not reproduce even part of it, *partly*
otherwise.

Criteria judge effect sizes (:class:`Effect`): the paper's effect as a number (a ratio, an
improvement or a level, with the paper's own spread over its cases) and a band around it. Ours is
*reproduced* inside the band (0.8x-1.25x of the paper's size unless stated), *partly* where it has
at least half the paper's effect in the paper's direction, *not reproduced* below that. A claim the
paper reports per path, load or configuration is judged on each, and takes the worst
(:func:`worst`); a claim about a disturbance first judges the disturbance's own effect on the source
it hurts, and takes the worse of the two.

A :class:`ClaimExperiment` runs one of the papers' experiments for one seed, in full (the
paper's protocol) or ``quick`` (a small version of it, minutes), and returns a JSON-able summary
of the numbers the claims read; several claims may share one experiment.
"""

from __future__ import annotations

import math
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
    """The verdict over seeds: reproduced on every seed -> reproduced; not even partly
    reproduced on most seeds (more than half) -> not reproduced; anything else -> partly."""
    if not outcomes:
        raise ValueError("combine needs the outcome of at least one seed, got none")
    verdicts = [outcome.verdict for outcome in outcomes]
    if all(verdict == "reproduced" for verdict in verdicts):
        return "reproduced"
    if 2 * verdicts.count("not reproduced") > len(verdicts):
        return "not reproduced"
    return "partly"


def worst(verdicts: Sequence[Verdict]) -> Verdict:
    """The worst of several verdicts (a claim judged per path, load or configuration, or a
    disturbance's own effect and the claim about it)."""
    if not verdicts:
        raise ValueError("worst needs at least one verdict, got none")
    return max(verdicts, key=VERDICTS.index)


EffectKind = Literal["ratio", "fraction", "level"]
EFFECT_KINDS: tuple[EffectKind, ...] = ("ratio", "fraction", "level")


@dataclass(frozen=True)
class Effect:
    """A paper's effect as a number, and the band in which ours reproduces it.

    Three kinds:

    - ``"ratio"``: one error over another (``a / b``; no effect: 1). The paper's ratio may lie on
      either side of 1; its effect is ``|log r|`` in the paper's direction. Reproduced where
      ours lies within ``band`` times the paper's range; partly where ours is on the paper's
      side of 1 with at least half the paper's smallest effect, ``|log r| >= 0.5 |log r_p|``
      (e.g. a paper's 5.67 -> at least 2.38), or beyond the band's top.
    - ``"fraction"``: an improvement or reduction ``(a - b) / a`` (no effect: 0). Reproduced
      within ``band`` times the paper's range; partly at least half the paper's smallest, or
      beyond the band's top.
    - ``"level"``: a value the paper states (an error "about 1 mm", an RMSE, a step count),
      where both too large and far too small miss it (an error far below the paper's is a
      fidelity gap). Reproduced within ``band`` times the paper's range; partly within half
      to twice it.

    Attributes:
        kind: one of :data:`EFFECT_KINDS`.
        paper: the paper's value, or its ``(smallest, largest)`` over the cases it reports.
        band: ``(low, high)`` factors on the paper's range for "reproduced" (default 0.8 and
            1.25; a claim may give the paper's own spread instead).
        unit: how a value is written (``"x"``, ``"%"`` for a fraction, ``"mm"``...).
    """

    kind: EffectKind
    paper: float | tuple[float, float]
    band: tuple[float, float] = (0.8, 1.25)
    unit: str = ""

    def __post_init__(self) -> None:
        if self.kind not in EFFECT_KINDS:
            raise ValueError(f"kind must be one of {list(EFFECT_KINDS)}, got {self.kind!r}")
        low, high = self.range
        if not (math.isfinite(low) and math.isfinite(high) and 0 < low <= high):
            raise ValueError(f"paper must be a positive value or a (smallest, largest) pair, "
                             f"got {self.paper!r}")
        if self.kind == "ratio" and low < 1 < high:
            raise ValueError(f"a ratio's paper range must lie on one side of 1, got "
                             f"{self.paper!r}")
        if self.kind == "ratio" and low == high == 1:
            raise ValueError("a ratio of 1 is no effect")
        if not (len(self.band) == 2 and 0 < self.band[0] <= 1 <= self.band[1]):
            raise ValueError(f"band must be (low <= 1, high >= 1) factors, got {self.band!r}")

    @property
    def range(self) -> tuple[float, float]:
        """The paper's ``(smallest, largest)`` value."""
        if isinstance(self.paper, tuple):
            return float(self.paper[0]), float(self.paper[1])
        return float(self.paper), float(self.paper)

    def _oriented(self, value: float) -> tuple[float, float, float]:
        """A ratio below 1 as its reciprocal, so the effect always grows with the value:
        ``(value, smallest, largest)``."""
        low, high = self.range
        if self.kind == "ratio" and high < 1:
            return (math.inf if value <= 0 else 1.0 / value), 1.0 / high, 1.0 / low
        return value, low, high

    def verdict(self, value: float | None) -> Verdict:
        """Ours (``None`` or NaN: not measured -> not reproduced) against the paper's."""
        if value is None or not math.isfinite(value):
            return "not reproduced"
        value, low, high = self._oriented(float(value))
        lo, hi = self.band[0] * low, self.band[1] * high
        if self.kind == "level":
            if lo <= value <= hi:
                return "reproduced"
            return "partly" if 0.5 * low <= value <= 2.0 * high else "not reproduced"
        half = (math.sqrt(low) if self.kind == "ratio" else 0.5 * low)
        if value < half:
            return "not reproduced"
        return "reproduced" if lo <= value <= hi else "partly"

    def criterion(self) -> str:
        """The bars in words: ``"reproduced within 4.53-7.09 x (0.8-1.25 x the paper's
        5.67); partly from 2.38 x"``."""
        low, high = self.range
        paper = self.show(low) if low == high else f"{self.show(low)}-{self.show(high)}"
        oriented = self.kind == "ratio" and high < 1
        lo, hi = self.band[0] * low, self.band[1] * high
        if self.kind == "ratio":  # never nearer 1 than half the paper's effect
            lo = max(lo, math.sqrt(low))
        if oriented:  # the band on the reciprocal, written back as ratios below 1
            lo, hi = low / self.band[1], min(high / self.band[0], math.sqrt(high))
        bars = (f"reproduced within {self.show(lo)}-{self.show(hi)} ({self.band[0]:g}-"
                f"{self.band[1]:g} x the paper's {paper})")
        if self.kind == "level":
            return bars + f"; partly within {self.show(0.5 * low)}-{self.show(2.0 * high)}"
        if self.kind == "ratio":
            half = math.sqrt(high) if oriented else math.sqrt(low)
            return bars + f"; partly {'up to' if oriented else 'from'} {self.show(half)}"
        return bars + f"; partly from {self.show(0.5 * low)}"

    def show(self, value: float | None) -> str:
        """A value in this effect's unit (a fraction as a percentage)."""
        if value is None or not math.isfinite(value):
            return "n/a"
        if self.kind == "fraction":
            return f"{100 * value:.0f} %"
        if self.unit == "steps":
            return f"{value:.0f} steps"
        return f"{value:.2f}{' ' + self.unit if self.unit else ''}"

    def part(self, label: str, value: float | None) -> "Part":
        """Ours judged on this effect as one part of a claim (:func:`judged`)."""
        verdict = self.verdict(value)
        return verdict, f"{label} {self.show(value)} ({SHORT[verdict]})"


def criteria(*named: tuple[str, Effect]) -> str:
    """A criterion in words from its effects, each named with its bars
    (``"pentagram: reproduced within ...; circle: ..."``)."""
    return "; ".join(f"{name}: {effect.criterion()}" for name, effect in named)


Part = tuple[Verdict, str]
"""One part of a claim's judgement: its verdict and the numbers behind it, in words."""


def bar(label: str, verdict: Verdict, shown: str) -> Part:
    """A part judged by a bar of its own (a count, an "every point reached"), not an
    :class:`Effect`."""
    if verdict not in VERDICTS:
        raise ValueError(f"verdict must be one of {list(VERDICTS)}, got {verdict!r}")
    return verdict, f"{label} {shown} ({SHORT[verdict]})"


def judged(parts: Sequence[Part], note: str = "") -> Outcome:
    """A claim judged part by part (per path, load, configuration, or a disturbance and the
    claim about it): the claim takes the worst part's verdict, and its measured line names
    every part with its value and verdict, then ``note`` (numbers shown beside them, judged
    by none)."""
    if not parts:
        raise ValueError("judged needs at least one part, got none")
    return Outcome(worst([verdict for verdict, _ in parts]),
                   "; ".join(text for _, text in parts) + note)


SHORT = {"reproduced": "in band", "partly": "partly", "not reproduced": "missed"}
"""How a part's verdict reads in a measured line."""


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
        version: the layout of its summary; raised whenever the summary gains or changes a
            field, so a record of another version is run again (and named by a report).
    """

    name: str
    paper: str
    description: str
    quick_description: str
    run: Callable[[int, bool, int, bool], dict[str, Any]]
    shares: str = ""
    cpu_minutes: tuple[float, float] = (1.0, 1.0)
    version: int = 1

    def __post_init__(self) -> None:
        if not isinstance(self.version, int) or isinstance(self.version, bool) \
                or self.version < 1:
            raise ValueError(f"version must be an integer >= 1, got {self.version!r}")
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
        experiment: the :class:`ClaimExperiment` it reads; ``None`` where the simulation
            cannot run the paper's experiment at all (then ``check`` is ``None`` and ``cause``
            says why: the claim is reported not reproduced, never left out).
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
    experiment: str | None
    check: Callable[[dict[str, Any]], Outcome] | None
    cause: str | None = None

    def __post_init__(self) -> None:
        if (self.experiment is None) != (self.check is None):
            raise ValueError(f"claim {self.key}: experiment and check come together (both or "
                             f"neither), got experiment {self.experiment!r}")
        if self.experiment is None and not self.cause:
            raise ValueError(f"claim {self.key}: a claim the simulation cannot run needs its "
                             f"cause")

    def judge(self, summary: dict[str, Any]) -> Outcome:
        """``check(summary)``, refusing anything but an :class:`Outcome`."""
        if self.check is None:
            raise ValueError(f"claim {self.key} has no experiment to judge: {self.cause}")
        outcome = self.check(summary)
        if not isinstance(outcome, Outcome):
            raise TypeError(f"claim {self.key}: check must return an Outcome, got "
                            f"{type(outcome).__name__}")
        return outcome


def numbers(values: Sequence[float], digits: int = 2) -> str:
    """``(4.42, 3.33)`` -> ``"4.42, 3.33"`` (``None`` -> ``"n/a"``)."""
    return ", ".join("n/a" if v is None else f"{v:.{digits}f}" for v in values)
