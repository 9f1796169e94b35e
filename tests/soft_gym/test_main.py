"""``python -m soft_gym`` (soft_gym/__main__.py): ``preset export`` writes a preset's arm file,
and refuses a bad NAME or FILE in one line naming it, exit status 2, before writing anything."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from cli_errors import assert_one_line_error
from soft_gym.__main__ import main
from soft_gym.robots import PRESETS, load_preset

pytestmark = pytest.mark.smoke

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.parametrize("name", sorted(PRESETS))
def test_preset_export_writes_the_presets_arm_file(name, tmp_path, capsys):
    out = tmp_path / f"{name}.yaml"
    main(["preset", "export", name, str(out)])
    assert load_preset(out) == PRESETS[name]
    assert capsys.readouterr().out == f"wrote preset {name} to {out}\n"


def test_force_replaces_an_existing_file(tmp_path):
    out = tmp_path / "arm.yaml"
    out.write_text("old", encoding="utf-8")
    main(["preset", "export", "ho2018", str(out), "--force"])
    assert load_preset(out) == PRESETS["ho2018"]


def test_help_explains_the_export(capsys):
    with pytest.raises(SystemExit) as exit_info:
        main(["preset", "export", "--help"])
    assert exit_info.value.code == 0
    text = capsys.readouterr().out
    for part in ("NAME", "FILE", "--force", "preset=", ".yaml", *sorted(PRESETS)):
        assert part in text, part
    with pytest.raises(SystemExit):
        main(["--help"])
    assert "preset export NAME FILE" in capsys.readouterr().out


def test_a_bad_name_or_file_is_one_line_before_any_work(tmp_path, capsys):
    out = tmp_path / "arm.yaml"
    line = assert_one_line_error(main, ["preset", "export", "wang2024", str(out)], "NAME", capsys,
                                 out=out, also="'wang2024'")
    assert str(sorted(PRESETS)) in line
    missing = tmp_path / "no_such_dir" / "arm.yaml"
    assert_one_line_error(main, ["preset", "export", "wang2023", str(missing)], "FILE", capsys,
                          out=missing, also="does not exist")
    a_file = tmp_path / "plain"
    a_file.write_text("", encoding="utf-8")
    assert_one_line_error(main, ["preset", "export", "wang2023", str(a_file / "arm.yaml")],
                          "FILE", capsys, also="is not a directory")
    assert_one_line_error(main, ["preset", "export", "wang2023", str(tmp_path)], "FILE", capsys,
                          also="is a directory")
    out.write_text("keep", encoding="utf-8")
    assert_one_line_error(main, ["preset", "export", "wang2023", str(out)], "FILE", capsys,
                          also="--force")
    assert out.read_text(encoding="utf-8") == "keep"
    assert_one_line_error(main, ["preset"], "ACTION", capsys)
    assert_one_line_error(main, [], "COMMAND", capsys)


def test_python_m_soft_gym_runs(tmp_path):
    out = tmp_path / "arm.yml"
    result = subprocess.run([sys.executable, "-m", "soft_gym", "preset", "export", "zou2022",
                             str(out)], cwd=ROOT, capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, result.stderr
    assert load_preset(out) == PRESETS["zou2022"]
