"""The command line's exit codes (piezotip.cli's docstring): 0 success, 1 another outcome, 2 bad input
or environment in one line, 3 an internal error in one line with its traceback in a file, 130
Ctrl-C; the bounds on ``--set`` values and the parameter ranges the model is built for; the
console script's name in its usage."""

from __future__ import annotations

import json
import math
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
import pytest

from piezotip import cli, scenarios
from piezotip.cosim import build_checks
from piezotip.scenarios.config import MAX_VALUE_CHARS, MIN_COVERAGE_MM, MIN_QUALITY_FACTOR, parse_value

ROOT = Path(__file__).resolve().parent.parent


def exits(capsys, argv, code):
    """Run ``argv`` in this process; assert the exit code; return stderr (stripped)."""
    got = cli.main(argv)
    err = capsys.readouterr().err.strip()
    assert got == code, (got, err[-2000:])
    return err


def one_error_line(err: str, *words: str) -> None:
    assert err.startswith("error: ") and "\n" not in err and "Traceback" not in err, err[:2000]
    assert len(err) < 1000, len(err)  # one short line, whatever was given
    for word in words:
        assert word in err, (word, err)


# --- 2: bad input, one line naming it ---------------------------------------------------------


@pytest.mark.parametrize(
    ("assignment", "words"),
    [
        # the fuzzer's finds: each a KeyError deep in the mode selector, a TypeError in the parser,
        # an OverflowError, a run that cannot finish, or a traceback after 43 s
        ("sensor.quality_factor=1e-3", ["sensor.quality_factor", "at least 50"]),
        ("sensor.quality_factor=1", ["sensor.quality_factor", "at least 50"]),
        ("sensor.quality_factor=1e12", ["sensor.quality_factor", "tau0"]),
        ("sensor.quality_factor=1e6", ["sensor.quality_factor", "84.5 s", "never read trusted"]),
        ("sensor.coverage_mm=(0,1e-9)", ["sensor.coverage_mm", "at least 0.2 mm"]),
        ("sensor.coverage_mm=(0,1)", ["controller.modes", "sensor.coverage_mm=(0.0, 1.0)", "4, 3, 2, 1"]),
        ("sensor.coverage_mm=(3,3.5)", ["controller.modes", "no switch pressure from mode 1 up to mode 2"]),
        ("controller.modes=[" + "1," * 60_000 + "1]", ["controller.modes", "120003 characters"]),
        ("controller.modes=[1, 1, 2]", ["controller.modes", "each mode once", "[1] repeated"]),
        ("sensor.modes=[1, 2, 3, 4, 4]", ["sensor.modes", "each mode once"]),
        ("controller.modes=[0]", ["controller.modes", "1..30"]),
        ("duration_s={{}}", ["duration_s", "a mapping or a set"]),
        ("duration_s={[1]:2}", ["duration_s", "a mapping or a set"]),
        ("object.mass_kg={1, 2}", ["object.mass_kg", "a mapping or a set"]),
        ("duration_s=" + "1+" * 60_000, ["duration_s", "120000 characters"]),
        ("duration_s=" + "1+" * 4_000 + "1", ["duration_s", "expected a number", "(8003 characters)"]),
        ("duration_s=" + "-" * 5_000 + "1", ["duration_s", "expected a number"]),
        ("duration_s=10**400", ["duration_s", "10**400"]),
        ("duration_s=1" + "0" * 400, ["duration_s", "too large a number"]),
        ("duration_s=" + "9" * 100_000, ["duration_s", "100000 characters"]),
        ("controller.modes=[[[[[1]]]]]", ["controller.modes", "5 brackets deep"]),
        ("duration_s=1e6", ["duration_s", "control periods"]),
        ("physics.control_period_s=1e6", ["physics.control_period_s", "at most 0.02 s"]),
        ("physics.control_period_s=1.7976931348623157e308", ["physics.control_period_s", "at most 0.02 s"]),
        ("sensor.damage_coupling=1e300", ["sensor.damage_coupling", "(0, 1]"]),
        ("sensor.damage_damping=1e5", ["sensor.damage_damping", "critical damping"]),
        ("sensor.seed=-1", ["sensor.seed", "0..2**63-1"]),
        ("sensor.unit_seed=" + str(2**64), ["sensor.unit_seed", "0..2**63-1"]),
        ("controller.persist=1000000", ["controller.persist", "at most 1 s"]),
        ("object.shape=--out=x", ["object.shape", "--out=x"]),
    ],
)
def test_bad_values_are_one_line_naming_them_and_exit_2(capsys, tmp_path, assignment, words):
    err = exits(capsys, ["run", "grasp", "--no-plot", "--out", str(tmp_path), "--set", assignment], 2)
    one_error_line(err, *words)
    assert not any(tmp_path.iterdir())  # refused before anything was written


