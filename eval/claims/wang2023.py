"""wang2023's claims: the hybrid controller against the CC model over a K_p sweep (Tables I-II),
the fusion under occlusion and lighting (Figs. 6-7), pushes and flicks (Tables III-IV) and
F-emp's initialisation size (Table VI) (Wang et al. 2023, Section IV; the experiments of
:mod:`eval.runner` and :mod:`eval.papers.estimation`)."""

from __future__ import annotations

import functools
from typing import Any, Callable

from eval import runner
from eval.claims.ledger import Claim, ClaimExperiment, Outcome, graded, numbers
from eval.metrics import estimation_errors, summarize
from eval.papers import estimation

GAINS = (0.04, 0.06, 0.08, 0.10)
"""Tables I-II's four K_p."""
QUICK_GAINS = (0.04, 0.10)
PATHS = ("pentagram", "circle")
TRACK_CYCLES, QUICK_TRACK_CYCLES = 4, 3
"""Cycles per tracking run: the paper's two model-based and two hybrid cycles (Section IV-D:
"the beginning 100 or 75 s ... corresponding to two cycles"); each policy is judged on its last."""
ESTIMATION_STEPS, QUICK_ESTIMATION_STEPS = 4000, 800
"""Steps of an estimation run (0.05 s each: the paper's 200 s, and 40 s with every phase
scaled)."""
QUICK_INIT_SAMPLES = (225, 450, 900)
"""``quick``: the init experiment's initialisation sizes, half the paper's 450 / 900 / 1800
(Table VI; the exploration of the three runs is the largest, so half as long too)."""

PAPER_TRACKING = {  # K_p -> (model, hybrid) mean tracking error / path deviation, mm
    "pentagram": {"tracking": {0.04: (16.942, 2.305), 0.06: (9.351, 1.461),
                               0.08: (4.541, 1.050), 0.10: (2.986, 0.929)},
                  "deviation": {0.04: (3.646, 0.696), 0.06: (2.252, 0.492),
                                0.08: (1.461, 0.384), 0.10: (1.057, 0.361)}},
    "circle": {"tracking": {0.04: (28.910, 2.864), 0.06: (24.979, 6.132),
                            0.08: (15.868, 4.655), 0.10: (5.874, 2.803)},
               "deviation": {0.04: (22.043, 1.311), 0.06: (15.101, 2.476),
                             0.08: (6.211, 1.294), 0.10: (2.087, 0.445)}},
}
"""Tables I (pentagram) and II (circle)."""


def paper_improvements(metric: str) -> list[float]:
    """The paper's improvements ``(e_m - e_h) / e_m`` over both paths and the four gains."""
    return [(model - hybrid) / model for path in PATHS
            for model, hybrid in PAPER_TRACKING[path][metric].values()]


# ------------------------------------------------------------------------------- experiments
def _run_tracking(seed: int, quick: bool, workers: int, progress: bool) -> dict[str, Any]:
    """cc_model and hybrid_gpr on both paths at each gain, EM feedback (Section IV-D: "EM
    trackers were used to provide the sensing feedback"); last-cycle mean tracking error and
    path deviation (mm)."""
    gains = QUICK_GAINS if quick else GAINS
    cycles = QUICK_TRACK_CYCLES if quick else TRACK_CYCLES
    runs = [(path, kp, policy) for path in PATHS for kp in gains
            for policy in ("cc_model", "hybrid_gpr")]
    configs = [runner.RunConfig(policy=policy, policy_params={"kp": kp}, seed=seed,
                                env_kwargs={"path": path, "cycles": cycles, "feedback": "em"})
               for path, kp, policy in runs]
    records = runner.run_many(configs, workers=workers, progress=progress)
    summary: dict[str, Any] = {"gains": list(gains), "cycles": cycles}
    for (path, kp, policy), record in zip(runs, records):
        stats = summarize(record)
        entry = summary.setdefault(path, {}).setdefault(policy, {"tracking_mm": [],
                                                                 "deviation_mm": []})
        entry["tracking_mm"].append(stats["tracking"]["per_cycle"]["mean_mm"][-1])
        entry["deviation_mm"].append(stats["deviation"]["per_cycle"]["mean_mm"][-1])
    return summary


