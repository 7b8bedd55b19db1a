"""The lift's planning (cosim/control/lift.py), apart from any simulation: the raise's speed
profile, the servo target's feed-forward, the load's tare and filter, the plateau window, the
hold's sliding load and the touchdown's table check, and the grip that follows the load."""

from __future__ import annotations

import dataclasses
import itertools
import math

import pytest

from piezotip.cosim.control.interface import RobotLimits
from piezotip.cosim.control.lift import LiftPlan, grip_for_load_n, ratchet_grip_n

ROBOT = RobotLimits(
    lift_kp_n_m=2e4,
    lift_kv_n_s_m=600.0,
    lift_force_limit_n=300.0,
    lift_range_m=(-0.25, 0.1),
    finger_force_limit_n=100.0,
    finger_damping_n_s_m=40.0,
    lift_moving_mass_kg=1.0,
    pad_area_m2=4e-4,
    pad_travel_m=4e-3,
    pad_areal_mass_kg_m2=5.0,
    min_load_n=0.005,
    home_lift_m=0.0,
    home_opening_m=0.09,
    gravity_m_s2=9.81,
)
DT_S = 0.005


def test_the_pads_height_is_the_lifts_plus_their_rise_along_the_arc():
    """RobotLimits.pads_height_m: the lift's position where the pads slide (no table); with a
    table, plus the rise linear between its points and held at its ends."""
    assert ROBOT.pads_height_m(0.012, 0.04) == 0.012
    arc = dataclasses.replace(ROBOT, pad_rise_m=((0.01, 0.03, 0.05), (-0.004, -0.002, 0.0)))
    assert arc.pads_height_m(0.1, 0.02) == pytest.approx(0.1 - 0.003, abs=1e-15)
    assert arc.pads_height_m(0.1, 0.045) == pytest.approx(0.1 - 0.0005, abs=1e-15)
    assert arc.pads_height_m(0.1, 0.03) == pytest.approx(0.1 - 0.002, abs=1e-15)
    assert arc.pads_height_m(0.1, 0.0) == pytest.approx(0.1 - 0.004, abs=1e-15)
    assert arc.pads_height_m(0.1, 0.09) == pytest.approx(0.1, abs=1e-15)


def test_the_lift_opens_the_fingers_by_its_coupling_times_its_acceleration():
    """RobotLimits.lift_opens_n: -c a (Lagrange's cross term), c linear in the opening between
    the table's points; none without a table (slides)."""
    assert ROBOT.lift_opens_n(0.04, -2.0) == 0.0
    linkage = dataclasses.replace(ROBOT, lift_coupling_kg=((0.02, 0.06), (0.01, 0.03)))
    assert linkage.lift_opens_n(0.03, -0.5) == pytest.approx(0.015 * 0.5, abs=1e-15)  # braking: opens
    assert linkage.lift_opens_n(0.03, 0.5) == pytest.approx(-0.015 * 0.5, abs=1e-15)  # speeding up: closes
    assert linkage.lift_opens_n(0.09, -1.0) == pytest.approx(0.03, abs=1e-15)


def plan(top_m: float = 0.05, accel_m_s2: float = 0.5) -> LiftPlan:
    return LiftPlan(ROBOT, top_m, accel_m_s2, load_filter_s=0.05, dt_s=DT_S)


def test_the_raise_reaches_the_top_without_a_speed_step_or_an_overshoot():
    """Up at the lift's acceleration, braking on the continuous curve v = sqrt(2 a d): it arrives
    with a remainder of speed, which the last period drops (under 5 a dt: 12.5 mm/s here; the
    fingers' :func:`~cosim.control.multimode.trapezoid_speed` brakes on the discrete curve)."""
    lift, top_speed = plan(), 0.05
    speeds = [0.0]
    for _ in range(10000):
        lift.rise(top_speed, DT_S)
        assert lift.goal_m <= lift.top_m
        speeds.append(lift.speed_m_s)
        if lift.goal_m >= lift.top_m and lift.speed_m_s == 0.0:
            break
    steps = [abs(b - a) for a, b in itertools.pairwise(speeds)]
    assert max(steps[:-1]) <= lift.accel_m_s2 * DT_S * (1 + 1e-12)  # no speed step on the way
    assert steps[-1] < 5 * lift.accel_m_s2 * DT_S
    assert lift.goal_m == lift.top_m and max(speeds) == pytest.approx(top_speed)
    # 0.05 m at 0.05 m/s with 0.1 s to speed up and to brake: 1.1 s, within a few periods
    assert len(speeds) * DT_S == pytest.approx(0.05 / top_speed + top_speed / 0.5, abs=4 * DT_S)