def test_a_sweeps_grid_values_are_bounded_and_name_their_key(capsys, tmp_path):
    err = exits(capsys, ["sweep", "grasp", "--grid", "sensor.seed=" + "9" * 20_000 + ",1", "--workers", "0", "--out", str(tmp_path)], 2)
    one_error_line(err, "sensor.seed", "20000 characters")
    err = exits(capsys, ["sweep", "grasp", "--grid", "controller.modes=[1, 1],[2]", "--workers", "0", "--out", str(tmp_path)], 2)
    one_error_line(err, "controller.modes", "each mode once")


def test_a_grid_too_large_or_too_many_workers_is_refused_before_anything_starts(capsys, tmp_path):
    values = ",".join(str(0.1 + i * 1e-4) for i in range(400))
    argv = ["sweep", "grasp", "--grid", f"object.mass_kg={values}", "--grid", f"object.friction={values}", "--workers", "0"]
    err = exits(capsys, [*argv, "--out", str(tmp_path / "a")], 2)
    one_error_line(err, "--grid", "400 x 400 = 160000 points")
    err = exits(capsys, ["sweep", "grasp", "--grid", "object.mass_kg=0.1", "--workers", "100000", "--out", str(tmp_path / "b")], 2)
    one_error_line(err, "--workers", "100000")
    err = exits(capsys, ["range", "--units", "2", "--workers", "100000"], 2)
    one_error_line(err, "--workers", "100000")


def test_the_experiment_refuses_bad_overrides_in_one_line(capsys, tmp_path):
    err = exits(capsys, ["experiment", "grasp-range", "--workers", "0", "--out", str(tmp_path), "--set", "sensor.quality_factor=1"], 2)
    one_error_line(err, "sensor.quality_factor")


def test_a_missing_dependency_is_the_environment_exit_2(capsys, tmp_path, monkeypatch):
    import piezotip.analysis.runner as runner

    def missing(*args, **kwargs):
        raise ModuleNotFoundError("No module named 'pyarrow'", name="pyarrow")

    monkeypatch.setattr(runner, "run_scenario", missing)
    err = exits(capsys, ["run", "grasp", "--out", str(tmp_path)], 2)
    one_error_line(err, "pyarrow", "dependency")


# --- 3: an internal error, one line and a traceback file ---------------------------------------


def _crash(*args, **kwargs):
    raise KeyError((1, 2))


@pytest.fixture
def crashing_run(monkeypatch):
    import piezotip.analysis.runner as runner

    monkeypatch.setattr(runner, "run_scenario", _crash)


def test_an_internal_error_is_exit_3_one_line_and_a_traceback_in_the_out_folder(capsys, tmp_path, crashing_run):
    err = exits(capsys, ["run", "grasp", "--out", str(tmp_path)], 3)
    assert "\n" not in err and "Traceback" not in err, err
    assert err.startswith("internal error: KeyError: (1, 2)") and "a bug in piezotip" in err, err
    path = tmp_path / "traceback.txt"
    assert err.endswith(f"traceback in {path})")
    text = path.read_text()
    assert text.startswith("Traceback (most recent call last):") and "_crash" in text and text.rstrip().endswith("KeyError: (1, 2)")


