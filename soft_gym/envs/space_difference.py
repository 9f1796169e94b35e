"""Where two Gymnasium spaces differ, in words.

A batch of arms (:class:`~soft_gym.envs.vector.SoftArmVectorEnv`) needs every arm's observation
and action spaces to be the first arm's; when one is not, the refusal names the first thing that
differs (the type, the dict's parts, the shape, the dtype, or a bound at an index with the
observation part it falls in) and the two values, rather than printing both spaces whole.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Mapping

import numpy as np
from gymnasium import spaces


@dataclass(frozen=True)
class SpaceDifference:
    """The first difference of two spaces: ``what`` differs, and its value in each.

    Attributes:
        what: the differing attribute, e.g. ``"high bound at index 7"`` or ``"shape"``.
        mine: its value in the space compared, with the part it falls in where known.
        theirs: its value in the reference space, likewise.
    """

    what: str
    mine: str
    theirs: str


def space_difference(mine: spaces.Space, theirs: spaces.Space,
                     parts_mine: Mapping[str, slice] | None = None,
                     parts_theirs: Mapping[str, slice] | None = None) -> SpaceDifference | None:
    """The first difference between ``mine`` and ``theirs``, or ``None`` if they are equal.

    Args:
        mine: the space compared.
        theirs: the reference space.
        parts_mine: for a flat ``Box`` observation, each part's slice of ``mine`` (the env's
            :attr:`~soft_gym.envs.soft_arm_env.SoftArmEnv.part_slices`), to say which part an
            index falls in; ``None``: indices only.
        parts_theirs: the same for ``theirs``.

    Returns:
        The difference (see :class:`SpaceDifference`), or ``None`` when ``mine == theirs``.
    """
    if mine == theirs:
        return None
    if type(mine) is not type(theirs):
        return SpaceDifference("type", type(mine).__name__, type(theirs).__name__)
    if isinstance(mine, spaces.Dict):
        if list(mine.spaces) != list(theirs.spaces):
            return SpaceDifference("list of parts", str(list(mine.spaces)),
                                   str(list(theirs.spaces)))
        for key in mine.spaces:
            inner = space_difference(mine[key], theirs[key])
            if inner is not None:
                return SpaceDifference(f"part {key!r} {inner.what}", inner.mine, inner.theirs)
        return None
    if isinstance(mine, spaces.Box):
        return _box_difference(mine, theirs, parts_mine, parts_theirs)
    return SpaceDifference("value", str(mine), str(theirs))


def _box_difference(mine: spaces.Box, theirs: spaces.Box, parts_mine: Mapping[str, slice] | None,
                    parts_theirs: Mapping[str, slice] | None) -> SpaceDifference:
    """The first of shape, dtype, then low or high bound (lowest index first) that differs."""
    if mine.shape != theirs.shape:
        return SpaceDifference("shape", f"{mine.shape}{_layout(parts_mine)}",
                               f"{theirs.shape}{_layout(parts_theirs)}")
    if mine.dtype != theirs.dtype:
        return SpaceDifference("dtype", str(mine.dtype), str(theirs.dtype))
    # Box equality is np.allclose of the bounds: the first entry not close is the one
    lows = (mine.low.reshape(-1), theirs.low.reshape(-1))
    highs = (mine.high.reshape(-1), theirs.high.reshape(-1))
    differing = np.flatnonzero(~np.isclose(*lows) | ~np.isclose(*highs))
    if differing.size:
        flat = int(differing[0])
        bound, (ours, reference) = (("low", lows) if not np.isclose(lows[0][flat], lows[1][flat])
                                    else ("high", highs))
        index = np.unravel_index(flat, mine.shape)
        shown = int(index[0]) if len(index) == 1 else tuple(int(i) for i in index)
        return SpaceDifference(f"{bound} bound at index {shown}",
                               f"{ours[flat]:.6g}{_part_of(parts_mine, flat)}",
                               f"{reference[flat]:.6g}{_part_of(parts_theirs, flat)}")
    return SpaceDifference("value", str(mine), str(theirs))


def _layout(parts: Mapping[str, slice] | None) -> str:
    """`` (parts pose 7, target 6)``: each part's size, or nothing without parts."""
    if not parts:
        return ""
    return " (parts " + ", ".join(f"{name} {part.stop - part.start}"
                                  for name, part in parts.items()) + ")"


def _part_of(parts: Mapping[str, slice] | None, index: int) -> str:
    """`` (part 'target' entry 0)``: the part a flat index falls in, or nothing."""
    for name, part in (parts or {}).items():
        if part.start <= index < part.stop:
            return f" (part {name!r} entry {index - part.start})"
    return ""
