"""The grip closed on the fingertips (issue 43, item 2): on a drive with dry joint friction, whose
force the pads feel only to within that friction once the fingers stand still, the gentle
controller holds the grip the fingertips feel (pressure times the pad's area, with its sigma) at
the grip it wants, moving the fingers across the friction's band when they are off
(``GentleGrasp._drive_for_grip``); a friction read past the pads' highest is said to be a misread
and read again.  The grippers here are written as a third party would (tests/test_third_party_grippers.py)
or robosuite's and dm_robotics' own, used untouched through the ``gripper.*`` keys."""

from __future__ import annotations

import dataclasses
import itertools
import math
import re
from pathlib import Path

import numpy as np
import pytest
from test_third_party_grippers import ROBOSUITE, ROBOTIQ_2F85, SERVOS, SLIDE_GRIPPER, _robosuite_grippers, _robotiq_2f85, keys

import piezotip
from piezotip import scenarios
from piezotip.cosim.control import Phase, phase_index
from piezotip.cosim.control.config import GentleConfig
from piezotip.cosim.control.gentle import (
    CLOSING_GAIN,
    EASE_LAG_PERIODS,
    FEEL_TOLERANCE,
    LetDown,
    felt_tolerance_n,
    loaded_pad_stiffness_n_m,
    span_contact_stiffness_n_m,
)
from piezotip.cosim.loop import CoSimulation

#: Each finger slide's dry friction, N: robosuite's Panda and Rethink carry 1 N.
FRICTION_N = 0.8


def sticky_gripper(tmp_path: Path) -> Path:
    """Two slides on position servos with FRICTION_N of dry friction each."""
    path = tmp_path / "sticky.xml"
    text = SLIDE_GRIPPER.format(actuators=SERVOS.format(force=30))
    path.write_text(text.replace('damping="20"', f'damping="20" frictionloss="{FRICTION_N}"'))
    return path


@pytest.fixture
def controller(tmp_path):
    """The gentle controller on the sticky gripper, carrying (as after the probe's verdict)."""
    c = CoSimulation(scenarios.get("grasp", keys(sticky_gripper(tmp_path)), "fast")).controller
    c.phase, c.raising = Phase.HOLD, True
    c._held_opening_m = _Obs.opening_m  # the fingers stand still
    return c


class _Obs:
    opening_m = 0.03
    lift_pos_m = -math.inf  # under where any object rested: a place there is landing


class _At:
    """An observation of fingers ``by_m`` (m) more open than _Obs's, their drive reading
    ``drive_n`` (N)."""

    def __init__(self, by_m: float, drive_n: float = 0.0) -> None:
        self.opening_m = _Obs.opening_m + by_m
        self.grip_force_n = drive_n


def _k(c, felt_n: float) -> float:
    """The pads' stiffness on the opening under a grip felt at ``felt_n`` (N), N/m: the joints'
    reckoning's (GentleGrasp._joint_contact_n)."""
    return loaded_pad_stiffness_n_m(c._gel, c.robot.pad_area_m2, felt_n)


def _drive(c, felt_n: float, grip_n: float, t: float = 10.0, sigma_n: float = 1e-4, obs=None):
    c._fingertips_grip_n = lambda: (felt_n, sigma_n)
    return c._drive_for_grip(obs or _Obs(), t, grip_n)


def test_only_a_drive_with_dry_friction_closes_the_grip_on_the_fingertips(controller):
    assert controller.grips_on_fingertips and controller.robot.finger_friction_n == pytest.approx(FRICTION_N, rel=1e-3)
    assert not CoSimulation(scenarios.get("grasp")).controller.grips_on_fingertips  # the house's drive is the grip


def test_a_linkage_sets_its_drive_for_its_pads_by_its_arc_not_by_its_fingertips():
    """dm_robotics' 2F-85 (no dry friction, pads on a four-bar's arc): its drive is set for the
    pads' grip (the load's pull along the arc taken off), not closed on what the fingertips feel;
    the house gripper's drive is the grip, neither."""
    robotiq = CoSimulation(scenarios.get("grasp", keys(_robotiq_2f85(), *ROBOTIQ_2F85), "fast")).controller
    assert robotiq.sets_drive_for_pads and not robotiq.grips_on_fingertips
    house = CoSimulation(scenarios.get("grasp")).controller
    assert not house.sets_drive_for_pads and not house.grips_on_fingertips


def test_a_grip_felt_within_its_tolerance_is_held_at_the_grip(controller):
    limit_n, opening_m = _drive(controller, 0.1, 0.1)
    assert limit_n == 0.1 and opening_m == controller.opening_target


@pytest.mark.parametrize("over_read", [0.9, 1.0, 1.33])
def test_within_its_tolerance_the_contact_creeps_to_the_grip_whatever_the_element_over_reads(controller, over_read):
    """Within the tolerance the drive is held at the grip less the felt excess over FEEL_TOLERANCE
    (the band's upper edge at zero).  Standing still, MuJoCo's soft dry friction lets the contact
    creep to the drive's force, and the element reads a small patch's pressure r times the
    contact's (robosuite's Panda, a rubber ball: r = 1.33): held at the grip itself the contact crept
    to it and the reading to r x the grip, pulled down only to the band's edge (1.15x: the ball held
    at 1.57x its need).  The creep's fixed point, felt = r drive(felt), in closed form
    r g (1 + 1/T) / (1 + r/T) (T the tolerance): within 4 % of the grip at r = 1.33, exact at r = 1."""
    grip_n, felt_n, share = 0.1, 0.1, 0.02  # the contact creeps 2 % of the way a period (MuJoCo's: ~0.5 %)
    for _ in range(2000):  # to the drive's force, the element reading it r times
        felt_n += share * (over_read * _drive(controller, felt_n, grip_n)[0] - felt_n)
    expected = over_read * grip_n * (1 + 1 / FEEL_TOLERANCE) / (1 + over_read / FEEL_TOLERANCE)
    assert felt_n == pytest.approx(expected, rel=1e-6)
    assert abs(felt_n / grip_n - 1.0) <= (0.04 if over_read != 1.0 else 1e-9)


def test_a_heavy_grip_read_a_little_light_is_crept_up_to_not_closed_on(controller):
    """Within the tolerance under the grip the drive rises by the shortfall over FEEL_TOLERANCE
    (the contact creeps up toward it), but never past the friction band's far edge about the
    contact: past it the fingers move, and a heavy grip's shortfall is past it (the Panda's 2 kg
    block read 0.90 N under its 12.9 N grip, the drive went to 18.9 N and the contact from 1.23x
    to 1.77x its need)."""
    friction_n = controller.robot.finger_friction_n
    grip_n = 20.0 * friction_n
    felt_n = grip_n * (1.0 - 0.45 * FEEL_TOLERANCE)  # within the tolerance's lower half
    limit_n, _ = _drive(controller, felt_n, grip_n)
    assert limit_n == pytest.approx(felt_n + friction_n)
    assert grip_n - (felt_n - grip_n) / FEEL_TOLERANCE > felt_n + friction_n  # the rule alone is past the band
    # a light grip's shortfall stays within the band: the rule as it was
    limit_n, _ = _drive(controller, 0.097, 0.1)
    assert limit_n == pytest.approx(0.1 + 0.003 / FEEL_TOLERANCE)


def test_a_grip_wanted_that_rises_past_the_felt_closes_the_fingers_past_their_friction_at_once(controller):
    """A load change's answer (the grip wanted risen over the felt): the drive's force goes past
    the friction's band at once (the contact follows it to the grip), and on while the fingertips
    read it short, at most to what presses the contact to grip_safety x the grip."""
    friction_n = controller.robot.finger_friction_n
    _drive(controller, 0.05, 0.05)  # held at 0.05 N
    most_n = controller.cfg.grip_safety * 0.1 + friction_n
    limit_n, opening_m = _drive(controller, 0.05, 0.1)  # this period also pays the rise to the damping
    assert 0.1 + friction_n < limit_n <= most_n + controller._rise_push_n(0.05)
    assert opening_m == controller.opening_target  # closing on the object
    limit_n, _ = _drive(controller, 0.05, 0.1)  # and on, past the band, while read short
    assert 0.1 + friction_n < limit_n <= most_n
    assert controller._hold_pull is None  # not paced
    for _ in range(50):  # a contact the fingertips read low however hard it is pressed: no runaway
        limit_n, _ = _drive(controller, 0.01, 0.1)
    assert limit_n == pytest.approx(controller.cfg.grip_safety * 0.1 + friction_n)


def test_a_shortfall_read_in_the_carry_is_pushed_at_a_pace(controller):
    """A grip read short with the grip wanted unchanged (no load to answer: the carry's own step,
    a pull's run-on) is pushed at a pace, as a pull is: the fingers are to close by the shortfall
    over the pads' loaded stiffness, the force from inside the friction's band up by half while
    they stand, and never past the band's far edge about the grip (the contact cannot be pushed
    past it however low the fingertips read it).  Pushed past the band at once, the readout's lag
    let robosuite's Rethink close 84 um in 40 ms on its raspberry as the raise began."""
    c, friction_n = controller, controller.robot.finger_friction_n
    _drive(c, 0.1, 0.1)  # held at the grip
    limit_n, opening_m = _drive(c, 0.05, 0.1, t=10.0)
    push = c._hold_pull
    assert push is not None and push.closing
    assert push.to_m == pytest.approx(_Obs.opening_m - 0.05 / _k(c, 0.05))
    assert 0.05 < limit_n <= 0.05 + friction_n / 4 and opening_m == c.opening_target
    limits = [_drive(c, 0.01, 0.1, t=10.0 + 0.005 * i)[0] for i in range(1, 8)]  # the fingers stand
    assert all(b >= a for a, b in itertools.pairwise(limits)) and limits[0] < limits[-1] and c._hold_pull is push
    assert limits[-1] == pytest.approx(0.05 + friction_n)  # the joints' contact (unmoved) plus the band, no more
    # the fingers closed the whole way: the push ends, held at the grip, read again
    limit_n, _ = _drive(c, 0.1, 0.1, t=10.05, obs=_At(push.to_m - _Obs.opening_m))
    assert c._hold_pull is None and limit_n == 0.1


class _Probing:
    """The gentle controller ``c`` on the sticky gripper, probing (the lift phase): each
    :meth:`period` is one of GentleGrasp._transfer, the lift a period's climb higher."""

    def __init__(self, c) -> None:
        self.c, self.t, self.lift_m = c, 5.0, 0.0

    def period(self) -> None:
        from types import SimpleNamespace

        c = self.c
        self.t += c.dt_s
        self.lift_m += c.cfg.probe_speed_m_s * c.dt_s
        obs = SimpleNamespace(time_s=self.t, lift_pos_m=self.lift_m, opening_m=0.03, grip_force_n=0.05, lift_vel_m_s=c.cfg.probe_speed_m_s)
        c._transfer(obs, self.t, c.dt_s)


@pytest.fixture
def prober(tmp_path):
    """The gentle controller on the sticky gripper, probing, both pads reading 40 Pa (the contact
    left by the touch's ease), its lift's window filled with the probe's climb."""
    c = CoSimulation(scenarios.get("grasp", keys(sticky_gripper(tmp_path)), "fast")).controller
    c.phase, c._t_phase = Phase.LIFT, 0.0
    for sel in c.selectors.values():
        sel.trusted, sel.status, sel.mode, sel.estimate_pa, sel.uncertainty_pa = True, "ok", sel.modes[0], 40.0, 2.0
    probing = _Probing(c)
    for _ in range(c.lift.plateau_steps + 2):
        probing.period()
    return probing


def test_the_probes_span_reads_one_pad_while_the_other_settles_and_grows_on_both(prober):
    """A friction drive's probe reads the grip on the fingertips.  With the envelope readout a
    pad's reading settles on each ramp, and robosuite's Panda at the accurate preset read both
    pads at once a tenth of the time once its 2 g wafer left the table: the verdict, waiting for
    both, came only once the grip had grown by grip_safety^3, and the wafer was crushed (0.056 N
    of its 0.05).  The object presses both pads alike, so the span takes the one that reads (the
    wafer: 0.040 N); the grip still grows only within a plateau window of a reading of both
    (grown on one, it grows while the other's readout settles on the ramp it makes: 0.09 N)."""
    c, period = prober.c, prober.period
    area = c.robot.pad_area_m2
    left, right = (c.selectors[pad] for pad in c.pads)
    right.trusted = False  # settling
    n, grip_n = len(c._span), c.grip_n
    period()
    assert len(c._span) == n + 1
    assert c._span[-1][0] == pytest.approx(40.0 * area, rel=0.05)  # the left pad's reading (the drive's is 1.2 N)
    left.trusted = False  # both settling: no reading, no sample
    period()
    assert len(c._span) == n + 1
    left.trusted = True
    for _ in range(c.lift.plateau_steps):  # the right pad settling: grown for a plateau window after both read
        period()
    assert c.grip_n > grip_n
    grown_n = c.grip_n
    for _ in range(c.lift.plateau_steps):  # and no further, the left pad's readings taken all the while
        period()
    assert c.grip_n == grown_n and len(c._span) == n + 1 + 2 * c.lift.plateau_steps


def test_a_contact_lost_in_the_probe_forgets_the_friction_read_on_it_and_the_drive_comes_down_to_the_regained_one(prober):
    """Every pad reading no load while the probe climbs: the contact the pads slid on is gone (a
    sphere's pads slid off it above its centre, and the fingers regain it higher up, tilted
    further: robosuite's Panda's raspberry at 2 degrees, then 13).  The friction read while the
    pads slid over it is forgotten (held by it, the raspberry was at 0.83x its need on the
    regained contact at the accurate preset, and fell), and the friction is the highest expected
    again.  The probe's grip grew on while nothing was read, past the drive's friction: at the
    first reading of the regained contact the drive comes down to it (the raspberry carried from
    the ramp that followed was held at 10.9x its need)."""
    c, period = prober.c, prober.period
    c._slid, c.friction, c._slides = True, 0.6, [(0.6, 0.01)]
    for sel in c.selectors.values():
        sel.status = "below_detection"
    period()
    assert not c._slid and c._slides == [] and c.friction == c.cfg.friction_max
    assert len(c._unslid) == 2  # the samples since the slide: the last before the loss, and this period's
    c.grip_n = 0.9  # grown past the friction's band while nothing was read
    period()
    assert c.grip_n >= 0.9  # nothing read yet: as it was (and growing)
    left = c.selectors[c.pads[0]]
    left.status, left.estimate_pa = "ok", 200.0
    period()
    assert c.grip_n == pytest.approx(200.0 * c.robot.pad_area_m2)
    c.grip_n = 0.9
    period()
    assert c.grip_n >= 0.9  # once only: the probe grows from there


