"""The lift's planning in a grasp: how its goal moves, what its servo is told, the load it feels,
and the grip that load needs.

:class:`LiftPlan` holds the lift's side of a grasp controller (:class:`~.multimode.MultimodeGrasp`
and its subclasses): the goal and its speed profile, the servo target with the sag and lag fed
forward, the load read from the servo (filtered, and tared on what the lift carries before
lifting), the plateau window that tells a lift following its goal from one held back, and the
held load's bookkeeping that the hold and the touchdown judge by.  It decides nothing: when to
raise, hold, give up or put down is the controller's phases'.  :func:`grip_for_load_n` and
:func:`ratchet_grip_n` are the grip that follows the load.

Its methods run in the controller's 5 ms step: they hold plain floats (the servo's gains copied
in) and allocate nothing but the window's tuples.
"""

from __future__ import annotations

import math
from collections import deque

from .interface import RobotLimits


def grip_for_load_n(load_n: float, friction: float, safety: float, floor_n: float) -> float:
    """The grip that carries ``load_n`` (N, negative read as none) at ``friction`` with ``safety``
    over the friction limit (two pads: safety x load / (2 mu)), at least ``floor_n``, N per finger."""
    return max(floor_n, safety * max(load_n, 0.0) / (2.0 * friction))


def ratchet_grip_n(grip_n: float, wanted_n: float, cap_n: float, rate_n_s: float, dt_s: float) -> float:
    """The next grip, N: toward ``wanted_n`` at ``rate_n_s`` over ``dt_s``, never down (while carrying,
    a lower grip would let the object slide), never over ``cap_n``."""
    target = min(wanted_n, cap_n)
    return max(grip_n, min(target, grip_n + rate_n_s * dt_s))


