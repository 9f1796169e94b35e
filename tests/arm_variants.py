"""Preset variants for the tests: per-segment changes, and the linear elastic beam."""

from __future__ import annotations

import dataclasses


def variant(spec, **changes):
    """The preset with ``changes`` applied to every segment."""
    segments = tuple(dataclasses.replace(segment, **changes) for segment in spec.segments)
    return dataclasses.replace(spec, segments=segments)


def linear(spec, **changes):
    """The preset without strain stiffening (the linear elastic beam of the references)."""
    return variant(spec, bending_stiffening=0.0, axial_stiffening=0.0, **changes)
