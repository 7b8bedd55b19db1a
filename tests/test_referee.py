"""The referee on records made by hand: one clean grasp, and the same grasp broken one way at a time."""

import numpy as np
import pytest

from piezotip.analysis.referee import OUTCOMES, Criteria, Disturbance, disturb_onset_s, judge, outside_model

DT = 0.005
LIFT = 0.05
HOLD = 1.0
Z0 = 0.02  # the object's resting centre height, m
WEIGHT = 0.98  # N


def clean_record() -> dict[str, np.ndarray]:
    """A grasp as a watcher wants it: squeeze, lift 50 mm, hold 1.2 s, lower (the last 5 mm at
    0.02 m/s), open, rest."""
    t = np.arange(0.0, 6.0, DT)
    lift = np.interp(t, [0, 1.0, 1.5, 2.7, 3.15, 3.4, 6.0], [0, 0, LIFT, LIFT, 0.005, 0, 0])
    grip = np.interp(t, [0, 0.5, 0.6, 3.3, 3.4, 6.0], [0, 0, 1.0, 1.0, 0, 0])
    z = Z0 + lift
    vz = np.gradient(z, t)
    carried = (lift > 0) & (grip > 0)
    return {
        "time_s": t,
        "lift_m": -0.26 + lift,
        "object_height_m": z,
        "object_x_m": np.zeros_like(t),
        "object_y_m": np.zeros_like(t),
        "object_vz_m_s": vz,
        "object_speed_m_s": np.abs(vz),
        "table_force_n": np.where(carried, 0.0, WEIGHT),
        "left_finger_force_n": grip.copy(),
        "right_finger_force_n": grip.copy(),
    }


def verdict(data, **kw):
    args = {"lift_height_m": LIFT, "hold_s": HOLD, "crush_force_n": None}
    args.update(kw)
    return judge(data, **args)


def test_a_clean_grasp_is_a_success():
    v = verdict(clean_record())
    assert v.outcome == "success", v.reason
    assert v.lifted and v.placed and v.released and not (v.crushed or v.slipped or v.dropped)
    assert v.held_s == pytest.approx(1.3, abs=0.02)  # at the height asked, less the 5 mm tolerance
    assert v.landing_speed_m_s == pytest.approx(0.02, rel=0.05)
    assert v.object_start_height_m == pytest.approx(Z0) and v.object_final_height_m == pytest.approx(Z0)
    assert v.as_dict()["success"] is True


def test_a_release_in_mid_air_is_dropped():
    d = clean_record()
    t = d["time_s"]
    # The fingers open at the top (t = 2.7 s): the object falls 50 mm, lands at 0.99 m/s.
    open_at = t >= 2.7
    d["left_finger_force_n"][open_at] = d["right_finger_force_n"][open_at] = 0.0
    fall = np.clip(t - 2.7, 0, None)
    z = np.where(open_at, np.maximum(Z0 + LIFT - 0.5 * 9.81 * fall**2, Z0), d["object_height_m"])
    d["object_height_m"] = z
    d["object_vz_m_s"] = np.where(open_at & (z > Z0), -9.81 * fall, np.where(open_at, 0.0, d["object_vz_m_s"]))
    d["table_force_n"] = np.where(open_at & (z <= Z0), WEIGHT, np.where(open_at, 0.0, d["table_force_n"]))
    v = verdict(d)
    assert v.outcome == "dropped", v.reason
    assert "fell from 50.0 mm" in v.reason


def test_an_object_left_on_the_table_never_lifted():
    d = clean_record()
    d["object_height_m"][:] = Z0
    d["object_vz_m_s"][:] = 0.0
    d["object_speed_m_s"][:] = 0.0
    d["table_force_n"][:] = WEIGHT
    v = verdict(d, events=[{"kind": "never_lifted", "message": "the pads slide", "time_s": 1.2}])
    assert v.outcome == "never_lifted"
    assert "rose 0.0 mm" in v.reason and "the pads slide" in v.reason