def _phase_stats(errors: dict) -> dict[str, Any]:
    """Mean, max, std and RMSE (mm) of each estimator, over the run and per phase."""
    keys = ("mean_mm", "max_mm", "std_mm", "rmse_mm")
    return {name: {"all": {k: float(errors[name][k]) for k in keys},
                   "phases": {phase: {k: float(stats[k]) for k in keys}
                              for phase, stats in errors[name]["phases"].items()}}
            for name in estimation.ESTIMATORS}


def _run_estimation(experiment: str, seed: int, quick: bool, workers: int,
                    progress: bool) -> dict[str, Any]:
    """Each estimator's errors (mm) over estimation experiment ``experiment`` and its phases;
    for ``init``, per initialisation size."""
    steps = QUICK_ESTIMATION_STEPS if quick else ESTIMATION_STEPS
    phases = estimation._phases(experiment, steps * 0.05)
    if experiment != "init":
        record = estimation.run_estimation(experiment, steps=steps, seed=seed,
                                           progress=progress)
        return _phase_stats(estimation_errors(record, phases=phases))
    ladder = QUICK_INIT_SAMPLES if quick else estimation.INIT_SAMPLES
    return {str(n_init): _phase_stats(estimation_errors(
        estimation.run_estimation("init", steps=steps, n_init=n_init, seed=seed,
                                  progress=progress, init_samples=ladder), phases=phases))
        for n_init in ladder}


def _estimation_runner(experiment: str) -> Callable[[int, bool, int, bool], dict[str, Any]]:
    """Experiment ``experiment``'s run (a partial of a module-level function: a pool worker
    unpickles it)."""
    return functools.partial(_run_estimation, experiment)


_SCALED = "40 s instead of 200 s, every phase scaled"
_SENSING = "the fused sensing's calibration (F-emp from 450 samples)"
EXPERIMENTS = (
    ClaimExperiment("wang2023.tracking", "wang2023",
                    "cc_model and hybrid_gpr track the pentagram and the circle for 4 cycles at "
                    "K_p = 0.04, 0.06, 0.08, 0.10 with EM feedback; each policy's last cycle",
                    "K_p = 0.04 and 0.10 only, 3 cycles", _run_tracking,
                    cpu_minutes=(0.7, 2.0)),
    ClaimExperiment("wang2023.occlusion", "wang2023",
                    "the 200 s spiral with a moving partial occluder from 100 s and full ~2 s "
                    "covers from 160 s (eval.papers.estimation)", _SCALED,
                    _estimation_runner("occlusion"), shares=_SENSING, cpu_minutes=(0.5, 2.7)),
    ClaimExperiment("wang2023.lighting", "wang2023",
                    "the 200 s spiral under low light, darkness from 75 to 150 s and a moving "
                    "LED glare from 150 s", _SCALED, _estimation_runner("lighting"),
                    shares=_SENSING, cpu_minutes=(0.3, 2.2)),
    ClaimExperiment("wang2023.push", "wang2023",
                    "the 200 s spiral with a slow push on the tip cap (40-70 s) and on the "
                    "fiber-covered body (110-140 s), each displacing the tip ~15 mm", _SCALED,
                    _estimation_runner("push"), shares=_SENSING, cpu_minutes=(0.5, 3.0)),
    ClaimExperiment("wang2023.flick", "wang2023",
                    "the 200 s spiral with a fast flick on the tip every 10 s", _SCALED,
                    _estimation_runner("flick"), shares=_SENSING, cpu_minutes=(0.5, 3.5)),
    ClaimExperiment("wang2023.init", "wang2023",
                    "the flick run three times, F-emp initialised from 450, 900 and 1800 "
                    "samples of one exploration",
                    f"{_SCALED}; 225, 450 and 900 samples", _estimation_runner("init"),
                    cpu_minutes=(2.0, 10.0)),
)


