"""piezotip.attach as a drop-in: any integrator at MuJoCo's default step, a plain ``mj_step`` loop,
readings in ``data.sensordata`` (cosim/mjhooks.py, cosim/attach.py).

The scene is tests/test_attach.py's: a plate resting with its weight on one pad (true pressure
m g / A), the other pad free.  The reference for the touch is the same scene under the house's
``discrete`` integrator at 0.1 ms.
"""

from __future__ import annotations

import ctypes

import mujoco
import numpy as np
import pytest
from test_attach import PLATE_KG, PRESSURE_PA, scene_xml

from piezotip.cosim import mjhooks
from piezotip.cosim.attach import SENSOR_FIELDS, STATUS_CODES, attach, sensor_name

G = 9.81
#: MuJoCo's own defaults (no <option>: Euler, 2 ms) and every other integrator at 2 ms.
OPTIONS = {
    "mujoco-default": "",
    "RK4": '<option integrator="RK4"/>',
    "implicit": '<option integrator="implicit"/>',
    "implicitfast": '<option integrator="implicitfast"/>',
    "discrete": '<option integrator="discrete" timestep="0.002"/>',
}


def bound(option: str = "", **attach_kwargs):
    spec = mujoco.MjSpec.from_string(scene_xml(option))
    tips = attach(spec, sites=["pressed", "free"], **attach_kwargs)
    model = spec.compile()
    data = mujoco.MjData(model)
    return model, data, tips.bind(model, data)


def sensors(data: mujoco.MjData, tip: str) -> dict[str, float]:
    return {field: float(data.sensor(sensor_name(tip, field)).data[0]) for field in SENSOR_FIELDS}


@pytest.mark.parametrize("option", OPTIONS.values(), ids=OPTIONS.keys())
def test_a_plain_mj_step_loop_reads_the_plates_weight_from_sensordata(option):
    model, data, sim = bound(option)
    assert model.opt.timestep == 0.002 and sim.period_s == pytest.approx(0.004)  # 5 ms -> two 2 ms steps
    pressed, free = [], []
    while data.time < 2.0:
        mujoco.mj_step(model, data)
        if data.time > 1.0:
            pressed.append(sensors(data, "pressed"))
            free.append(sensors(data, "free"))
    # The statics are the gel law's under every integrator (the strips' force is the law): within
    # 1e-5, the law's table (measured: 1.2e-6 under the explicit integrators' ramped contact, the
    # plate still settling by a micronewton; 1e-7 under discrete).
    assert sim.pad_state("pressed").normal_force_n == pytest.approx(PLATE_KG * G, rel=1e-5)
    assert all(s["true_pressure_pa"] == pytest.approx(PRESSURE_PA, rel=1e-5) for s in pressed)
    ok = [s for s in pressed if s["status"] == STATUS_CODES["ok"]]
    assert len(ok) >= 0.9 * len(pressed)
    for s in ok:
        assert abs(s["pressure_pa"] - PRESSURE_PA) <= 3 * s["sigma_pa"]
        assert s["mode"] == 1
    assert {s["status"] for s in free} <= {STATUS_CODES["below_detection"], STATUS_CODES["settling"]}


def test_every_mode_that_reads_ok_holds_the_applied_pressure_under_mujocos_defaults():
    """MuJoCo's default options; each of the fingertip's modes driven in turn in a plain loop,
    one second to ring up and settle, then one second of readings from sensordata."""
    model, data, sim = bound(OPTIONS["mujoco-default"])
    read_ok = []
    for mode in sim.tips.config.sensor.modes:
        sim.set_mode("pressed", mode)
        readings = []
        start_s = data.time
        while data.time < start_s + 2.0:
            mujoco.mj_step(model, data)
            if data.time > start_s + 1.0:
                readings.append(sensors(data, "pressed"))
        assert all(r["mode"] == mode for r in readings)
        ok = [r for r in readings if r["status"] == STATUS_CODES["ok"]]
        for r in ok:
            assert abs(r["pressure_pa"] - PRESSURE_PA) <= 3 * r["sigma_pa"], (mode, r)
        if len(ok) >= 0.5 * len(readings):
            read_ok.append(mode)
    assert read_ok == list(sim.tips.config.sensor.modes)  # 2.45 kPa is within every mode's range (measured: all four)


