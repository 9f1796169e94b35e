"""Soaks at the issue's size (``bench/soak.py``): hours on one core, so ``-m slow`` only.

* 10^6 random-action steps per preset with randomised loads, noise, stiffness and lag: no
  exception, no non-finite value, every observation inside its space, every tip within reach,
  resident memory growing less than 5 %;
* 1,000 create/close cycles of a camera env: file descriptors and PyBullet clients all returned,
  memory growth under 50 kB per cycle after warm-up;
* 20,000 fused-env steps under each wang2023 fault schedule: as the first, and a bounded
  tracking error.
"""

from __future__ import annotations

import importlib.util
from pathlib import Path

import pytest

from soft_gym.robots.presets import PRESETS

ROOT = Path(__file__).resolve().parents[2]
_spec = importlib.util.spec_from_file_location("bench_soak", ROOT / "bench" / "soak.py")
soak = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(soak)

pytestmark = pytest.mark.slow


def _assert_clean(row: dict) -> None:
    for kind in ("exceptions", "non_finite", "outside_space", "beyond_reach"):
        assert row[kind] == 0, f"{kind}: {row[kind]} (first: {row['first'].get(kind)})"
    assert row["rss_growth_pct"] < 5.0, row


@pytest.mark.parametrize("preset", PRESETS)
def test_a_million_random_steps_stay_physical(preset):
    _assert_clean(soak.random_action_soak(preset, steps=1_000_000, progress=False))


def test_a_thousand_create_close_cycles_return_their_resources():
    row = soak.create_close_cycles(1000, progress=False)
    assert row["after"]["fds"] <= row["before"]["fds"], row
    assert row["after"]["clients"] == row["before"]["clients"], row
    assert row["rss_growth_mb_per_cycle"] < 0.05, row


@pytest.mark.parametrize("schedule", soak.SCHEDULES)
def test_the_fused_env_soaks_under_the_wang2023_fault_schedules(schedule):
    row = soak.fused_soak(schedule, steps=20_000, progress=False)
    _assert_clean(row)
    assert row["mean_error_mm"] < 20.0, row
