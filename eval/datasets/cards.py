"""Data cards: the ``card.md`` written next to each dataset (how it was collected, seeds,
versions, fields with units, layout, known biases). docs/datasets.md summarises them."""

from __future__ import annotations

from importlib.metadata import PackageNotFoundError, version
from typing import Any

from soft_gym._distributions import REFERENCE_ENGINE_PACKAGE

PROCEDURE_LAYOUT = (
    "One episode holds the procedure's samples in the order taken. Step `i`'s action is sample "
    "`i`'s command as the env's absolute-mode action (`a = 2 (p - p_pre) / (p_max - p_pre) - 1`)"
    " and `observations[i + 1]` the readings once it settled. `observations[0]` and every "
    "info column's row 0 are NaN (nothing is read before the first command); rewards are 0, "
    "no step terminates and the last is truncated. `recover_environment()` makes the env whose "
    "arm and sensors took the samples, with ground-truth feedback (nothing calibrates); the "
    "samples were taken on a private simulator of that arm, held to equilibrium rather than "
    "stepped by the env, so replaying the actions there does not give them back.")

PAPER_CARDS: dict[str, dict[str, Any]] = {
    "zhao2021": {
        "title": "zhao2021 random exploration (Section VI-A)",
        "how": "A random walk in pressure space on a private simulator of the zhao2021 arm: "
               "each sample adjusts two random chambers by +-1/16 of p_max (0.05 bar), holds "
               "the command 1 s and reads the strain gauges and the backbone. The first "
               "`n_free` samples are taken with the arm free, the next `n_loaded` with a 75 g "
               "tip mass (the same walk continues). This is the record `strain_sr` and "
               "`local_ik_asdm` learn from, taken by the procedure that builds them "
               "(`soft_gym.procedures.zhao2021_exploration`), so the calibration cache shares it.",
        "observations": "`strain` (6,): the strain gauges' readings (3 per segment, the sensor's "
                        "units: bending strain with the gauges' noise).",
        "infos": "`command_pa` (6,) Pa; `tip_position_m` (3,) m; `key_points_m` (6, 3) m, "
                 "zhao2021's P_1..P_6; `backbone_m` (n_links + 1, 3) m; `tip_load_kg` kg.",
        "biases": "The arm is simulated (2 x 4 rigid links, thread-limited bores); gauges "
                  "read the simulated curvature with Gaussian noise, no drift or hysteresis. "
                  "The walk never leaves [p_pre, p_max]; the loaded half follows the free half "
                  "without a reset.",
    },
    "zou2022": {
        "title": "zou2022 ASES-labelled pressure sweep (Section 5.1 (1))",
        "how": "Distinct commands of the 0.1 bar grid (0-3 bar per muscle, 31^3 = 29791 "
               "commands) in random order on a private simulator, each held 2 s; the cable "
               "encoders' chamber lengths are read and the stereo pair's ASES (SOM centreline) "
               "labels seven backbone points. A sample where ASES lost the arm is replaced by "
               "a copy of a good one turned about the axis (the paper's supplement; "
               "`augmented`). Train / validation / test sets are dealt out by command "
               "(`split`). The procedure is `soft_gym.procedures.zou2022_dataset`.",
        "observations": "`encoder` (3,): chamber lengths from the cable encoders (m).",
        "infos": "`command_pa` (3,) Pa; `stereo_labels_m` (7, 3) m, ASES's P_0..P_6 (the "
                 "DNN's labels); `true_points_m` (7, 3) m, the simulator's P_0..P_6; "
                 "`tip_position_m` (3,) m, true; `augmented` (1 = rotated copy); `split` "
                 "(0 train, 1 validation, 2 test).",
        "biases": "The labels are ASES's, not the truth: they carry the stereo pair's "
                  "triangulation and SOM errors (compare `true_points_m`). The simulated arm "
                  "twists as its muscles fill (an assumed unbalanced braid). Augmented samples "
                  "are copies, not measurements.",
    },
    "wang2023": {
        "title": "wang2023 sensing calibration (Section IV-B)",
        "how": "The predefined spiral actuation, one command per control period, on a private "
               "simulator of the wang2023 arm at rest after the env's settle time; every step "
               "reads the helical FBG fiber and the eye-in-hand camera, whose ORB + PnP pose "
               "labels the FBG shifts when it trusts the frame. These labelled samples "
               "initialise F-emp (`fused`, `camera`, `fbg` feedback). The procedure is "
               "`soft_gym.procedures.wang2023_calibration.calibrate_pipeline`.",
        "observations": "`fbg` (17,): Bragg wavelength shifts (nm).",
        "infos": "`command_pa` (3,) Pa; `pressures_pa` (3,) Pa, the chambers' pressures "
                 "(lagging the command); `tip_position_m` (3,) m and `tip_quaternion` (4,) "
                 "(x, y, z, w), true; `backbone_m` (n_links + 1, 3) m; "
                 "`camera_label_position_m` (3,) m and `camera_label_quaternion` (4,), the "
                 "camera's pose (NaN where it gave none); `labelled` (1 = used by F-emp).",
        "biases": "The camera labels are the vision tracker's, with its errors; frames it "
                  "did not trust are unlabelled. The exploration covers the spiral only.",
    },
    "ho2018": {
        "title": "ho2018 pre-training walk (Section 3.2)",
        "how": "`lwpr_rwr`'s pre-training: on an unloaded, fault-free copy of the env "
               "(EM-tracker feedback), 20 control steps at the rest actuation, then straight "
               "lines of 30 decisions (2 control steps each) between random actuator-space "
               "waypoints (uniform in [0, 0.6] of every chamber's range). The LWPR forward "
               "model learns the transitions (p, u, du, dp) every `hold_steps` steps of this "
               "episode. Recorded as the env ran it.",
        "observations": "the env's flat observation: `pose` (7,), the EM tracker's tip "
                        "position (m) and quaternion; `target` (6,) m (the reach task's, not "
                        "used by the walk).",
        "infos": "`tip_position_m` (3,) m, `tip_quaternion` (4,), `backbone_m` (n, 3) m, "
                 "`chamber_lengths_m` (6,) m, `pressures_pa` (6,) Pa, `target_m` (3,) m, "
                 "`error_mm` mm, `time_s` s: the ground truth of every step (row 0: the reset).",
        "biases": "EM noise 0.8 mm / 0.7 deg; the arm is unloaded; waypoints cover only "
                  "[0, 0.6] of each chamber's range.",
        "layout": "One Gymnasium episode as the env ran it: `observations` (steps + 1), "
                  "`actions`, `rewards`, `terminations`, `truncations` (steps) and `infos` "
                  "(steps + 1, row 0 from the reset). `recover_environment()` makes that env; "
                  "`reset(seed=episode's seed)` and the actions give the observations back bit "
                  "for bit.",
    },
}