def _untouched_record() -> dict[str, np.ndarray]:
    """The fingers still closing when the record ends: the object never touched, never moved."""
    d = clean_record()
    for key in ("left_finger_force_n", "right_finger_force_n", "object_vz_m_s", "object_speed_m_s"):
        d[key][:] = 0.0
    d["object_height_m"][:] = Z0
    d["table_force_n"][:] = WEIGHT
    return d


def test_time_running_out_before_any_touch_is_a_timeout_not_never_lifted():
    """`run grasp --set duration_s=1`: the fingers were still closing when the time ran out.
    Nothing was tried on the object, so it did not fail to lift it: the outcome was
    `never_lifted` ("rose 0.0 mm of the 50 mm asked")."""
    v = verdict(_untouched_record(), finished=False)
    assert v.outcome == "timeout", v.reason
    assert "before the fingers touched the object" in v.reason and "6.00 s" in v.reason
    # A controller that gave up without touching (finished) did fail to lift: never_lifted.
    gave_up = verdict(_untouched_record(), events=[{"kind": "no_object", "message": "nothing between the fingers", "time_s": 2.0}])
    assert gave_up.outcome == "never_lifted" and "nothing between the fingers" in gave_up.reason
    # Touched and not lifted when the time ran out: never_lifted, as before.
    d = _untouched_record()
    d["left_finger_force_n"][100:] = d["right_finger_force_n"][100:] = 0.5
    assert verdict(d, finished=False).outcome == "never_lifted"


def test_a_grip_over_the_crush_limit_is_crushed_even_when_the_rest_went_well():
    v = verdict(clean_record(), crush_force_n=0.9)
    assert v.outcome == "crushed" and v.crushed
    assert verdict(clean_record(), crush_force_n=1.1).outcome == "success"


def test_moving_in_the_fingers_beyond_the_tolerance_is_slipped():
    d = clean_record()
    t = d["time_s"]
    sag = np.interp(t, [0, 1.6, 2.4, 6.0], [0, 0, 0.008, 0.008])  # sinks 8 mm in the fingers while held
    d["object_height_m"] = d["object_height_m"] - sag * (d["lift_m"] > -0.26 + 0.01)
    v = verdict(d)
    assert v.outcome == "slipped" and v.max_slip_m > Criteria().slip_tolerance_m
    # 3 mm, under the 5 mm tolerance, is not a slip.
    d = clean_record()
    d["object_height_m"] = d["object_height_m"] - np.interp(t, [0, 1.6, 2.4, 6.0], [0, 0, 0.003, 0.003]) * (d["lift_m"] > -0.25)
    assert not verdict(d).slipped and verdict(d).max_slip_m == pytest.approx(0.003, rel=0.01)


def test_a_landing_faster_than_the_limit_is_dropped():
    d = clean_record()
    i = np.flatnonzero(np.diff((d["table_force_n"] > 0).astype(int)) > 0)[-1]  # the touchdown
    d["object_vz_m_s"][i - 1 : i + 1] = -0.3
    v = verdict(d)
    assert v.outcome == "dropped" and v.landing_speed_m_s == pytest.approx(0.3)


def test_a_grasp_never_released_is_not_a_success():
    d = clean_record()
    d["left_finger_force_n"][-100:] = 0.5
    d["right_finger_force_n"][-100:] = 0.5
    v = verdict(d)
    assert not v.released and v.outcome == "timeout" and "not released" in v.reason


