"""Arm files (soft_gym/robots/arm_file.py; docs/architecture.md, "Your own arm"): every preset
round-trips through YAML bit for bit, an env built from the file is the env built from the name,
and a bad file is one ValueError naming the file, the field and what is allowed."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
import yaml

import soft_gym  # noqa: F401 - registers the env ids
from soft_gym.envs.soft_arm_env import SoftArmEnv
from soft_gym.robots import PRESETS, load_preset, save_preset
from soft_gym.robots.arm_file import ARM_FILE_FORMAT, arm_from_preset, is_arm_file
from soft_gym.robots.presets import CYLINDERS, volume_actuated
from soft_gym.robots.spec import ArmSpec

pytestmark = pytest.mark.smoke


def _assert_identical(loaded: ArmSpec, spec: ArmSpec) -> None:
    """Equal as specs, and every value of the same type and bits (notes, which the spec's
    equality leaves out, included)."""
    assert loaded == spec
    assert loaded.notes == spec.notes
    assert repr(loaded) == repr(spec)
    assert type(loaded.segments) is tuple
    pairs = [(loaded, spec), *zip(loaded.segments, spec.segments)]
    if spec.cylinders is not None:
        pairs.append((loaded.cylinders, spec.cylinders))
    for a, b in pairs:
        for field in dataclasses.fields(b):
            x, y = getattr(a, field.name), getattr(b, field.name)
            if field.name == "segments" or field.name == "cylinders":
                continue
            assert type(x) is type(y), (field.name, x, y)
            if isinstance(y, float):
                assert np.float64(x).tobytes() == np.float64(y).tobytes(), (field.name, x, y)


# ------------------------------------------------------------------------------- round trip
@pytest.mark.parametrize("name", sorted(PRESETS))
def test_every_preset_round_trips_through_a_file_bit_for_bit(name, tmp_path):
    path = save_preset(name, tmp_path / f"{name}.yaml")
    assert path == tmp_path / f"{name}.yaml"
    loaded = load_preset(path)
    _assert_identical(loaded, PRESETS[name])
    # written again, the file is the same text
    again = save_preset(loaded, tmp_path / "again.yaml")
    assert again.read_text(encoding="utf-8") == path.read_text(encoding="utf-8")
    document = yaml.safe_load(path.read_text(encoding="utf-8"))
    assert document["format"] == ARM_FILE_FORMAT
    assert len(document["segments"]) == PRESETS[name].n_segments


@pytest.mark.parametrize("name", sorted(CYLINDERS))
def test_a_volume_actuated_arm_round_trips_with_its_cylinders(name, tmp_path):
    spec = volume_actuated(PRESETS[name])
    loaded = load_preset(save_preset(spec, tmp_path / "arm.yml"))
    _assert_identical(loaded, spec)
    assert loaded.actuation == "volume"


def test_floats_numpy_values_and_text_survive_exactly(tmp_path):
    """Floats that the shortest decimal text only just holds, numpy scalars (written as plain
    numbers), and a description with quotes, a colon, a newline and non-ASCII text."""
    base = PRESETS["wang2023"]
    segment = dataclasses.replace(
        base.segments[0], length_m=0.1 + 0.2, youngs_modulus_pa=np.float64(9.0e4) * (1 + 2**-52),
        density_kg_m3=1e17 / 1e14, extra_tip_mass_kg=5e-324, p_pre_pa=np.float64(1.0 / 3.0),
        n_links=np.int64(5), torsion=np.bool_(True), braid_twist_m=-1e-3,
        axial_modulus_pa=1e-5 * 3e9, thread_length_m=math.nextafter(0.4, 1.0))
    spec = dataclasses.replace(
        base, name="tricky", segments=(segment, base.segments[0]),
        description="Ø 20 mm: 'quoted' \"twice\"\nsecond line # not a comment",
        notes={"a": "b: c", "ü": "- not a list"})
    loaded = load_preset(save_preset(spec, tmp_path / "tricky.yaml"))
    assert loaded == spec and loaded.notes == spec.notes
    first = loaded.segments[0]  # numpy's scalars come back as Python's
    assert type(first.n_links) is int and type(first.torsion) is bool
    assert type(first.youngs_modulus_pa) is float
    for name in ("length_m", "youngs_modulus_pa", "density_kg_m3", "extra_tip_mass_kg",
                 "p_pre_pa", "axial_modulus_pa", "thread_length_m", "braid_twist_m"):
        assert float(getattr(first, name)).hex() == float(getattr(segment, name)).hex(), name


def test_exponent_numbers_are_numbers_and_an_integer_is_taken_for_a_float(tmp_path):
    """``1.5e5`` and ``2e-2`` are numbers (YAML 1.1 would read them as strings), an integer is
    taken for a float."""
    text = save_preset("wang2023", tmp_path / "wang.yaml").read_text(encoding="utf-8")
    path = tmp_path / "mine.yaml"
    path.write_text(text.replace("name: wang2023", "name: mine")
                    .replace("  p_max_pa: 125000.0", "  p_max_pa: 1.5e5")
                    .replace("  outer_radius_m: 0.01", "  outer_radius_m: 1e-2")
                    .replace("  youngs_modulus_pa: 90000.0", "  youngs_modulus_pa: 90000"),
                    encoding="utf-8")
    spec = load_preset(path)
    segment = dataclasses.replace(PRESETS["wang2023"].segments[0], p_max_pa=150000.0)
    assert spec == dataclasses.replace(PRESETS["wang2023"], name="mine", segments=(segment,))
    assert type(spec.segments[0].youngs_modulus_pa) is float


# ------------------------------------------------------------------------------- the env
@pytest.mark.parametrize("name", ["wang2023", "ho2018"])
def test_the_env_from_a_file_steps_as_the_env_from_the_name(name, tmp_path):
    """gym.make with the file's path (str) and SoftArmEnv with a Path give the named preset's
    observations and tip positions exactly, on the default engine."""
    path = save_preset(name, tmp_path / f"{name}.yaml")
    actions = np.random.default_rng(3).uniform(-1.0, 1.0, (4, PRESETS[name].n_chambers))
    runs = []
    for make in (lambda: gym.make("SoftArmReach-v0", preset=name, feedback="ground_truth"),
                 lambda: gym.make("SoftArmReach-v0", preset=str(path), feedback="ground_truth"),
                 lambda: SoftArmEnv(preset=path, feedback="ground_truth")):
        env = make()
        assert env.unwrapped.arm == PRESETS[name]
        obs, _ = env.reset(seed=7)
        record = [obs, env.unwrapped.sim.tip_pose()[0]]
        for action in actions:
            obs, *_ = env.step(action.astype(np.float32))
            record += [obs, env.unwrapped.sim.tip_pose()[0]]
        env.close()
        runs.append(record)
    for other in runs[1:]:
        for a, b in zip(runs[0], other):
            np.testing.assert_array_equal(a, b)


# ------------------------------------------------------------------------------- name or file
@pytest.mark.parametrize("value, is_file", [
    ("wang2023", False), ("my_arm", False), ("my_arm.yaml", True), ("my_arm.YML", True),
    ("arms/my_arm", True), ("./wang2023", True), (Path("my_arm"), True), (3, False)])
def test_a_preset_value_is_a_file_by_its_suffix_a_separator_or_its_type(value, is_file):
    assert is_arm_file(value) is is_file


def test_an_unknown_name_lists_the_presets_and_the_arm_file(tmp_path):
    with pytest.raises(ValueError) as error:
        arm_from_preset("wang2024")
    message = str(error.value)
    assert "'wang2024'" in message and str(sorted(PRESETS)) in message
    assert "or a path to an arm file" in message
    with pytest.raises(ValueError, match=r"or a path to an arm file.*got 'wang2024'"):
        gym.make("SoftArmReach-v0", preset="wang2024")
    with pytest.raises(ValueError, match=r"preset must be a preset name, a path to an arm file "
                                         r"or an ArmSpec, got 3 \(int\)"):
        SoftArmEnv(preset=3)
    missing = tmp_path / "nowhere" / "arm.yaml"
    with pytest.raises(ValueError, match=rf"arm file '{missing}' does not exist"):
        gym.make("SoftArmReach-v0", preset=str(missing))


# ------------------------------------------------------------------------------- bad files
def _wang_text(tmp_path: Path) -> str:
    return save_preset("wang2023", tmp_path / "good.yaml").read_text(encoding="utf-8")


def _segments(text: str, block: str) -> str:
    """``text`` with its segments' block replaced by ``block``."""
    start, end = text.index("segments:"), text.index("cylinders:")
    return text[:start] + block + text[end:]


