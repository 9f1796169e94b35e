"""The papers, one folder each: ``soft_gym/papers/<key>/`` holds the paper's arm (``arm.py``),
its estimators and feedback sources, the procedures that calibrate them on a private simulator
and its dataset readers; ``paper.py`` joins them into one :class:`Paper`, registered below.

Shared layers (sensors, engines, tasks, the env) live outside this package; a paper's evaluation
(experiments, claims, its subcommand) lives in ``eval/papers/<key>/``, named by
:attr:`Paper.evaluation`. Inside a paper folder the rule of the sensing layer holds: an estimator
never holds a simulator; only the calibration procedures (``calibration.py``, ``exploration.py``,
``dataset.py``, ``arm_fit.py``) drive one.

A paper of your own: build a :class:`Paper` and call :func:`register_paper` (docs/architecture.md,
"A fifth paper").
"""

from __future__ import annotations

from soft_gym.papers.paper import PAPERS, Paper, register_paper, unregister_paper
from soft_gym.papers.wang2023.paper import PAPER as WANG2023_PAPER
from soft_gym.papers.zhao2021.paper import PAPER as ZHAO2021_PAPER
from soft_gym.papers.zou2022.paper import PAPER as ZOU2022_PAPER
from soft_gym.papers.ho2018.paper import PAPER as HO2018_PAPER

for _paper in (WANG2023_PAPER, ZHAO2021_PAPER, ZOU2022_PAPER, HO2018_PAPER):
    register_paper(_paper)

DEFAULT_PRESET: str = WANG2023_PAPER.arms[0].name
"""The env's arm when none is named: the reference paper's, whose camera and FBG fiber give the
default ``fused`` feedback."""

__all__ = ["DEFAULT_PRESET", "PAPERS", "Paper", "register_paper", "unregister_paper"]