# ------------------------------------------------------------------------------------ checks
def _improvements(summary: dict, metric: str) -> list[float]:
    key = f"{metric}_mm"
    return [(model - hybrid) / model for path in PATHS
            for model, hybrid in zip(summary[path]["cc_model"][key],
                                     summary[path]["hybrid_gpr"][key])]


def _gain_trend(summary: dict) -> Outcome:
    parts, monotonic, ends = [], True, True
    for path in PATHS:
        model = summary[path]["cc_model"]["tracking_mm"]  # gains ascending
        monotonic &= all(a > b for a, b in zip(model, model[1:]))
        ends &= model[0] > model[-1]
        parts.append(f"{path} {numbers(model)} mm")
    gains = ", ".join(f"{g:g}" for g in summary["gains"])
    return graded(monotonic, ends, f"cc_model at K_p {gains}: " + "; ".join(parts))


def _improvement_check(metric: str, threshold: float):
    def check(summary: dict) -> Outcome:
        values = _improvements(summary, metric)
        shown = ", ".join(f"{100 * v:.0f}" for v in values)
        return graded(min(values) >= threshold, min(values) > 0.0,
                      f"improvement (pentagram then circle, K_p ascending) {shown} %; smallest "
                      f"{100 * min(values):.0f} %")
    return check


def _phase(summary: dict, estimator: str, phase: str, key: str) -> float:
    return summary[estimator]["phases"][phase][key]


def _full_covers(summary: dict) -> Outcome:
    camera = _phase(summary, "camera", "full covers", "max_mm")
    fused = _phase(summary, "fused", "full covers", "max_mm")
    ratio = camera / fused
    return graded(ratio >= 6.5, ratio >= 2.0,
                  f"full covers: camera max {camera:.2f} mm, fused max {fused:.2f} mm "
                  f"({ratio:.1f} x)")


def _partial_occluder(summary: dict) -> Outcome:
    phase = "partial occluder"
    camera_mean, fused_mean = (_phase(summary, k, phase, "mean_mm") for k in ("camera", "fused"))
    camera_max, fused_max = (_phase(summary, k, phase, "max_mm") for k in ("camera", "fused"))
    ratio = camera_max / fused_max
    return graded(fused_mean <= camera_mean and ratio >= 8.2,
                  fused_mean <= camera_mean or ratio >= 2.0,
                  f"partial occluder: mean camera {camera_mean:.2f} / fused {fused_mean:.2f} mm, "
                  f"max {camera_max:.2f} / {fused_max:.2f} mm ({ratio:.1f} x)")


def _lighting(summary: dict) -> Outcome:
    camera, fused = summary["camera"]["all"]["rmse_mm"], summary["fused"]["all"]["rmse_mm"]
    ratio = camera / fused
    return graded(ratio >= 1.88, ratio > 1.0,
                  f"lighting run RMSE: camera {camera:.2f} mm, fused {fused:.2f} mm "
                  f"({ratio:.2f} x)")


PUSHES = ("push on tip cap", "push on body")


def _push_fusion(summary: dict) -> Outcome:
    full = part = True
    shown = []
    for phase in PUSHES:
        camera, femp, fused = (_phase(summary, k, phase, "mean_mm")
                               for k in ("camera", "femp", "fused"))
        part &= fused <= max(camera, femp)
        full &= fused <= max(camera, femp) and fused <= min(camera, femp) + 0.25
        shown.append(f"{phase}: camera {camera:.2f}, F-emp {femp:.2f}, fused {fused:.2f} mm")
    return graded(full, part, "; ".join(shown))


def _body_push_noise(summary: dict) -> Outcome:
    cap, body = (_phase(summary, "femp", phase, "std_mm") for phase in PUSHES)
    return graded(body >= 1.05 * cap, body > cap,
                  f"F-emp error std: cap push {cap:.3f} mm, body push {body:.3f} mm "
                  f"({body / cap:.2f} x)")


def _flick_fusion(summary: dict) -> Outcome:
    camera, femp, fused = (summary[k]["all"]["mean_mm"] for k in ("camera", "femp", "fused"))
    return graded(fused <= min(camera, femp), fused <= max(camera, femp),
                  f"flicks, mean error: camera {camera:.2f}, F-emp {femp:.2f}, fused "
                  f"{fused:.2f} mm")


