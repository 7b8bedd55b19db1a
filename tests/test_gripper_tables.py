"""reports/gripper_tables.py: docs/grippers.md's tables from the runs' rows (the runs themselves
are whole grasps, run by hand; here the rows are made up, so the counting is checked alone)."""

from __future__ import annotations

import json

import pytest

from piezotip.reports import gripper_tables as gt
from piezotip.scenarios import OBJECTS


def _row(gripper, obj, controller, outcome, friction_x=1.0, mass_x=1.0, margin=1.3):
    return {
        "gripper": gripper,
        "object": obj,
        "controller": controller,
        "scenario": "grasp",
        "friction_x": friction_x,
        "mass_x": mass_x,
        "outcome": outcome,
        "reason": f"{outcome} here",
        "grip_margin": margin,
        "touch_peak_n": 0.01,
    }


def test_the_grid_is_six_variations_a_controller_and_three_for_the_lightest():
    keys = {"g": {"gripper.mjcf": "x.xml"}}
    variations = [r for r in gt.runs(("variation",), keys)]
    per_object = {name: sum(r["object"] == name for r in variations) for name in OBJECTS}
    assert per_object[gt.LIGHTEST] == 3 * len(gt.CONTROLLERS)
    assert all(n == 6 * len(gt.CONTROLLERS) for name, n in per_object.items() if name != gt.LIGHTEST)
    assert all(r["overrides"]["controller.kind"] == r["controller"] for r in variations)


def test_the_tables_count_successes_and_name_every_failure():
    name = next(iter(OBJECTS))
    rows = [
        _row("panda", name, "gentle", "success"),
        _row("panda", name, "gentle", "success", friction_x=0.9, margin=1.7),
        _row("panda", name, "gentle", "dropped", friction_x=1.1),
        _row("panda", name, "multimode", "success", friction_x=0.9),
        _row("panda", name, "multimode", "does_not_fit", friction_x=1.1),
    ]
    text = gt.tables(rows)
    assert f"| {name} | - | success 1.30, 0.01 N |" in text  # the nominal table: multimode has no nominal row
    assert f"| {name} | 1/1 | 1/2 (dropped) |" in text  # an object that does not fit is no run
    assert "| all | 1 of 1 | 1 of 2 |" in text
    assert f"panda gentle: successes' margins 1.70-1.70x; over 1.5x: {name}" in text
    assert f"- panda gentle {name} (friction x1.1, mass x1): dropped 1.30: dropped here" in text


def test_two_runs_of_the_tables_are_compared_run_for_run():
    """``--compare``: per gripper and controller, the feasible runs within the goal (1.5x) and the
    successes, before -> after; then the runs that changed, each marked where it crossed the goal
    or failed; a margin moved by less than MARGIN_STEP is not listed, and neither is a run that
    does not fit or a run in one table only."""
    a, b, c = list(OBJECTS)[:3]
    before = [
        _row("panda", a, "gentle", "success", margin=7.36),
        _row("panda", a, "gentle", "success", friction_x=0.9, margin=1.40),
        _row("panda", b, "gentle", "success", margin=1.30),
        _row("panda", c, "gentle", "success", margin=1.20),
        _row("panda", c, "gentle", "does_not_fit", friction_x=1.1, margin=None),
        _row("panda", c, "gentle", "success", friction_x=0.9, mass_x=0.9),
    ]
    after = [
        _row("panda", a, "gentle", "success", margin=1.16),
        _row("panda", a, "gentle", "success", friction_x=0.9, margin=1.40 + 0.5 * gt.MARGIN_STEP),
        _row("panda", b, "gentle", "crushed", margin=1.25),
        _row("panda", c, "gentle", "success", margin=1.20 + 2.0 * gt.MARGIN_STEP),
        _row("panda", c, "gentle", "does_not_fit", friction_x=1.1, margin=None),
    ]
    text = gt.compare(before, after)
    assert "| panda | gentle | 4 of 5 -> 3 of 4 | 0 -> 0 | 5 -> 3 |" in text  # made-up rows record no peak
    crossed = "success 7.36x, touch 0.01 N -> success 1.16x, touch 0.01 N (now within 1.5x)"
    assert f"- panda gentle {a} (friction x1, mass x1): {crossed}" in text
    assert f"- panda gentle {b} (friction x1, mass x1): success 1.30x, touch 0.01 N -> crushed 1.25x, touch 0.01 N **failed**" in text
    assert f"- panda gentle {c} (friction x1, mass x1): success 1.20x, touch 0.01 N -> success 1.30x, touch 0.01 N" in text
    assert "changed (3 of 5 runs in both):" in text
    assert f"{a} (friction x0.9" not in text  # moved by less than MARGIN_STEP


