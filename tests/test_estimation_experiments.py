"""The wang2023 estimation experiments (Section IV-C/F, Figs. 6-7, Tables III and VI) end to end.

The default suite runs a 40 %-length lighting run; the full 4000-step runs are marked slow
(``pytest -m slow tests/test_estimation_experiments.py``, about 9 minutes).
"""

from __future__ import annotations

import pytest

from eval.estimation import INIT_SAMPLES, _phases, run_estimation
from eval.metrics import estimation_errors


def _errors(experiment: str, steps: int, **kwargs) -> dict:
    record = run_estimation(experiment, steps=steps, progress=False, **kwargs)
    return estimation_errors(record, phases=_phases(experiment, steps * 0.05))


def _phase(errors: dict, estimator: str, phase: str) -> dict:
    return errors[estimator]["phases"][phase]


def test_short_lighting_run_fusion_rides_through_darkness():
    """Fig. 7 at 40 % of the length (80 s): weak light, darkness, then LED glare. Measured:
    fused RMSE 1.31 mm against the camera's 9.89 mm; in darkness fused max 2.79 mm against the
    camera's 26.0 mm."""
    errors = _errors("lighting", steps=1600)
    assert errors["fused"]["rmse_mm"] <= 0.5 * errors["camera"]["rmse_mm"]
    dark_fused = _phase(errors, "fused", "darkness")["max_mm"]
    assert dark_fused < 5.0
    assert _phase(errors, "camera", "darkness")["max_mm"] >= 5.0 * dark_fused


@pytest.fixture(scope="module")
def full_runs() -> dict:
    return {name: _errors(name, steps=4000) for name in ("clean", "occlusion", "lighting",
                                                        "push")}


@pytest.mark.slow
def test_clean_femp_error_after_initialisation(full_runs):
    assert full_runs["clean"]["femp"]["mean_mm"] < 1.5


@pytest.mark.slow
def test_fusion_bounds_the_error_when_the_camera_is_blind(full_runs):
    """Fig. 6 (full ~2 s covers) and Fig. 7 (darkness): fused max under 5 mm and the camera's
    max several times larger; over the lighting run the fused RMSE is at most half the camera's.

    Measured: darkness 22.3 vs 3.1 mm (7.2x); full covers 11.2 vs 2.3 mm (4.8x; 5.3x before the
    F-emp prior). While covered the camera holds its last pose, so its error is the distance the
    arm travels in 2 s of the spiral (~11 mm); the paper's SLAM error reached 38.5 mm."""
    for experiment, phase, factor in (("occlusion", "full covers", 4.0),
                                      ("lighting", "darkness", 5.0)):
        errors = full_runs[experiment]
        fused = _phase(errors, "fused", phase)["max_mm"]
        assert fused < 5.0, (experiment, fused)
        assert _phase(errors, "camera", phase)["max_mm"] >= factor * fused, experiment
    assert full_runs["occlusion"]["fused"]["max_mm"] < 5.0
    lighting = full_runs["lighting"]
    assert lighting["fused"]["rmse_mm"] <= 0.5 * lighting["camera"]["rmse_mm"]


@pytest.mark.slow
def test_fusion_stays_with_the_better_source_under_pushes(full_runs):
    """Table III: pushes that each displace the tip ~15 mm (0.07 N on the cap, 0.3 N on the
    fiber-covered body); fusion stays within 0.05 mm of the better source's mean error.

    Which push degrades F-emp more is not stable here: F-emp's means under the two pushes differ
    by about 0.1-0.2 mm either way from run to run, and the contact strain of a 0.3 N push moves
    F-emp's mean by 0.003 mm. (The paper's own LEGO means are larger for the cap push.)"""
    errors = full_runs["push"]
    free = _phase(errors, "femp", "free")["mean_mm"]
    for phase in ("push on tip cap", "push on body"):
        femp, camera, fused = (_phase(errors, name, phase)["mean_mm"]
                               for name in ("femp", "camera", "fused"))
        assert fused <= min(femp, camera) + 0.05, phase
        assert femp < 2.0 * free, phase


@pytest.mark.slow
def test_more_initialisation_samples_lower_the_flick_error():
    """Table VI: F-emp initialised from 450 / 900 / 1800 samples of one exploration (the same
    camera estimates for all three), then flicked; its mean error falls with more samples, most
    clearly in the first 20 s, before the online updates from the camera take over. Measured:
    0.98 / 0.94 / 0.88 mm over the first 20 s, 1.47 / 1.45 / 1.43 mm over the 200 s run."""
    early, whole = [], []
    for n_init in INIT_SAMPLES:
        errors = _errors("init", steps=4000, n_init=n_init)
        early.append(_phase(errors, "femp", "first 20 s")["mean_mm"])
        whole.append(errors["femp"]["mean_mm"])
    assert early[0] > early[1] > early[2], early
    assert whole[0] > whole[1] > whole[2], whole
