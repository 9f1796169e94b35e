"""The modal length-to-pressure map (agents/controllers/modal_map.py) and the CC model controllers
on the extensible zou2022 arm.

References: eq. (27) itself (the modal map with one gain for extension and bending is eq. (27)
with that gain in every chamber), the exact inverse the anti-windup relies on, and the wang2023
finding reproduced on zou2022 in closed loop: the model controller follows the path, and the
GPR-compensated one follows it better (wang2023 Section IV-B); with eq. (27)'s rest-probed gains
neither does.
"""

from __future__ import annotations

import json

import gymnasium as gym
import numpy as np
import pytest

import soft_gym  # noqa: F401
from agents.controllers.cc_model import CCModelController
from agents.controllers.modal_map import ModalLengthMap
from agents.policies import make_policy
from agents.rollout import run_episode

SCHEDULED = ModalLengthMap(mean_lengths_m=np.array([0.077, 0.16, 0.20, 0.23]),
                           common_pressures_pa=np.array([0.0, 75e3, 150e3, 225e3]),
                           bending_gains_pa_m=np.array([12e6, 13e6, 13.5e6, 14e6]))


@pytest.mark.smoke
def test_one_gain_for_extension_and_bending_is_eq_27():
    alpha, rest, p_pre = 2.0e6, 0.077, 40e3  # Pa/m, m, Pa
    modal = ModalLengthMap(np.array([rest, rest + 0.05]), np.array([p_pre, p_pre + alpha * 0.05]),
                           np.array([alpha, alpha]))
    rng = np.random.default_rng(0)
    for _ in range(20):
        lengths = rest + rng.uniform(-0.01, 0.08, 3)  # inside, below and beyond the levels
        np.testing.assert_allclose(modal.pressures(lengths), p_pre + alpha * (lengths - rest),
                                   rtol=1e-12)


def test_the_map_inverts_exactly_and_its_mean_pressure_is_the_common_one():
    rng = np.random.default_rng(1)
    for _ in range(50):
        lengths = rng.uniform(0.07, 0.26, 3)
        pressures = SCHEDULED.pressures(lengths)
        np.testing.assert_allclose(SCHEDULED.lengths(pressures), lengths, atol=1e-12)
        mean = lengths.mean()
        if SCHEDULED.mean_lengths_m[0] <= mean <= SCHEDULED.mean_lengths_m[-1]:
            assert pressures.mean() == pytest.approx(np.interp(
                mean, SCHEDULED.mean_lengths_m, SCHEDULED.common_pressures_pa))
    # a pure bend about a level: differential pressure = bending gain x differential length
    bend = np.array([2e-3, -1e-3, -1e-3])
    np.testing.assert_allclose(SCHEDULED.pressures(0.16 + bend) - 75e3, 13e6 * bend)


@pytest.mark.parametrize("fields, name", [
    ({"mean_lengths_m": [0.2, 0.1]}, "mean_lengths_m"),
    ({"common_pressures_pa": [0.0, 0.0]}, "common_pressures_pa"),
    ({"bending_gains_pa_m": [1e6, -1.0]}, "bending_gains_pa_m"),
    ({"bending_gains_pa_m": [1e6, float("nan")]}, "bending_gains_pa_m"),
    ({"mean_lengths_m": [0.1]}, "mean_lengths_m"),
])
def test_a_bad_map_is_refused_by_name(fields, name):
    data = {"mean_lengths_m": [0.1, 0.2], "common_pressures_pa": [0.0, 1e5],
            "bending_gains_pa_m": [1e6, 2e6], **fields}
    with pytest.raises(ValueError, match=name):
        ModalLengthMap.from_dict(data)


def test_from_dict_refuses_other_objects():
    for bad in (None, [], {"mean_lengths_m": [0.1, 0.2]},
                {**SCHEDULED.to_dict(), "extra": 1},
                {**SCHEDULED.to_dict(), "bending_gains_pa_m": "fast"}):
        with pytest.raises(ValueError, match="modal length map|must be a list"):
            ModalLengthMap.from_dict(bad)
    again = ModalLengthMap.from_dict(SCHEDULED.to_dict())
    for name in ("mean_lengths_m", "common_pressures_pa", "bending_gains_pa_m"):
        np.testing.assert_array_equal(getattr(again, name), getattr(SCHEDULED, name))