def test_compare_reads_two_folders_and_names_one_without_runs(tmp_path, capsys):
    before, after, empty = tmp_path / "before", tmp_path / "after", tmp_path / "empty"
    for folder, margin in ((before, 2.0), (after, 1.2)):
        folder.mkdir()
        (folder / "runs.jsonl").write_text(json.dumps(_row("rethink", next(iter(OBJECTS)), "gentle", "success", margin=margin)) + "\n")
    empty.mkdir()
    assert gt.main(["--compare", str(before), str(after)]) == 0
    assert "| rethink | gentle | 0 of 1 -> 1 of 1 | 0 -> 0 | 1 -> 1 |" in capsys.readouterr().out
    with pytest.raises(SystemExit):
        gt.main(["--compare", str(before), str(empty)])
    assert f"{empty / 'runs.jsonl'} not found" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        gt.main([])
    assert "--out is required" in capsys.readouterr().err


def test_a_peak_is_judged_against_one_and_a_half_times_the_need_or_the_lightest_crush_force_protected():
    """Issue 43: "crushes nothing whose crush force is at least 1.5x that grip", its objects
    crushing at 0.03 N or more: a peak of 1.5x the need passes and a hair over does not; under
    0.03 N any peak passes (the 1 g tissue box needs 8 mN); a failed run, or a row without the
    peak, passes nothing.  ``--compare`` counts them and marks a run whose peak crossed."""
    name = next(iter(OBJECTS))

    def peaked(peak_n, need_n, outcome="success"):
        return _row("panda", name, "gentle", outcome) | {"peak_contact_n": peak_n, "needed_grip_n": need_n}

    assert gt._gentle(peaked(0.30, 0.20)) and not gt._gentle(peaked(0.30 * (1 + 1e-9), 0.20))
    assert gt._gentle(peaked(0.03, 0.008)) and not gt._gentle(peaked(0.031, 0.008))
    assert not gt._gentle(peaked(0.1, 0.2, "dropped")) and not gt._gentle(_row("panda", name, "gentle", "success"))
    text = gt.compare([peaked(0.40, 0.20)], [peaked(0.28, 0.20)])
    assert "| panda | gentle | 1 of 1 -> 1 of 1 | 0 -> 1 | 1 -> 1 |" in text
    assert "peak 2.00x -> success 1.30x, touch 0.01 N, peak 1.40x (peak now within)" in text
    assert "**peak now over**" in gt.compare([peaked(0.28, 0.20)], [peaked(0.40, 0.20)])
    lines = gt.tables([peaked(0.40, 0.20) | {"friction_x": 0.9}, peaked(0.28, 0.20) | {"friction_x": 1.1}])
    assert f"panda gentle: peaks over max(1.5x the need, 0.03 N) in 1 of 2: {name}" in lines


