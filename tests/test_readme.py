"""The README and the docs pages it leads to: their code runs as written, their links resolve,
the README stays a front door (its measured numbers live in docs/results.md, which is current),
and the version it documents is the package's."""

from __future__ import annotations

import contextlib
import io
import re
from pathlib import Path

import pytest

import soft_gym

ROOT = Path(__file__).resolve().parent.parent
GUIDE = ROOT / "docs" / "guide.md"

README_MAX_LINES = 350
"""The README is a front door: what the toolkit is, the two commands, a tour, where to go next."""


def _python_blocks(path: Path) -> list[str]:
    return re.findall(r"```python\n(.*?)```", path.read_text(encoding="utf-8"), flags=re.S)


def _run_block(block: str, where: str) -> dict:
    """Run a documented code block (its prints swallowed); its namespace afterwards."""
    namespace: dict = {}
    with contextlib.redirect_stdout(io.StringIO()):
        exec(compile(block, where, "exec"), namespace)
    return namespace


def test_the_readme_baseline_loop_runs_and_tracks():
    """The README's ``obs -> predict -> step`` loop with a baseline made by make_policy: it runs
    to the end of the episode without an explicit calibrate() and tracks the circle."""
    (block,) = [block for block in _python_blocks(ROOT / "README.md")
                if "make_policy(\"hybrid_gpr\"" in block and ".predict(" in block]
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
    """The guide's quick builds of ``local_ik_asdm`` and ``lwpr_rwr``, built afresh (no
    cache): both finish with a trained model of the size asked for, and both show their
    progress bars on stderr. Slow (about 70 s on one core): both builds are also tested in
    their own modules (``tests/agents/controllers``)."""
    (block,) = [block for block in _python_blocks(GUIDE) if ".pretrain()" in block]
    from soft_gym.sensing import calibration_cache

    monkeypatch.setenv("SOFT_GYM_CACHE", "off")
    calibration_cache.clear_memory()
    namespace: dict = {}
    exec(compile(block, "docs/guide.md", "exec"), namespace)
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


def test_the_guide_gymnasium_and_sb3_recipes_run(tmp_path, monkeypatch):
    """The guide's recipes block: async vector envs step, both env checkers pass, RecordVideo
    writes an MP4 of the episode, and the shipped SAC agent tracks the circle in a plain loop."""
    (block,) = [block for block in _python_blocks(GUIDE) if "RecordVideo" in block]
    monkeypatch.chdir(tmp_path)
    namespace = _run_block(block, "docs/guide.md")
    assert namespace["observations"].shape == (2, 16)
    videos = list((tmp_path / "videos").glob("*.mp4"))
    assert videos and videos[0].stat().st_size > 1000
    assert namespace["info"]["error_mm"] < 3.0


def test_the_guide_batched_mujoco_block_runs():
    """The guide's "Two engines" block: a batch of 64 MuJoCo arms as one vector env resets and
    steps."""
    (block,) = [block for block in _python_blocks(GUIDE) if "vector_entry_point" in block]
    namespace = _run_block(block, "docs/guide.md")
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
    """The tables users read (the guide, the env's and modules' docstrings, the architecture
    document) name exactly what the registries hold, in their order."""
    import soft_gym.envs.observations as observations
    import soft_gym.envs.soft_arm_env as soft_arm_env
    import soft_gym.sensing.feedback as feedback
    import soft_gym.sensors as sensors
    from soft_gym.envs.observations import OBSERVATION_PARTS
    from soft_gym.sensing import FEEDBACK_SOURCES
    from soft_gym.sensors import SENSORS

    guide = GUIDE.read_text(encoding="utf-8")
    architecture = (ROOT / "docs" / "architecture.md").read_text(encoding="utf-8")
    parts = list(OBSERVATION_PARTS)
    for text in (guide, observations.__doc__, soft_arm_env.__doc__):
        assert _first_column_names(text, "|`pose`|") == parts
    for text in (feedback.__doc__, architecture):
        assert _first_column_names(text, "|`ground_truth`|") == list(FEEDBACK_SOURCES)
    assert _first_column_names(sensors.__doc__, "|`fbg`|") == list(SENSORS)


def test_what_the_documented_examples_write_is_ignored_by_git():
    """The folders the examples of the README and the docs pages write into (RecordVideo's
    ``video_folder``, the commands' ``results/``) are in ``.gitignore``."""
    readme = "\n".join(path.read_text(encoding="utf-8") for path in _documents())
    ignored = {line.strip().rstrip("/") for line in
               (ROOT / ".gitignore").read_text().splitlines() if line.strip()}
    folders = set(re.findall(r'video_folder="([^"/]+)"', readme))
    assert folders == {"videos"}
    folders |= {path.split("/")[0] for path in re.findall(r"`(results/[^`]+)`", readme)}
    assert folders <= ignored, folders - ignored


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


# ---------------------------------------------------------------------------- the front door
DOCS_PAGES = ("guide.md", "training.md", "experiments.md", "results.md", "datasets.md",
              "suite.md", "claims.md", "sweeps.md", "gpu.md")
