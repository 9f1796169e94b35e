"""``n/a`` in the suite means only a declared refusal (:class:`agents.policies.PolicyRefusal`):
the issue's bad ``sensing`` options (``stereo: {bogus: 1}``, ``seed: 2**64``, ``n_points: 12``)
are refused by the check before any run, naming the key and the option; a run whose env or
policy fails with any other error is an error (no record, listed, the command line exits
non-zero), never an ``n/a`` row; a baseline refusing the arm with its defaults too is ``n/a``."""

from __future__ import annotations

import json
import textwrap
from pathlib import Path

import pytest

import eval.__main__ as eval_main
from agents.policies import PolicyRefusal
from eval import suite
from eval.suite import check as check_module
from eval.suite import report
from suite_specs import counting_backend

pytest.importorskip("rliable")

SENSING = """\
name: sensing
seeds: [0]
cycles: 1
arms:
  zou2022:
    paths: [circle]
    feedback: encoder_cc
    env: {{speed_m_s: 0.05}}
    conditions:
      nominal: {{}}
      {condition}
    policies:
      - {{name: cc_model, params: {{probe_steps: 5}}}}
"""

BAD_SENSING = {  # condition -> (its YAML, the option the message must name)
    "stereo_bogus": ("stereo_bogus: {feedback: encoder_dnn, sensing: {stereo: {bogus: 1}}}",
                     "bogus"),
    "seed_2_64": ("seed_2_64: {feedback: stereo, sensing: {seed: 18446744073709551616}}",
                  "seed"),
    "n_points_12": ("n_points_12: {feedback: stereo, sensing: {n_points: 12}}", "n_points"),
}


def _spec(tmp_path: Path, condition: str, name: str = "sensing.yaml") -> Path:
    path = tmp_path / name
    path.write_text(SENSING.format(condition=condition))
    return path


@pytest.mark.parametrize("case", sorted(BAD_SENSING))
def test_the_issues_bad_sensing_options_are_refused_before_any_run(case, tmp_path):
    condition, option = BAD_SENSING[case]
    path = _spec(tmp_path, condition)
    with pytest.raises(ValueError) as error:
        suite.check_suite(suite.load_suite(path))
    message = str(error.value)
    assert str(path) in message and f"arms.zou2022.conditions.{case}" in message, message
    assert option in message and "sensing" in message and "\n" not in message, message


def test_the_command_line_refuses_a_bad_sensing_option_in_one_line(tmp_path, capsys):
    path = _spec(tmp_path, BAD_SENSING["n_points_12"][0])
    with pytest.raises(SystemExit) as exit_info:
        eval_main.main(["suite", str(path), "--out", str(tmp_path / "o")])
    assert exit_info.value.code == 2
    error = capsys.readouterr().err.strip().splitlines()[-1]
    assert error.startswith("python -m eval suite: error: spec:") and "n_points" in error
    assert not (tmp_path / "o").exists()


def test_a_run_failing_with_an_error_other_than_a_refusal_is_an_error_not_na(tmp_path):
    """Past the check (``check=False``), the env's refusal of an option is an error of the run:
    no record, listed, the report counts the cell as not made; the nominal run is done."""
    spec = suite.load_suite(_spec(tmp_path, BAD_SENSING["stereo_bogus"][0]))
    cells = {c.labels["condition"]: c for c in suite.expand(spec)}
    out = tmp_path / "out"
    ran: list[str] = []
    with pytest.raises(suite.SuiteRunError) as error:
        suite.run_suite(spec, out, backend=counting_backend(ran), progress=False, check=False)
    assert sorted(ran) == sorted(c.key for c in cells.values())
    (failure,) = error.value.failures
    assert failure["key"] == cells["stereo_bogus"].key and "bogus" in failure["error"]
    assert suite.read_record(out, cells["stereo_bogus"].key) is None
    assert (out / "errors" / f"{cells['stereo_bogus'].key}.txt").is_file()
    assert suite.read_record(out, cells["nominal"].key)["status"] == "done"
    rows = {r["condition"]: r for r in report.collect_rows(list(cells.values()), out)}
    assert rows["stereo_bogus"]["status"] == "missing" and rows["nominal"]["status"] == "done"


def _one_policy(name: str, policy: str) -> str:
    """A suite of one nominal wang2023 run (ground-truth feedback) of the ``policy`` entry."""
    return textwrap.dedent(f"""\
        name: {name}
        seeds: [0]
        cycles: 1
        arms:
          wang2023:
            paths: [circle]
            feedback: ground_truth
            conditions:
              nominal: {{}}
            policies:
              - {policy}
        """)


REFUSING = _one_policy("refusing", "{name: local_ik_asdm, env: {obs: [pose, target, pressure]}}")
"""local_ik_asdm on an env whose observation has no strain part."""


def test_a_declared_refusal_is_na_with_its_reason(tmp_path):
    """local_ik_asdm reads strain: on an env without it, it refuses (with its defaults too)."""
    path = tmp_path / "refusing.yaml"
    path.write_text(REFUSING)
    spec = suite.load_suite(path)
    (cell,) = suite.check_suite(spec)
    result = suite.run_cell({"key": cell.key, "suite": spec.name, "labels": cell.labels,
                             "config": cell.config, "versions": {}, "git_revision": None})
    assert result["status"] == "n/a" and result["metrics"] is None
    assert "obs must include" in result["reason"] and "strain" in result["reason"]


# ------------------------------------------------------------- the check's classification
TINY = _one_policy("classify", "{name: cc_model, params: {kp: 0.05}}")


def _stand_in(with_params: Exception | None, with_defaults: Exception | None):
    def make_policy(name, env=None, **params):
        error = with_params if params else with_defaults
        if error is not None:
            raise error
    return make_policy


CLASSIFY = {  # case -> (error with the entry's params, with the defaults, a suite error?)
    "refusal with the defaults too: n/a": (PolicyRefusal("no strain"), PolicyRefusal("x"),
                                           False),
    "refusal of the params only": (PolicyRefusal("kp too big"), None, True),
    "plain ValueError with the defaults too": (ValueError("broken"), ValueError("broken"),
                                               True),
    "TypeError": (TypeError("bad type"), TypeError("bad type"), True),
    "accepted": (None, None, False),
}


@pytest.mark.parametrize("case", sorted(CLASSIFY))
def test_the_check_calls_only_a_policy_refusal_n_a(case, tmp_path, monkeypatch):
    with_params, with_defaults, is_error = CLASSIFY[case]
    path = tmp_path / "classify.yaml"
    path.write_text(TINY)
    spec = suite.load_suite(path)
    monkeypatch.setattr(check_module, "make_policy", _stand_in(with_params, with_defaults))
    if is_error:
        with pytest.raises(suite.SuiteError) as error:
            suite.check_suite(spec)
        assert "arms.wang2023.policies[0].params" in str(error.value)
        assert str(with_params) in str(error.value)
    else:
        assert len(suite.check_suite(spec)) == 1


def test_records_of_refusals_stay_readable(tmp_path):
    """An n/a record written from a refusal verifies (its reason is the refusal's text)."""
    path = tmp_path / "refusing.yaml"
    path.write_text(REFUSING)
    spec = suite.load_suite(path)
    out = tmp_path / "out"
    counts = suite.run_suite(spec, out, backend="serial", progress=False, check=False)
    assert (counts["n/a"], counts["done"]) == (1, 0)
    (cell,) = suite.expand(spec)
    record = json.loads(suite.record_path(out, cell.key).read_text())
    assert record["status"] == "n/a" and suite.record_problem(out, cell.key) is None
