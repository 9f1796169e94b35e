"""The README's code runs as written, and the version it documents is the package's."""

from __future__ import annotations

import contextlib
import io
import re
from pathlib import Path

import pytest

import soft_gym

ROOT = Path(__file__).resolve().parent.parent


def _python_blocks(path: Path) -> list[str]:
    return re.findall(r"```python\n(.*?)```", path.read_text(encoding="utf-8"), flags=re.S)


def test_the_readme_baseline_loop_runs_and_tracks():
    """The README's ``obs -> predict -> step`` loop with a baseline made by make_policy: it runs
    to the end of the episode without an explicit calibrate() and tracks the circle."""
    (block,) = [block for block in _python_blocks(ROOT / "README.md")
                if "make_policy(" in block and ".predict(" in block and "make_vec(" not in block]
    printed = io.StringIO()
    namespace: dict = {}
    with contextlib.redirect_stdout(printed):
        exec(compile(block, "README.md", "exec"), namespace)
    env, policy = namespace["env"], namespace["policy"]
    assert namespace["done"] and policy.alpha is not None
    assert namespace["info"]["error_mm"] < 3.0, namespace["info"]["error_mm"]
    assert re.fullmatch(r"error at the end: \d+\.\d\d mm\n", printed.getvalue())
    env.close()


@pytest.mark.slow
def test_the_readme_quick_builds_run_with_progress_bars(monkeypatch, capsys):
    """The README's quick builds of ``local_ik_asdm`` and ``lwpr_rwr``, built afresh (no
    cache): both finish with a trained model of the size asked for, and both show their
    progress bars on stderr. Slow (about 70 s on one core): both builds are also tested in
    their own modules (``tests/agents/controllers``)."""
    (block,) = [block for block in _python_blocks(ROOT / "README.md") if ".pretrain()" in block]
    from soft_gym.sensing import calibration_cache

    monkeypatch.setenv("SOFT_GYM_CACHE", "off")
    calibration_cache.clear_memory()
    namespace: dict = {}
    exec(compile(block, "README.md", "exec"), namespace)
    err = capsys.readouterr().err
    assert "zhao2021 exploration" in err and "/600" in err and "local IK training" in err
    assert "lwpr_rwr pre-training waypoints" in err and "/20" in err
    assert namespace["ik"].network is not None and namespace["ik"].training
    lwpr = namespace["lwpr"]
    assert lwpr.pretraining["samples"] == 20 * lwpr.leg_decisions
    for name in ("zhao", "ho"):
        namespace[name].close()
    calibration_cache.clear_memory()


def test_the_package_reports_the_version_of_pyproject_and_the_changelog():
    (version,) = re.findall(r'^version = "([^"]+)"$', (ROOT / "pyproject.toml").read_text(),
                            flags=re.M)
    assert soft_gym.__version__ == version
    changelog = (ROOT / "CHANGELOG.md").read_text(encoding="utf-8")
    assert re.search(rf"^## \[{re.escape(version)}\] - \d{{4}}-\d{{2}}-\d{{2}}$", changelog,
                     flags=re.M)


def test_the_readme_gymnasium_and_sb3_recipes_run(tmp_path, monkeypatch):
    """The recipes block: async vector envs step, both env checkers pass, RecordVideo writes an
    MP4 of the episode, and the shipped SAC agent tracks the circle in a plain loop."""
    (block,) = [block for block in _python_blocks(ROOT / "README.md") if "RecordVideo" in block]
    monkeypatch.chdir(tmp_path)
    namespace: dict = {}
    with contextlib.redirect_stdout(io.StringIO()):
        exec(compile(block, "README.md", "exec"), namespace)
    assert namespace["observations"].shape == (2, 16)
    videos = list((tmp_path / "videos").glob("*.mp4"))
    assert videos and videos[0].stat().st_size > 1000
    assert namespace["info"]["error_mm"] < 3.0


def test_the_readme_batched_mujoco_block_runs():
    """The "Two engines" block: a batch of 64 MuJoCo arms as one vector env resets and steps."""
    (block,) = [block for block in _python_blocks(ROOT / "README.md")
                if "vector_entry_point" in block]
    namespace: dict = {}
    with contextlib.redirect_stdout(io.StringIO()):
        exec(compile(block, "README.md", "exec"), namespace)
    assert namespace["observations"].shape == (64, 16)
    assert namespace["envs"].metadata["autoreset_mode"].value == "NextStep"


def _first_column_names(text: str, first_row: str) -> list[str]:
    """The backquoted names in the first column of the Markdown table whose first row starts
    with ``first_row``."""
    lines = text.splitlines()
    start = next(i for i, line in enumerate(lines) if line.replace(" ", "").startswith(first_row))
    names = []
    for line in lines[start:]:
        if not line.startswith("|"):
            break
        match = re.match(r"^\|\s*`([a-z_0-9]+)`", line)
        if match:
            names.append(match.group(1))
    return names


