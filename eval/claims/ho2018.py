"""ho2018's claims: online local learning under an unknown static and a filling tip load
(Ho et al. 2018, Tables 1-2; the experiments of :mod:`eval.papers.ho2018`)."""

from __future__ import annotations

import functools
from typing import Any, Callable

from eval.claims.ledger import Claim, ClaimExperiment, Outcome, graded, numbers
from eval.papers import ho2018 as experiments

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


EXPERIMENTS = (
    ClaimExperiment(
        "ho2018.static", "ho2018",
        "lwpr_rwr drives the cylinders' volumes to track the 25 x 100 mm rectangle for 3 "
        "cycles of 133.3 s (400 s) at 20 Hz with EM feedback: offline without load, online "
        "under an unknown 14.2 g tip (eval.papers.ho2018)",
        "20 s cycles at 10 Hz and an 8 s lead-in", _runner("static"), cpu_minutes=(1.5, 3.6)),
    ClaimExperiment(
        "ho2018.varying", "ho2018",
        "lwpr_rwr drives the cylinders' volumes to track the 40 x 60 mm rectangle for 4 cycles "
        "of 45 s: offline at 20 Hz with the empty 14 g container, offline at 20 Hz and online "
        "at 6.7 Hz while it fills by 10 g from cycle 3 and 6 g from cycle 4 (eval.papers.ho2018)",
        "15 s cycles at 10 Hz and an 8 s lead-in", _runner("varying"), cpu_minutes=(3.6, 6.3)),
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


STATIC_ONLINE, STATIC_OFFLINE = "online, 14.2 g tip", "offline, no load"
EMPTY, FILLING_OFFLINE, FILLING_ONLINE = ("offline, empty 14 g tip", "offline, filling",
                                          "online, filling")


def _online_learns_static(summary: dict) -> Outcome:
    online = summary[STATIC_ONLINE]["cycle_mean_mm"]
    falls = all(b < a for a, b in zip(online, online[1:]))
    ratio = online[-1] / online[0]
    return graded(falls and ratio <= 0.5, online[-1] < online[0],
                  f"online {numbers(online)} mm: falls every cycle {falls}, cycle 3 / cycle 1 "
                  f"= {ratio:.2f}")


def _online_below_offline(summary: dict) -> Outcome:
    online = summary[STATIC_ONLINE]["cycle_mean_mm"][-1]
    offline = summary[STATIC_OFFLINE]["cycle_mean_mm"][-1]
    return graded(online <= 0.5 * offline, online < offline,
                  f"cycle 3: online under load {online:.2f} mm, offline without load "
                  f"{offline:.2f} mm (ratio {online / offline:.2f})")


def _filling_breaks_offline(summary: dict) -> Outcome:
    filling = summary[FILLING_OFFLINE]["cycle_mean_mm"]
    empty = summary[EMPTY]["cycle_mean_mm"]
    grows, flat = filling[-1] / filling[0], empty[-1] / empty[0]
    return graded(grows >= 1.77 and flat < 1.5, grows >= 1.77 or (grows > 1.2 and flat < 1.5),
                  f"offline filling {numbers(filling)} mm (cycle 4 / 1 = {grows:.2f}); empty "
                  f"{numbers(empty)} mm ({flat:.2f})")


def _online_rides_the_filling(summary: dict) -> Outcome:
    online = summary[FILLING_ONLINE]["cycle_mean_mm"]
    ratio = online[-1] / online[0]
    return graded(ratio <= 0.5 and online[-1] <= 1.5, online[-1] < online[0],
                  f"online filling {numbers(online)} mm: cycle 4 / cycle 1 = {ratio:.2f}")


CLAIMS = (
    Claim("ho2018.table1_online_learns", "ho2018", "Table 1, Section 3.5.1",
          "Under an unknown static 14.2 g tip load, online local learning lowers the tracking "
          "error every cycle.",
          "online, 14.2 g tip: 4.42, 3.33, 1.63 mm per cycle (cycle 3 = 0.37 x cycle 1)",
          "reproduced: the online error falls every cycle and cycle 3 is at most 0.5 x cycle "
          "1; partly: cycle 3 below cycle 1",
          "ho2018.static", _online_learns_static,
          cause="online 0.97, 0.92, 1.06 / 4.18, 3.97, 6.26 / 1.07, 1.17, 1.32 mm on seeds "
                "0-2: " + PLATEAU),
    Claim("ho2018.table1_online_beats_offline", "ho2018", "Table 1",
          "Online learning under the load ends far below the offline model's error without "
          "load, which does not improve.",
          "cycle 3: online under load 1.63 mm, offline without load 5.53 mm (0.29 x); offline "
          "4.56, 5.72, 5.53 mm",
          "reproduced: online cycle 3 at most 0.5 x offline cycle 3; partly: below it",
          "ho2018.static", _online_below_offline,
          cause="cycle 3 online under load / offline without load: 0.50 (1.06 / 2.11 mm, "
                "just above the criterion's 0.5), 0.94, 0.59 x on seeds 0-2: " + PLATEAU),
    Claim("ho2018.table2_offline_unstable", "ho2018", "Table 2, Section 3.5.2",
          "Offline, the filling container makes the error grow cycle by cycle (unstable), "
          "where the empty container's does not.",
          "offline filling 5.82, 7.24, 10.36, 12.84 mm (cycle 4 = 2.21 x cycle 1); empty "
          "6.01, 7.19, 7.08, 6.94 mm (1.15 x)",
          "reproduced: filling cycle 4 at least 1.77 x cycle 1 (0.8 x the paper's 2.21) and "
          "empty below 1.5 x; partly: one of the two, or filling above 1.2 x with empty flat",
          "ho2018.varying", _filling_breaks_offline),
    Claim("ho2018.table2_online_near_1mm", "ho2018", "Table 2",
          "Online learning under the filling load takes the error down to about 1 mm by the "
          "fourth cycle.",
          "online filling 4.16, 3.10, 1.07, 0.98 mm (cycle 4 = 0.24 x cycle 1)",
          "reproduced: cycle 4 at most 0.5 x cycle 1 and at most 1.5 mm; partly: cycle 4 "
          "below cycle 1",
          "ho2018.varying", _online_rides_the_filling,
          cause="online filling 2.44 -> 2.55, 2.23 -> 2.02 and 2.36 -> 2.25 mm (cycle 4 / 1 = "
                "1.05, 0.91, 0.96) on seeds 0-2: stable through the filling, where the offline "
                "model reaches 14.3-17.1 mm in cycle 4, but not down to 1 mm. At the paper's 6.7 "
                "Hz its first cycle is already 2.2-2.4 mm, below the offline model's 2.6 mm under "
                "the empty container, so there is no load error to learn away before the "
                "filling, and with 251-272 transitions learnt a cycle (the "
                "paper about 300) it holds 2.0-2.6 mm while the container fills; the same runs at "
                "20 Hz end at 2.0 mm (seed 0)"),
)
