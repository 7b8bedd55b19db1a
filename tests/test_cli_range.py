"""`run_sim.py range`: strict JSON with the documented keys, coverage option, files, and errors."""

import csv
import json
import math

import pytest
from numpy.testing import assert_allclose

from piezotip import cli as run_sim

KEYS = {
    "p_min_pa",
    "p_max_pa",
    "dynamic_range",
    "modes",
    "switch_pressures_pa",
    "mode_bands",
    "coverage_m",
    "rated_pressure_pa",
    "backstop_pressure_pa",
    # where the model ends, and the range within it (issue 44, item 10)
    "p_max_within_model_pa",
    "dynamic_range_beyond_model",
    "gel_valid_pressure_pa",
    "model_limit_pa",
    "model_limit",
}
MODE_KEYS = {"mode", "freq_hz", "p_min_pa", "p_max_pa", "sigma_v1"}
PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


def _strict(text: str) -> dict:
    def reject(name):
        raise ValueError(f"non-standard JSON constant {name}")

    return json.loads(text, parse_constant=reject)


@pytest.fixture(scope="module")
def whole_report():
    # one run shared by the tests that only read it (each run costs ~1 s)
    import io
    from contextlib import redirect_stdout

    buf = io.StringIO()
    with redirect_stdout(buf):
        rc = run_sim.main(["range", "--json"])
    assert rc == 0
    return _strict(buf.getvalue())


def test_range_json_has_exact_keys_and_consistent_values(whole_report):
    r = whole_report
    assert set(r) == KEYS
    assert [m["mode"] for m in r["modes"]] == [1, 2, 3, 4]
    assert all(set(m) == MODE_KEYS for m in r["modes"])
    assert all(set(b) == {"mode", "from_pa", "to_pa"} for b in r["mode_bands"])
    assert r["coverage_m"] == [0.0, 7.5e-3]
    assert r["p_min_pa"] == min(m["p_min_pa"] for m in r["modes"])
    assert r["p_max_pa"] == max(m["p_max_pa"] for m in r["modes"])
    assert_allclose(r["dynamic_range_beyond_model"], r["p_max_pa"] / r["p_min_pa"], rtol=1e-15)
    assert_allclose(r["dynamic_range"], r["p_max_within_model_pa"] / r["p_min_pa"], rtol=1e-15)
    assert r["switch_pressures_pa"] == sorted(r["switch_pressures_pa"])
    assert r["dynamic_range"] >= 1e4  # the paper's calibration target (physics.md section 4)


@pytest.mark.parametrize("coverage", [(), ("--coverage", "6.5", "7.5")])
def test_the_dynamic_range_stops_where_the_model_does(capsys, coverage):
    """``dynamic_range`` reported 1.18e5 (whole beam) and 2.15e5 (tip), P_max / P_min, whose tops
    lie 4.6x past the backstop listed beside them and 6.1x: the range is now the one the model
    vouches for, up to the backstop or the gel's valid strain, and P_max / P_min is named for
    what it is."""
    assert run_sim.main(["range", "--json", *coverage]) == 0
    r = _strict(capsys.readouterr().out)
    ends = {"backstop": r["backstop_pressure_pa"], "gel_strain": r["gel_valid_pressure_pa"]}
    assert r["model_limit_pa"] == min(ends.values()) and ends[r["model_limit"]] == r["model_limit_pa"]
    assert r["p_max_within_model_pa"] == min(r["p_max_pa"], r["model_limit_pa"])
    top = r["dynamic_range"] * r["p_min_pa"]  # the range's top
    assert top <= r["backstop_pressure_pa"] * (1 + 1e-12) and top <= r["gel_valid_pressure_pa"] * (1 + 1e-12)
    assert r["dynamic_range_beyond_model"] > 4 * r["dynamic_range"]  # P_max lies far past the model's end
    # The gel's law is outside its range above its valid-strain pressure, not below it.
    from piezotip.sensor import GelModel

    strain = GelModel().state([0.999 * r["gel_valid_pressure_pa"], 1.001 * r["gel_valid_pressure_pa"]]).beyond_valid_strain
    assert strain.tolist() == [False, True]


def test_the_table_gives_the_range_within_the_model_and_names_the_other(capsys):
    assert run_sim.main(["range"]) == 0
    text = capsys.readouterr().out
    assert "dynamic range within the model 2.55e+04" in text and "the element's backstop ends the model" in text
    assert "past the model's end, 1.18e+05" in text


def test_range_json_via_capsys(capsys):
    assert run_sim.main(["range", "--json", "--coverage", "6.5", "7.5"]) == 0
    out, err = capsys.readouterr()
    r = _strict(out)
    assert set(r) == KEYS
    assert_allclose(r["coverage_m"], [6.5e-3, 7.5e-3], rtol=1e-15)
    assert err == ""


def test_coverage_changes_the_report(capsys, whole_report):
    assert run_sim.main(["range", "--json", "--coverage", "6.5", "7.5"]) == 0
    tip = _strict(capsys.readouterr().out)
    assert tip["coverage_m"] != whole_report["coverage_m"]
    # tip coverage widens the range (physics.md section 3)
    assert tip["p_max_pa"] > whole_report["p_max_pa"] and tip["p_min_pa"] > whole_report["p_min_pa"]


def test_out_writes_plots_csv_and_json(tmp_path, capsys):
    out = tmp_path / "range"
    assert run_sim.main(["range", "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert "dynamic range" in text and "wrote" in text
    for name in ("output_vs_pressure.png", "resolution_vs_pressure.png", "gel_vs_pressure.png"):
        path = out / name
        assert path.is_file() and path.stat().st_size > 1000, name
        assert path.read_bytes()[:8] == PNG_MAGIC, name
    with (out / "range_curves.csv").open() as fh:
        rows = list(csv.reader(fh))
    header = rows[0]
    assert header[0] == "pressure_pa"
    # every column names its unit or is the dimensionless V_1
    for col in header[1:]:
        assert col.startswith("v1_") or any(u in col for u in ("_pa_", "_n_m3_", "_n_s_m3_")), col
    assert {f"v1_mode{m}" for m in (1, 2, 3, 4)} <= set(header)
    assert len(rows) > 100 and all(len(r) == len(header) for r in rows)
    assert all(math.isfinite(float(v)) for v in rows[1][:2])
    r = _strict((out / "range.json").read_text())
    assert set(r) == KEYS


@pytest.mark.parametrize(
    ("x1", "x2", "shown"),
    # The error repeats the values in the millimetres the user typed.
    [("5", "3", ("got 5 3",)), ("-1", "3", ("got -1 3",)), ("0", "9", ("got 0 9",)), ("2", "nan", ("nan",))],
)
def test_bad_coverage_exits_2_naming_the_values(capsys, x1, x2, shown):
    assert run_sim.main(["range", "--coverage", x1, x2]) == 2
    out, err = capsys.readouterr()
    assert out == ""
    assert err.startswith("error:") and "coverage" in err
    assert len(err.strip().splitlines()) == 1
    for s in shown:
        assert s in err, err


def test_malformed_coverage_is_an_argparse_error(capsys):
    with pytest.raises(SystemExit) as exc:
        run_sim.main(["range", "--coverage", "abc", "3"])
    assert exc.value.code == 2
    assert "coverage" in capsys.readouterr().err
