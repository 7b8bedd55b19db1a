"""A skin of 16 attached fingertips under a resting box, in a plain ``mj_step`` loop at MuJoCo's
default options (reports/skin_bench.py's scene): the pads under the box carry its weight and
read it, the others read nothing; and ``bench --skin``'s report."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from piezotip.cosim import mjhooks
from piezotip.cosim.attach import STATUS_CODES, attach, sensor_name
from piezotip.reports.skin_bench import BOX_KG, PAD_HALF_M, _variants, format_skin_report, skin_report, skin_xml

ROWS = COLS = 4
PAD_AREA_M2 = (2 * PAD_HALF_M) ** 2


@pytest.fixture(scope="module", params=["house", "lean", "touch"], ids=["house-pads", "element-sized-pads", "touch-pads"])
def skin(request):
    lean = request.param == "lean"
    spec = mujoco.MjSpec.from_string(skin_xml(ROWS, COLS, lean=lean))
    names = [f"tip{i}_{j}" for i in range(ROWS) for j in range(COLS)]
    tips = attach(spec, sites=names, pad="touch" if request.param == "touch" else "gel")
    model = spec.compile()
    data = mujoco.MjData(model)
    sim = tips.bind(model, data)
    if lean:  # the box's 13 kPa on an element-sized pad saturates the lowest mode: the highest reads it
        for n in names:
            sim.set_mode(n, max(tips.config.sensor.modes))
    readings = []
    while data.time < 2.0:
        mujoco.mj_step(model, data)
        if data.time > 1.0:
            readings.append({n: {f: data.sensor(sensor_name(n, f)).data[0] for f in ("pressure_pa", "sigma_pa", "status")} for n in names})
    return sim, names, readings


def test_the_pads_under_the_box_carry_its_weight_and_the_others_nothing(skin):
    sim, names, _ = skin
    force = {n: sim.pad_state(n).normal_force_n for n in names}
    loaded = {n for n, f in force.items() if f > 1e-6}
    assert loaded == {"tip0_0", "tip0_1", "tip1_0", "tip1_1"}  # the box sits on the first 2 x 2 pads
    assert sum(force.values()) == pytest.approx(BOX_KG * 9.81, rel=1e-6)


def test_loaded_pads_read_within_three_sigma_and_the_others_below_detection(skin):
    sim, names, readings = skin
    for n in names:
        truth = sim.pad_state(n).mean_pressure_pa
        statuses = np.array([r[n]["status"] for r in readings])
        if truth > 0:
            ok = [r[n] for r in readings if r[n]["status"] == STATUS_CODES["ok"]]
            assert len(ok) >= 0.9 * len(readings), n
            assert all(abs(r["pressure_pa"] - truth) <= 3 * r["sigma_pa"] for r in ok), n
        else:  # now and then a 3-sigma false detection on noise (the readout's, docs/physics.md): under 1 %
            assert (statuses == STATUS_CODES["below_detection"]).mean() > 0.9, n
            assert np.isin(statuses, [STATUS_CODES["ok"], STATUS_CODES["saturated"]]).mean() < 0.01, n


def test_the_skin_bench_reports_ratios_over_the_bare_model():
    report = skin_report(rows=2, cols=2, steps=50, repeats=1)
    variants = {"bare", "rigid", "touch", "piezotip", "piezotip_mechanics", "piezotip_lean", "piezotip_touch"}
    assert report["pads"] == 4 and set(report["step_us"]) == variants
    assert report["ratio_over_bare"]["bare"] == 1.0 and report["ratio_over_rigid"]["rigid"] == 1.0
    assert report["contacts"]["piezotip"] > report["contacts"]["bare"]  # the box rests on the pads' strips
    # A lean pad is one strip: a third of the 20 x 20 mm pad's contacts under the same box.
    assert 3 * report["contacts"]["piezotip_lean"] == report["contacts"]["piezotip"]
    assert report["contacts"]["rigid"] == report["contacts"]["piezotip_lean"]
    assert report["contacts"]["piezotip_touch"] == report["contacts"]["bare"]  # no pad geometry: the box on the palm
    assert "per pad over bare" in format_skin_report(report)


def test_the_bench_variants_run_what_they_say():
    """``piezotip_mechanics`` runs the gel law without the readout (its sensors stay as at bind),
    ``piezotip`` both, so their difference is the readout's cost."""
    variants = _variants(2, 2)
    for model, data in variants.values():
        for _ in range(10):
            mujoco.mj_step(model, data)
    hooks = {name: [type(h).__name__ for h in mjhooks.hooks_of(data)] for name, (_, data) in variants.items()}
    assert hooks["piezotip"] == ["GelPassive", "_FingertipHook"]
    assert hooks["piezotip_mechanics"] == ["GelPassive"]
    assert hooks["bare"] == hooks["rigid"] == hooks["touch"] == []
    lean, full = variants["piezotip_lean"][0], variants["piezotip"][0]
    assert full.njnt - 1 == 3 * (lean.njnt - 1)  # the box's freejoint, and one strip a pad against three


