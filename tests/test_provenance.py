"""Results record what made them (issue 30): the versions of piezotip and its numerical
libraries, Python's, and the git commit when run from a checkout."""

import json
import subprocess
import sys
from pathlib import Path

import mujoco
import numpy as np
import pytest

from piezotip import provenance
from piezotip.cli import main

ROOT = Path(__file__).resolve().parents[1]


def test_versions_name_the_installed_libraries_and_this_checkouts_commit():
    v = provenance.versions()
    assert v["mujoco"] == mujoco.__version__ and v["numpy"] == np.__version__
    assert v["python"] == ".".join(map(str, sys.version_info[:3]))
    head = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "HEAD"], capture_output=True, text=True).stdout.strip()
    if head:  # run from a checkout (CI's clone is one)
        assert v["git_commit"].removesuffix("-dirty") == head


def test_outside_a_checkout_there_is_no_commit(tmp_path):
    assert provenance.git_commit(str(tmp_path)) is None


def test_summary_json_and_run_json_record_the_versions(tmp_path, capsys):
    out = tmp_path / "run"
    code = main(["run", "grasp", "--preset", "fast", "--set", "duration_s=0.2", "--no-plot", "--json", "--out", str(out)])
    assert code in (0, 1)
    printed = json.loads(capsys.readouterr().out)
    written = json.loads((out / "summary.json").read_text())
    assert printed["versions"] == written["versions"] == json.loads(json.dumps(provenance.versions()))


def test_sweep_json_records_the_versions(tmp_path, capsys):
    out = tmp_path / "sweep"
    argv = ["sweep", "grasp", "--grid", "object.mass_kg=0.05", "--preset", "fast", "--set", "duration_s=0.2"]
    code = main([*argv, "--workers", "0", "--no-plot", "--out", str(out)])
    assert code in (0, 1)
    assert json.loads((out / "sweep.json").read_text())["versions"]["mujoco"] == mujoco.__version__


# Every output carries what repeats it: versions, the commit, the seeds and the fully resolved
# config (issue 44, item 9).  Before: versions alone, and the sweep's Parquet file had no
# metadata, mode_switches as float, modes_used as the text "1 2", error "" for no error.

SHORT = ["duration_s=0.2"]


def _expected_config(overrides: list[str], preset: str | None = "fast") -> dict:
    from piezotip import scenarios

    return provenance.resolved_config(scenarios.get("grasp", overrides, preset))


def test_summary_json_and_run_json_carry_the_seeds_and_the_resolved_config(tmp_path, capsys):
    out = tmp_path / "run"
    sets = ["sensor.seed=7", *SHORT]
    code = main(["run", "grasp", "--preset", "fast", *[a for s in sets for a in ("--set", s)], "--no-plot", "--json", "--out", str(out)])
    assert code in (0, 1)
    printed = json.loads(capsys.readouterr().out)
    written = json.loads((out / "summary.json").read_text())
    assert printed["seed"] == written["seed"] == 7 and written["unit_seed"] == 0
    config = written["config"]
    assert config == printed["config"] == json.loads(json.dumps(_expected_config(sets)))
    # the preset's and the defaults' values are there, not only what was set
    assert config["physics"]["timestep_s"] == pytest.approx(1 / 600) != _expected_config(SHORT, None)["physics"]["timestep_s"]
    assert config["duration_s"] == 0.2 and config["object"]["mass_kg"] == 0.1 and config["controller"]["kind"]
    assert written["interrupted"] is False and list(written)[-4:] == ["versions", "seed", "unit_seed", "config"]


def _sweep_with_an_error(tmp_path, monkeypatch, capsys) -> Path:
    """The command line's sweep over mass and seed, its second point raising (a message with "#")."""
    from piezotip.analysis import runner

    real = runner.run_scenario

    def flaky(name, overrides, *args, **kwargs):
        if "object.mass_kg=0.2" in overrides and "sensor.seed=3" in overrides:
            raise RuntimeError("the solver fell over #3, a, b")
        return real(name, overrides, *args, **kwargs)

    monkeypatch.setattr(runner, "run_scenario", flaky)
    out = tmp_path / "sweep"
    argv = ["sweep", "grasp", "--grid", "object.mass_kg=0.2", "--grid", "sensor.seed=0,3", "--preset", "fast", "--set", SHORT[0]]
    assert main([*argv, "--workers", "0", "--no-plot", "--out", str(out)]) == 1  # a point raised
    capsys.readouterr()
    return out