BAD_FILES = {  # case -> (the file's text from a good one, what the message names)
    "unknown field": (lambda t: t.replace("  n_links: 4", "  n_linkz: 4"),
                      ["unknown field 'segments[0].n_linkz'", "fields of SegmentSpec are",
                       "'n_links'"]),
    "unknown top-level field": (lambda t: t.replace("mount: hanging",
                                                    "mount: hanging\ncolour: red"),
                                ["unknown field 'colour'", "fields of ArmSpec are"]),
    "wrong type": (lambda t: t.replace("  n_links: 4", "  n_links: 4.5"),
                   ["segments[0].n_links must be an integer", "got 4.5 (float)"]),
    "quoted number": (lambda t: t.replace("- length_m: 0.09", "- length_m: '0.09'"),
                      ["segments[0].length_m must be a number", "got '0.09' (str)"]),
    "bool for a number": (lambda t: t.replace("  p_pre_pa: 0.0", "  p_pre_pa: yes"),
                          ["segments[0].p_pre_pa must be a number", "(bool)"]),
    "string for a bool": (lambda t: t.replace("  torsion: false", "  torsion: 'false'"),
                          ["segments[0].torsion must be true or false", "(str)"]),
    "null for a number": (lambda t: t.replace("  p_max_pa: 125000.0", "  p_max_pa: null"),
                          ["segments[0].p_max_pa must be a number", "got None"]),
    "negative length": (lambda t: t.replace("- length_m: 0.09", "- length_m: -0.09"),
                        ["segments[0].length_m: length_m must be a finite number > 0",
                         "got -0.09"]),
    "no wall left": (lambda t: t.replace("  chamber_area_m2: 1.6e-05", "  chamber_area_m2: 1.6e-4"),
                     ["segments[0].chamber_area_m2: chamber_area_m2=0.00016 leaves no wall"]),
    "unknown mount": (lambda t: t.replace("mount: hanging", "mount: sideways"),
                      ["mount: mount must be one of ['hanging', 'upright', 'horizontal']",
                       "got 'sideways'"]),
    "step not dividing the period": (
        lambda t: t.replace("physics_dt_s: 0.0025", "physics_dt_s: 0.003"),
        ["control_period_s: control_period_s=0.05 must be a whole multiple of physics_dt_s"]),
    "bad cylinders": (lambda t: t.replace("cylinders: null",
                                          "cylinders: {bore_area_m2: 1.0e-4, max_stroke_m: -1, "
                                          "dead_volume_m3: 0, atmospheric_pa: 101325}"),
                      ["cylinders.max_stroke_m: max_stroke_m must be a finite number > 0"]),
    "cylinders not a mapping": (lambda t: t.replace("cylinders: null", "cylinders: 3"),
                                ["cylinders must be a mapping of CylinderSpec fields or null",
                                 "got 3 (int)"]),
    "note not a string": (lambda t: t.replace("notes:", "notes:\n  extra: 3"),
                          ["notes.extra must be a string", "got 3 (int)"]),
    "missing segments": (lambda t: _segments(t, ""),
                         ["field 'segments' is missing", "every field of ArmSpec"]),
    "no segments": (lambda t: _segments(t, "segments: []\n"),
                    ["segments: segments must hold at least one SegmentSpec"]),
    "segments not a list": (lambda t: _segments(t, "segments: 2\n"),
                            ["segments must be a list of mappings of SegmentSpec fields",
                             "got 2 (int)"]),
    "segment not a mapping": (lambda t: _segments(t, "segments:\n- 0.09\n"),
                              ["segments[0] must be a mapping of SegmentSpec fields",
                               "got 0.09 (float)"]),
    "missing segment field": (lambda t: t.replace("- length_m: 0.09\n  outer_radius_m",
                                                  "- outer_radius_m"),
                              ["field 'segments[0].length_m' is missing",
                               "every field of SegmentSpec"]),
    "missing field with a default": (lambda t: t.replace("  poisson_ratio: 0.48\n", ""),
                                     ["field 'segments[0].poisson_ratio' is missing",
                                      "preset export writes a complete one"]),
    "cut at a line": (lambda t: t[:t.index("  n_links")], ["field 'notes' is missing"]),
    "cut before the notes": (lambda t: t[:t.index("notes:")],
                             ["field 'notes' is missing"]),
    "missing name": (lambda t: t.replace("name: wang2023\n", ""),
                     ["field 'name' is missing"]),
    "name not a string": (lambda t: t.replace("name: wang2023", "name: no"),
                          ["name must be a string", "got False (bool)"]),
    "missing format": (lambda t: t.replace(f"format: {ARM_FILE_FORMAT}\n", ""),
                       ["field 'format' is missing", f"format: {ARM_FILE_FORMAT}"]),
    "another format": (lambda t: t.replace(f"format: {ARM_FILE_FORMAT}", "format: 99"),
                       [f"format must be {ARM_FILE_FORMAT}", "got 99"]),
    "duplicated key": (lambda t: t.replace("mount: hanging", "mount: hanging\nmount: upright"),
                       ["is not valid YAML", "found duplicate key 'mount'", "line "]),
    "garbled YAML": (lambda t: t.replace("mount: hanging", "mount: [hanging"),
                     ["is not valid YAML", "line "]),
    "cut short": (lambda t: t[:t.index("segments:") + 30].rsplit("\n", 1)[0] + "\n  - [",
                  ["is not valid YAML"]),
    "not a mapping": (lambda t: "- wang2023\n- ho2018\n",
                      ["must hold a mapping of the arm's fields", "got list"]),
    "empty": (lambda t: "", ["must hold a mapping of the arm's fields", "got an empty file"]),
}


