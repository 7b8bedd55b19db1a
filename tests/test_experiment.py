"""The grasp-range experiment: multimode succeeds everywhere, each single mode fails somewhere."""

import csv
import json

import pytest

import run_sim
from analysis.experiment import COLUMNS, CONTROLLERS, OBJECTS


@pytest.fixture(scope="module")
def table(tmp_path_factory):
    out = tmp_path_factory.mktemp("grasp-range")
    code = run_sim.main(["experiment", "grasp-range", "--out", str(out)])
    return code, out


@pytest.mark.slow
def test_multimode_succeeds_on_every_object_and_each_single_mode_fails_somewhere(table):
    code, out = table
    assert code == 0
    rows = json.loads((out / "grasp_range.json").read_text())["rows"]
    assert len(rows) == len(OBJECTS) * len(CONTROLLERS)
    masses = [float(o.overrides[1].split("=")[1]) for o in OBJECTS]
    assert min(masses) <= 0.001 and max(masses) >= 10.0
    assert any("crush_force_n" in " ".join(o.overrides) for o in OBJECTS)
    multimode = [r for r in rows if r["controller"] == "multimode"]
    assert all(r["success"] for r in multimode), [r for r in multimode if not r["success"]]
    for name, _ in CONTROLLERS[1:]:
        failed = [r for r in rows if r["controller"] == name and not r["success"]]
        assert failed, f"{name} succeeded everywhere"
        assert all(r["why"] for r in failed)  # the table says why


@pytest.mark.slow
def test_table_files_have_units_and_the_plot(table):
    _, out = table
    with (out / "grasp_range.csv").open() as fh:
        header = next(csv.reader(fh))
    assert tuple(header) == COLUMNS
    units = json.loads((out / "grasp_range.json").read_text())["units"]
    assert units["peak_pressure_pa"] == "Pa" and units["touch_latency_s"] == "s"
    assert (out / "grasp_range.png").stat().st_size > 10_000


def test_unknown_experiment_names_the_valid_one(capsys):
    assert run_sim.main(["experiment", "grasp-everything"]) == 2
    assert "valid experiments: grasp-range" in capsys.readouterr().err
