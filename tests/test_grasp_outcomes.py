"""Whole grasps judged by the referee: every registered scenario, and the failures a watcher saw."""

import dataclasses
import math

import mujoco
import numpy as np
import pytest

from piezotip import scenarios
from piezotip.analysis.referee import judge
from piezotip.analysis.runner import run_scenario
from piezotip.cosim.control import Phase, grip_floor_n
from piezotip.cosim.loop import REST_MIN_S, CoSimulation, make_fingertip


def grasp(tmp_path, name, *overrides):
    return run_scenario(name, list(overrides), tmp_path, plot=False, quiet=True)


@pytest.mark.slow
@pytest.mark.parametrize("name", scenarios.names())
def test_every_registered_scenario_is_a_success_a_watcher_would_agree_with(tmp_path, name):
    summary, data = grasp(tmp_path, name)
    assert summary["outcome"] == "success", summary["reason"]
    cfg = scenarios.get(name)
    rise = data["object_height_m"] - data["object_height_m"][0]
    assert rise.max() >= cfg.controller.lift_height_m - 0.005
    assert abs(rise[-1]) <= 0.002 and summary["placed"]
    # Put down, not dropped: the object met the table slower than 0.1 m/s, and it was still
    # held by both fingers when it did.
    assert summary["landing_speed_m_s"] < 0.1
    done = np.flatnonzero(data["phase"] == Phase.DONE)
    assert done.size and data["time_s"][-1] - data["time_s"][done[0]] >= REST_MIN_S - 1e-9  # recorded after release
    assert data["object_speed_m_s"][-1] < 0.005
    crush = cfg.object.crush_force_n
    if crush is not None:
        assert summary["peak_grip_force_n"] < crush


@pytest.mark.slow
@pytest.mark.parametrize(
    "overrides",
    [
        # The issue's: a 1 kg cylinder at friction 0.4, below the 0.8 the controller assumes.
        ("object.mass_kg=1", "object.shape='cylinder'", "object.size_m=0.07", "object.friction=0.4"),
        # ... and a 0.2 kg egg at 0.6 that used to slide out of the fingers.
        ("object.mass_kg=0.2", "object.shape='egg'", "object.size_m=0.044", "object.friction=0.6"),
    ],
)
def test_objects_slipperier_than_assumed_are_still_carried(tmp_path, overrides):
    summary, _ = grasp(tmp_path, "grasp", *overrides, "controller.kind=multimode")  # its assumed friction
    assert summary["outcome"] == "success", summary["reason"]
    assert any(e["kind"] == "on_table" for e in summary["events"])  # the friction check found it


_LOAD_LAG = pytest.mark.xfail(
    strict=True,
    reason="known defect of the multimode controller (docs/cosimulation.md, 'The friction check'): the lift's load "
    "estimate differentiates the lift's velocity over "
    "the 5 ms control period, which lags the gripper's inertia (1.06 kg) while the servo settles; on a 1-2 g "
    "object that lag (8 mN of a 20 mN weight just after lift-off) still reads as the load following the grip",
)


