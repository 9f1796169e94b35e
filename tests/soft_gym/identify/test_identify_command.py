"""``python -m soft_gym identify``: the fitted arm file, its report and plot, and every bad
option refused in one line naming it, exit status 2, before any work and with nothing written."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml

from cli_errors import assert_one_line_error
from soft_gym.__main__ import main
from soft_gym.identify.log import write_log
from soft_gym.identify.parameters import parse_parameters, with_values
from soft_gym.identify.report import file_sha256
from soft_gym.identify.synthetic import random_commands, simulated_log
from soft_gym.robots import load_preset, save_preset
from soft_gym.robots.presets import get_preset, volume_actuated

ROOT = Path(__file__).resolve().parents[3]
BASE = get_preset("wang2023")
PARAMS = ["youngs_modulus_pa", "pneumatic_time_constant_s"]


@pytest.fixture(scope="module")
def log_file(tmp_path_factory) -> Path:
    """A 10 s log of wang2023 with E +20 % and the time constant -15 %."""
    parameters = parse_parameters(PARAMS, BASE)
    truth = with_values(BASE, parameters, [1.2 * 90e3, 0.85 * 0.12])
    rng = np.random.default_rng(3)
    times, commands = random_commands(BASE, 10.0, 0.5, rng)
    path = tmp_path_factory.mktemp("identify") / "run.csv"
    return write_log(path, simulated_log(truth, times, commands, 0.5e-3, rng))


def _outputs(out: Path) -> list[Path]:
    return [out, out.with_name(out.stem + ".identify.yaml"),
            out.with_name(out.stem + ".identify.png")]


def test_identify_writes_the_fitted_arm_its_report_and_plot(log_file, tmp_path, capsys):
    out = tmp_path / "my_arm.yaml"
    main(["identify", "--preset", "wang2023", "--data", str(log_file), "--out", str(out),
          "--params", *PARAMS])
    fitted = load_preset(out)
    report = yaml.safe_load(_outputs(out)[1].read_text(encoding="utf-8"))
    assert fitted.name == "my_arm" and report["arm"] == "my_arm"
    values = report["parameters"]
    assert fitted.segments[0].youngs_modulus_pa == values["youngs_modulus_pa[0]"]["value"]
    assert fitted.pneumatic_time_constant_s == values["pneumatic_time_constant_s"]["value"]
    assert values["youngs_modulus_pa[0]"]["value"] == pytest.approx(108e3, rel=0.05)
    assert all(entry["identifiable"] for entry in values.values())
    assert report["log"]["sha256"] == file_sha256(log_file)
    assert report["rms_tip_error_mm"]["held_out"] < 1.0
    assert _outputs(out)[2].read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert "held out" in capsys.readouterr().out
    main(["identify", "--preset", str(out), "--data", str(log_file), "--out", str(out),
          "--params", "damping_ratio", "--name", "renamed", "--force"])
    assert load_preset(out).name == "renamed"


def test_bad_options_are_one_line_before_any_work(log_file, tmp_path, capsys):
    out = tmp_path / "arm.yaml"
    run = ["identify", "--preset", "wang2023", "--data", str(log_file), "--out", str(out)]
    assert_one_line_error(main, [*run[:2], "wang2024", *run[3:]], "--preset", capsys, out=out)
    assert_one_line_error(main, [*run[:4], str(tmp_path / "none.csv"), *run[5:]], "--data",
                          capsys, out=out, also="does not exist")
    bad = tmp_path / "bad.csv"
    bad.write_text("t,p0,p1,p2,x,y\n0,0,0,0,0,0\n", encoding="utf-8")
    assert_one_line_error(main, [*run[:4], str(bad), *run[5:]], "--data", capsys, out=out,
                          also="missing column z")
    short = tmp_path / "short.csv"
    short.write_text("t,p0,p1,p2,x,y,z\n" + "".join(f"{i},0,0,0,0,0,0.09\n" for i in range(5)),
                     encoding="utf-8")
    assert_one_line_error(main, [*run[:4], str(short), *run[5:]], "--data", capsys, out=out,
                          also="5 samples: too few")
    assert_one_line_error(main, [*run, "--params", "stiffness"], "--params", capsys, out=out,
                          also="'stiffness'")
    assert_one_line_error(main, [*run, "--engine", "bullet"], "--engine", capsys, out=out)
    assert_one_line_error(main, [*run[:-1], str(tmp_path / "arm.txt")], "--out", capsys,
                          also=".yaml")
    assert_one_line_error(main, [*run[:-1], str(tmp_path / "no" / "arm.yaml")], "--out", capsys,
                          also="does not exist")
    report = _outputs(out)[1]
    report.write_text("keep", encoding="utf-8")
    assert_one_line_error(main, run, "--out", capsys, out=out, also="--force")
    assert report.read_text(encoding="utf-8") == "keep"
    assert sorted(path.name for path in tmp_path.iterdir()) == ["arm.identify.yaml", "bad.csv",
                                                                 "short.csv"]


def test_a_volume_driven_arm_is_refused_before_any_work(log_file, tmp_path, capsys):
    """An arm file with cylinders drives volumes, which a pressure log cannot replay."""
    arm = tmp_path / "volume_arm.yaml"
    save_preset(volume_actuated(get_preset("ho2018")), arm)
    out = tmp_path / "fitted.yaml"
    assert_one_line_error(main, ["identify", "--preset", str(arm), "--data", str(log_file),
                                 "--out", str(out)], "--preset", capsys, out=out,
                          also="cylinders")


def test_python_m_soft_gym_identify_shows_progress_when_piped(log_file, tmp_path):
    out = tmp_path / "arm.yaml"
    result = subprocess.run([sys.executable, "-m", "soft_gym", "identify", "--preset",
                             "wang2023", "--data", str(log_file), "--out", str(out),
                             "--params", "pneumatic_time_constant_s"],
                            cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stderr
    assert "identify: simulations" in result.stderr
    report = yaml.safe_load(_outputs(out)[1].read_text(encoding="utf-8"))
    fitted = report["parameters"]["pneumatic_time_constant_s"]["value"]
    assert load_preset(out).pneumatic_time_constant_s == fitted != 0.12


def test_help_explains_identify(capsys):
    with pytest.raises(SystemExit) as exit_info:
        main(["identify", "--help"])
    assert exit_info.value.code == 0
    text = capsys.readouterr().out
    for part in ("--preset", "--data", "--out", "--params", "--engine", "youngs_modulus_pa",
                 "identify.yaml", "mujoco"):
        assert part in text, part
