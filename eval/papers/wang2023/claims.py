"""wang2023's claims: the hybrid controller against the CC model over a K_p sweep (Tables I-II),
the fusion under occlusion and lighting (Figs. 6-7), pushes and flicks (Tables III-IV) and
F-emp's initialisation size (Table VI) (Wang et al. 2023, Section IV; the experiments of
:mod:`eval.runner` and :mod:`eval.papers.wang2023.estimation`)."""

from __future__ import annotations

import functools
from typing import Any, Callable

from eval import runner
from eval.claims.ledger import (Claim, ClaimExperiment, Effect, Outcome, bar, criteria, judged,
                                numbers)
from eval.metrics import estimation_errors, summarize
import eval.papers.wang2023.estimation as estimation

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
FIG11_KP = 0.1
"""Fig. 11's gain ("the same hybrid controller as in Section IV-D (K_p = 0.1)")."""
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


def paper_improvements(metric: str, path: str | None = None) -> list[float]:
    """The paper's improvements ``(e_m - e_h) / e_m`` at the four gains, on ``path`` (default:
    both paths)."""
    return [(model - hybrid) / model for name in ((path,) if path else PATHS)
            for model, hybrid in PAPER_TRACKING[name][metric].values()]


# ------------------------------------------------------------------------------- experiments
def _track(seed: int, quick: bool, workers: int, progress: bool, gains: tuple[float, ...],
           feedback: str, paths: tuple[str, ...] = PATHS) -> dict[str, Any]:
    """cc_model and hybrid_gpr on ``paths`` at each gain with ``feedback``; each policy's
    last-cycle mean and max tracking error and mean path deviation (mm)."""
    cycles = QUICK_TRACK_CYCLES if quick else TRACK_CYCLES
    runs = [(path, kp, policy) for path in paths for kp in gains
            for policy in ("cc_model", "hybrid_gpr")]
    configs = [runner.RunConfig(policy=policy, policy_params={"kp": kp}, seed=seed,
                                env_kwargs={"path": path, "cycles": cycles,
                                            "feedback": feedback})
               for path, kp, policy in runs]
    records = runner.run_many(configs, workers=workers, progress=progress)
    summary: dict[str, Any] = {"gains": list(gains), "cycles": cycles}
    for (path, kp, policy), record in zip(runs, records):
        stats = summarize(record)
        entry = summary.setdefault(path, {}).setdefault(
            policy, {"tracking_mm": [], "deviation_mm": [], "max_mm": []})
        entry["tracking_mm"].append(stats["tracking"]["per_cycle"]["mean_mm"][-1])
        entry["deviation_mm"].append(stats["deviation"]["per_cycle"]["mean_mm"][-1])
        entry["max_mm"].append(stats["tracking"]["per_cycle"]["max_mm"][-1])
    return summary


def _run_tracking(seed: int, quick: bool, workers: int, progress: bool) -> dict[str, Any]:
    """Tables I-II: EM feedback (Section IV-D: "EM trackers were used to provide the sensing
    feedback") at the four gains (``quick``: two)."""
    return _track(seed, quick, workers, progress, QUICK_GAINS if quick else GAINS, "em")


