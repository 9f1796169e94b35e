"""One colour per policy, the same in every plot of every command.

:func:`policy_color` keys the colour on the policy's name (:func:`policy_label`: a baseline's
name, or an ``sb3:`` agent's directory name), never on its position in a plot, so ``cc_model``
is drawn in the same colour in ``track``, ``compare``, ``benchmark`` and every panel of a suite's
report. The registered baselines (:data:`agents.policies.BASELINES`, in registry order) and the
shipped agents (:func:`agents.policies.shipped_agents`, by name) take the first colours of
:data:`PALETTE`, one each; any other name (a suite's own label, a run directory) takes one of the
remaining colours chosen by a hash of the name, so it too is the same wherever it appears.
"""

from __future__ import annotations

import hashlib
from functools import lru_cache
from pathlib import Path

from agents.policies import BASELINES, shipped_agents

PALETTE = ("#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd", "#8c564b", "#e377c2",
           "#17becf", "#bcbd22", "#7f7f7f", "#aec7e8", "#ff9896", "#98df8a", "#ffbb78",
           "#c5b0d5", "#c49c94", "#f7b6d2", "#9edae5", "#dbdb8d", "#393b79")
"""The colours (matplotlib's tab10, then tab20's light shades and one dark blue): the named
policies take the first ones, other names the rest."""


def policy_label(policy: str) -> str:
    """Short label of a policy: the baseline name or the agent directory's name."""
    return Path(policy[4:]).name if policy.startswith("sb3:") else policy


@lru_cache(maxsize=1)
def named_policies() -> tuple[str, ...]:
    """The policies with a colour of their own: the baselines, then the shipped agents."""
    return tuple(BASELINES) + tuple(name for name in shipped_agents() if name not in BASELINES)


def policy_color(policy: str) -> str:
    """The colour (``#rrggbb``) of ``policy`` (a name, ``sb3:PATH`` or a label)."""
    if not isinstance(policy, str):
        raise TypeError(f"policy must be a str, got {type(policy).__name__}")
    label = policy_label(policy)
    named = named_policies()
    if label in named:
        return PALETTE[named.index(label) % len(PALETTE)]
    spare = PALETTE[len(named):] or PALETTE
    digest = int.from_bytes(hashlib.sha256(label.encode()).digest()[:8], "big")
    return spare[digest % len(spare)]