@pytest.mark.parametrize("option", [OPTIONS["mujoco-default"], OPTIONS["RK4"]], ids=["Euler", "RK4"])
def test_the_touch_under_an_explicit_integrator_stays_near_the_reference(option):
    """The plate dropped on the pad: its gel force against a discrete 0.1 ms reference, over the
    first 0.3 s.  The explicit integrators' softer contact (3 steps, the house's 30 um ramp:
    cosim.attach.EXPLICIT_PAD_SOLIMP) and their strips' mass scaling and damping may cost at most
    twice what the house's discrete integrator at the same 2 ms step does (measured: 6.2 % of the
    load for discrete, 8.9 % Euler, 11.7 % RK4: the softer contact loads the pad a step later)."""

    def trace(option_xml: str) -> tuple[np.ndarray, np.ndarray]:
        model, data, sim = bound(option_xml)
        t, load = [], []
        while data.time < 0.3 - 1e-9:
            mujoco.mj_step(model, data)
            t.append(data.time)
            load.append(sim.pad_state("pressed").gel_force_n / (PLATE_KG * G))
        return np.array(t), np.array(load)

    t_ref, load_ref = trace('<option integrator="discrete" timestep="0.0001"/>')
    t_disc, load_disc = trace(OPTIONS["discrete"])
    t, load = trace(option)
    house_error = np.abs(load_disc - np.interp(t_disc, t_ref, load_ref)).max()
    error = np.abs(load - np.interp(t, t_ref, load_ref))
    assert error.max() <= 2.0 * house_error
    assert error[t > 0.1].max() < 1e-3  # settled on the same load


def test_mass_scaling_only_under_explicit_integrators():
    _, _, implicit = bound(OPTIONS["discrete"])
    assert not implicit.gel.armature_kg().any()
    model, data, explicit = bound(OPTIONS["mujoco-default"])
    for _ in range(500):
        mujoco.mj_step(model, data)
    armature = explicit.gel.armature_kg()
    # At 2 ms even the unloaded gel needs it (its strip rings at omega h = 2.2 on its own mass);
    # the pressed pad's strips, stiffer, need more.
    assert armature[3:].min() > 0
    assert armature[:3].sum() > armature[3:].sum()


@pytest.mark.usefixtures("dispatch")
def test_a_model_without_fingertips_steps_bit_for_bit_as_before():
    xml = """<mujoco><worldbody><geom type="plane" size="1 1 .1"/>
      <body pos="0 0 .2"><freejoint/><geom type="box" size=".05 .04 .03"/></body>
      <body pos=".02 0 .5"><freejoint/><geom type="sphere" size=".03"/></body></worldbody>
      <sensor><user name="theirs" dim="1" needstage="acc"/></sensor></mujoco>"""

    def run() -> np.ndarray:
        model = mujoco.MjModel.from_xml_string(xml)
        data = mujoco.MjData(model)
        states = []
        for _ in range(400):
            mujoco.mj_step(model, data)
            states.append(np.concatenate([data.qpos, data.qvel, data.sensordata]))
        return np.array(states)

    before = run()
    _, _, sim = bound()  # the callbacks are installed from here on
    sim.step()
    assert mujoco.get_mjcb_passive() is not None
    after = run()
    np.testing.assert_array_equal(after, before)


@pytest.mark.usefixtures("dispatch")
def test_two_bound_models_do_not_interfere():
    def readings(interleave: bool) -> np.ndarray:
        a, b = bound(), bound(config={"sensor.seed": 7})
        out = []
        for _ in range(300):
            for model, data, _ in (a, b) if interleave else (a,):
                mujoco.mj_step(model, data)
            out.append(a[1].sensordata.copy())
        return np.array(out)

    np.testing.assert_array_equal(readings(interleave=True), readings(interleave=False))


