"""A paper as one plug-in: its arms, its feedback sources with their calibration, and where the
evaluation layer finds its experiments, claims, datasets and subcommand.

One :func:`register_paper` call makes a paper known everywhere: its arms become presets
(:data:`soft_gym.robots.presets.PRESETS`, with the cylinders its paper drives volumes with), its
feedback sources become ``feedback=`` names (:data:`soft_gym.sensing.FEEDBACK_SOURCES`) with
their calibration procedures (:data:`soft_gym.procedures.calibration.CALIBRATIONS`), its visual
disturbance protocols become ``faults=`` presets (:data:`soft_gym.sensors.faults.FAULT_PRESETS`),
and the
evaluation layer imports :attr:`Paper.evaluation` for the rest. A paper outside the package is
registered the same way (docs/architecture.md, "A fifth paper").
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field

from soft_gym._registry import Registry
from soft_gym.procedures.calibration import CALIBRATIONS, Calibration
from soft_gym.robots.presets import PRESETS, register_preset, unregister_preset
from soft_gym.robots.spec import ArmSpec, CylinderSpec
from soft_gym.sensing import FEEDBACK_SOURCES
from soft_gym.sensing.feedback_base import FeedbackSource
from soft_gym.sensors.faults import FAULT_PRESETS


@dataclass(frozen=True)
class Paper:
    """What one paper adds to the toolkit.

    Attributes:
        key: the paper's key (first author and year, ``"zou2022"``): its folder's name and the
            name docs and claims cite it by.
        citation: the paper in words (``"Zou et al. 2022"``).
        arms: the arms it describes, each registered as a preset under its ``name``.
        feedback_sources: its estimators as :class:`FeedbackSource` classes, each registered
            under its ``name`` (in this order).
        calibrations: the calibration procedure of each calibrating source, by source name.
        cylinders: the cylinders that drive the chamber volumes where the paper drives volumes
            (``actuation="volume"``), for every arm of the paper; ``None`` where it drives
            pressures.
        cylinder_notes: where :attr:`cylinders`' numbers come from (merged into the arm's notes).
        fault_presets: the paper's visual-disturbance protocols by name (``faults=<name>``),
            each a function returning a list of faults
            (:data:`soft_gym.sensors.faults.FAULT_PRESETS`).
        evaluation: the importable module of the evaluation layer holding the paper's
            experiments, claims, datasets and subcommand (``"eval.papers.zou2022"``), or
            ``None`` for a paper with none.
    """

    key: str
    citation: str
    arms: tuple[ArmSpec, ...] = ()
    feedback_sources: tuple[type[FeedbackSource], ...] = ()
    calibrations: Mapping[str, Calibration] = field(default_factory=dict)
    cylinders: CylinderSpec | None = None
    cylinder_notes: Mapping[str, str] = field(default_factory=dict)
    fault_presets: Mapping[str, Callable[..., list]] = field(default_factory=dict)
    evaluation: str | None = None


PAPERS: Registry[Paper] = Registry("paper")
"""Every registered paper by key, in registration order."""


def _check(paper: Paper) -> None:
    """One ``ValueError`` naming the field, the value and what is allowed."""
    if not isinstance(paper, Paper):
        raise ValueError(f"paper must be a Paper, got {type(paper).__name__}")
    if not isinstance(paper.key, str) or not paper.key.isidentifier():
        raise ValueError(f"Paper.key must be a name usable as a module name (letters, digits, "
                         f"underscores), got {paper.key!r}")
    for arm in paper.arms:
        if not isinstance(arm, ArmSpec):
            raise ValueError(f"Paper.arms of {paper.key!r} must hold ArmSpec, got "
                             f"{type(arm).__name__}")
    names = []
    for source in paper.feedback_sources:
        if not (isinstance(source, type) and issubclass(source, FeedbackSource) and source.name):
            raise ValueError(f"Paper.feedback_sources of {paper.key!r} must hold named "
                             f"FeedbackSource subclasses, got {source!r}")
        names.append(source.name)
    if len(set(names)) != len(names) or len({arm.name for arm in paper.arms}) != len(paper.arms):
        raise ValueError(f"Paper {paper.key!r} names a feedback source or an arm twice: sources "
                         f"{names}, arms {[arm.name for arm in paper.arms]}")
    calibrating = [source.name for source in paper.feedback_sources if source.calibrates]
    missing = sorted(set(calibrating) - set(paper.calibrations))
    stray = sorted(set(paper.calibrations) - set(calibrating))
    if missing or stray:
        raise ValueError(f"Paper.calibrations of {paper.key!r} must give a procedure for each "
                         f"calibrating source {sorted(calibrating)} and nothing else; missing "
                         f"{missing}, not calibrating sources {stray}")
    for name, preset in paper.fault_presets.items():
        if not (isinstance(name, str) and name and callable(preset)):
            raise ValueError(f"Paper.fault_presets of {paper.key!r} must map names to functions "
                             f"returning faults, got {name!r}: {preset!r}")
    if paper.cylinders is not None and not paper.arms:
        raise ValueError(f"Paper.cylinders of {paper.key!r} needs arms to drive")
    if paper.evaluation is not None and not (
            isinstance(paper.evaluation, str)
            and all(part.isidentifier() for part in paper.evaluation.split("."))):
        raise ValueError(f"Paper.evaluation of {paper.key!r} must be a dotted module name or "
                         f"None, got {paper.evaluation!r}")


def register_paper(paper: Paper) -> None:
    """Register ``paper``: its arms as presets, its feedback sources with their calibrations,
    and the paper itself in :data:`PAPERS` (for the evaluation layer).

    Everything is checked before anything is registered, so a refused paper leaves every
    registry as it was.

    Raises:
        ValueError: a malformed paper, or a key, arm or source name already registered.
    """
    _check(paper)
    for registry, names in ((PAPERS, [paper.key]),
                            (FEEDBACK_SOURCES, [s.name for s in paper.feedback_sources]),
                            (FAULT_PRESETS, list(paper.fault_presets))):
        taken = [name for name in names if name in registry]
        if taken:
            raise ValueError(f"{registry.kind} {taken} of paper {paper.key!r} already "
                             f"registered (registered: {list(registry)})")
    taken = [arm.name for arm in paper.arms if arm.name in PRESETS]
    if taken:
        raise ValueError(f"preset {taken} of paper {paper.key!r} already registered "
                         f"(registered: {list(PRESETS)})")
    for arm in paper.arms:
        register_preset(arm, paper.cylinders, paper.cylinder_notes)
    for source in paper.feedback_sources:
        FEEDBACK_SOURCES.register(source.name, source)
    for name, procedure in paper.calibrations.items():
        CALIBRATIONS.register(name, procedure)
    for name, preset in paper.fault_presets.items():
        FAULT_PRESETS.register(name, preset)
    PAPERS.register(paper.key, paper)


def unregister_paper(key: str) -> None:
    """Remove the paper ``key`` and everything its registration added (a plug-in that is done,
    e.g. in a test)."""
    paper = PAPERS[key]
    for name in paper.fault_presets:
        FAULT_PRESETS.unregister(name)
    for name in paper.calibrations:
        CALIBRATIONS.unregister(name)
    for source in paper.feedback_sources:
        FEEDBACK_SOURCES.unregister(source.name)
    for arm in paper.arms:
        unregister_preset(arm.name)
    PAPERS.unregister(key)