def test_a_touch_skin_leaves_the_model_s_physics_bit_for_bit_as_it_was():
    """``pad="touch"`` adds sensors only: the model with its 16 fingertips steps exactly as the
    model without them (the box's whole trajectory), while its fingertips read the box."""
    spec = mujoco.MjSpec.from_string(skin_xml(ROWS, COLS))
    names = [f"tip{i}_{j}" for i in range(ROWS) for j in range(COLS)]
    tips = attach(spec, sites=names, pad="touch")
    model = spec.compile()
    data = mujoco.MjData(model)
    tips.bind(model, data)
    bare = mujoco.MjModel.from_xml_string(skin_xml(ROWS, COLS))
    bare_data = mujoco.MjData(bare)
    assert (model.nbody, model.ngeom, model.njnt) == (bare.nbody, bare.ngeom, bare.njnt)
    for _ in range(300):
        mujoco.mj_step(model, data)
        mujoco.mj_step(bare, bare_data)
        assert np.array_equal(data.qpos, bare_data.qpos) and np.array_equal(data.qvel, bare_data.qvel)
    # MuJoCo's own touch in sensordata: the box's weight, shared by the four pads under it.
    touch = [data.sensor(sensor_name(n, "touch_n")).data[0] for n in names]
    assert sum(touch) == pytest.approx(BOX_KG * 9.81, rel=1e-6)
    # the truth the readout was given at its last period (a step or so ago; the box is at rest)
    assert data.sensor(sensor_name("tip0_0", "true_pressure_pa")).data[0] == pytest.approx(touch[0] / PAD_AREA_M2, rel=1e-6)


def test_a_touch_skin_reads_the_same_in_its_own_loop_and_in_a_plain_one():
    """While the box lands (its load changing every step): a touch pad's readout samples the
    ``touch`` sensor as the last step left it, in a plain ``mj_step`` loop (at the next step's
    position stage) as in the fingertips' own loop (at the period's end)."""
    names = [f"tip{i}_{j}" for i in range(ROWS) for j in range(COLS)]
    loops = []
    for _ in range(2):
        spec = mujoco.MjSpec.from_string(skin_xml(ROWS, COLS))
        tips = attach(spec, sites=names, pad="touch")
        model = spec.compile()
        data = mujoco.MjData(model)
        loops.append((model, data, tips.bind(model, data)))
    (_, _, own), (model, data, plain) = loops
    seen = set()
    for period in range(60):
        own.step()
        for _ in range(plain.substeps + (period == 0)):  # the plain loop samples one step later
            mujoco.mj_step(model, data)
        assert own.readings() == plain.readings(), period
        seen.add(round(own.readings()["tip0_0"].true_pressure_pa, 3))
    assert len(seen) > 10  # the load changed while the two were compared


@pytest.mark.usefixtures("dispatch")
def test_the_touch_sensors_computed_once_a_period_give_the_readout_what_every_step_would():
    """Bind gives the touch pads' ``touch`` sensors the readout's period as MuJoCo's sensor
    ``interval`` (cosim.attach.TouchReader): MuJoCo computes them once a period, at the step
    before the readout samples them, whatever the phase (a bind mid-period, a reset).  The
    readout's every value is what it is with them computed at every step, while the box lands."""
    names = [f"tip{i}_{j}" for i in range(ROWS) for j in range(COLS)]

    def run(every_step: bool) -> tuple[np.ndarray, int]:
        spec = mujoco.MjSpec.from_string(skin_xml(ROWS, COLS))
        tips = attach(spec, sites=names, pad="touch")
        model = spec.compile()
        data = mujoco.MjData(model)
        for _ in range(3):  # bound mid-period: the readout's periods start at bind
            mujoco.mj_step(model, data)
        sim = tips.bind(model, data)
        touch = np.flatnonzero(model.sensor_type == mujoco.mjtSensor.mjSENS_TOUCH)
        assert (model.sensor_interval[touch, 0] == sim.period_s).all() and sim.substeps > 1
        if every_step:  # the reference: no interval, and the pass never asks for the sensors
            model.sensor_interval[touch, 0] = 0.0
            sim._pass.bind_history(data.history, [-1] * len(names))
        fields = ("pressure_pa", "sigma_pa", "status", "mode", "true_pressure_pa")
        readout = [model.sensor(sensor_name(n, f)).adr[0] for n in names for f in fields]
        out, computed = [], 0
        for k in range(400):
            if k == 200:
                mujoco.mj_resetData(model, data)  # the readout starts again, at t = 0
            before = data.sensordata[model.sensor_adr[touch]].copy()
            mujoco.mj_step(model, data)
            computed += int(not np.array_equal(before, data.sensordata[model.sensor_adr[touch]]))
            out.append(data.sensordata[readout].copy())
        return np.array(out), computed

    held, computed_held = run(every_step=False)
    every, computed_every = run(every_step=True)
    np.testing.assert_array_equal(held, every)
    assert len(np.unique(every[:, 4])) > 10  # the load changed while the two were compared
    assert computed_held <= 400 // 2 + 2 < computed_every  # once a period (2 steps) against every step
