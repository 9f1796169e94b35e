"""One colour per policy, the same in every plot of every command, and distinct within a plot.

:func:`policy_color` keys the colour on the policy's name (:func:`policy_label`: a baseline's
name, or an ``sb3:`` agent's directory name), never on its position in a plot, so ``cc_model``
is drawn in the same colour in ``track``, ``compare``, ``benchmark`` and every panel of a suite's
report.

The colours are matplotlib's qualitative ``tab10`` (:data:`TAB10`), then a few spares
(:data:`SPARES`); every two of :data:`PALETTE` differ by at least :data:`MIN_DELTA_E` in CIE76
delta-E (:func:`delta_e`), and none is a light shade of another (``tab20``'s pale halves, such as
the light orange once drawn beside ``local_ik_asdm``'s orange, are left out). The registered
baselines (:data:`agents.policies.BASELINES`, in registry order) take the first ``tab10``
colours, one each. A shipped agent (:func:`agents.policies.shipped_agents`) takes the colour of
its *family*, its name without the arm (``sac_zhao2021_track`` -> ``sac_track``,
``ppo_lstm_wang2023_fused`` -> ``ppo_lstm_fused``): one colour per family on every arm, the
next ``tab10`` colours, the most common family first. Agents of one family are trained on
different arms and never share a plot (every plot and panel is one arm's), so the policies of
one arm are drawn in distinct colours. Any other name (a suite's own label, a run directory)
takes a spare colour chosen by a hash of the name, so it too is the same wherever it appears;
:func:`policy_colors` gives a set of policies drawn together their colours with such names moved
off any colour already taken in the set.
"""

from __future__ import annotations

import hashlib
from collections import Counter
from collections.abc import Iterable
from functools import lru_cache
from pathlib import Path

import numpy as np
from matplotlib.colors import to_rgb

from agents.policies import BASELINES, shipped_agents
from soft_gym.robots.presets import PRESETS

TAB10 = ("#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd", "#8c564b", "#e377c2",
         "#7f7f7f", "#bcbd22", "#17becf")
"""matplotlib's ``tab10`` (red and orange swapped, so the first baselines are blue, red, green)."""

SPARES = ("#000000", "#393b79", "#637939", "#e7ba52")
"""Colours beyond ``tab10`` (``tab20b``'s dark blue, dark olive and gold, and black), each at
least :data:`MIN_DELTA_E` from every ``tab10`` colour and from each other."""

PALETTE = TAB10 + SPARES
"""Every colour a policy can take."""

MIN_DELTA_E = 25.0
"""The least CIE76 delta-E between two colours of :data:`PALETTE`."""


def policy_label(policy: str) -> str:
    """Short label of a policy: the baseline name or the agent directory's name."""
    return Path(policy[4:]).name if policy.startswith("sb3:") else policy


def lab(color: str) -> np.ndarray:
    """CIE L*a*b* (D65) of a matplotlib colour (sRGB)."""
    rgb = np.asarray(to_rgb(color), dtype=float)
    linear = np.where(rgb <= 0.04045, rgb / 12.92, ((rgb + 0.055) / 1.055) ** 2.4)
    xyz = np.array([[0.4124564, 0.3575761, 0.1804375],
                    [0.2126729, 0.7151522, 0.0721750],
                    [0.0193339, 0.1191920, 0.9503041]]) @ linear
    xyz = xyz / np.array([0.95047, 1.0, 1.08883])
    f = np.where(xyz > (6 / 29) ** 3, np.cbrt(xyz), xyz / (3 * (6 / 29) ** 2) + 4 / 29)
    return np.array([116.0 * f[1] - 16.0, 500.0 * (f[0] - f[1]), 200.0 * (f[1] - f[2])])


def delta_e(first: str, second: str) -> float:
    """CIE76 colour difference of two colours (the Euclidean distance in L*a*b*)."""
    return float(np.linalg.norm(lab(first) - lab(second)))


def agent_family(name: str) -> str:
    """An agent's name without its arm (``sac_zhao2021_track`` -> ``sac_track``); the name
    itself where it names no preset."""
    for preset in sorted(PRESETS, key=len, reverse=True):
        if f"_{preset}" in name:
            return name.replace(f"_{preset}", "", 1)
    return name


@lru_cache(maxsize=1)
def named_policies() -> tuple[str, ...]:
    """The policies with a colour of their own: the baselines, then the shipped agents."""
    return tuple(BASELINES) + tuple(name for name in shipped_agents() if name not in BASELINES)


@lru_cache(maxsize=1)
def _named_colors() -> dict[str, str]:
    """Name -> colour of every named policy: the baselines one ``tab10`` colour each, the
    agents their family's."""
    colors = {name: TAB10[i % len(TAB10)] for i, name in enumerate(BASELINES)}
    agents = [name for name in named_policies() if name not in colors]
    counts = Counter(agent_family(name) for name in agents)
    families = sorted(counts, key=lambda family: (-counts[family], family))
    for name in agents:
        index = len(BASELINES) + families.index(agent_family(name))
        colors[name] = PALETTE[index % len(PALETTE)]
    return colors


def _spares() -> tuple[str, ...]:
    """The colours no named policy takes (all of :data:`PALETTE` where every one is taken)."""
    taken = set(_named_colors().values())
    return tuple(color for color in PALETTE if color not in taken) or PALETTE


def _hash(label: str) -> int:
    return int.from_bytes(hashlib.sha256(label.encode()).digest()[:8], "big")


def policy_color(policy: str) -> str:
    """The colour (``#rrggbb``) of ``policy`` (a name, ``sb3:PATH`` or a label)."""
    if not isinstance(policy, str):
        raise TypeError(f"policy must be a str, got {type(policy).__name__}")
    label = policy_label(policy)
    named = _named_colors()
    if label in named:
        return named[label]
    spare = _spares()
    return spare[_hash(label) % len(spare)]


def policy_colors(policies: Iterable[str]) -> dict[str, str]:
    """The colours of policies drawn together, keyed as given: each its :func:`policy_color`,
    except that a name outside the registries whose colour another policy of the set has
    already takes the next free colour (spares first, then ``tab10``); the named policies keep
    theirs."""
    policies = list(dict.fromkeys(policies))
    named = _named_colors()
    colors = {policy: policy_color(policy) for policy in policies
              if policy_label(policy) in named}
    order = _spares() + tuple(color for color in PALETTE if color not in _spares())
    for policy in sorted((p for p in policies if p not in colors), key=policy_label):
        taken = set(colors.values())
        start = order.index(policy_color(policy))
        free = [order[(start + k) % len(order)] for k in range(len(order))
                if order[(start + k) % len(order)] not in taken]
        colors[policy] = free[0] if free else policy_color(policy)
    return {policy: colors[policy] for policy in policies}