def test_controller_reports_explain_but_physics_comes_first():
    d = clean_record()
    assert verdict(d, finished=False).outcome == "timeout"
    assert verdict(d, error="simulation diverged at t = 1 s").outcome == "fault"
    flat = clean_record()
    for k in ("object_vz_m_s", "object_speed_m_s"):
        flat[k][:] = 0.0
    flat["object_height_m"][:] = Z0
    flat["table_force_n"][:] = WEIGHT
    events = [{"kind": "blind", "message": "needs 2 N, measures 1.2 N", "time_s": 1.0}]
    assert verdict(flat, events=events).outcome == "blind"
    events = [{"kind": "self_test", "message": "coupling lost", "time_s": 0.0}]
    assert verdict(flat, events=events).outcome == "fault"
    # A crushed object is crushed whatever the controller said.
    assert verdict(d, crush_force_n=0.5, events=events).outcome == "crushed"


def test_every_outcome_is_named_and_an_empty_record_is_a_fault():
    assert set(OUTCOMES) == {"success", "crushed", "slipped", "dropped", "never_lifted", "blind", "timeout", "fault"}
    assert verdict({"time_s": np.zeros(0)}).outcome == "fault"


def test_outside_model_names_each_limit():
    limits = {
        "gel_beyond_valid_strain": True,
        "max_gel_strain": 0.6,
        "bottomed": True,
        "element_on_backstop": True,
        "element_overstressed": False,
        "max_bending_stress_pa": 2e7,
    }
    flags = outside_model(limits)
    assert len(flags) == 3 and "60 %" in flags[0] and "backstop" in flags[2]
    assert outside_model({}) == []


# -- grip economy ---------------------------------------------------------------------------


def test_needed_grip_is_the_coulomb_limit_of_two_fingers():
    from piezotip.analysis.referee import needed_grip_n

    # m g / (2 mu): 50 g at mu 0.5 under 9.81 m/s^2 is 0.4905 N per finger (hand-computed).
    assert needed_grip_n(0.05, 0.5, 9.81) == pytest.approx(0.4905, rel=1e-12)
    # Three fingers share it three ways; twice the friction halves it.
    assert needed_grip_n(0.05, 0.5, 9.81, fingers=3) == pytest.approx(0.4905 * 2 / 3)
    assert needed_grip_n(0.05, 1.0, 9.81) == pytest.approx(0.4905 / 2)
    for bad in ((0.0, 0.5), (0.05, -1.0), (float("nan"), 0.5)):
        with pytest.raises(ValueError, match="needed_grip_n"):
            needed_grip_n(*bad)


def test_hold_grip_is_the_median_while_carried_clear_of_the_table():
    d = clean_record()
    carried = d["table_force_n"] == 0.0
    # A grip spike at touch (on the table) and a 3x grip over a short stretch of the carry: the
    # median over the carry is the steady 1 N, the peak contact the spike.
    d["left_finger_force_n"][100] = d["right_finger_force_n"][100] = 7.0
    burst = np.flatnonzero(carried)[:20]
    d["left_finger_force_n"][burst] = d["right_finger_force_n"][burst] = 3.0
    # The two fingers unequal: the grip is their mean.
    d["left_finger_force_n"][carried] *= 1.2
    d["right_finger_force_n"][carried] *= 0.8
    v = verdict(d, needed_grip=0.8)
    assert v.hold_grip_n == pytest.approx(1.0)
    assert v.needed_grip_n == 0.8
    assert v.grip_margin == pytest.approx(1.25)
    assert v.peak_contact_n == pytest.approx(7.0)
    assert {"hold_grip_n", "needed_grip_n", "grip_margin", "peak_contact_n"} <= set(v.as_dict())


def test_grip_economy_is_nan_where_nothing_was_carried_or_needed_unknown():
    d = clean_record()
    d["object_height_m"] = np.full_like(d["time_s"], Z0)  # never left the table
    v = verdict(d, needed_grip=0.5)
    assert np.isnan(v.hold_grip_n) and np.isnan(v.grip_margin) and v.needed_grip_n == 0.5
    v = verdict(clean_record())
    assert np.isnan(v.needed_grip_n) and np.isnan(v.grip_margin) and v.hold_grip_n == pytest.approx(1.0)


