"""The gentle grasp, the default controller: the multimode controller, finding the grip that
holds instead of assuming a friction (``controller.kind=gentle``).

:class:`GentleGrasp` is :class:`~.multimode.MultimodeGrasp` (the same touch, squeeze, mode
switching, hold, place and release) with another lift.  The multimode controller grips at
``grip_safety`` x load / (2 x ``friction_assumed``) and raises the grip by the safety factor at
every friction check that reads "still on the table": it holds an object of friction 1 with
1.6x the grip it needs, and 2-7x where its checks misread MuJoCo's creep.  The gentle one knows
neither mass nor friction and measures both:

- *the probe* (:meth:`GentleGrasp._transfer`): from the grip floor, the lift's goal rises at
  ``probe_speed_m_s``; while the lift follows it (the pads slide up the object, or the object is
  off the table) the grip grows exponentially, by ``grip_safety`` per plateau window; while the
  pads hold the object on the table the grip waits and the load grows.  Over each span in which
  the grip grew by ``grip_safety`` (:func:`probe_verdict`; or fell by it, on a drive with dry
  friction, whose contact creeps down from the touch's toward the lower command), a load that
  followed the grip is the pads' friction limit 2 mu G (the friction is measured there), and a
  load that stayed, and is steady (:func:`load_is_steady`), is the weight: the object is
  *carried*;
- the grip then drops to ``grip_safety`` x weight / (2 mu), the least that holds with the
  margin people keep (10-40 %, Johansson and Westling 1984), and is raised only on evidence of
  a slip (the multimode controller's slip checks, from the fingertips and the lift's load).

The grip the probe reads is the drive's (the house gripper's finger servo reads the squeeze
exactly); where the drive's joints carry dry friction, which takes up to that friction of the
drive's force either way once the fingers stand still (robosuite's Panda and Rethink grippers:
1 N a finger), the fingertips' readings are blended in by the inverse of the two variances
(:func:`grip_read_n`): the pads' pressure times their area is the grip, to the readout's sigma.

Its price: the pads slide up the object while the probe measures the friction (1-3 mm).  On
MuJoCo's hard pad contacts (``physics.pad_contact=hard``: mounted grippers) sliding pads chatter
(the element's pressure swings by 25-30 % at a 1 ms step), faster than the fingertip's resonator
follows, so "ok" readings taken during the probe can miss the pressure of the instant, and the
friction it reads is the stick-slip's, 10-15 % low; the house pads' ramped contacts slide
smoothly (models/README.md, "Sliding pads").
"""

from __future__ import annotations

import math

from piezotip.controllers import register
from piezotip.scenarios.config import GentleConfig

from .interface import Observation
from .lift import grip_for_load_n, load_is_steady, ratchet_grip_n
from .multimode import MultimodeGrasp
from .phases import Phase


def _thirds(span: list[tuple[float, float]]) -> tuple[int, float, float, float, float] | None:
    """(n, mean grip of the first n samples, of the last n, mean load of the first n, of the last
    n), N, with n a third of ``span``; None under two samples a third."""
    n = len(span) // 3
    if n < 2:
        return None
    first, last = span[:n], span[-n:]
    g1, g3 = (sum(g for g, _ in part) / n for part in (first, last))
    l1, l3 = (sum(load for _, load in part) / n for part in (first, last))
    return n, g1, g3, l1, l3


def _grew(g1: float, g3: float, safety: float, falls: bool = False) -> bool:
    """Whether the grip grew by ``safety`` from the first third to the last (or, with ``falls``,
    fell by it): enough to tell."""
    if g1 <= 0.0 or g3 <= 0.0:
        return False
    return max(g3 / g1, g1 / g3) >= safety if falls else g3 >= safety * g1