@pytest.mark.slow
@pytest.mark.parametrize(
    "name",
    [
        pytest.param("tissue-box-1g", marks=_LOAD_LAG),
        pytest.param("paper-ball-2g", marks=_LOAD_LAG),
        "cube-3g",
        "box-100g",
        "can-500g",
    ],
)
def test_a_friction_check_says_on_the_table_only_of_an_object_the_table_touched(tmp_path, name):
    """The check compares the load before and after a grip raise, each averaged over the plateau
    window (60 ms) in which the lift followed its goal.  It used a 50 ms low-pass instead, which
    after that window had caught only 70 % of the load taken on at lift-off: the check read the
    filter's own rise as the load following the grip and said "still on the table" of every light
    object that had left it, each verdict raising the grip by the safety factor (the 2 g paper
    ball was held at 0.092 N against its 0.1 N limit and crushed at touchdown).  Ground truth:
    every "on_table" verdict needs the table touching the object at some time during its check."""
    from piezotip.cosim.recorder import Recorder, read_recording

    config = scenarios.get("grasp", [*scenarios.object_overrides(name), "controller.kind=multimode"])  # its friction checks
    sim = CoSimulation(config)
    c = sim.controller
    table = sim._table_i + 2
    state = {"touched": False, "seen": 0}
    verdicts = []

    def watch(sim) -> None:
        for event in c.events[state["seen"] :]:
            if event.kind == "on_table":
                verdicts.append((round(event.time_s, 3), state["touched"]))
                state["touched"] = False
        state["seen"] = len(c.events)
        if c._check is None:
            state["touched"] = False
        elif abs(sim.data.sensordata[table]) > 0.0:
            state["touched"] = True

    result = sim.run(Recorder(tmp_path / "run"), on_step=watch)
    assert all(touched for _, touched in verdicts), f"on_table said of an object off the table: {verdicts}"
    data, _ = read_recording(result.files[0])
    ctrl = config.controller
    verdict = judge(data, ctrl.lift_height_m, ctrl.hold_s, config.object.crush_force_n, [dataclasses.asdict(e) for e in c.events], True)
    assert verdict.outcome == "success", verdict.reason


@pytest.mark.slow
def test_more_than_the_gripper_can_hold_is_a_clear_never_lifted(tmp_path):
    summary, _ = grasp(tmp_path, "grasp-10kg", "object.friction=0.3")  # needs 164 N per finger
    assert summary["outcome"] == "never_lifted" and not summary["success"]
    assert "100 N" in summary["reason"]
    assert summary["sim_time_s"] < 8.0  # it gave up, it did not run out the clock (12 s)


@pytest.mark.slow
def test_a_grasp_the_fingertip_cannot_measure_gives_up_blind(tmp_path):
    summary, _ = grasp(tmp_path, "grasp-heavy", "controller.modes=[1]")
    assert summary["outcome"] == "blind", summary["reason"]
    assert summary["sim_time_s"] < 6.0


def _ice_pads(sim, friction):
    pads = [g for g in range(sim.model.ngeom) if "_pad_" in (mujoco.mj_id2name(sim.model, mujoco.mjtObj.mjOBJ_GEOM, g) or "")]
    sim.model.geom_friction[pads, 0] = friction


@pytest.mark.slow
def test_a_slip_in_the_hold_is_felt_and_answered():
    """The pads' friction falls from 1 to 0.3 in mid-hold: the box starts to slide, the lift feels
    the weight go, the grip rises by what it fell short, and the box stays in the fingers."""
    cfg = scenarios.get("grasp")
    sim = CoSimulation(cfg)
    rows = []
    while sim.controller.phase is not Phase.HOLD:
        rows.append(sim.step())
    for _ in range(80):  # past the hold's settling
        rows.append(sim.step())
    _ice_pads(sim, 0.3)
    while not sim.controller.finished:
        rows.append(sim.step())
    slips = [e for e in sim.controller.events if e.kind == "slip"]
    assert slips and "grip" in slips[0].message
    data = {k: np.array([r[k] for r in rows]) for k in rows[0]}
    events = [e.__dict__ for e in sim.controller.events]
    verdict = judge(data, cfg.controller.lift_height_m, cfg.controller.hold_s, None, events, sim.controller.finished)
    assert verdict.outcome == "success", verdict.reason
    assert 0.5e-3 < verdict.max_slip_m < 5e-3  # it did slide, and was caught within the tolerance


@pytest.mark.slow
def test_a_lost_object_is_noticed_and_reported(tmp_path):
    """The pads turn to ice in mid-hold: the box falls; the fingertips notice and the controller stops."""
    cfg = scenarios.get("grasp")
    sim = CoSimulation(cfg)
    rows = []
    while sim.controller.phase is not Phase.HOLD:
        rows.append(sim.step())
    _ice_pads(sim, 1e-4)
    t_lost = sim.time_s
    while not sim.controller.finished and sim.time_s < t_lost + 4.0:  # opening from shut takes 1.8 s
        rows.append(sim.step())
    kinds = [e.kind for e in sim.controller.events]
    assert "lost" in kinds, kinds
    lost = next(e for e in sim.controller.events if e.kind == "lost")
    assert lost.time_s - t_lost < 0.5  # not a second of holding an empty gripper
    assert sim.controller.finished
    data = {k: np.array([r[k] for r in rows]) for k in rows[0]}
    verdict = judge(data, cfg.controller.lift_height_m, cfg.controller.hold_s, None, [e.__dict__ for e in sim.controller.events])
    assert verdict.outcome == "dropped"