def package_versions() -> dict[str, str]:
    """Installed versions of what made the data."""
    versions = {}
    for name in ("soft-arm-gym", "minari", "gymnasium", REFERENCE_ENGINE_PACKAGE, "numpy",
                 "torch"):
        try:
            versions[name] = version(name)
        except PackageNotFoundError:
            continue
    return versions


def paper_card(paper: str, dataset_id: str, settings: dict[str, Any], n_samples: int,
               env_id: str, env_kwargs: dict[str, Any], size_bytes: int | None = None) -> str:
    """The Markdown data card of ``paper``'s dataset."""
    card = PAPER_CARDS[paper]
    lines = [f"# {dataset_id}", "", card["title"] + ".", "",
             "## How it was collected", "", card["how"], "",
             "## Settings and seeds", "",
             *[f"- `{key}`: {value}" for key, value in settings.items()],
             f"- samples (steps): {n_samples}", "",
             "## Layout", "", card.get("layout", PROCEDURE_LAYOUT), "",
             f"Env: `{env_id}` with `{env_kwargs}`.", "",
             "## Fields", "", f"Observations: {card['observations']}", "",
             f"Infos: {card['infos']}", "",
             "## Known biases", "", card["biases"], "",
             "## Versions", "",
             *[f"- {name} {value}" for name, value in package_versions().items()]]
    if size_bytes is not None:
        lines += ["", f"Size on disk: {size_bytes / 1e6:.2f} MB."]
    return "\n".join(lines) + "\n"


def suite_card(dataset_id: str, suite: str, labels: dict[str, Any], policies: list[str],
               n_episodes: int, n_steps: int, env_id: str, env_kwargs: dict[str, Any]) -> str:
    """The Markdown data card of one arm and condition of a suite run."""
    lines = [f"# {dataset_id}", "",
             f"Runs of the suite `{suite}` on arm `{labels.get('preset')}`, condition "
             f"`{labels.get('condition')}`: {n_episodes} episodes, {n_steps} steps.", "",
             "## How it was collected", "",
             "`python -m eval suite SPEC --record minari`: every run of this arm and condition "
             "(each policy and seed, the env of the cell) is one episode recorded as it ran. "
             "Each episode's metadata holds `policy`, `seed`, `path`, the run's `key`, `env_id` "
             "and `env_kwargs` (a policy may read other observation parts; episodes are "
             "grouped so that one dataset holds one observation and action space).", "",
             f"Policies: {', '.join(policies)}.", "",
             "## Fields", "",
             "Observations and actions: the env's (see README.md, \"Environments\"). Rewards: "
             "minus the tracking error (m) minus the action-rate term. Infos (row 0 from the "
             "reset): `tip_position_m` (3,) m, `tip_quaternion` (4,), `target_m` (3,) m, "
             "`error_mm` mm, `backbone_m` m, `chamber_lengths_m` m, `pressures_pa` Pa, "
             "`time_s` s (ground truth), and `estimate_<name>` for every numeric estimate of "
             "the feedback source (e.g. the camera, F-emp and fused poses).", "",
             f"Env (`recover_environment()`): `{env_id}` with `{env_kwargs}`.", "",
             "## Known biases", "",
             "The policies' own behaviour: a dataset of controllers tracking paths, not an "
             "exploration of the workspace. Online learners (`hybrid_gpr`, `lwpr_rwr`) change "
             "during an episode.", "",
             "## Versions", "",
             *[f"- {name} {value}" for name, value in package_versions().items()]]
    return "\n".join(lines) + "\n"
