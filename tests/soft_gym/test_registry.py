"""The one name-plus-parameters parser behind make_scenario, make_faults, make_sensor and
make_policy: the accepted forms, and a ValueError naming the parameter, the value and what is
allowed for every malformed input."""

from __future__ import annotations

import pytest

from agents.policies import make_policy
from soft_gym._registry import Spec, build, parse_spec
from soft_gym.scenarios import SCENARIO_ELEMENTS, TipMass, make_scenario
from soft_gym.sensors import SENSORS, make_sensor
from soft_gym.sensors.faults import FAULT_PRESETS, FAULTS, LowLight, make_faults

pytestmark = pytest.mark.smoke


def test_parse_spec_flattens_every_accepted_form_in_order():
    mass = TipMass(mass_kg=0.01)
    items = parse_spec(["tip_mass", None, [{"name": "push", "link": 0}, mass]], "scenario",
                       SCENARIO_ELEMENTS, forms=("none", "name", "dict", "list", "instance"),
                       instance_types=(TipMass,))
    assert items == [Spec("tip_mass", {}), Spec("push", {"link": 0}), mass]
    assert parse_spec(None, "scenario", SCENARIO_ELEMENTS) == []


@pytest.mark.parametrize("value, fragments", [
    ({"name": ["tip_mass"]}, ["scenario name", "['tip_mass']", "tip_mass", "push"]),
    (42, ["scenario must be", "42", "a name from", "a dict", "TipMass", "a list of these"]),
    (4.2, ["scenario must be", "4.2"]),
    (True, ["scenario must be", "True"]),
    ({"mass_kg": 0.1}, ["scenario must have a 'name' key", "{'mass_kg': 0.1}"]),
    ({"name": "tip_mass", 3: 1}, ["scenario 'tip_mass' parameter names must be strings", "[3]"]),
    (["tip_mass", "earthquake"], ["scenario[1] name", "'earthquake'", "tip_mass"]),
    (["tip_mass", {1, 2}], ["scenario[1] must be", "{1, 2}"]),
    ({"name": "tip_mass", "mass": 0.1}, ["scenario 'tip_mass' got invalid parameters",
                                         "'mass'"]),
    ({"name": None}, ["scenario name", "None"]),
])
def test_make_scenario_bad_inputs_name_the_parameter_the_value_and_what_is_allowed(value,
                                                                                  fragments):
    with pytest.raises(ValueError) as error:
        make_scenario(value)
    for fragment in fragments:
        assert fragment in str(error.value), (fragment, str(error.value))


@pytest.mark.parametrize("value, fragments", [
    ({"name": ["low_light"]}, ["faults name", "['low_light']", "wang2023_lighting"]),
    (7, ["faults must be", "7", "VisualFault", *FAULTS, *FAULT_PRESETS]),
    ({"strength": 0.5}, ["faults must have a 'name' key"]),
    (["low_light", "fog"], ["faults[1] name", "'fog'", "led_glare"]),
    ({"name": "wang2023_occlusion", "scale": 2}, ["faults 'wang2023_occlusion' got invalid "
                                                  "parameters", "'scale'"]),
])
def test_make_faults_bad_inputs(value, fragments):
    with pytest.raises(ValueError) as error:
        make_faults(value)
    for fragment in fragments:
        assert fragment in str(error.value), (fragment, str(error.value))


def test_make_faults_keeps_its_forms():
    fault = LowLight(strength=0.3)
    made = make_faults([None, "low_light", {"name": "wang2023_lighting", "time_scale": 0.1},
                        fault])
    assert [type(f).__name__ for f in made] == ["LowLight", "LowLight", "LEDGlare", "LowLight"]
    assert made[-1] is fault


