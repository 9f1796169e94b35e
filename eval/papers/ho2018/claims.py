"""ho2018's claims: online local learning under an unknown static and a filling tip load
(Ho et al. 2018, Tables 1-2; the experiments of :mod:`eval.papers.ho2018.experiments`)."""

from __future__ import annotations

import functools
from typing import Any, Callable

from eval.claims.ledger import (Claim, ClaimExperiment, Effect, Outcome, Part, bar, criteria,
                                judged, numbers)
import eval.papers.ho2018.experiments as experiments

QUICK_CYCLE_S = {"static": 20.0, "varying": 15.0}
"""``quick``: the cycle time of each experiment (s) on the shorter protocol's 10 Hz decisions
(the paper's protocol: 133.3 s at 20 Hz and 45 s at 6.7 Hz)."""
QUICK_LEAD_IN_S = 8.0
"""``quick``: the lead-in on the first corner (s; the paper's protocol: 30 s)."""


def _run(name: str, seed: int, quick: bool, workers: int, progress: bool) -> dict[str, Any]:
    """Per-cycle means (mm) of every setting of experiment ``name``."""
    timing = ({"protocol": "quick", "cycle_s": QUICK_CYCLE_S[name],
               "lead_in_s": QUICK_LEAD_IN_S} if quick else {"protocol": "paper"})
    results = experiments.run_experiment(name, seed=seed, progress=progress, **timing)
    return {label: {"cycle_mean_mm": record["cycle_mean_mm"],
                    "cycle_max_mm": record["cycle_max_mm"],
                    "learnt_per_cycle": record["learnt_per_cycle"]}
            for label, record in results.items()}


def _runner(name: str) -> Callable[[int, bool, int, bool], dict[str, Any]]:
    """Experiment ``name``'s run (a partial of a module-level function: a pool worker
    unpickles it)."""
    return functools.partial(_run, name)


def _run_pretraining(seed: int, quick: bool, workers: int, progress: bool) -> dict[str, Any]:
    """Section 3.2's check of the pre-trained models (:func:`eval.papers.ho2018.experiments.
    run_pretraining_check`): the forward model's test RMSE and the inverse's error bounds."""
    result = experiments.run_pretraining_check(seed=seed, quick=quick, progress=progress)
    return {key: result[key] for key in (
        "n_transitions", "n_test", "receptive_fields", "forward_rmse_mm", "zero_dp_rmse_mm",
        "em_noise_floor_mm", "inverse_error_mm", "inverse_error_reachable_mm", "epochs")}


EXPERIMENTS = (
    ClaimExperiment(
        "ho2018.static", "ho2018",
        "lwpr_rwr drives the cylinders' volumes to track the 25 x 100 mm rectangle for 3 "
        "cycles of 133.3 s (400 s) at 20 Hz with EM feedback: offline without load, online "
        "under an unknown 14.2 g tip (eval.papers.ho2018.experiments)",
        "20 s cycles at 10 Hz and an 8 s lead-in", _runner("static"), cpu_minutes=(1.5, 3.6)),
    ClaimExperiment(
        "ho2018.varying", "ho2018",
        "lwpr_rwr drives the cylinders' volumes to track the 40 x 60 mm rectangle for 4 cycles "
        "of 45 s: offline at 20 Hz with the empty 14 g container, offline at 20 Hz and online "
        "at 6.7 Hz while it fills by 10 g from cycle 3 and 6 g from cycle 4 (eval.papers.ho2018.experiments)",
        "15 s cycles at 10 Hz and an 8 s lead-in", _runner("varying"), cpu_minutes=(3.6, 6.3)),
    ClaimExperiment(
        "ho2018.pretraining", "ho2018",
        "lwpr_rwr's pre-training walk of the static experiment (80 random waypoints joined by "
        "straight lines, EM feedback), its transitions split 80/20: the forward model's test "
        "RMSE of dp and the inverse's error through the forward model (Section 3.2)",
        "8 waypoints", _run_pretraining, cpu_minutes=(0.1, 0.8)),
)