def test_lowering_brakes_to_the_touchdown_speed_and_holds_it():
    lift = plan()
    lift.goal_m, lift.speed_m_s = 0.05, 0.05
    touchdown_m, margin_m, end_speed = 0.0, 0.005, 0.01
    for _ in range(2000):
        before = lift.speed_m_s
        lift.lower(lift.goal_m - touchdown_m - margin_m, 0.05, end_speed, DT_S)
        assert abs(lift.speed_m_s - before) <= lift.accel_m_s2 * DT_S * (1 + 1e-12)  # never a speed step
        if lift.goal_m <= touchdown_m + margin_m:
            break
    assert end_speed <= lift.speed_m_s < end_speed + 3 * lift.accel_m_s2 * DT_S  # braked to about it
    for _ in range(3):  # past the braking point: down to the touchdown speed, then held
        lift.lower(lift.goal_m - touchdown_m - margin_m, 0.05, end_speed, DT_S)
    assert lift.speed_m_s == end_speed


def test_the_servo_target_feeds_the_sag_and_the_lag_forward():
    lift = plan()
    lift.goal_m = 0.02
    assert lift.servo_target(0.0, 0.0) == 0.02
    assert lift.servo_target(20.0, 0.0) == pytest.approx(0.02 + 20.0 / 2e4)  # sag under 20 N: 1 mm
    assert lift.servo_target(0.0, 0.05) == pytest.approx(0.02 + 600.0 * 0.05 / 2e4)  # lag at 50 mm/s


def test_the_load_is_tared_on_what_the_lift_carries_before_lifting_and_low_passed():
    """Without free-closing readings (no closing seen), the tare is what it carries now."""
    lift = plan()
    lift.target_m = 1e-4  # the servo pushes 2 N: the gripper's own share, before lifting
    lift.read_load(0.0, 0.0, DT_S)
    assert lift.raw_load_n == pytest.approx(2.0)
    lift.tare()
    assert lift.raw_load_n == lift.load_n == 0.0 and lift.goal_m == lift.target_m
    lift.target_m = 1e-4 + 5.0 / 2e4  # 5 N more: the object's
    lift.read_load(0.0, 0.0, DT_S)
    assert lift.raw_load_n == pytest.approx(5.0)
    assert lift.load_n == pytest.approx(5.0 * DT_S / 0.05)  # one period of the 50 ms low-pass


def test_the_tare_is_what_the_lift_carried_while_the_fingers_closed_freely():
    """Zeroed at the mean of the last plateau window of free-closing readings, not at what it
    carries as it lifts: pads that already carry part of the weight (a linkage's springback
    lifts the object by the pads' friction) or ring then would be taken for the gripper."""
    lift = plan()
    for k in range(lift.plateau_steps + 5):  # closing freely: 2 N, scattered by +-1 mN
        lift.target_m = (2.0 + (1e-3 if k % 2 else -1e-3)) / 2e4
        lift.read_load(0.0, 0.0, DT_S)
        lift.note_free_load()
    free = [(2.0 + (1e-3 if k % 2 else -1e-3)) for k in range(5, lift.plateau_steps + 5)]
    lift.target_m = (2.0 - 6.9e-3) / 2e4  # squeezed: the pads carry 6.9 mN of a 9.8 mN box
    lift.read_load(0.0, 0.0, DT_S)
    lift.tare()
    assert lift.raw_load_n == pytest.approx(2.0 - 6.9e-3 - sum(free) / len(free), abs=1e-12)
    assert lift.load_n == lift.raw_load_n and lift.goal_m == lift.target_m
    lift.target_m = (2.0 + 9.81e-3) / 2e4  # the box carried: its whole weight, not 0.9 mN of it
    lift.read_load(0.0, 0.0, DT_S)
    assert lift.raw_load_n == pytest.approx(9.81e-3, rel=0.1)


def test_the_window_tells_a_lift_that_follows_its_goal_from_one_held_back():
    lift = plan()
    full = [lift.record(1e-3 * i, 1e-3 * i) for i in range(lift.plateau_steps)]
    assert full == [False] * (lift.plateau_steps - 1) + [True]
    assert lift.follows() and lift.pace() == pytest.approx(1.0)
    for i in range(lift.plateau_steps):  # the goal rises, the lift stays
        lift.record(1.0 + 1e-3 * i, 0.0)
    assert len(lift.window) == lift.plateau_steps and not lift.follows() and lift.risen_m() == 0.0


def test_a_sliding_load_is_two_low_readings_in_a_row_and_their_mean():
    lift = plan()
    lift.held_load_n = 1.0
    low = 0.9 * (1.0 - 2.0 * lift.load_noise_fraction)  # below what the lift's acceleration explains
    readings = [1.0, low, 1.0, low, low - 0.1]
    found = []
    for reading in readings:
        lift.raw_load_n = reading
        found.append(lift.read_sliding_load_n())
    assert found[:4] == [None, None, None, None]
    assert found[4] == pytest.approx(low - 0.05)


