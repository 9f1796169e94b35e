"""The papers' headline claims as a ledger: each run on several seeds and reported reproduced,
partly or not reproduced, with the numbers that decided it (``python -m eval claims``).

:data:`CLAIMS` holds every claim (:class:`~eval.claims.ledger.Claim`) and :data:`EXPERIMENTS`
the experiments they read (:class:`~eval.claims.ledger.ClaimExperiment`), filled from each
registered paper's evaluation folder (``eval/papers/<key>/``, its ``CLAIMS`` and
``EXPERIMENTS``, looked up on each access); :func:`~eval.claims.run.run_ledger` runs them and
:mod:`eval.claims.report` writes ``claims.md`` and ``claims.json``. The criteria are the papers'
own figures, written before any run; a claim that does not reproduce keeps its criterion and says
why (``Claim.cause``).
"""

from __future__ import annotations

from eval.claims.ledger import Claim, ClaimExperiment, Outcome, VERDICTS, combine, graded
from eval.papers import PaperParts

CLAIMS: PaperParts[Claim] = PaperParts("claim", "CLAIMS", lambda claim: claim.key)
"""Every claim by key: each paper's ``CLAIMS`` in registration order, then any registered here."""
EXPERIMENTS: PaperParts[ClaimExperiment] = PaperParts("claim experiment", "EXPERIMENTS",
                                                      lambda experiment: experiment.name)
"""Every claim experiment by name, as :data:`CLAIMS`."""


def claim_papers() -> tuple[str, ...]:
    """The papers with claims, in ledger order (their registration order)."""
    return tuple(dict.fromkeys(claim.paper for claim in CLAIMS.values()))


__all__ = ["CLAIMS", "EXPERIMENTS", "VERDICTS", "Claim", "ClaimExperiment", "Outcome",
           "claim_papers", "combine", "graded"]
