"""Plots a person reads the grasp from (issue 29, item 6): the run plot draws only "ok" estimates,
with the true force against the grip needed and the crush limit; the run's progress bar ends
full; the experiment's grip margin is grouped bars per object; the sweep row says which sense
felt the touch."""

import dataclasses
import math

import numpy as np
import pytest

from piezotip import scenarios
from piezotip.analysis import experiment, run_report
from piezotip.analysis.sweep_rows import point_row, touch_sense
from piezotip.cosim.rows import STATUS_CODES

STEPS = 120  # a short stretch of the grasp: the plot draws whatever is recorded


@pytest.fixture(scope="module")
def recorded(tmp_path_factory):
    """(config, fingertip, data) of a short real run, its readings rewritten to a known pattern:
    every status in turn, a positive estimate at every step (so a reading drawn where it must
    not be would show), the fingers on the object in the middle third only."""
    from piezotip.cosim.loop import CoSimulation
    from piezotip.cosim.recorder import Recorder

    config = scenarios.get("grasp", [], "fast")
    sim = CoSimulation(config)
    recorder = Recorder(tmp_path_factory.mktemp("plot-run") / "run")
    sim.run(recorder, max_steps=STEPS)
    data = dict(recorder.data())
    n = data["time_s"].size
    for k, side in enumerate(config.sensor.pads):
        data[f"{side}_status"] = ((np.arange(n) // 7 + k) % len(STATUS_CODES)).astype(float)
        data[f"{side}_estimate_pa"] = 100.0 + 10.0 * np.arange(n)
        data[f"{side}_uncertainty_pa"] = np.full(n, 5.0)
    touching = (np.arange(n) >= n // 3) & (np.arange(n) < 2 * n // 3)
    for finger in ("left", "right"):
        data[f"{finger}_finger_force_n"] = np.where(touching, 1.2, 0.0)
    data["grip_force_n"] = np.full(n, 0.4)  # the servo's drive, closing on nothing most of the time
    return config, sim.fingertip, data


REPORT = {
    "outcome": "success",
    "reason": "lifted, held, placed, released",
    "success": True,
    "hold_grip_n": 1.1,
    "needed_grip_n": 0.49,
    "grip_margin": 1.1 / 0.49,
}


def _axes(fig, ylabel: str):
    return next(ax for ax in fig.axes if ax.get_ylabel().startswith(ylabel))


def test_only_ok_readings_are_drawn_as_estimates(recorded):
    config, tip, data = recorded
    fig = run_report.run_figure(config, tip, data, REPORT)
    ax_p = _axes(fig, "pressure on element")
    for side in config.sensor.pads:
        ok = data[f"{side}_status"] == STATUS_CODES.index("ok")
        assert ok.any() and (~ok).any()
        drawn = [ln for ln in ax_p.lines if ln.get_label().startswith(f"{side}: estimate")]
        assert drawn, [ln.get_label() for ln in ax_p.lines]
        for line in drawn:
            x, y = (np.asarray(v, dtype=float) for v in line.get_data())
            shown = np.isfinite(x) & np.isfinite(y)
            assert shown.any()
            # every point drawn is at an "ok" step, with that step's estimate
            on_ok = np.isin(x[shown], data["time_s"][ok])
            assert on_ok.all(), f"{side}: {np.count_nonzero(~on_ok)} estimates drawn at a status that is not ok"
        # the band (estimate -+ 3 sigma) and the points: nothing where the status is not ok
        r = run_report.estimate_readings(data, side)
        assert np.array_equal(r["ok"], ok)
        assert np.isnan(r["estimate"][~ok]).all() and np.isnan(r["low"][~ok]).all() and np.isnan(r["high"][~ok]).all()
        np.testing.assert_allclose(r["high"][ok] - r["estimate"][ok], 3 * 5.0)
        np.testing.assert_allclose(r["estimate"][ok] - r["low"][ok], 3 * 5.0)


def test_force_panel_draws_the_truth_the_needed_grip_and_the_crush_limit(recorded):
    config, tip, data = recorded
    crushable = dataclasses.replace(config, object=dataclasses.replace(config.object, crush_force_n=2.0))
    fig = run_report.run_figure(crushable, tip, data, REPORT)
    ax_f = _axes(fig, "force on the object")
    levels = {float(ln.get_ydata()[0]): ln.get_label() for ln in ax_f.lines if np.ptp(np.asarray(ln.get_ydata(), float)) == 0}
    assert 0.49 in levels and "needed grip" in levels[0.49] and "2.24x" in levels[0.49]
    assert 2.0 in levels and "crush" in levels[2.0]
    labels = [ln.get_label() for ln in ax_f.lines]
    assert any("left finger" in lab and "true" in lab for lab in labels) and any("right finger" in lab for lab in labels)
    # the servo's drive is never called a grip, and is drawn only while the fingers touch
    assert [lab for lab in labels if "grip" in lab] == [levels[0.49]]
    drive = next(ln for ln in ax_f.lines if "drive" in ln.get_label())
    touching = data["left_finger_force_n"] > 0
    y = np.asarray(drive.get_ydata(), dtype=float)
    assert np.isnan(y[~touching]).all() and np.isfinite(y[touching]).all()
    assert "grip margin 2.24x" in fig.axes[0].get_title()
    # a crush limit far over every force drawn: written off the scale, the forces keep theirs
    largest = max(float(np.nanmax(data[k])) for k in ("left_finger_force_n", "right_finger_force_n", "grip_force_n"))
    robust = dataclasses.replace(config, object=dataclasses.replace(config.object, crush_force_n=100.0 * largest))
    ax_f = _axes(run_report.run_figure(robust, tip, data, REPORT), "force on the object")
    crush = next(ln for ln in ax_f.lines if "crush" in ln.get_label())
    assert "off the scale: 100x" in crush.get_label()
    assert largest <= ax_f.get_ylim()[1] < 2.0 * largest
    assert ax_f.get_ylim()[1] == pytest.approx(1.15 * largest)
    # no crush limit, no crush line
    fig = run_report.run_figure(config, tip, data, REPORT)
    ax_f = _axes(fig, "force on the object")
    assert not any("crush" in ln.get_label() for ln in ax_f.lines)


def _run_with_the_loop_cut(monkeypatch, tmp_path, interrupted=False):
    """run_scenario, its loop ended after a few steps (as a run ends once the object is at rest),
    and the bars it made."""
    import tqdm

    from piezotip.analysis.runner import run_scenario
    from piezotip.cosim.loop import CoSimulation

    bars = []

    class Bar(tqdm.tqdm):
        def __init__(self, *args, **kwargs):
            super().__init__(*args, **kwargs)
            bars.append(self)

    run = CoSimulation.run

    def short_run(self, recorder=None, progress=None, max_steps=None, on_step=None):
        result = run(self, recorder, progress, 30, on_step)
        return dataclasses.replace(result, interrupted=interrupted)

    monkeypatch.setattr(tqdm, "tqdm", Bar)
    monkeypatch.setattr(CoSimulation, "run", short_run)
    report, _ = run_scenario("grasp", [], tmp_path, plot=False, quiet=False, preset="fast")
    assert len(bars) == 1 and bars[0].n == 30
    return report, bars[0]


def test_progress_bar_ends_full_when_a_run_ends_before_its_time_out(monkeypatch, tmp_path):
    report, bar = _run_with_the_loop_cut(monkeypatch, tmp_path)
    assert not report["interrupted"]
    assert bar.total == bar.n == 30


def test_progress_bar_of_an_interrupted_run_stays_partial(monkeypatch, tmp_path):
    report, bar = _run_with_the_loop_cut(monkeypatch, tmp_path, interrupted=True)
    assert report["interrupted"]
    assert bar.total > bar.n


def test_the_true_pressure_drawn_is_what_the_sensing_patch_feels(recorded):
    """On a round object the pad's mean over the element is not what the sensor feels (an egg:
    1.25x, a 50 mm ball 1.47x, the 30 mm paper ball 1.82x the coverage's mean while held), yet it
    was drawn as the truth beside estimates of the coverage's pressure: the truth line is now the
    coverage's."""
    config, tip, data = recorded
    data = dict(data)
    n = data["time_s"].size
    for side in config.sensor.pads:
        data[f"{side}_true_pressure_pa"] = np.full(n, 1800.0)  # the pad's mean, not sensed
        data[f"{side}_coverage_pressure_pa"] = np.full(n, 1000.0)  # what the readout's input is
    ax_p = _axes(run_report.run_figure(config, tip, data, REPORT), "pressure on element")
    for side in config.sensor.pads:
        truth = [ln for ln in ax_p.lines if ln.get_label().startswith(f"{side}: true")]
        assert [ln.get_label() for ln in truth] == [f"{side}: true, felt by the sensing patch"]
        np.testing.assert_array_equal(truth[0].get_ydata(), 1000.0)
        pad = next(ln for ln in ax_p.lines if ln.get_label().startswith(f"{side}: pad's mean"))
        assert "not sensed" in pad.get_label() and pad.get_linewidth() < truth[0].get_linewidth()
        np.testing.assert_array_equal(pad.get_ydata(), 1800.0)
    # a record from before the coverage column: the pad's mean, the one truth there is
    old = {k: v for k, v in data.items() if not k.endswith("_coverage_pressure_pa")}
    ax_p = _axes(run_report.run_figure(config, tip, old, REPORT), "pressure on element")
    np.testing.assert_array_equal(next(ln for ln in ax_p.lines if ln.get_label().startswith("left: true")).get_ydata(), 1800.0)
    assert not any("pad's mean" in ln.get_label() for ln in ax_p.lines)


def _rows():
    """An experiment's rows: three objects by three controllers, one run never carried its object."""
    rows = []
    for i, obj in enumerate(("light", "medium", "heavy")):
        for j, ctrl in enumerate(("multimode", "mode 1 only", "mode 4 only")):
            carried = not (obj == "heavy" and ctrl == "mode 1 only")
            rows.append(
                {
                    "object": obj,
                    "controller": ctrl,
                    "outcome": "success" if carried else "blind",
                    "outside_model": "",
                    "feasible": True,
                    "grip_margin": 1.2 + i + 3.0 * j if carried else math.nan,
                    "peak_pressure_pa": 1e3 * (1 + i + j),
                }
            )
    return rows


def test_experiment_grip_margin_is_grouped_bars_per_object():
    rows = _rows()
    fig = experiment.experiment_figure(rows)
    ax = _axes(fig, "grip margin")
    objects, controllers = ["light", "medium", "heavy"], ["multimode", "mode 1 only", "mode 4 only"]
    assert ax.get_yscale() == "log"
    containers = ax.containers
    assert [c.get_label() for c in containers] == controllers  # a set of bars per controller...
    centres = np.array([[p.get_x() + 0.5 * p.get_width() for p in c.patches] for c in containers])
    assert centres.shape == (len(controllers), len(objects))
    for i in range(len(objects)):  # ...one bar of each in every object's group, side by side
        assert (np.abs(centres[:, i] - i) < 0.5).all() and np.all(np.diff(centres[:, i]) > 0)
    for c, name in zip(containers, controllers, strict=True):
        for i, obj in enumerate(objects):
            row = next(r for r in rows if r["object"] == obj and r["controller"] == name)
            patch = c.patches[i]
            if math.isfinite(row["grip_margin"]):
                assert patch.get_y() + patch.get_height() == pytest.approx(row["grip_margin"])
                assert patch.get_fill() and patch.get_facecolor()[3] > 0
            else:  # never carried: an empty hatched bar, named by its outcome
                assert patch.get_hatch() and patch.get_facecolor()[3] == 0
                assert any(t.get_text() == "blind" and abs(t.get_position()[0] - centres[1, 2]) < 1e-9 for t in ax.texts)
    # the reference levels: 1 (holds exactly) and the target, and no line from one object to another
    levels = {float(ln.get_ydata()[0]) for ln in ax.lines if np.ptp(np.asarray(ln.get_ydata(), float)) == 0}
    assert {1.0, experiment.TARGET_MARGIN} <= levels
    for line in ax.lines:
        x, y = (np.asarray(v, dtype=float) for v in line.get_data())
        if np.ptp(y[np.isfinite(y)]) == 0 or np.ptp(x[np.isfinite(x)]) == 0:
            continue  # a level or a separator
        groups = set(np.round(x[np.isfinite(x) & np.isfinite(y)]).astype(int))
        assert len(groups) <= 1, f"{line.get_label()!r} joins objects {sorted(groups)}"
    # the outcome matrix stays
    assert any(ax.get_title().startswith("referee's outcome") for ax in fig.axes)


def test_experiment_plot_draws_the_controllers_aim_from_its_config_and_the_bound_as_a_bound():
    """The figure drew "1.5: the target" where the default controller aims at its grip_safety
    (1.25; it holds at 1.2-1.4x): the aim is now read from the controller's config, and 1.5 is
    labelled as the bound it is."""
    safety = scenarios.get("grasp").controller.grip_safety
    for aim, level in ((None, safety), (experiment.ControllerAim("gentle", 1.4), 1.4)):
        ax = _axes(experiment.experiment_figure(_rows(), aim), "grip margin")
        levels = {float(ln.get_ydata()[0]): ln.get_label() for ln in ax.lines if np.ptp(np.asarray(ln.get_ydata(), float)) == 0}
        assert "aim" in levels[level] and "controller.grip_safety" in levels[level], levels
        assert "bound" in levels[1.5] and "target" not in levels[1.5]
        assert not any("target" in label for label in levels.values())
    assert experiment.controller_aim(scenarios.get("grasp", ["controller.grip_safety=1.3"]).controller).margin == 1.3
    assert experiment.controller_aim(scenarios.get("grasp", ["controller.kind=scripted"]).controller) is None


def test_experiment_plot_is_written(tmp_path):
    rows = [{c: r.get(c, "") for c in experiment.COLUMNS} | {"touch_latency_s": 0.01, "touch_sense": "fingertip"} for r in _rows()]
    files = experiment.write_outputs(rows, tmp_path)
    assert (tmp_path / "grasp_range.png") in files and (tmp_path / "grasp_range.png").stat().st_size > 10_000


FINGERTIP = "squeeze: touch on left_pad, right_pad (CUSUM); grip floor 0.00618 N"
JOINTS = "squeeze: touch felt by the joints (the drive needs 0.407 N against its free 0.4 N); grip floor 0.00618 N"


def _events(*messages):
    return [{"time_s": 0.1, "pad": "", "kind": "phase", "message": "close"}] + [
        {"time_s": 1.0 + k, "pad": "", "kind": "phase", "message": m} for k, m in enumerate(messages)
    ]


def test_touch_sense_says_which_sense_felt_the_touch():
    assert touch_sense(_events(FINGERTIP, "lift: grip 0.1 N")) == "fingertip"
    assert touch_sense(_events(JOINTS, "lift: grip 0.1 N")) == "joints"
    assert touch_sense(_events()) == ""
    assert touch_sense(_events(FINGERTIP, "close: on", JOINTS)) == "joints"  # the last touch, as its time
    # not a phase event: no touch
    assert touch_sense([{"time_s": 1.0, "pad": "left_pad", "kind": "note", "message": FINGERTIP}]) == ""


@pytest.mark.parametrize(("message", "sense"), [(FINGERTIP, "fingertip"), (JOINTS, "joints"), (None, "")])
def test_touch_sense_reaches_the_sweep_row_and_the_experiment_table(message, sense):
    summary = {
        "outcome": "success",
        "reason": "held",
        "success": True,
        "max_pressure_pa": 1e3,
        "wall_time_s": 1.0,
        "crushed": False,
        "slipped": False,
        "lifted": True,
        "mode_switches": 2,
        "peak_grip_force_n": 1.0,
        "sim_time_s": 7.0,
        "touch_time_s": 2.0 if message else math.nan,
        "events": _events(message) if message else _events(),
    }
    row = point_row(summary, {})
    assert row["touch_sense"] == sense
    table_row = experiment.experiment_row({**row, "object": "box-100g", "controller": "multimode", "object_config": None})
    assert table_row["touch_sense"] == sense
    assert tuple(table_row) == experiment.COLUMNS
    text = experiment.format_table([table_row])
    assert "by" in text.splitlines()[0] and (sense or "-") in text.splitlines()[2]