def _shut_and_settling(sim, readings: int) -> list[str]:
    """From the hold: ``readings`` control steps in which both fingertips read "settling" and
    the fingers report an opening 1 mm past the object's width less the pads' travel (what a
    high grip's yielding mechanism shows, just after a mode switch); the controller's events
    of those steps."""
    from piezotip.cosim.control.interface import PadSignal
    from piezotip.sensor.estimator import Estimate

    settling = Estimate(math.nan, math.nan, "settling")
    ctrl = sim.controller
    past_width = ctrl._width_m - 2.0 * ctrl.robot.pad_travel_m - 1e-3
    before = len(ctrl.events)
    for _ in range(readings):
        obs = sim.sense()
        pads = {pad: PadSignal(sig.reading, settling) for pad, sig in obs.pads.items()}
        sim.act(ctrl.step(dataclasses.replace(obs, opening_m=past_width, pads=pads), sim.dt))
    return [e.kind for e in ctrl.events[before:]]


@pytest.mark.slow
def test_fingers_past_the_width_while_both_fingertips_settle_is_not_yet_a_loss():
    """Proprioception says "lost" only when it persists for lost_s, as the fingertips' own
    loss does: "settling" is unknown, not empty (it called a held object lost at once)."""
    cfg = scenarios.get("grasp")
    lost_steps = round(cfg.controller.lost_s / cfg.physics.control_period_s)
    sim = CoSimulation(cfg)
    while sim.controller.phase is not Phase.HOLD:
        sim.step()
    for _ in range(20):
        sim.step()
    assert "lost" not in _shut_and_settling(sim, lost_steps - 1)
    for _ in range(5):  # the fingertips read the load again: the count starts over
        sim.step()
    assert sim.controller.phase is Phase.HOLD
    kinds = _shut_and_settling(sim, lost_steps)
    assert kinds.count("lost") == 1 and sim.controller.phase is Phase.RELEASE, kinds


def test_the_first_squeeze_is_the_gentlest_the_fingertip_resolves():
    """The grip floor is where the lowest mode resolves 10 % of the pressure (physics.md section 5)."""
    cfg = scenarios.get("grasp-raspberry")
    tip = make_fingertip(cfg)
    area = 4e-4
    floor = grip_floor_n(tip, 1, area)
    p = floor / area
    assert tip.resolution(p, 1) / p == pytest.approx(0.1, rel=0.05)  # the criterion, at the floor
    assert tip.resolution(0.9 * p, 1) / (0.9 * p) > 0.1  # and not below it
    assert floor < 0.01  # a hundredth of a newton, a hundredth of the old fixed 1 N floor


@pytest.mark.slow
def test_a_light_fragile_object_is_held_gently(tmp_path):
    summary, data = grasp(tmp_path, "grasp-raspberry")
    assert summary["outcome"] == "success"
    grip = np.maximum(data["left_finger_force_n"], data["right_finger_force_n"])
    held = data["phase"] == Phase.HOLD
    weight = 0.004 * 9.81
    # Held with about what its weight needs (m g / (2 mu) = 0.022 N at mu 0.9) times the safety
    # factor and the friction check's margin, far under its 1.5 N crush limit.
    assert np.median(grip[held]) < 10 * weight / (2 * 0.9)
    assert summary["peak_grip_force_n"] < 0.5 * 1.5