def test_a_load_changes_peak_is_judged_against_the_need_it_raised_and_its_answer_is_listed():
    """grasp-disturb's extra load doubles the 100 g box's need (0.49 -> 0.98 N): its answer's peak
    is judged against the new need, and the extras' line gives the slip, the answer's time and the
    new hold's margin."""
    row = _row("menagerie", "grasp-disturb", "gentle", "success") | {
        "scenario": "grasp-disturb",
        "peak_contact_n": 1.47,
        "needed_grip_n": 0.49,
        "disturb_needed_grip_n": 0.98,
        "disturb_slip_mm": 0.67,
        "disturb_reaction_ms": 25.0,
        "disturb_grip_margin": 1.39,
    }
    assert gt._peak_ratio(row) == pytest.approx(1.5) and gt._gentle(row)
    assert not gt._gentle(row | {"peak_contact_n": 1.48})
    assert gt._peak_ratio(row | {"disturb_needed_grip_n": None}) == pytest.approx(3.0)
    text = gt.tables([row])
    line = "- menagerie gentle grasp-disturb: success 1.30, 0.01 N, slip 0.67 mm, answered in 25 ms, held at 1.39x the new need"
    assert f"{line}, peak 1.50x the need" in text


def test_a_run_takes_the_noise_seed_it_is_given_and_seed_0_as_before(monkeypatch):
    """``--seed`` reaches every run as ``sensor.seed``; seed 0 (the default) leaves the run's
    overrides as they were."""
    import piezotip

    seen = []

    def refuse(scenario, overrides, preset):
        seen.append(dict(overrides))
        raise ValueError("the object does not fit")

    monkeypatch.setattr(piezotip, "run", refuse)
    run = {"gripper": "Panda", "object": "cube-3g", "controller": "gentle", "scenario": "grasp", "friction_x": 1.0, "mass_x": 1.0}
    run["overrides"] = {"object.mass_kg": 0.003}
    assert gt.one(run, "balanced", seed=2)["outcome"] == "does_not_fit"
    assert gt.one(run, "balanced")["outcome"] == "does_not_fit"
    assert seen == [{"object.mass_kg": 0.003, "sensor.seed": 2}, {"object.mass_kg": 0.003}]


def test_a_row_names_its_preset_and_seed_and_a_resume_under_others_is_refused(monkeypatch, tmp_path, capsys):
    """A journal is resumed only at the preset and seed its runs were made at: resumed under
    another ``--seed`` it would mix two seeds' runs into one table without a word."""
    import piezotip

    monkeypatch.setattr(piezotip, "run", lambda scenario, overrides, preset: (_ for _ in ()).throw(ValueError("does not fit")))
    run = {"gripper": "Panda", "object": "cube-3g", "controller": "gentle", "scenario": "grasp", "friction_x": 1.0, "mass_x": 1.0}
    row = gt.one(run | {"overrides": {}}, "balanced", seed=1)
    assert (row["preset"], row["seed"]) == ("balanced", 1)
    assert gt.resumable([row], "balanced", 1) == [row] and gt.resumable([], "fast", 0) == []
    with pytest.raises(ValueError, match="preset balanced, seed 1, not at preset balanced, seed 2"):
        gt.resumable([row], "balanced", 2)
    with pytest.raises(ValueError, match="not at preset accurate, seed 1"):
        gt.resumable([row], "accurate", 1)
    with pytest.raises(ValueError, match="preset and seed unrecorded"):
        gt.resumable([_row("panda", "cube-3g", "gentle", "success")], "fast", 0)
    (tmp_path / "runs.jsonl").write_text(json.dumps(row) + "\n")
    with pytest.raises(SystemExit):
        gt.main(["--out", str(tmp_path), "--preset", "balanced", "--seed", "2", "--grippers", "none"])
    assert "give the same --preset and --seed to resume it" in capsys.readouterr().err
    assert (tmp_path / "runs.jsonl").read_text() == json.dumps(row) + "\n"  # nothing written over


def test_compare_says_which_preset_and_seed_each_side_ran_at(tmp_path, capsys):
    name = next(iter(OBJECTS))
    for folder, seed in (("before", 0), ("after", 2)):
        (tmp_path / folder).mkdir()
        row = _row("rethink", name, "gentle", "success") | {"preset": "balanced", "seed": seed}
        (tmp_path / folder / "runs.jsonl").write_text(json.dumps(row) + "\n")
    assert gt.main(["--compare", str(tmp_path / "before"), str(tmp_path / "after")]) == 0
    assert "before: preset balanced, seed 0; after: preset balanced, seed 2" in capsys.readouterr().out
