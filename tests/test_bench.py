"""The benchmark command runs and reports its keys (it times nothing here: claims come from the command)."""

import contextlib
import io
import json

import pytest

from piezotip import cli as run_sim
from piezotip import scenarios
from piezotip.analysis.bench import BenchCase, bench_cases

TOP_KEYS = {"overhead_ratio", "realtime_factor", "wall_s_per_sim_s", "bare_step_us", "cosim_step_us", "stages_us", "scenes"}
STAGES = {"physics", "gel_forces", "pressure", "sensor", "readout", "controller", "actuators", "record", "other"}


@pytest.fixture(scope="module")
def report(tmp_path_factory):
    """One tiny benchmark (10 control steps, one repeat) through the command line, with --out."""
    out = tmp_path_factory.mktemp("bench")
    printed = io.StringIO()
    with contextlib.redirect_stdout(printed):
        code = run_sim.main(["bench", "--json", "--duration", "0.05", "--repeats", "1", "--no-presets", "--out", str(out)])
    assert code == 0
    return out, json.loads(printed.getvalue())


def test_bench_json_has_the_keys(report):
    out, printed = report
    data = json.loads((out / "bench.json").read_text())
    assert printed.keys() == data.keys()
    assert TOP_KEYS <= data.keys()
    assert set(data["stages_us"]) == STAGES
    assert data["scene"] == "grasp" and data["scenes"][0]["name"] == "grasp"
    entry = data["scenes"][0]
    assert entry["control_steps"] == 10 and entry["physics_steps"] == 10 * entry["substeps"]
    for key in ("overhead_ratio", "realtime_factor", "wall_s_per_sim_s", "bare_step_us", "cosim_step_us"):
        assert data[key] > 0
    assert (out / "bench.png").stat().st_size > 0


def test_bench_prints_a_table(capsys):
    assert run_sim.main(["bench", "--duration", "0.02", "--repeats", "1", "--no-presets", "--set", "controller.kind=scripted"]) == 0
    text = capsys.readouterr().out
    assert "grasp" in text and "bare mj_step" in text and "ratio" in text


def test_a_list_of_configs_is_benchmarked_each_under_its_name():
    """Fidelity presets will come as named configs: each gets its own entry."""
    scripted = ["controller.kind=scripted"]  # the cheapest controller to build
    cases = [
        BenchCase("default", scenarios.get("grasp", scripted)),
        BenchCase("2ms-control", scenarios.get("grasp", [*scripted, "physics.control_period_s=0.002"])),
    ]
    entries = bench_cases(cases, repeats=1, duration_s=0.02)
    assert [e["name"] for e in entries] == ["default", "2ms-control"]
    assert [e["substeps"] for e in entries] == [5, 2]
    for e in entries:
        assert e["wall_s_per_sim_s"] > 0 and e["realtime_factor"] > 0


def test_bench_rejects_bad_arguments(capsys):
    assert run_sim.main(["bench", "--repeats", "0"]) == 2
    assert "repeats" in capsys.readouterr().err
    assert run_sim.main(["bench", "--duration", "-1", "--repeats", "1"]) == 2
    assert "duration" in capsys.readouterr().err


@pytest.mark.slow
def test_fidelity_presets_report_cost_and_errors_against_reference():
    """The presets' table on one scene: every preset named, errors against reference, the
    reference's halving check; the reference against itself has no error."""
    from piezotip.analysis.fidelity import fidelity_report

    report = fidelity_report(scenes=("grasp",))
    names = [e["name"] for e in report["presets"]]
    assert names == ["fast", "balanced", "accurate", "reference"]
    for e in report["presets"]:
        assert e["wall_s_per_sim_s"] > 0 and e["realtime_factor"] > 0
        assert {"pressure_estimate", "true_pressure", "output_v1", "touch_time_s", "outcome"} <= e["errors"].keys()
    ref = report["presets"][-1]["errors"]
    assert ref["pressure_estimate"] == 0 and ref["outcome"]
    assert report["convergence"]["name"] == "reference-halved"
    assert {"fast_speedup_over_accurate", "reference_converged", "targets_met"} <= report["checks"].keys()