def test_without_an_out_folder_the_traceback_goes_to_a_temporary_file(capsys, tmp_path, monkeypatch, crashing_run):
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    monkeypatch.chdir(tmp_path)
    err = exits(capsys, ["run", "grasp"], 3)
    path = tmp_path / f"piezotip-traceback-{os.getpid()}.txt"
    assert err == f"internal error: KeyError: (1, 2) (a bug in piezotip; traceback in {path})"
    assert "KeyError" in path.read_text()


@pytest.mark.parametrize("where", ["before", "after"])
def test_debug_prints_the_traceback_too(capsys, tmp_path, crashing_run, where):
    argv = ["run", "grasp", "--out", str(tmp_path)]
    argv = ["--debug", *argv] if where == "before" else [*argv, "--debug"]
    err = exits(capsys, argv, 3)
    lines = err.splitlines()
    assert lines[0] == "Traceback (most recent call last):" and "_crash" in err
    assert lines[-1].startswith("internal error: KeyError") and (tmp_path / "traceback.txt").exists()


def test_sweep_and_experiment_crashes_are_exit_3_not_an_outcome(capsys, tmp_path, monkeypatch):
    import piezotip.analysis.experiment as experiment
    import piezotip.analysis.sweep as sweep

    monkeypatch.setattr(sweep, "run_points", _crash)
    monkeypatch.setattr(experiment, "run_experiment", _crash)
    err = exits(capsys, ["sweep", "grasp", "--grid", "object.mass_kg=0.1,0.2", "--workers", "0", "--out", str(tmp_path / "s")], 3)
    assert err.startswith("internal error: KeyError") and (tmp_path / "s" / "traceback.txt").exists()
    err = exits(capsys, ["experiment", "grasp-range", "--workers", "0", "--out", str(tmp_path / "e")], 3)
    assert err.startswith("internal error: KeyError") and (tmp_path / "e" / "traceback.txt").exists()


def test_a_warning_turned_error_or_any_other_exception_is_exit_3(capsys, tmp_path, monkeypatch):
    import piezotip.analysis.runner as runner

    def overflow(*args, **kwargs):
        np.float64(1e308) * np.float64(10)  # RuntimeWarning, an error under pytest's filterwarnings
        raise AssertionError("not reached")

    monkeypatch.setattr(runner, "run_scenario", overflow)
    err = exits(capsys, ["run", "grasp", "--out", str(tmp_path)], 3)
    assert err.startswith("internal error: RuntimeWarning: overflow"), err


def test_the_command_line_process_exits_3_with_one_line(tmp_path):
    """Through a real process: the status, one line on stderr, the file."""
    script = (
        "import sys, piezotip.analysis.runner as r, piezotip.cli as cli\n"
        "def crash(*a, **k): raise ZeroDivisionError('division by zero')\n"
        "r.run_scenario = crash\n"
        f"sys.exit(cli.main(['run', 'grasp', '--out', {str(tmp_path)!r}]))\n"
    )
    proc = subprocess.run([sys.executable, "-c", script], cwd=ROOT, capture_output=True, text=True, timeout=120)
    assert proc.returncode == 3, proc.stderr
    assert proc.stderr.count("\n") == 1 and proc.stderr.startswith("internal error: ZeroDivisionError: division by zero")
    assert "ZeroDivisionError" in (tmp_path / "traceback.txt").read_text()


# --- 0 and 1: outcomes -----------------------------------------------------------------------


def test_a_grasp_that_did_not_succeed_is_exit_1(capsys, tmp_path):
    assert cli.main(["run", "grasp", "--no-plot", "--json", "--out", str(tmp_path), "--set", "duration_s=0.05"]) == 1
    report = json.loads(capsys.readouterr().out)
    assert report["success"] is False and report["outcome"] != "success"