def _run_fused_control(seed: int, quick: bool, workers: int, progress: bool) -> dict[str, Any]:
    """Fig. 11: the same controllers at K_p = 0.1 on the fused camera/FBG pose (Section IV-E:
    "the pose information would be provided by the fusion result of SLAM and FBG")."""
    return _track(seed, quick, workers, progress, (FIG11_KP,), "fused",
                  PATHS[:1] if quick else PATHS)


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
    for ``init``, per initialisation size; for ``flick``, the flick run's and the same spiral's
    without flicks (``{"flick": ..., "clean": ...}``)."""
    steps = QUICK_ESTIMATION_STEPS if quick else ESTIMATION_STEPS
    phases = estimation._phases(experiment, steps * 0.05)
    if experiment == "flick":  # with the same spiral undisturbed: what the flicks do
        return {name: _phase_stats(estimation_errors(estimation.run_estimation(
            name, steps=steps, seed=seed, progress=progress),
            phases=estimation._phases(name, steps * 0.05))) for name in ("flick", "clean")}
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
                    "covers from 160 s (eval.papers.wang2023.estimation)", _SCALED,
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
                    "the 200 s spiral with a fast flick on the tip every 10 s, and the same "
                    "spiral without flicks", _SCALED,
                    _estimation_runner("flick"), shares=_SENSING, cpu_minutes=(1.0, 6.2),
                    version=2),
    ClaimExperiment("wang2023.init", "wang2023",
                    "the flick run three times, F-emp initialised from 450, 900 and 1800 "
                    "samples of one exploration",
                    f"{_SCALED}; 225, 450 and 900 samples", _estimation_runner("init"),
                    cpu_minutes=(2.0, 10.0)),
    ClaimExperiment("wang2023.fused_control", "wang2023",
                    "cc_model and hybrid_gpr track the pentagram and the circle for 4 cycles at "
                    "K_p = 0.1 on the fused camera/FBG pose (Fig. 11's controllers; the paper's "
                    "elephant path is not among the env's paths); each policy's last cycle",
                    "the pentagram only, 3 cycles", _run_fused_control, shares=_SENSING,
                    cpu_minutes=(2.0, 6.0)),
)


# ------------------------------------------------------------------------------------ checks
def _paper_ratio(path: str, metric: str, low_kp: float, high_kp: float) -> float:
    table = PAPER_TRACKING[path][metric]
    return table[low_kp][0] / table[high_kp][0]


GAIN_EFFECT = {path: Effect("ratio", round(_paper_ratio(path, "tracking", 0.04, 0.10), 2),
                            unit="x") for path in PATHS}
"""Tables I-II: the CC model's error at K_p 0.04 over its error at 0.10 (pentagram 5.67,
circle 4.92)."""
IMPROVEMENT = {metric: {path: Effect("fraction", (
    min(paper_improvements(metric, path)), max(paper_improvements(metric, path))))
    for path in PATHS} for metric in ("tracking", "deviation")}
"""Tables I-II: the hybrid's improvement over the CC model, the paper's range over the four
gains per path (tracking 69-86 % / 52-90 %, deviation 66-81 % / 79-94 %)."""


def _gain_effect(summary: dict) -> Outcome:
    gains = summary["gains"]
    low, high = gains.index(min(gains)), gains.index(max(gains))
    return judged([GAIN_EFFECT[path].part(
        f"{path} cc_model {summary[path]['cc_model']['tracking_mm'][low]:.2f} / "
        f"{summary[path]['cc_model']['tracking_mm'][high]:.2f} mm =",
        summary[path]["cc_model"]["tracking_mm"][low]
        / summary[path]["cc_model"]["tracking_mm"][high]) for path in PATHS])


def _improvement_check(metric: str) -> Callable[[dict], Outcome]:
    def check(summary: dict) -> Outcome:
        key = f"{metric}_mm"
        parts = []
        for path in PATHS:
            model, hybrid = summary[path]["cc_model"][key], summary[path]["hybrid_gpr"][key]
            for kp, m, h in zip(summary["gains"], model, hybrid):
                parts.append(IMPROVEMENT[metric][path].part(f"{path} K_p {kp:g}", (m - h) / m))
        return judged(parts)
    return check


def _phase(summary: dict, estimator: str, phase: str, key: str) -> float:
    return summary[estimator]["phases"][phase][key]


FIG5_CAMERA_RMSE = Effect("level", 0.998, unit="mm")
"""Fig. 5: the camera's RMSE against the EM tracker over the undisturbed spiral."""
COVERS_CAMERA_MAX = Effect("level", 38.483, unit="mm")
COVERS_RATIO = Effect("ratio", 8.11, unit="x")
"""Fig. 6, full covers: SLAM max 38.483 mm, fusion max 4.747 mm."""
PARTIAL_CAMERA_MAX = Effect("level", 26.272, unit="mm")
PARTIAL_MAX_RATIO = Effect("ratio", 10.21, unit="x")
PARTIAL_MEAN_RATIO = Effect("ratio", 1.50, unit="x")
"""Fig. 6, partial occluder: SLAM mean 1.694 / max 26.272 mm, fusion 1.132 / 2.573 mm."""
LIGHTING_CAMERA_RMSE = Effect("level", 3.116, unit="mm")
LIGHTING_RATIO = Effect("ratio", 2.35, unit="x")
"""Fig. 7: RMSE over the lighting run, SLAM 3.116 mm, fusion 1.324 mm."""
PUSH_CAMERA_MAX = Effect("level", (2.374, 16.109), unit="mm")
"""Table III: the camera's max error during the pushes, over the paper's eight cases."""
PUSH_FUSED_ABOVE_BETTER_MM = 0.25
"""Table III: the fused mean at most 0.24 mm above the better source's in 7 of 8 cases."""
CAP_PUSH_SPIKE = Effect("ratio", 5.07, unit="x")
"""Table III, abdominal, cap push 1: camera max 16.109 mm, fusion max 3.180 mm."""
BODY_PUSH_STD = Effect("ratio", (1.06, 1.85), unit="x")
"""Table III: F-emp's error std under the body push over the cap push, four cases."""
FLICK_CAMERA = Effect("ratio", (1.49, 2.20), unit="x")
"""Table IV's camera means under flicks (1.249-1.849 mm) over the camera's mean on the same
scene undisturbed (0.840 mm, Fig. 6's first 100 s)."""
FLICK_FUSION_GAIN = Effect("ratio", (1.023, 1.106), unit="x")
"""Table IV: the better source's mean over the fused mean, four cases (fusion lowest in all)."""
INIT_FEMP = Effect("ratio", (0.31, 0.57), unit="x")
"""Table VI: F-emp's mean error initialised from 1800 samples over 450, two cases."""
FIG11_MEAN_RATIO = Effect("ratio", 1.64, unit="x")
FIG11_PEAK_RATIO = Effect("ratio", 1.68, unit="x")
"""Fig. 11(b): the model-based cycle's mean / peak tracking error (2.625 / 13.322 mm) over the
hybrid cycle's (1.604 / 7.944 mm), on the fused pose at K_p = 0.1."""