def _init_size(summary: dict) -> Outcome:
    ladder = sorted(int(n) for n in summary)  # the paper's 450 / 900 / 1800, or quick's
    means = [summary[str(n)]["femp"]["all"]["mean_mm"] for n in ladder]
    falls = all(a > b for a, b in zip(means, means[1:]))
    sizes = "/".join(str(n) for n in ladder)
    return graded(falls, means[-1] < means[0],
                  f"F-emp mean error with {sizes} initialisation samples: {numbers(means, 3)} mm")


_TRACKING_SMALLEST = min(paper_improvements("tracking"))  # 52.3 %
_DEVIATION_SMALLEST = min(paper_improvements("deviation"))  # 65.8 %

CLAIMS = (
    Claim("wang2023.tables1-2_gain_matters", "wang2023", "Tables I-II, Section IV-D",
          "The CC model-based controller's tracking error grows as K_p falls from 0.10 to 0.04 "
          "on both paths.",
          "cc_model: pentagram 2.99, 4.54, 9.35, 16.94 mm; circle 5.87, 15.87, 24.98, 28.91 mm "
          "(K_p 0.10 -> 0.04)",
          "reproduced: the last-cycle error falls with every larger K_p on both paths; partly: "
          "larger at the smallest K_p than at the largest on both",
          "wang2023.tracking", _gain_trend),
    Claim("wang2023.tables1-2_hybrid_tracking", "wang2023", "Tables I-II",
          "The hybrid controller (CC + online GPR) reduces the tracking error of the CC model "
          "at every K_p on both paths.",
          "improvement 68.9-86.4 % (pentagram), 52.3-90.1 % (circle)",
          f"reproduced: at least {100 * 0.9 * _TRACKING_SMALLEST:.0f} % (0.9 x the paper's "
          "smallest) at every gain on both paths; partly: some improvement at every one",
          "wang2023.tracking", _improvement_check("tracking", 0.9 * _TRACKING_SMALLEST)),
    Claim("wang2023.tables1-2_hybrid_deviation", "wang2023", "Tables I-II",
          "The hybrid controller reduces the path deviation of the CC model at every K_p on "
          "both paths.",
          "improvement 65.8-80.9 % (pentagram), 78.7-94.1 % (circle)",
          f"reproduced: at least {100 * 0.9 * _DEVIATION_SMALLEST:.0f} % (0.9 x the paper's "
          "smallest) at every gain on both paths; partly: some improvement at every one",
          "wang2023.tracking", _improvement_check("deviation", 0.9 * _DEVIATION_SMALLEST),
          cause="the hybrid's path deviation stays at 0.54-0.85 mm at every gain (about the EM "
                "feedback's 0.8 mm noise), while the CC model's is only 0.72-0.98 mm at K_p "
                "0.08-0.10 (the paper's 1.06-6.21 mm), so 3-34 % is left to remove there "
                "(41-75 % at K_p 0.04; seeds 0-2)"),
    Claim("wang2023.fig6_full_covers", "wang2023", "Fig. 6, Section IV-C1",
          "While a hand covers the whole view for ~2 s at a time, the camera's estimate "
          "stagnates and its error grows, while the fused estimate stays bounded.",
          "full covers: SLAM max 38.48 mm, fusion max 4.75 mm (8.1 x)",
          "reproduced: camera max at least 6.5 x the fused max (0.8 x the paper's ratio); "
          "partly: at least 2 x",
          "wang2023.occlusion", _full_covers,
          cause="7.6 x and 9.2 x on seeds 0-1, 5.2 x on seed 2 (fused max 3.19 mm under the "
                "covers against 1.71-2.05 mm); why seed 2's fused estimate peaks higher is "
                "unknown"),
    Claim("wang2023.fig6_partial_occluder", "wang2023", "Fig. 6, Section IV-C1",
          "Behind a moving hand that partly shields the view, the fusion's error is lower than "
          "the camera's, most of all at its peaks.",
          "partial occluder: SLAM mean 1.69 / max 26.27 mm, fusion 1.13 / 2.57 mm (10.2 x at "
          "the max)",
          "reproduced: fused mean at most the camera's and the camera's max at least 8.2 x the "
          "fused max (0.8 x the paper's); partly: one of the two, or the max ratio at least 2",
          "wang2023.occlusion", _partial_occluder,
          cause="the fused mean is below the camera's on every seed (0.70-0.72 against "
                "0.78-1.01 mm), but the camera's peaks behind the partial occluder are far "
                "smaller than the paper's SLAM's (max 4.9-11.8 mm against 26.3 mm) and the "
                "fused max larger (3.3-5.0 against 2.6 mm): 1.5-2.4 x, not 10 x"),
    Claim("wang2023.fig7_lighting", "wang2023", "Fig. 7, Section IV-C2",
          "Under low light, darkness and LED glare the fusion keeps a stable estimate, "
          "improving on the camera's RMSE.",
          "RMSE over the lighting run: SLAM 3.116 mm, fusion 1.324 mm (2.35 x)",
          "reproduced: camera RMSE at least 1.88 x the fused (0.8 x the paper's ratio); "
          "partly: larger than it",
          "wang2023.lighting", _lighting),
    Claim("wang2023.table3_push_fusion", "wang2023", "Table III, Section IV-F1",
          "Under slow pushes on the tip cap and on the fiber-covered body, the fused estimate's "
          "mean error stays between its sources', close to the better one.",
          "fusion mean within the two sources' in 7 of 8 cases, at most 0.24 mm above the "
          "better (LEGO cap 0.689/0.950/0.747, body 0.516/0.732/0.703 mm: SLAM/F-emp/fusion)",
          "reproduced: in both push phases the fused mean at most the worse source's and at "
          "most 0.25 mm above the better's; partly: at most the worse source's in both",
          "wang2023.push", _push_fusion),
    Claim("wang2023.table3_body_push_noise", "wang2023", "Table III, Section IV-F1",
          "A push on the fiber-covered body strains the gratings, so F-emp's error scatters "
          "more than under a push on the rigid cap.",
          "F-emp error std, cap vs body: LEGO 0.752/0.730 vs 0.875/0.774 mm, abdominal "
          "0.926/1.188 vs 1.712/1.377 mm (body larger in 4 of 4; smallest ratio 1.06)",
          "reproduced: body-push std at least 1.05 x the cap-push std; partly: larger",
          "wang2023.push", _body_push_noise,
          cause="F-emp's error scatters as much under the push on the cap as under the push on "
                "the body (std 0.322-0.334 against 0.327-0.333 mm, seeds 0-2): the contact "
                "strain the body push puts on the gratings under it does not show in F-emp's "
                "estimate; whether the strain model is too weak or F-emp's online updates learn "
                "it away is unknown"),
    Claim("wang2023.table4_flick_fusion", "wang2023", "Table IV, Section IV-F2",
          "Under fast flicks, which blur the camera, the fused estimate is no worse than either "
          "source.",
          "LEGO, 4 cases: fusion mean 1.22-1.77 mm against SLAM 1.25-1.85 and F-emp 1.32-2.18 "
          "mm (fusion lowest in all 4)",
          "reproduced: fused mean error at most both sources'; partly: at most the worse one's",
          "wang2023.flick", _flick_fusion,
          cause="F-emp alone is the best estimate under the flicks here (0.51 mm against the "
                "camera's 0.60) and the fused one lies between them (0.57 mm, seeds 0-2), "
                "where the paper's fusion beat both; why the fusion does not lean on F-emp "
                "more during the blur is not yet measured"),
    Claim("wang2023.table6_init_size", "wang2023", "Table VI, Appendix",
          "F-emp initialised from more samples (450, 900, 1800) estimates the pose better "
          "under flicks.",
          "F-emp mean: case 1 1.972 / 1.939 / 0.615 mm, case 2 1.582 / 1.179 / 0.899 mm",
          "reproduced: F-emp's mean error falls with each doubling; partly: lower with 1800 "
          "than with 450",
          "wang2023.init", _init_size),
)
