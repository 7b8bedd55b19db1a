"""reports/gripper_tables.py: docs/grippers.md's tables from the runs' rows (the runs themselves
are whole grasps, run by hand; here the rows are made up, so the counting is checked alone)."""

from __future__ import annotations

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
