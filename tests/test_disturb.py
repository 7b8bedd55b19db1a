"""A load change while held (issue 43, item 4: ``grasp-disturb``, the ``disturb.*`` keys, the
referee's ``disturb_*``) and the referee's touch in every output (item 5: ``touch_peak_n``,
``time_to_touch_s`` in ``run --json``, summary.json, the API, a sweep's files, the experiment).

The synthetic-record tests of the referee's numbers are in tests/test_referee.py; here the
loop's schedule against hand-computed numbers, the keys' checks, and whole runs."""

import itertools
import json
import math

import numpy as np
import pytest

import piezotip
from piezotip import cli, scenarios
from piezotip.analysis.referee import disturb_onset_s
from piezotip.analysis.sweep_output import read_csv_rows
from piezotip.cosim.disturb import onset_s, ramp_share
from piezotip.cosim.loop import CoSimulation
from piezotip.scenarios.config import MAX_EXTRA_LOAD_N, valid_keys

DISTURB_KEYS = ("disturb_slip_mm", "disturb_reaction_ms", "disturb_hold_grip_n", "disturb_needed_grip_n", "disturb_grip_margin")
TOUCH_KEYS = ("touch_peak_n", "time_to_touch_s")

#: The box's weight and the grip that holds it with its weight again on it, (m g + m g) / (2 mu):
#: 0.1 kg x 9.81 m/s^2 = 0.981 N; 1.962 N / (2 x 1) = 0.981 N per finger.
BOX_WEIGHT_N = 0.981
NEEDED_UNDER_LOAD_N = 0.981

#: The issue's goals for the answer to the load (reported, met or not).
GOAL_SLIP_MM = 2.0
GOAL_REACTION_MS = 40.0
GOAL_MARGIN = 1.5


# -- the scenario and its keys ---------------------------------------------------------------


def test_the_scenario_is_listed_with_the_objects_weight_as_its_load(capsys):
    assert cli.main(["list"]) == 0
    assert "grasp-disturb" in capsys.readouterr().out
    config = scenarios.get("grasp-disturb")
    assert config.disturb.extra_load_n is None and config.disturb.ramp_s == 0.05 and config.disturb.active
    assert config.object == scenarios.get("grasp").object  # the default job's box


@pytest.mark.parametrize("name", scenarios.names())
def test_every_scenario_has_the_disturb_keys_and_only_grasp_disturb_is_disturbed(name):
    config = scenarios.get(name)
    assert {"disturb.extra_load_n", "disturb.ramp_s"} <= set(valid_keys(config))
    assert config.disturb.active == (name == "grasp-disturb")


def test_the_keys_take_a_load_none_and_a_ramp():
    config = scenarios.get("grasp", ["disturb.extra_load_n=2.5", "disturb.ramp_s=0.02"])
    assert (config.disturb.extra_load_n, config.disturb.ramp_s) == (2.5, 0.02) and config.disturb.active
    assert scenarios.get("grasp", ["disturb.extra_load_n=None"]).disturb.load_n(BOX_WEIGHT_N) == BOX_WEIGHT_N
    assert not scenarios.get("grasp-disturb", ["disturb.extra_load_n=0"]).disturb.active