@pytest.mark.slow
def test_fingers_open_at_a_grippers_speed_and_opening_is_not_felt_as_pressure(tmp_path):
    _, data = grasp(tmp_path, "grasp-light")
    cfg = scenarios.get("grasp-light").controller
    release = data["phase"] == Phase.RELEASE
    t, opening = data["time_s"][release], data["opening_m"][release]
    speed = np.diff(opening) / np.diff(t)
    assert speed.max() < 1.3 * cfg.opening_speed_m_s
    # With no contact, what the pads still press on the element is their own gel's inertia,
    # rho h0 a: the fingers speed up and brake (into home too, after "done") at the acceleration
    # that keeps it under the lowest mode's detection limit, so the opening is never felt (a
    # set-point step into home jolted the pads with 134 Pa).
    sim = CoSimulation(scenarios.get("grasp-light"))
    p_min = 2.0 * sim.controller.finger_accel_m_s2 * sim.robot.pad_areal_mass_kg_m2  # its definition
    for side in ("left", "right"):
        pressure = data[f"{side}_true_pressure_pa"]
        free = (data["phase"] >= Phase.RELEASE) & (data[f"{side}_finger_force_n"] == 0)
        # once the gel has relaxed from the squeeze (its pressure under the limit), it stays there
        relaxed = free & (np.cumsum(free & (pressure < p_min)) > 0)
        assert relaxed.sum() > 100 and pressure[relaxed].max() < p_min
    done = data["phase"] == Phase.DONE
    assert done.any() and abs(data["grip_force_n"][done]).max() <= grip_floor_or_opening(sim) + 1e-9


def grip_floor_or_opening(sim) -> float:
    """The most the fingers' drive may push once the object is let go: the opening force."""
    return sim.controller.opening_force_n


def rest_to_rest_s(distance: float, top: float, accel: float) -> float:
    """The closed-form time of a trapezoidal move from rest to rest, s: d / v_top + v_top / a with
    a cruise, 2 sqrt(d / a) without."""
    return distance / top + top / accel if distance >= top * top / accel else 2.0 * math.sqrt(distance / accel)


@pytest.mark.parametrize(
    ("distance", "top", "accel", "dt"), [(0.0016, 0.05, 0.5, 0.005), (0.02, 0.05, 0.5, 0.005), (0.1, 0.02, 2.0, 0.001)]
)
def test_a_trapezoidal_move_stops_where_it_should_in_the_time_it_should(distance, top, accel, dt):
    from piezotip.cosim.control.multimode import trapezoid_speed

    x = v = 0.0
    speeds = []
    for _ in range(100000):
        v_new = trapezoid_speed(distance - x, v, top, accel, dt)
        assert abs(v_new - v) <= accel * dt * (1 + 1e-12) + 1e-15  # never a speed step
        v = v_new
        x = min(distance, x + v * dt)
        speeds.append(v)
        if x >= distance and v == 0.0:
            break
    assert x == pytest.approx(distance) and max(speeds) <= top
    expected = rest_to_rest_s(distance, top, accel)  # within a few steps
    assert len(speeds) * dt == pytest.approx(expected, abs=4 * dt + 0.02 * expected)


@pytest.mark.slow
def test_a_placed_soft_object_is_let_go_at_once(tmp_path):
    # The pads' gel, unloading from the squeeze, pushes the fingers open slowly (its stiffness
    # falls with its pressure): a release that restarted its opening profile from rest whenever
    # the fingers crept ahead of it held the raspberry on the table for 1.7 s.  Now the profile
    # keeps its speed and overtakes the creep: the fingers are 2 mm open within the time the
    # profile itself needs for 2 mm from rest, plus a control period or two.
    _, data = grasp(tmp_path, "grasp-raspberry")
    sim = CoSimulation(scenarios.get("grasp-raspberry"))
    accel, dt = sim.controller.finger_accel_m_s2, sim.dt
    top = scenarios.get("grasp-raspberry").controller.opening_speed_m_s
    gap = 0.002
    from_rest = rest_to_rest_s(gap, top, accel)  # more than the profile needs to pass gap
    release = np.flatnonzero(data["phase"] == Phase.RELEASE)
    opening, t = data["opening_m"], data["time_s"]
    opened = release[opening[release] > opening[release[0]] + gap]
    assert opened.size and t[opened[0]] - t[release[0]] <= from_rest + 2 * dt
    # ...and lets it go where it was put: no push, no drag
    after = slice(release[0], None)
    for axis in ("x", "y"):
        drift = data[f"object_{axis}_m"][after]
        assert np.ptp(drift) < 1e-4