def _env(preset: str = "zou2022", **kwargs):
    return gym.make("SoftArmTrack-v0", preset=preset, path="circle", cycles=2,
                    feedback="ground_truth", **kwargs)


def test_the_default_map_is_modal_on_zou2022_only_and_bad_choices_are_named():
    for preset, expected in (("zou2022", "modal"), ("wang2023", "chamber"),
                             ("ho2018", "chamber"), ("zhao2021", "chamber")):
        env = _env(preset)
        assert make_policy("cc_model", env=env).length_map == expected
        assert make_policy("hybrid_gpr", env=env).length_map == expected
        env.close()
    env = _env("ho2018")
    with pytest.raises(ValueError, match="length_map 'modal' is for one-segment arms"):
        CCModelController(env, length_map="modal")
    for bad in ("linear", 1, ""):
        with pytest.raises(ValueError, match="length_map must be one of"):
            CCModelController(env, length_map=bad)
    env.close()


@pytest.fixture(scope="module")
def zou_probes():
    """The zou2022 arm probed both ways (ground truth, 20 control steps per hold)."""
    env = _env()
    modal = CCModelController(env, probe_steps=20)
    modal.calibrate(seed=0)
    chamber = CCModelController(env, probe_steps=20, length_map="chamber")
    chamber.calibrate(seed=0)
    yield modal, chamber
    env.close()


def test_zou2022_is_many_times_stiffer_in_bending_than_eq_27_probes_at_rest(zou_probes):
    modal, chamber = zou_probes
    table = modal.modal_map
    # the levels extend the 77 mm muscles steadily (3 bar would take them towards 250 mm)
    assert table.mean_lengths_m[0] == pytest.approx(0.077, abs=2e-4)
    assert np.all(np.diff(table.mean_lengths_m) > 0.02)
    assert table.mean_lengths_m[-1] > 0.2
    # eq. (27)'s rest probes mix extension into each chamber's gain: bending needs 5x more
    assert np.all(table.bending_gains_pa_m > 5.0 * chamber.alpha.max())
    np.testing.assert_array_equal(modal.alpha, np.full(3, table.bending_gains_pa_m[0]))


def test_a_modal_controller_saves_and_loads_back_identically(zou_probes, tmp_path):
    modal, _ = zou_probes
    modal.save(tmp_path / "modal.json")
    loaded = CCModelController.load(tmp_path / "modal.json", env=modal.env)
    assert loaded.length_map == "modal"
    np.testing.assert_array_equal(loaded.modal_map.bending_gains_pa_m,
                                  modal.modal_map.bending_gains_pa_m)
    observation = modal.env.observation_space.sample()
    modal.reset(), loaded.reset()
    np.testing.assert_array_equal(loaded.predict(observation)[0], modal.predict(observation)[0])


def test_a_modal_file_without_its_map_is_refused_by_name(zou_probes, tmp_path):
    modal, _ = zou_probes
    path = tmp_path / "broken.json"
    modal.save(path)
    data = json.loads(path.read_text())
    data["modal_map"] = None  # the gains without the map they belong to
    path.write_text(json.dumps(data))
    with pytest.raises(ValueError, match="broken.json.*modal_map must be given"):
        CCModelController.load(path, env=modal.env)


def _last_cycle_error_mm(name: str, length_map: str, kp: float) -> float:
    env = _env(speed_m_s=0.0225)  # twice the default speed: two ~10 s cycles
    policy = make_policy(name, env=env, kp=kp, probe_steps=20, length_map=length_map)
    policy.calibrate(seed=0)
    record = run_episode(env, policy, seed=0)
    env.close()
    last = record["cycle"] == record["cycle"].max()
    return float(np.mean(np.linalg.norm(record["tip_m"] - record["target_m"], axis=1)[last])
                 * 1000.0)


def test_on_zou2022_the_modal_map_tracks_and_the_gpr_compensator_tracks_better():
    chamber = _last_cycle_error_mm("cc_model", "chamber", 0.12)
    modal = _last_cycle_error_mm("cc_model", "modal", 0.12)
    hybrid = _last_cycle_error_mm("hybrid_gpr", "modal", 0.06)
    # measured: 24.1, 6.9 and 1.7 mm (the circle is 71 mm across)
    assert modal < 0.5 * chamber, (modal, chamber)
    assert modal < 10.0
    assert hybrid < 0.5 * modal, (hybrid, modal)