def test_set_mode_acts_in_a_plain_loop_and_a_reset_restarts_the_readout():
    model, data, sim = bound()
    first = []
    for _ in range(50):
        mujoco.mj_step(model, data)
        first.append(list(data.sensordata))
    sim.set_mode("pressed", 2)
    for _ in range(10):
        mujoco.mj_step(model, data)
    assert data.sensor(sensor_name("pressed", "mode")).data[0] == 2
    mujoco.mj_resetData(model, data)  # time goes back: the readout starts as at bind, in mode 1
    again = []
    for _ in range(50):
        mujoco.mj_step(model, data)
        again.append(list(data.sensordata))
    # The same noise; the first step after the reset still has the strips' last armature and
    # damping (MuJoCo builds the mass matrix before the hook sees the reset): 1e-6 apart.
    np.testing.assert_allclose(np.array(again), np.array(first), rtol=1e-5, equal_nan=True)


@pytest.mark.usefixtures("dispatch")
def test_step_and_a_plain_loop_read_the_same():
    _, _, sim = bound()
    model, data, plain = bound()
    for _ in range(100):
        sim.step()
    # A plain loop samples the period's end state in the next step's sensor stage: one step more.
    for _ in range(100 * plain.substeps + 1):
        mujoco.mj_step(model, data)
    assert sim.readings() == plain.readings()


@pytest.mark.parametrize("pad", ["gel", "touch"])
def test_the_fingertips_sensors_cost_mujoco_no_acceleration_stage_pass(pad):
    """The fingertips' ``user`` sensors are of the position stage: MuJoCo runs
    ``mj_rnePostConstraint`` (cacc, cfrc_int, cfrc_ext) at every step for a ``user`` sensor of
    the acceleration stage, and for nothing the fingertips add, so it leaves ``cacc`` unset."""
    model, data, _ = bound(pad=pad)
    users = model.sensor_type == mujoco.mjtSensor.mjSENS_USER
    assert users.sum() == 2 * len(SENSOR_FIELDS)
    assert set(model.sensor_needstage[users].tolist()) == {int(mujoco.mjtStage.mjSTAGE_POS)}
    for _ in range(10):
        mujoco.mj_step(model, data)
    assert sensors(data, "pressed")["status"] == STATUS_CODES["settling"] or np.isfinite(sensors(data, "pressed")["true_pressure_pa"])
    assert not data.cacc.any()


@pytest.mark.usefixtures("dispatch")
def test_a_python_callback_already_set_is_refused_and_a_c_one_is_kept():
    calls = []
    try:
        spec = mujoco.MjSpec.from_string(scene_xml())
        tips = attach(spec, sites=["pressed"])
        model = spec.compile()  # (a Python callback fails MuJoCo's own compiling: set it after)
        mujoco.set_mjcb_passive(lambda m, d: None)
        with pytest.raises(ValueError, match="mjcb_passive is already set"):
            tips.bind(model, mujoco.MjData(model))
        mujoco.set_mjcb_passive(None)
        theirs = ctypes.CFUNCTYPE(None, ctypes.c_void_p, ctypes.c_void_p)(lambda m, d: calls.append(d))
        mujoco.set_mjcb_passive(theirs)
        model, data, _ = bound()
        mujoco.mj_step(model, data)
        assert data._address in calls  # chained: theirs runs first, for every model
    finally:
        mujoco.set_mjcb_passive(None)
        mjhooks._PREVIOUS["passive"] = None


def test_unbind_stops_the_fingertips():
    _, data, sim = bound()
    sim.unbind()
    assert sim._hook not in mjhooks.hooks_of(data)
    with pytest.raises(RuntimeError, match="unbound"):
        sim.step()


