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
    fused RMSE 1.58 mm against the camera's 10.5 mm; in darkness fused max 3.91 mm against the
    camera's 25.1 mm."""
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
    """Fig. 6 (full ~2 s covers) and Fig. 7 (darkness): fused max under 5 mm while the camera's
    max is at least five times larger; over the lighting run the fused RMSE is at most half the
    camera's.

    Measured: full covers 14.9 vs 2.2 mm (6.9x), darkness 15.5 vs 2.4 mm (6.4x); lighting RMSE
    1.2 vs 5.7 mm. While covered the camera holds its last pose, so its error is the distance the
    arm travels in 2 s on the way out of the spiral; the paper's SLAM error reached 38.5 mm.
    The covers' ratio depends on the episode seed (cover timing, sensor noise): seeds 1 and 2 give
    16.1 vs 3.4 mm (4.7x) and 15.9 vs 2.8 mm (5.7x), darkness 6.5x and 6.8x. The fused max is
    then F-emp's error near the outer trajectory after 2 s without camera updates."""
    for experiment, phase in (("occlusion", "full covers"), ("lighting", "darkness")):
        errors = full_runs[experiment]
        fused = _phase(errors, "fused", phase)["max_mm"]
        assert fused < 5.0, (experiment, fused)
        assert _phase(errors, "camera", phase)["max_mm"] >= 5.0 * fused, experiment
    assert full_runs["occlusion"]["fused"]["max_mm"] < 5.0
    lighting = full_runs["lighting"]
    assert lighting["fused"]["rmse_mm"] <= 0.5 * lighting["camera"]["rmse_mm"]


@pytest.mark.slow
def test_body_push_makes_femp_noisier_and_fusion_stays_with_the_better_source(full_runs):
    """Table III: pushes that each displace the tip ~15 mm (0.07 N on the cap, 0.3 N on the
    fiber-covered body). The push on the body strains the gratings under it, so F-emp's error
    scatters more (std) than under the push on the cap, as in all four of the paper's cases
    ("noise was observed from the F-emp pose estimations"); fusion stays within 0.05 mm of the
    better source's mean error.

    Measured (F-emp mean / std, mm): free 1.15 / 0.71, cap 2.00 / 0.54, body 1.89 / 0.84; with
    the fiber's contact strain switched off the body push gives 1.45 / 0.67, so the contact
    costs 0.45 mm of mean error. The means are not ordered either way, in the paper (its LEGO
    means are larger for the cap) or here, where moving the arm by the cap costs F-emp more
    than by the body (2.00 against 1.45 mm without contact strain)."""
    errors = full_runs["push"]
    free = _phase(errors, "femp", "free")["mean_mm"]
    cap_std = _phase(errors, "femp", "push on tip cap")["std_mm"]
    body_std = _phase(errors, "femp", "push on body")["std_mm"]
    assert body_std > cap_std, (body_std, cap_std)
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
    0.80 / 0.72 / 0.70 mm over the first 20 s, 1.07 / 1.06 / 1.05 mm over the 200 s run."""
    early, whole = [], []
    for n_init in INIT_SAMPLES:
        errors = _errors("init", steps=4000, n_init=n_init)
        early.append(_phase(errors, "femp", "first 20 s")["mean_mm"])
        whole.append(errors["femp"]["mean_mm"])
    assert early[0] > early[1] > early[2], early
    assert whole[0] > whole[1] > whole[2], whole