def _fig5(summary: dict) -> Outcome:
    return judged([FIG5_CAMERA_RMSE.part(
        "camera RMSE over the undisturbed first half",
        _phase(summary, "camera", "undisturbed", "rmse_mm"))])


def _full_covers(summary: dict) -> Outcome:
    camera = _phase(summary, "camera", "full covers", "max_mm")
    fused = _phase(summary, "fused", "full covers", "max_mm")
    return judged([COVERS_CAMERA_MAX.part("camera max under the covers", camera),
                   COVERS_RATIO.part(f"camera / fused max ({fused:.2f} mm)", camera / fused)])


def _partial_occluder(summary: dict) -> Outcome:
    phase = "partial occluder"
    camera_mean, fused_mean = (_phase(summary, k, phase, "mean_mm") for k in ("camera", "fused"))
    camera_max, fused_max = (_phase(summary, k, phase, "max_mm") for k in ("camera", "fused"))
    return judged([PARTIAL_CAMERA_MAX.part("camera max behind the occluder", camera_max),
                   PARTIAL_MAX_RATIO.part(f"camera / fused max ({fused_max:.2f} mm)",
                                          camera_max / fused_max),
                   PARTIAL_MEAN_RATIO.part(f"camera / fused mean ({camera_mean:.2f} / "
                                           f"{fused_mean:.2f} mm)", camera_mean / fused_mean)])


def _lighting(summary: dict) -> Outcome:
    camera, fused = summary["camera"]["all"]["rmse_mm"], summary["fused"]["all"]["rmse_mm"]
    return judged([LIGHTING_CAMERA_RMSE.part("camera RMSE", camera),
                   LIGHTING_RATIO.part(f"camera / fused RMSE ({fused:.2f} mm)", camera / fused)])


PUSHES = ("push on tip cap", "push on body")