@pytest.mark.parametrize("bad", [float("nan"), float("inf"), 1e30])
def test_a_control_mujoco_would_zero_is_an_error_naming_the_actuator(bad):
    xml = scene_xml().replace("</worldbody>", "</worldbody><actuator><motor name='press_motor' joint='press'/></actuator>")
    spec = mujoco.MjSpec.from_string(xml)
    tips = attach(spec, sites=["pressed"])
    model = spec.compile()
    data = mujoco.MjData(model)
    sim = tips.bind(model, data)
    data.ctrl[0] = bad
    with pytest.raises(ValueError, match=r"press_motor = "):
        sim.step()
    assert data.time == 0.0  # refused before stepping


def test_a_reset_within_the_first_period_linearizes_the_gel_law_again():
    """``physics.gel_update=control`` holds the law's linearization over a period; a reset that
    lands in the same period (an episode shorter than a period) must not keep the old one."""
    model, data, sim = bound(OPTIONS["discrete"], config={"physics.gel_update": "control"})
    gel = sim.gel
    data.qpos[gel._qadr] = 1e-3  # every strip 1 mm in, at t = 0: the law linearized there
    mujoco.mj_forward(model, data)
    mujoco.mj_resetData(model, data)  # t = 0 again (the same period), the strips at rest
    mujoco.mj_forward(model, data)
    law = -gel._area * np.interp(data.qpos[gel._qadr], gel._grid, gel._pressure)
    gel_force = data.qfrc_passive[gel._dof] - data.qfrc_damper[gel._dof] - data.qfrc_gravcomp[gel._dof]
    np.testing.assert_allclose(gel_force, law, atol=1e-9)


@pytest.mark.usefixtures("dispatch")
def test_a_bound_mjdata_is_freed_with_its_hooks_and_the_fingertips_run_without_their_loop_object():
    import gc
    import weakref

    model, data, sim = bound()
    del sim  # a plain loop that keeps only its model and data: the fingertips run on
    for _ in range(10):
        mujoco.mj_step(model, data)
    assert data.sensor(sensor_name("pressed", "status")).data[0] in STATUS_CODES.values()
    assert data.sensor(sensor_name("pressed", "true_pressure_pa")).data[0] >= 0.0
    address, gone = data._address, weakref.ref(data)
    del data
    gc.collect()
    assert gone() is None  # nothing of piezotip's keeps it alive (the environments made and dropped by the thousand)
    assert address not in mjhooks._BOUND


def test_touch_pads_install_only_mujocos_sensor_callback():
    """Touch pads need no gel law: MuJoCo's passive callback stays unset (an installed
    dispatcher is a Python call in every model's step of the process), the sensor one is ours."""
    script = """
import mujoco
from test_attach import scene_xml
from piezotip.cosim.attach import attach
spec = mujoco.MjSpec.from_string(scene_xml())
tips = attach(spec, sites=["pressed", "free"], pad="touch")
model = spec.compile()
data = mujoco.MjData(model)
tips.bind(model, data)
mujoco.mj_step(model, data)
print(mujoco.get_mjcb_passive() is None, mujoco.get_mjcb_sensor() is not None)
"""
    import subprocess
    import sys
    from pathlib import Path

    env = {**__import__("os").environ, "PYTHONPATH": str(Path(__file__).parent)}
    result = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, env=env, check=True)
    assert result.stdout.split() == ["True", "True"]


def test_the_readout_pass_refuses_what_it_cannot_read():
    from piezotip.cosim._readout import ReadoutPass

    def make(readers=(None,), touch_adr=(0,), sensor_adr=(1, 2, 3, 4, 5), first=(0.0,) * 5):
        return ReadoutPass(
            [lambda c, dt: None], list(readers), list(touch_adr), [1e-4], [[1.0]], list(sensor_adr), list(first), 1e6, 1e7, STATUS_CODES, 4
        )

    with pytest.raises(ValueError, match="one reader, touch address"):
        make(readers=(None, None))
    with pytest.raises(ValueError, match="5 sensor addresses"):
        make(sensor_adr=(1, 2, 3))
    with pytest.raises(ValueError, match=r"a reader \(gel pad\) or a touch sensor address"):
        make(touch_adr=(-1,))
    readout = make()
    with pytest.raises(ValueError, match=r"outside sensordata \(4 values"):
        readout.bind(np.zeros(4))
    readout.bind(np.zeros(6))
    readout.write()