@pytest.mark.slow
@pytest.mark.parametrize("preset", [None, "fast"])
def test_an_object_no_fingertip_feels_is_given_up_not_pushed_until_the_clock_runs_out(tmp_path, preset):
    """A 13 mm ball's equator meets the fingers' lower guards, 3.7 mm below the element's gel
    coverage.  With the pad's load landing only straight below it (``sensor.load_spread=none``)
    no fingertip can feel it.  The controller used to close on it until the clock ran out (or
    loop touch, "false touch", close on, a hundred times); now the joints feel the contact,
    the fingertips read nothing at the grip floor, and it says so within a second of the
    fingers stopping (the closing takes 4 s from 90 mm: fast to the camera's band, at the touch
    speed within it) and opens."""
    args = ["object.shape='sphere'", "object.size_m=0.013", "sensor.load_spread=none"]
    summary, data = run_scenario("grasp", args, tmp_path, plot=False, quiet=True, preset=preset)
    assert summary["outcome"] == "never_lifted" and "unfelt_contact" in summary["reason"], summary["reason"]
    gave_up = next(e for e in summary["events"] if e["kind"] == "unfelt_contact")
    touched_s = data["time_s"][np.flatnonzero(np.maximum(data["left_finger_force_n"], data["right_finger_force_n"]) > 0.0)[0]]
    assert gave_up["time_s"] < touched_s + 1.0
    # opened again, off the ball (its 13 mm), and the run ended before its duration
    assert data["opening_m"][-1] > 0.013 and data["left_finger_force_n"][-1] == data["right_finger_force_n"][-1] == 0.0
    assert data["time_s"][-1] < scenarios.get("grasp").duration_s - 1.0
    assert data["left_finger_force_n"].max() > 0.0 and data["right_finger_force_n"].max() > 0.0  # it was touched


@pytest.mark.slow
def test_the_gel_brings_a_touch_beside_the_coverage_to_the_element(tmp_path):
    """The same 13 mm ball, with the gel layer spreading its load (the default): 3.7 mm below
    the coverage under 5 mm of gel, the element feels it, and the ball is carried."""
    args = ["object.shape='sphere'", "object.size_m=0.013"]
    summary, data = run_scenario("grasp", args, tmp_path, plot=False, quiet=True)
    assert summary["outcome"] == "success", summary["reason"]
    touch = np.flatnonzero(data["left_finger_force_n"] > 0.0)[0]
    assert data["left_cell0_pressure_pa"][touch] == 0.0  # nothing over the element itself at first


@pytest.mark.slow
def test_a_fragile_object_touched_outside_the_gel_coverage_is_not_crushed(tmp_path):
    """The 30 mm paper ball (0.1 N) at the accurate preset presses the element's middle strips,
    outside the gel's coverage (its tip millimetre).  It was crushed (0.18 N), then dropped: the
    fingertip felt nothing until the pad's deformation reached its tip strip, 25 ms later, while
    the fingers closed on.  Now the joints stop the closing at the contact, and the gel brings
    the contact's load to the coverage, so the ball is carried."""
    summary, data = run_scenario("grasp", scenarios.object_overrides("paper-ball-2g"), tmp_path, plot=False, quiet=True, preset="accurate")
    # what the fingertip can feel is where the contact lands: here not under the coverage
    touch = np.flatnonzero(data["left_finger_force_n"] > 0.0)[0]
    # (the tip cell's micropascals are the pad's own gel as the fingers slow: rho h0 a)
    assert data["left_cell4_pressure_pa"][touch] < 1e-4 * data["left_cell2_pressure_pa"][touch]
    assert summary["outcome"] == "success", summary["reason"]
    assert any("felt by the joints" in e["message"] for e in summary["events"])


