"""zou2022's claims: the DNN's accuracy on its test set (Table 3) and against constant curvature
on a continuous bend (Table 4) (Zou et al. 2022, Section 5; the experiments of
:mod:`eval.papers.zou2022`)."""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import numpy as np

from eval.claims.ledger import Claim, ClaimExperiment, Outcome, graded, numbers
from eval.papers import zou2022 as experiments
from soft_gym.sensing.zou2022.shape_dnn import ShapeDNNConfig

QUICK_DNN = ShapeDNNConfig(n_samples=1000, settle_s=0.8, batch_size=32, epochs=200)
"""``quick``: 1000 grid commands settled 0.8 s and 200 epochs (the paper's 29,791 samples,
2 s and 500 epochs)."""

PAPER_TABLE4_RATIO = experiments.TABLE4_PAPER_RATIO


def _run_dnn(seed: int, quick: bool, workers: int, progress: bool) -> dict[str, Any]:
    config = replace(QUICK_DNN if quick else ShapeDNNConfig(), seed=seed)
    dnn, report = experiments.shape_dnn(config, progress=progress)
    table3 = experiments.run_table3(dnn, report)
    table4 = experiments.run_table4(dnn, seed=seed, progress=progress)
    return {"n_samples": table3["n_samples"], "n_test": table3["n_test"],
            "test_share_with_a_training_command":
                table3["test_share_with_a_training_command"],
            "table3_rmse_vs_ases_mm": np.asarray(table3["ases"]["rmse_mm"]).tolist(),
            "table3_rmse_vs_truth_mm": np.asarray(table3["truth"]["rmse_mm"]).tolist(),
            "table4_rses_tip_rmse_mm": np.asarray(
                table4["rses_vs_ases"]["tip_rmse_mm"]).tolist(),
            "table4_dnn_tip_rmse_mm": np.asarray(table4["dnn_vs_ases"]["tip_rmse_mm"]).tolist(),
            "table4_ratio_vs_ases": table4["ratio_tip_vs_ases"],
            "table4_ratio_vs_truth": table4["ratio_tip_vs_truth"]}


EXPERIMENTS = (
    ClaimExperiment("zou2022.dnn", "zou2022",
                    "the DNN from the paper's 29,791 grid commands (each once, 2 s settling, "
                    "ASES labels, split by command), Table 3 on its test set and Table 4's "
                    "1 -> 2.5 bar bend",
                    "1000 grid commands settled 0.8 s, 200 epochs", _run_dnn,
                    cpu_minutes=(2.2, 90.0)),
)


def _table3(summary: dict) -> Outcome:
    rmse = summary["table3_rmse_vs_ases_mm"]
    paper = experiments.TABLE3_PAPER["rmse_mm"]
    shared = summary["test_share_with_a_training_command"]
    full = all(ours <= 1.5 * theirs for ours, theirs in zip(rmse, paper)) and shared == 0.0
    part = float(np.linalg.norm(rmse)) <= 2.0 * float(np.linalg.norm(paper))
    return graded(full, part,
                  f"RMSE vs ASES x / y / z {numbers(rmse)} mm on {summary['n_test']} test "
                  f"samples, {100 * shared:.1f} % sharing a training command")


def _table4(summary: dict) -> Outcome:
    ratio = summary["table4_ratio_vs_ases"]
    return graded(ratio >= 0.8 * PAPER_TABLE4_RATIO, ratio > 1.0,
                  f"end point RMSE vs ASES: RSES {numbers(summary['table4_rses_tip_rmse_mm'])}"
                  f" mm, DNN {numbers(summary['table4_dnn_tip_rmse_mm'])} mm (ratio of the "
                  f"3-D RMSEs {ratio:.2f}; vs the truth {summary['table4_ratio_vs_truth']:.2f})")


CLAIMS = (
    Claim("zou2022.table3_dnn_accuracy", "zou2022", "Table 3, Section 5.1",
          "The DNN estimates the seven backbone points from the encoders' chamber lengths to "
          "about 2.6 mm RMSE per axis against the vision labels, on samples it was not "
          "trained on.",
          "RMSE x / y / z 2.56 / 2.59 / 2.61 mm (MAE 1.76 / 1.80 / 2.07 mm)",
          "reproduced: every axis's RMSE at most 1.5 x the paper's, with no test sample "
          "sharing a training command; partly: the 3-D RMSE at most 2 x the paper's",
          "zou2022.dnn", _table3),
    Claim("zou2022.table4_dnn_beats_rses", "zou2022", "Table 4, Figs. 18-19, Section 5.2",
          "On a continuous bend the DNN estimates the end point several times more accurately "
          "than constant curvature (RSES) from the same encoders.",
          "end point RMSE x / y / z: RSES 10.89 / 6.54 / 6.56 mm, DNN 2.21 / 2.11 / 2.30 mm "
          f"(3-D ratio {PAPER_TABLE4_RATIO:.2f}; x alone 4.92)",
          f"reproduced: RSES / DNN of the 3-D end-point RMSEs against ASES at least "
          f"{0.8 * PAPER_TABLE4_RATIO:.2f} (0.8 x the paper's {PAPER_TABLE4_RATIO:.2f}); "
          "partly: above 1",
          "zou2022.dnn", _table4),
)
