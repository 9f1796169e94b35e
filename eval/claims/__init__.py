"""The papers' headline claims as a ledger: each run on several seeds and reported reproduced,
partly or not reproduced, with the numbers that decided it (``python -m eval claims``).

:data:`CLAIMS` holds every claim (:class:`~eval.claims.ledger.Claim`) and :data:`EXPERIMENTS`
the experiments they read (:class:`~eval.claims.ledger.ClaimExperiment`), filled from one module
per paper; :func:`~eval.claims.run.run_ledger` runs them and :mod:`eval.claims.report` writes
``claims.md`` and ``claims.json``. The criteria are the papers' own figures, written before any
run; a claim that does not reproduce keeps its criterion and says why (``Claim.cause``).
"""

from __future__ import annotations

from eval.claims import ho2018, wang2023, zhao2021, zou2022
from eval.claims.ledger import Claim, ClaimExperiment, Outcome, VERDICTS, combine, graded
from soft_gym._registry import Registry

CLAIMS: Registry[Claim] = Registry("claim")
EXPERIMENTS: Registry[ClaimExperiment] = Registry("claim experiment")

for _module in (wang2023, ho2018, zhao2021, zou2022):
    for _experiment in _module.EXPERIMENTS:
        EXPERIMENTS.register(_experiment.name, _experiment)
    for _claim in _module.CLAIMS:
        CLAIMS.register(_claim.key, _claim)

PAPERS: tuple[str, ...] = tuple(dict.fromkeys(claim.paper for claim in CLAIMS.values()))
"""The papers with claims, in ledger order."""

__all__ = ["CLAIMS", "EXPERIMENTS", "PAPERS", "VERDICTS", "Claim", "ClaimExperiment", "Outcome",
           "combine", "graded"]
