"""soft_gym/identify/log.py: a CSV log read into an ArmLog, and every bad log refused with one
ValueError naming the column or the row."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from soft_gym.identify.log import ArmLog, check_log, read_log, write_log
from soft_gym.robots.presets import get_preset

pytestmark = pytest.mark.smoke

SPEC = get_preset("wang2023")
HEADER = "t,p0,p1,p2,x,y,z"


def _rows(n: int = 5) -> list[list[float]]:
    return [[0.05 * i, 1000.0 * i, 0.0, 500.0, 0.001 * i, 0.0, 0.09] for i in range(n)]


def _write(tmp_path: Path, rows: list[list], header: str = HEADER) -> Path:
    path = tmp_path / "log.csv"
    lines = [header, *(",".join(str(value) for value in row) for row in rows)]
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


def test_a_good_log_is_read_with_its_columns_in_chamber_order(tmp_path):
    path = _write(tmp_path, [[r[4], r[2], r[0], r[3], r[1], r[5], r[6], "note"] for r in _rows()],
                  header="x,p1,t,p2,p0,y,z,comment")
    log = read_log(path, SPEC)
    expected = np.array(_rows())
    np.testing.assert_array_equal(log.times_s, expected[:, 0])
    np.testing.assert_array_equal(log.commands_pa, expected[:, 1:4])
    np.testing.assert_array_equal(log.tip_positions_m, expected[:, 4:7])
    assert log.tip_quaternions is None and log.n_samples == 5


def test_write_log_reads_back_exactly_with_quaternions(tmp_path):
    rows = np.array(_rows())
    quaternions = np.tile([0.0, 0.0, 0.0, 1.0], (5, 1))
    log = ArmLog(rows[:, 0] / 3.0, rows[:, 1:4], rows[:, 4:7] / 7.0, quaternions)
    back = read_log(write_log(tmp_path / "log.csv", log), SPEC)
    for name in ("times_s", "commands_pa", "tip_positions_m", "tip_quaternions"):
        np.testing.assert_array_equal(getattr(back, name), getattr(log, name))


@pytest.mark.parametrize("header, names", [
    ("t,p0,p1,p2,x,y", "z"),
    ("p0,p1,p2,x,y,z", "t"),
    ("t,p0,p2,x,y,z", "p1 .*arm 'wang2023' has 3 chambers"),
    ("t,p0,p1,x,y,z", "p2 .*arm 'wang2023' has 3 chambers"),
    ("t,p0,p1,p2,x,y,z,qx,qy,qz", "qw"),
])
def test_a_missing_column_is_named(tmp_path, header, names):
    columns = header.split(",")
    full = HEADER.split(",") + ["qx", "qy", "qz", "qw"]
    rows = [[row[full.index(c)] if c in full[:7] else 0.0 for c in columns] for row in _rows()]
    with pytest.raises(ValueError, match=f"missing column.*{names}"):
        read_log(_write(tmp_path, rows, ",".join(columns)), SPEC)


def test_a_chamber_count_that_does_not_match_the_arm_is_refused(tmp_path):
    rows = [[*row[:4], 0.0, 0.0, 0.0, *row[4:]] for row in _rows()]
    path = _write(tmp_path, rows, "t,p0,p1,p2,p3,p4,p5,x,y,z")
    with pytest.raises(ValueError, match=r"6 command columns \(p0, p1, p2, p3, p4, p5\), but arm "
                                         r"'wang2023' has 3 chambers"):
        read_log(path, SPEC)


@pytest.mark.parametrize("where, value, message", [
    (0, 0.05, r"column t at row 3: .* repeats the row before"),
    (0, 0.01, r"column t at row 3: .* goes back from the row before"),
    (5, "nan", r"column y at row 3: 'nan' is not a finite number"),
    (1, "", r"column p0 at row 3: '' is not a number"),
    (4, 2.0, r"columns x, y, z at row 3: .*looks like millimetres"),
    (2, 125001.0, r"column p1 at row 3: command 125001.0 Pa is outside \[0, 125000\] Pa"),
    (3, -1.0, r"column p2 at row 3: command -1.0 Pa is outside"),
])
def test_a_bad_value_names_its_column_and_row(tmp_path, where, value, message):
    rows = _rows()
    rows[2][where] = value
    with pytest.raises(ValueError, match=message):
        read_log(_write(tmp_path, rows), SPEC)


def test_a_log_in_millimetres_is_refused(tmp_path):
    rows = [[*row[:4], row[4] * 1e3, row[5] * 1e3, row[6] * 1e3] for row in _rows()]
    with pytest.raises(ValueError, match="row 1: the tip is 90 m from the base.*millimetres"):
        read_log(_write(tmp_path, rows), SPEC)


def test_a_short_ragged_or_empty_log_is_refused(tmp_path):
    with pytest.raises(ValueError, match="2 samples, at least 3"):
        read_log(_write(tmp_path, _rows(2)), SPEC)
    rows = _rows()
    rows[1] = rows[1][:-1]
    with pytest.raises(ValueError, match="row 2 has 6 cells, the header 7"):
        read_log(_write(tmp_path, rows), SPEC)
    empty = tmp_path / "empty.csv"
    empty.write_text("\n", encoding="utf-8")
    with pytest.raises(ValueError, match="is empty"):
        read_log(empty, SPEC)
    with pytest.raises(ValueError, match="cannot be read"):
        read_log(tmp_path / "absent.csv", SPEC)
    duplicated = _write(tmp_path, [[*row, row[1]] for row in _rows()], HEADER + ",p0")
    with pytest.raises(ValueError, match="column 'p0' appears more than once"):
        read_log(duplicated, SPEC)


@pytest.mark.parametrize("array, what", [(0, "t"), (1, "command"), (2, "tip position")])
def test_check_log_names_the_row_of_a_nan(array, what):
    rows = np.array(_rows())
    arrays = [rows[:, 0].copy(), rows[:, 1:4].copy(), rows[:, 4:7].copy()]
    arrays[array].reshape(5, -1)[3, 0] = np.nan
    with pytest.raises(ValueError, match=f"run.csv: row 4 holds a {what} that is not a finite"):
        check_log(*arrays, None, SPEC, source="run.csv")