PLATEAU = ("on the paper's protocol (volume-driven chambers, 20 Hz updates, 400 s) online "
           "learning adapts to the 14.2 g tip within its first cycle and then levels off: cycle 1 "
           "is already 0.97, 4.18, 1.07 mm on seeds 0-2, where the offline model under the same "
           "tip tracks at 3.02-3.26 mm (seed 0; 1.76-2.11 unloaded); at 20 Hz it learns "
           "2,237-2,315 transitions a cycle where the paper had about 400 (the EM tracker's 0.8 "
           "mm noise per axis puts 86 % of the 50 ms transitions past the 1 mm minimum step), "
           "and seed 1's pre-trained model tracks at 6.7 mm unloaded, its online run drifting up "
           "in cycle 3 (docs/architecture.md, \"ho2018: the paper's protocol, and what sets the "
           "online floor\")")
"""The measured cause shared by the claims of online learning that do not reproduce."""


FILLING_FLOOR = ("online filling 2.44 -> 2.55, 2.23 -> 2.02 and 2.36 -> 2.25 mm (cycle 4 / 1 = "
                 "1.05, 0.91, 0.96) on seeds 0-2: stable through the filling, where the offline "
                 "model reaches 14.3-17.1 mm in cycle 4, but not down to 1 mm. At the paper's 6.7 "
                 "Hz its first cycle is already 2.2-2.4 mm, below the offline model's 2.6 mm under "
                 "the empty container, so there is no load error to learn away before the "
                 "filling, and with 251-272 transitions learnt a cycle (the "
                 "paper about 300) it holds 2.0-2.6 mm while the container fills; the same runs at "
                 "20 Hz end at 2.0 mm (seed 0)")
"""The measured cause of the filling claim that does not reproduce."""


STATIC_ONLINE, STATIC_OFFLINE = "online, 14.2 g tip", "offline, no load"
EMPTY, FILLING_OFFLINE, FILLING_ONLINE = ("offline, empty 14 g tip", "offline, filling",
                                          "online, filling")

ONLINE_LEARNS = Effect("ratio", 0.37, unit="x")
"""Table 1: online under the 14.2 g tip, cycle 3 over cycle 1 (1.63 / 4.42 mm)."""
ONLINE_VS_OFFLINE = Effect("ratio", 0.29, unit="x")
"""Table 1: online cycle 3 under the load over offline cycle 3 without it (1.63 / 5.53 mm)."""
OFFLINE_FILLING_GROWS = Effect("ratio", 2.21, unit="x")
"""Table 2: offline filling, cycle 4 over cycle 1 (12.84 / 5.82 mm)."""
OFFLINE_EMPTY_FLAT = Effect("level", 1.15, unit="x")
"""Table 2: offline with the empty container, cycle 4 over cycle 1 (6.94 / 6.01 mm)."""
ONLINE_FILLING_FALLS = Effect("ratio", 0.24, unit="x")
ONLINE_FILLING_FLOOR = Effect("level", 0.98, unit="mm")
"""Table 2: online filling, cycle 4 over cycle 1 (0.98 / 4.16 mm), and cycle 4 itself ("to < 1
mm", Section 4)."""
FORWARD_TEST_RMSE = Effect("level", 1.0, unit="mm")
"""Section 3.2: the forward model's RMSE of dp on the test set, "converging to approximately 1
mm"."""
INVERSE_BOUND_MM = 0.5
"""Section 3.2: "The error bounds for each dimension of the learned inverse model were under
0.5 mm"."""
ONLINE_KEEPS_STABLE = Effect("ratio", 0.076, unit="x")
"""Table 2: online filling over offline filling in cycle 4 (0.98 / 12.84 mm)."""


def _falls(label: str, means: list[float]) -> Part:
    """A bar: the error falls every cycle (reproduced) or not (partly: the ratio judges the
    size)."""
    falls = all(b < a for a, b in zip(means, means[1:]))
    return bar(label, "reproduced" if falls else "partly",
               f"{numbers(means)} mm, {'falls' if falls else 'does not fall'} every cycle")


def _online_learns_static(summary: dict) -> Outcome:
    online = summary[STATIC_ONLINE]["cycle_mean_mm"]
    return judged([_falls("online", online),
                   ONLINE_LEARNS.part("cycle 3 / cycle 1", online[-1] / online[0])])


