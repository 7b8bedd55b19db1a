"""benchmarks/stages.py: each stage of a control step timed (it times nothing that a test judges:
the keys, their sums and the command line)."""

import json

import pytest

from benchmarks import stages
from piezotip import scenarios

#: Every stage of a control step, physics' gel forces among them, and the loop's own rest.
STAGES = {"physics", "gel_forces", "pressure", "sensor", "readout", "controller", "actuators", "record", "other"}


@pytest.fixture(scope="module")
def report():
    """Ten control steps of the default grasp, one run of each kind."""
    return stages.stages_report("grasp", scenarios.get("grasp"), repeats=1, duration_s=0.05)


def test_every_stage_is_timed_and_the_shares_add_up(report):
    assert set(report["stages_us"]) == STAGES and report["control_steps"] == 10
    assert all(us >= 0 for us in report["stages_us"].values())
    assert report["stages_us"]["physics"] > 0 and report["stages_us"]["physics"] >= report["stages_us"]["gel_forces"]
    # the gel forces are a part of physics: the shares of the rest make the whole step
    assert sum(v for k, v in report["stages_share"].items() if k != "gel_forces") == pytest.approx(1.0)
    assert report["overhead_ratio"] == pytest.approx(report["cosim_step_us"] / report["bare_step_us"])


def test_the_table_names_each_stage_beside_bare_mj_step(report):
    text = stages.format_stages(report)
    for name in STAGES - {"gel_forces"}:
        assert f"\n  {name} " in text
    assert "of which gel forces" in text and "bare mj_step x 5" in text


def test_a_timer_costs_something_and_is_subtracted():
    inside, whole = stages.wrapper_costs(samples=2000)
    assert 0 < inside <= whole < 1e-4


def test_the_command_prints_json_and_rejects_bad_arguments(capsys):
    args = ["--duration", "0.02", "--repeats", "1", "--set", "controller.kind=scripted", "--json"]
    assert stages.main(args) == 0
    printed = json.loads(capsys.readouterr().out)
    assert set(printed["stages_us"]) == STAGES and printed["control_steps"] == 4
    bad = {
        "repeats": ["--repeats", "0", "--duration", "0.02"],
        "duration": ["--duration", "-1", "--repeats", "1"],
        "nope": ["--set", "nope=1", "--duration", "0.02", "--repeats", "1"],
    }
    for named, argv in bad.items():
        with pytest.raises(SystemExit) as stop:
            stages.main(argv)
        assert stop.value.code == 2 and named in capsys.readouterr().err