# -- the touch: touch_peak_n and time_to_touch_s (issue 43, item 5) -------------------------

#: The recorded phase codes (cosim.control.Phase).
P_CLOSE, P_SQUEEZE, P_LIFT, P_HOLD, P_PLACE = 1, 2, 3, 4, 5


def touch_record() -> dict[str, np.ndarray]:
    """A hand-made grasp whose touch is known: closing starts at sample 20 (0.1 s); a finger's
    force of 0.1 uN (under the 1 uN contact threshold) at samples 90-99; the left finger touches
    at sample 100 (0.5 s), the right at 102; 3 N at 150 and 4 N at 209, the last sample on the
    table; the object is 10 mm up from sample 210 on (9 N there, 7 N while held: after lift-off)."""
    n = 800
    t = np.arange(n) * DT
    phase = np.zeros(n)
    for start, code in ((20, P_CLOSE), (120, P_SQUEEZE), (200, P_LIFT), (300, P_HOLD), (500, P_PLACE)):
        phase[start:] = code
    left, right = np.zeros(n), np.zeros(n)
    left[90:100] = 1e-7
    left[100:700], right[102:700] = 0.2, 0.2
    right[150], left[209], right[210], left[400] = 3.0, 4.0, 9.0, 7.0
    z = np.full(n, Z0)
    z[210:600] += 0.01
    return {
        "time_s": t,
        "phase": phase,
        "lift_m": -0.26 + (z - Z0),
        "object_height_m": z,
        "object_x_m": np.zeros(n),
        "object_y_m": np.zeros(n),
        "object_vz_m_s": np.zeros(n),
        "object_speed_m_s": np.zeros(n),
        "table_force_n": np.where(z > Z0, 0.0, WEIGHT),
        "left_finger_force_n": left,
        "right_finger_force_n": right,
    }


def test_touch_peak_is_the_largest_finger_force_from_first_contact_until_lift_off():
    v = verdict(touch_record())
    assert v.touch_peak_n == 4.0  # sample 209's; 9 N at the lift-off sample and 7 N held come after
    assert v.peak_contact_n == 9.0  # (the whole run's peak, for contrast)
    assert v.time_to_touch_s == pytest.approx(0.5 - 0.1, abs=1e-12)  # sample 100 less sample 20
    assert {"touch_peak_n", "time_to_touch_s"} <= set(v.as_dict())


def test_touch_peak_reads_the_fingers_peak_between_samples_where_recorded():
    d = touch_record()
    d["left_finger_peak_force_n"] = d["left_finger_force_n"].copy()
    d["right_finger_peak_force_n"] = d["right_finger_force_n"].copy()
    d["right_finger_peak_force_n"][180] = 5.5  # between two samples, on the table
    assert verdict(d).touch_peak_n == 5.5


def test_touch_metrics_are_nan_when_never_touched_and_the_time_without_a_close_phase():
    d = touch_record()
    d["left_finger_force_n"][:] = d["right_finger_force_n"][:] = 0.0
    v = verdict(d)
    assert np.isnan(v.touch_peak_n) and np.isnan(v.time_to_touch_s)
    d = touch_record()
    del d["phase"]
    v = verdict(d)
    assert v.touch_peak_n == 4.0 and np.isnan(v.time_to_touch_s)


def test_touch_peak_runs_to_the_end_of_a_record_that_never_leaves_the_table():
    d = touch_record()
    d["object_height_m"][:] = Z0
    assert verdict(d).touch_peak_n == 9.0


# -- a load change while held: disturb_* (issue 43, item 4) ----------------------------------