# --- the bounds' derivations ----------------------------------------------------------------


def test_the_quality_factor_bound_is_the_readouts_inference_gain():
    """An unloaded fingertip's inferred reading amplifies the noise by tau0 sqrt(192 dt / W^3)
    (the derivation in SensorConfig's docstring), measured on the readout's own inference."""
    from piezotip.sensor.inference import MAX_GAIN, WINDOW_S, PySteadyInference

    rng = np.random.default_rng(0)
    dt, sigma = 0.005, 1e-3
    for tau0 in (0.66, 2.0, 3.0):
        inference = PySteadyInference(tau0, sigma)
        inference.seed(1 + 0j, 0.0, dt)
        gains = [inference.step(k * dt, 1 + sigma * complex(*rng.standard_normal(2)) / math.sqrt(2))[1] for k in range(1, 300)]
        predicted = tau0 * math.sqrt(192 * dt / WINDOW_S**3)
        assert abs(np.median(gains) / predicted - 1) < 0.1, (tau0, np.median(gains), predicted)
    # The bound: the largest Q whose unloaded reading is trusted (gain <= MAX_GAIN) at 5 ms readings.
    cfg = scenarios.get("grasp", ["sensor.quality_factor=4e4"])
    assert cfg.sensor.quality_factor == 4e4 and MAX_GAIN == 10
    with pytest.raises(ValueError, match=r"at most 4\.27e\+04"):
        scenarios.get("grasp", ["sensor.quality_factor=5e4"])
    with pytest.raises(ValueError, match=r"at most 1\.35e\+05"):  # 10x more readings in the window: sqrt(10)x
        scenarios.get("grasp", ["sensor.quality_factor=2e5", "physics.control_period_s=0.0005", "physics.timestep_s=0.0005"])


def test_below_the_lowest_quality_factor_the_higher_modes_lose_their_switch_pressures():
    """Why Q >= 50: at Q 20 mode 4 is nowhere the most useful mode, at Q 1 only mode 1 is."""
    from piezotip.sensor import ElementParams, Fingertip, GelModel, SensorElement

    def bands(q):
        element = SensorElement(ElementParams()).with_quality_factor(q)
        gel = GelModel(reference_freq_hz=element.natural_frequency_hz(1))
        return [b[0] for b in Fingertip(element=element, gel=gel, coverage=(6.5e-3, 7.5e-3), modes=(1, 2, 3, 4)).mode_bands()]

    assert bands(MIN_QUALITY_FACTOR) == [1, 2, 3, 4]
    assert 4 not in bands(20) and bands(1) == [1]
    assert scenarios.get("grasp", [f"sensor.quality_factor={MIN_QUALITY_FACTOR}"]).sensor.quality_factor == MIN_QUALITY_FACTOR


def test_the_narrowest_coverage_is_the_moulded_edges_tolerance():
    from piezotip.sensor.variation import SPREADS

    assert MIN_COVERAGE_MM == pytest.approx(2 * SPREADS["wide"].coverage_edge_m * 1e3)
    assert scenarios.get("grasp", [f"sensor.coverage_mm=(7.3, {7.3 + MIN_COVERAGE_MM})"]).sensor.coverage_mm[0] == 7.3
    with pytest.raises(ValueError, match=r"sensor\.coverage_mm .* mm wide: at least 0\.2 mm"):
        scenarios.get("grasp", ["sensor.coverage_mm=(7.4, 7.5)"])


def test_a_scripted_grasp_drives_no_mode_selector_so_any_band_order_is_fine():
    cfg = scenarios.get("grasp", ["sensor.coverage_mm=(0, 1)", "controller.kind=scripted"])
    assert cfg.sensor.coverage_mm == (0.0, 1.0)