@pytest.mark.parametrize("value, fragments", [
    (None, ["sensor must be a name from", "None", "fbg"]),
    (3, ["sensor must be a name from", "3"]),
    (["fbg"], ["sensor must be a name from", "['fbg']"]),
    ({"name": "fbg"}, ["sensor must be a name from", "{'name': 'fbg'}"]),
    ("sonar", ["sensor name must be one of", "'sonar'", "strain"]),
])
def test_make_sensor_bad_names(value, fragments):
    with pytest.raises(ValueError) as error:
        make_sensor(value)
    for fragment in fragments:
        assert fragment in str(error.value), (fragment, str(error.value))
    assert all(name in str(error.value) for name in SENSORS)


def test_make_sensor_bad_parameters_name_the_sensor():
    with pytest.raises(ValueError, match="sensor 'em' got invalid parameters"):
        make_sensor("em", noise=1.0)


@pytest.mark.parametrize("value, fragments", [
    (None, ["policy must be a name from", "None", "cc_model", "sb3:PATH"]),
    (0.06, ["policy must be a name from", "0.06"]),
    ("pid", ["policy name must be one of", "'pid'", "hybrid_gpr", "sb3:PATH"]),
])
def test_make_policy_bad_names(value, fragments):
    with pytest.raises(ValueError) as error:
        make_policy(value)
    for fragment in fragments:
        assert fragment in str(error.value), (fragment, str(error.value))


def test_parse_spec_checks_its_own_forms_and_build_wraps_bad_keywords():
    with pytest.raises(ValueError, match="forms"):
        parse_spec("x", "thing", ["x"], forms=("name", "yaml"))
    with pytest.raises(ValueError, match="thing 'x' got invalid parameters"):
        build("thing", "x", lambda a: a, {"b": 1})


# ------------------------------------------------------------------ Registry
def test_registry_is_a_mapping_in_registration_order_that_refuses_unknown_names_by_kind():
    from soft_gym._registry import Registry

    registry = Registry("widget")
    registry.register("b", 2)
    registry.register("a", 1)
    assert list(registry) == ["b", "a"] and len(registry) == 2 and "a" in registry
    assert registry["a"] == 1 and registry.get("c") is None and registry.get("c", 5) == 5
    with pytest.raises(ValueError, match=r"^widget must be one of \['b', 'a'\], got 'c'$"):
        registry["c"]
    with pytest.raises(ValueError, match=r"^widget name must be a new non-empty string"):
        registry.register("a", 3)
    with pytest.raises(ValueError, match=r"^widget name must be a new non-empty string"):
        registry.register("", 3)
    registry.unregister("b")
    assert list(registry) == ["a"]
    with pytest.raises(ValueError, match=r"^widget must be one of \['a'\], got 'b'$"):
        registry.unregister("b")


def test_a_lazy_registry_entry_is_imported_on_first_access():
    from soft_gym._registry import Registry

    registry = Registry("thing")
    registry.register("dumps", "json:dumps", lazy=True)
    import json

    assert registry["dumps"] is json.dumps and registry.get("dumps") is json.dumps
    with pytest.raises(ValueError, match=r"^a lazy thing must be given as 'module:attribute'"):
        registry.register("bad", "json.dumps", lazy=True)


def test_every_family_of_named_parts_is_a_registry():
    """One registry style: every family is a Registry (name lists in messages come from it)."""
    from agents.policies import BASELINES
    from soft_gym._registry import Registry
    from soft_gym.engines import ENGINES
    from soft_gym.envs.observations import OBSERVATION_PARTS
    from soft_gym.procedures.calibration import CALIBRATIONS
    from soft_gym.scenarios import SCENARIO_ELEMENTS
    from soft_gym.sensing import FEEDBACK_SOURCES
    from soft_gym.sensors import SENSORS
    from soft_gym.sensors.faults import FAULT_PRESETS, FAULTS

    for registry in (BASELINES, ENGINES, OBSERVATION_PARTS, CALIBRATIONS, SCENARIO_ELEMENTS,
                     FEEDBACK_SOURCES, SENSORS, FAULTS, FAULT_PRESETS):
        assert isinstance(registry, Registry) and len(registry) > 0
    calibrating = [name for name in FEEDBACK_SOURCES if FEEDBACK_SOURCES[name].calibrates]
    assert sorted(calibrating) == sorted(CALIBRATIONS)