@pytest.mark.filterwarnings("ignore::pytest.PytestUnraisableExceptionWarning")
@pytest.mark.usefixtures("dispatch")
def test_an_error_inside_mj_step_is_raised_by_the_fingertips_own_loop():
    """MuJoCo's C cannot take a Python exception from its callback (ctypes prints it and steps
    on): the fingertips keep it, and their own loop raises it, naming it, once."""
    model, data, loop = bound()
    hook = loop._hook
    working = hook._pass

    class Broken:
        periods = 0

        def tick(self, stage):
            raise ZeroDivisionError("a broken readout")

    hook._pass = Broken()
    mjhooks.refresh(data)  # the dispatcher's fast path: the broken pass's
    for _ in range(2 * hook.substeps):  # a plain loop: the callback's sample fails, printed
        mujoco.mj_step(model, data)
    with pytest.raises(RuntimeError, match="failed inside mj_step: ZeroDivisionError: a broken readout"):
        loop.readings()
    hook._pass = working
    mjhooks.refresh(data)
    loop.step()  # taken: nothing pending
    assert set(loop.readings()) == {"pressed", "free"}


@pytest.mark.filterwarnings("ignore::pytest.PytestUnraisableExceptionWarning")
@pytest.mark.parametrize("path", ["fast", "python"])
@pytest.mark.usefixtures("dispatch")
def test_ctrl_c_inside_a_callback_reaches_the_fingertips_own_loop(path):
    """A KeyboardInterrupt raised in the callback (Ctrl-C landing there) is printed and dropped by
    ctypes inside ``mj_step``; the fingertips' own loop raises it as it ends its period.  In the
    dispatcher's fast path (the compiled pass's tick) and in the hook's own ``sensor``."""
    _, data, loop = bound()
    hook = loop._hook
    calls = []

    def interrupted(*args):
        if not calls:
            calls.append(args)
            raise KeyboardInterrupt
        return 0

    if path == "fast":
        hook.fast_sensor = lambda: interrupted
    else:
        hook.fast_sensor = lambda: None
        hook.sensor = interrupted
    mjhooks.refresh(data)
    with pytest.raises(KeyboardInterrupt):
        loop.step()
    assert len(calls) == 1
    loop.step()  # taken: nothing pending


@pytest.mark.parametrize("pad", ["gel", "touch"])
def test_the_c_and_the_python_dispatchers_write_the_same_sensordata(pad):
    """The compiled dispatchers run the hooks the Python ones run, in the same order, and take a
    step that samples nothing as the pass's tick does: the same bits in sensordata and in the
    state, over a load that changes (the plate lifted off its pad) and a reset."""
    if mjhooks._C is None:
        pytest.skip("the C dispatchers are not in use (not built, or PIEZOTIP_PURE_PYTHON)")

    def run(compiled: bool) -> np.ndarray:
        before = mjhooks.compiled_dispatch()
        mjhooks.use_compiled(compiled)
        try:
            model, data, _ = bound(pad=pad)
            assert (mujoco.get_mjcb_sensor() is mjhooks._C[0]["sensor"]) == compiled
            out = []
            for k in range(400):
                data.xfrc_applied[model.body("plate").id, 2] = 0.5 * PLATE_KG * G if 150 < k < 300 else 0.0
                if k == 250:  # time goes back: the readout starts afresh (the pass's own tick, then the hook's)
                    mujoco.mj_resetData(model, data)
                mujoco.mj_step(model, data)
                out.append(np.concatenate([data.qpos, data.qvel, data.sensordata]))
            return np.array(out)
        finally:
            mjhooks.use_compiled(before)

    np.testing.assert_array_equal(run(True), run(False))
