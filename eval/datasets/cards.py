"""Data cards: the ``card.md`` written next to each dataset (how it was collected, seeds,
versions, fields with units, layout, known biases). Each paper's card text is its
``PaperDataset.card`` (``eval/papers/<key>/dataset.py``); docs/datasets.md summarises them."""

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
    from eval.datasets.papers import PAPER_DATASETS

    card = PAPER_DATASETS[paper].card
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
