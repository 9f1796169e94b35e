"""zou2022's claims: the DNN's accuracy on its test set (Table 3) and against constant curvature
on a continuous bend (Table 4) (Zou et al. 2022, Section 5; the experiments of
:mod:`eval.papers.zou2022.experiments`)."""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import numpy as np

from eval.claims.ledger import Claim, ClaimExperiment, Effect, Outcome, bar, judged, numbers
import eval.papers.zou2022.experiments as experiments
from soft_gym.papers.zou2022.shape_dnn import ShapeDNNConfig

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


def _run_dnn_distribution(seed: int, quick: bool, workers: int, progress: bool
                          ) -> dict[str, Any]:
    """Table 3's MAE and Fig. 16's error distribution of the same DNN (built once with
    ``zou2022.dnn``: the same config and cache)."""
    config = replace(QUICK_DNN if quick else ShapeDNNConfig(), seed=seed)
    dnn, report = experiments.shape_dnn(config, progress=progress)
    table3 = experiments.run_table3(dnn, report)
    errors = np.abs(table3["ases"]["_errors_mm"])
    return {"n_test": table3["n_test"],
            "table3_mae_vs_ases_mm": np.asarray(table3["ases"]["mae_mm"]).tolist(),
            "table3_mae_vs_truth_mm": np.asarray(table3["truth"]["mae_mm"]).tolist(),
            "fig16_within_2_5_mm": np.asarray(table3["ases"]["within_2_5_mm"]).tolist(),
            "fig16_beyond_10_mm": (errors > 10.0).mean(axis=0).tolist(),
            "labels_vs_truth_rmse_mm": float(np.linalg.norm(
                np.atleast_1d(table3["ases_vs_truth_rmse_mm"])))}


_DNN = "the DNN's data set and training"
EXPERIMENTS = (
    ClaimExperiment("zou2022.dnn", "zou2022",
                    "the DNN from the paper's 29,791 grid commands (each once, 2 s settling, "
                    "ASES labels, split by command), Table 3 on its test set and Table 4's "
                    "1 -> 2.5 bar bend",
                    "1000 grid commands settled 0.8 s, 200 epochs", _run_dnn, shares=_DNN,
                    cpu_minutes=(2.2, 90.0)),
    ClaimExperiment("zou2022.dnn_distribution", "zou2022",
                    "the same DNN's test-set errors against the ASES labels: MAE per axis and "
                    "the shares within +-2.5 mm and beyond +-10 mm (Fig. 16)",
                    "1000 grid commands settled 0.8 s, 200 epochs", _run_dnn_distribution,
                    shares=_DNN, cpu_minutes=(0.1, 0.5)),
)

AXES = ("x", "y", "z")
TABLE3_BAND = (0.67, 1.5)
"""Table 3's band: the test set's per-sample RMSE scatters widely about its 2.30 mm mean (60 of
4463 samples near 8 mm, Section 5.1), so 0.67-1.5 x the paper's per-axis figure."""
TABLE3_RMSE = {axis: Effect("level", value, band=TABLE3_BAND, unit="mm")
               for axis, value in zip(AXES, experiments.TABLE3_PAPER["rmse_mm"])}
TABLE3_MAE = {axis: Effect("level", value, band=TABLE3_BAND, unit="mm")
              for axis, value in zip(AXES, (1.7601, 1.8049, 2.0677))}
"""Table 3: RMSE 2.56 / 2.59 / 2.61 mm and MAE 1.76 / 1.80 / 2.07 mm (x / y / z)."""
FIG16_WITHIN = {axis: Effect("level", share, band=(1 - 0.10 / share, 1 + 0.10 / share))
                for axis, share in zip(AXES, (0.82, 0.814, 0.7375))}
"""Fig. 16: the shares within +-2.5 mm, 82 / 81.4 / 73.75 %, each within 10 points."""
FIG16_BEYOND_MAX = 0.002
"""Fig. 16: "does not exceed +-10 mm" (0.11-0.18 % of the samples "about +-10 mm")."""
TABLE4_RATIO = Effect("ratio", round(PAPER_TABLE4_RATIO, 2), unit="x")
"""Table 4: RSES / DNN of the 3-D end-point RMSEs against ASES, 3.74."""


def _table3(summary: dict) -> Outcome:
    rmse, truth = summary["table3_rmse_vs_ases_mm"], summary["table3_rmse_vs_truth_mm"]
    shared = summary["test_share_with_a_training_command"]
    parts = [TABLE3_RMSE[axis].part(f"{axis} (vs the truth {true:.2f} mm)", ours)
             for axis, ours, true in zip(AXES, rmse, truth)]
    parts.append(bar("test samples sharing a training command",
                     "reproduced" if shared == 0.0 else "partly", f"{100 * shared:.1f} %"))
    return judged(parts, f"; {summary['n_test']} test samples")


def _table3_mae(summary: dict) -> Outcome:
    return judged([TABLE3_MAE[axis].part(f"MAE {axis} (vs the truth {true:.2f} mm)", ours)
                   for axis, ours, true in zip(AXES, summary["table3_mae_vs_ases_mm"],
                                               summary["table3_mae_vs_truth_mm"])],
                  f"; the labels themselves {summary['labels_vs_truth_rmse_mm']:.2f} mm RMSE "
                  "from the true shape")