@pytest.mark.parametrize("case", sorted(BAD_FILES))
def test_a_bad_file_is_one_value_error_naming_the_file_and_the_field(case, tmp_path):
    edit, expected = BAD_FILES[case]
    text = _wang_text(tmp_path)
    path = tmp_path / "bad.yaml"
    path.write_text(edit(text), encoding="utf-8")
    assert path.read_text(encoding="utf-8") != text
    with pytest.raises(ValueError) as error:
        load_preset(path)
    message = str(error.value)
    assert message.startswith(f"arm file '{path}'"), message
    assert "\n" not in message, message
    for part in expected:
        assert part in message, (part, message)
    # the env refuses it with the same message
    with pytest.raises(ValueError) as from_env:
        SoftArmEnv(preset=str(path), feedback="ground_truth")
    assert str(from_env.value) == message


def test_an_unreadable_file_is_refused_by_name(tmp_path):
    binary = tmp_path / "binary.yaml"
    binary.write_bytes(b"\xff\xfe\x00format: 1")
    with pytest.raises(ValueError, match=rf"arm file '{binary}' cannot be read as UTF-8 text"):
        load_preset(binary)
    with pytest.raises(ValueError, match=rf"arm file '{tmp_path}' is a directory"):
        load_preset(tmp_path)
    with pytest.raises(ValueError, match="path must be a str or os.PathLike"):
        load_preset(None)


def test_save_refuses_what_no_file_can_hold(tmp_path):
    with pytest.raises(ValueError, match=r"name_or_spec must be one of .*got 'wang2024'"):
        save_preset("wang2024", tmp_path / "x.yaml")
    spec = dataclasses.replace(PRESETS["wang2023"], notes={"k": 3.0})
    with pytest.raises(ValueError, match="notes must map strings to strings"):
        save_preset(spec, tmp_path / "x.yaml")
    assert list(tmp_path.iterdir()) == []  # nothing written, no temporary left
