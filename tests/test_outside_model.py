"""Readings past where the model holds are recorded ``outside_model`` (issue 44, item 10): the
gel past its valid strain over the element, or the coverage's pressure past the element's
backstop.  The readout cannot know it (a real fingertip would not); the simulator does, and its
record, ``attach``'s status sensor and ``TipReading.status`` say so.  The controller still sees
the readout's own status."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest
from test_attach import PAD_AREA_M2, scene_xml

import piezotip
from piezotip.cosim import rows
from piezotip.cosim.attach import STATUS_CODES, attach, sensor_name
from piezotip.cosim.loop import make_fingertip
from piezotip.scenarios import get

FINGERTIP = make_fingertip(get("grasp"))
GEL_VALID_PA = FINGERTIP.gel.params.max_valid_pressure_pa
BACKSTOP_PA = FINGERTIP.backstop_pressure_pa()
OUTSIDE = STATUS_CODES["outside_model"]


def test_the_model_ends_at_the_backstop_or_the_gels_valid_strain():
    limit_pa, why = FINGERTIP.model_limit()
    assert limit_pa == min(GEL_VALID_PA, BACKSTOP_PA) and why in ("backstop", "gel_strain")
    assert rows.STATUS_CODES.index("outside_model") == OUTSIDE == 4
    assert "outside_model" not in rows.READOUT_STATUSES  # what a controller or an agent sees


@pytest.mark.parametrize("kernel", ["compiled", "python"])
def test_a_row_past_either_limit_is_recorded_outside_the_model(kernel):
    builder_class = rows.RowBuilder if kernel == "compiled" else rows.PyRowBuilder
    status_index = {s: float(i) for i, s in enumerate(rows.STATUS_CODES)}
    limits = (GEL_VALID_PA, BACKSTOP_PA)
    with_limits = _row_status(builder_class, status_index, limits)
    without = _row_status(builder_class, status_index, None)
    ok = status_index["ok"]
    assert with_limits(strips=[1e3, 2e3], cell=1.5e3) == ok  # inside the model: the readout's own
    assert with_limits(strips=[1e3, 0.999 * GEL_VALID_PA], cell=0.999 * BACKSTOP_PA) == ok
    assert with_limits(strips=[1e3, 1.001 * GEL_VALID_PA], cell=1e3) == OUTSIDE  # one strip past the gel's strain
    assert with_limits(strips=[1e3, 2e3], cell=1.001 * BACKSTOP_PA) == OUTSIDE  # the coverage on the backstop
    assert without(strips=[1e3, 10 * GEL_VALID_PA], cell=10 * BACKSTOP_PA) == ok  # no limits given: no check
    with pytest.raises(ValueError, match="outside_model"):
        builder_class(["left_pad"], [5], [1, 3], 7, False, [1.0], 1e9, {"ok": 0.0}, limits)


def _row_status(builder_class, status_index, limits):
    """A one-pad RowBuilder; a function of (strips, cell) giving the row's recorded status."""
    from piezotip.cosim.control.interface import Observation, PadSignal
    from piezotip.sensor.estimator import Estimate
    from piezotip.sensor.resonator import Reading

    builder = builder_class(["left_pad"], [5], [1, 3], 7, False, [1.0], 1e9, status_index, limits)
    builder.bind(np.zeros(3), np.zeros(6), np.zeros(12))
    reading = Reading(1, 0.9, 0.9, 0.0, 1.0, 0.1, True, 0.0, 0.0, 0.9 + 0j)
    estimate = Estimate(1e3, 10.0, "ok")
    obs = Observation(0.0, {"left_pad": PadSignal(reading, estimate)}, 0.0, 0.02, 0.0, 1.0)

    class Command:
        phase = 0

    def status(strips, cell):
        row = builder.row(0.0, obs, Command, [list(strips)], [[cell]], None)
        columns = rows.row_columns(["left_pad"], len(strips), False)
        return row[columns.index("left_status")]

    return status


def test_attach_reports_a_pad_pressed_past_the_backstop_outside_the_model():
    spec = mujoco.MjSpec.from_string(scene_xml())
    tips = attach(spec, sites=["pressed", "free"])
    model = spec.compile()
    data = mujoco.MjData(model)
    sim = tips.bind(model, data)
    plate = model.body("plate").id
    light, heavy = [], []
    for periods, force_n, out in ((300, 0.0, light), (300, 2.0 * BACKSTOP_PA * PAD_AREA_M2, heavy)):
        data.xfrc_applied[plate, 2] = -force_n  # pressed down past the backstop
        for k in range(periods):
            sim.step()
            if k >= periods // 2:  # settled
                r = sim.readings()["pressed"]
                out.append((r.status, int(data.sensor(sensor_name("pressed", "status")).data[0]), r.true_pressure_pa))
    assert all(status != "outside_model" and code != OUTSIDE for status, code, _ in light)
    assert all(p > BACKSTOP_PA for *_, p in heavy)
    assert all(status == "outside_model" and code == OUTSIDE for status, code, _ in heavy)


def _past_the_model(data: dict, side: str) -> np.ndarray:
    """Where the record's own truths are past the model: the coverage on the backstop, or any
    element strip past the gel's valid strain."""
    cells = np.column_stack([data[k] for k in sorted(data) if k.startswith(f"{side}_cell")])
    return (data[f"{side}_coverage_pressure_pa"] > BACKSTOP_PA) | (cells.max(axis=1) > GEL_VALID_PA)


@pytest.mark.parametrize(("scenario", "expect_outside"), [("grasp", False), ("grasp-10kg", True)])
def test_the_record_marks_exactly_the_readings_past_the_model(tmp_path, scenario, expect_outside):
    result = piezotip.run(scenario, preset="fast", out=tmp_path, plot=False)
    assert result.outcome == "success"
    with np.load(tmp_path / "run.npz") as npz:
        data = {k: npz[k] for k in npz.files}
    for side in ("left", "right"):
        past = _past_the_model(data, side)
        recorded = data[f"{side}_status"] == OUTSIDE
        assert np.array_equal(recorded, past), side
        assert past.any() == expect_outside, side
    if expect_outside:  # the 10 kg block's grip, 167 kPa on the coverage: far past where the model ends
        assert data["left_coverage_pressure_pa"].max() > 2 * FINGERTIP.model_limit()[0]
