"""The backbone's key points: the material points at sixths of the rest length that the
``shape`` observation part, zhao2021's shape reconstruction and zou2022's shape DNN all report.

zhao2021 Section III carries its backbone on key points ``P_1..P_6``; zou2022's seven-point shape
is the base and the same six. Shared here because the exact source (``ground_truth``), both
papers' estimators and the data-set procedures place them the same way.
"""

from __future__ import annotations

import numpy as np

from soft_gym.robots.spec import ArmSpec
from soft_gym.sensors.fbg import locate, rest_vertex_arcs, segment_bounds

N_SUBSEGMENTS = 3
"""zhao2021 Section III: the backbone is cut into ``N = 3`` subsegments, each carried by three
key points, so ``2N = 6`` key points ``P_1..P_6`` at sixths of the arm's rest length (on the
paper's two equal segments: thirds of each segment). Any arm gets the same six."""

N_KEY_POINTS = 2 * N_SUBSEGMENTS


def key_point_arcs(spec: ArmSpec) -> np.ndarray:
    """Rest arc position (m from the base) of each key point: sixths of the rest length."""
    return segment_bounds(spec)[-1] * np.arange(1, N_KEY_POINTS + 1) / N_KEY_POINTS


def key_points_from_backbone(spec: ArmSpec, backbone_m: np.ndarray) -> np.ndarray:
    """The key points (m) on a simulated backbone ``(..., n_links + 1, 3)``: the material points
    at :func:`key_point_arcs`, linearly interpolated between backbone vertices (the paper's
    markers move with the body). Returns ``(..., n_key_points, 3)``."""
    backbone = np.asarray(backbone_m, dtype=float)
    vertices = rest_vertex_arcs(spec)
    if backbone.shape[-2:] != (len(vertices), 3):
        raise ValueError(f"backbone_m must have shape (..., {len(vertices)}, 3) for arm "
                         f"{spec.name!r}, got {backbone.shape}")
    link, fraction = locate(vertices, key_point_arcs(spec))
    start, end = backbone[..., link, :], backbone[..., link + 1, :]
    return start + fraction[:, None] * (end - start)