@pytest.mark.parametrize(
    ("assignment", "named"),
    [
        ("disturb.extra_load_n=-1", "-1"),
        ("disturb.extra_load_n=nan", "nan"),
        ("disturb.extra_load_n=1e400", "inf"),
        (f"disturb.extra_load_n={2 * MAX_EXTRA_LOAD_N}", f"{2 * MAX_EXTRA_LOAD_N!r}"),
        ("disturb.extra_load_n=heavy", "heavy"),
        ("disturb.ramp_s=0", "0"),
        ("disturb.ramp_s=-0.05", "-0.05"),
        ("disturb.ramp_s=nan", "nan"),
        ("disturb.ramp_s=None", "None"),
    ],
)
def test_bad_disturb_values_name_the_key_and_the_value(assignment, named, capsys, tmp_path):
    key = assignment.partition("=")[0]
    with pytest.raises(ValueError, match=key.replace(".", r"\.")) as err:
        scenarios.get("grasp-disturb", [assignment])
    assert named in str(err.value)
    # the command line: one line naming the key, exit status 2, nothing run
    assert cli.main(["run", "grasp-disturb", "--set", assignment, "--out", str(tmp_path / "never")]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and key in lines[0]
    assert not (tmp_path / "never" / "run.npz").exists()


def test_a_config_made_directly_is_checked_too():
    from piezotip.scenarios.config import DisturbConfig

    for bad in ({"ramp_s": math.nan}, {"ramp_s": math.inf}, {"extra_load_n": math.nan}, {"extra_load_n": True}):
        key = f"disturb.{next(iter(bad))}"
        with pytest.raises(ValueError, match=key.replace(".", r"\.")):
            DisturbConfig(**bad)


def test_a_bad_value_reads_its_range():
    with pytest.raises(ValueError, match=rf"within 0-{MAX_EXTRA_LOAD_N:g} N"):
        scenarios.get("grasp-disturb", ["disturb.extra_load_n=-0.5"])
    with pytest.raises(ValueError, match="positive number of seconds"):
        scenarios.get("grasp-disturb", ["disturb.ramp_s=0"])


# -- the loop's schedule ----------------------------------------------------------------------


def test_the_ramps_mean_share_over_a_period_against_hand_numbers():
    # A ramp from 0 at 1 s to 1 at 1.05 s: over its first 5 ms the load climbs 0 -> 0.1 (mean
    # 0.05); over 1.045-1.055 s it is 0.9 -> 1 then 1 (mean 0.975); before, 0; after, 1.
    assert ramp_share(1.0, 1.005, 1.0, 0.05) == pytest.approx(0.05, rel=1e-12)
    assert ramp_share(1.045, 1.055, 1.0, 0.05) == pytest.approx(0.975, rel=1e-12)
    assert ramp_share(0.9, 0.995, 1.0, 0.05) == 0.0
    assert ramp_share(1.2, 1.205, 1.0, 0.05) == pytest.approx(1.0)
    # A ramp shorter than a period: rising over 2 ms of a 5 ms period (1 ms at full load, on
    # average) and on for the other 3 ms: mean (1 ms + 3 ms) / 5 ms = 0.8.
    assert ramp_share(1.0, 1.005, 1.0, 0.002) == pytest.approx(0.8, rel=1e-12)
    # Period by period the impulse is the ramp's: 0.025 s at full load for the rise, then the rest.
    edges = 1.0 + 0.005 * np.arange(21)
    impulse = sum(0.005 * ramp_share(a, b, 1.0, 0.05) for a, b in itertools.pairwise(edges))
    assert impulse == pytest.approx(0.025 + 0.05, rel=1e-12)
    with pytest.raises(ValueError, match="t1_s > t0_s"):
        ramp_share(1.0, 1.0, 1.0, 0.05)
    assert onset_s(4.75, 1.0) == 5.25


def _stepped(config) -> tuple[CoSimulation, dict[str, np.ndarray], np.ndarray]:
    """Run ``config`` step by step: the simulation, its record, and the load (N, down positive)
    applied over the period after each recorded step."""
    sim = CoSimulation(config)
    body = sim.model.body("object").id
    rows, loads = [], []
    for _ in range(round(config.duration_s / config.physics.control_period_s)):
        rows.append(sim.step())
        loads.append(-float(sim.data.xfrc_applied[body, 2]))
        if sim.controller.finished:
            break
    record = {k: np.array([r[k] for r in rows]) for k in rows[0]}
    return sim, record, np.array(loads)


def test_the_loop_puts_the_load_on_at_the_middle_of_the_recorded_hold():
    config = scenarios.get("grasp-disturb", ["controller.kind=multimode", "disturb.ramp_s=0.02"], preset="fast")
    sim, record, loads = _stepped(config)
    t, dt = record["time_s"], config.physics.control_period_s
    # The referee finds the onset in the record where the loop put it: the first hold sample + 0.5 s.
    onset = disturb_onset_s(t, record["phase"], config.controller.hold_s)
    assert onset == sim.disturbance.onset_s
    assert onset == pytest.approx(t[np.argmax(record["phase"] == 4)] + 0.5)
    weight = float(sim.model.body("object").mass[0]) * 9.81
    assert sim.disturbance.load_n == pytest.approx(weight) == pytest.approx(BOX_WEIGHT_N)
    # Each period's load is the ramp's mean over it: nothing before the onset, the full weight
    # from a period past the ramp's end on, in between a 4-step staircase (0.02 s over 5 ms).
    expected = np.array([weight * ramp_share(a, a + dt, onset, 0.02) for a in t])
    np.testing.assert_allclose(loads, expected, rtol=1e-12, atol=0)
    assert loads[t < onset - 1e-9].max() == 0.0
    ramping = (t >= onset - 1e-9) & (t < onset + 0.02 - 1e-9)
    np.testing.assert_allclose(loads[ramping] / weight, [0.125, 0.375, 0.625, 0.875], rtol=1e-9)
    assert np.all(loads[t >= onset + 0.02 - 1e-9] == pytest.approx(weight))


def test_a_scenario_without_a_disturbance_applies_none():
    sim = CoSimulation(scenarios.get("grasp"))
    assert sim.disturbance is None and "_actuate" not in vars(sim)
    assert not np.any(sim.data.xfrc_applied)


# -- whole runs -------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def runs():
    """grasp-disturb with the default (gentle) controller and the multimode one: the summaries."""
    found = {}
    for kind in ("gentle", "multimode"):
        found[kind] = dict(piezotip.run("grasp-disturb", overrides={"controller.kind": kind}).summary)
    return found


@pytest.mark.slow
@pytest.mark.parametrize("kind", ["gentle", "multimode"])
def test_grasp_disturb_runs_headless_and_the_referee_measures_the_answer(runs, kind):
    s = runs[kind]
    assert s["disturb_needed_grip_n"] == pytest.approx(NEEDED_UNDER_LOAD_N, rel=1e-9)
    assert s["needed_grip_n"] == pytest.approx(NEEDED_UNDER_LOAD_N / 2, rel=1e-9)
    assert math.isfinite(s["disturb_slip_mm"]) and math.isfinite(s["disturb_hold_grip_n"]) and math.isfinite(s["disturb_grip_margin"])
    # the margin is the new hold over the new need, and the hold happened before the load came
    assert s["disturb_grip_margin"] == pytest.approx(s["disturb_hold_grip_n"] / s["disturb_needed_grip_n"])
    assert s["held_s"] > 0.5


@pytest.mark.slow
@pytest.mark.parametrize("kind", ["gentle", "multimode"])
def test_the_box_is_held_through_the_load_change(runs, kind):
    s = runs[kind]
    assert s["outcome"] == "success", s["reason"]
    assert not s["dropped"] and math.isfinite(s["disturb_reaction_ms"])
    assert s["disturb_hold_grip_n"] >= s["disturb_needed_grip_n"]  # the new hold holds


def _goal(kind: str, name: str, measured: str):
    return pytest.param(kind, name, marks=pytest.mark.xfail(strict=True, reason=f"{kind}: {name} {measured} (measured, mujoco 4.0.0)"))


@pytest.mark.slow
@pytest.mark.parametrize(
    ("kind", "goal"),
    [
        ("gentle", "slip"),  # 0.00 mm: the hold follows the load read each period (GentleGrasp._follow_load)
        ("gentle", "reaction"),  # 20 ms
        ("gentle", "margin"),  # 1.29x
        ("multimode", "slip"),  # 0.001 mm
        _goal("multimode", "reaction", "70 ms: its grip follows the lift's load through a 50 ms filter (over 40 ms)"),
        _goal("multimode", "margin", "1.56x: 1.53 N where 0.981 N holds the box (over 1.5x)"),
    ],
)
def test_the_issues_goals_for_the_answer(runs, kind, goal):
    """Slip <= 2 mm, a reaction within 40 ms, the new hold within 1-1.5x of the new need; where a
    controller misses one, the strict xfail says by how much."""
    s = runs[kind]
    if goal == "slip":
        assert s["disturb_slip_mm"] <= GOAL_SLIP_MM
    elif goal == "reaction":
        assert s["disturb_reaction_ms"] is not None and s["disturb_reaction_ms"] <= GOAL_REACTION_MS
    else:
        assert 1.0 <= s["disturb_grip_margin"] <= GOAL_MARGIN


@pytest.mark.slow
def test_the_reaction_is_at_least_a_control_period_and_grows_with_it():
    """The controller answers once a period, so no reaction is shorter than one period, and a
    longer period answers later: the multimode controller (the gentle one never answers in time:
    above), at 5 and 10 ms (measured: 70 and 80 ms)."""
    reaction = {}
    for period in (0.005, 0.01):
        s = piezotip.run("grasp-disturb", {"controller.kind": "multimode", "physics.control_period_s": period}).summary
        assert s["outcome"] == "success", s["reason"]
        reaction[period] = s["disturb_reaction_ms"]
        assert reaction[period] >= 1e3 * period - 1e-9
    assert reaction[0.01] > reaction[0.005]


# -- the touch and the disturbance in every output (item 5) ------------------------------------


@pytest.mark.slow
def test_the_keys_are_in_run_json_summary_json_and_the_api(tmp_path, capsys):
    out = tmp_path / "run"
    assert cli.main(["run", "grasp", "--preset", "fast", "--json", "--no-plot", "--out", str(out)]) == 0
    printed = json.loads(capsys.readouterr().out)
    written = json.loads((out / "summary.json").read_text())
    api = piezotip.run("grasp", preset="fast").summary
    data = np.load(out / "run.npz")
    # Independently of the referee: the first sample either finger pushes the object, less the
    # first sample in the close phase; the largest force between it and 2 mm of rise.
    t, phase = data["time_s"], data["phase"]
    force = np.maximum(data["left_finger_force_n"], data["right_finger_force_n"])
    contact = int(np.argmax(force > 1e-6))
    lifted = contact + int(np.argmax(data["object_height_m"][contact:] - data["object_height_m"][0] > 0.002))
    for summary in (printed, written, api):
        assert set(TOUCH_KEYS + DISTURB_KEYS) <= set(summary)
        assert summary["time_to_touch_s"] == pytest.approx(t[contact] - t[np.argmax(phase == 1)], abs=1e-12)
        assert summary["touch_peak_n"] == pytest.approx(force[contact:lifted].max(), rel=1e-12)
        assert all(summary[k] is None or math.isnan(summary[k]) for k in DISTURB_KEYS)  # no load change: null
    assert 0 < printed["touch_peak_n"] <= printed["peak_contact_n"]
    assert printed["time_to_touch_s"] > 0


@pytest.mark.slow
def test_the_printed_summary_says_the_touch_and_the_answer_to_the_load(tmp_path, capsys):
    argv = ["run", "grasp-disturb", "--set", "controller.kind=multimode", "--preset", "fast", "--no-plot"]
    assert cli.main([*argv, "--out", str(tmp_path / "text")]) == 0
    text = capsys.readouterr().out
    assert "touch: first contact" in text and "N at most before lift-off" in text
    assert "load change: moved" in text and "ms after the onset" in text and "where 0.981 N holds it" in text
    assert cli.main(["run", "grasp", "--preset", "fast", "--no-plot", "--out", str(tmp_path / "quiet")]) == 0
    assert "load change" not in capsys.readouterr().out


@pytest.mark.slow
def test_the_sweeps_csv_and_parquet_carry_the_columns(tmp_path, capsys):
    import pyarrow.parquet as pq

    out = tmp_path / "sweep"
    argv = ["sweep", "grasp-disturb", "--grid", "disturb.extra_load_n=0,None", "--set", "controller.kind=multimode"]
    assert cli.main([*argv, "--preset", "fast", "--workers", "0", "--no-plot", "--out", str(out), "--json"]) == 0
    capsys.readouterr()
    rows = read_csv_rows(out / "sweep.csv")  # its "# " header lines skipped
    header = list(rows[0])
    table = pq.read_table(out / "sweep.parquet")
    for column in (*TOUCH_KEYS, *DISTURB_KEYS):
        assert column in header and column in table.column_names
    quiet, loaded = table.to_pylist()  # extra_load_n 0 (none), then None (the box's weight)
    assert quiet["disturb_needed_grip_n"] is None and rows[0]["disturb_needed_grip_n"] == "nan"  # Parquet's null, the CSV's nan
    assert loaded["disturb_needed_grip_n"] == pytest.approx(NEEDED_UNDER_LOAD_N, rel=1e-9)
    assert loaded["disturb_slip_mm"] < GOAL_SLIP_MM and loaded["disturb_reaction_ms"] > 0
    assert quiet["touch_peak_n"] == loaded["touch_peak_n"] > 0  # the same grasp up to the hold


@pytest.mark.slow
def test_the_grasp_range_table_shows_the_touch_per_object(tmp_path):
    from piezotip.analysis import experiment

    box = next(o for o in experiment.OBJECTS if o.name == "box-100g")
    gentle = next(c for c in experiment.experiment_controllers() if c[0] == "gentle")
    result = experiment.run_experiment("fast", objects=(box,), controllers=(gentle,), workers=0, progress=False)
    (row,) = result.rows
    files = experiment.write_outputs(result.rows, tmp_path, plot=False)
    assert tuple(read_csv_rows(files[0])[0]) == experiment.COLUMNS
    assert set(TOUCH_KEYS) <= set(experiment.COLUMNS)
    units = json.loads(files[1].read_text())["units"]
    assert units["touch_peak_n"].startswith("N") and units["time_to_touch_s"].startswith("s")
    # the experiment's box is the grasp scenario's: the same touch as the API's run of it
    api = piezotip.run("grasp", preset="fast").summary
    assert row["touch_peak_n"] == api["touch_peak_n"] and row["time_to_touch_s"] == api["time_to_touch_s"]
    text = experiment.format_table(result.rows)
    assert "touch [N]" in text.splitlines()[0] and "to touch [s]" in text.splitlines()[0]
    assert f"{row['touch_peak_n']:.3g}" in text.splitlines()[2] and f"{row['time_to_touch_s']:.3f}" in text.splitlines()[2]