def disturbed_record() -> dict[str, np.ndarray]:
    """A hand-made hold with a load change: the hold is samples 300-499 (1.5-2.495 s) of a 1 s
    hold, so the load comes on at 2.0 s (sample 400); the grip is 1 N, 1.05 N at 402 (short of
    +10 %), 1.2 N at 403-404, dips to 1.05 N at 405 (pads chattering), 1.5 N from 406 on (3 N at
    420-425), and the object sinks 1.5 mm in the fingers from 420 and sways 2 mm sideways at 450:
    2.5 mm from where it was; after the hold (550) it sinks 10 mm more, which is not counted."""
    n = 800
    t = np.arange(n) * DT
    phase = np.zeros(n)
    for start, code in ((20, P_CLOSE), (120, P_SQUEEZE), (200, P_LIFT), (300, P_HOLD), (500, P_PLACE)):
        phase[start:] = code
    up = np.zeros(n)
    up[200:600] = LIFT
    lift = -0.26 + up
    z = Z0 + up
    z[420:600] -= 0.0015
    z[550:600] -= 0.01
    x = np.zeros(n)
    x[450] = 0.002
    grip = np.zeros(n)
    grip[100:700] = 1.0
    grip[402], grip[403:405], grip[405], grip[406:600] = 1.05, 1.2, 1.05, 1.5
    grip[420:426] = 3.0
    return {
        "time_s": t,
        "phase": phase,
        "lift_m": lift,
        "object_height_m": z,
        "object_x_m": x,
        "object_y_m": np.zeros(n),
        "object_vz_m_s": np.zeros(n),
        "object_speed_m_s": np.zeros(n),
        "table_force_n": np.where(up > 0, 0.0, WEIGHT),
        "left_finger_force_n": grip.copy(),
        "right_finger_force_n": grip.copy(),
    }


LOAD = Disturbance(extra_load_n=WEIGHT, ramp_s=0.05, needed_grip_n=1.2)


def test_the_disturbance_starts_at_the_middle_of_the_recorded_hold():
    d = disturbed_record()
    assert disturb_onset_s(d["time_s"], d["phase"], HOLD) == pytest.approx(1.5 + 0.5)
    assert np.isnan(disturb_onset_s(d["time_s"], np.zeros_like(d["phase"]), HOLD))


def test_disturbance_metrics_from_a_hand_made_record():
    v = verdict(disturbed_record(), disturbance=LOAD)
    assert v.disturb_slip_mm == pytest.approx(2.5, rel=1e-9)  # sqrt(1.5^2 + 2^2), within the hold only
    assert v.disturb_reaction_ms == pytest.approx(30.0, abs=1e-6)  # sample 406 (2.03 s): the lasting rise
    assert v.disturb_hold_grip_n == 1.5  # the median from the ramp's end (2.05 s) to the hold's end
    assert v.disturb_needed_grip_n == 1.2
    assert v.disturb_grip_margin == pytest.approx(1.25)
    keys = {"disturb_slip_mm", "disturb_reaction_ms", "disturb_hold_grip_n", "disturb_needed_grip_n", "disturb_grip_margin"}
    assert keys <= set(v.as_dict())


def test_a_grip_that_rises_and_is_then_lost_has_no_reaction():
    d = disturbed_record()
    d["left_finger_force_n"][480:] = d["right_finger_force_n"][480:] = 0.0  # let go before the hold ends
    v = verdict(d, disturbance=LOAD)
    assert np.isnan(v.disturb_reaction_ms) and np.isfinite(v.disturb_slip_mm)


def test_disturbance_metrics_are_nan_without_one_or_without_a_hold():
    v = verdict(disturbed_record())
    assert all(np.isnan(getattr(v, k)) for k in ("disturb_slip_mm", "disturb_reaction_ms", "disturb_needed_grip_n", "disturb_grip_margin"))
    d = disturbed_record()
    d["phase"][d["phase"] == P_HOLD] = P_LIFT  # never held
    v = verdict(d, disturbance=LOAD)
    assert np.isnan(v.disturb_slip_mm) and np.isnan(v.disturb_reaction_ms) and np.isnan(v.disturb_hold_grip_n)
    assert v.disturb_needed_grip_n == 1.2  # known without a hold