class LiftPlan:
    """The lift's goal, speed, servo target and load in a grasp (the module docstring).

    Parameters
    ----------
    robot : the gripper's limits: the lift servo's gains (kp, kv), its moving mass, gravity.
    top_m : the raise's goal, m (the lift's home plus the lift height).
    accel_m_s2 : the lift's acceleration while carrying, m/s^2 (speeding up and braking).
    load_filter_s : time constant of the low-pass on the lift's load, s.
    dt_s : the control period, s (sets the plateau window's length).

    Attributes (the state, read and written by the controller's phases)
    ----------
    goal_m : where the lift should be, m; ``target_m`` is the servo's target that puts it there.
    speed_m_s : the goal's speed, m/s (a magnitude: up while raising, down while placing).
    raw_load_n, load_n : the load the lift carries beyond what it carried before lifting, N, as
        read and low-passed over ``load_filter_s``.
    held_load_n : the load carried at the top, N: the reference of the hold and the touchdown.
    window : (lead, lift position, raw load) over the last ``plateau_steps`` periods; the lead is
        what the lift follows (its goal, m, in the multimode transfer; the applied grip, N, in
        the gentle probe).
    """

    def __init__(self, robot: RobotLimits, top_m: float, accel_m_s2: float, load_filter_s: float, dt_s: float) -> None:
        self.robot = robot
        self.top_m = top_m
        self.accel_m_s2 = accel_m_s2
        self.load_filter_s = load_filter_s
        self.kp_n_m = robot.lift_kp_n_m
        self.kv_n_s_m = robot.lift_kv_n_s_m
        #: The plateau window: two of the lift servo's time constants kv / kp, so a lift that
        #: lags its goal is not taken for one that cannot follow it.
        self.plateau_steps = max(3, math.ceil(2.0 * robot.lift_kv_n_s_m / robot.lift_kp_n_m / dt_s))
        #: Share of a load change the lift's own acceleration explains (load = m (g + a)).
        self.load_noise_fraction = accel_m_s2 / robot.gravity_m_s2
        self.goal_m = self.target_m = robot.home_lift_m
        self.speed_m_s = 0.0
        self._last_vel_m_s = 0.0
        #: The lift's acceleration over the last period, m/s^2 (its encoder's speeds).
        self.measured_accel_m_s2 = 0.0
        self.raw_load_n = 0.0
        self.load_n = 0.0
        self._baseline_n = 0.0  # what the lift carried before lifting (the gripper's own share), N
        #: The raw loads of the last plateau window while the fingers closed freely (tare), N.
        self._free_loads: deque[float] = deque(maxlen=self.plateau_steps)
        self.held_load_n = 0.0
        # (lead, lift position, raw load) over the last plateau window, to tell a lift that
        # follows its lead (the object airborne, or the pads sliding) from one held back by the
        # object, and to average the load over the same window.
        self.window: list[tuple[float, float, float]] = []
        self._low_steps = 0  # readings in a row below the held load (read_sliding_load_n)
        self._low_sum_n = 0.0  # their sum, N
        self._steady_steps = 0  # periods in a row at the touchdown speed (table_took_weight)
        self._table_steps = 0  # of them, periods in a row with the table carrying the weight
        #: The fastest the object may land, m/s: the touchdown speed asked of :meth:`lower` and
        #: :meth:`table_took_weight` is capped by it (none by default; the gentle controller sets
        #: it from its touch bound as it starts to place: gentle.py, :func:`~.gentle.landing_speed_m_s`).
        self.touchdown_cap_m_s = math.inf

    # -- the load -------------------------------------------------------------------------

    def read_load(self, pos_m: float, vel_m_s: float, dt_s: float) -> None:
        """Read the load from the servo (its force less the gripper's inertia, less the tare) and
        low-pass it; called once per control period, before the phases act."""
        accel = self.measured_accel_m_s2 = (vel_m_s - self._last_vel_m_s) / dt_s
        self._last_vel_m_s = vel_m_s
        self.raw_load_n = self.robot.lift_load_n(self.target_m, pos_m, vel_m_s, accel) - self._baseline_n
        self.load_n += (self.raw_load_n - self.load_n) * min(1.0, dt_s / self.load_filter_s)

    def note_free_load(self) -> None:
        """Keep this period's raw load as one read while the fingers close freely: the object
        untouched, the lift carries the gripper's own share alone (:meth:`tare`)."""
        self._free_loads.append(self.raw_load_n)

    def tare(self) -> None:
        """The lift is about to lift: its load is zeroed at what it carried while the fingers
        closed freely (the mean of the last plateau window of :meth:`note_free_load`; without
        one, at what it carries now), and its goal starts at its target.

        Not at what it carries now: by the lift, the pads may already carry part of the object's
        weight or press it into the table.  A linkage's fingertips swing along an arc as they
        close and spring back (tests/test_third_party_grippers.py::
        test_robotiqs_pads_swing_down_their_arc_and_the_lift_braking_opens_them), and pads that
        grip move the object with them: a tare taken then takes what the pads already carry for
        the gripper's own, and the object reads light once carried
        (tests/test_lift.py::test_the_tare_is_what_the_lift_carried_while_the_fingers_closed_freely), or
        catches the squeeze still ringing in the linkage
        (tests/test_third_party_grippers.py::test_robotiqs_four_bar_grasps_the_default_box[gentle-egg])."""
        free = self._free_loads
        zero_n = sum(free) / len(free) if free else self.raw_load_n
        self._baseline_n += zero_n
        self.raw_load_n -= zero_n
        self.load_n = self.raw_load_n
        self.goal_m = self.target_m

    def read_sliding_load_n(self) -> float | None:
        """The load the pads carry as they slide while held still, N, or None: the mean of the raw
        readings below the held load by more than the lift's acceleration explains, two or more in
        a row.  Stationary, the raw load is clean (the filter would cost 50 ms of sliding); the
        mean, because single readings of a slide just begun scatter widely about the pads'
        friction limit (stick-slip, the lift recoiling), and the grip the last one alone asks can
        leave the object sliding (tests/test_lift.py::test_a_sliding_load_is_two_low_readings_in_a_row_and_their_mean,
        tests/test_grasp_outcomes.py::test_a_slip_in_the_hold_is_felt_and_answered).  Once per period."""
        low = self.raw_load_n < (1.0 - 2.0 * self.load_noise_fraction) * self.held_load_n
        self._low_steps = self._low_steps + 1 if low else 0
        self._low_sum_n = self._low_sum_n + self.raw_load_n if low else 0.0
        return self._low_sum_n / self._low_steps if self._low_steps >= 2 else None

    def table_took_weight(self, touchdown_speed_m_s: float, table_load_fraction: float) -> bool:
        """Whether the table has taken the weight while placing: the raw load under
        ``table_load_fraction`` of the held load two periods in a row, judged only after a plateau
        window at the steady touchdown speed, ``touchdown_speed_m_s`` at most :attr:`touchdown_cap_m_s`
        (while the lift brakes, the gripper's own inertia, far more than a light object's, blurs
        the load).  Once per period."""
        touchdown_speed_m_s = min(touchdown_speed_m_s, self.touchdown_cap_m_s)
        self._steady_steps = self._steady_steps + 1 if self.speed_m_s == touchdown_speed_m_s else 0
        on_table = self._steady_steps >= self.plateau_steps and self.raw_load_n < table_load_fraction * self.held_load_n
        self._table_steps = self._table_steps + 1 if on_table else 0
        return self._table_steps >= 2

    # -- the plateau window ---------------------------------------------------------------

    def record(self, lead: float, pads_m: float) -> bool:
        """Add this period's (lead, the pads' height, raw load) to the window, dropping the oldest;
        True once the window is full.  The pads' height is on the lift's scale
        (:meth:`RobotLimits.pads_height_m`): the lift's position where the pads keep theirs."""
        window = self.window
        window.append((lead, pads_m, self.raw_load_n))
        if len(window) > self.plateau_steps:
            window.pop(0)
        return len(window) == self.plateau_steps

    def window_load_n(self) -> float:
        """The raw load averaged over the window, N.

        The friction check compares loads over the window in which the lift followed its goal,
        so a load taken on before that window (at lift-off) is wholly in the first average; a
        low-pass would still be rising toward it and read its own rise as the load following
        the grip (the 50 ms filter has caught only 70 % of a step after the 60 ms window).
        Averaged over the window, because sliding pads stick and slip and one reading of a
        small load is mostly that noise."""
        return sum(entry[2] for entry in self.window) / len(self.window)

    def risen_m(self) -> float:
        """How far the pads moved over the window, m."""
        return self.window[-1][1] - self.window[0][1]

    def pace(self) -> float:
        """How far the pads moved over the window, as a share of how far the lift's goal (the lead) did."""
        (g0, q0, _), (g1, q1, _) = self.window[0], self.window[-1]
        return (q1 - q0) / (g1 - g0) if g1 - g0 > 1e-7 else 0.0

    def follows(self) -> bool:
        """The lift has moved by at least half as much as its goal over the window."""
        return self.pace() > 0.5

    # -- the goal and the servo -----------------------------------------------------------

    def transfer_speed_m_s(self, top_speed_m_s: float, grip_rate_n_s: float, friction: float, safety: float) -> float:
        """The goal's speed while the weight moves onto the pads, m/s: the load it adds on a held
        object (kp per metre) needs grip (safety x load / (2 mu)) no faster than the grip rises."""
        return min(top_speed_m_s, grip_rate_n_s * 2.0 * friction / (safety * self.kp_n_m))

    def climb(self, speed_m_s: float, dt_s: float) -> None:
        """Move the goal up at ``speed_m_s`` for a period, at most to the top, the servo's target on
        it (no sag fed forward: the load is still moving onto the pads)."""
        self.goal_m = min(self.top_m, self.goal_m + speed_m_s * dt_s)
        self.target_m = self.goal_m

    def rise(self, top_speed_m_s: float, dt_s: float) -> None:
        """Move the goal toward the top for a period, at ``top_speed_m_s`` at most, speeding up and
        braking at the lift's acceleration (:meth:`next_speed_m_s`)."""
        self.speed_m_s = self.next_speed_m_s(self.top_m - self.goal_m, top_speed_m_s, 0.0, dt_s)
        self.goal_m = min(self.top_m, self.goal_m + self.speed_m_s * dt_s)

    def lower(self, distance_m: float, top_speed_m_s: float, end_speed_m_s: float, dt_s: float, margin_m: float = 0.0) -> None:
        """Move the goal down for a period, braking to ``end_speed_m_s`` over ``distance_m`` and, where
        :attr:`touchdown_cap_m_s` is slower, to the cap over the rest of the way less the cap's share
        of ``margin_m`` (the margin that ``distance_m`` keeps above the landing, m, at the end
        speed).  The margin covers the landing height's uncertainty in the time the lift takes
        over it at the end speed; a slow cap keeps that time, not that distance: 5 mm at a light
        object's 1.4 mm/s took 3.6 s, and robosuite's Panda, placing its 1.2 g tissue box at the
        accurate preset, ran out of the scenario's time with the box on the table
        (tests/test_lift.py::test_a_slow_landing_keeps_the_margins_time_not_its_distance)."""
        cap = min(end_speed_m_s, self.touchdown_cap_m_s)
        if cap >= end_speed_m_s or end_speed_m_s <= 0.0:
            self.speed_m_s = self.next_speed_m_s(distance_m, top_speed_m_s, cap, dt_s)
        else:
            capped_m = distance_m + margin_m * (1.0 - cap / end_speed_m_s)
            self.speed_m_s = min(
                self.next_speed_m_s(distance_m, top_speed_m_s, end_speed_m_s, dt_s),
                self.next_speed_m_s(capped_m, top_speed_m_s, cap, dt_s),
            )
        self.goal_m -= self.speed_m_s * dt_s

    def arrived_at_top(self, pos_m: float, vel_m_s: float) -> bool:
        """The goal is at the top and the lift on it (within 2 mm), at rest (under 1 mm/s)."""
        return self.goal_m >= self.top_m and abs(pos_m - self.top_m) < 0.002 and not abs(vel_m_s) > 1e-3

    def next_speed_m_s(self, distance_m: float, top_speed_m_s: float, end_speed_m_s: float, dt_s: float) -> float:
        """The next speed of a trapezoidal move, m/s: up at the lift's acceleration to
        ``top_speed_m_s``, braking so as to reach ``end_speed_m_s`` after ``distance_m`` (then
        holding it; 0 stops there).  Speed steps would load the pads with m a."""
        a = self.accel_m_s2
        allowed = math.sqrt(end_speed_m_s * end_speed_m_s + 2.0 * a * max(distance_m, 0.0))
        wanted = min(top_speed_m_s, allowed)
        if end_speed_m_s == 0.0 and distance_m <= 0.0:
            return 0.0
        speed = self.speed_m_s
        return min(wanted, speed + a * dt_s) if speed < wanted else max(wanted, speed - a * dt_s)

    def servo_target(self, load_n: float, speed_m_s: float) -> float:
        """The lift target that puts the lift on its goal, m: the servo sags by load / kp under the
        object and lags by kv v / kp in motion (the robot knows its gains), both fed forward."""
        return self.goal_m + (load_n + self.kv_n_s_m * speed_m_s) / self.kp_n_m


def load_is_steady(loads: list[float], fraction: float) -> bool:
    """Whether ``loads`` (N) scatter about their mean by at most ``fraction`` of it (their
    population standard deviation): a carried object's load changes only with the lift's
    acceleration, m a = (L / g) a."""
    n = len(loads)
    mean = sum(loads) / n if n else 0.0
    if n < 2 or mean <= 0.0:
        return False
    return math.sqrt(sum((x - mean) ** 2 for x in loads) / n) <= fraction * mean


__all__ = ["LiftPlan", "grip_for_load_n", "load_is_steady", "ratchet_grip_n"]
