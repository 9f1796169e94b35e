"""soft_gym/identify/parameters.py: the names --params takes and the arm with new values."""

from __future__ import annotations

import pytest

from soft_gym.identify.parameters import default_parameters, parse_parameters, with_values
from soft_gym.robots.presets import get_preset

pytestmark = pytest.mark.smoke


def test_a_family_name_stands_for_every_segment_and_the_tip_mass_for_the_last():
    spec = get_preset("zhao2021")
    names = [p.name for p in parse_parameters(
        ["youngs_modulus_pa", "extra_tip_mass_kg", "damping_ratio[1]", "youngs_modulus_pa[0]",
         "pneumatic_time_constant_s"], spec)]
    last = spec.n_segments - 1
    assert names == [*(f"youngs_modulus_pa[{k}]" for k in range(spec.n_segments)),
                     f"extra_tip_mass_kg[{last}]", "damping_ratio[1]",
                     "pneumatic_time_constant_s"]


def test_with_values_changes_only_the_named_fields():
    spec = get_preset("wang2023")
    parameters = parse_parameters(["youngs_modulus_pa", "pneumatic_time_constant_s"], spec)
    changed = with_values(spec, parameters, [1e5, 0.2])
    assert changed.segments[0].youngs_modulus_pa == 1e5
    assert changed.pneumatic_time_constant_s == 0.2
    assert with_values(changed, parameters, [p.value(spec) for p in parameters]) == spec


@pytest.mark.parametrize("names, message", [
    (["stiffness"], "parameter 'stiffness' is unknown"),
    (["youngs_modulus_pa[3]"], "has segments 0 to 0"),
    (["pneumatic_time_constant_s[0]"], "belongs to the whole arm"),
    ([], "at least one parameter"),
])
def test_a_bad_name_is_refused(names, message):
    with pytest.raises(ValueError, match=message):
        parse_parameters(names, get_preset("wang2023"))


def test_a_zero_start_is_refused_and_left_out_of_the_defaults():
    spec = get_preset("ho2018")
    assert spec.segments[-1].extra_tip_mass_kg == 0.0
    with pytest.raises(ValueError, match=r"'extra_tip_mass_kg\[1\]' is 0 in arm 'ho2018'"):
        parse_parameters(["extra_tip_mass_kg"], spec)
    assert "extra_tip_mass_kg" not in " ".join(p.name for p in default_parameters(spec))