def probe_verdict(span: list[tuple[float, float]], safety: float, falls: bool = False) -> tuple[float, float, float, float]:
    """(elasticity d ln L / d ln G, its standard error, mean grip, mean load) of a probe's span of
    (grip applied, load) samples, N, from the means of its first and last thirds.

    While the pads slide the load is their friction limit 2 mu G, proportional to the grip
    (elasticity 1); once the object is off the table it is the weight, whatever the grip
    (elasticity 0).  The grip grows exponentially, so a load lagging it by a constant time is a
    constant factor of it and the ratio of the thirds' means is free of the lag.  With
    ``falls``, a grip that falls tells the same: the contact of a drive with dry friction creeps
    from the touch's leftover down toward a lower command (the Panda's, from 0.088 to 0.055 N in
    0.7 s, with the fingertips reading it); a drive without friction applies the command, which
    the probe only raises, and a reading of it that falls is the drive settling, not the contact
    (the 2F-85's linkage read 0.011 then 0.008 N while its pads slid up a can at an unchanged
    load).  The error comes from the scatter of the loads within each third (stick-slip at
    milli-newton grips): infinite until the grip has changed by ``safety`` over the span (too
    short to tell)."""
    thirds = _thirds(span)
    if thirds is None:
        return 0.0, math.inf, 0.0, 0.0
    n, g1, g3, l1, l3 = thirds
    first, last = span[:n], span[-n:]
    g_mean = sum(g for g, _ in span) / len(span)
    l_mean = sum(load for _, load in span) / len(span)
    if not _grew(g1, g3, safety, falls) or l1 <= 0.0 or l3 <= 0.0:
        return 0.0, math.inf, g_mean, l_mean
    growth = math.log(g3 / g1)
    var1 = sum((load - l1) ** 2 for _, load in first) / (n - 1)
    var3 = sum((load - l3) ** 2 for _, load in last) / (n - 1)
    error = math.sqrt(var1 / (n * l1 * l1) + var3 / (n * l3 * l3)) / abs(growth)
    return math.log(l3 / l1) / growth, error, g_mean, l_mean


def carried_nothing_at_first(span: list[tuple[float, float]], safety: float, falls: bool = False) -> bool:
    """Whether a probe's span of (grip applied, load) samples, N, long enough for a verdict (its
    last third's mean grip ``safety`` times its first third's, or with ``falls`` a ``safety``-th
    of it: :func:`probe_verdict`), carried nothing over its first
    third: that third's mean load is not positive, so no ratio of loads can be read over it.

    The load is the lift's, zeroed (tared) on one reading as the lift phase begins; where the
    squeeze still rings in the gripper then, the load starts below zero (Robotiq's 2F-85 on a
    60 g egg: the tare caught +0.13 N of a linkage's ringing, gone 20 ms later, so the load
    read -0.13 N until the egg rose), and a span anchored there never reaches a verdict,
    however far the grip grows: the probe squeezed the egg to 43 N, past its 25 N."""
    thirds = _thirds(span)
    if thirds is None:
        return False
    _, g1, g3, l1, _ = thirds
    return _grew(g1, g3, safety, falls) and l1 <= 0.0


def grip_read_n(drive_n: float, drive_error_n: float, felt_n: float | None, felt_sigma_n: float) -> float:
    """The grip on each finger, N: the drive's reading ``drive_n`` and the fingertips'
    ``felt_n`` weighted by the inverse of their variances, ``drive_error_n`` and
    ``felt_sigma_n`` (N) squared; the drive's alone where its error is 0 or the fingertips have
    no reading (``felt_n`` None), the fingertips' alone where their sigma is 0."""
    if drive_error_n <= 0.0 or felt_n is None:
        return drive_n
    if felt_sigma_n <= 0.0:
        return felt_n
    w_drive, w_felt = drive_error_n**-2, felt_sigma_n**-2
    return (w_drive * drive_n + w_felt * felt_n) / (w_drive + w_felt)


