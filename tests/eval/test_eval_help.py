"""The command lines' help agrees with the README and the code: ``python -m eval --help`` names
the README's main job, ``benchmark --help`` describes its fixed runs from their settings,
``suite --help`` is short and links the schema in docs/suite.md (whose tables list the keys the
spec checker allows), the bundled small suite's description matches its policies, and
``bench/env_speed.py`` says what its ``env/ref`` ratio is."""

from __future__ import annotations

import importlib.util
import re
from pathlib import Path

import pytest
import yaml

import eval.__main__ as eval_main
import eval.papers.wang2023.benchmark_command as paper_benchmark
from eval.suite import ARM_KEYS, POLICY_KEYS, TOP_KEYS, SUITES_DIR

pytestmark = pytest.mark.smoke

ROOT = Path(__file__).resolve().parents[2]


def _help(argv: list[str], capsys) -> str:
    with pytest.raises(SystemExit) as exit_info:
        eval_main.main(argv + ["--help"])
    assert exit_info.value.code == 0
    return capsys.readouterr().out


def _readme_main_job() -> str:
    """The ``python -m eval ...`` command of the README's first bash block (the main job)."""
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    first = re.search(r"```bash\n(.*?)```", readme, flags=re.S).group(1)
    return re.search(r"-m eval ([a-z_]+ [a-z_]+)", first).group(1)


def test_eval_help_names_the_readme_main_job_and_not_benchmark(capsys):
    text = _help([], capsys)
    main_job = _readme_main_job()
    assert main_job == "suite small"
    assert f"python -m eval {main_job}`` is the\nREADME's main job" in text \
        or f"python -m eval {main_job}`` is the README's main job" in text.replace("\n", " ")
    assert "benchmark`` (the README's main job)" not in text


def test_benchmark_help_describes_its_runs_from_their_settings(capsys):
    text = " ".join(_help(["benchmark"], capsys).split())
    load_g = f"{paper_benchmark.BENCHMARK_LOAD_KG * 1000:g} g tip load"
    start = f"from {paper_benchmark.BENCHMARK_OCCLUDER['start_s']:g} s on"
    assert load_g in text and start in text and "fused camera/FBG feedback" in text
    assert "The README's main job is 'suite small'" in text


def test_suite_help_is_short_and_links_the_schema(capsys):
    text = _help(["suite"], capsys)
    assert len(text.splitlines()) < 40, len(text.splitlines())
    assert "docs/suite.md" in text and "Arm block" not in text
    assert (ROOT / "docs" / "suite.md").is_file()


def _table_keys(text: str, heading: str) -> list[str]:
    """The backquoted first-column names of the first table after ``heading``."""
    section = text[text.index(heading):]
    rows = re.findall(r"^\| `([a-z_]+)` \|", section.split("\n## ")[0], flags=re.M)
    return rows


def test_docs_suite_lists_the_keys_the_checker_allows():
    text = (ROOT / "docs" / "suite.md").read_text(encoding="utf-8")
    assert _table_keys(text, "## Top level") == list(TOP_KEYS)
    assert _table_keys(text, "## Arm block") == list(ARM_KEYS)
    assert _table_keys(text, "## Policy entry") == list(POLICY_KEYS)
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    assert "schema in [`docs/suite.md`](docs/suite.md)" in readme
    for name in ("small", "default"):
        assert "# Schema: docs/suite.md." in (SUITES_DIR / f"{name}.yaml").read_text()


def test_the_small_suite_description_matches_its_agents():
    """Its description says every arm runs its shipped SB3 agents: every arm lists one."""
    spec = yaml.safe_load((SUITES_DIR / "small.yaml").read_text())
    description = " ".join(spec["description"].split())
    assert ("its shipped SB3 agents (SAC and the recurrent PPO on every arm, TD3 too on "
            "wang2023)") in description
    for arm, block in spec["arms"].items():
        names = [p if isinstance(p, str) else p["name"] for p in block["policies"]]
        assert f"sb3:sac_{arm}_track" in names, arm
        assert f"sb3:ppo_lstm_{arm}_track" in names, arm
        assert (f"sb3:td3_{arm}_track" in names) == (arm == "wang2023"), arm


def test_env_speed_says_what_env_over_reference_is_and_who_meets_the_target():
    spec = importlib.util.spec_from_file_location("bench_env_speed_help",
                                                  ROOT / "bench" / "env_speed.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    note = module.speed_target_note([{"env_over_reference": 0.48},
                                     {"env_over_reference": 0.94},
                                     {"env_over_reference": None}])
    assert "above 1 the env is faster" in note
    assert "Measured 0.48-0.94" in note and "is met by 0 of 2 presets" in note
    assert "met by 1 of 1" in module.speed_target_note([{"env_over_reference": 5.0}])
    assert "goal is" not in note
