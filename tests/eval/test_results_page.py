"""``python -m eval results`` (eval/results_page.py, eval/results_records.py,
eval/results_measurements.py): docs/results.md is read off the records, every number from the
record that holds it, and ``--check`` names the first stale line."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
import yaml

from agents.policies.sb3 import shipped_agents, training_budget, training_segments
from eval import results_page
from eval.__main__ import main
from eval.claims.report import summary_line
from eval.results_measurements import load_measurements
from eval.results_records import agents_section, claims_section, leaderboard_section
from eval.suite.report import budget_text

ROOT = Path(__file__).resolve().parents[2]

ENTRY = {"title": "a timing", "command": "python bench/env_speed.py", "machine": "2 idle cores",
         "revision": "2b31693", "text": "1073 env steps/s"}


def _rows(lines: list[str], first_cell: str) -> list[list[str]]:
    """The cells of the table rows of ``lines`` whose first cell is ``first_cell``."""
    return [[cell.strip() for cell in line.strip().strip("|").split("|")] for line in lines
            if line.startswith(f"| {first_cell} |")]


def test_each_shipped_agent_is_read_off_its_training_record():
    """Every shipped agent's budget is its training.yaml's (as the leaderboard writes it), and
    each segment's steps and minutes are that segment's."""
    lines = "\n".join(agents_section()).splitlines()
    for name in shipped_agents():
        (budget_row, *segment_rows) = _rows(lines, f"`{name}`")[:1 + len(
            training_segments(name))]
        assert budget_row[1] == budget_text(training_budget(name)), name
        for row, segment in zip(segment_rows, training_segments(name)):
            assert row[5] == f"{segment['timesteps']:,}", name
            assert row[6] == f"{segment['wall_s'] / 60:.0f}", name


def test_the_leaderboard_rows_are_the_suite_reports():
    """The best agent against the best baseline per arm and condition is what the suite's own
    report (docs/leaderboard/leaderboard.md) gives for the same runs."""
    report = (ROOT / "docs" / "leaderboard" / "leaderboard.md").read_text(encoding="utf-8")
    expected = re.findall(r"^\| (\w+) \| [\w ]+ \| (\w+) \| ([\d.]+) \| (\w+) \| ([\d.]+) \| "
                          r"([\d.]+) \| (yes|no) \|$", report, flags=re.M)
    shown = []
    for line in "\n".join(leaderboard_section(ROOT)).splitlines():
        if re.match(r"^\| (wang2023|ho2018|zhao2021|zou2022) \|", line):
            cells = [cell.strip().replace("`", "") for cell in line.strip("|").split("|")]
            shown.append((cells[1], *cells[3].split(), *cells[4].split(), cells[5], cells[6]))
    assert shown == expected and len(shown) > 0


def test_the_claims_counts_are_the_ledgers():
    """The verdict line is the one docs/claims.md opens with, from the same record."""
    import json

    ledger = json.loads((ROOT / "docs" / "claims" / "claims.json").read_text(encoding="utf-8"))
    line = summary_line(ledger)
    assert f"**{line}**" in claims_section(ROOT)
    assert f"**{line}**" in (ROOT / "docs" / "claims.md").read_text(encoding="utf-8")


@pytest.mark.parametrize(("expected", "written", "stale"), [
    ("a\nb\n", "a\nb\n", None),
    ("a\nb\n", "a\nc\n", (2, "c", "b")),
    ("a\nb\n", "a\n", (2, "", "b")),
    ("a\n", "a\nb\n", (2, "b", "")),
    ("a\n", "a", (2, "", "")),
])
def test_the_first_stale_line_is_named(expected, written, stale):
    assert results_page.first_stale_line(expected, written) == stale


def test_check_names_the_first_stale_line_and_writing_makes_it_current(tmp_path, capsys):
    page = tmp_path / "results.md"
    main(["results", "--out", str(page)])
    assert page.read_text(encoding="utf-8") == results_page.render_page()
    main(["results", "--check", "--out", str(page)])
    assert "is current" in capsys.readouterr().out
    lines = page.read_text(encoding="utf-8").splitlines()
    lines[2] = "a line written by hand"
    page.write_text("\n".join(lines) + "\n", encoding="utf-8")
    with pytest.raises(SystemExit) as exit_info:
        main(["results", "--check", "--out", str(page)])
    assert exit_info.value.code == 1
    assert "is stale at line 3: it has 'a line written by hand'" in capsys.readouterr().err


def test_a_folder_for_the_page_is_refused_in_one_line(tmp_path, capsys):
    with pytest.raises(SystemExit) as exit_info:
        main(["results", "--out", str(tmp_path)])
    assert exit_info.value.code == 2
    assert "--out" in capsys.readouterr().err


def test_the_measurements_file_is_read_in_its_order():
    entries = load_measurements(ROOT / "docs" / "measurements.yaml")
    assert entries and all(entry.revision and entry.command for entry in entries)
    assert len({entry.title for entry in entries}) == len(entries)


@pytest.mark.parametrize(("entry", "message"), [
    ({**ENTRY, "notes": "x"}, r"entry 0 has keys .*allowed and required are title, command"),
    ({key: value for key, value in ENTRY.items() if key != "revision"},
     r"entry 0 has keys .*revision"),
    ({**ENTRY, "revision": "HEAD"}, r"entry 0 \('a timing'\): revision must be a git commit"),
    ({**ENTRY, "text": ""}, r"entry 0 \('a timing'\): text must be a non-empty string"),
    ({**ENTRY, "command": "`python`"}, r"command must not hold a backquote"),
    ("a string", r"entry 0 must be a mapping"),
])
def test_a_bad_measurement_entry_is_one_value_error_naming_it(tmp_path, entry, message):
    path = tmp_path / "measurements.yaml"
    path.write_text(yaml.safe_dump([entry]), encoding="utf-8")
    with pytest.raises(ValueError, match=message):
        load_measurements(path)


def test_a_measurements_file_that_is_not_a_list_is_refused(tmp_path):
    path = tmp_path / "measurements.yaml"
    path.write_text("title: a timing\n", encoding="utf-8")
    with pytest.raises(ValueError, match="must hold a non-empty list of entries"):
        load_measurements(path)
