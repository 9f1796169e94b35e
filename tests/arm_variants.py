"""Preset variants for the tests (per-segment changes, the linear elastic beam), the pneumatic
load of a segment derived independently of the library's load map, and the arc positions of the
discrete beam's joints."""

from __future__ import annotations

import dataclasses

import numpy as np


def variant(spec, **changes):
    """The preset with ``changes`` applied to every segment."""
    segments = tuple(dataclasses.replace(segment, **changes) for segment in spec.segments)
    return dataclasses.replace(spec, segments=segments)


def linear(spec, **changes):
    """The preset without strain stiffening (the linear elastic beam of the references)."""
    return variant(spec, bending_stiffening=0.0, axial_stiffening=0.0, **changes)


def pneumatic_loads_reference(spec, pressures_pa):
    """Per-segment axial force (N) and bending moment (N m, about the segment's x and y) from
    first principles: chamber ``i`` of a segment is a force ``p_i A_c`` along the segment axis,
    acting at ``d (cos(2 pi i / 3), sin(2 pi i / 3), 0)`` in the segment's cross-section, and its
    moment is the cross product of that point with the force. Independent of
    ``soft_gym.robots.pneumatics.chamber_loads`` and of the library's chamber-angle constant."""
    import numpy as np

    pressures = np.asarray(pressures_pa, dtype=float).reshape(spec.n_segments, 3)
    axial, moment = np.zeros(spec.n_segments), np.zeros((spec.n_segments, 2))
    for k, segment in enumerate(spec.segments):
        for i in range(3):
            angle = 2.0 * np.pi * i / 3.0
            point = segment.chamber_offset_m * np.array([np.cos(angle), np.sin(angle), 0.0])
            force = np.array([0.0, 0.0, pressures[k, i] * segment.chamber_area_m2])
            axial[k] += force[2]
            moment[k] += np.cross(point, force)[:2]
    return axial, moment


def vertex_arcs(spec) -> np.ndarray:
    """Arc positions (m) of the discrete beam's vertices at rest: the base, then the end of every
    link, segment after segment."""
    arcs = [0.0]
    for segment in spec.segments:
        for _ in range(segment.n_links):
            arcs.append(arcs[-1] + segment.link_length_m)
    return np.array(arcs)
