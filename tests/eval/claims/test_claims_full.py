"""Every claim of the ledger at its paper's criterion, on the paper's protocol, seeds 0, 1 and 2
(slow: hours; ``pytest -m slow tests/eval/claims/test_claims_full.py``).

A claim passes when every seed reproduces it. A claim the ledger records as not reproduced
(``Claim.cause``) is a strict xfail carrying that cause, so it shows up the day it passes.
Experiments are run once per seed and shared between the claims that read them.
"""

from __future__ import annotations

import functools

import pytest

from eval.claims import CLAIMS, EXPERIMENTS

pytestmark = pytest.mark.slow

SEEDS = (0, 1, 2)


@functools.lru_cache(maxsize=None)
def _summary(experiment: str, seed: int) -> dict:
    return EXPERIMENTS[experiment].run(seed, False, 2, False)


PARAMS = [pytest.param(key, id=key, marks=[pytest.mark.xfail(strict=True, reason=claim.cause,
                                                             raises=AssertionError)]
                       if claim.cause is not None else [])
          for key, claim in CLAIMS.items() if claim.experiment is not None]
"""Every claim with an experiment (those the simulation cannot run are reported not reproduced
with their cause, and checked by the default suite)."""


@pytest.mark.parametrize("key", PARAMS)
def test_claim_reproduces_on_every_seed(key):
    claim = CLAIMS[key]
    outcomes = {seed: claim.judge(_summary(claim.experiment, seed)) for seed in SEEDS}
    failed = {seed: f"{o.verdict}: {o.measured}" for seed, o in outcomes.items()
              if o.verdict != "reproduced"}
    assert not failed, f"{key} ({claim.criterion}): {failed}"