def test_the_sweeps_parquet_has_true_types_nulls_and_its_provenance(tmp_path, monkeypatch, capsys):
    import pyarrow as pa
    import pyarrow.parquet as pq

    out = _sweep_with_an_error(tmp_path, monkeypatch, capsys)
    table = pq.read_table(out / "sweep.parquet")
    types = {field.name: field.type for field in table.schema}
    assert types["mode_switches"] == pa.int64() and types["modes_used"] == pa.list_(pa.int64())
    assert types["sensor.seed"] == pa.int64() and types["object.mass_kg"] == pa.float64() and types["success"] == pa.bool_()
    assert types["error"] == pa.string() and types["max_pressure_pa"] == pa.float64()
    ran, raised = table.to_pylist()
    assert (
        ran["error"] is None
        and isinstance(ran["mode_switches"], int)
        and ran["modes_used"]
        and all(isinstance(m, int) for m in ran["modes_used"])
    )
    assert ran["held_pressure_pa"] is None  # a missing number (never held): null, not NaN
    assert "the solver fell over #3" in raised["error"] and raised["outcome"] == "error"
    assert raised["modes_used"] is None and raised["mode_switches"] is None and raised["max_pressure_pa"] is None
    made = json.loads(table.schema.metadata[b"piezotip"])
    assert made["versions"] == json.loads(json.dumps(provenance.versions()))
    assert made["seed"] == 0 and made["unit_seed"] == 0 and made["grid"] == {"object.mass_kg": ["0.2"], "sensor.seed": ["0", "3"]}
    assert made["config"] == json.loads(json.dumps(_expected_config(SHORT))) and made["preset"] == "fast" and made["overrides"] == SHORT
    report = json.loads((out / "sweep.json").read_text())
    assert report["config"] == made["config"] and report["seed"] == 0 and report["versions"] == made["versions"]


def test_the_sweeps_csv_starts_with_its_provenance_and_reads_as_before(tmp_path, monkeypatch, capsys):
    import csv

    import pyarrow.parquet as pq

    from piezotip.analysis.sweep_output import read_csv_rows

    out = _sweep_with_an_error(tmp_path, monkeypatch, capsys)
    lines = (out / "sweep.csv").read_text().splitlines()
    assert lines[0].startswith("# piezotip sweep of grasp: piezotip ") and "seed per row" in lines[0]
    assert f"mujoco {mujoco.__version__}" in lines[0] and "git commit " in lines[0]
    assert lines[1].startswith("# piezotip: ") and not lines[2].startswith("#")
    with (out / "sweep.csv").open() as fh:
        assert provenance.read_csv_header(fh) == json.loads(pq.read_table(out / "sweep.parquet").schema.metadata[b"piezotip"])
    rows = read_csv_rows(out / "sweep.csv")
    assert [r["sensor.seed"] for r in rows] == ["0", "3"] and rows[0]["error"] == "" and rows[0]["modes_used"]  # as today: "1 2"
    assert rows[1]["error"].startswith("RuntimeError: the solver fell over #3, a, b")
    # a "#" in a cell is quoted: a reader that takes "#" to begin a comment (pandas' comment="#") reads it whole
    assert [next(csv.reader([line])) for line in lines[2:]] == [list(rows[0]), *[list(r.values()) for r in rows]]
    assert all(f'"{cell}"' in line for line in lines[3:] for cell in next(csv.reader([line])) if "#" in cell)


def test_the_experiments_tables_carry_their_provenance(tmp_path):
    from piezotip.analysis import experiment
    from piezotip.analysis.sweep_output import read_csv_rows

    row = {column: None for column in experiment.COLUMNS} | {"object": "box-100g", "controller": "gentle", "reason": "held it # well"}
    made = experiment.experiment_provenance("fast", ("sensor.seed=5",))
    csv_path, json_path = experiment.write_outputs([row], tmp_path, plot=False, provenance=made)
    written = json.loads(json_path.read_text())
    assert written["seed"] == 5 and written["config"] == json.loads(json.dumps(_expected_config(["sensor.seed=5"])))
    assert written["versions"] == json.loads(json.dumps(provenance.versions())) and written["overrides"] == ["sensor.seed=5"]
    assert "box-100g" in written["objects"] and "gentle" in written["controllers"]
    with csv_path.open() as fh:
        assert fh.readline().startswith("# piezotip experiment grasp-range: piezotip ")
        fh.seek(0)
        assert provenance.read_csv_header(fh) == {k: v for k, v in written.items() if k not in ("units", "rows")}
    (read,) = read_csv_rows(csv_path)
    assert tuple(read) == experiment.COLUMNS and read["reason"] == "held it # well"