"""The docs pages the README leads to, whose links are checked with the README's (the
architecture document's own links within it are its own)."""


def _documents() -> list[Path]:
    """The README and the docs pages it leads to."""
    return [ROOT / "README.md"] + [ROOT / "docs" / name for name in DOCS_PAGES]


def _without_code(text: str) -> str:
    """Markdown without its fenced code blocks (a ``#`` there is a comment, not a heading)."""
    return re.sub(r"^```.*?^```", "", text, flags=re.S | re.M)


def _anchors(path: Path) -> set[str]:
    """The anchors GitHub gives the headings of a Markdown file (lower case, punctuation but
    ``-`` and ``_`` dropped, spaces as ``-``, a repeated one numbered)."""
    anchors: set[str] = set()
    for line in _without_code(path.read_text(encoding="utf-8")).splitlines():
        if re.match(r"^#{1,6} ", line):
            slug = re.sub(r"[^\w\- ]", "", line.lstrip("#").strip().lower()).replace(" ", "-")
            number, unique = 0, slug
            while unique in anchors:
                number += 1
                unique = f"{slug}-{number}"
            anchors.add(unique)
    return anchors


def _broken_links(path: Path) -> list[str]:
    """The relative links of a Markdown file whose file, folder or heading does not exist."""
    broken = []
    for target in re.findall(r"\]\(([^)\s]+)\)", _without_code(path.read_text(encoding="utf-8"))):
        if re.match(r"^[a-z]+:", target):
            continue  # a web address
        file_part, _, anchor = target.partition("#")
        linked = (path.parent / file_part).resolve() if file_part else path
        if not linked.exists():
            broken.append(f"{path.relative_to(ROOT)}: {target} (no such file)")
        elif anchor and linked.suffix == ".md" and anchor not in _anchors(linked):
            broken.append(f"{path.relative_to(ROOT)}: {target} (no such heading)")
    return broken


@pytest.mark.smoke
def test_the_readme_is_a_front_door_of_at_most_350_lines():
    lines = (ROOT / "README.md").read_text(encoding="utf-8").splitlines()
    assert len(lines) <= README_MAX_LINES, len(lines)


@pytest.mark.smoke
def test_every_relative_link_of_the_readme_and_the_docs_pages_resolves():
    """Every relative link of the README, docs/results.md and the other docs pages names a file
    or folder that exists, and a heading of it where it names one."""
    broken = [link for path in _documents() for link in _broken_links(path)]
    assert not broken, "\n".join(broken)


def test_the_readme_gives_no_measured_number():
    """The README's prose gives no time, rate, distance or size: those are measurements, and
    they live in docs/results.md, written from the records (the code blocks may print some)."""
    prose = _without_code((ROOT / "README.md").read_text(encoding="utf-8"))
    measured = re.findall(r"\b\d[\d,.]*\s?(?:s|ms|us|min|minutes|hours|mm|GB|MB|x|%|"
                          r"steps/s|runs/min)\b", prose)
    assert not measured, measured


def test_the_results_page_is_what_the_records_give():
    """``python -m eval results --check`` passes on the committed docs/results.md: every
    measured number there is the one its record (or docs/measurements.yaml) gives."""
    from eval.__main__ import main

    printed = io.StringIO()
    with contextlib.redirect_stdout(printed):
        main(["results", "--check"])
    assert "is current" in printed.getvalue()


def test_the_tour_builds_an_env_and_runs_a_shipped_agent():
    """The tour's env block makes and steps an env; its agent block runs a shipped agent through
    an episode, tracking its path."""
    blocks = _python_blocks(ROOT / "README.md")
    (env_block,) = [block for block in blocks if "scenario=" in block]
    namespace = _run_block(env_block, "README.md")
    assert namespace["obs"].shape == namespace["env"].observation_space.shape
    namespace["env"].close()
    (agent_block,) = [block for block in blocks if "make_policy(\"sb3:" in block]
    namespace = _run_block(agent_block, "README.md")
    assert namespace["truncated"] or namespace["terminated"]
    assert namespace["info"]["error_mm"] < 10.0, namespace["info"]["error_mm"]
    namespace["env"].close()


def test_the_tour_makes_an_env_on_an_exported_arm_file(tmp_path, monkeypatch):
    """The tour's own arm: the export command writes the arm file the env block then loads."""
    from soft_gym.__main__ import main as soft_gym_main

    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    (command,) = re.findall(r"^python -m soft_gym (preset export .+)$", readme, flags=re.M)
    monkeypatch.chdir(tmp_path)
    with contextlib.redirect_stdout(io.StringIO()):
        soft_gym_main(command.split())
    (block,) = [block for block in _python_blocks(ROOT / "README.md") if "my_arm.yaml" in block]
    namespace = _run_block(block, "README.md")
    assert namespace["env"].unwrapped.arm.name == "wang2023"
    namespace["env"].close()