def _push_fusion(summary: dict) -> Outcome:
    parts = []
    for phase in PUSHES:
        camera, femp, fused = (_phase(summary, k, phase, "mean_mm")
                               for k in ("camera", "femp", "fused"))
        parts.append(PUSH_CAMERA_MAX.part(f"{phase}: camera max",
                                          _phase(summary, "camera", phase, "max_mm")))
        above = fused - min(camera, femp)
        verdict = ("reproduced" if fused <= max(camera, femp)
                   and above <= PUSH_FUSED_ABOVE_BETTER_MM else
                   "partly" if fused <= max(camera, femp) else "not reproduced")
        parts.append(bar("fused mean", verdict, f"{fused:.2f} mm, {above:+.2f} mm from the "
                                                f"better source (camera {camera:.2f}, F-emp "
                                                f"{femp:.2f})"))
    return judged(parts)


def _cap_push_spike(summary: dict) -> Outcome:
    camera = _phase(summary, "camera", "push on tip cap", "max_mm")
    fused = _phase(summary, "fused", "push on tip cap", "max_mm")
    return judged([CAP_PUSH_SPIKE.part(f"cap push: camera max {camera:.2f} / fused max "
                                       f"{fused:.2f} mm =", camera / fused)])


def _body_push_noise(summary: dict) -> Outcome:
    cap, body = (_phase(summary, "femp", phase, "std_mm") for phase in PUSHES)
    return judged([BODY_PUSH_STD.part(f"F-emp error std body / cap push ({body:.3f} / "
                                      f"{cap:.3f} mm)", body / cap)])


def _flick_fusion(summary: dict) -> Outcome:
    flick, clean = summary["flick"], summary["clean"]
    camera, femp, fused = (flick[k]["all"]["mean_mm"] for k in ("camera", "femp", "fused"))
    undisturbed = clean["camera"]["all"]["mean_mm"]
    return judged([FLICK_CAMERA.part(f"camera mean under flicks / without ({camera:.2f} / "
                                     f"{undisturbed:.2f} mm)", camera / undisturbed),
                   FLICK_FUSION_GAIN.part(f"better source / fused mean (camera {camera:.2f}, "
                                          f"F-emp {femp:.2f}, fused {fused:.2f} mm)",
                                          min(camera, femp) / fused)])


def _init_size(summary: dict) -> Outcome:
    ladder = sorted(int(n) for n in summary)  # the paper's 450 / 900 / 1800, or quick's
    means = [summary[str(n)]["femp"]["all"]["mean_mm"] for n in ladder]
    return judged([INIT_FEMP.part(f"F-emp mean with {ladder[-1]} / {ladder[0]} samples "
                                  f"({numbers(means, 3)} mm)", means[-1] / means[0])])


def _fused_control(summary: dict) -> Outcome:
    parts = []
    for path in (path for path in PATHS if path in summary):  # quick: the pentagram only
        model, hybrid = summary[path]["cc_model"], summary[path]["hybrid_gpr"]
        parts.append(FIG11_MEAN_RATIO.part(
            f"{path} mean cc / hybrid ({model['tracking_mm'][0]:.2f} / "
            f"{hybrid['tracking_mm'][0]:.2f} mm)",
            model["tracking_mm"][0] / hybrid["tracking_mm"][0]))
        parts.append(FIG11_PEAK_RATIO.part(
            f"peak ({model['max_mm'][0]:.2f} / {hybrid['max_mm'][0]:.2f} mm)",
            model["max_mm"][0] / hybrid["max_mm"][0]))
    return judged(parts)



DISTURBANCE = "the disturbance first: "