@register("gentle", config=GentleConfig, experiment=True, senses=True)
class GentleGrasp(MultimodeGrasp):
    """The multimode controller with the friction probe (the module docstring): the same
    parameters, and the probe's (:class:`~scenarios.config.GentleConfig`: ``friction_max`` and
    ``probe_speed_m_s``).  Built as the multimode one is (its self-test first)."""

    shut_check_in_transfer = True

    def __init__(self, *args, **kwargs) -> None:
        super().__init__(*args, **kwargs)
        c, robot, dt_s = self.cfg, self.robot, self.dt_s
        #: The pad-object friction: measured while the pads slide in the probe (_transfer); until
        #: then the highest expected, so the first grip is the gentlest.
        self.friction = c.friction_max
        self._slid = False  # the probe has seen the pads slide (self.friction is measured)
        self._grip_goal_n = 0.0  # the grip the raise brings the probe's down to, N (_carry)
        self._span: list[tuple[float, float]] = []  # (grip applied, raw load) since the last verdict
        self._weight_n = 0.0  # the object's weight, N: the load the probe found carried
        #: The grip's growth rate while the pads may slide, 1/s: by the safety factor in one
        #: plateau window, the time the load takes to show it (so the grip overshoots the one
        #: that holds by at most that factor before the probe sees the load stay).
        self.grip_growth_per_s = math.log(c.grip_safety) / (self.lift.plateau_steps * dt_s)
        #: Whether the probe's grip can fall: a drive with dry friction holds the touch's contact
        #: above the probe's lower command, and it creeps down to it (probe_verdict's ``falls``).
        self.contact_falls = robot.finger_friction_n > 0.0
        #: The share of a carried object's load that the lift's own acceleration during the probe
        #: can change, -: the goal's speed grows with the sag 2 mu_max G / kp that the grip's
        #: growth adds, at most at 2 mu_max r (grip rate) / kp per second, over g.  A load that
        #: scatters more is pads sticking and slipping, not a weight (load_is_steady).
        self.steady_load_fraction = (
            2.0 * c.friction_max * self.grip_growth_per_s * self.grip_rate_n_s / (robot.lift_kp_n_m * robot.gravity_m_s2)
        )
        # The probe gives up after twice the time the grip needs to grow from the floor to its
        # cap (exponentially, then at the grip rate) and the goal to rise by the lift height.
        knee_n = min(self.grip_cap_n, max(self.grip_floor_n, self.grip_rate_n_s / self.grip_growth_per_s))
        ramp_s = math.log(knee_n / self.grip_floor_n) / self.grip_growth_per_s + (self.grip_cap_n - knee_n) / self.grip_rate_n_s
        self.transfer_timeout_s = 2.0 * (ramp_s + c.lift_height_m / c.lift_speed_m_s)

    def _lift_message(self) -> str:
        return f"grip {self.grip_n:.3g} N: probing for the grip that holds"

    def _grip_felt_n(self, obs: Observation) -> float:
        """The grip the probe reads, N per finger (:func:`grip_read_n`): the drive's, within its
        joints' dry friction F_f (``RobotLimits.finger_friction_n``: standing still, the friction
        takes up to F_f of the drive's force either way, and robosuite's Panda carries 1 N a
        finger where a 4 g raspberry needs 22 mN), and the fingertips' (each pad's trusted "ok"
        estimate times the pad's area, a full-face contact, within its readout's sigma; their
        mean).  A drive without friction is read alone: the house gripper's, exactly."""
        friction_n = self.robot.finger_friction_n
        felt = self._fingertips_grip_n() if friction_n > 0.0 else None
        if felt is None:
            return obs.grip_force_n
        return grip_read_n(obs.grip_force_n, friction_n, *felt)

    def _fingertips_grip_n(self) -> tuple[float, float] | None:
        """The grip the fingertips read, N per finger, and its sigma: each pad's trusted "ok"
        estimate times the pad's area (a full-face contact), their mean; None unless every pad
        has one."""
        area, felt_n, variance = self.robot.pad_area_m2, 0.0, 0.0
        for pad in self.pads:
            sel = self.selectors[pad]
            if not (sel.trusted and sel.status == "ok" and math.isfinite(sel.uncertainty_pa)):
                return None
            felt_n += sel.estimate_pa * area
            variance += (sel.uncertainty_pa * area) ** 2
        n = len(self.pads)
        return felt_n / n, math.sqrt(variance) / n

    def _transfer(self, obs: Observation, t: float, dt_s: float) -> None:
        """Find the grip that holds, then hand the weight to it (the module docstring's probe).

        Each period, over the plateau window: if the pads rise (they slide up the object, or the
        object is off the table; their height is the lift's plus a linkage's arc,
        :meth:`RobotLimits.pads_height_m`, as each squeeze swings them down it), the grip grows
        by ``grip_growth_per_s`` and the verdict below runs; if they do not (they hold the object
        on the table), the grip holds and the load grows with the goal until the pads slide or
        the object leaves."""
        c, lift = self.cfg, self.lift
        if t - self._t_phase > self.transfer_timeout_s:
            self._give_up(t, "never_lifted", f"the load transfer did not finish in {self.transfer_timeout_s:.2g} s", Phase.PLACE)
            return
        applied = max(self._grip_felt_n(obs), 0.0)
        window_full = lift.record(applied, self.robot.pads_height_m(obs.lift_pos_m, obs.opening_m))
        rising = window_full and lift.risen_m() >= 0.5 * c.probe_speed_m_s * (lift.plateau_steps - 1) * dt_s
        growth_n_s = 0.0
        if rising:
            if self.grip_n >= self.grip_cap_n:
                self._pads_slide_at_cap(t, lift.raw_load_n)
                return
            growth_n_s = min(self.grip_growth_per_s * self.grip_n, self.grip_rate_n_s)
            self.grip_n = min(self.grip_cap_n, self.grip_n + growth_n_s * dt_s)
        # The goal rises at the probe's pace, plus the sag that the grip's growth adds to a lift
        # whose pads slide (2 mu G / kp), at the friction measured so far (the highest expected
        # until then): the lift keeps rising while the pads slide, and the pads slide up the
        # object at about the probe's pace, not faster.
        lift.climb(c.probe_speed_m_s + 2.0 * self.friction * growth_n_s / self.robot.lift_kp_n_m, dt_s)
        if not rising:
            self._span = []  # held on the table: the load grows, the grip waits
            return
        self._span.append((applied, lift.raw_load_n))
        falls = self.contact_falls
        elasticity, error, grip_n, load_n = probe_verdict(self._span, c.grip_safety, falls)
        if math.isinf(error):
            if carried_nothing_at_first(self._span, c.grip_safety, falls):
                self._span = self._span[-1:]  # the span starts again where the pads carry a load
            return  # the grip has not grown enough over the span to tell
        if load_n <= self.robot.min_load_n:
            self._span = self._span[-1:]
            return  # nothing carried yet: no evidence either way
        # Decided when the elasticity's 2-sigma interval lies on one side of 1/2 (the load's
        # stick-slip scatter at milli-newton grips needs a longer span than a clean slide), or
        # once the span has changed the grip by the safety factor three times over.
        first_n = self._span[0][0]
        low_n, high_n = sorted((first_n, applied)) if falls else (first_n, applied)
        if abs(elasticity - 0.5) < 2.0 * error and high_n < c.grip_safety**3 * low_n:
            return
        # The least grip that carried it bounds the friction best (the last on a falling span).
        carried_from_n = min(g for g, _ in self._span) if falls else first_n
        last = [load for _, load in self._span[-(len(self._span) // 3) :]]
        self._span = [self._span[-1]]
        if elasticity >= 0.5:
            # The load grew with the grip: the pads slide at their friction limit, 2 mu G.  The
            # load is the lift servo's force less the gripper's inertia (RobotLimits.lift_load_n),
            # so a sliding load reaches it without lag.  (A factor e^(-r kv/kp) for the servo's lag
            # was divided out here while the hard pad contacts stuck and slipped: it made up for
            # their 10-15 % lower mean friction, and read the smooth slide 9-18 % high.)
            # Past the highest friction the pads can have, the reading is the grip's error, not
            # the object's (a mounted drive reads light grips through its levers, up to 2x off).
            self.friction, self._slid = min(load_n / (2.0 * grip_n), c.friction_max), True
            return
        if not load_is_steady(last, self.steady_load_fraction):
            # The load did not follow the grip, but it is not a weight either: it scatters as
            # pads that stick and slip do (at milli-newton grips they chatter on the object,
            # and the friction follows the touches, not the drive).  Still sliding.
            return
        # The weight is the load found steady, the last third's: the plateau window can still
        # hold the stick-slip before it (the Panda's 270 g jar read 2.14 N of its 2.65 N there).
        self._carry(obs, t, sum(last) / len(last), carried_from_n, grip_n)

    def _carry(self, obs: Observation, t: float, weight_n: float, carried_from_n: float, carried_mean_n: float) -> None:
        """The load stayed while the grip changed: the object is off the table, its weight the
        load (``weight_n``, the probe's span's last third's, found steady).  The grip that holds
        it is the weight over the friction measured while the pads slid; never seen sliding, it
        was carried at the span's least grip (its
        friction at least load / 2 G there; where the grip that asks is past the cap,
        ``carried_mean_n``, the span's mean grip, bounds the friction measured while sliding
        likewise).

        Fingers that coast past a control period (:attr:`brakes`) are brought down to that grip
        at ``grip_rate_n_s`` over the raise (:meth:`_raise`), not in one step: the 2F-85's,
        dropped from 22 to 5 N at once, sprang 3.8 mm open on their 0.74 kg and let a 270 g jar
        fall back to the table."""
        c = self.cfg
        if not self._slid:
            self.friction = min(weight_n / (2.0 * carried_from_n), c.friction_max)
        held_n = max(self.grip_floor_n, c.grip_safety * weight_n / (2.0 * self.friction))
        if self._slid and held_n > self.grip_cap_n:
            # Before giving up for a grip past the cap: carried over the span, the friction is at
            # least load / 2 G at its mean grip, which the one measured while the pads slid must
            # meet (their stick-slip reads it low: the Panda's 2.2 kg block, friction 0.9, slid
            # at a measured 0.50, and the grip asked was past the rating).  Only then: a bound
            # on a light grip is only as good as the drive's reading of it (the 2F-85's reads
            # 0.012 N of a 0.02 N grip on the paper ball, and the bound made its 0.5 a 0.65).
            self.friction = max(self.friction, min(weight_n / (2.0 * carried_mean_n), c.friction_max))
            held_n = max(self.grip_floor_n, c.grip_safety * weight_n / (2.0 * self.friction))
        if self._over_cap(t, held_n, weight_n, carried=True):
            return
        self._grip_goal_n = min(held_n, self.grip_cap_n)
        if not self.brakes or self._grip_goal_n > self.grip_n:  # up at once; down over the raise
            self.grip_n = self._grip_goal_n
        self.lift.goal_m = obs.lift_pos_m  # the raise feeds the sag forward from where the lift is
        self.lift.load_n = self._weight_n = weight_n
        self.raising = True
        self._start_carry(obs)
        how = f"friction {self.friction:.3g} measured while the pads slid" if self._slid else f"friction at least {self.friction:.3g}"
        self._event(t, "carried", f"load {weight_n:.3g} N stayed while the grip changed: carried; {how}; grip {self._grip_goal_n:.3g} N")

    def _start_carry(self, obs: Observation) -> None:
        """The raise begins.  The fingertips' slip references are taken once the grip the probe
        has just set has settled on the pads, six load-filter time constants on (the settling
        the hold gives the lift's load): a grip lowered to the one that holds is not a slip."""
        self.lift.speed_m_s = 0.0
        self._slip_watch_from_s = obs.time_s + 6.0 * self.cfg.load_filter_s
        self._reference_pa = {}

    def _slip(self, t: float, why: str, deficit: float = 1.0) -> None:
        super()._slip(t, why, deficit)
        self._grip_goal_n = self.grip_n  # a slip's answer is the grip the raise keeps

    def _raise(self, obs: Observation, t: float, dt_s: float) -> None:
        lift = self.lift
        if self.grip_n > self._grip_goal_n:
            self.grip_n = max(self._grip_goal_n, self.grip_n - self.grip_rate_n_s * dt_s)
            # A grip coming down is no slip: the fingertips' slip references wait for it to settle.
            self._slip_watch_from_s = t + 6.0 * self.cfg.load_filter_s
            self._reference_pa = {}
        lift.rise(self.cfg.lift_speed_m_s, dt_s)
        # The grip stays where the probe set it (raised only by a slip): the load the lift reads
        # while it speeds up and brakes is mostly the gripper's own inertia, not the object's.
        lift.target_m = lift.servo_target(self._weight_n, lift.speed_m_s)
        if lift.arrived_at_top(obs.lift_pos_m, obs.lift_vel_m_s):
            lift.held_load_n = self._weight_n
            self._enter(Phase.HOLD, t, f"carrying {self._weight_n:.3g} N with {self.grip_n:.3g} N of grip")

    def _follow_load(self, t: float, dt_s: float) -> None:
        """The grip is the probe's, raised by a slip, and in the hold by a load change: once the
        lift has settled (six load-filter time constants: its braking forgotten, the load the
        object's), a load read this period (unfiltered: an extra load along the pads uses the
        grip's margin within a few periods, before a filtered load shows it) that has used half
        the grip's margin, grown past the held weight by sqrt(grip_safety), is followed: safety
        x load / 2 mu at the probe's friction, never down.  Elsewhere not: while the lift moves,
        brakes and settles its load is the gripper's inertia as much as the object's weight.
        Without it an extra load along the pads (``grasp-disturb``: the box's weight again)
        leaves their pressure as it was, and the box slid out before the lift's slip check
        answered."""
        lift = self.lift
        if self.phase is not Phase.HOLD or t - self._t_phase < 6.0 * self.cfg.load_filter_s:
            return
        load_n = max(lift.raw_load_n, lift.load_n)
        if load_n > math.sqrt(self.cfg.grip_safety) * lift.held_load_n:
            wanted = grip_for_load_n(load_n, self.friction, self.cfg.grip_safety, self.grip_floor_n)
            if not self._over_cap(t, wanted, load_n, carried=True):
                self.grip_n = ratchet_grip_n(self.grip_n, wanted, self.grip_cap_n, self.grip_rate_n_s, dt_s)


__all__ = ["GentleGrasp", "carried_nothing_at_first", "grip_read_n", "load_is_steady", "probe_verdict"]
