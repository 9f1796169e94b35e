"""A fifth paper as a plug-in: registered from a module outside the package, with its arm from a
file, one feedback source and one claim; its env runs and its claim is judged by the ledger
without editing the package (docs/architecture.md, "A fifth paper")."""

from __future__ import annotations

import importlib
import sys
import textwrap

import gymnasium as gym
import numpy as np
import pytest

import soft_gym  # noqa: F401  (registers the env ids)
from eval.claims import CLAIMS, EXPERIMENTS, claim_papers
from eval.claims.run import run_ledger
from eval.datasets import PAPER_DATASETS
from soft_gym.papers import PAPERS, Paper, register_paper, unregister_paper
from soft_gym.procedures.calibration import CALIBRATIONS
from soft_gym.robots import save_preset
from soft_gym.robots.presets import PRESETS
from soft_gym.sensing import FEEDBACK_SOURCES

OFFSET_M = 1.0e-3
"""The toy tracker's constant error (m): its claim's paper value is 1.0 mm."""

TOY_PAPER = '''
"""A toy paper: a tracker that reads the tip 1 mm off along x."""
import numpy as np

from soft_gym.papers import Paper, register_paper
from soft_gym.robots import load_preset
from soft_gym.sensing.feedback_base import FeedbackEstimate, FeedbackSource


class OffsetTracker(FeedbackSource):
    name = "toy_offset_tracker"
    sensors = ("truth",)

    def estimate(self, measurement):
        truth = measurement["truth"]
        return FeedbackEstimate(truth["position_m"] + np.array([{offset}, 0.0, 0.0]),
                                truth["quaternion"])


register_paper(Paper(key="toy2026", citation="Toy et al. 2026",
                     arms=(load_preset({arm_file!r}),), feedback_sources=(OffsetTracker,),
                     evaluation="toy2026_eval"))
'''

TOY_EVALUATION = '''
"""The toy paper's evaluation: one experiment (the tracker's mean error on a random episode)
and one claim (the paper's 1.0 mm)."""
import gymnasium as gym
import numpy as np

from eval.claims.ledger import Claim, ClaimExperiment, Effect, judged


def run(seed, quick, workers, progress):
    env = gym.make("SoftArmReach-v0", preset="toy2026", feedback="toy_offset_tracker")
    errors = []
    try:
        env.reset(seed=seed)
        env.action_space.seed(seed)
        for _ in range(5 if quick else 20):
            _, _, terminated, truncated, info = env.step(env.action_space.sample())
            errors.append(np.linalg.norm(env.unwrapped.estimate.position_m
                                         - info["tip_position_m"]))
            if terminated or truncated:
                break
    finally:
        env.close()
    return {{"error_mm": 1e3 * float(np.mean(errors))}}


EXPERIMENTS = (ClaimExperiment("toy2026.tracker", "toy2026", "20 random steps", "5 steps", run),)
CLAIMS = (Claim("toy2026.tracker_1mm", "toy2026", "Fig. 1", "The tracker errs by 1 mm.",
                "1.0 mm", Effect("level", {paper_mm}, unit="mm").criterion(), "toy2026.tracker",
                lambda s: judged([Effect("level", {paper_mm}, unit="mm").part(
                    "tracker error", s["error_mm"])])),)
'''


@pytest.fixture
def toy_paper(tmp_path, monkeypatch):
    """The toy paper's two modules written outside the package, imported (which registers the
    paper), and everything it registered removed again afterwards."""
    arm_file = tmp_path / "toy2026.yaml"
    save_preset("wang2023", arm_file)
    arm_file.write_text(arm_file.read_text().replace("name: wang2023", "name: toy2026"))
    (tmp_path / "toy2026_paper.py").write_text(TOY_PAPER.format(offset=OFFSET_M,
                                                                arm_file=str(arm_file)))
    (tmp_path / "toy2026_eval.py").write_text(TOY_EVALUATION.format(paper_mm=1.0))
    monkeypatch.syspath_prepend(str(tmp_path))
    importlib.import_module("toy2026_paper")
    yield PAPERS["toy2026"]
    unregister_paper("toy2026")
    for module in ("toy2026_paper", "toy2026_eval"):
        sys.modules.pop(module, None)


def test_a_paper_registered_from_outside_adds_its_arm_source_and_claim(toy_paper):
    assert "toy2026" in PRESETS and PRESETS["toy2026"].name == "toy2026"
    assert "toy_offset_tracker" in FEEDBACK_SOURCES
    assert "toy2026.tracker_1mm" in CLAIMS and "toy2026.tracker" in EXPERIMENTS
    assert claim_papers()[-1] == "toy2026"
    assert "toy2026" not in PAPER_DATASETS  # it defines no dataset


def test_the_fifth_papers_env_reads_its_own_source(toy_paper):
    env = gym.make("SoftArmReach-v0", preset="toy2026", feedback="toy_offset_tracker")
    try:
        env.reset(seed=0)
        _, _, _, _, info = env.step(np.zeros(env.action_space.shape, dtype=np.float32))
    finally:
        env.close()
    offset = env.unwrapped.estimate.position_m - info["tip_position_m"]
    np.testing.assert_allclose(offset, [OFFSET_M, 0.0, 0.0], atol=1e-12)


def test_the_ledger_judges_the_fifth_papers_claim(toy_paper, tmp_path):
    ledger = run_ledger(["toy2026"], seeds=[0], quick=True, out=tmp_path / "claims",
                        progress=False)
    (claim,) = ledger["claims"]
    assert claim["key"] == "toy2026.tracker_1mm"
    assert claim["verdict"] == "reproduced"  # 1.0 mm measured against the paper's 1.0 mm


def test_unregistering_the_paper_removes_everything_it_added(toy_paper):
    unregister_paper("toy2026")
    assert "toy2026" not in PRESETS and "toy_offset_tracker" not in FEEDBACK_SOURCES
    assert "toy2026.tracker_1mm" not in CLAIMS
    register_paper(toy_paper)  # the fixture unregisters it again


def test_a_malformed_paper_is_refused_before_anything_is_registered():
    before = (list(PAPERS), list(PRESETS), list(FEEDBACK_SOURCES), list(CALIBRATIONS))
    with pytest.raises(ValueError, match="Paper.key must be a name"):
        register_paper(Paper(key="lee 2026", citation="x"))
    with pytest.raises(ValueError, match="preset .*'wang2023'.* already registered"):
        register_paper(Paper(key="copy2026", citation="x", arms=(PRESETS["wang2023"],)))
    with pytest.raises(ValueError, match="must give a procedure for each calibrating source"):
        register_paper(Paper(key="fused2026", citation="x",
                             feedback_sources=(type("Fused2", (FEEDBACK_SOURCES["fused"],),
                                                    {"name": "fused2"}),)))
    with pytest.raises(ValueError, match="names a feedback source or an arm twice"):
        register_paper(Paper(key="twice2026", citation="x",
                             feedback_sources=(FEEDBACK_SOURCES["em"],) * 2))
    assert (list(PAPERS), list(PRESETS), list(FEEDBACK_SOURCES), list(CALIBRATIONS)) == before
