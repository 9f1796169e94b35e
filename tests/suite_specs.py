"""A tiny benchmark suite spec shared by the suite tests: two quick wang2023 runs per seed (a
26-step circle, one cycle, nominal and with a 10 g tip) and one n/a per seed (cc_model refuses
ho2018's two segments)."""

from __future__ import annotations

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
    policies: [cc_model]
"""


def tiny_suite(name: str = "tiny", seeds: tuple[int, ...] = (0,)) -> str:
    """The spec's YAML text with this ``name`` and these ``seeds``."""
    return f"name: {name}\nseeds: {list(seeds)}\n" + _ARMS