def test_a_unit_that_cannot_be_built_names_the_sensors_keys():
    bad = [["sensor.variation=wide", f"sensor.unit_seed={seed}", "sensor.coverage_mm=(7.3, 7.5)"] for seed in range(40)]
    messages = []
    for overrides in bad:
        try:
            scenarios.get("grasp", overrides)
        except ValueError as err:
            messages.append(str(err))
    assert messages and all("sensor.variation=wide" in m and "sensor.coverage_mm=(7.3, 7.5)" in m for m in messages), messages[:2]


# --- the value parser -----------------------------------------------------------------------


def test_values_are_bounded_before_they_are_parsed():
    assert parse_value("[1, 2]") == [1, 2] and parse_value("envelope") == "envelope" and parse_value("-1.5") == -1.5
    assert parse_value("[[[[1]]]]") == [[[[1]]]]  # four deep: the limit
    assert parse_value("x" * MAX_VALUE_CHARS) == "x" * MAX_VALUE_CHARS
    with pytest.raises(ValueError, match=r"^k: a value of 10001 characters"):
        parse_value("x" * (MAX_VALUE_CHARS + 1), "k")
    with pytest.raises(ValueError, match="5 brackets deep"):
        parse_value("[[[[[1]]]]]")
    assert parse_value("'[[[[[[[['") == "[[[[[[[["  # brackets inside a quoted string do not nest
    for text in ("{}", "{1: 2}", "{1, 2}", "{{}}", "{[1]: 2}", "[{}]"):
        with pytest.raises(ValueError, match="a mapping or a set"):
            parse_value(text, "k")
    # Too deep for Python's own parser or literal_eval (RecursionError, MemoryError): the text itself.
    for text in ("1+" * 4_000 + "1", "-" * 5_000 + "1", "(" * 4 + "1" + ")" * 4):
        assert parse_value(text) in (text, 1)


def test_a_text_a_mapping_gives_reads_back_as_that_text():
    assert scenarios.override_strings({"object.shape": "{1: 2}"}) == ["object.shape='{1: 2}'"]
    with pytest.raises(ValueError, match=r"object\.shape must be one of .*'\{1: 2\}'"):
        scenarios.get("grasp", {"object.shape": "{1: 2}"})


def test_the_fingertip_check_is_computed_once_per_sensor():
    build_checks._FINGERTIPS.clear()
    for mass in (0.1, 0.2, 0.3):
        scenarios.get("grasp", [f"object.mass_kg={mass}"])
    assert len(build_checks._FINGERTIPS) == 1


# --- the console script's name --------------------------------------------------------------


@pytest.mark.parametrize(
    ("argv0", "prog"),
    [
        ("/usr/local/bin/piezotip", "piezotip"),
        ("piezotip", "piezotip"),
        (r"C:\venv\Scripts\piezotip.exe", "piezotip"),  # the console script on Windows
        ("run_sim.py", "run_sim.py"),
        ("/work/piezotip/cli/__main__.py", "run_sim.py"),  # python -m piezotip.cli
        ("", "run_sim.py"),
    ],
)
def test_the_parser_is_named_as_it_was_invoked(monkeypatch, argv0, prog):
    monkeypatch.setattr(sys, "argv", [argv0])
    parser = cli.build_parser()
    assert parser.prog == prog
    assert parser.format_usage().startswith(f"usage: {prog} ")


def test_the_console_script_names_itself_in_its_help():
    script = shutil.which("piezotip", path=str(Path(sys.executable).parent))
    if script is None:
        pytest.skip("the piezotip console script is not installed beside this Python")
    proc = subprocess.run([script, "--help"], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0 and proc.stdout.startswith("usage: piezotip "), proc.stdout[:200]
    proc = subprocess.run([script, "run", "--help"], capture_output=True, text=True, timeout=120)
    assert proc.stdout.startswith("usage: piezotip run "), proc.stdout[:200]
    proc = subprocess.run([sys.executable, "run_sim.py", "--help"], cwd=ROOT, capture_output=True, text=True, timeout=120)
    assert proc.stdout.startswith("usage: run_sim.py "), proc.stdout[:200]