def test_the_tables_of_names_list_every_registered_name():
    """The tables users read (README, the env's and modules' docstrings, the architecture
    document) name exactly what the registries hold, in their order."""
    import soft_gym.envs.observations as observations
    import soft_gym.envs.soft_arm_env as soft_arm_env
    import soft_gym.sensing.feedback as feedback
    import soft_gym.sensors as sensors
    from soft_gym.envs.observations import OBSERVATION_PARTS
    from soft_gym.sensing import FEEDBACK_SOURCES
    from soft_gym.sensors import SENSORS

    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    architecture = (ROOT / "docs" / "architecture.md").read_text(encoding="utf-8")
    parts = list(OBSERVATION_PARTS)
    for text in (readme, observations.__doc__, soft_arm_env.__doc__):
        assert _first_column_names(text, "|`pose`|") == parts
    for text in (feedback.__doc__, architecture):
        assert _first_column_names(text, "|`ground_truth`|") == list(FEEDBACK_SOURCES)
    assert _first_column_names(sensors.__doc__, "|`fbg`|") == list(SENSORS)


def test_what_the_readme_examples_write_is_ignored_by_git():
    """The folders the README's examples write into (RecordVideo's ``video_folder``, the
    commands' ``results/``) are in ``.gitignore``."""
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    ignored = {line.strip().rstrip("/") for line in
               (ROOT / ".gitignore").read_text().splitlines() if line.strip()}
    folders = set(re.findall(r'video_folder="([^"/]+)"', readme))
    assert folders == {"videos"}
    folders |= {path.split("/")[0] for path in re.findall(r"`(results/[^`]+)`", readme)}
    assert folders <= ignored, folders - ignored


def _training(agent: str) -> dict:
    import yaml

    (last,) = yaml.safe_load((ROOT / "agents" / "trained" / agent / "training.yaml")
                             .read_text())[-1:]
    return last


def test_the_readme_training_times_are_the_shipped_agents_measured_ones():
    """The minutes the README gives for training come from the shipped agents' own
    ``training.yaml`` (wall time, and steps over the measured env steps/s)."""
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    text = " ".join(readme.split())
    sac = _training("sac_wang2023_track")
    ((steps, minutes),) = re.findall(r"# the shipped SAC: ([\d,]+) steps to its plateau, ~(\d+) min",
                                     readme)
    assert sac["stopped_at_plateau"] and sac["timesteps"] == int(steps.replace(",", ""))
    assert int(minutes) == round(sac["wall_s"] / 60)
    td3 = _training("td3_wang2023_track")
    ((steps, minutes),) = re.findall(r"# the shipped TD3: ([\d,]+) steps to its plateau, ~(\d+) min",
                                     readme)
    assert td3["stopped_at_plateau"] and td3["timesteps"] == int(steps.replace(",", ""))
    assert int(minutes) == round(td3["wall_s"] / 60)
    assert f"{round(td3['training_env_steps_per_s'])} training env steps/s for the TD3 on " \
           f"PyBullet with one env, {round(sac['training_env_steps_per_s'])} training env " \
           f"steps/s for the SAC" in text
    plateaus = {
        "ho2018": r"`sac_ho2018_track` \(the sweep's chosen config on 4 batched MuJoCo arms, "
                  r"plateau at ([\d,]+) steps, (\d+) minutes, (\d+) training env steps/s",
        "zhao2021": r"`sac_zhao2021_track` trained on `strain_sr` too, with the sweep's chosen "
                    r"config \(4 batched MuJoCo arms, plateau at ([\d,]+) steps, (\d+) minutes, "
                    r"(\d+) training env steps/s"}
    for agent, pattern in plateaus.items():
        ((steps, minutes, rate),) = re.findall(pattern, text)
        training = _training(f"sac_{agent}_track")
        assert training["stopped_at_plateau"], agent
        assert training["timesteps"] == int(steps.replace(",", "")), agent
        assert int(minutes) == round(training["wall_s"] / 60), agent
        assert int(rate) == round(training["training_env_steps_per_s"]), agent
    (steps, zou, rate) = re.findall(r"tracking curve flattened \(([\d,]+) steps, (\d+) minutes, "
                                    r"(\d+) env steps/s", text)[0]
    assert int(zou) == round(_training("sac_zou2022_track")["wall_s"] / 60)
    zou2022 = _training("sac_zou2022_track")
    assert zou2022["timesteps"] == int(steps.replace(",", ""))
    assert round(zou2022["training_env_steps_per_s"]) == int(rate)


def test_the_contributing_section_gives_the_loop_smoke_before_a_commit_suite_before_a_push():
    """README's Contributing section: the smoke subset before every commit, then the default
    suite (CI's command) before every push, in that order, and the marker it selects exists."""
    import tomllib

    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    section = readme[readme.index("## Contributing"):]
    blocks = re.findall(r"```bash\n(.*?)```", section, flags=re.S)
    assert [block.strip() for block in blocks[:2]] == [".venv/bin/python -m pytest -m smoke",
                                                       ".venv/bin/python -m pytest"]
    assert section.index("Before every commit") < section.index(blocks[0])
    assert section.index(blocks[0]) < section.index("Before every push") \
        < section.rindex(blocks[1])
    markers = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["pytest"][
        "ini_options"]["markers"]
    assert any(marker.startswith("smoke:") for marker in markers)
    assert "pytest" in (ROOT / ".ci" / "run").read_text()