def test_the_table_takes_the_weight_only_at_the_steady_touchdown_speed():
    lift = plan()
    lift.held_load_n, lift.raw_load_n, lift.speed_m_s = 1.0, 0.1, 0.02  # braking: blurred
    assert not any(lift.table_took_weight(0.01, 0.5) for _ in range(3 * lift.plateau_steps))
    lift.speed_m_s = 0.01
    took = [lift.table_took_weight(0.01, 0.5) for _ in range(lift.plateau_steps + 1)]
    assert took == [False] * lift.plateau_steps + [True]


def test_the_grip_follows_the_load_never_down_and_never_over_its_cap():
    assert grip_for_load_n(1.0, 0.5, 1.25, 0.01) == pytest.approx(1.25)  # safety x L / (2 mu)
    assert grip_for_load_n(-3.0, 0.5, 1.25, 0.01) == 0.01  # no load: the floor
    assert ratchet_grip_n(2.0, 1.0, 10.0, 100.0, DT_S) == 2.0  # never down
    assert ratchet_grip_n(2.0, 5.0, 10.0, 100.0, DT_S) == pytest.approx(2.5)  # at the grip rate
    assert ratchet_grip_n(9.9, 50.0, 10.0, 100.0, DT_S) == 10.0  # never over the cap
    assert math.isfinite(ratchet_grip_n(0.0, 1.0, 10.0, 100.0, DT_S))


def _descend(lift: LiftPlan, landing_m: float, margin_m: float, end_m_s: float) -> tuple[list[float], list[float]]:
    """Lower the goal as the place does (braking to ``end_m_s`` by ``margin_m`` over the landing, a
    capped landing speed by the margin's share) until it reaches ``landing_m``: the goal's
    heights and speeds, a period apart."""
    heights, speeds = [], []
    while lift.goal_m > landing_m:
        lift.lower(lift.goal_m - landing_m - margin_m, 0.1, end_m_s, DT_S, margin_m)
        heights.append(lift.goal_m)
        speeds.append(lift.speed_m_s)
    return heights, speeds


def _descent(cap_m_s: float, margin_m: float = 0.005, end_m_s: float = 0.02) -> tuple[list[float], list[float]]:
    lift = plan()
    lift.goal_m = lift.target_m = 0.05
    lift.touchdown_cap_m_s = cap_m_s
    return _descend(lift, 0.0, margin_m, end_m_s)


def test_a_slow_landing_keeps_the_margins_time_not_its_distance():
    """LiftPlan.lower with a landing speed capped under the touchdown speed: the lift brakes to
    the touchdown speed by the margin over the landing as before, and to the cap by the margin's
    cap / speed share, so it spends the margin's time at the touchdown speed (M / v) at the cap
    before the landing, not the margin's distance (M / c: 5 mm at 1.4 mm/s is 3.6 s, which ran a
    light object's place out of the scenario's time)."""
    margin_m, end_m_s, cap_m_s = 0.005, 0.02, 0.0014
    heights, speeds = _descent(cap_m_s, margin_m, end_m_s)
    assert speeds[-1] == pytest.approx(cap_m_s, rel=1e-9)
    # at the cap from M c / v over the landing on, within a period's travel at the touchdown speed
    capped_from = min(h for h, v in zip(heights, speeds, strict=True) if v > cap_m_s * (1 + 1e-9))
    assert capped_from == pytest.approx(margin_m * cap_m_s / end_m_s, abs=end_m_s * DT_S)
    # never faster than the touchdown speed's stage alone, which is at that speed at the landing
    free_heights, free_speeds = _descent(math.inf, margin_m, end_m_s)
    assert all(v <= fv * (1 + 1e-9) for v, fv in zip(speeds, free_speeds, strict=False))
    assert free_speeds[-1] == pytest.approx(end_m_s)
    # what the slow stage adds to the free descent, the closed form of its three pieces (at v to
    # the braking, braking at a from v to c, M c / v at c, against M / v at v), within the time at
    # c of the period's travel at v the cap may be reached late by (above)
    v, c, a = end_m_s, cap_m_s, 0.5
    braking_m = (v * v - c * c) / (2 * a)
    slow_s = (margin_m - margin_m * c / v - braking_m) / v + (v - c) / a + margin_m / v
    assert (len(heights) - len(free_heights)) * DT_S == pytest.approx(slow_s - margin_m / v, abs=v * DT_S / c)
    assert slow_s - margin_m / v < 0.1 * (margin_m / c)  # the old cap over the whole margin: 3.6 s


def test_a_landing_cap_over_the_touchdown_speed_leaves_the_descent_as_it_was():
    """A cap at or over the touchdown speed (a heavy object's landing): the margin passed to
    LiftPlan.lower changes nothing."""
    lift = plan()
    lift.goal_m = lift.target_m = 0.05
    lift.touchdown_cap_m_s = 0.05
    heights = []
    while lift.goal_m > 0.0:
        lift.lower(lift.goal_m - 0.005, 0.1, 0.02, DT_S)
        heights.append(lift.goal_m)
    assert _descent(0.05)[0] == heights
