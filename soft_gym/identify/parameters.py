"""The arm parameters a fit may change: their names, values and bounds, and an arm with new values.

A parameter is a field of the arm (``pneumatic_time_constant_s``) or of one segment
(``youngs_modulus_pa[0]``, ``damping_ratio[1]``, ``extra_tip_mass_kg[1]``). A family name without
an index (``youngs_modulus_pa``) stands for the field of every segment; ``extra_tip_mass_kg``
alone is the last segment's (the tip payload). Every value is positive and fitted in log-scale
within ``[LOWER_FACTOR, UPPER_FACTOR]`` times the base arm's value.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, replace

from soft_gym.robots.spec import ArmSpec

ARM_FIELDS = ("pneumatic_time_constant_s",)
"""Fittable fields of the arm as a whole."""
SEGMENT_FIELDS = ("youngs_modulus_pa", "damping_ratio", "extra_tip_mass_kg")
"""Fittable fields of a segment."""
FAMILIES = (*SEGMENT_FIELDS, *ARM_FIELDS)
"""Every name ``--params`` takes (with ``[k]`` after a segment field for one segment)."""
DEFAULT_FAMILIES = ("youngs_modulus_pa", "pneumatic_time_constant_s", "damping_ratio",
                    "extra_tip_mass_kg")
"""What a fit changes unless told: the parameters tip positions under pressure commands show
(the tip mass only where the base arm has one, see :func:`default_parameters`)."""
LOWER_FACTOR = 0.2
UPPER_FACTOR = 5.0
"""Bounds of every parameter, as factors of the base arm's value."""

_NAME = re.compile(r"^([a-z_]+)(?:\[(\d+)\])?$")


@dataclass(frozen=True)
class Parameter:
    """One fittable value.

    Attributes:
        field: the ``ArmSpec`` or ``SegmentSpec`` field.
        segment: the segment's index, or ``None`` for an arm field.
    """

    field: str
    segment: int | None = None

    @property
    def name(self) -> str:
        """``field`` or ``field[segment]``."""
        return self.field if self.segment is None else f"{self.field}[{self.segment}]"

    def value(self, spec: ArmSpec) -> float:
        """The parameter's value in ``spec`` (SI units of its field)."""
        owner = spec if self.segment is None else spec.segments[self.segment]
        return float(getattr(owner, self.field))

    def apply(self, spec: ArmSpec, value: float) -> ArmSpec:
        """``spec`` with this parameter set to ``value`` (the arm's own checks apply)."""
        if self.segment is None:
            return replace(spec, **{self.field: float(value)})
        segments = list(spec.segments)
        segments[self.segment] = replace(segments[self.segment], **{self.field: float(value)})
        return replace(spec, segments=tuple(segments))


def parse_parameters(names: list[str] | tuple[str, ...], spec: ArmSpec) -> list[Parameter]:
    """The parameters ``names`` stand for on the arm ``spec``, each once, in the order given.

    Raises:
        ValueError: an unknown name, a segment index out of range, an index on an arm field, or
            a parameter whose value is 0 in ``spec`` (a log-scale fit needs a positive start).
    """
    parameters: list[Parameter] = []
    for text in names:
        match = _NAME.match(text)
        family = match.group(1) if match else None
        if family not in FAMILIES:
            raise ValueError(f"parameter {text!r} is unknown: give one of {list(FAMILIES)}, a "
                             f"segment field optionally with [k] for segment k")
        index = match.group(2)
        if index is not None and family in ARM_FIELDS:
            raise ValueError(f"parameter {text!r}: {family} belongs to the whole arm, give it "
                             f"without [k]")
        if index is not None and int(index) >= spec.n_segments:
            raise ValueError(f"parameter {text!r}: arm {spec.name!r} has segments 0 to "
                             f"{spec.n_segments - 1}")
        if family in ARM_FIELDS:
            found = [Parameter(family)]
        elif index is not None:
            found = [Parameter(family, int(index))]
        elif family == "extra_tip_mass_kg":
            found = [Parameter(family, spec.n_segments - 1)]
        else:
            found = [Parameter(family, k) for k in range(spec.n_segments)]
        for parameter in found:
            if not parameter.value(spec) > 0.0:
                raise ValueError(f"parameter {parameter.name!r} is 0 in arm {spec.name!r}: a fit "
                                 f"in log-scale needs a positive starting value; set one in the "
                                 f"arm file (python -m soft_gym preset export) and fit that")
            if parameter not in parameters:
                parameters.append(parameter)
    if not parameters:
        raise ValueError("parameters must name at least one parameter")
    return parameters


def default_parameters(spec: ArmSpec) -> list[Parameter]:
    """:data:`DEFAULT_FAMILIES` on ``spec``, the tip mass left out where the base arm has none."""
    families = [family for family in DEFAULT_FAMILIES
                if family != "extra_tip_mass_kg" or spec.segments[-1].extra_tip_mass_kg > 0.0]
    return parse_parameters(families, spec)


def with_values(spec: ArmSpec, parameters: list[Parameter], values: list[float]) -> ArmSpec:
    """``spec`` with each of ``parameters`` set to the matching value of ``values``."""
    for parameter, value in zip(parameters, values, strict=True):
        spec = parameter.apply(spec, value)
    return spec