def test_a_probe_that_loses_the_contact_waits_for_the_fingers_to_close_back_on_it(prober):
    """Every pad empty after the probe read the object: the fingers, light in their friction's
    band, could not close after an object narrowing above the contact (robosuite's Rethink lost a
    16 mm sphere 0.14 mm into its probe and climbed 2.8 mm more, over its top).  The lift's goal
    stays where it is while the probe's grip grows, closing the fingers back on the object at the
    height they lost it; once a pad reads it again, the climb goes on."""
    c, period = prober.c, prober.period
    for sel in c.selectors.values():
        sel.status = "below_detection"
    goal_m, grip_n = c.lift.goal_m, c.grip_n
    for _ in range(c.lift.plateau_steps):
        period()
        assert c.lift.goal_m == goal_m
    assert c.grip_n > grip_n  # the probe's grip grows meanwhile, closing the fingers back on the object
    left = c.selectors[c.pads[0]]
    left.status, left.estimate_pa = "ok", 40.0
    period()
    assert c.lift.goal_m > goal_m


def test_a_probe_that_never_read_the_object_climbs_on(prober):
    """Nothing read yet in the probe (the fingertips' reference unset): no contact to lose, the
    lift climbs as ever (a pad reading nothing from the touch on is the verdict's business)."""
    c, period = prober.c, prober.period
    c._seen_ref = (math.inf, 0.0)
    for sel in c.selectors.values():
        sel.status = "below_detection"
    goal_m = c.lift.goal_m
    period()
    assert c.lift.goal_m > goal_m


def test_a_probe_blind_past_its_friction_over_a_steady_load_takes_its_friction_off_the_drive(prober):
    """The probe's grip grows only within a plateau window of every pad's reading; on a drive with
    dry friction F_f pushed past its band (its force over the contact felt by more than F_f) the
    fingers slide closed on, unread, whatever the growth does, toward the drive less F_f.  Where
    the load has stopped following (steady over the window: the object is being carried), the
    drive comes down by F_f once, to the band's middle about the contact it presses, and the
    fingers stop there; robosuite's Rethink gripper, blind through a switch's ring-up as its 60 g
    egg left the table at the accurate preset, pressed it on from 0.52 N to 1.27 N and held it at
    1.73x its need (1.44x).  Not within the band (the contact creeps there), not while the load
    still follows the grip (the pads slide: a 500 g can's probe lost its contact so), and once per
    blind spell."""
    c, lift = prober.c, prober.c.lift
    friction_n, steps = c.robot.finger_friction_n, lift.plateau_steps
    felt_n = c._fingertips_grip_n()[0]

    def blind(periods: int, load_n: float = 0.2, growth: float = 0.0) -> None:
        for sel in c.selectors.values():
            sel.trusted, sel.status = False, "settling"
        for k in range(periods):
            lift.raw_load_n = load_n * (1.0 + growth * k)
            prober.period()

    lift.raw_load_n = 0.2
    for _ in range(steps):
        prober.period()  # every pad reads: the load steady over the window
    assert c._felt_at_s == prober.t
    c.grip_n = felt_n + 2.5 * friction_n  # past the band's far edge about the contact felt, by more than F_f
    pushed_n = c.grip_n
    blind(steps)  # within a plateau window of the reading: grown on
    assert c.grip_n > pushed_n
    grown_n = c.grip_n
    blind(1)
    assert c.grip_n == pytest.approx(grown_n - friction_n)  # blind past the window: F_f off, once
    blind(steps)
    assert c.grip_n == pytest.approx(grown_n - friction_n)
    # the load still following the grip (past the band or within it): nothing taken off
    for grip_n in (felt_n + 0.5 * friction_n, felt_n + 1.5 * friction_n):
        for sel in c.selectors.values():
            sel.trusted, sel.status = True, "ok"
        lift.raw_load_n = 0.2
        for _ in range(steps):
            prober.period()
        c.grip_n = grip_n
        blind(steps + 3, growth=0.05)
        assert c.grip_n >= grip_n, grip_n


def test_a_probe_blind_within_its_band_over_a_steady_load_stops_the_contact_where_it_is(prober):
    """Within the band, a drive over the contact draws it up by MuJoCo's soft friction's creep,
    unread while the readouts settle on that ramp: robosuite's Rethink lifted a 19 g cylinder at
    0.14 N and its contact crept on to 0.35 N, 2.6x its need, before the verdict.  Blind past the
    window over a steady load (the object leaving the table), the pads seen to slide before, the
    drive comes down once to the contact the joints say the fingers press: the last reading and the
    pads' stiffness times the closing since."""
    c, lift = prober.c, prober.c.lift
    friction_n, steps = c.robot.finger_friction_n, lift.plateau_steps
    felt_n = c._fingertips_grip_n()[0]
    lift.raw_load_n = 0.2
    for _ in range(steps):
        prober.period()  # every pad reads: the load steady over the window
    c._slid = True  # the pads were seen to slide (a contact carried before is let down instead)
    c.grip_n = felt_n + 0.5 * friction_n  # within the band about the contact felt
    for sel in c.selectors.values():
        sel.trusted, sel.status = False, "settling"
    for _ in range(steps):  # within a plateau window of the reading: grown on
        prober.period()
    assert c.grip_n > felt_n + 0.5 * friction_n
    prober.period()  # blind past the window: down to the contact (the fingers have not moved: the reading)
    assert c.grip_n == pytest.approx(felt_n)
    c.grip_n = felt_n + 0.5 * friction_n
    for _ in range(steps):
        prober.period()
    assert c.grip_n == felt_n + 0.5 * friction_n  # once a blind spell


def _let_down(prober, loads, read_n=None, seen_n: float = 0.02, carried_from_n: float = 0.01, weight_n: float = 0.0098):
    """Start the probe's let-down on ``prober`` (the fingertips last read ``seen_n`` N at a 30 mm
    opening, and settle since, reading ``read_n`` N once the pull is over where it is given, or,
    a callable, each pad's reading ``read_n(j)`` the j-th period after it (N, None: settling); the
    object, of weight ``weight_n`` N, carried from ``carried_from_n`` N) and run its periods, the
    fingers opening at the pull's pace while it pulls and the lift's load the k-th period
    ``loads(k)`` N, until it is over; the periods it took, the lift's goal before it, and its
    pull."""
    from types import SimpleNamespace

    c, lift = prober.c, prober.c.lift
    pa_per_n = 40.0 / c._fingertips_grip_n()[0]
    if read_n is None or not callable(read_n):
        reading = None if read_n is None else (read_n,) * len(c.pads)
        read_n = lambda j: reading  # noqa: E731
    for sel in c.selectors.values():
        sel.trusted, sel.status = False, "settling"
    c._seen_ref = (0.03, seen_n)
    obs = SimpleNamespace(time_s=prober.t, lift_pos_m=prober.lift_m, opening_m=0.03, grip_force_n=0.05, lift_vel_m_s=0.0)
    goal_m = lift.goal_m
    c._start_let_down(obs, prober.t, weight_n, carried_from_n)
    assert c._let_down is not None
    pull = c._let_down.pull
    j = 0  # periods since the pull ended
    for k in range(400):
        if c._let_down is None:
            return k, goal_m, pull
        if math.isinf(c._let_down.pulled_s):  # pulled open: the fingers follow at the pull's pace
            assert c.opening_target == c.robot.home_opening_m and c.grip_n > 0.0
            obs.opening_m += pull.pace_m
        else:
            for sel, pad_n in zip(c.selectors.values(), read_n(j) or (None,) * len(c.pads), strict=True):
                if pad_n is None:
                    sel.trusted, sel.status = False, "settling"
                else:
                    sel.trusted, sel.status, sel.estimate_pa = True, "ok", pa_per_n * pad_n
            j += 1
        obs.time_s = prober.t = prober.t + c.dt_s
        lift.raw_load_n = loads(k)
        c._transfer(obs, prober.t, c.dt_s)
        assert lift.goal_m == goal_m or c.raising  # the lift held where it is until carried
    raise AssertionError("the let-down never ended")


def test_a_probe_carried_before_its_pads_slid_lets_the_contact_down_before_it_carries(prober):
    """Carried before the pads were ever seen to slide, the probe's least carrying grip bounds the
    friction only from below, and a drive with dry friction keeps the contact the touch's ease
    left (over its goal where the contact is softer than a full face): robosuite's Panda carried
    its 1 g tissue box from 11 mN, 1.34x its need, and held it at 1.51x, the grip's safety factor
    on top.  The fingers are eased open on their joints from the contact last read (20 mN) to
    that grip over grip_safety, the lift held; carried still a plateau window after, the grip is
    held at grip_safety x the fingertips' reading then, not grip_safety x the bound.  Once, and
    only on a friction drive whose pads never slid, below the cap."""
    c = prober.c
    safety, k_n_m = c.cfg.grip_safety, c.contact_stiffness_n_m
    goal_n = 0.01 / safety
    periods, _, pull = _let_down(prober, lambda k: 0.0098, read_n=0.009)
    assert pull.to_m - 0.03 == pytest.approx((0.02 - goal_n) / k_n_m)  # opened by the excess over the pads' stiffness
    assert c.raising and c.events[-1].kind == "carried" and "let_down" in [e.kind for e in c.events]
    assert c._grip_goal_n == pytest.approx(safety * 0.009)  # the reading's, not the bound's
    pulled = math.ceil((pull.to_m - 0.03) / pull.pace_m)
    assert periods > pulled + c.lift.plateau_steps - 2 * EASE_LAG_PERIODS  # carried only a plateau window after the pull
    assert not c._lets_down(False)  # once


@pytest.mark.parametrize("read_n", [None, 0.012])
def test_a_let_down_unread_or_read_over_the_bound_carries_from_the_bound(prober, read_n):
    """The joints reckon the contact left by a full face's stiffness, the stiffest, so they may
    read it low and the friction high (robosuite's Rethink held its 1.2 g tissue box at 1.00x its
    need on them): a let-down the fingertips do not read within the readout's longest window
    after the plateau window, or read over the bound it started from (a curved patch's softer
    contact), is carried from that bound, as without the let-down."""
    c = prober.c
    periods, *_ = _let_down(prober, lambda k: 0.0098, read_n=read_n)
    assert c.raising and c._grip_goal_n == pytest.approx(c.cfg.grip_safety * 0.01)
    if read_n is None:
        assert periods * c.dt_s > c.ease_wait_s


def test_a_let_down_whose_load_falls_probes_up_from_the_contact_left(prober):
    """The object slides back onto the table as the let-down takes the contact under its need: the
    lift's load (a plateau window's mean) falls under half the weight, and the probe grows the grip
    again from the contact the joints say is left, its span started afresh, to read the friction
    as the pads slide."""
    c = prober.c
    periods, goal_m, *_ = _let_down(prober, lambda k: 0.0098 if k < 4 else 0.0)
    assert not c.raising and c._let_down is None and periods < 4 + 2 * c.lift.plateau_steps
    assert c.events[-1].kind == "let_down" and "fell" in c.events[-1].message
    assert c._span == [] and c._unslid == []
    assert c.grip_floor_n <= c.grip_n < 0.02 and c.opening_target == 0.0  # held at the contact left, closing
    prober.period()
    assert c.lift.goal_m > goal_m  # the probe climbs again


def test_a_let_down_reads_the_contact_after_the_readouts_flag(prober):
    """The first reading after the pull can be the contact before it, the readout's window still
    holding the pressure the pull left behind (robosuite's Panda read its tissue box at 16.3 mN a
    period after letting it down to 10 mN, and held it at 1.62x its need from that): a reading
    before the readouts flag the change is forgotten at the flag, and the wait goes on for the
    reading after it (one pad's, the other settling, as the probe's span takes it)."""
    c = prober.c
    n = c.lift.plateau_steps  # the wait's least: a window of the load after the pull
    stale, settling = (0.016, 0.016), (None, None)
    reads = lambda j: stale if j < 2 else settling if j < n + 2 else (0.0085, None)  # noqa: E731
    _let_down(prober, lambda k: 0.0098, read_n=reads)
    assert c.raising and c.events[-1].kind == "carried"
    assert c._grip_goal_n == pytest.approx(c.cfg.grip_safety * 0.0085)  # not from the bound (10 mN) the stale 16 mN left


def test_a_spans_contact_stiffness_is_its_least_squares_slope():
    """The contact's stiffness a probe's span reads: minus the least-squares slope of the grip read
    over the opening, and its standard error, as scipy's linregress gives them; None for fewer
    than three samples or one opening."""
    from scipy.stats import linregress

    rng = np.random.default_rng(3)
    openings = 0.030 - np.linspace(0.0, 10e-6, 40)
    grips = 0.011 + 600.0 * (0.030 - openings) + rng.normal(0.0, 5e-4, openings.size)
    span = [(g, 0.0098, o) for g, o in zip(grips, openings, strict=True)]
    k_n_m, error_n_m = span_contact_stiffness_n_m(span)
    fit = linregress(openings, grips)
    assert k_n_m == pytest.approx(-fit.slope, rel=1e-9) and error_n_m == pytest.approx(fit.stderr, rel=1e-9)
    assert abs(k_n_m - 600.0) < 3.0 * error_n_m
    assert span_contact_stiffness_n_m(span[:2]) is None
    assert span_contact_stiffness_n_m([(g, 0.0098, 0.03) for g, *_ in span]) is None


@pytest.mark.parametrize(("share", "noise_n", "by_span"), [(0.7, 0.0, True), (0.4, 0.0, False), (1.3, 0.0, False), (0.7, 0.01, False)])
def test_a_let_down_pulls_over_a_faces_own_stiffness_and_a_patchs_full_face(prober, share, noise_n, by_span):
    """The let-down opens the fingers by the excess over the contact's own stiffness, as its span
    read it, where that is a face's (softer than a full face's, surely over half of it): over a
    full face's, robosuite's Panda left its tissue box's contact at 10.3 mN for 8.1 mN wanted
    (its span read 560 N/m, the full face 770) and held it at 1.53x.  A patch (the Rethink's
    raspberry read 0.4 of a full face) keeps the full face's: pulled to its goal, the sphere slid
    back onto the table and was lost.  So do a span read stiffer than a full face and one
    too scattered to tell."""
    from types import SimpleNamespace

    c = prober.c
    full_n_m = c.contact_stiffness_n_m
    rng = np.random.default_rng(5)
    openings = 0.030 + np.linspace(0.0, 10e-6, 30)
    span = [(0.02 - share * full_n_m * (o - 0.030) + rng.normal(0.0, noise_n), 0.0098, o) for o in openings]
    obs = SimpleNamespace(time_s=prober.t, lift_pos_m=prober.lift_m, opening_m=0.03, grip_force_n=0.05, lift_vel_m_s=0.0)
    c._seen_ref = (0.03, 0.02)
    c._start_let_down(obs, prober.t, 0.0098, 0.01, span)
    pull = c._let_down.pull
    k_n_m = share * full_n_m if by_span else full_n_m
    assert pull.to_m - 0.03 == pytest.approx((0.02 - 0.01 / c.cfg.grip_safety) / k_n_m, rel=0.02)


