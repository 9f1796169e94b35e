"""The wang2023 estimation experiments (Section IV-C/F, Figs. 6-7, Tables III and VI) end to end.

The default suite runs a 40 %-length lighting run; the full 4000-step runs are marked slow
(``pytest -m slow tests/eval/papers/test_estimation_experiments.py``, about 9 minutes).
"""

from __future__ import annotations

import numpy as np
import pytest

from eval.papers.estimation import INIT_SAMPLES, _phases, fusion_weights, run_estimation
from eval.metrics import estimation_errors


def _errors(experiment: str, steps: int, **kwargs) -> dict:
    record = run_estimation(experiment, steps=steps, progress=False, **kwargs)
    return estimation_errors(record, phases=_phases(experiment, steps * 0.05))


def _phase(errors: dict, estimator: str, phase: str) -> dict:
    return errors[estimator]["phases"][phase]


@pytest.fixture(scope="module")
def short_lighting() -> dict:
    return run_estimation("lighting", steps=1600, progress=False)


def test_short_lighting_run_fusion_rides_through_darkness(short_lighting):
    """Fig. 7 at 40 % of the length (80 s): weak light, darkness, then LED glare."""
    errors = estimation_errors(short_lighting, phases=_phases("lighting", 1600 * 0.05))
    assert errors["fused"]["rmse_mm"] <= 0.5 * errors["camera"]["rmse_mm"]
    dark_fused = _phase(errors, "fused", "darkness")["max_mm"]
    assert dark_fused < 5.0
    assert _phase(errors, "camera", "darkness")["max_mm"] >= 5.0 * dark_fused


def test_the_camera_leads_in_good_views_and_femp_learns_only_what_the_fusion_trusts(
        short_lighting):
    """wang2023's premise: in ordinary light, on the frames where the camera is the more accurate
    estimate, the fusion gives the camera at least half the weight on most of them; in darkness
    (tracking lost) F-emp carries the estimate alone; F-emp is updated only from frames where
    the camera's weight is at least one half."""
    phases = {name: (start, end) for name, start, end in _phases("lighting", 1600 * 0.05)}
    ordinary = fusion_weights(short_lighting, *phases["ordinary light"])
    assert ordinary["camera_trusted_when_better"] > 0.5, ordinary
    assert fusion_weights(short_lighting, *phases["darkness"])["femp_weight_mean"] > 0.99
    updated = short_lighting["femp_updated"] > 0
    assert updated.any() and np.all(short_lighting["femp_weight"][updated] <= 0.5)


@pytest.fixture(scope="module")
def full_runs() -> dict:
    return {name: _errors(name, steps=4000) for name in ("clean", "occlusion", "lighting",
                                                        "push")}


@pytest.mark.slow
def test_clean_femp_error_after_initialisation(full_runs):
    assert full_runs["clean"]["femp"]["mean_mm"] < 1.5


FEMP_PUSH_SCATTER = (
    "with keyframe poses refitted from their neighbours the camera labels F-emp learns from are "
    "better, and F-emp's error under the push on the fiber-covered body scatters no more than "
    "under the push on the cap (std 0.33 and 0.33 mm, seed 0; means 0.84 and 0.84 mm): open "
    "until the body push's strain on the gratings shows in F-emp again")


@pytest.mark.slow
def test_fusion_rides_through_darkness_over_the_whole_lighting_run(full_runs):
    """Fig. 7 (darkness): fused max under 5 mm while the camera's max is at least five times
    larger; over the lighting run the fused RMSE is at most half the camera's. Measured (seed 0,
    camera-led fusion): darkness 16.1 vs 1.6 mm (10x); lighting RMSE 0.74 vs 5.69 mm."""
    errors = full_runs["lighting"]
    fused = _phase(errors, "fused", "darkness")["max_mm"]
    assert fused < 5.0
    assert _phase(errors, "camera", "darkness")["max_mm"] >= 5.0 * fused
    assert errors["fused"]["rmse_mm"] <= 0.5 * errors["camera"]["rmse_mm"]


@pytest.mark.slow
def test_fusion_bounds_the_error_during_full_covers(full_runs):
    """Fig. 6 (full ~2 s covers): fused max under 5 mm while the camera's max is at least five
    times larger, and under 5 mm over the whole occlusion run. Measured with the camera-led
    fusion (seeds 0 / 1 / 2): full covers 15.5 vs 2.1 mm (7.6x), 15.7 vs 1.7 mm (9.2x) and
    16.6 vs 3.2 mm (5.2x); whole run fused max 4.1 / 3.3 / 5.0 mm, the largest behind the
    partial occluder (so seed 2 misses the last bound by 0.01 mm)."""
    errors = full_runs["occlusion"]
    fused = _phase(errors, "fused", "full covers")["max_mm"]
    assert fused < 5.0
    assert _phase(errors, "camera", "full covers")["max_mm"] >= 5.0 * fused
    assert errors["fused"]["max_mm"] < 5.0


@pytest.mark.slow
@pytest.mark.xfail(strict=True, reason=FEMP_PUSH_SCATTER)
def test_body_push_makes_femp_noisier(full_runs):
    """Table III: pushes that each displace the tip ~15 mm (0.07 N on the cap, 0.3 N on the
    fiber-covered body). The push on the body strains the gratings under it, so F-emp's error
    scatters more (std) than under the push on the cap, as in all four of the paper's cases
    ("noise was observed from the F-emp pose estimations").

    The means are not ordered either way, in the paper (its LEGO means are larger for the cap)
    or here, where moving the arm by the cap costs F-emp more than by the body."""
    errors = full_runs["push"]
    free = _phase(errors, "femp", "free")["mean_mm"]
    cap_std = _phase(errors, "femp", "push on tip cap")["std_mm"]
    body_std = _phase(errors, "femp", "push on body")["std_mm"]
    assert body_std > cap_std, (body_std, cap_std)
    for phase in ("push on tip cap", "push on body"):
        assert _phase(errors, "femp", phase)["mean_mm"] < 2.0 * free, phase


@pytest.mark.slow
def test_fusion_stays_with_the_better_source_under_pushes(full_runs):
    """Table III: the fused mean error is within 0.05 mm of the better source's. Measured
    (seed 0): push on the cap, fused 0.85 mm against F-emp's 0.84 and the camera's 0.86; on the
    body 0.87 against 0.84 and 0.88."""
    errors = full_runs["push"]
    for phase in ("push on tip cap", "push on body"):
        femp, camera, fused = (_phase(errors, name, phase)["mean_mm"]
                               for name in ("femp", "camera", "fused"))
        assert fused <= min(femp, camera) + 0.05, phase


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