def _online_below_offline(summary: dict) -> Outcome:
    online = summary[STATIC_ONLINE]["cycle_mean_mm"][-1]
    offline = summary[STATIC_OFFLINE]["cycle_mean_mm"][-1]
    return judged([ONLINE_VS_OFFLINE.part(
        f"cycle 3: online under load / offline without ({online:.2f} / {offline:.2f} mm)",
        online / offline)])


def _filling_breaks_offline(summary: dict) -> Outcome:
    filling = summary[FILLING_OFFLINE]["cycle_mean_mm"]
    empty = summary[EMPTY]["cycle_mean_mm"]
    return judged([OFFLINE_FILLING_GROWS.part(f"offline filling {numbers(filling)} mm: cycle 4 "
                                              f"/ 1", filling[-1] / filling[0]),
                   OFFLINE_EMPTY_FLAT.part(f"empty {numbers(empty)} mm: cycle 4 / 1",
                                           empty[-1] / empty[0])])


def _online_rides_the_filling(summary: dict) -> Outcome:
    online = summary[FILLING_ONLINE]["cycle_mean_mm"]
    return judged([ONLINE_FILLING_FALLS.part(f"online filling {numbers(online)} mm: cycle 4 / 1",
                                             online[-1] / online[0]),
                   ONLINE_FILLING_FLOOR.part("cycle 4", online[-1])])


def _online_keeps_stable(summary: dict) -> Outcome:
    online = summary[FILLING_ONLINE]["cycle_mean_mm"][-1]
    offline = summary[FILLING_OFFLINE]["cycle_mean_mm"][-1]
    return judged([ONLINE_KEEPS_STABLE.part(
        f"cycle 4 online / offline filling ({online:.2f} / {offline:.2f} mm)", online / offline)])


def _forward_model(summary: dict) -> Outcome:
    return judged([FORWARD_TEST_RMSE.part("forward test RMSE of dp",
                                          summary["forward_rmse_mm"]["test"])],
                  f" on {summary['n_test']} test transitions (predicting no motion "
                  f"{summary['zero_dp_rmse_mm']['test']:.2f} mm; the EM readings' own floor "
                  f"{summary['em_noise_floor_mm']:.2f} mm)")


def _inverse_model(summary: dict) -> Outcome:
    largest = max(summary["inverse_error_mm"]["max_per_axis"])
    reachable = max(summary["inverse_error_reachable_mm"]["max_per_axis"])
    return judged([bar("inverse through the forward model, largest per axis",
                       "reproduced" if largest < INVERSE_BOUND_MM else
                       "partly" if largest < 2 * INVERSE_BOUND_MM else "not reproduced",
                       f"{largest:.2f} mm (on the dp the forward model reaches "
                       f"{reachable:.2f} mm)")])