@pytest.mark.parametrize("why", ["slid", "at_cap", "no_friction"])
def test_only_a_friction_drive_whose_pads_never_slid_lets_its_contact_down(prober, why):
    c = prober.c
    assert c._lets_down(False)
    if why == "slid":
        c._slid = True
    elif why == "no_friction":
        c.grips_on_fingertips = False
    assert not c._lets_down(why == "at_cap")


def test_the_probe_climbs_slower_where_the_contact_fades_and_back_where_it_reads_a_rise(prober):
    """The pads slide up the object in the probe, and over a sphere held at its centre the fingers
    must close after it as it narrows; in their drive's friction band they only creep (robosuite's
    Panda lost its raspberry within 0.8 mm of climb, regained it 13 degrees up, and held it at 2-2.9x
    its need).  Where a pad's reading fades while the grip rises, the fingers do not open and the
    lift's load falls with it (contact_fades), the climb's pace halves, to
    ``controller.slowest_climb`` at the least, moving there over a plateau window (a step in the
    lift's speed reads as a load that is not steady); a reading 2 sigma over the first since
    doubles it back.  A reading that falls while the load stays (a carried object's) changes
    nothing."""
    c, lift = prober.c, prober.c.lift
    steps = lift.plateau_steps

    def read(pa: float, load_n: float, periods: int, growth: float = 1.01) -> None:
        for sel in c.selectors.values():
            sel.estimate_pa = pa
        for _ in range(periods):
            lift.raw_load_n = load_n
            lift.record(c.grip_n, 0.0)
            c.grip_n *= growth
            c._pace_climb(0.03)

    c.grip_n, c._pad_top = 0.01, {}  # the probe from its floor
    read(40.0, 0.03, steps, growth=1.0)  # the load's highest: 30 mN
    read(30.0, 0.02, steps, growth=1.0)  # the readings and the load fall, but the grip did not rise
    assert c.climb_pace == 1.0
    read(30.0, 0.03, steps, growth=1.0)
    read(30.0, 0.03, steps)  # the grip rises, the readings stay down, the load back at its highest: carried
    assert c.climb_pace == 1.0
    read(30.0, 0.02, steps // 2)  # fading: the load's window mean past 10 % under its highest
    assert c._pace_goal == 0.5 and 0.5 < c.climb_pace < 1.0  # on its way there
    read(30.0, 0.02, steps)
    assert c.climb_pace == 0.5
    slowest = c.cfg.slowest_climb
    assert slowest == 0.25  # the default
    read(20.0, 0.01, steps)  # fading on
    assert c._pace_goal == 0.25
    for pa in (15.0, 10.0, 5.0):
        read(pa, 0.005, steps)
    read(5.0, 0.005, steps)
    assert c.climb_pace == slowest  # and no slower
    read(8.0, 0.005, steps)  # a rise within 2 sigma (4 Pa here) of the first reading since: as it was
    assert c.climb_pace == slowest
    read(10.0, 0.005, 2 * steps)  # past it: doubled back
    assert c.climb_pace == 2.0 * slowest
    c.cfg = dataclasses.replace(c.cfg, slowest_climb=0.125)  # a slower floor, a key away
    for pa in (30.0, 22.0, 14.0, 6.0):
        read(pa, 0.002, steps)
    read(6.0, 0.002, steps)
    assert c.climb_pace == 0.125

    # the probe's climb at the pace, the goal's speed: a period's rise of the lift's goal
    c.grip_n = 0.001
    for pace in (1.0, 0.25):
        c.climb_pace = c._pace_goal = pace
        c._pad_top.clear()
        goal_m = lift.goal_m
        prober.period()
        assert lift.goal_m - goal_m == pytest.approx(pace * c.cfg.probe_speed_m_s * c.dt_s, rel=0.05)


@pytest.mark.parametrize("value", [0, -0.5, 1.5, math.nan, True])
def test_a_climb_floor_outside_the_probes_pace_is_one_error_naming_the_key(value):
    with pytest.raises(ValueError, match=r"controller\.slowest_climb"):
        piezotip.run("grasp", overrides={"controller.kind": "gentle", "controller.slowest_climb": value})


def test_a_push_is_not_kept_while_the_fingertips_are_blind(controller):
    """A push past the friction's band, the fingertips then blind (a pad's readout settling on
    the ramp the push makes): the fingers are pushed on only until their joints say the contact
    is up to the grip (the grip last felt plus the pads' contact stiffness times the closing
    since), then stopped at the grip, not pushed on unseen (the Panda pressed its 1 g tissue box
    to 24x its need in the 0.6 s its readout read the ramp "settling", at the balanced preset).
    Below detection is a reading, not blindness: there the push goes on (a contact lost is
    closed on)."""
    c, k = controller, _k(controller, 0.05)
    friction_n = c.robot.finger_friction_n
    _drive(c, 0.05, 0.05)
    assert _drive(c, 0.05, 0.1)[0] > 0.1 + friction_n  # the grip wanted rose (a load change's answer): pushed
    c._fingertips_grip_n = lambda: None
    c._fingertips_blind = lambda: False  # below detection: read, and no grip felt
    assert c._drive_for_grip(_Obs(), 10.0, 0.1)[0] > 0.1 + friction_n
    c._fingertips_blind = lambda: True  # settling
    assert c._drive_for_grip(_At(-0.5 * 0.05 / k), 10.0, 0.1)[0] > 0.1 + friction_n  # half way by the joints: on
    limit_n, opening_m = c._drive_for_grip(_At(-1.01 * 0.05 / k), 10.005, 0.1)
    assert limit_n == 0.1 and opening_m == c.opening_target  # at the grip by the joints: stopped
    # and held there while blind, as a reading of that contact would hold it (the grip less the excess over the tolerance)
    assert c._drive_for_grip(_At(-1.01 * 0.05 / k), 10.01, 0.1)[0] == pytest.approx(0.1 - 0.0005 / FEEL_TOLERANCE)
    controller._fingertips_blind = lambda: False
    assert _drive(controller, 0.11, 0.1, t=10.01)[0] < 0.1  # within the tolerance, over: held under the grip
    held_n = _drive(controller, 0.11, 0.1, t=10.015)[0]
    controller._fingertips_blind, controller._fingertips_grip_n = (lambda: True), (lambda: None)
    # blind, the joints stand in for the fingertips: the fingers still, the contact is the last felt, held as it was
    assert controller._drive_for_grip(_Obs(), 10.02, 0.1)[0] == pytest.approx(held_n)
    k = _k(controller, 0.11)
    # the fingers opened (the contact creeping down toward that drive): the joints say under the grip, brought up to it
    assert controller._drive_for_grip(_At(0.02 / k), 10.025, 0.1)[0] == 0.1


def test_a_blind_pull_reckons_the_contact_on_the_loaded_pads(controller):
    """Blind, the joints reckon the contact as the grip last felt less the pads' stiffness under it
    times the opening since (loaded_pad_stiffness_n_m): at a heavy grip the gel is stiffer than at
    no load (Gent's law), and a reckoning at the no-load stiffness read a contact creeping open
    short, so a pull went on past the grip (robosuite's Panda's 500 g can: pulled from 3.4 N toward
    3.0 N wanted, blind, on to 2.5 N, its need, and slid out in the hold).  Fingers opened so far
    that the no-load stiffness says the contact is still within the tolerance under the grip,
    and the loaded one says it is under it: the drive goes back up to the grip."""
    grip_n, k0 = 3.0, controller.contact_stiffness_n_m
    k_loaded = loaded_pad_stiffness_n_m(controller._gel, controller.robot.pad_area_m2, grip_n)
    assert k_loaded > 1.5 * k0
    _drive(controller, grip_n, grip_n, t=10.0)  # a reading at the grip: the joints' reference
    controller._fingertips_blind, controller._fingertips_grip_n = (lambda: True), (lambda: None)
    below = felt_tolerance_n(grip_n, 1e-4)[0]
    opened_m = 1.5 * below / k_loaded  # the loaded pads: 1.5 tolerances under; the no-load ones: under one
    assert k0 * opened_m < below
    assert controller._joint_contact_n(_At(opened_m).opening_m) == pytest.approx(grip_n - k_loaded * opened_m)
    assert controller._drive_for_grip(_At(opened_m), 10.005, grip_n)[0] >= grip_n


def test_a_blind_hold_whose_joints_see_the_contact_creep_up_holds_the_drive_under_the_grip(controller):
    """Held at the grip while a pad's readout settles, a contact under a drive with MuJoCo's soft
    dry friction creeps toward the drive's force, which is in newtons, while the grip wanted is
    in the element's units: over a curved patch, which the element over-reads (1.6x on the egg),
    it crept up to that many times the grip meant.  So the joints stand in for the fingertips as
    the hold's rule has it: the contact last felt plus the pads' contact stiffness times the
    closing since, within FEEL_TOLERANCE over the grip, holds the drive under the grip by the
    excess over the tolerance, as a reading would (robosuite's Panda, its 60 g egg at the
    accurate preset: blind for 0.8 s of its hold, the fingers crept 0.33 mm closed and the egg
    was held at 1.81x its need, 1.40x since)."""
    c, grip_n = controller, 0.5
    k = _k(c, grip_n)
    held_n = _drive(c, grip_n, grip_n)[0]  # felt at the grip: held there
    c._slip_watch_from_s = -math.inf
    assert held_n == pytest.approx(grip_n)
    c._fingertips_grip_n, c._fingertips_blind = (lambda: None), (lambda: True)
    excess_n = 0.1 * grip_n  # the fingers closed by it over k, unseen
    limit_n, opening_m = c._drive_for_grip(_At(-excess_n / k), 10.005, grip_n)
    assert opening_m == c.opening_target and limit_n == pytest.approx(grip_n - excess_n / FEEL_TOLERANCE)
    assert limit_n < grip_n and c._moved_dir == 0
    assert c._slip_watch_from_s > 10.005  # the pressure it lets down is no slip
    # past the tolerance the same rule goes on (test_past_its_tolerance_the_hold_lets_the_contact_creep_down_not_up_to_the_grip)
    past_n = grip_n + 2.0 * FEEL_TOLERANCE * grip_n
    limit_n = c._drive_for_grip(_At(-(past_n - grip_n) / k), 10.01, grip_n)[0]
    assert limit_n == pytest.approx(max(0.0, past_n - c.robot.finger_friction_n)) and limit_n < grip_n


def test_past_its_tolerance_the_hold_lets_the_contact_creep_down_not_up_to_the_grip(controller):
    """Over the tolerance, a contact read while the fingers close (creeping up) or stood in for
    by the joints while blind is held by the tolerance's rule carried on past its top: the drive
    at the grip less the excess over FEEL_TOLERANCE, never under zero (a pull is the paced pull's
    alone) nor under the friction band's near edge, so that it is continuous at the tolerance's
    top.  Held at the grip instead, the contact crept toward the grip in newtons, which the
    element reads r times over a curved patch (the egg's 1.6x at the accurate preset): the hold
    came back over the tolerance after each pull, and robosuite's Panda held its 60 g egg at
    1.85-1.95x its need, its rubber ball at 1.57-1.61x (test_the_pandas_curved_patches_are_held_within_one_and_a_half_at_accurate)."""
    c, k = controller, controller.contact_stiffness_n_m
    grip_n, friction_n = 0.5, controller.robot.finger_friction_n
    top_n = (1.0 + FEEL_TOLERANCE) * grip_n
    still_m = 0.1 * c.touch_speed_m_s * c.dt_s

    def felt_closing(felt_n: float, t: float) -> float:
        c._held_opening_m = _Obs.opening_m + 3.0 * still_m  # the fingers closed since the last period
        return _drive(c, felt_n, grip_n, t=t)[0]

    c._slip_watch_from_s = -math.inf
    below, above = felt_closing(top_n - 1e-6, 10.0), felt_closing(top_n + 1e-6, 10.005)
    assert below == pytest.approx(above, abs=1e-4)  # continuous at the tolerance's top
    for k_period, excess in enumerate((1.5, 2.0, 4.0)):
        felt_n = grip_n + excess * FEEL_TOLERANCE * grip_n
        limit_n = felt_closing(felt_n, 10.01 + 0.005 * k_period)
        assert limit_n == pytest.approx(max(0.0, felt_n - friction_n)) and limit_n < grip_n, excess
    assert c._slip_watch_from_s > 10.0  # the pressure let down is no slip
    # blind, the joints' contact (the last reading plus k times the closing since) holds it the same way
    _drive(c, grip_n, grip_n, t=11.0)
    c._fingertips_grip_n, c._fingertips_blind = (lambda: None), (lambda: True)
    c._held_opening_m = _Obs.opening_m
    for excess in (1.5, 3.0):
        contact_n = grip_n + excess * FEEL_TOLERANCE * grip_n
        limit_n = c._drive_for_grip(_At(-(contact_n - grip_n) / k), 11.005, grip_n)[0]
        assert limit_n == pytest.approx(max(0.0, contact_n - friction_n)), excess
    # under the grip by the joints it is still brought up to it
    assert c._drive_for_grip(_At(0.2 * grip_n / k), 11.01, grip_n)[0] >= grip_n


def test_a_contact_creeping_open_over_the_grip_is_eased_down_not_waited_for(controller):
    """The probe leaves the contact over the grip wanted, and MuJoCo's soft dry friction lets it
    creep open toward the drive's force.  Fingers creeping the way the correction wants them are
    eased on (pulled from the band's near edge after ``persist`` readings, the slip watch waiting:
    a pressure let down is no slip); held until they stood still, the Rethink gripper's contact
    came down from 2.6x to 1.2x only by its creep over the hold, at the balanced preset.  Fingers
    moving against it (closing, here) are held first: the friction brakes them."""
    c = controller
    grip, over = 0.1, 0.1 * (1 + 2 * FEEL_TOLERANCE)
    still_m = 0.1 * c.touch_speed_m_s * c.dt_s
    c._fingertips_grip_n = lambda: (over, 1e-4)

    def period(k: int, step_m: float) -> float:
        obs = _Obs()
        obs.opening_m = _Obs.opening_m + k * step_m
        return c._drive_for_grip(obs, 10.0 + 0.005 * k, grip)[0]

    c._slip_watch_from_s = -math.inf
    closing = [period(k, -3 * still_m) for k in range(c.cfg.persist + 3)]
    assert all(d >= 0.0 for d in closing)  # closing while a pull is wanted: held (let down, never pulled)
    assert c._slip_watch_from_s > 10.0  # held under the contact, which creeps down to the drive: no slip
    c._over_periods, c._moved_dir, c._slip_watch_from_s = 0, 0, -math.inf
    opening = [period(k, 3 * still_m) for k in range(c.cfg.persist + 3)]
    assert opening[c.cfg.persist - 1] < grip  # creeping open: eased on (pulled)
    assert c._slip_watch_from_s > 10.0  # the slip watch waits while the pressure is let down


def test_a_grip_felt_too_hard_is_eased_down_by_pulling_open_only_after_it_persists(controller):
    """A contact past the friction's band (felt - F_f over the grip: a heavy grip) over the
    tolerance for ``persist`` readings (sliding pads' chatter reads high one period): the drive
    eases from the band's near edge downward by a small step a period, and once it pulls (a
    negative force) the opening target is home, the limit the pull's size."""
    grip, too_hard = 4.0, 4.0 * (1 + 2 * FEEL_TOLERANCE)
    edge = too_hard - controller.robot.finger_friction_n
    # the fingers creep open a little each period, as an over-pressed contact's do under MuJoCo's
    # soft friction (standing still, they could press no more than the drive's force and F_f:
    # test_a_reading_past_what_the_drive_can_press_is_read_as_the_drive_can)
    steps = [_drive(controller, too_hard, grip, t=10.0 + 0.005 * k, obs=_At(1e-5 * k)) for k in range(controller.cfg.persist + 2)]
    assert steps[0] == (grip, controller.opening_target)  # a first reading over it moves nothing
    eased = [limit for limit, _ in steps[controller.cfg.persist - 1 :]]
    assert eased[0] < edge and all(b < a for a, b in itertools.pairwise(eased))
    controller._drive_n = -0.3
    limit_n, opening_m = _drive(controller, too_hard, grip, t=11.0)
    assert opening_m == controller.robot.home_opening_m and limit_n > 0.3


def test_a_raised_grip_is_not_pulled_down_for_six_load_filter_time_constants(controller):
    grip, too_hard = 0.1, 0.1 * (1 + 2 * FEEL_TOLERANCE)
    _drive(controller, grip, 0.08, t=10.0)
    _drive(controller, grip, grip, t=10.005)  # raised: a slip's or a load change's answer
    for k in range(10):
        assert _drive(controller, too_hard, grip, t=10.01 + 0.005 * k)[0] == grip


def test_placing_the_falling_pressure_is_not_closed_on(controller):
    """Landing, the table takes the weight and the pads' pressure falls (a slip to the fingertips):
    the drive stays where the descent left it, and is not closed past its friction onto an object
    that is landing, nor set to the grip wanted (in the fingertips' units, over-read on a curved
    patch: the contact would creep up toward it)."""
    controller.phase = Phase.PLACE
    controller._drive_n = 0.07  # the descent's last drive
    assert _drive(controller, 0.02, 0.1) == (0.07, controller.opening_target)


def test_above_the_landing_a_grip_creeping_open_is_set_back_to_the_grip_never_closed_past_the_friction(controller):
    """Coming down, the object hangs in the pads, and its contact creeps toward a drive set in the
    friction's band: within the hold's tolerance the drive stays where it is; read under it, the
    drive goes back to the grip wanted (the contact creeps up toward it), and never past the
    friction as the hold closes a shortfall; at the landing it stays where it is."""
    above = _Obs()
    above.lift_pos_m = controller._rested_lift_m() + 2.0 * controller.cfg.touchdown_margin_m
    controller.phase = Phase.PLACE
    controller._drive_n = 0.07
    assert _drive(controller, 0.097, 0.1, obs=above) == (0.07, controller.opening_target)  # within the tolerance
    assert _drive(controller, 0.05, 0.1, obs=above) == (0.1, controller.opening_target)  # creeping open
    assert controller._drive_n == 0.1
    at = _Obs()
    at.lift_pos_m = controller._rested_lift_m() + 0.5 * controller.cfg.touchdown_margin_m
    controller._drive_n = 0.07
    assert _drive(controller, 0.05, 0.1, obs=at) == (0.07, controller.opening_target)


def test_fingers_still_opening_are_held_not_closed_on_at_once(controller):
    """Moving, the friction pushes with the drive the other way: fingers that a pull still opens
    and then read too light are held at the grip until they stand still (a close started at once
    snaps them shut past the grip), and only then closed on (the grip wanted unchanged: pushed at
    a pace, :meth:`GentleGrasp._start_push`)."""
    controller._moved_dir = -1  # a pull eases the grip down
    controller._held_opening_m = _Obs.opening_m - 1e-4  # and the fingers opened in the last period
    assert _drive(controller, 0.05, 0.1) == (0.1, controller.opening_target)
    assert controller._moved_dir == 0 and controller._hold_pull is None
    limit_n, _ = _drive(controller, 0.05, 0.1)  # standing still now
    assert controller._moved_dir == 1 and controller._hold_pull.closing and limit_n > 0.05


def test_a_grip_felt_far_over_is_held_at_the_friction_bands_near_edge(controller):
    """The probe leaves the contact up to twice the grip wanted.  Fingers closing that then read
    it are held F_f under the contact felt, at the friction band's near edge, where it creeps down
    toward the grip: set to the grip at once, the drive would throw them open by the whole excess
    and the object rock off the pads."""
    controller._moved_dir = 1  # closing
    controller._held_opening_m = _Obs.opening_m + 1e-4  # and the fingers closed in the last period
    controller._drive_n = 2.0 + 1.5 * controller.robot.finger_friction_n  # the drive that closed them, past the band
    limit_n, opening_m = _drive(controller, 2.0, 1.0)
    assert limit_n == pytest.approx(2.0 - controller.robot.finger_friction_n) and opening_m == controller.opening_target


@pytest.mark.parametrize("over_read", [1.0, 1.25, 1.6])
def test_a_heavy_patch_read_high_is_not_closed_on_by_the_friction_bands_edge(controller, over_read):
    """The element reads a curved patch's pressure over the whole pad, r times the contact C, and
    held at the friction band's near edge about the reading, r C - F_f, the drive stands past the
    far edge about the contact, C + F_f, once (r - 1) C > 2 F_f: the fingers close, the reading
    and the drive rise together (robosuite's Panda took a 728 g egg from 5.4 N to 16.4 N and crushed
    it).  Fingers that do not open press with their drive's force to within F_f, so the band's
    contact is bounded by the drive's own reading plus F_f: here a toy contact that creeps toward
    the band about it never rises, and comes down toward the grip."""
    friction_n = controller.robot.finger_friction_n
    grip_n, contact_n = 5.0, 12.0
    assert over_read == 1.0 or (over_read - 1.0) * contact_n > 2.0 * friction_n  # the old edge past the far one
    drive_n, share, k_n_m = contact_n, 0.3, 2000.0  # the contact's stiffness on the opening
    controller._held_opening_m, controller._drive_n = _Obs.opening_m, drive_n
    for _ in range(400):
        obs = _At(-(contact_n - 12.0) / k_n_m, drive_n)  # fingers that close press harder
        drive_n = _drive(controller, over_read * contact_n, grip_n, obs=obs)[0]
        if drive_n > contact_n + friction_n:  # past the far edge: the fingers close
            contact_n += share * (drive_n - contact_n - friction_n)
        elif drive_n < contact_n - friction_n:  # past the near edge: they open
            contact_n -= share * (contact_n - friction_n - drive_n)
        assert contact_n <= 12.0 + 1e-9
    assert contact_n < 12.0 - friction_n  # pulled down across the band, toward the grip


@pytest.mark.parametrize("over_read", [1.25, 1.6])
def test_a_blind_hold_is_not_closed_on_by_its_joints_stand_in(controller, over_read):
    """Blind, the joints stand in for the fingertips from their last reading, r times the contact
    over a curved patch, plus the pads' stiffness times the closing since: closing fingers raise
    their own stand-in.  Held at the band's near edge about it, the drive stood past the far edge
    about the contact and closed them on, unread (robosuite's Panda, an 889 g, 47 mm sphere: 7.6 N
    to 20 N in the raise).  Bounded by the drive's own force, a toy contact that creeps toward the
    band about it never rises."""
    c, friction_n = controller, controller.robot.finger_friction_n
    grip_n, contact_n = 5.0, 8.0
    k_n_m = _k(c, over_read * contact_n)  # the joints' reckoning's stiffness
    c._felt_ref = (_Obs.opening_m, over_read * contact_n)  # the last reading
    c._fingertips_grip_n, c._fingertips_blind = (lambda: None), (lambda: True)
    drive_n, share = contact_n, 0.3
    c._drive_n = drive_n  # the drive that stands the fingers at this contact
    for i in range(400):
        obs = _At(-(contact_n - 8.0) / k_n_m, drive_n)  # fingers that close press harder
        drive_n = c._drive_for_grip(obs, 10.0 + i * c.dt_s, grip_n)[0]
        if drive_n > contact_n + friction_n:
            contact_n += share * (drive_n - contact_n - friction_n)
        elif drive_n < contact_n - friction_n:
            contact_n -= share * (contact_n - friction_n - drive_n)
        assert contact_n <= 8.0 + 1e-9


def test_a_reading_past_what_the_drive_can_press_is_read_as_the_drive_can(controller):
    """Fingers at rest press with their drive's force to within F_f: a reading over the drive's last
    force plus F_f is the element's over-read of a curved patch (1.25-1.6x), not the contact.  A
    heavy grip found on the drive's reading while the fingertips were blind (robosuite's Panda, a
    448 g egg carried at 8.55 N and read at 11.6 N) is held, not pulled down by the over-read and
    dropped; a reading the drive can press (its last force over it) is too hard, and pulled."""
    friction_n, grip_n = controller.robot.finger_friction_n, 8.55
    for drive_n, pulled in ((grip_n, False), (11.6 + friction_n, True)):
        controller._drive_n, controller._moved_dir, controller._hold_pull, controller._over_periods = drive_n, 0, None, 0
        controller._grip_rose_s = -math.inf
        limits = [_drive(controller, 11.6, grip_n, t=10.0 + 0.005 * k)[0] for k in range(controller.cfg.persist + 3)]
        if pulled:
            assert limits[-1] < drive_n - friction_n  # pulled down, past the band
        else:
            assert min(limits) >= grip_n - 1e-9 and controller._hold_pull is None


def test_opening_fingers_are_held_at_the_band_about_the_reading(controller):
    """Fingers seen opening press with more than their drive's force less F_f: the drive's last force
    bounds nothing then, and the drive is held at the band's near edge about the reading (set
    under it, they would be thrown open by the whole excess).  Standing still, the same reading is
    more than they can press, and the contact is under the grip: closed on."""
    friction_n = controller.robot.finger_friction_n
    grip_n, felt_n = 10.0, 10.0 * (1.0 + 0.5 * FEEL_TOLERANCE)  # within the tolerance, a heavy grip
    controller._held_opening_m, controller._drive_n = _Obs.opening_m, 5.0  # the drive at 5 N in the last period
    limit_n, _ = _drive(controller, felt_n, grip_n, obs=_At(1e-4))  # opening: the reading stands
    assert limit_n == pytest.approx(felt_n - friction_n)
    controller._held_opening_m, controller._drive_n, controller._moved_dir = _Obs.opening_m, 5.0, 0
    limit_n, _ = _drive(controller, felt_n, grip_n, obs=_At(0.0))  # still: it presses 5.8 N at most, under the grip
    assert limit_n > 5.0 + friction_n and controller._moved_dir == 1


@pytest.mark.slow
@pytest.mark.parametrize(
    ("obj", "most"),
    [
        ({"object.mass_kg": 0.003, "object.size_m": 0.03, "object.friction": 0.8}, 1.5),
        ({"object.shape": "sphere", "object.mass_kg": 0.002, "object.size_m": 0.025, "object.friction": 0.6}, 1.6),
    ],
    ids=["box-3g", "sphere-2g"],
)
def test_a_light_object_on_a_friction_drive_is_held_near_its_need(tmp_path, obj, most):
    """0.8 N of dry friction a finger against grips of 15-30 mN: closing at 20 mm/s the touch left
    0.1 N that the friction held (robosuite's Panda: a 3 g cube at 5.3x its need); now held within
    ``most`` of the need, the contact under 1.6x it until the object is put down (the touchdown
    presses a light object into the pads: test_gentle_touch.py's known gap)."""
    result = piezotip.run("grasp", overrides={**keys(sticky_gripper(tmp_path)), **obj}, preset="fast")
    assert result.outcome == "success", result.reason
    assert 1.0 < result.grip_margin <= most
    data = result.data
    force = np.maximum(data["left_finger_force_n"], data["right_finger_force_n"])
    assert force[data["phase"] < phase_index("place")].max() < 1.6 * result.summary["needed_grip_n"]


@pytest.mark.slow
def test_the_pandas_light_box_is_held_on_its_fingertips_not_at_the_touchs_leftover():
    """robosuite's Panda (1 N of dry friction a finger) held the 1 g tissue box at 12.8x its need,
    the touch's 0.1 N held by its friction: now under 2x."""
    file, tips, actuators = ROBOSUITE["panda"]
    overrides = {**keys(_robosuite_grippers() / file, tips, actuators), **_catalogue("tissue-box-1g")}
    result = piezotip.run("grasp", overrides=overrides, preset="fast")
    assert result.outcome == "success", result.reason
    assert result.grip_margin < 2.0
    assert result.summary["touch_peak_n"] < 0.05


@pytest.mark.slow
def test_the_pandas_grip_answers_a_load_change_on_its_fingertips():
    """``grasp-disturb`` on robosuite's Panda: the hold's answer (the grip following the load)
    reaches the pads across the drive's 1 N of friction, and the box stays put."""
    file, tips, actuators = ROBOSUITE["panda"]
    result = piezotip.run("grasp-disturb", overrides=keys(_robosuite_grippers() / file, tips, actuators), preset="fast")
    assert result.outcome == "success", result.reason
    assert result.summary["disturb_slip_mm"] <= 2.0


@pytest.mark.slow
def test_a_friction_read_past_the_pads_highest_is_a_misread_said_and_read_again():
    """Robotiq's 2F-85 read the rubber ball's friction (1.2) past the pads' highest (1.5), its
    drive reading the grip without what the load adds on the linkage's arc.  Taken as the cap, a
    misread held Menagerie's 2F-85's box under its need; now each is an event, and the probe
    reads again.  Since the friction read counts the load on the arc (gentle.py _load_closes_n)
    it reads 1.07 there; the pads' highest set at 1.0 makes those reads the misreads here."""
    overrides = {**keys(_robotiq_2f85(), *ROBOTIQ_2F85), **_catalogue("rubber-ball-50g"), "controller.friction_max": 1.0}
    result = piezotip.run("grasp", overrides=overrides, preset="fast")
    misreads = [e for e in result.events if e["kind"] == "friction_misread"]
    assert misreads and all("reading again" in e["message"] for e in misreads)
    assert result.outcome == "success", result.reason
    assert 1.0 < result.grip_margin <= 2.5
    assert not math.isnan(result.summary["touch_peak_n"])


@pytest.mark.slow
def test_the_2f85s_friction_read_counts_the_load_on_its_arc_and_holds_menageries_box():
    """Menagerie's 2F-85 on the 100 g box (friction 1.0): the drive read the grip 0.33 N where the
    pads pressed 0.5-0.7 N (the box's weight pulls the pads down their arc, closing them: L dh/do,
    the arc's slope 0.17 at 40 mm).  The friction read from it, 1.49 after two misreads, held the
    box at 0.41 N of its 0.49 N: it slid 19 mm down the pads in the raise and landed at 0.10 m/s
    (dropped).  Counted, the friction is read within the pads' highest and the box is carried."""
    from test_third_party_grippers import menagerie_keys

    result = piezotip.run("grasp", overrides=menagerie_keys("robotiq-2f85"), preset="fast")
    assert result.outcome == "success", result.reason
    assert not [e for e in result.events if e["kind"] == "friction_misread"]
    assert result.grip_margin >= 1.0


@pytest.mark.slow
@pytest.mark.parametrize("gripper", ["dm_robotics", "menagerie"])
def test_a_linkages_raise_is_not_read_as_a_slip(gripper):
    """Both 2F-85s on the 1 g box, 10 % heavier than the catalogue's (1.1 g, friction 0.6, needs
    9 mN).  The fingers swing on their arc as the lift speeds up (their inertia): the pads'
    force rose to 2.5x the grip and fell back over 0.15 s, and that fall was answered as a slip,
    the grip raised 1.25x: 1.54-1.61x the need.  And the probe's bound on the friction came from
    the span's first grip, at which the pads still slid (the table holding the rest): Menagerie's
    read "at least 0.93" for the box's 0.6, held it at 1.00x, and it slid 10 mm down the pads and
    landed at 0.10 m/s (dropped).  Now: the friction read within 10 % (the least grip that
    carried the weight, gentle.least_carrying_grip_n), no slip answered in the raise, held within
    1.5x."""
    from test_third_party_grippers import menagerie_keys

    box = {**_catalogue("tissue-box-1g"), "object.mass_kg": 1.1 * scenarios.OBJECTS["tissue-box-1g"].mass_kg}
    drive = keys(_robotiq_2f85(), *ROBOTIQ_2F85) if gripper == "dm_robotics" else menagerie_keys("robotiq-2f85")
    result = piezotip.run("grasp", overrides={**drive, **box}, preset="fast")
    assert result.outcome == "success", result.reason
    carried = next(e for e in result.events if e["kind"] == "carried")
    read = float(re.search(r"friction (?:at least )?([0-9.]+)", carried["message"]).group(1))  # a bound, or read sliding
    assert read == pytest.approx(scenarios.OBJECTS["tissue-box-1g"].friction, rel=0.1), carried["message"]
    hold = next(e["time_s"] for e in result.events if e["kind"] == "phase" and e["message"].startswith("hold"))
    assert not [e for e in result.events if e["kind"] == "slip" and carried["time_s"] < e["time_s"] < hold]
    assert 1.0 < result.grip_margin <= 1.5


@pytest.mark.slow
@pytest.mark.parametrize("obj", ["box-100g", "can-500g"])
def test_a_linkage_holds_the_grip_wanted_on_its_pads_not_on_its_drive(obj):
    """dm_robotics' 2F-85 (a four-bar, no dry friction) on the catalogue's box and can (the
    mounted grippers' compliant pad contact): the drive held the grip wanted while the weight's pull along the pads'
    arc (W dh/do) pressed them 0.17 W more, 1.60x and 1.80x the need; the weight's closing taken off
    the drive, the pads hold the grip wanted, 1.25x."""
    overrides = {**keys(_robotiq_2f85(), *ROBOTIQ_2F85), **_catalogue(obj)}
    result = piezotip.run("grasp", overrides=overrides, preset="fast")
    assert result.outcome == "success", result.reason
    assert 1.0 <= result.grip_margin <= 1.4


@pytest.mark.slow
def test_a_linkages_damping_push_answers_the_controllers_grip_not_the_lifts_braking_term():
    """dm_robotics' 2F-85 on the 2 g wafer (crushes at 0.05 N, needs 0.025 N): the push that pays
    a rise in the grip to the fingers' damping was paid on every rise of the grip the drive was
    given, which carries the lift's braking term (``RobotLimits.lift_opens_n``, jittering with
    the lift's measured acceleration); the pads closed to 1.6x and crushed it.  Paid on the
    controller's own grip, it is held at about 1.3x, whole."""
    from piezotip.reports.gripper_tables import WAFER

    result = piezotip.run("grasp", overrides={**keys(_robotiq_2f85(), *ROBOTIQ_2F85), **WAFER}, preset="fast")
    assert result.outcome == "success", result.reason
    assert result.grip_margin <= 1.4


@pytest.mark.slow
def test_a_linkages_raise_while_placing_does_not_press_the_landing():
    """Menagerie's 2F-85 on the 2 g wafer (crushes at 0.05 N, needs 0.025 N): placing, the table
    took the weight and the pads' pressure fell 146 -> 117 Pa, read as a slip: its raise (0.0325
    -> 0.0406 N) reached the linkage's pads, and the landing's slip, whose speed was planned for
    the grip before it, pressed them to 0.056 N: crushed.  Held at the planned grip while placing
    (as a friction drive's raise stays within its friction), it lands whole."""
    from test_third_party_grippers import menagerie_keys

    from piezotip.reports.gripper_tables import WAFER

    result = piezotip.run("grasp", overrides={**menagerie_keys("robotiq-2f85"), **WAFER}, preset="fast")
    assert result.outcome == "success", result.reason
    assert result.summary["peak_contact_n"] < WAFER["object.crush_force_n"]


def test_the_load_closes_a_linkages_pads_by_its_arcs_slope_and_slides_not_at_all(controller):
    """The grip the load L adds on the opening, L dh/do: 0 on slides; on the 2F-85 the slope of
    the pads' rise along the free closing (0.17-0.19 at a 40 mm opening, steeper when open)."""
    from types import SimpleNamespace

    def opening(m: float):
        return SimpleNamespace(opening_m=m)

    assert controller._load_closes_n(opening(0.03), 1.0) == 0.0
    robotiq = CoSimulation(scenarios.get("grasp", keys(_robotiq_2f85(), *ROBOTIQ_2F85), "fast")).controller
    at_40mm = robotiq._load_closes_n(opening(0.040), 1.0)
    assert 0.15 < at_40mm < 0.2
    assert robotiq._load_closes_n(opening(0.040), 2.0) == pytest.approx(2.0 * at_40mm)
    assert robotiq._load_closes_n(opening(0.060), 1.0) > at_40mm


def test_a_rise_in_the_grip_wanted_is_paid_to_the_fingers_damping_for_a_period(controller):
    """A grip wanted that rises past the felt (a load change's answer) closes the fingers at the
    rise's rate: past the friction's band by c_j rise / (k dt) for that period (its impulse moves
    damped fingers by rise / k), then no more; a grip already felt is not closed on."""
    c, friction_n = controller, controller.robot.finger_friction_n
    assert _drive(c, 0.1, 0.1, t=10.0)[0] == 0.1  # held
    rise = 0.02
    push = c.robot.finger_joint_damping_n_s_m * rise / (c.contact_stiffness_n_m * c.dt_s)
    assert push > 0.0
    closing = min(c._closing_drive_n(0.1 + rise, rise), c.cfg.grip_safety * (0.1 + rise) + friction_n)
    limit_n, _ = _drive(c, 0.1, 0.1 + rise, t=10.005)
    assert limit_n == pytest.approx(closing + push)
    assert _drive(c, 0.1, 0.1 + rise, t=10.01)[0] == pytest.approx(closing)  # paid once
    c._last_grip_n = 0.1  # a rise to a grip the fingertips already feel moves nothing
    held = _drive(c, 0.125, 0.12, t=10.015)[0]  # held within the tolerance, the excess taken off
    assert held == pytest.approx(max(0.12 - 0.005 / FEEL_TOLERANCE, 0.125 - friction_n)) and held < 0.12


def test_the_shortfall_is_closed_through_the_fingers_damping_in_four_periods(controller):
    """Damped fingers close at the force past the friction's band over their damping c_j: the
    drive is grip + F_f + c_j off / (k 4 dt) (at least CLOSING_GAIN x off), no memory of the last."""
    c = controller
    tau_s = c.dt_s / CLOSING_GAIN
    gain = max(CLOSING_GAIN, c.robot.finger_joint_damping_n_s_m / (c.contact_stiffness_n_m * tau_s))
    friction_n = c.robot.finger_friction_n
    assert c._closing_drive_n(0.1, 0.02) == pytest.approx(0.1 + friction_n + gain * 0.02)


def test_a_load_change_is_answered_while_the_fingertips_settle(controller):
    """Held at its grip, the fingertips then blind (a pad settling as the load comes on), the grip
    wanted rises over the contact (a load change's answer): the drive pushes past the friction's
    band at once, paying the rise to the fingers' damping, until the joints say the contact is up
    to it.  Stopped at the grip in the friction's band instead, robosuite's Panda stood while
    grasp-disturb's load came on at the balanced preset, and the box fell."""
    c, k, friction_n = controller, controller.contact_stiffness_n_m, controller.robot.finger_friction_n
    _drive(c, 0.1, 0.1)
    assert c._moved_dir == 0  # held
    c._fingertips_grip_n, c._fingertips_blind = (lambda: None), (lambda: True)
    limit_n, opening_m = c._drive_for_grip(_Obs(), 10.005, 0.15)
    assert limit_n > 0.15 + friction_n and opening_m == c.opening_target and c._moved_dir == 1
    assert c._drive_for_grip(_At(-0.5 * 0.05 / k), 10.01, 0.15)[0] > 0.15 + friction_n  # half way: on
    assert c._drive_for_grip(_At(-1.01 * 0.05 / k), 10.015, 0.15)[0] == 0.15  # there by the joints: held


def test_a_blind_push_stops_where_the_drive_past_its_friction_says_the_grip_is(controller):
    """A loaded gel stiffens, and the joints' small-strain estimate reads a heavy grip's rise short
    (robosuite's Rethink pushed its box's contact to 1.4x the grip at the accurate preset): fingers
    closing slide through their friction, so their drive's reading less F_f presses the pads, and
    a blind push stops where that reaches the grip.  A grip wanted that rises again while they
    close is pushed for at the new grip, its rise not paid to the damping twice."""
    c, k, friction_n = controller, controller.contact_stiffness_n_m, controller.robot.finger_friction_n
    _drive(c, 0.1, 0.1)
    c._fingertips_grip_n, c._fingertips_blind = (lambda: None), (lambda: True)
    c._drive_for_grip(_Obs(), 10.005, 0.15)
    closing = -0.2 * 0.05 / k  # a fifth of the way by the joints
    first_n = c._drive_for_grip(_At(closing, 0.15 + friction_n - 0.01), 10.01, 0.15)[0]
    assert first_n > 0.15 + friction_n and c._moved_dir == 1  # the drive says short of it: on
    again_n = c._drive_for_grip(_At(2 * closing, 0.15 + friction_n - 0.01), 10.015, 0.2)[0]  # the grip wanted rose again
    assert again_n > 0.2 + friction_n and again_n <= c.cfg.grip_safety * 0.2 + friction_n
    limit_n, _ = c._drive_for_grip(_At(3 * closing, 0.2 + friction_n), 10.02, 0.2)  # the drive says there
    assert limit_n == 0.2 and c._moved_dir == 0


@pytest.mark.slow
@pytest.mark.parametrize("preset", ["fast", "balanced"])
@pytest.mark.parametrize("gripper", ["rethink", "panda"])
def test_robosuites_grip_answers_a_load_change_in_time(gripper, preset):
    """``grasp-disturb`` on robosuite's slides (1 kg of armature, 100 N s/m of damping and 1 N of
    dry friction a finger): the Rethink gripper dropped the box (51 mm; the pads' grip fell 0.67 ->
    0.49 N while the drive rose to 1.84 N): the drive set the fingers closing by a quarter of the
    shortfall past their friction, which their damping turned into 1 mm/s where the load used the
    grip's margin in 15 ms; once the box slid, MuJoCo's sliding contact pushed the pads apart.
    Closing at the rate the grip wanted rises (and the shortfall in four periods) it holds; at the
    balanced preset too, where a pad settles as the load comes on (the push goes on blind as far
    as the fingers' joints say the contact is under the grip)."""
    file, tips, actuators = ROBOSUITE[gripper]
    result = piezotip.run("grasp-disturb", overrides=keys(_robosuite_grippers() / file, tips, actuators), preset=preset)
    s = result.summary
    assert result.outcome == "success", result.reason
    assert s["disturb_slip_mm"] <= 2.0
    assert s["disturb_reaction_ms"] <= 40.0
    assert s["disturb_grip_margin"] <= (1.5 if gripper == "rethink" else 1.7)


@pytest.mark.slow
@pytest.mark.parametrize(("gripper", "preset"), [("dm_robotics", "fast"), ("menagerie", "fast"), ("menagerie", "balanced")])
def test_the_2f85s_grip_holds_through_a_load_change(gripper, preset):
    """``grasp-disturb`` on Robotiq's 2F-85 (no dry friction; a four-bar whose pads the load
    closes): the box slid 10 mm (dm_robotics') or fell (Menagerie's) under the weight again while
    the grip was held from a friction read 1.1-1.5 for its 1.0; read with the load on the arc
    counted, it stays put.  Held at the grip wanted on the pads (the load's closing taken off the
    drive, never for more load than the grip answers: taken for the load at once, the box slid
    14-16 mm while the grip rose), the answer paid to the fingers' damping (without: 75-95 ms),
    and the raised grip's ring not read as a slip (read as one, it raised the new hold to
    1.8x), the issue's goals: slip <= 2 mm, reaction <= 40 ms, the new hold within 1.5x.
    (Menagerie's at `balanced` slipped 2.6 mm, answered in 70 ms and held at 1.59x until its
    friction was read at the grip nearest the hold's: gentle.lifted_off_friction.)"""
    from test_third_party_grippers import menagerie_keys

    overrides = keys(_robotiq_2f85(), *ROBOTIQ_2F85) if gripper == "dm_robotics" else menagerie_keys("robotiq-2f85")
    result = piezotip.run("grasp-disturb", overrides=overrides, preset=preset)
    s = result.summary
    assert result.outcome == "success", result.reason
    assert s["disturb_slip_mm"] <= 2.0
    assert s["disturb_reaction_ms"] <= 40.0
    assert s["disturb_grip_margin"] <= 1.5


def _catalogue(name: str) -> dict:
    obj = scenarios.OBJECTS[name]
    return {f"object.{k}": getattr(obj, k) for k in ("shape", "mass_kg", "size_m", "friction", "crush_force_n")}


@pytest.mark.parametrize("preset", ["balanced", "accurate"])
@pytest.mark.parametrize("gripper", ["panda", "rethink"])
def test_friction_drives_probe_on_the_fingertips_at_the_envelope_presets(gripper, preset):
    """At the presets whose readout runs the envelope dynamics, the readings go "settling" while
    the pressure ramps under a pad and through a switch's ring-up, most of the probe's periods on
    one pad or the other.  The probe read the drive's force then, off by its 1 N of dry friction:
    robosuite's Panda called the 100 g box carried at 0.05 N of load (friction "at least 1.5")
    and lost it; the Rethink gripper read the friction 0.27 for its 1.0 and held the box at 4.8x.
    Taking only the periods the fingertips read, growing the grip only while they have read
    within a plateau window, and raising the object the lift height from where it was carried
    (its pads slid up the box for seconds), the friction is read within 5 % and the box held
    within 1.5x of its need."""
    file, tips, actuators = ROBOSUITE[gripper]
    overrides = keys(_robosuite_grippers() / file, tips, actuators, **{"controller.kind": "gentle"})
    result = piezotip.run("grasp", overrides=overrides, preset=preset)
    s = result.summary
    assert result.outcome == "success", result.reason
    carried = [e["message"] for e in result.events if e["kind"] == "carried"]
    read = float(re.search(r"friction (?:at least )?([0-9.]+)", carried[0]).group(1))
    assert read == pytest.approx(scenarios.OBJECTS["box-100g"].friction, rel=0.05), carried
    assert s["grip_margin"] <= 1.5
    assert s["max_rise_m"] >= GentleConfig().lift_height_m  # the raise lifted the box the height asked


def test_a_friction_drives_probe_grows_the_contact_it_presses_not_the_drives_force(controller):
    """The probe's grip grows in proportion to itself; on a drive with dry friction F_f pressing
    its fingers, in proportion to the contact it presses (the drive's force less F_f, or the
    fingertips' reading, whichever is more), not to the drive's force: a 0.03 N contact under a
    1.03 N drive grew by 0.26 N a plateau window, 8x itself."""
    c, friction_n = controller, controller.robot.finger_friction_n
    c._fingertips_grip_n = lambda: (0.03, 1e-4)
    c.grip_n = 0.5 * friction_n  # within the friction's band: the drive's own force
    assert c._probe_base_n() == 0.5 * friction_n
    c.grip_n = friction_n + 0.01  # pressing: the contact, the fingertips' 0.03 N here
    assert c._probe_base_n() == pytest.approx(0.03)
    c.grip_n = friction_n + 0.2
    assert c._probe_base_n() == pytest.approx(0.2)
    house = CoSimulation(scenarios.get("grasp")).controller  # no friction: the grip itself
    house.grip_n = 0.7
    assert house._probe_base_n() == 0.7


@pytest.mark.parametrize("gripper", ["panda", "rethink"])
def test_a_raspberry_the_pads_slid_off_is_not_crushed_at_the_balanced_preset(gripper):
    """The 20 mm raspberry (crushes at 1.5 N), pinched above its centre: the pads slide up over it
    and off during the probe, and the regained contact ramped unseen (the envelope readout reads
    a ramp's onset "settling") under a drive grown in proportion to its own force past the
    friction: crushed at 1.4-5 N on both grippers.  Grown with the contact, never crushed."""
    file, tips, actuators = ROBOSUITE[gripper]
    overrides = {**keys(_robosuite_grippers() / file, tips, actuators), **_catalogue("raspberry-4g"), "controller.kind": "gentle"}
    result = piezotip.run("grasp", overrides=overrides, preset="balanced")
    assert result.outcome != "crushed", result.reason
    assert result.summary["peak_contact_n"] < scenarios.OBJECTS["raspberry-4g"].crush_force_n


def _robosuite_run(gripper: str, obj: str, preset: str, mass_x: float = 1.0, friction_x: float = 1.0, seed: int = 0):
    file, tips, actuators = ROBOSUITE[gripper]
    overrides = {**keys(_robosuite_grippers() / file, tips, actuators), **_catalogue(obj), "controller.kind": "gentle"}
    overrides["sensor.seed"] = seed
    overrides["object.mass_kg"] = mass_x * scenarios.OBJECTS[obj].mass_kg
    overrides["object.friction"] = friction_x * scenarios.OBJECTS[obj].friction
    return piezotip.run("grasp", overrides=overrides, preset=preset)


@pytest.mark.slow
@pytest.mark.parametrize(
    ("gripper", "friction_x", "mass_x", "seed"),
    [("panda", 1.0, 1.0, 0), ("rethink", 1.1, 1.1, 0), ("panda", 1.0, 1.0, 1), ("panda", 1.0, 1.0, 2), ("panda", 1.1, 1.1, 1)],
)
def test_a_tissue_box_carried_before_its_pads_slid_is_let_down_and_held_near_its_need(gripper, friction_x, mass_x, seed):
    """The 1 g tissue box at the balanced preset, carried from the contact the touch's ease left
    before its pads were ever seen to slide: robosuite's Panda held it at 1.51x its need (the
    grip's safety factor on the bound that contact gave), and on the fingers' joints alone the
    let-down held the Rethink's at 1.00x, creeping down.  Let down and carried from the
    fingertips' reading: within 1.5x, and over grip_safety's share of it the element under-reads.
    At noise seed 1 the Panda's let-down read a stale reading, the contact before the pull
    (test_a_let_down_reads_the_contact_after_the_readouts_flag), and held the box at 1.62x; at
    seed 2, and at 1.1x friction and mass at seed 1, it pulled over a full face's stiffness and
    left the contact over its goal, 1.53x and 1.55x
    (test_a_let_down_pulls_over_a_faces_own_stiffness_and_a_patchs_full_face)."""
    result = _robosuite_run(gripper, "tissue-box-1g", "balanced", mass_x=mass_x, friction_x=friction_x, seed=seed)
    assert result.outcome == "success", result.reason
    assert "let_down" in [e["kind"] for e in result.events]
    assert 1.1 <= result.summary["grip_margin"] <= 1.5


@pytest.mark.slow
def test_the_pandas_wafer_survives_the_probe_at_the_accurate_preset():
    """robosuite's Panda on the 2 g wafer (needs 25 mN, crushes at 0.05 N) at the accurate preset:
    its two readouts settle by turns, and a probe whose span waited for both read them together
    in 9 of 116 periods once the wafer was off the table, decided only after the grip grew 1.95x,
    and crushed it (0.056 N).  The span takes the pad that reads: carried at 1.2-1.3x its need,
    whole (test_the_probes_span_reads_one_pad_while_the_other_settles_and_grows_on_both)."""
    from piezotip.reports.gripper_tables import WAFER

    file, tips, actuators = ROBOSUITE["panda"]
    overrides = {**keys(_robosuite_grippers() / file, tips, actuators), **WAFER, "controller.kind": "gentle"}
    result = piezotip.run("grasp", overrides=overrides, preset="accurate")
    assert result.outcome == "success", result.reason
    assert result.summary["peak_contact_n"] < 0.9 * WAFER["object.crush_force_n"]
    assert result.summary["grip_margin"] <= 1.5


@pytest.mark.slow
@pytest.mark.parametrize("gripper", ["panda", "rethink"])
def test_the_raspberry_is_held_within_one_and_a_half_of_its_need_at_balanced_where_its_contact_holds(gripper):
    """The 4 g raspberry at 1.1x mass and 0.9x friction (robosuite's Panda) and as it is (its
    Rethink gripper), at the balanced preset: their probes' spans, waiting for both pads' readouts
    at once, decided late and the raspberry was held at 2.0x and 2.8x its need; taking the pad
    that reads, within 1.5x."""
    mass_x, friction_x = (1.1, 0.9) if gripper == "panda" else (1.0, 1.0)
    result = _robosuite_run(gripper, "raspberry-4g", "balanced", mass_x=mass_x, friction_x=friction_x)
    assert result.outcome == "success", result.reason
    assert result.summary["grip_margin"] <= 1.5


@pytest.mark.slow
@pytest.mark.parametrize(
    ("preset", "friction_x", "mass_x", "was"),
    [("balanced", 1.0, 1.0, 2.31), ("balanced", 0.9, 0.9, 2.07), ("accurate", 1.0, 1.0, 2.23), ("accurate", 1.1, 0.9, 2.60)],
)
def test_the_pandas_raspberry_keeps_its_contact_through_the_probe(preset, friction_x, mass_x, was):
    """robosuite's Panda meets the 4 g raspberry at its equator with its pads' lower edge, and its
    fingers, in their drive's 1 N friction band, only creep after the sphere as it narrows under
    the sliding pads: the contact was lost within 0.8 mm of the probe's climb, regained 13 degrees
    up on the blind growth's ramp, and the raspberry carried from there at ``was`` x its need
    (the friction bounded only from below).  The climb slowed where the contact fades
    (test_the_probe_climbs_slower_where_the_contact_fades_and_back_where_it_reads_a_rise), the
    fingers keep it: the friction is measured while the pads slide, and the raspberry held within
    1.5x (at 0.9x friction and mass with the climb's floor an eighth, not a quarter: 1.87x, its
    grip grown further before it left the table)."""
    result = _robosuite_run("panda", "raspberry-4g", preset, mass_x=mass_x, friction_x=friction_x)
    assert result.outcome == "success", result.reason
    carried = next(e["message"] for e in result.events if e["kind"] == "carried")
    assert "measured while the pads slid" in carried, carried
    assert result.summary["grip_margin"] <= 1.5
    # Not under its safety factor either: its friction is read at the grip nearest the hold's
    # (the contact tilts further as the grip grows, and the read falls: read at a lighter grip
    # it held the raspberry at 1.08-1.10x; gentle.lifted_off_friction).
    data = result.data
    held = np.asarray(data["phase"]) == phase_index("hold")
    grip = 0.5 * (np.asarray(data["left_finger_force_n"])[held] + np.asarray(data["right_finger_force_n"])[held])
    assert grip.min() >= 1.15 * result.summary["needed_grip_n"]


@pytest.mark.slow
@pytest.mark.parametrize(("gripper", "obj", "was"), [("panda", "rubber-ball-50g", 1.57), ("rethink", "egg-60g", 1.58)])
def test_a_friction_drive_places_at_the_grip_it_held(gripper, obj, was):
    """The place set a friction drive to the grip wanted, in the fingertips' units, which
    over-read a curved patch by 30-40 %: for the second the place lasted the contact crept up
    toward it, and landed ``was`` x its need (`fast`).  Held as in the hold on the way down, and at
    the descent's last drive as it lands, the place presses the object no harder than the hold
    did, but for the landing's slip (its plan allows the grip's safety factor), and within 1.5x
    its need."""
    result = _robosuite_run(gripper, obj, "fast")
    assert result.outcome == "success", result.reason
    data = result.data
    phase = np.asarray(data["phase"])
    grip = 0.5 * (np.asarray(data["left_finger_force_n"]) + np.asarray(data["right_finger_force_n"]))
    held, placed = grip[phase == phase_index("hold")], grip[phase == phase_index("place")]
    need_n = result.summary["needed_grip_n"]
    assert placed.min() >= need_n
    assert placed.max() <= min(GentleConfig().grip_safety * held[-1], 1.5 * need_n)
    assert result.summary["peak_contact_n"] <= 1.5 * need_n


@pytest.mark.slow
def test_a_friction_drives_place_reckons_a_contact_creeping_open_on_its_joints_while_blind():
    """robosuite's Panda, its 500 g can at 0.9x friction and mass, the readout's noise seed 1, at
    the balanced preset: the hold handed the place a drive 0.65 N under the contact (a pull under
    way), the fingertips went blind (settling) as the descent began, and the contact crept open
    unread from 1.23x its need to 1.00x; the descent's braking slid it out of the pads.  Blind, the
    fingers' joints stand in for the fingertips (the contact last felt less the pads' loaded
    stiffness times the opening since), and the drive goes back to the grip wanted: placed whole,
    never under its need."""
    result = _robosuite_run("panda", "can-500g", "balanced", mass_x=0.9, friction_x=0.9, seed=1)
    assert result.outcome == "success", result.reason
    data = result.data
    phase = np.asarray(data["phase"])
    grip = 0.5 * (np.asarray(data["left_finger_force_n"]) + np.asarray(data["right_finger_force_n"]))
    assert grip[phase == phase_index("place")].min() >= result.summary["needed_grip_n"]


@pytest.mark.slow
def test_a_grip_read_to_rise_as_the_readout_catches_up_is_no_verdict():
    """robosuite's Rethink gripper, its 3 g cube at 0.9x friction and mass, the readout's noise seed
    1, at the balanced preset: as the readout caught up with a contact it had under-read, it read a
    rise of 30 % while the fingers closed 0.1 um (a few hundredths of a millinewton through the
    pads); the probe called the cube carried at a quarter of its weight and lost it
    (``never_lifted``).  A rise must be the fingers' doing (fingers_closed_for): carried, within 1.5x."""
    result = _robosuite_run("rethink", "cube-3g", "balanced", mass_x=0.9, friction_x=0.9, seed=1)
    assert result.outcome == "success", result.reason
    assert result.summary["grip_margin"] <= 1.5
    assert result.summary["peak_contact_n"] <= 1.5 * result.summary["needed_grip_n"]


@pytest.mark.slow
def test_the_raise_waits_for_the_carrys_push():
    """robosuite's Rethink gripper, its raspberry at 1.1x mass, the accurate preset: the probe let
    the contact down to 0.047 N and carried it there, by pads that had slid up to 17 degrees above
    the sphere's centre; the carry set 0.078 N and read the grip 18 % short.  Pushed past the
    friction's band at once as the raise began, the fingers closed 84 um in 40 ms and the sphere
    was lost in 20 ms (``never_lifted``); pushed at a pace but raised at once, it slipped as the
    lift sped up (slipping up a sphere above its equator, the pads press it less).  Pushed at a
    pace, the raise waiting for the push (60 ms): carried, within 1.5x."""
    result = _robosuite_run("rethink", "raspberry-4g", "accurate", mass_x=1.1)
    assert result.outcome == "success", result.reason
    assert result.summary["grip_margin"] <= 1.5
    assert result.summary["peak_contact_n"] <= 1.5 * result.summary["needed_grip_n"]


@pytest.mark.slow
def test_a_held_grasp_is_done_once_its_pads_are_off_the_object_not_when_the_fingers_reach_home():
    """robosuite's Rethink, its raspberry at 0.9x mass, the balanced preset, seed 1: held at 1.24x
    after a second probe, placed and let go, it was a ``timeout`` at 12 s, the fingers still
    opening from the 20 mm sphere to their 48 mm home (1.1 s).  The release ends once the fingers
    are past any squeeze of the pads' gel (multimode.clear_opening_m): a success, done with the
    pads off the sphere, short of home, and the fingers go on opening."""
    result = _robosuite_run("rethink", "raspberry-4g", "balanced", mass_x=0.9, seed=1)
    assert result.outcome == "success", result.reason
    assert result.summary["grip_margin"] <= 1.5
    data = result.data
    done = int(np.flatnonzero(data["phase"] == phase_index(Phase.DONE))[0])
    release = int(np.flatnonzero(data["phase"] == phase_index(Phase.RELEASE))[0])
    assert data["left_finger_force_n"][done] == data["right_finger_force_n"][done] == 0.0
    assert data["opening_m"][done] < data["opening_m"][0] - 0.01  # a centimetre short of home (where it began)
    assert data["opening_m"][-1] > data["opening_m"][done]  # and still opening
    assert data["time_s"][done] - data["time_s"][release] < 0.8


@pytest.mark.slow
@pytest.mark.parametrize(("obj", "friction_x", "mass_x", "was"), [("egg-60g", 1.1, 0.9, 1.85), ("rubber-ball-50g", 0.9, 0.9, 1.61)])
def test_the_pandas_curved_patches_are_held_within_one_and_a_half_at_accurate(obj, friction_x, mass_x, was):
    """robosuite's Panda at the accurate preset: the element reads the egg's and the rubber ball's
    patch 1.4-1.6x over its force, and the hold, held at the grip (in newtons) over the tolerance,
    let the contact creep back up after each pull: ``was`` x the need.  The tolerance's rule
    carried on past its top lets it creep down
    (test_past_its_tolerance_the_hold_lets_the_contact_creep_down_not_up_to_the_grip)."""
    result = _robosuite_run("panda", obj, "accurate", mass_x=mass_x, friction_x=friction_x)
    assert result.outcome == "success", result.reason
    assert result.summary["grip_margin"] <= 1.5


@pytest.mark.slow
def test_the_pandas_heavy_block_near_its_limit_is_carried_at_the_grips_cap():
    """robosuite's Panda on the 2 kg block at 1.1x mass and 0.9x friction (12 N of its 20 N), the
    accurate preset: lifted at 13 N, the block's load stayed while the grip grew 1.2x over the
    span, and the cap came before the safety factor the verdict waits for: "never lifted", off
    the table.  At the cap the span decides as it is: carried and held within 1.5x
    (tests/test_grip_economy.py::test_a_probe_at_its_cap_decides_on_the_span_it_has)."""
    result = _robosuite_run("panda", "block-2kg", "accurate", mass_x=1.1, friction_x=0.9)
    assert result.outcome == "success", result.reason
    assert result.summary["grip_margin"] <= 1.5


def _finger_force_at(result, time_s: float) -> float:
    data = result.data
    i = int(np.searchsorted(data["time_s"], time_s))
    return 0.5 * float(data["left_finger_force_n"][i] + data["right_finger_force_n"][i])


@pytest.mark.slow
@pytest.mark.parametrize("gripper", ["panda", "rethink"])
def test_a_friction_drives_touch_is_eased_down_before_the_lift(gripper):
    """At the balanced preset the envelope readout sees the touch's ramp tens of milliseconds late,
    and a drive with dry friction keeps the contact the touch left: robosuite's grippers left the
    3 g cube 2.5-3x the touch's bound, which the probe found it carried from (friction "at
    least" a third of the cube's) and held it at 1.7-3.8x its need.  The squeeze eases the
    contact down, paced on the fingers' joints, to between the floor and the bound before the
    lift (never below detection: a probe starting there misread the floor's scatter as the
    grip's change and called the box carried at a hundredth of its weight), and the probe
    measures the friction while the pads slide."""
    result = _robosuite_run(gripper, "cube-3g", "balanced")
    ease = [e for e in result.events if e["kind"] == "ease"]
    assert ease, [e["message"] for e in result.events]
    left_n = float(re.search(r"the touch left ([0-9.e-]+) N", ease[0]["message"]).group(1))
    bound_n = float(re.search(r"over its bound ([0-9.e-]+) N", ease[0]["message"]).group(1))
    floor_n = bound_n / 3.0  # TOUCH_FLOORS grip floors
    assert left_n > bound_n
    lift_s = next(e["time_s"] for e in result.events if e["kind"] == "phase" and e["message"].startswith("lift"))
    assert floor_n <= _finger_force_at(result, lift_s) <= bound_n
    assert result.outcome == "success", result.reason
    carried = next(e["message"] for e in result.events if e["kind"] == "carried")
    assert "measured while the pads slid" in carried, carried
    assert result.summary["grip_margin"] <= 1.5


def test_a_friction_drives_probe_reads_its_drive_once_its_friction_is_within_the_tolerance(controller):
    """While the probe closes the fingers, the contact lies in the friction's band under the
    drive's force, [D - F_f, D], read as its middle: within FEEL_TOLERANCE of the grip from
    F_f / (2 FEEL_TOLERANCE) + F_f / 2 on, where the probe reads the drive while the fingertips
    settle; a drive without friction is read alone anyway."""
    c, friction_n = controller, controller.robot.finger_friction_n
    threshold_n = 0.5 * friction_n / FEEL_TOLERANCE + 0.5 * friction_n
    assert not c._drive_reads_grip(0.999 * threshold_n) and c._drive_reads_grip(1.001 * threshold_n)
    c._fingertips_grip_n, c._fingertips_blind = (lambda: None), (lambda: True)  # a pad settling

    class Obs:
        grip_force_n = 2.0 * threshold_n

    assert c._grip_felt_n(Obs()) == pytest.approx(2.0 * threshold_n - 0.5 * friction_n)
    assert c._probe_sees(1.0, 2.0 * threshold_n, 0.03) and not c._probe_sees(1.0, 0.5 * threshold_n, 0.03)
    house = CoSimulation(scenarios.get("grasp")).controller
    assert not house._drive_reads_grip(50.0)


@pytest.mark.slow
def test_the_pandas_heavy_block_is_lifted_at_the_balanced_preset():
    """The catalogue's 2 kg block on robosuite's Panda at the balanced preset: the fingertips
    settle through most of the probe (the pressure ramping under them, four mode switches'
    ring-ups), and a probe that read only them grew the grip past the need
    unread, to the drive's 20 N limit, and never lifted the block.  Reading the drive past its
    friction's tolerance, it lifts it within 1.5x of its need."""
    result = _robosuite_run("panda", "block-2kg", "balanced")
    assert result.outcome == "success", result.reason
    assert result.summary["grip_margin"] <= 1.5


def test_a_pull_kept_while_blind_stops_where_the_joints_say_the_grip_is(controller):
    """A grip felt over its tolerance for ``persist`` readings is pulled down; the fingertips then
    blind (a pad settling on the falling pressure), the pull is kept only while the contact last
    felt, less the pads' contact stiffness times the opening since, is over the grip: kept on
    unseen, robosuite's Panda pulled its rubber ball's contact from 0.38 N to 0.18 N in 0.6 s of
    a pad settling, under the 0.33 N grip, and dropped it."""
    grip_n, felt_n = 4.0, 5.2  # past the friction's band (in it: test_a_contact_held_over_the_grip_in_the_band_is_pulled_open...)
    c, k = controller, _k(controller, felt_n)
    for i in range(c.cfg.persist + 1):
        _drive(c, felt_n, grip_n, t=10.0 + i * c.dt_s)
    assert c._moved_dir == -1  # pulling
    c._fingertips_grip_n, c._fingertips_blind = (lambda: None), (lambda: True)
    limit_n, opening_m = c._drive_for_grip(_At(0.5 * (felt_n - grip_n) / k), 10.1, grip_n)
    assert opening_m == c.robot.home_opening_m and c._moved_dir == -1  # the joints say over: pulled on
    limit_n, opening_m = c._drive_for_grip(_At(1.01 * (felt_n - grip_n) / k), 10.105, grip_n)
    assert opening_m == c.opening_target and limit_n >= grip_n and c._moved_dir == 0  # at the grip: held


def test_a_contact_held_over_the_grip_in_the_band_is_pulled_open_on_the_joints(controller):
    """A contact over the grip's tolerance for ``persist`` readings and inside the friction's band
    (felt - F_f under the grip: a light grip, where a pull from the grip down by a share of it a
    period moves nothing): the fingers are pulled open by half the excess over the pads' contact
    stiffness, read on their joints, at a paced pull (its force F_f / 8 at first, raised by half
    each period the fingers stand still), the slip watch waiting; it ends once the way left is
    within the run-on's EASE_LAG_PERIODS of the last period's motion, and the grip is held
    again until the next readings; a grip wanted that rises ends it at once."""
    c, k = controller, controller.contact_stiffness_n_m
    friction_n, grip_n, felt_n = controller.robot.finger_friction_n, 0.1, 0.2
    c._slip_watch_from_s = -math.inf
    drives = [_drive(c, felt_n, grip_n, t=10.0 + i * c.dt_s) for i in range(c.cfg.persist)]
    assert drives[-1] == (pytest.approx(felt_n - friction_n / 8), c.opening_target)  # the pull starts
    assert c._hold_pull.to_m == pytest.approx(_Obs.opening_m + 0.5 * (felt_n - grip_n) / k)
    assert c._slip_watch_from_s > 10.0
    limit_n, opening_m = c._drive_for_grip(_Obs(), 10.02, grip_n)  # standing still: pulled harder
    assert (limit_n, opening_m) == (pytest.approx(felt_n - friction_n * 1.5 / 8), c.opening_target)
    way_m = c._hold_pull.to_m - _Obs.opening_m
    c._drive_for_grip(_At(0.1 * way_m), 10.025, grip_n)  # a tenth of the way, read on the joints: on
    assert c._hold_pull is not None and c._moved_dir == -1
    c._drive_for_grip(_At(0.8 * way_m), 10.03, grip_n)  # the rest within the run-on of this motion: ended
    assert c._hold_pull is None and c._moved_dir == 0
    _drive(c, felt_n, grip_n, t=10.035)
    assert c._hold_pull is None  # the next readings decide (persist of them)
    for i in range(c.cfg.persist):
        _drive(c, felt_n, grip_n, t=10.04 + i * c.dt_s)
    assert c._hold_pull is not None
    limit_n, opening_m = _drive(c, felt_n, 1.5 * grip_n, t=10.1)  # the grip wanted rose: the pull is over
    assert c._hold_pull is None and c._moved_dir == 0 and (limit_n, opening_m) == (1.5 * grip_n, c.opening_target)


@pytest.mark.slow
def test_the_pandas_rubber_ball_is_eased_down_not_dropped_at_the_balanced_preset():
    """The 45 g rubber ball (the catalogue's 50 g at 0.9x) on robosuite's Panda at the balanced
    preset: the probe left its contact at 1.15x the grip, and the hold's pull, kept while a pad
    settled, opened the fingers until the ball fell.  Stopped where the joints say the contact
    is down to the grip, the ball is held, its grip never under its need through the hold.
    (How far over it: 1.5x, set by the friction the probe reads while the ball's pads slide,
    0.84 of its 1.2, and the hold's tolerance; docs/grippers.md.)"""
    result = _robosuite_run("panda", "rubber-ball-50g", "balanced", mass_x=0.9)
    assert result.outcome == "success", result.reason
    data = result.data
    held = np.asarray(data["phase"]) == phase_index("hold")
    grip = 0.5 * (data["left_finger_force_n"][held] + data["right_finger_force_n"][held])
    assert grip.min() >= result.summary["needed_grip_n"]


@pytest.mark.slow
def test_the_carried_bound_is_the_least_grip_since_the_pads_last_slid():
    """The 1.2 g tissue box (the catalogue's 1.1 g at 1.1x mass and friction) on robosuite's
    Rethink gripper at the balanced preset: the probe's first span saw the load reach the weight
    while the table let go of it (its last third not yet steady: "still sliding", started
    again), and the next span began a readout's blind stretch later, at 4x the grip that first
    carried the box.  Bounded by that span alone the friction read "at least 0.17" for 0.66 and
    the box was held at 4.9x its need; bounded by every sample since the pads last slid, the
    least grip that carried the weight, the friction is read within the safety factor of the
    object's, and the box is held within 1.5x (its contact, which the probe left at 4x the grip,
    eased down on the fingers' joints: test_a_contact_held_over_the_grip_in_the_friction_band_is_eased_open_on_the_joints)."""
    result = _robosuite_run("rethink", "tissue-box-1g", "balanced", mass_x=1.1, friction_x=1.1)
    assert result.outcome == "success", result.reason
    assert result.summary["grip_margin"] <= 1.5
    carried = next(e["message"] for e in result.events if e["kind"] == "carried")
    read = float(carried.split("friction at least ")[1].split(";")[0])
    assert read >= scenarios.OBJECTS["tissue-box-1g"].friction * 1.1 / 1.25, carried


@pytest.mark.slow
def test_a_grip_read_to_rise_while_the_fingers_stood_still_is_no_verdict():
    """The 500 g can on robosuite's Panda at the balanced preset, at the 1.1x-friction, 0.9x-mass
    variation of the gripper tables moved by 0.1 % (1.1011x, 0.9009x): the pads slid up the can at
    a constant 11 mN while the envelope readout, catching up with the contact's creep before the
    probe's span, read it rising 26 % with the fingers still (their opening changed by 1 um, the
    wrong way).  The load (the pads' sliding friction, 25 mN) stayed, so the span read "carried"
    at 0.6 % of the can's weight; the raise pulled the pads off it and it was never lifted.  A rise
    the fingers did not close for (the pads' loaded contact stiffness, twice over) is no verdict:
    the probe reads on, and the can is carried at its weight and held within 1.5x.  The drift's
    timing is on a knife's edge (at 0.9 x 1.001 in floating point, 1e-16 off 0.9009, the can is
    lifted without the rule): the rule itself is pinned by tests/test_grip_economy.py::
    test_a_grip_read_to_rise_counts_only_where_the_fingers_closed."""
    result = _robosuite_run("panda", "can-500g", "balanced", mass_x=0.9009, friction_x=1.1011)
    assert result.outcome == "success", result.reason
    weight_n = 0.9009 * scenarios.OBJECTS["can-500g"].mass_kg * 9.81
    carried = next(e["message"] for e in result.events if e["kind"] == "carried")
    load_n = float(re.search(r"load ([0-9.e-]+) N stayed", carried).group(1))
    assert load_n == pytest.approx(weight_n, rel=0.05), carried
    assert result.summary["grip_margin"] <= 1.5


@pytest.mark.slow
def test_a_pull_kept_while_blind_is_no_slip():
    """The 1.2 g tissue box (1.1x mass) on robosuite's Rethink gripper at the balanced preset: the
    probe left its contact at 2.7x the grip, and the hold pulled it down while the pads' readouts
    settled.  The slip watch, started while they were blind, took its reference on the way down
    and read the rest of the pull as a slip, raising the grip to 2.1x the need.  A pull, read
    or not, is no slip: no slip is answered and the box is held within 1.5x."""
    result = _robosuite_run("rethink", "tissue-box-1g", "balanced", mass_x=1.1)
    assert result.outcome == "success", result.reason
    assert not [e for e in result.events if e["kind"] == "slip"], [e["message"] for e in result.events if e["kind"] == "slip"]
    assert result.summary["grip_margin"] <= 1.5


@pytest.mark.slow
def test_a_contact_held_over_the_grip_in_the_friction_band_is_eased_open_on_the_joints():
    """The 2 g paper ball on robosuite's Rethink gripper at the balanced preset: the probe left
    its contact at 2.5x the grip wanted, and a pull from the grip down by a share of it a
    period moved nothing inside the drive's 1 N of friction: the contact crept down by itself
    and the ball was held at 1.9x its need.  Opened on the joints by half the excess at a
    time, paced, it is eased to the grip within the hold's first tenths of a second, and held
    within 1.5x; a pull is no slip (none answered)."""
    result = _robosuite_run("rethink", "paper-ball-2g", "balanced")
    assert result.outcome == "success", result.reason
    assert result.summary["grip_margin"] <= 1.5
    assert not [e for e in result.events if e["kind"] == "slip"]


@pytest.mark.slow
def test_the_pandas_egg_is_not_crept_up_through_a_blind_hold_at_the_accurate_preset():
    """robosuite's Panda, its 60 g egg at the accurate preset: a pad's readout settles for most of
    a second of the hold, and held at the grip wanted (the fingertips' reading, which over-reads the
    egg's patch 1.6x) the drive crept the contact up toward it in newtons, from 0.70 to 0.93 N, and
    the egg was held at 1.81x its need.  Its joints standing in for the fingertips, the hold keeps
    it within 1.5x, and the contact at the hold's end within 10 % of where the hold began."""
    result = _robosuite_run("panda", "egg-60g", "accurate")
    assert result.outcome == "success", result.reason
    assert result.grip_margin < 1.5
    data = result.data
    held = np.flatnonzero(np.asarray(data["phase"]) == phase_index("hold"))
    start, end = (_finger_force_at(result, float(data["time_s"][i])) for i in (held[0], held[-1]))
    assert end < 1.1 * start, (start, end)


def test_a_linkages_fingers_closing_as_the_grip_falls_are_braked_by_their_momentum_for_a_period():
    """_fall_brake_n: where the grip wanted falls while a linkage's fingers still close at v, the
    drive takes off their momentum on the opening within a period, m v / dt (m the fingers'
    inertia there), within the drive's rating; nothing where the grip did not fall or the
    fingers open or stand still.  Robotiq's 2F-85 (0.8 kg on the opening, 600 N/m of pads)
    otherwise carried the probe's closing into the 2 g wafer for 30 ms after its verdict, 1.50x
    -> 1.61x its need."""
    from types import SimpleNamespace

    robotiq = CoSimulation(scenarios.get("grasp", keys(_robotiq_2f85(), *ROBOTIQ_2F85), "fast")).controller
    dt, m = robotiq.dt_s, robotiq.robot.finger_mass_kg
    assert 0.5 < m < 1.5  # the linkage's inertia on the opening, kg

    def brake(fell: bool, from_m: float, to_m: float, periods: int = 1) -> float:
        robotiq._link_opening = (10.0, from_m)
        return robotiq._fall_brake_n(SimpleNamespace(opening_m=to_m, time_s=10.0 + periods * dt), fell)

    v = 3.5e-4  # m/s, the probe's closing on the wafer
    assert brake(True, 0.030, 0.030 - v * dt) == pytest.approx(m * v / dt, rel=1e-6)
    assert robotiq._link_opening == pytest.approx((10.0 + dt, 0.030 - v * dt))  # the next period's reference
    assert brake(True, 0.030, 0.030 - v * dt, periods=3) == 0.0  # an opening read periods ago is no speed
    assert brake(False, 0.030, 0.030 - v * dt) == 0.0  # the grip held or rose: no brake
    assert brake(True, 0.030, 0.030 + v * dt) == 0.0  # opening already
    assert brake(True, 0.030, 0.030) == 0.0  # standing still
    assert brake(True, math.nan, 0.030) == 0.0  # no last opening yet
    assert brake(True, 0.030, 0.020) == robotiq.robot.finger_force_limit_n  # within the rating


@pytest.mark.slow
def test_the_probes_verdict_stops_a_linkages_fingers_within_two_periods_of_its_rise():
    """Robotiq's 2F-85 on the 2 g wafer: after the probe's verdict lowers the drive, the contact
    rises no more than the probe's own rise over two control periods (the brake's period and the
    one it was read in): unbraked, the fingers' momentum pressed on for 30 ms, four periods'
    rise (0.0378 -> 0.0406 N, 1.50x -> 1.61x the wafer's need)."""
    from piezotip.reports.gripper_tables import WAFER

    overrides = {**keys(_robotiq_2f85(), *ROBOTIQ_2F85), **WAFER, "controller.kind": "gentle"}
    result = piezotip.run("grasp", overrides=overrides, preset="balanced")
    assert result.outcome == "success", result.reason
    data, t = result.data, result.data["time_s"]
    grip = 0.5 * (data["left_finger_force_n"] + data["right_finger_force_n"])
    verdict_s = next(e["time_s"] for e in result.events if e["kind"] == "carried")
    i = int(np.searchsorted(t, verdict_s))
    period_rise = grip[i] - grip[i - 1]
    assert period_rise > 0.0  # the probe was still pressing on
    after = grip[i : int(np.searchsorted(t, verdict_s + 0.1))]
    assert after.max() - grip[i] <= 2.0 * period_rise, (after.max(), grip[i], period_rise)


def test_the_raise_waits_until_the_carrys_grip_is_read_and_pushed_on(controller):
    """The carry's raise starts once every pad has read in the carry and no push is under way, or
    after the readout's longest window (blind that long, the joints' reckoning has to do)."""
    c, obs = controller, _Obs()
    obs.time_s = 10.0
    c._start_carry(obs)
    assert c._grip_not_on(10.0)  # nothing read yet
    _drive(c, 0.1, 0.1, t=10.005)  # read at the grip
    assert not c._grip_not_on(10.005)
    c._start_carry(obs)
    _drive(c, 0.05, 0.1, t=10.005)  # read short: pushed at a pace
    assert c._hold_pull.closing and c._grip_not_on(10.005)
    assert not c._grip_not_on(10.0 + c.ease_wait_s)  # waited the readout's longest window: the raise goes
    assert not CoSimulation(scenarios.get("grasp")).controller._grip_not_on(0.0)  # the house's drive is the grip: never waits


@pytest.mark.parametrize("falling", [False, True])
def test_a_let_down_whose_load_falls_as_its_wait_ends_is_not_carried(controller, falling):
    """The let-down's verdict, its wait over and the contact read: a load steady at the weight is
    carried; one falling in the window's last periods (robosuite's Rethink's raspberry slid back
    onto the table there, 0.035 -> 0.026 N, the window's mean still over half the weight) is no
    verdict yet, and once the window's mean is under half the weight the probe grows the grip
    from the contact left."""
    c, obs, weight_n = controller, _Obs(), 0.035
    n, carried = c.lift.plateau_steps, []
    c._carry = lambda obs, t, weight_n, *bounds: carried.append(t)
    c._fingertips_grip_n = lambda every_pad=True: (0.05, 1e-4)
    pull = c._start_pull(obs, 9.0, 0.06, 0.01, 0.001)
    c._let_down = LetDown(pull, weight_n, 0.06, loads=[weight_n] * 3 * n, pulled_s=9.5)
    loads = [weight_n * (1.0 - 0.08 * i) for i in range(1, 4 * n)] if falling else [weight_n] * 4 * n
    for i, load_n in enumerate(loads):
        c.lift.raw_load_n = load_n
        c._let_down_step(obs, 10.0 + i * c.dt_s)
        if c._let_down is None:
            break
    if falling:
        assert not carried and c.events[-1].kind == "let_down" and "the load fell" in c.events[-1].message
    else:
        assert carried == [10.0]


@pytest.mark.slow
@pytest.mark.parametrize(("friction_x", "mass_x", "seed"), [(1.1, 0.9, 0), (0.9, 0.9, 2)])
def test_the_rethinks_raspberry_lost_in_its_probe_is_regained_where_it_was_lost(friction_x, mass_x, seed):
    """robosuite's Rethink gripper lost its raspberry in the probe, the pads sliding up over the
    sphere with both readouts empty, and climbed on while the probe's drive grew blind: at 1.1x
    friction and 0.9x mass the fingers closed back on it at 140 mN/s, the readouts settling on the
    ramp, and it was held at 1.70x its need; at 0.9x both, noise seed 2, it was never lifted.  The
    lift now waits while no pad reads the object (GentleGrasp._contact_lost): 1.26x and 1.25x."""
    result = _robosuite_run("rethink", "raspberry-4g", "balanced", mass_x=mass_x, friction_x=friction_x, seed=seed)
    assert result.outcome == "success", result.reason
    assert result.grip_margin <= 1.5


def _robosuite_object_run(gripper: str, shape: str, mass_kg: float, size_m: float, friction: float, crush_n: float):
    """The gentle grasp at `balanced` of an object no catalogue names on one of robosuite's grippers."""
    file, tips, actuators = ROBOSUITE[gripper]
    obj = {"object.shape": shape, "object.mass_kg": mass_kg, "object.size_m": size_m, "object.friction": friction}
    overrides = {**keys(_robosuite_grippers() / file, tips, actuators), **obj, "object.crush_force_n": crush_n, "controller.kind": "gentle"}
    return piezotip.run("grasp", overrides=overrides, preset="balanced")


@pytest.mark.slow
@pytest.mark.parametrize(
    ("gripper", "mass_kg", "size_m", "friction", "crush_n"),
    [("panda", 0.72812, 0.0391, 0.998, 7.99), ("rethink", 0.4755, 0.036, 1.14, 5.58)],
)
def test_a_heavy_egg_is_not_closed_on_by_its_patch_reading(gripper, mass_kg, size_m, friction, crush_n):
    """Heavy eggs (18-20 g/cm^3, within the catalogue's densities; crushing at 2-2.3x their
    need) on robosuite's friction drives.  Held at the friction band's near edge about the
    patch's reading (1.25-1.6x the contact), or about the joints' stand-in reckoned on from it
    while blind, the drive stood past the band's far edge and the fingers closed on: the Panda
    took the 728 g egg from 5.4 N to 16.4 N in its hold, the Rethink the 475 g one to 12.6 N in
    its raise, both crushed.  Bounded by the drive's own force, neither is
    (GentleGrasp._band_contact_n)."""
    result = _robosuite_object_run(gripper, "egg", mass_kg, size_m, friction, crush_n)
    assert result.outcome == "success", result.reason
    assert result.summary["peak_contact_n"] < crush_n and result.grip_margin <= 1.6


@pytest.mark.slow
@pytest.mark.parametrize(
    ("shape", "mass_kg", "size_m", "friction", "crush_n"),
    [("cylinder", 0.01922, 0.0382, 0.704, 0.324), ("box", 0.006514, 0.0245, 0.305, 0.226), ("egg", 0.01437, 0.0403, 0.789, 0.178)],
)
def test_the_rethinks_light_objects_are_not_crushed_by_the_probes_creep(shape, mass_kg, size_m, friction, crush_n):
    """Light objects no test named (crushing at 2.1-2.4x their need) on robosuite's Rethink gripper:
    lifted at about their need, their contact crept on toward the probe's drive while the readouts
    settled on the ramp, and was 1.8-2.6x the need when the verdict read it: crushed.  The drive
    now comes down to the contact the joints say as the load turns steady
    (test_a_probe_blind_within_its_band_over_a_steady_load_stops_the_contact_where_it_is)."""
    result = _robosuite_object_run("rethink", shape, mass_kg, size_m, friction, crush_n)
    assert result.outcome == "success", result.reason
    assert result.grip_margin <= 1.5 and result.summary["peak_contact_n"] <= 1.5 * result.summary["needed_grip_n"]


@pytest.mark.slow
@pytest.mark.parametrize(("shape", "mass_kg", "size_m", "friction"), [("egg", 0.447905, 0.05006, 0.472), ("egg", 0.801517, 0.04627, 0.921)])
def test_the_pandas_heavy_round_objects_are_held_not_pulled_down_by_their_over_read(shape, mass_kg, size_m, friction):
    """Heavy round objects no test named on robosuite's Panda: their grip found on the drive's reading
    while the fingertips were blind, then read 1.36x over by the element on their patch, "too hard",
    pulled down by the over-read and dropped at 0.74-0.78x their need.  Read as the drive can press
    (test_a_reading_past_what_the_drive_can_press_is_read_as_the_drive_can), held within 1.5x."""
    result = _robosuite_object_run("panda", shape, mass_kg, size_m, friction, 1e3)
    assert result.outcome == "success", result.reason
    assert result.grip_margin <= 1.5