def _fig16(summary: dict) -> Outcome:
    parts = [FIG16_WITHIN[axis].part(f"{axis} within +-2.5 mm", share)
             for axis, share in zip(AXES, summary["fig16_within_2_5_mm"])]
    beyond = max(summary["fig16_beyond_10_mm"])
    parts.append(bar("beyond +-10 mm", "reproduced" if beyond <= FIG16_BEYOND_MAX else
                     "partly" if beyond <= 5 * FIG16_BEYOND_MAX else "not reproduced",
                     f"{100 * beyond:.2f} % (largest axis)"))
    return judged(parts)


def _table4(summary: dict) -> Outcome:
    return judged([TABLE4_RATIO.part("RSES / DNN end-point RMSE vs ASES",
                                     summary["table4_ratio_vs_ases"])],
                  f" (RSES {numbers(summary['table4_rses_tip_rmse_mm'])} mm, DNN "
                  f"{numbers(summary['table4_dnn_tip_rmse_mm'])} mm; vs the truth "
                  f"{summary['table4_ratio_vs_truth']:.2f})")


LABELS_TOO_CLEAN = (
    "against the simulated ASES labels the DNN's RMSE is 0.44-0.48 / 1.52-1.58 / 0.60-0.68 mm "
    "per axis on seeds 0-2 (1.7-5.6 x below the paper's 2.56-2.61 mm against its stereo rig), "
    "against the true shape 1.06 / 2.61 / 2.56 mm (seed 0): the simulated labels are nearly "
    "deterministic, so the error far below the paper's is a fidelity gap of the labels, not a "
    "better estimator")
"""The measured cause of the Table 3 claims that do not reproduce."""

CLAIMS = (
    Claim("zou2022.table3_dnn_accuracy", "zou2022", "Table 3, Section 5.1",
          "The DNN estimates the seven backbone points from the encoders' chamber lengths to "
          "about 2.6 mm RMSE per axis against the vision labels, on samples it was not "
          "trained on.",
          "RMSE x / y / z 2.56 / 2.59 / 2.61 mm (MAE 1.76 / 1.80 / 2.07 mm)",
          "per axis, its RMSE against the labels as a level: reproduced within 0.67-1.5 x the "
          "paper's (the wide scatter of its per-sample RMSE), partly within 0.5-2 x; every "
          "test sample's command unseen in training (else partly); the error against the true "
          "shape reported beside it",
          "zou2022.dnn", _table3, cause=LABELS_TOO_CLEAN),
    Claim("zou2022.table3_mae", "zou2022", "Table 3, Section 5.1",
          "The DNN's mean absolute error against the vision labels is about 1.8-2.1 mm per "
          "axis.",
          "MAE x / y / z 1.76 / 1.80 / 2.07 mm",
          "per axis, its MAE against the labels as a level: reproduced within 0.67-1.5 x the "
          "paper's, partly within 0.5-2 x",
          "zou2022.dnn_distribution", _table3_mae),
    Claim("zou2022.fig16_error_shares", "zou2022", "Fig. 16, Section 5.1",
          "Most of the DNN's test errors lie within +-2.5 mm on each axis, and none beyond "
          "+-10 mm.",
          "within +-2.5 mm: x 82 %, y 81.4 %, z 73.75 %; none beyond +-10 mm (0.11-0.18 % "
          "\"about +-10 mm\")",
          "per axis, the share within +-2.5 mm: reproduced within 10 points of the paper's, "
          "partly within 0.5-2 x it; beyond +-10 mm: reproduced at most 0.2 %, partly at most "
          "1 %",
          "zou2022.dnn_distribution", _fig16),
    Claim("zou2022.table4_dnn_beats_rses", "zou2022", "Table 4, Figs. 18-19, Section 5.2",
          "On a continuous bend the DNN estimates the end point several times more accurately "
          "than constant curvature (RSES) from the same encoders.",
          "end point RMSE x / y / z: RSES 10.89 / 6.54 / 6.56 mm, DNN 2.21 / 2.11 / 2.30 mm "
          f"(3-D ratio {PAPER_TABLE4_RATIO:.2f}; x alone 4.92)",
          "RSES / DNN of the 3-D end-point RMSEs against the labels: "
          + TABLE4_RATIO.criterion(),
          "zou2022.dnn", _table4,
          cause="RSES / DNN is 5.06-5.37 x against the labels on seeds 0-2, above the band (to "
                "4.68 x): the DNN's end point is 2.0-2.2 mm from the simulated labels in 3-D "
                "(the paper's 3.8 mm), too clean labels again; against the true shape the ratio "
                "is 3.66-4.12 x"),
    Claim("zou2022.fig20_dnn_vs_rbf_mlp", "zou2022", "Fig. 20, Section 5.3",
          "Trained on the same data for the same epochs, the DNN's loss ends far below a "
          "two-layer MLP's, and an RBF network fails to fit.",
          "qualitative: MLP loss \"relatively large compared to DNN\", RBF loss \"hardly sees a "
          "significant decrease\" (no numbers)",
          "reproduced: DNN loss < MLP loss and the RBF's loss falls by less than half over the "
          "epochs",
          None, None,
          cause="the RBF and two-layer MLP baselines of Section 5.3 are not built, so the "
                "comparison is not run"),
)