def test_the_referees_phase_codes_are_the_controllers():
    from piezotip.analysis import referee
    from piezotip.cosim.control import Phase

    assert (referee.CLOSE_PHASE, referee.HOLD_PHASE) == (Phase.CLOSE, Phase.HOLD)


def test_needed_grip_under_an_extra_load_adds_it_to_the_weight():
    from piezotip.analysis.referee import needed_grip_n

    # (m g + extra) / (2 mu): 100 g under 9.81 m/s^2 with its own weight again, mu 1: 0.981 N.
    assert needed_grip_n(0.1, 1.0, 9.81, extra_load_n=0.981) == pytest.approx(0.981, rel=1e-12)
    with pytest.raises(ValueError, match="extra load"):
        needed_grip_n(0.1, 1.0, extra_load_n=-1.0)


# -- the need on tilted contacts (a round object held above its centre) ---------------------


def test_needed_grip_on_tilted_contacts_is_the_wedges_law():
    """G = m g / sum_i tan(phi - a_i), phi = atan(mu): level contacts give m g / (2 mu); contacts
    pressing the object down need more, contacts under its centre less; past the friction angle
    no squeeze holds it."""
    import math

    from piezotip.analysis.referee import needed_grip_n, tilted_need_factor

    level = needed_grip_n(0.004, 0.9, 9.81)
    assert needed_grip_n(0.004, 0.9, 9.81, tilts_rad=[0.0, 0.0]) == pytest.approx(level, rel=1e-12)
    # 45 degrees of friction (mu = 1) less 15 of tilt leaves 30: tan 30 = 1 / sqrt 3 a finger.
    assert needed_grip_n(0.1, 1.0, 10.0, tilts_rad=[math.radians(15)] * 2) == pytest.approx(1.0 / (2 / math.sqrt(3)), rel=1e-12)
    # One finger level, one tilted by 15 degrees (mu = 1): 1 / (tan 45 + tan 30).
    assert needed_grip_n(0.1, 1.0, 10.0, tilts_rad=[0.0, math.radians(15)]) == pytest.approx(1.0 / (1 + 1 / math.sqrt(3)), rel=1e-12)
    assert needed_grip_n(0.004, 0.9, 9.81, tilts_rad=[-0.2, -0.2]) < level < needed_grip_n(0.004, 0.9, 9.81, tilts_rad=[0.2, 0.2])
    assert needed_grip_n(0.004, 0.9, 9.81, tilts_rad=[math.atan(0.9) + 1e-6] * 2) == math.inf  # past the friction angle
    assert tilted_need_factor(0.9, [0.0, 0.0]) == pytest.approx(1.0, rel=1e-12)
    for bad in ([], [float("nan"), 0.0], [2.0, 0.0]):
        with pytest.raises(ValueError, match="tilts_rad"):
            needed_grip_n(0.004, 0.9, 9.81, tilts_rad=bad)


