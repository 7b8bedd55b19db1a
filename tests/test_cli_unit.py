"""`run_sim.py range` with a physical unit and its Monte Carlo; a grasp with a varied unit."""

import io
import json
import math
from contextlib import redirect_stderr, redirect_stdout

import pytest
from test_cli_range import KEYS, MODE_KEYS, _strict

from piezotip import cli as run_sim


def _run(argv: list[str]) -> tuple[int, str, str]:
    out, err = io.StringIO(), io.StringIO()
    with redirect_stdout(out), redirect_stderr(err):
        rc = run_sim.main(argv)
    return rc, out.getvalue(), err.getvalue()


def test_range_of_a_unit_reports_todays_keys_and_its_error():
    rc, out, _ = _run(["range", "--variation", "typical", "--unit-seed", "3", "--calibration", "full", "--json"])
    assert rc == 0
    r = _strict(out)
    assert KEYS <= set(r)
    assert set(r) - KEYS == {"max_estimate_error", "calibration", "unit", "temperature_estimate_c"}
    assert all(MODE_KEYS | {"drive_freq_hz"} == set(m) for m in r["modes"])
    assert r["calibration"]["level"] == "full"
    assert r["unit"] == {**r["unit"], "variation": "typical", "unit_seed": 3, "temperature_c": 25.0}
    assert 0 < r["max_estimate_error"] < 0.02
    assert r["dynamic_range"] >= 1e4
    # the same unit, the same numbers
    assert _strict(_run(["range", "--variation", "typical", "--unit-seed", "3", "--calibration", "full", "--json"])[1]) == r


def test_uncalibrated_unit_has_no_estimate():
    rc, out, _ = _run(["range", "--variation", "typical", "--unit-seed", "3", "--calibration", "none", "--temperature-c", "30", "--json"])
    assert rc == 0
    r = _strict(out)
    assert r["max_estimate_error"] is None or r["max_estimate_error"] > 0.5  # inf is null in strict JSON


def test_monte_carlo_yield():
    rc, out, _ = _run(["range", "--units", "4", "--variation", "typical", "--calibration", "full", "--json", "--workers", "1"])
    assert rc == 0
    r = _strict(out)
    assert r["n_units"] == 4 and len(r["units"]) == 4
    assert [u["unit_seed"] for u in r["units"]] == [0, 1, 2, 3]
    good = [u["dynamic_range"] >= 1e4 and u["max_estimate_error"] <= 0.05 for u in r["units"]]
    assert r["yield"] == sum(good) / 4
    for key in ("p_min_pa", "p_max_pa", "dynamic_range", "max_estimate_error"):
        q = r["summary"][key]
        assert q["min"] <= q["median"] <= q["max"]


@pytest.mark.parametrize(
    "argv, text",
    [
        (["range", "--variation", "huge"], "huge"),
        (["range", "--variation", "typical", "--unit-seed", "-2"], "-2"),
        (["range", "--variation", "typical", "--calibration", "bench"], "bench"),
        (["range", "--variation", "typical", "--temperature-c", "-40"], "-40"),
        (["range", "--units", "0", "--variation", "typical"], "0"),
        (["run", "grasp", "--set", "sensor.variation=huge"], "huge"),
        (["run", "grasp", "--set", "sensor.temperature_c=95"], "95"),
    ],
)
def test_bad_unit_input_is_one_line_and_exit_2(argv, text):
    rc, _, err = _run(argv)
    assert rc == 2
    assert err.count("\n") == 1 and text in err


def test_grasp_with_a_varied_unit_succeeds(tmp_path):
    from piezotip.analysis.runner import run_scenario

    report, _ = run_scenario("grasp", ["sensor.variation=typical", "sensor.unit_seed=2"], tmp_path, plot=False, quiet=True)
    assert report["success"], report.get("outcome")


def test_default_config_runs_the_nominal_model():
    from piezotip import scenarios
    from piezotip.cosim.loop import make_fingertip, make_unit

    config = scenarios.get("grasp")
    assert make_unit(config) is None
    assert math.isclose(make_fingertip(config).freq_hz(1), 3768.0, rel_tol=1e-3)
    assert json.dumps(config.sensor.unit_config().__dict__)  # plain values