CLAIMS = (
    Claim("wang2023.tables1-2_gain_matters", "wang2023", "Tables I-II, Section IV-D",
          "The CC model-based controller's tracking error grows as K_p falls from 0.10 to 0.04 "
          "on both paths.",
          "cc_model: pentagram 2.99, 4.54, 9.35, 16.94 mm; circle 5.87, 15.87, 24.98, 28.91 mm "
          "(K_p 0.10 -> 0.04): 5.67 x and 4.92 x",
          "the error at K_p 0.04 over the error at 0.10, per path: " + criteria(
              *((path, GAIN_EFFECT[path]) for path in PATHS)),
          "wang2023.tracking", _gain_effect,
          cause="the CC model's error grows 1.9-2.3 x from K_p 0.10 to 0.04 (the paper's 4.9-5.7 "
                "x): at K_p 0.10 it is already 2.6-2.9 mm, near the paper's 3.0 / 5.9 mm, but at "
                "0.04 only 5.0-6.6 mm against 16.9 / 28.9 mm; the pressure-driven arm's nearly "
                "linear pressure-to-elongation map fits eq. (27) (docs/claims/records, seeds "
                "0-2)"),
    Claim("wang2023.tables1-2_hybrid_tracking", "wang2023", "Tables I-II",
          "The hybrid controller (CC + online GPR) reduces the tracking error of the CC model "
          "at every K_p on both paths.",
          "improvement 68.9-86.4 % (pentagram), 52.3-90.1 % (circle)",
          "the improvement at every gain, against the paper's range on that path: " + criteria(
              *((path, IMPROVEMENT["tracking"][path]) for path in PATHS)),
          "wang2023.tracking", _improvement_check("tracking"),
          cause="at K_p 0.10 on the pentagram the improvement is 55-57 % on seeds 0-2, at the "
                "band's lower edge (55 %, 0.8 x the paper's smallest 69 %): the CC model's "
                "error there is 2.6 mm (the paper's 3.0 mm) and the hybrid's 1.2 mm (0.93 mm); "
                "seed 0 falls just under it"),
    Claim("wang2023.tables1-2_hybrid_deviation", "wang2023", "Tables I-II",
          "The hybrid controller reduces the path deviation of the CC model at every K_p on "
          "both paths.",
          "improvement 65.8-80.9 % (pentagram), 78.7-94.1 % (circle)",
          "the improvement at every gain, against the paper's range on that path: " + criteria(
              *((path, IMPROVEMENT["deviation"][path]) for path in PATHS)),
          "wang2023.tracking", _improvement_check("deviation"),
          cause="the hybrid's path deviation stays at 0.54-0.85 mm at every gain (about the EM "
                "feedback's 0.8 mm noise), while the CC model's is only 0.72-0.98 mm at K_p "
                "0.08-0.10 (the paper's 1.06-6.21 mm), so 3-34 % is left to remove there "
                "(41-75 % at K_p 0.04; seeds 0-2)"),
    Claim("wang2023.fig5_camera_accuracy", "wang2023", "Fig. 5, Section IV-B",
          "Undisturbed, the eye-in-hand camera's pose tracks the EM ground truth to about 1 mm "
          "RMSE.",
          "SLAM RMSE 0.998 mm (mean absolute errors 0.508 / 0.596 / 0.385 mm on x / y / z)",
          criteria(("camera RMSE", FIG5_CAMERA_RMSE)),
          "wang2023.occlusion", _fig5,
          cause="the simulated camera is more accurate than the paper's ORB-SLAM2: 0.59-0.68 "
                "mm RMSE over the undisturbed first half on seeds 0-2 (the paper's 0.998 mm)"),
    Claim("wang2023.fig6_full_covers", "wang2023", "Fig. 6, Section IV-C1",
          "While a hand covers the whole view for ~2 s at a time, the camera's estimate "
          "stagnates and its error grows, while the fused estimate stays bounded.",
          "full covers: SLAM max 38.48 mm, fusion max 4.75 mm (8.1 x)",
          DISTURBANCE + criteria(("camera max under the covers", COVERS_CAMERA_MAX),
                                   ("camera / fused max", COVERS_RATIO)),
          "wang2023.occlusion", _full_covers,
          cause="the covers hurt the simulated camera less than the paper's: its max under them "
                "is 15.4-15.6 mm on seeds 0-2 against the paper's 38.5 mm (under half), while "
                "the fused max stays 1.8-2.4 mm (camera / fused 6.4-8.4 x, the paper's 8.1 x)"),
    Claim("wang2023.fig6_partial_occluder", "wang2023", "Fig. 6, Section IV-C1",
          "Behind a moving hand that partly shields the view, the fusion's error is lower than "
          "the camera's, most of all at its peaks.",
          "partial occluder: SLAM mean 1.69 / max 26.27 mm, fusion 1.13 / 2.57 mm (1.50 x at "
          "the mean, 10.2 x at the max)",
          DISTURBANCE + criteria(("camera max", PARTIAL_CAMERA_MAX),
                                   ("camera / fused max", PARTIAL_MAX_RATIO),
                                   ("camera / fused mean", PARTIAL_MEAN_RATIO)),
          "wang2023.occlusion", _partial_occluder,
          cause="the partial occluder barely hurts the simulated camera: its max behind it is "
                "5.8-9.3 mm on seeds 0-2 against the paper's 26.3 mm, and the fused max "
                "3.0-4.5 mm against 2.6 mm, so camera / fused is 1.5-3.1 x at the max (the "
                "paper's 10.2 x) and 1.13-1.40 x at the mean (1.50 x)"),
    Claim("wang2023.fig7_lighting", "wang2023", "Fig. 7, Section IV-C2",
          "Under low light, darkness and LED glare the fusion keeps a stable estimate, "
          "improving on the camera's RMSE.",
          "RMSE over the lighting run: SLAM 3.116 mm, fusion 1.324 mm (2.35 x)",
          DISTURBANCE + criteria(("camera RMSE", LIGHTING_CAMERA_RMSE),
                                   ("camera / fused RMSE", LIGHTING_RATIO)),
          "wang2023.lighting", _lighting,
          cause="darkness hurts the simulated camera more than the paper's (RMSE 5.6-5.7 mm over "
                "the run on seeds 0-2 against 3.1 mm) while the fusion holds 0.71-0.79 mm (the "
                "paper's 1.32 mm): camera / fused 7.1-7.9 x against 2.35 x"),
    Claim("wang2023.table3_push_fusion", "wang2023", "Table III, Section IV-F1",
          "Under slow pushes on the tip cap and on the fiber-covered body, the fused estimate's "
          "mean error stays between its sources', close to the better one.",
          "fusion mean within the two sources' in 7 of 8 cases, at most 0.24 mm above the "
          "better (LEGO cap 0.689/0.950/0.747, body 0.516/0.732/0.703 mm: SLAM/F-emp/fusion); "
          "the camera's max during the pushes 2.37-16.11 mm over the eight cases",
          DISTURBANCE + "in each push, " + criteria(("the camera's max", PUSH_CAMERA_MAX))
          + "; then the fused mean: reproduced at most the worse source's and at most "
          f"{PUSH_FUSED_ABOVE_BETTER_MM} mm above the better's; partly at most the worse's",
          "wang2023.push", _push_fusion),
    Claim("wang2023.table3_push_maxima", "wang2023", "Table III, Section IV-F1",
          "A push on the rigid cap turns the robot abruptly, which gives the camera large "
          "occasional errors that the fusion suppresses.",
          "abdominal, cap push 1: SLAM max 16.109 mm, fusion max 3.180 mm (5.07 x); in the "
          "other seven cases 0.52-1.10 x",
          criteria(("camera / fused max under the cap push", CAP_PUSH_SPIKE)),
          "wang2023.push", _cap_push_spike,
          cause="no spike: under the cap push the simulated camera's max is 2.24-2.42 mm and the "
                "fused max the same on seeds 0-2 (1.00 x; the paper's abdominal case 5.07 x, its "
                "seven other cases 0.52-1.10 x): the camera never loses the tip's sudden turn"),
    Claim("wang2023.table3_body_push_noise", "wang2023", "Table III, Section IV-F1",
          "A push on the fiber-covered body strains the gratings, so F-emp's error scatters "
          "more than under a push on the rigid cap.",
          "F-emp error std, cap vs body: LEGO 0.752/0.730 vs 0.875/0.774 mm, abdominal "
          "0.926/1.188 vs 1.712/1.377 mm (1.06-1.85 x)",
          criteria(("body / cap std", BODY_PUSH_STD)),
          "wang2023.push", _body_push_noise,
          cause="F-emp's error std under the body push over the cap push is 1.15, 0.92 and 1.09 "
                "x on seeds 0-2 (the paper's 1.06-1.85 x): on seed 1 the body push scatters "
                "F-emp less than the cap push; whether the contact strain model is too weak or "
                "F-emp's online updates learn it away is unknown"),
    Claim("wang2023.table4_flick_fusion", "wang2023", "Table IV, Section IV-F2",
          "Fast flicks blur the camera, and the fused estimate is then better than either "
          "source.",
          "LEGO, 4 cases: SLAM 1.249-1.849 mm (undisturbed 0.840 mm, Fig. 6), F-emp 1.324-2.175, "
          "fusion 1.221-1.769 mm: fusion lowest in all 4, 2-10 % below the better source",
          DISTURBANCE + criteria(("camera mean under flicks / without", FLICK_CAMERA),
                                   ("better source / fused mean", FLICK_FUSION_GAIN)),
          "wang2023.flick", _flick_fusion,
          cause="the flicks barely hurt the simulated camera: its mean error under them is "
                "1.04-1.23 x its mean without them on seeds 0-2 (the paper's 1.49-2.20 x), and "
                "F-emp alone is the best estimate (0.49-0.65 mm against the fused 0.54-0.71 mm: "
                "better source / fused 0.89-0.91 x), where the paper's fusion beat both"),
    Claim("wang2023.table6_init_size", "wang2023", "Table VI, Appendix",
          "F-emp initialised from more samples (450, 900, 1800) estimates the pose better "
          "under flicks.",
          "F-emp mean: case 1 1.972 / 1.939 / 0.615 mm, case 2 1.582 / 1.179 / 0.899 mm "
          "(1800 / 450: 0.31 and 0.57; the camera's own mean falls 0.48 and 0.62 x across "
          "the same runs)",
          criteria(("F-emp mean 1800 / 450", INIT_FEMP)),
          "wang2023.init", _init_size,
          cause="F-emp's mean error barely moves with its initialisation size (0.563, 0.560, "
                "0.550 mm on seed 0 for 450 / 900 / 1800 samples; 1800 / 450 0.98-0.99 x on seeds "
                "0-2, the paper's 0.31-0.57 x): the online updates after initialisation level "
                "the three runs"),
    Claim("wang2023.fig11_fused_hybrid", "wang2023", "Fig. 11, Section IV-E1",
          "On the fused pose, the hybrid controller tracks better than the CC model, in the "
          "mean and at the peaks.",
          "elephant path, K_p 0.1: model-based 2.625 mm mean / 13.322 mm peak, hybrid 1.604 / "
          "7.944 mm (1.64 x, 1.68 x)",
          "per path (pentagram and circle: the elephant path is not among the env's): "
          + criteria(("CC / hybrid mean", FIG11_MEAN_RATIO),
                       ("CC / hybrid peak", FIG11_PEAK_RATIO)),
          "wang2023.fused_control", _fused_control,
          cause="on the fused pose the hybrid's gain at the mean is larger than the paper's: CC "
                "/ hybrid 2.02-2.63 x on seeds 0-2 (the paper's 1.64 x; band to 2.05 x), the "
                "peaks within the band (1.55-2.09 x); the CC model tracks at 1.5 mm (the "
                "paper's 2.6 mm on its elephant path) and the hybrid at 0.58-0.76 mm (1.6 mm)"),
    Claim("wang2023.fig12_spline_mapping", "wang2023", "Fig. 12, Section IV-E2",
          "With a cubic-spline actuation mapping, hybrid control on the fused pose keeps "
          "tracking under moving visual obstacles.",
          "last cycle with moving obstacles in view: tracking 1.751 mm, path deviation 0.336 mm",
          "tracking error and path deviation levels: reproduced within 0.8-1.25 x the paper's",
          None, None,
          cause="cc_model has only eq. (27)'s linear actuation mapping; the spline-fitted "
                "mapping of Section IV-E2 fits the stepper-driven cylinders, which the "
                "pressure-driven wang2023 arm does not have"),
)
