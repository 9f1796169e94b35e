"""A tiny benchmark suite spec shared by the suite tests: two quick wang2023 runs per seed (a
26-step circle, one cycle, nominal and with a 10 g tip) and one n/a per seed (the shipped
wang2023 agent refuses ho2018's six chambers)."""

from __future__ import annotations

from pathlib import Path

import pytest

_ARMS = """\
cycles: 1
arms:
  wang2023:
    paths: [circle]
    feedback: ground_truth
    env: {speed_m_s: 0.05}
    conditions:
      nominal: {}
      load_10g: {scenario: {name: tip_mass, mass_kg: 0.01}}
    policies:
      - {name: cc_model, params: {probe_steps: 5}}
  ho2018:
    paths: [rectangle]
    feedback: ground_truth
    env: {speed_m_s: 0.05}
    conditions:
      nominal: {}
    policies: ["sb3:sac_wang2023_track"]
"""


def tiny_suite(name: str = "tiny", seeds: tuple[int, ...] = (0,)) -> str:
    """The spec's YAML text with this ``name`` and these ``seeds``."""
    return f"name: {name}\nseeds: {list(seeds)}\n" + _ARMS


def counting_backend(ran: list[str]):
    """A serial suite backend that appends every key it runs to ``ran``."""
    def map_function(fn, items, workers):
        for item in items:
            ran.append(item["key"])
            yield fn(item)
    return map_function


def assert_suite_cli_error(argv: list[str], option: str, tmp_path: Path, capsys) -> None:
    """``python -m eval suite small`` with ``argv`` exits 2 with one line naming ``option``,
    before writing anything."""
    import eval.__main__ as eval_main

    with pytest.raises(SystemExit) as exit_info:
        eval_main.main(["suite", "small", "--out", str(tmp_path / "o")] + argv)
    assert exit_info.value.code == 2
    error = capsys.readouterr().err.strip().splitlines()[-1]
    assert error.startswith("python -m eval suite: error:") and option in error
    assert not (tmp_path / "o").exists()