def _finger_forces_every_step(sim) -> list[float]:
    """Each physics step's largest finger force on the object (N), computed independently of
    MuJoCo's sensors from the contacts themselves (mj_contactForce in world x), through the
    loop's own instrument hook (the state each step starts from)."""
    m = sim.model
    obj = m.body("object").id
    force = np.zeros(6)
    seen: list[float] = []

    def before(model, data):
        per_side = {"left": 0.0, "right": 0.0}
        for i in range(data.ncon):
            c = data.contact[i]
            bodies = (model.geom_bodyid[c.geom1], model.geom_bodyid[c.geom2])
            if obj not in bodies:
                continue
            side = model.body(bodies[1] if bodies[0] == obj else bodies[0]).name.partition("_")[0]
            if side in per_side:
                mujoco.mj_contactForce(model, data, i, force)
                per_side[side] += abs((c.frame.reshape(3, 3).T @ force[:3])[0])
        seen.append(max(per_side.values()))

    sim.watch_mj_step(before)
    return seen


@pytest.mark.slow
def test_a_crush_between_two_samples_is_still_a_crush():
    """The fingers' force peaks between control periods (the default grasp's squeeze on the hard
    pad contacts: 6 % over the samples; the ramped ones ring 0.4 %).  For an object with a crush
    limit the loop records each period's peak over its physics steps, equal to the contacts' own
    forces, and the referee judges the crush on it: a limit between the sampled peak and the
    true one is crushed (on the samples it was not)."""
    sim = CoSimulation(scenarios.get("grasp", ["object.crush_force_n=1000", "physics.pad_contact=hard"]))
    every = _finger_forces_every_step(sim)
    rows = []
    while not sim.controller.finished:
        rows.append(sim.advance())
    every.append(max(np.array(rows)[-1, [sim.columns.index(f"{s}_finger_force_n") for s in ("left", "right")]]))  # after the last step
    col = {c: np.array(rows)[:, i] for i, c in enumerate(sim.columns)}
    sampled = np.maximum(col["left_finger_force_n"], col["right_finger_force_n"])
    peak = np.maximum(col["left_finger_peak_force_n"], col["right_finger_peak_force_n"])
    true_peaks = np.array(every[1:]).reshape(-1, sim.substeps).max(axis=1)  # each period's steps
    np.testing.assert_allclose(peak, true_peaks, rtol=1e-9, atol=1e-12)
    assert np.all(peak >= sampled) and peak.max() > 1.03 * sampled.max()
    limit = 0.5 * (peak.max() + sampled.max())
    summary = {"lift_height_m": sim.config.controller.lift_height_m, "hold_s": sim.config.controller.hold_s}
    verdict = judge(col, summary["lift_height_m"], summary["hold_s"], limit, [], True)
    assert verdict.outcome == "crushed" and verdict.peak_grip_force_n == pytest.approx(peak.max())
    without_peaks = {k: v for k, v in col.items() if "peak" not in k}
    assert judge(without_peaks, summary["lift_height_m"], summary["hold_s"], limit, [], True).outcome != "crushed"


def test_peaks_cost_nothing_for_a_robust_object_and_never_change_the_motion():
    """Only an object with a crush limit pays for MuJoCo's sensors in every physics step; the
    sensors never act on the dynamics, so the motion is the same to the last bit."""

    def first_second(overrides):
        sim = CoSimulation(scenarios.get("grasp", [*overrides, "duration_s=1.0"]))
        flags: list[int] = []
        sim.watch_mj_step(lambda m, d: flags.append(int(m.opt.disableflags)))
        sim.run(None, max_steps=200)
        return sim, flags, sim.data.qpos.copy()

    robust, robust_flags, robust_q = first_second([])
    fragile, fragile_flags, fragile_q = first_second(["object.crush_force_n=1000"])
    sensors_off = int(mujoco.mjtDisableBit.mjDSBL_SENSOR)
    assert "left_finger_peak_force_n" not in robust.columns and "left_finger_peak_force_n" in fragile.columns
    assert sum(f & sensors_off != 0 for f in robust_flags) == 200 * (robust.substeps - 1)
    assert not any(f & sensors_off for f in fragile_flags)
    np.testing.assert_array_equal(robust_q, fragile_q)
