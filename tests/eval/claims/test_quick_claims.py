"""One quick claim per paper through the whole ledger path: the experiment's quick version runs,
its record is written and read back, the claim is judged and reported.

wang2023's, ho2018's and zhao2021's quick experiments are long runs (about 60 s, 37 s and 70 s on
one core, zhao2021's mostly its drive to the paper's start), marked slow; the default suite takes
the ledger's path through zou2022's.

wang2023's Tables I-II run as ``--quick`` runs them and are judged at the paper's effect sizes
per path (the verdict itself is the full ledger's, docs/claims.md). The others run on the
smaller models the default suite already trains (zhao2021's 360-sample SR model and 16 steps of
sway, zou2022's 150-sample DNN: cached once per machine), where a verdict says nothing about the
paper, so they check the ledger's bookkeeping against the experiment's own numbers.
"""

from __future__ import annotations

import math

import pytest

from eval.claims import VERDICTS
from eval.papers.ho2018 import claims as ho2018_claims
from eval.papers.zhao2021 import claims as zhao2021_claims
from eval.papers.zou2022 import claims as zou2022_claims
from eval.claims.report import markdown
from eval.claims.run import read_record, record_file, run_ledger
from eval.papers.zhao2021 import experiments as zhao2021_papers
from soft_gym.papers.zhao2021.shape_reconstruction import ReconstructionConfig
from soft_gym.papers.zou2022.shape_dnn import ShapeDNNConfig


def _quick(paper: str, claim: str, out) -> tuple[dict, dict]:
    ledger = run_ledger([paper], seeds=[0], quick=True, out=out, claims=[claim],
                        progress=False)
    entry = ledger["claims"][0]
    assert entry["key"] == claim and entry["verdict"] in VERDICTS
    assert [s["seed"] for s in entry["seeds"]] == [0]
    record = read_record(record_file(out, entry["experiment"], 0, True), entry["experiment"], 0,
                         True)
    assert record is not None and record["seconds"] > 0
    assert claim in markdown(ledger, "python -m eval claims --quick")
    return entry, record["summary"]


@pytest.mark.slow
def test_wang2023_tables1_2_quick_are_judged_on_each_path_at_its_gains(tmp_path):
    ledger = run_ledger(["wang2023"], seeds=[0], quick=True, out=tmp_path, progress=False,
                        claims=["wang2023.tables1-2_gain_matters",
                                "wang2023.tables1-2_hybrid_tracking"])
    summary = read_record(record_file(tmp_path, "wang2023.tracking", 0, True),
                          "wang2023.tracking", 0, True)["summary"]
    gain, tracking = (entry["seeds"][0]["measured"] for entry in ledger["claims"])
    for path in ("pentagram", "circle"):  # each path's numbers, computed here from the record
        model, hybrid = (summary[path][policy]["tracking_mm"]
                         for policy in ("cc_model", "hybrid_gpr"))
        assert f"{path} cc_model {model[0]:.2f} / {model[-1]:.2f} mm = " \
               f"{model[0] / model[-1]:.2f} x" in gain
        for kp, m, h in zip(summary["gains"], model, hybrid):
            assert f"{path} K_p {kp:g} {100 * (m - h) / m:.0f} %" in tracking


@pytest.mark.slow
def test_ho2018_table1_quick_is_judged_on_its_three_cycles(tmp_path):
    entry, summary = _quick("ho2018", "ho2018.table1_online_learns", tmp_path)
    online = summary[ho2018_claims.STATIC_ONLINE]["cycle_mean_mm"]
    assert len(online) == 3 and all(math.isfinite(v) and v > 0 for v in online)
    assert f"cycle 3 / cycle 1 {online[2] / online[0]:.2f} x" in entry["seeds"][0]["measured"]


@pytest.mark.slow
def test_zhao2021_sway_quick_is_judged_on_its_steps(tmp_path, monkeypatch):
    monkeypatch.setattr(zhao2021_claims, "QUICK_MODEL",
                        ReconstructionConfig(n_free=240, n_loaded=120, max_iterations=80))
    monkeypatch.setattr(zhao2021_papers, "MAX_P2P_STEPS", 16)  # past the pull (steps 7-12)
    entry, summary = _quick("zhao2021", "zhao2021.sway_and_pull", tmp_path)
    assert 2.0 <= summary["step_mm_before_pull"] <= summary["step_mm_during_pull"] <= 15.0
    assert (f"(before it {summary['step_mm_before_pull']:.1f} mm) "
            f"{summary['step_mm_during_pull']:.2f} mm") in entry["seeds"][0]["measured"]


def test_zou2022_table4_quick_is_judged_without_a_leaking_test_set(tmp_path, monkeypatch):
    monkeypatch.setattr(zou2022_claims, "QUICK_DNN", ShapeDNNConfig(
        n_samples=150, settle_s=0.8, batch_size=16, epochs=200))
    entry, summary = _quick("zou2022", "zou2022.table4_dnn_beats_rses", tmp_path)
    assert summary["test_share_with_a_training_command"] == 0.0
    assert summary["table4_ratio_vs_ases"] > 0
    assert f"RMSE vs ASES {summary['table4_ratio_vs_ases']:.2f} x" in \
        entry["seeds"][0]["measured"]


@pytest.mark.slow
def test_the_quick_ledger_judges_every_claim_it_can_run(tmp_path):
    """Every claim's check reads its experiment's quick summary (about 8 minutes on 2 cores)."""
    ledger = run_ledger(seeds=[0], quick=True, out=tmp_path, workers=2, progress=False)
    for entry in ledger["claims"]:
        assert entry["verdict"] in VERDICTS, (entry["key"], entry["verdict"])
        assert entry["experiment"] is None or [s["seed"] for s in entry["seeds"]] == [0]