CLAIMS = (
    Claim("ho2018.table1_online_learns", "ho2018", "Table 1, Section 3.5.1",
          "Under an unknown static 14.2 g tip load, online local learning lowers the tracking "
          "error every cycle.",
          "online, 14.2 g tip: 4.42, 3.33, 1.63 mm per cycle (cycle 3 = 0.37 x cycle 1)",
          "the error falls every cycle (else at most partly); "
          + criteria(("cycle 3 / cycle 1", ONLINE_LEARNS)),
          "ho2018.static", _online_learns_static,
          cause="online 0.97, 0.92, 1.06 / 4.18, 3.97, 6.27 / 1.07, 1.17, 1.32 mm on seeds "
                "0-2: " + PLATEAU),
    Claim("ho2018.table1_online_beats_offline", "ho2018", "Table 1",
          "Online learning under the load ends far below the offline model's error without "
          "load, which does not improve.",
          "cycle 3: online under load 1.63 mm, offline without load 5.53 mm (0.29 x); offline "
          "4.56, 5.72, 5.53 mm",
          criteria(("online cycle 3 / offline cycle 3", ONLINE_VS_OFFLINE)),
          "ho2018.static", _online_below_offline,
          cause="cycle 3 online under load / offline without load: 0.50 (1.06 / 2.11 mm), "
                "0.94, 0.59 x on seeds 0-2, where the paper's offline model tracks at 5.53 mm "
                "and ours at 1.8-2.1 mm unloaded: " + PLATEAU),
    Claim("ho2018.table2_offline_unstable", "ho2018", "Table 2, Section 3.5.2",
          "Offline, the filling container makes the error grow cycle by cycle (unstable), "
          "where the empty container's does not.",
          "offline filling 5.82, 7.24, 10.36, 12.84 mm (cycle 4 = 2.21 x cycle 1); empty "
          "6.01, 7.19, 7.08, 6.94 mm (1.15 x)",
          criteria(("filling cycle 4 / 1", OFFLINE_FILLING_GROWS),
                     ("empty cycle 4 / 1", OFFLINE_EMPTY_FLAT)),
          "ho2018.varying", _filling_breaks_offline,
          cause="the filling grows the offline error 5.4-6.7 x over the four cycles on seeds 0-2 "
                "(the paper's 2.21 x), from 2.6 mm where the paper's started at 5.8 mm: the "
                "offline model tracks the empty container at 2.5-2.7 mm (the paper's 6.0-7.2 "
                "mm), so the same filling error is a larger multiple of it"),
    Claim("ho2018.table2_online_near_1mm", "ho2018", "Table 2",
          "Online learning under the filling load takes the error down to about 1 mm by the "
          "fourth cycle.",
          "online filling 4.16, 3.10, 1.07, 0.98 mm (cycle 4 = 0.24 x cycle 1)",
          criteria(("cycle 4 / cycle 1", ONLINE_FILLING_FALLS),
                     ("cycle 4, the floor", ONLINE_FILLING_FLOOR)),
          "ho2018.varying", _online_rides_the_filling,
          cause=FILLING_FLOOR),
    Claim("ho2018.pretraining_forward_model", "ho2018", "Fig. 4, Section 3.2",
          "The pre-trained forward model predicts the tip's transitions to about 1 mm RMSE on "
          "held-out data.",
          "test RMSE of dp converging to approximately 1 mm (lowest at 11 of 15 epochs; 139 "
          "receptive fields)",
          criteria(("forward test RMSE", FORWARD_TEST_RMSE)),
          "ho2018.pretraining", _forward_model,
          cause="the forward model's test RMSE of dp is 2.14-2.18 mm on seeds 0-2, just above "
                "the 1.96 mm floor that the simulated EM tracker's 0.8 mm white noise per axis "
                "puts under any model of a dp read from two readings (sqrt(6) x 0.8 mm); "
                "without it about 0.9 mm remains, near the paper's 1 mm: the tracker's error "
                "model (0.8 mm is the Aurora's accuracy, not its jitter) sets the number"),
    Claim("ho2018.pretraining_inverse_model", "ho2018", "Fig. 5, Section 3.2",
          "The learned inverse model's commands, pushed through the forward model, give the "
          "asked transition to within 0.5 mm on every axis.",
          "error bounds of each dimension under 0.5 mm on the combined test set",
          f"reproduced: the largest per-axis error under {INVERSE_BOUND_MM} mm; partly: under "
          f"{2 * INVERSE_BOUND_MM:g} mm",
          "ho2018.pretraining", _inverse_model,
          cause="the largest per-axis error is 3.9-5.0 mm on seeds 0-2: the asked dp carry the "
                "EM readings' noise, which no command reaches; on the dp the forward model "
                "itself predicts the bound is still 1.8-2.4 mm, as the inverse undershoots (its "
                "commands about 40 % of the recorded actuation changes, seed 0)"),
    Claim("ho2018.table2_online_stable", "ho2018", "Table 2, Section 3.5.3",
          "Where the offline model goes unstable under the filling load, online learning "
          "avoids the instability.",
          "cycle 4: online 0.98 mm, offline 12.84 mm (\"unstable\"): 0.076 x",
          criteria(("online / offline filling, cycle 4", ONLINE_KEEPS_STABLE)),
          "ho2018.varying", _online_keeps_stable, cause=FILLING_FLOOR),
)
