"""reports/random_objects.py: objects no test names, drawn within the catalogue's own ranges
(issue 43's hidden objects), and how a run of one is judged."""

from __future__ import annotations

import math

import pytest

from piezotip import scenarios
from piezotip.reports import random_objects as ro


@pytest.mark.parametrize(
    ("shape", "volume"),
    [
        ("box", lambda s: s**3),
        ("sphere", lambda s: math.pi * s**3 / 6.0),
        ("cylinder", lambda s: math.pi * (s / 2) ** 2 * 1.2 * s),  # 1.2 diameters tall
        ("egg", lambda s: math.pi * s**3 / 6.0 * 57.0 / 43.0),  # a sphere stretched 57/43 along the pads
    ],
)
def test_a_shapes_volume_is_its_solids(shape, volume):
    assert ro.shape_volume_m3(shape, 0.04) == pytest.approx(volume(0.04), rel=1e-12)


def test_the_ranges_are_the_catalogues():
    ranges = ro.catalogue_ranges()
    assert ranges["size_m"] == (0.02, 0.08)
    assert ranges["friction"] == (0.3, 1.2)
    tissue = scenarios.OBJECTS["tissue-box-1g"]  # the lightest for its volume
    assert ranges["density_kg_m3"][0] == pytest.approx(tissue.mass_kg / tissue.size_m**3)
    assert ranges["density_kg_m3"][1] == pytest.approx(10.0 / 0.08**3)  # the 10 kg blocks


def test_the_draws_keep_to_the_catalogues_ranges_and_the_issues_bounds():
    ranges = ro.catalogue_ranges()
    objects = ro.draw(400, seed=3, widest_m=0.05)
    assert objects == ro.draw(400, seed=3, widest_m=0.05) and objects != ro.draw(400, seed=4, widest_m=0.05)
    assert {obj["object.shape"] for obj in objects} == {o.shape for o in scenarios.OBJECTS.values()}
    for obj in objects:
        size, mass, mu, crush = (obj[f"object.{k}"] for k in ("size_m", "mass_kg", "friction", "crush_force_n"))
        assert ranges["size_m"][0] <= size <= 0.05
        assert ranges["friction"][0] <= mu <= ranges["friction"][1]
        assert ro.MASS_RANGE_KG[0] <= mass <= ro.MASS_RANGE_KG[1]
        density = mass / ro.shape_volume_m3(obj["object.shape"], size)
        if ro.MASS_RANGE_KG[0] < mass < ro.MASS_RANGE_KG[1]:  # not clipped
            assert ranges["density_kg_m3"][0] * 0.999 <= density <= ranges["density_kg_m3"][1] * 1.001
        flat_n = mass * 9.81 / (2.0 * mu)
        assert crush >= ro.LEAST_CRUSH_N and crush >= 1.5 * flat_n * 0.999
        assert crush <= max(ro.LEAST_CRUSH_N, 4.0 * flat_n) * 1.001


@pytest.mark.parametrize(("count", "widest"), [(-1, None), (3, 0.019)])
def test_a_draw_that_cannot_be_made_is_one_error(count, widest):
    with pytest.raises(ValueError, match=r"count|narrowest"):
        ro.draw(count, 0, widest)


def _row(outcome, margin=None, need=0.1, crush=0.2):
    return {"outcome": outcome, "grip_margin": margin, "needed_grip_n": need, "object.crush_force_n": crush}


@pytest.mark.parametrize(
    ("row", "expected"),
    [
        (_row("success", 1.3), "held"),
        (_row("success", 1.6), "over"),
        (_row("crushed", need=0.1, crush=0.2), "crushed"),  # 2x its need: the goal protects it
        (_row("crushed", need=0.1, crush=0.14), "crushed (unprotected)"),  # a tilted contact's need: 1.4x
        (_row("crushed", need=None, crush=0.14), "crushed"),  # need unknown: counted against the run
        (_row("never_lifted"), "never_lifted"),
    ],
)
def test_a_run_is_judged_by_the_goal(row, expected):
    assert ro.verdict(row) == expected


def test_an_object_past_the_grippers_rating_is_infeasible_and_not_run():
    """The house gripper is rated 100 N a finger: a 2 kg box at friction 0.05 needs 196 N."""
    slippery = {"object.shape": "box", "object.size_m": 0.04, "object.mass_kg": 2.0, "object.friction": 0.05, "object.crush_force_n": 1e3}
    row = ro.run_one(ro.HOUSE, slippery, "fast")
    assert row["outcome"] == "infeasible" and "over the 100 N allowed" in row["reason"]


def test_an_unknown_gripper_is_one_error_naming_it(capsys):
    assert ro.main(["--grippers", "no-such-gripper", "--count", "1"]) == 2
    assert "no-such-gripper" in capsys.readouterr().err


def test_a_drawn_object_is_grasped_and_tabled(tmp_path):
    assert ro.main(["--count", "1", "--seed", "0", "--preset", "fast", "--out", str(tmp_path)]) == 0
    text = (tmp_path / "table.md").read_text()
    assert "| house (fast) | 1 |" in text
    assert ro.main(["--count", "1", "--seed", "0", "--preset", "fast", "--out", str(tmp_path)]) == 0  # resumed: nothing run again
    assert len((tmp_path / "runs.jsonl").read_text().splitlines()) == 1