def _pinched_sphere_holds(plate_bottom_m: float, grip_n: float) -> tuple[bool, float]:
    """A 4 g, 20 mm sphere (mu 0.9) pinched by two plates pushed at it with ``grip_n`` each,
    their lower edges ``plate_bottom_m`` above its centre (below it: its equator meets their
    faces): whether it is held after 0.6 s (sunk < 2 mm), and the left contact's tilt (rad, from
    MuJoCo's contact sensor, as the record's).  Exact Coulomb friction: elliptic cones, no creep
    (the noslip solver), stiff contacts."""
    import math

    import mujoco

    radius, face = 0.01, math.sqrt(0.01**2 - max(0.0, plate_bottom_m) ** 2)
    zc = plate_bottom_m + 0.02
    xml = f"""<mujoco><option timestep="0.0005" cone="elliptic" noslip_iterations="50"/>
      <default><geom friction="0.9 0.005 0.0001" solref="0.002 1"/></default>
      <worldbody>
        <body name="object"><freejoint/><geom type="sphere" size="{radius}" mass="0.004"/></body>
        <body name="left" pos="{-face - 0.002} 0 {zc}"><joint name="lx" type="slide" axis="1 0 0" damping="0.5"/>
          <geom type="box" size="0.002 0.01 0.02" mass="0.01"/></body>
        <body name="right" pos="{face + 0.002} 0 {zc}"><joint name="rx" type="slide" axis="-1 0 0" damping="0.5"/>
          <geom type="box" size="0.002 0.01 0.02" mass="0.01"/></body>
      </worldbody>
      <sensor><contact name="normal" body1="left" body2="object" data="found normal" reduce="maxforce"/></sensor></mujoco>"""
    model = mujoco.MjModel.from_xml_string(xml)
    data = mujoco.MjData(model)
    data.qfrc_applied[model.jnt_dofadr[[model.joint("lx").id, model.joint("rx").id]]] = grip_n
    for _ in range(1200):
        mujoco.mj_step(model, data)
    found, nx, ny, nz = data.sensor("normal").data
    return bool(data.qpos[2] > -0.002), math.atan2(-nz, math.hypot(nx, ny)) if found > 0 else math.nan


@pytest.mark.parametrize("plate_bottom_mm", [-20.0, 1.5, 3.0], ids=["level", "9-degrees", "17-degrees"])
def test_the_tilted_need_is_the_least_grip_that_holds_a_sphere_in_mujoco(plate_bottom_mm):
    """The independent number: the least grip that holds, found by bisection in MuJoCo, against
    needed_grip_n on the tilt MuJoCo's contact sensor reports (within 2 %; the level need is
    short by 27 % and 50 % on the tilted ones: they need 1.38 and 2.0 times it)."""
    from piezotip.analysis.referee import needed_grip_n

    low, high = 0.004 * 9.81 * 0.1, 0.004 * 9.81 * 5
    for _ in range(14):
        mid = 0.5 * (low + high)
        low, high = (low, mid) if _pinched_sphere_holds(1e-3 * plate_bottom_mm, mid)[0] else (mid, high)
    held, tilt = _pinched_sphere_holds(1e-3 * plate_bottom_mm, 1.2 * high)
    assert held
    assert high == pytest.approx(needed_grip_n(0.004, 0.9, 9.81, tilts_rad=[tilt, tilt]), rel=0.02)


def test_the_judge_reads_the_need_on_the_contacts_recorded_tilts():
    """With the friction given and the record's contact tilts, the need (and a disturbance's) is
    the tilted one; without the friction, or without tilts, the level one."""
    import math

    from piezotip.analysis.referee import tilted_need_factor

    d = clean_record()
    tilt = math.radians(10.0)
    d["left_contact_tilt_rad"] = np.where(d["left_finger_force_n"] > 0, tilt, np.nan)
    d["right_contact_tilt_rad"] = np.where(d["right_finger_force_n"] > 0, tilt, np.nan)
    factor = tilted_need_factor(0.9, [tilt, tilt])
    assert factor == pytest.approx((1 + 0.9 * math.tan(tilt)) / (1 - math.tan(tilt) / 0.9), rel=1e-12)  # tan(phi) / tan(phi - a)
    v = verdict(d, needed_grip=0.5, friction=0.9)
    assert v.needed_grip_n == pytest.approx(0.5 * factor) and v.grip_margin == pytest.approx(1.0 / (0.5 * factor))
    assert v.contact_tilt_deg == pytest.approx(10.0)
    level = verdict(d, needed_grip=0.5)
    assert level.needed_grip_n == 0.5 and level.contact_tilt_deg == pytest.approx(10.0)
    assert math.isnan(verdict(clean_record(), needed_grip=0.5, friction=0.9).contact_tilt_deg)
    assert verdict(clean_record(), needed_grip=0.5, friction=0.9).needed_grip_n == 0.5
