"""The multimode grasp controller: feel a touch of a few pascals, carry what the grip allows.

It reads only the fingertip readouts and the robot's own joints (:class:`Observation`) and
knows only the robot's design (:class:`RobotLimits`); every number it uses is a field of
:class:`~cosim.control.config.MultimodeConfig` with its derivation, or derived here from the
fingertip's ranges and the robot's limits.  Registered as ``controller.kind=multimode``.

Phases (:class:`Phase`), one method each::

    approach -> close -> squeeze -> lift -> hold -> place -> release -> done
                                  (any of them may give up with a reason, then put down / open)

- approach: learn each fingertip's unloaded baseline; refuse to grasp if the self-test failed.
- close: close at ``closing_speed_m_s`` with the force the fingers need to move (a guard, not
  a grip) until a CUSUM on the most sensitive mode detects touch on both fingertips.  Fingers
  whose joints' damping does not stop them within a control period once the force drops (their
  mass on the opening over that damping, ``RobotLimits``) are braked for one period first
  (:meth:`MultimodeGrasp._brake_n`): their momentum would press the object on.
- squeeze: settle at the grip floor: the gentlest grip whose pad pressure the lowest mode
  resolves to 10 % (:func:`grip_floor_n`).  A fingertip reading nothing there was alarmed by
  something else (a false touch): close on; but fingers that cannot close, twice felt by no
  fingertip, touch the object off the pads (``unfelt_contact``: give up).
- lift, in three stages.  *Transfer*: the lift goal rises only as far as the grip can carry
  at the assumed friction, and the grip follows the load the lift feels (grip = safety x
  load / (2 mu)), so the weight moves from the table onto the pads.  When the load stops
  growing with the goal, the object has left the table *or* the pads are sliding on it (the
  load then sits at the friction limit 2 mu grip): a *friction check* raises the grip by the
  safety factor and watches whether the load follows it (on a drive with dry friction, the
  pads' grip as the fingertips read it, which the drive's force reaches only past its
  friction: a check whose change did not reach them says nothing).  If it does, the pads were
  sliding: the friction measured there replaces the assumption and the transfer goes on.
  If not, the object is *carried*: raise it at ``lift_speed_m_s`` (ramped), the servo's sag
  under the load compensated (the robot knows its gain).
- hold: hold for ``hold_s``, watching for slip and loss.
- place: lower (fast, then at ``touchdown_speed_m_s`` over the last stopping distance), the
  sag offset kept, until the lift feels the table take the weight; then stop there.
- release: grip back to the floor, open at ``opening_speed_m_s`` (speeding up and braking at the
  fingers' acceleration, also into home after ``done``).

Slip and loss while carried: a fingertip's trusted pressure estimate falling by more than
``slip_pressure_drop`` (and 3 sigma), or the load the lift feels falling by more than the lift's
own acceleration can explain, is a slip: the grip rises by the safety factor, within what the
fingertip can measure and ``max_grip_n`` allows.  Both fingertips reading no load for
``lost_s``, or the fingers shut past the object's width for ``lost_s`` with no fingertip
reading a load, is a loss.  Give-ups (``no_object``, ``unfelt_contact``, ``never_lifted``, ``blind``,
``lost``) and faults (``self_test``, ``out_of_range``) are events with their time and reason;
after a give-up the controller puts down what it still holds and opens, instead of running out
the clock.

The phases decide; the lift's side of them (its goal and speed profile, the servo's target with
the sag fed forward, the load it reads, the plateau window, the held load's bookkeeping) is
:class:`~.lift.LiftPlan`'s, in lift.py, with the grip that follows the load.
"""

from __future__ import annotations

import math
from operator import attrgetter
from typing import TYPE_CHECKING

import numpy as np

from piezotip.cosim.control.config import MultimodeConfig
from piezotip.sensor import Fingertip
from piezotip.sensor.cache import disk_cached

from ._control import make_command
from .interface import Command, Event, Observation, RobotLimits, Why, pad_names
from .lift import LiftPlan, grip_for_load_n, load_is_steady, ratchet_grip_n
from .phases import FINISHED, Phase
from .registry import register
from .selector import ModeSelector, TouchDetector

if TYPE_CHECKING:  # annotations only: the scenario's config is above the controllers
    from piezotip.cosim.config import ScenarioConfig


def trapezoid_speed(distance_m: float, speed_m_s: float, top_speed_m_s: float, accel_m_s2: float, dt_s: float) -> float:
    """The next speed of a trapezoidal move toward a stop ``distance_m`` ahead, m/s: from
    ``speed_m_s`` up at ``accel_m_s2`` to ``top_speed_m_s``, braking at ``accel_m_s2`` so as to
    stop there; 0 once there.  Speeds are magnitudes (m/s), dt_s the step (s), the position
    advanced by the new speed times dt_s.  The braking speed is discrete time's: stepping down
    by a dt from v covers v^2 / (2 a) + v dt / 2, so v = sqrt((a dt / 2)^2 + 2 a d) - a dt / 2
    (the continuous v = sqrt(2 a d) would arrive with speed to spare and stop in one step)."""
    if distance_m <= 0.0:
        return 0.0
    half_step = 0.5 * accel_m_s2 * dt_s
    wanted = min(top_speed_m_s, math.sqrt(half_step * half_step + 2.0 * accel_m_s2 * distance_m) - half_step)
    return min(wanted, speed_m_s + accel_m_s2 * dt_s) if speed_m_s < wanted else max(wanted, speed_m_s - accel_m_s2 * dt_s)


#: Resolution that counts as "measured": physics.md section 5's P_max criterion, dP <= 10 % P.
RESOLVED_FRACTION = 0.1


def clear_opening_m(touch_width_m: float, release_opening_m: float, pad_travel_m: float) -> float:
    """The opening past which both pads are off the object, m (inf where no touch was felt).

    As the release begins, the object between the pads is no wider than the opening then plus
    both gels' travel (the most each compresses before its housing stops it, ``pad_travel_m``):
    whatever grip squeezed them, pads that have opened that far have let their gel's surface off
    it.  Nor is it narrower than where the pads first touched it (no squeeze), which bounds the
    opening from below where the object turned in the grip to a narrower face.
    """
    if math.isnan(touch_width_m):
        return math.inf
    return max(touch_width_m, release_opening_m + 2.0 * pad_travel_m)


def settling_remainder_n(rise_n: float, last_rise_n: float) -> float:
    """What a force that rose by ``last_rise_n`` then ``rise_n`` (N, over two periods) has still
    to rise if each period's rise keeps the ratio r = rise / last rise (a first-order settling):
    rise r / (1 - r), the geometric series' tail, N.  Infinite for a rise that does not shrink
    (r >= 1); the rise itself where there is no ratio (a first rise, none, or one of the other
    sign: a ring about the value)."""
    if rise_n == 0.0 or not math.isfinite(last_rise_n) or last_rise_n == 0.0:
        return abs(rise_n)
    ratio = rise_n / last_rise_n
    if ratio <= 0.0:
        return abs(rise_n)
    if ratio >= 1.0:
        return math.inf
    return abs(rise_n) * ratio / (1.0 - ratio)


def grip_floor_n(fingertip: Fingertip, mode: int, pad_area_m2: float, resolved_fraction: float = RESOLVED_FRACTION) -> float:
    """The gentlest grip the fingertip measures, N: the lowest pressure that ``mode`` resolves to
    ``resolved_fraction`` of itself (dP(P) <= f P, physics.md section 5), over the pad's face.

    A full-face contact is assumed (pressure = force / pad area); a smaller contact presses
    harder on the element, so it is measured at least as well.
    """
    return resolved_floor_pa(fingertip, mode, resolved_fraction) * pad_area_m2


def resolved_floor_pa(fingertip: Fingertip, mode: int, resolved_fraction: float = RESOLVED_FRACTION) -> float:
    """The lowest pressure ``mode`` resolves to ``resolved_fraction`` of itself, Pa (on a 400-point
    log grid over [P_min, P_max]); kept in the disk cache, keyed by the fingertip's configuration."""

    def compute() -> dict[str, np.ndarray]:
        p_min, p_max = fingertip.detection_limit(mode), fingertip.upper_limit(mode)
        if not (math.isfinite(p_min) and math.isfinite(p_max) and p_max > p_min):
            return {"floor_pa": np.array(math.nan), "p_min_pa": np.array(p_min), "p_max_pa": np.array(p_max)}
        grid = np.geomspace(p_min, p_max, 400)
        ok = np.nonzero(fingertip.resolution(grid, mode) <= resolved_fraction * grid)[0]
        return {"floor_pa": np.array(grid[ok[0]]), "p_min_pa": np.array(p_min), "p_max_pa": np.array(p_max)}

    numbers = disk_cached("resolved-floor", (fingertip.config_key(), mode, float(resolved_fraction)), compute, extra_modules=[__file__])
    if not math.isfinite(numbers["floor_pa"]):
        p_min, p_max = float(numbers["p_min_pa"]), float(numbers["p_max_pa"])
        raise ValueError(f"mode {mode} has no measurable range (P_min {p_min!r} Pa, P_max {p_max!r} Pa)")
    return float(numbers["floor_pa"])


#: The phases in which the lift may carry the object.
_CARRYING = (Phase.LIFT, Phase.HOLD, Phase.PLACE)
_EMPTY = attrgetter("empty")  # all(map(_EMPTY, ...)): no generator made and closed each step


def element_self_test(config: ScenarioConfig, fingertip: Fingertip) -> str | None:
    """None if the element of ``config``'s scenario passes its start-up self-test in the
    controller's modes, else the self-test's message: the element as built (its unit, as warm as
    it is, and its injected damage), not the model the readout is calibrated with (``fingertip``)."""
    from piezotip.sensor.configured import physical_unit
    from piezotip.sensor.selftest import damaged, self_test

    s = config.sensor
    unit = physical_unit(s)
    element = unit.physical.fingertip_at(s.temperature_c).element if unit is not None else fingertip.element
    physical = damaged(element, s.damage_stiffness, s.damage_coupling, s.damage_damping)
    modes = config.controller.modes
    report = self_test(physical, healthy=fingertip.element, modes=modes, noise=fingertip.noise, rng=np.random.default_rng(s.seed))
    return None if report.passed else report.message


@register("multimode", config=MultimodeConfig, experiment=True, senses=True)
class MultimodeGrasp:
    """The multimode grasp controller (module docstring).

    Parameters
    ----------
    config : MultimodeConfig (``modes`` restricts the modes: ``[1]`` is a single-mode baseline).
    robot : the gripper's limits and home targets, read from the model.
    pads : instrumented pad names.
    fingertip : the fingertip model the readout is calibrated with.
    self_test_message : None if the element's self-test passed, else its message (the
        controller then refuses to grasp).
    dt_s : the control period, s.
    """

    #: Whether the grip, once the object is carried, is closed on what the fingertips feel rather
    #: than commanded to the drive (the gentle controller's, on a drive with dry friction).
    grips_on_fingertips = False
    #: Whether the drive, once the object is carried, is set for the grip the pads hold rather
    #: than given it (:meth:`_drive_for_grip`: the gentle controller's, on a drive whose force the
    #: pads do not feel: dry friction, a linkage's arc).
    sets_drive_for_pads = False

    #: Whether the fingers shut past the object's width count as a loss during the transfer too
    #: (not only once carried): the gentle probe grows the grip while the lift rises, which
    #: closes fingers that hold nothing.
    shut_check_in_transfer = False

    @classmethod
    def from_scenario(cls, config: ScenarioConfig, robot: RobotLimits, fingertip: Fingertip) -> MultimodeGrasp:
        """The controller of ``config``'s scenario, after the element's self-test (:func:`element_self_test`)."""
        message = element_self_test(config, fingertip)
        return cls(config.controller, robot, pad_names(config.sensor.pads), fingertip, message, config.physics.control_period_s)

    def __init__(
        self,
        config: MultimodeConfig,
        robot: RobotLimits,
        pads: tuple[str, ...],
        fingertip: Fingertip,
        self_test_message: str | None = None,
        dt_s: float = 0.005,
    ) -> None:
        self.cfg = c = config
        self.robot = robot
        self.pads = pads
        self.dt_s = dt_s
        self.selectors = {pad: ModeSelector(fingertip, c.modes, c.hysteresis, c.persist) for pad in pads}
        lowest, highest = min(c.modes), max(c.modes)
        sigma = fingertip.sigma(lowest)
        self.touch = {pad: TouchDetector(sigma, c.cusum_drift_sigma, c.cusum_alarm_sigma, c.touch_single_sigma) for pad in pads}
        # Per pad, its selector and the readings it takes as in range, [0, 1] widened by
        # out_of_range_sigma of the lowest mode's sigma (V_1 units): the element is faulty outside.
        bound = c.out_of_range_sigma
        self._reading_bounds = {pad: (self.selectors[pad], -bound * sigma, 1 + bound * sigma) for pad in pads}
        sel = self.selectors[pads[0]]
        area = robot.pad_area_m2
        #: The most grip whose pressure the fingertip still measures, N per finger.
        self.measurable_grip_n = c.measurable_share * sel.p_max_pa[highest] * area
        #: The most grip the robot and the task allow, N per finger.
        self.max_grip_n = min(robot.finger_force_limit_n, c.max_grip_n if c.max_grip_n is not None else math.inf)
        self.grip_cap_n = min(self.max_grip_n, self.measurable_grip_n)
        self.grip_floor_n = c.grip_floor_n if c.grip_floor_n is not None else grip_floor_n(sel.fingertip, lowest, area)
        self.grip_floor_n = min(self.grip_floor_n, self.grip_cap_n)
        #: Grip ramp rate, N/s: by default the finger drive's whole force range in one second.
        self.grip_rate_n_s = c.grip_rate_n_s if c.grip_rate_n_s is not None else robot.finger_force_limit_n
        #: The fingers' force limit while they move freely: what their drive's damping and its
        #: joints' dry friction need at the commanded speed, x 1.5 (a guard: a touch before it is
        #: detected meets no more; the house gripper's joints have no friction, a mounted one's
        #: may, and a force on the damping alone leaves them too little past it to keep pace:
        #: tests/test_third_party_grippers.py::test_the_pandas_fingers_close_at_the_commanded_pace_against_their_dry_friction).
        moving = c.drive_margin * (robot.finger_damping_n_s_m * c.closing_speed_m_s + robot.finger_friction_n)
        self.moving_force_n = min(robot.finger_force_limit_n, max(self.grip_floor_n, moving))
        opening = c.drive_margin * (robot.finger_damping_n_s_m * c.opening_speed_m_s + robot.finger_friction_n)
        self.opening_force_n = min(robot.finger_force_limit_n, opening)
        #: The fingers' acceleration, m/s^2: the element feels its own pad's inertia (rho h0 a
        #: on its face), so they speed up slowly enough that it stays under half the lowest
        #: mode's detection limit, unseen (a faster start reads as a touch).
        self.finger_accel_m_s2 = 0.5 * sel.p_min_pa[lowest] / robot.pad_areal_mass_kg_m2
        #: Whether the fingers coast on past a touch by more than they close in a control period
        #: once the drive's force drops to the grip floor: their joints' damping alone stops
        #: them in m_o / c_j (the servo's velocity gain is inside its force, which the floor
        #: caps), longer than the period for heavy fingers or a mounted drive's armature.  Such
        #: fingers are braked (_brake_n; tests/test_third_party_grippers.py::
        #: test_fingers_that_coast_past_a_control_period_are_braked_at_the_touch and
        #: test_the_pandas_and_the_2f85s_fingers_coast_past_a_control_period_and_are_braked).
        self.brakes = robot.finger_mass_kg > robot.finger_joint_damping_n_s_m * dt_s
        #: Whether the lift's acceleration moves the fingers (RobotLimits.lift_coupling_kg: a
        #: linkage's), which the grip then makes up for while the lift carries the object.
        self.lift_opens = bool(robot.lift_coupling_kg[0])
        self._braking = False  # the period after a touch: the fingers are being stopped
        self._finger_speed = 0.0
        #: The closing's pace now, m/s of opening: the speed the fingers close toward, and at which
        #: the joints learn the drive's free force (``closing_speed_m_s``; gentle.py slows it).
        self._pace_m_s = c.closing_speed_m_s
        #: What the pads' own inertia takes off each fingertip's reading this period (V_1 units),
        #: given back to the touch detector: none here (the fingers speed up slowly enough that
        #: a reading or two does not show it); the gentle controller's longer speed-up is read.
        self._pad_inertia_v1 = 0.0
        self._opening_speed = 0.0  # of the opening target on release, m/s
        # The drive's force while the fingers close freely at pace (learned, as the fingertips'
        # baselines are), and the force in the last period: see _joint_touch.
        self._free_drive_n: float | None = None
        self._joints_felt_touch = False  # the last touch was the joints', not the fingertips'
        self._last_drive_n = math.nan
        self._last_rise_n = math.nan  # the drive's force's change over the last period, N
        #: The load transfer gives up after twice the time the grip needs to ramp to its cap
        #: and the goal to rise by the lift height at lift speed.
        self.transfer_timeout_s = 2.0 * (self.grip_cap_n / self.grip_rate_n_s + c.lift_height_m / c.lift_speed_m_s)
        #: The lift's goal, speed, servo target and load (lift.py); the phases here say when it moves.
        self.lift = LiftPlan(robot, robot.home_lift_m + c.lift_height_m, c.lift_accel_m_s2, c.load_filter_s, dt_s)
        #: The grip's growth per period while pads that read nothing are closed on (the squeeze's
        #: pads let go at the floor, the transfer's sprung back off): the safety factor per
        #: plateau window.
        self.close_on_factor = c.grip_safety ** (1.0 / self.lift.plateau_steps)
        self.phase = Phase.APPROACH
        #: The lift's stage: False while the weight moves onto the pads (the transfer and its
        #: friction checks), True once the object is carried and raised.  A bool, as ``faulted``
        #: is: the per-step path tests them instead of comparing enum members, which on Python
        #: 3.11 pass EnumType's __getattr__ hook (0.1 us, ten times the rest of a comparison).
        self.raising = False
        self.faulted = False  # the phase is FAULT (set by _fault alone, which nothing leaves)
        self.events: list[Event] = []
        self.gave_up: str | None = None
        self.touch_time_s = math.nan
        self.friction = c.friction_assumed  # assumed, never estimated (see _transfer)
        self._sliding_ratio = c.friction_assumed
        self._t_phase = 0.0
        self.opening_target = robot.home_opening_m
        self.grip_n = self.moving_force_n
        self._check: tuple[float, float, float] | None = None  # (t0, G0, L0)
        self._check_pace = 0.0
        self._check_felt: tuple[float, float] | None = None  # the fingertips' grip as the check began (_pads_grip_gain)
        self._reference_pa: dict[str, float] = {}
        self._empty_s = 0.0
        self._off_s = 0.0  # how long both pads have read nothing while the weight moves onto them
        self._shut_s = 0.0  # how long the fingers have been shut past the object, no fingertip reading it
        self._last_slip_s = -math.inf
        self._width_m = math.nan
        self._released_from_n = math.nan  # the grip as the release began, N (_release)
        self._clear_opening_m = math.nan  # the opening past which the pads are off the object, m (_release)
        self._saturated_logged: set[str] = set()
        self._unfelt_opening_m: float | None = None  # the opening at the last false touch felt by no fingertip
        self._felt_in_squeeze: set[str] = set()  # the pads with a trusted "ok" reading since the touch
        self._last_opening_m = math.inf  # the fingers' opening at the last closing step, m
        self._slip_watch_from_s = 0.0  # the fingertips' slip check starts then (gentle.py delays it)
        if self_test_message is not None:
            self._fault(0.0, "", "self_test", self_test_message)

    # -- bookkeeping -----------------------------------------------------------------------

    @property
    def finished(self) -> bool:
        return self.phase in FINISHED

    def _event(self, t: float, kind: str, message: str, pad: str = "") -> None:
        self.events.append(Event(t, pad, kind, message))

    def _enter(self, phase: Phase, t: float, why: str = "") -> None:
        self.phase, self._t_phase = phase, t
        self._event(t, "phase", f"{phase.label}: {why}" if why else phase.label)

    def _fault(self, t: float, pad: str, kind: str, message: str) -> None:
        self._event(t, kind, message, pad)
        self.phase, self.faulted = Phase.FAULT, True
        self.gave_up = self.gave_up or kind

    def _give_up(self, t: float, kind: str, message: str, then: Phase) -> None:
        """Stop trying, say why, and put down / open (``then``) instead of running out the clock."""
        self.gave_up = kind
        self._event(t, kind, message)
        self._enter(then, t, f"giving up ({kind})")

    def pressure_estimate(self) -> dict[str, float]:
        """Each fingertip's last trusted pressure estimate, Pa."""
        return {pad: sel.estimate_pa for pad, sel in self.selectors.items()}

    # -- one step ----------------------------------------------------------------------

    def step(self, obs: Observation, dt_s: float) -> Command:
        t = obs.time_s
        self.dt_s = dt_s
        modes, reasons = self._read_fingertips(obs, t)
        lift = self.lift
        if self.faulted:
            # Refused or faulted: hold still with the fingers open (nothing was grasped) or
            # as they are, never squeezing.
            return make_command(lift.target_m, self.opening_target, self.opening_force_n, modes, self.phase, self.events[-1].message)
        lift.read_load(obs.lift_pos_m, obs.lift_vel_m_s, dt_s)
        _HANDLERS[self.phase](self, obs, t, dt_s)
        grip_n = self.grip_n
        if self.lift_opens and self.raising and self.phase in _CARRYING:
            # What the lift's acceleration pulls the fingers open by (a linkage's pads rise as
            # they open: braking at the top opens them) is added to the grip, and what it
            # pushes them closed by, speeding up, is taken off it (never under the grip's
            # floor): left on, the raise's push pressed Robotiq's 2F-85s' 2 g wafer from the
            # carried 1.5x its need to 1.7x (tests/test_third_party_grippers.py::
            # test_an_object_crushing_at_one_and_a_half_times_its_need_survives_the_probe).
            # Slides never feel it.  Once carried: the probe's lift barely accelerates, and its
            # grip is what the probe reads the friction by.
            grip_n = max(self.grip_floor_n, grip_n + self.robot.lift_opens_n(obs.opening_m, lift.measured_accel_m_s2))
        if self.sets_drive_for_pads and self.raising and self.phase in _CARRYING:
            # The grip closed on what the fingertips feel (gentle.py): the drive's force and its
            # direction that bring the pads' grip to grip_n.
            limit_n, opening_m = self._drive_for_grip(obs, t, grip_n)
            return make_command(lift.target_m, opening_m, limit_n, modes, self.phase, Why.join(reasons))
        return make_command(lift.target_m, self.opening_target, grip_n, modes, self.phase, Why.join(reasons))

    def _drive_for_grip(self, obs: Observation, t: float, grip_n: float) -> tuple[float, float]:
        """The drive's force limit (N) and opening target (m) that bring the pads' grip to
        ``grip_n`` (:attr:`sets_drive_for_pads`): here the drive's force is the grip."""
        return grip_n, self.opening_target

    def _read_fingertips(self, obs: Observation, t: float) -> tuple[dict[str, int], list]:
        """Check each reading's range and choose each fingertip's next mode."""
        modes, reasons = {}, []
        for pad, sig in obs.pads.items():
            sel, low, high = self._reading_bounds[pad]
            reading = sig.reading
            v1 = reading.v1
            if not (low <= v1 <= high) and not self.faulted:
                bound = self.cfg.out_of_range_sigma
                self._fault(t, pad, "out_of_range", f"{pad}: reading {v1!r} outside [0, 1] by more than {bound:g} sigma")
            mode, why = sel.update(sig.estimate)
            if mode != reading.mode:
                self._event(t, "mode_switch", str(why), pad)
            if sel.blind and pad not in self._saturated_logged:
                self._saturated_logged.add(pad)
                self._event(t, "saturated", str(why), pad)
            modes[pad] = mode
            reasons.append((pad, why))
        return modes, reasons

    # -- phases ------------------------------------------------------------------------

    def _approach(self, obs: Observation, t: float, dt_s: float) -> None:
        for pad, sig in obs.pads.items():
            self.touch[pad].learn(sig.reading.v1)
        if t >= self.cfg.baseline_s:
            self.grip_n = self.moving_force_n
            self._enter(Phase.CLOSE, t)

    def _close_step(self, obs: Observation, dt_s: float) -> None:
        """Move the closing's target on by a period: at ``closing_speed_m_s`` all the way, speeding
        up at the fingers' acceleration (the gentle controller slows down near where a camera saw
        the object, gentle.py)."""
        self._finger_speed = min(self.cfg.closing_speed_m_s, self._finger_speed + self.finger_accel_m_s2 * dt_s)
        self.opening_target = max(0.0, self.opening_target - self._finger_speed * dt_s)

    def _touch_cues(self, obs: Observation) -> tuple[list[bool], str]:
        """Each pad's touch cue this period, and what gave them: the CUSUM on the lowest mode's
        reading, with the press of the pad's own gel as the fingers speed up taken off."""
        inertia_v1 = self._pad_inertia_v1
        return [self.touch[pad].update(obs.pads[pad].reading.v1 + inertia_v1) for pad in self.pads], "CUSUM"

    def _close(self, obs: Observation, t: float, dt_s: float) -> None:
        self._close_step(obs, dt_s)
        touched, cue = self._touch_cues(obs)
        felt_by_joints = self._joint_touch(obs.grip_force_n)
        if all(touched) or felt_by_joints:
            self.touch_time_s = t
            self._width_m = obs.opening_m  # the object's width: the pads barely pressed yet
            self._cap_at_width(t, obs.opening_m)
            self.opening_target = 0.0  # squeeze at the force limit
            self.grip_n = self.grip_floor_n
            brake_n = self._brake_n(obs.opening_m, dt_s)
            if brake_n > 0.0:
                self.opening_target, self.grip_n, self._braking = self.robot.home_opening_m, brake_n, True
            self._free_drive_n = None
            self._felt_in_squeeze = set()
            self._joints_felt_touch = not all(touched)
            how = f"on {', '.join(self.pads)} ({cue})" if all(touched) else f"felt by the joints ({felt_by_joints})"
            self._enter(Phase.SQUEEZE, t, f"touch {how}; grip floor {self.grip_floor_n:.3g} N")
        else:
            self.lift.note_free_load()  # nothing touched yet: the lift carries the gripper alone
            if self.opening_target <= 0.0:
                if obs.opening_m < 0.002:
                    self._give_up(t, "no_object", "closed without feeling a touch", Phase.RELEASE)
                elif self._last_opening_m - obs.opening_m < 0.5 * self._pace_m_s * dt_s:
                    # Told to close all the way, the fingers stand still (under half a period's free
                    # travel) wide of it, and the fingertips did not both feel a touch: a finger
                    # touches the object off its pad, and pushing on would only run out the clock.
                    self._give_up(
                        t,
                        "unfelt_contact",
                        f"the fingers stopped at {obs.opening_m * 1e3:.1f} mm without a touch felt on both fingertips: "
                        "a finger touches the object off its sensing pad",
                        Phase.RELEASE,
                    )
        self._last_opening_m = obs.opening_m

    def _joint_touch(self, drive_n: float) -> str:
        """Whether the fingers' drive, closing at pace, meets a resistance the fingertips have
        not reported: a message saying so, or "".

        The drive's force at a steady closing speed is constant (its damping at that speed);
        it is learned once it stops changing by more than the grip floor per period, as the
        lowest it has been since.  A rise over it by more than the grip floor (the gentlest
        grip a fingertip resolves, on its coverage) is a contact the joints feel first: on a
        pad beside the element's coverage, which the gel brings to the element weakened
        (sensor/spread.py), or on a resonator still ringing up.  Closing on until the
        fingertips felt it would press on at the pace's force, a period at a time.
        """
        last, self._last_drive_n = self._last_drive_n, drive_n
        rise, last_rise = drive_n - last, self._last_rise_n
        self._last_rise_n = rise
        if self._finger_speed != self._pace_m_s:  # still speeding up (or slowing down) to the pace
            self._free_drive_n = None
            return ""
        free, floor = self._free_drive_n, self.grip_floor_n
        if free is None:
            # Learned once settled: the rise this period under the floor, and what a rise that
            # shrinks by a constant ratio each period (a servo settling exponentially) has still
            # to add under it too: a drive with dry friction creeps up to its pace, and the rest
            # of such a rise is no contact (tests/test_third_party_grippers.py::
            # test_fingers_with_dry_friction_feel_the_touch_on_the_fingertips).
            if abs(rise) < floor and settling_remainder_n(rise, last_rise) < floor:
                self._free_drive_n = drive_n
            return ""
        return self._against_free_drive(drive_n)

    def _against_free_drive(self, drive_n: float) -> str:
        """Once the drive's free force is learned: a contact where ``drive_n`` (N) rises over it by
        more than the grip floor (a message saying so), else "" and the free force follows the
        drive down (the lowest it has been)."""
        free = self._free_drive_n
        if drive_n - free > self.grip_floor_n:
            return f"the drive needs {drive_n:.3g} N against its free {free:.3g} N"
        self._free_drive_n = min(free, drive_n)
        return ""

    def _brake_n(self, opening_m: float, dt_s: float) -> float:
        """The force that stops fingers closing at the pace of the last period within the next
        one, N per finger: m_o o' / T (their mass on the opening, RobotLimits.finger_mass_kg),
        within their rating; 0 where they do not need it (:attr:`brakes`).

        The touch is felt in the period the pads meet the object; fingers that then coast on
        for m_o / c_j press it by their momentum, not by the grip the controller asks.  Braked,
        the drive pulls the fingers back with this force (its opening target the open
        fingers') for one period, then squeezes at the grip floor.  One period only: held on
        for longer (up to m_o / c_j) the brake's force acts on fingers it has already stopped
        (tests/test_third_party_grippers.py::test_the_pandas_touch_leaves_the_paper_ball_whole
        and test_robotiqs_touch_leaves_the_paper_ball_whole)."""
        if not self.brakes:
            return 0.0
        speed_m_s = max(self._last_opening_m - opening_m, 0.0) / dt_s
        if not math.isfinite(speed_m_s):
            return 0.0
        return min(self.robot.finger_force_limit_n, self.robot.finger_mass_kg * speed_m_s / dt_s)

    def _squeeze(self, obs: Observation, t: float, dt_s: float) -> None:
        if self._braking:  # the fingers stopped: squeeze at the grip floor
            self.opening_target, self.grip_n, self._braking = 0.0, self.grip_floor_n, False
        self._felt_in_squeeze.update(pad for pad, sel in self.selectors.items() if sel.trusted and sel.status == "ok")
        if t - self._t_phase < self.cfg.squeeze_settle_s or self._squeeze_eases(obs, t):
            return
        # A touch leaves the floor's pressure on the pads; a fingertip that reads nothing was
        # alarmed by something else (its own pad's inertia as the fingers jerk): close on.
        empty = [pad for pad, sel in self.selectors.items() if sel.trusted and sel.status == "below_detection"]
        if empty and self._felt_in_squeeze.issuperset(empty):
            # Each of them read the object's pressure since the touch: no alarm, but pads that
            # the grip floor lets go (a linkage's springs push its pads back off a light object,
            # under the floor's pressure).  Closing on at the moving force would press and spring
            # back again; the grip grows instead, by the safety factor per plateau window, until
            # they read it (tests/test_third_party_grippers.py::
            # test_robotiqs_pads_that_let_go_at_the_grip_floor_are_squeezed_not_closed_on).
            if self.grip_n >= self.grip_cap_n:
                self._give_up(
                    t,
                    "unfelt_contact",
                    f"{', '.join(empty)} read the object after the touch, then nothing even at the grip cap "
                    f"({self.grip_cap_n:.3g} N): the object is no longer between the pads' elements",
                    Phase.RELEASE,
                )
                return
            self.grip_n = min(self.grip_cap_n, self.grip_n * self.close_on_factor)
            return
        if empty:
            # Closing on is for fingers that are free.  If every fingertip read nothing here and
            # at the last false touch, and the fingers have not closed since by what one control
            # period of free closing at the pace covers, something they do not feel blocks them (an object
            # touching the guards below or above the pads): closing on would loop forever.
            unfelt = len(empty) == len(self.pads)
            previous, self._unfelt_opening_m = self._unfelt_opening_m, obs.opening_m if unfelt else None
            if unfelt and self._joints_felt_touch:
                # The joints felt the contact that stopped the closing, and no fingertip reads it
                # at the grip floor: closing on would press it at the pace's force, unfelt.
                self._give_up(
                    t,
                    "unfelt_contact",
                    f"the joints felt a contact at {obs.opening_m * 1e3:.1f} mm that no fingertip reads at the grip floor: "
                    "the object touches the pads away from the element's gel coverage",
                    Phase.RELEASE,
                )
                return
            if unfelt and previous is not None and previous - obs.opening_m < self._pace_m_s * dt_s:
                self._give_up(
                    t,
                    "unfelt_contact",
                    f"the fingers stopped at {obs.opening_m * 1e3:.1f} mm twice with no pressure on any fingertip: "
                    "they touch the object off the sensing pads",
                    Phase.RELEASE,
                )
                return
            for pad in self.pads:
                self.touch[pad].rearm_unloaded()  # the fingertips read nothing: the closing's readings were unloaded
            self.opening_target, self._finger_speed = obs.opening_m, 0.0
            self.grip_n = self.moving_force_n
            self._event(t, "false_touch", f"{', '.join(empty)} read no pressure at the grip floor: closing on")
            self._enter(Phase.CLOSE, t)
            return
        self.lift.tare()  # what the lift carries before lifting is not the object's
        self._enter(Phase.LIFT, t, self._lift_message())

    def _squeeze_eases(self, obs: Observation, t: float) -> bool:
        """Whether the squeeze goes on easing the touch's contact down before the lift (a drive
        whose dry friction holds it: gentle.py); never here, where the drive's force is the grip."""
        return False

    def _rested_lift_m(self) -> float:
        """The lift's height at which the object it carries rested on the table, m: where the lift
        was as the fingers touched it (its home); the gentle controller's pads slide up the
        object before it leaves the table, and it lands that much higher (gentle.py)."""
        return self.robot.home_lift_m

    def _lift_message(self) -> str:
        """What the lift phase's event says it starts from."""
        return f"grip {self.grip_n:.3g} N, assumed friction {self.friction:g}"

    def _lift(self, obs: Observation, t: float, dt_s: float) -> None:
        raising = self.raising
        if self._carried_checks(obs, t, raising):
            return
        if raising:
            self._raise(obs, t, dt_s)
        else:
            self._transfer(obs, t, dt_s)

    def _transfer(self, obs: Observation, t: float, dt_s: float) -> None:
        """Move the weight onto the pads: the goal rises only as far as the grip carries."""
        c, lift = self.cfg, self.lift
        load = max(lift.raw_load_n, 0.0)
        if t - self._t_phase > self.transfer_timeout_s:
            self._give_up(t, "never_lifted", f"the load transfer did not finish in {self.transfer_timeout_s:.2g} s", Phase.PLACE)
            return
        if self._over_cap(t, c.grip_safety * load / (2.0 * self.friction), load, carried=False):
            return
        # The grip follows the load at the friction assumed or, once a check has seen the load
        # follow the grip, at the load-to-grip ratio seen then: while the pads slide that ratio
        # is the friction, and the grip grows until the pads hold.  (Where MuJoCo's soft
        # friction crept at a tiny grip the ratio is low, and the grip carries more margin.)
        wanted = grip_for_load_n(load, self._sliding_ratio, c.grip_safety, self.grip_floor_n)
        if self._check is not None:
            wanted = max(wanted, c.grip_safety * self._check[1])
        if all(map(_EMPTY, self.selectors.values())):
            self._off_s += dt_s
            if self._lasted_lost_s(self._off_s):
                # Both pads have read nothing for lost_s: they are off the object (a linkage's
                # spring back from the touch against the grip floor), so no load can come.  The
                # grip closes them on by the safety factor per plateau window until one reads.
                wanted = max(wanted, self.grip_n * self.close_on_factor)
        else:
            self._off_s = 0.0
        self.grip_n = ratchet_grip_n(self.grip_n, wanted, self.grip_cap_n, self.grip_rate_n_s, dt_s)
        # The goal rises at the speed at which the load it adds on a held object (kp per metre)
        # needs grip no faster than the grip can rise, and only while the grip the fingers
        # apply (their drive lags the command) can carry the load at the friction assumed.
        applied = max(obs.grip_force_n, 0.0)
        carry = 2.0 * self.friction * applied - load
        speed = lift.transfer_speed_m_s(c.lift_speed_m_s, self.grip_rate_n_s, self.friction, c.grip_safety)
        lift.climb(speed if carry > 0 else 0.0, dt_s)
        # While the pads hold the object on the table the lift cannot follow its goal (the
        # load grows by kp per metre of goal instead); pads that follow it carry the object in
        # the air, or slide up it at the friction limit.  The pads', not the lift's: a
        # linkage's squeeze swings them down their arc, and the lift rises over them.
        follows = lift.record(lift.goal_m, self.robot.pads_height_m(obs.lift_pos_m, obs.opening_m)) and lift.follows()
        if self._check is None:
            if follows and applied > 0.0:
                self._check = (t, applied, lift.window_load_n())
                self._check_pace = lift.pace()
                self._check_felt = self._fingertips_grip_n()
            return
        t0, g0, l0 = self._check
        risen = self._grip_risen(g0, applied)
        grip_gain = self._pads_grip_gain(g0, applied) if risen else None
        window_load = lift.window_load_n()
        if grip_gain is not None and math.copysign(1.0, grip_gain) * (window_load - l0 * (1.0 + 0.5 * grip_gain)) > 0.0:
            # The load followed the grip by half its gain or more (sliding pads' load is 2 mu
            # times their grip, whichever way it changes; on a friction drive the pads' grip may
            # fall while the drive's rises: _pads_grip_gain): the object still rests on the
            # table, held or sliding.  The grip keeps the raise (a ratchet), so every check that
            # finds the object on the table leaves the grip higher by the safety factor: a friction below
            # the one assumed is met in a few checks, without estimating it (MuJoCo's soft
            # friction creeps below the limit, so a slide cannot be told from a hold here).
            self._event(t, "on_table", f"load {load:.3g} N followed the grip ({g0:.3g} -> {applied:.3g} N): still on the table")
            if self._check_pace >= self.cfg.sliding_pace:
                self._sliding_ratio = min(self._sliding_ratio, max(l0, 1e-12) / (2.0 * self._pads_grip_n(g0)))
            self._check = None
            lift.window.clear()
            if self.grip_n >= self.grip_cap_n:
                self._pads_slide_at_cap(t, l0)
        elif risen and t - t0 >= self._check_window_s(g0) and follows and window_load >= self.robot.min_load_n:
            if grip_gain is None:
                # No verdict: the drive's force rose, but the pads' grip did not change (fingers
                # that their joints' dry friction holds still), so a load that did not follow
                # it tells nothing.  Checked again from here, the grip up by the safety factor,
                # until the change reaches the pads (_pads_grip_gain).
                self._check = None
                lift.window.clear()
                return
            if not self._window_load_is_steady(speed):
                # Neither: the load did not follow the drive's reading, and it is no weight's:
                # pads sliding at a grip the reading does not show (fingers that the drive's dry
                # friction holds still), or whose load creeps below their friction limit.  Checked
                # again from here, the grip up by the safety factor (_window_load_is_steady).
                self._check = None
                lift.window.clear()
                return
            self._check = None
            self.raising = True
            self._start_carry(obs)
            self._event(t, "carried", f"load {load:.3g} N does not follow the grip ({g0:.3g} -> {applied:.3g} N): the object is carried")

    def _grip_risen(self, g0: float, applied: float) -> bool:
        """Whether the friction check's grip, ``g0`` as it began, has risen enough to tell by:
        the drive's reading ``applied`` (N) half the safety factor's rise over it, or the grip at
        its cap."""
        return applied / g0 - 1.0 >= 0.5 * (self.cfg.grip_safety - 1.0) or self.grip_n >= self.grip_cap_n

    def _pads_grip_gain(self, g0: float, applied: float) -> float | None:
        """The pads' grip's gain over the friction check, -, that their load must follow, up or
        down, if they slide (it is 2 mu times their grip); None where the check's change of the
        drive's force has not reached the pads, and a load that did not follow it tells nothing.

        A drive without dry friction applies its force to the pads (the house gripper's,
        exactly): the drive's reading's gain, ``applied`` over ``g0`` (N), less 1.  One whose
        joints carry dry friction F_f (``RobotLimits.finger_friction_n``) holds its fingers
        still while its force changes by less than the friction takes, up to F_f either way,
        and MuJoCo's soft friction lets the contact creep toward it: its reading is the pads'
        grip only to within F_f.  Robosuite's Panda on the 330 g jar, on the compliant pad
        contact: the drive's 0.091 -> 0.115 N against its 1 N of friction, the pads' 0.128 ->
        0.126 N, sliding up the jar under a steady load that did not follow the drive's gain:
        "carried", and lost.  On the 2 g paper ball (the hard contact) the pads' grip crept
        down from the touch's 0.118 N to 0.094 N over five checks while the drive rose 0.021 ->
        0.083 N.  The fingertips read the pads' grip: the gain is theirs, where their grip
        changed by more than 3 sigma of their readings (a ratio, so a contact smaller than the
        pad's face reads it right).  Where a fingertip has no trusted reading the drive's gain
        counts only once its rise is past the band's width, 2 F_f: then it moved the fingers
        whatever the friction held before (tests/test_third_party_grippers.py::
        test_the_pandas_friction_check_reads_the_pads_grip_on_the_fingertips and
        test_the_pandas_friction_check_follows_the_pads_grip_down)."""
        drive_gain = applied / g0 - 1.0
        friction_n = self.robot.finger_friction_n
        if friction_n <= 0.0:
            return drive_gain
        before, now = self._check_felt, self._fingertips_grip_n()
        if before is None or now is None or not before[0] > 0.0:
            return drive_gain if applied - g0 > 2.0 * friction_n else None
        rise_n = now[0] - before[0]
        return rise_n / before[0] if abs(rise_n) > 3.0 * math.hypot(before[1], now[1]) else None

    def _pads_grip_n(self, g0: float) -> float:
        """The pads' grip as the friction check began, N per finger, that the load's ratio to it
        is read over: the drive's force ``g0`` on a drive without dry friction, the fingertips'
        reading on one with it, whose force is the pads' only to within its friction
        (:meth:`_pads_grip_gain`).  Robosuite's Panda on the 60 g egg (friction 0.6, the
        compliant pad contact): over the 17 checks that found it on the table the load over the
        drive's grip fell from 0.50 to 0.20 as the drive rose to 1.3 N against the pads' 0.58 N,
        over the pads' it stayed at 0.44-0.48, the friction the pads slid at; taken over the
        drive's the egg was held at 3.6 N of grip (7.4x its need), over the pads' at 1.7 N
        (3.5x).  The drive's where a fingertip had no trusted reading."""
        felt = self._check_felt if self.robot.finger_friction_n > 0.0 else None
        return g0 if felt is None or felt[0] <= 0.0 else felt[0]

    def _fingertips_grip_n(self, every_pad: bool = True) -> tuple[float, float] | None:
        """The grip the fingertips read, N per finger, and its sigma: each pad's trusted "ok"
        estimate times the pad's area (a full-face contact), their mean; None unless every pad
        has one (``every_pad``), or, without it, unless one has (the object presses both pads
        alike: their mean is of those that read)."""
        felt_n, variance, n = 0.0, 0.0, 0
        for pad in self.pads:
            reading = self._pad_grip_n(pad)
            if reading is None:
                if every_pad:
                    return None
                continue
            felt_n += reading[0]
            variance += reading[1] ** 2
            n += 1
        if n == 0:
            return None
        return felt_n / n, math.sqrt(variance) / n

    def _pad_grip_n(self, pad: str) -> tuple[float, float] | None:
        """One pad's reading of the grip, N, and its sigma: its trusted "ok" estimate times the
        pad's area (a full-face contact); None where it has none this period."""
        sel, area = self.selectors[pad], self.robot.pad_area_m2
        if not (sel.trusted and sel.status == "ok" and math.isfinite(sel.uncertainty_pa)):
            return None
        return sel.estimate_pa * area, sel.uncertainty_pa * area

    def _window_load_is_steady(self, speed_m_s: float) -> bool:
        """Whether the window's load is a weight's.  A load that did not follow the grip's
        reading may still be pads sliding: at an unchanged grip, on a drive whose dry friction
        (``finger_friction_n``) holds its fingers still while its force changes by less, or at a
        load that creeps below their friction limit (MuJoCo's soft friction).  A carried object's
        load changes only with the lift's acceleration, at most the transfer speed ``speed_m_s``
        over the servo's time constant kv / kp, as a share of g; sliding pads stick and slip far
        more (:func:`load_is_steady`; tests/test_third_party_grippers.py::
        test_the_pandas_friction_check_tells_sliding_pads_from_a_weight and
        test_robotiqs_friction_check_needs_a_steady_load_to_call_it_carried)."""
        robot = self.robot
        fraction = speed_m_s * robot.lift_kp_n_m / (robot.lift_kv_n_s_m * robot.gravity_m_s2)
        return load_is_steady([entry[2] for entry in self.lift.window], fraction)

    def _check_window_s(self, g0: float) -> float:
        """How long the friction check waits: the grip's ramp by the safety factor, then three of
        the lift servo's time constants (kv / kp) for the load to answer."""
        ramp = (self.cfg.grip_safety - 1.0) * g0 / self.grip_rate_n_s
        return ramp + 3.0 * self.robot.lift_kv_n_s_m / self.robot.lift_kp_n_m

    def _start_carry(self, obs: Observation) -> None:
        self.lift.speed_m_s = 0.0
        self._reference_pa = {pad: sel.estimate_pa for pad, sel in self.selectors.items() if sel.status == "ok"}

    def _raise(self, obs: Observation, t: float, dt_s: float) -> None:
        lift = self.lift
        lift.rise(self.cfg.lift_speed_m_s, dt_s)
        self._follow_load(t, dt_s)
        lift.target_m = lift.servo_target(lift.load_n, lift.speed_m_s)
        if lift.arrived_at_top(obs.lift_pos_m, obs.lift_vel_m_s):
            lift.held_load_n = lift.load_n
            self._enter(Phase.HOLD, t, f"carrying {lift.load_n:.3g} N with {self.grip_n:.3g} N of grip")

    def _hold(self, obs: Observation, t: float, dt_s: float) -> None:
        lift = self.lift
        lift.speed_m_s = 0.0
        if self._carried_checks(obs, t, True):
            return
        self._follow_load(t, dt_s)
        # The lift has stopped and its filtered load forgotten the braking after six filter time
        # constants (e^-6 = 0.25 %); the load then is the reference.  Half of it gone is the
        # object gone; less than the lift's own acceleration explains is weight the pads no
        # longer carry: a slip, answered at most once per six time constants (the time the
        # load takes to show the answer).
        settle = 6.0 * self.cfg.load_filter_s
        if t - self._t_phase < settle:
            lift.held_load_n = lift.load_n
        elif lift.load_n < self.cfg.table_load_fraction * lift.held_load_n:
            held = lift.held_load_n
            self._give_up(t, "lost", f"the lift's load fell to {lift.load_n:.3g} N of the {held:.3g} N held", Phase.RELEASE)
            return
        else:
            sliding_n = lift.read_sliding_load_n()
            if sliding_n is not None and t - self._last_slip_s >= settle:
                # Sliding, the pads carry their friction limit 2 mu G: the held weight over it is
                # the grip the weight needs, over the grip there is.
                held = lift.held_load_n
                deficit = held / max(sliding_n, 1e-9 * held)
                self._slip(t, f"the lift's load fell to {sliding_n:.3g} N from {held:.3g} N", deficit)
        lift.target_m = lift.servo_target(lift.held_load_n, 0.0)
        if t - self._t_phase >= self.cfg.hold_s:
            self._enter(Phase.PLACE, t)

    def _place(self, obs: Observation, t: float, dt_s: float) -> None:
        c, lift = self.cfg, self.lift
        if self.gave_up is None and self._carried_checks(obs, t, True):
            return
        touchdown = self._rested_lift_m()
        # Full speed, braking at the lift's acceleration to the touchdown speed by
        # ``touchdown_margin_m`` above where the object rested, then the touchdown speed (and, a
        # landing speed capped below it, that cap by the same time's travel at it: LiftPlan.lower).
        lift.lower(lift.goal_m - touchdown - c.touchdown_margin_m, c.lift_speed_m_s, c.touchdown_speed_m_s, dt_s, c.touchdown_margin_m)
        lift.target_m = lift.servo_target(lift.held_load_n, -lift.speed_m_s)
        table_has_weight = lift.table_took_weight(c.touchdown_speed_m_s, c.table_load_fraction)
        below = obs.lift_pos_m < touchdown - c.touchdown_margin_m
        # Nothing carried (a give-up during the transfer): back down to where the lift was, or
        # open where it is if the lift carries nothing of the object either: fingers closed
        # over an object's top would press it into the table on the way down
        # (tests/test_third_party_grippers.py::test_a_give_up_with_nothing_carried_opens_where_the_lift_is).
        home = lift.held_load_n < self.robot.min_load_n and obs.lift_pos_m <= touchdown + 1e-4
        unloaded = self.gave_up is not None and max(lift.held_load_n, lift.load_n) < self.robot.min_load_n
        if table_has_weight or below or home or unloaded:
            # Stop where the lift is: its servo carries nothing more, the table the rest.
            lift.goal_m = lift.target_m = obs.lift_pos_m
            why = (
                f"load {lift.raw_load_n:.3g} N of {lift.held_load_n:.3g} N: the table has the weight"
                if table_has_weight
                else "the lift is back where the object rested"
                if home
                else "the lift carries nothing of the object: opening where it is"
                if unloaded
                else "the lift is below where the object rested"
            )
            self._enter(Phase.RELEASE, t, why)

    def _release(self, obs: Observation, t: float, dt_s: float) -> None:
        if math.isnan(self._released_from_n):
            self._released_from_n = self.grip_n
            self._clear_opening_m = clear_opening_m(self._width_m, obs.opening_m, self.robot.pad_travel_m)
        if self.opening_target < obs.opening_m:
            # The fingers are ahead of their target: squeezing (the target inside the object) on
            # the first period, then the pads' gel unloading pushes them out.  The target jumps
            # to them with the grip at the floor (the servo never squeezes the object back) and
            # its profile keeps its speed: it overtakes the gel's creep within a few periods.
            # (A target left behind, its profile restarted from rest whenever the fingers crept
            # ahead, would hold the object until the creep stopped: tests/test_grasp_outcomes.py::
            # test_a_placed_soft_object_is_let_go_at_once.)
            self.opening_target = obs.opening_m
            self.grip_n = self.grip_floor_n
        else:
            self.grip_n = self.opening_force_n
            if self.robot.pad_rise_m[0] and obs.opening_m < self._width_m:
                # A linkage's pads still on the object: once its force range widened from the
                # grip to the full opening force, Menagerie's 2F-85 closed its pads 45 um and
                # pressed its 2 g wafer from 0.033 N to 0.048 N (crushes at 0.05 N), although its
                # commands lay on the opening side of the actuator's present length: the closing
                # is inside the linkage (a tendon servo on the drivers' mean, soft equality
                # constraints), not the target's mapping (docs/grippers.md).  Until the pads are
                # past the width they touched at, the drive pushes and pulls with no more than the
                # grip it released from.
                self.grip_n = min(self.opening_force_n, max(self._released_from_n, self.grip_floor_n))
        self._open_toward_home(dt_s)
        # Done once the pads are off the object: the fingers go on opening home in DONE, but a
        # grasp whose hand is clear is over (the Rethink opened 1.1 s from a 20 mm raspberry to
        # its 48 mm home, which timed a held grasp out at 12 s).
        if obs.opening_m >= min(self.robot.home_opening_m - 0.002, self._clear_opening_m):
            self._enter(Phase.DONE, t, self.gave_up or "")

    def _done(self, obs: Observation, t: float, dt_s: float) -> None:
        self._open_toward_home(dt_s)

    def _open_toward_home(self, dt_s: float) -> None:
        """Move the opening target toward home at ``opening_speed_m_s``, speeding up and braking
        at the fingers' acceleration: a set-point step at either end (the fingers slammed to a
        stop at home) jolts the pads' gel against the pascal-sensitive elements (rho h0 a)."""
        remaining = self.robot.home_opening_m - self.opening_target
        self._opening_speed = trapezoid_speed(remaining, self._opening_speed, self.cfg.opening_speed_m_s, self.finger_accel_m_s2, dt_s)
        self.opening_target = min(self.robot.home_opening_m, self.opening_target + self._opening_speed * dt_s)

    # -- shared by the carried phases -------------------------------------------------

    def _follow_load(self, t: float, dt_s: float) -> None:
        """The grip follows the lift's filtered load at the friction (:func:`~.lift.grip_for_load_n`),
        never down; a load that needs more than the cap is a give-up (:meth:`_over_cap`)."""
        load_n = self.lift.load_n
        wanted = grip_for_load_n(load_n, self.friction, self.cfg.grip_safety, self.grip_floor_n)
        if not self._over_cap(t, wanted, load_n, carried=True):
            self.grip_n = ratchet_grip_n(self.grip_n, wanted, self.grip_cap_n, self.grip_rate_n_s, dt_s)

    def _cap_at_width(self, t: float, width_m: float) -> None:
        """The grip's cap brought down to what the drive gives at the object's width ``width_m``
        (m, the opening at the touch), where its servo reaches less there than its rating
        (:meth:`RobotLimits.finger_force_limit_at_n`): a position servo whose closed command holds
        the fingers just touching presses an object with kp times how far short of that they
        stand, not its force range (Menagerie's Franka hand: 1.75 N a finger on a 60 mm jar, rated
        50 N), and a grip commanded past it is a grip the pads never feel.  Said in the record."""
        reach_n = self.robot.finger_force_limit_at_n(width_m)
        if reach_n >= self.max_grip_n:
            return
        self.max_grip_n = reach_n
        self.grip_cap_n = min(self.grip_cap_n, reach_n)
        self.grip_floor_n = min(self.grip_floor_n, self.grip_cap_n)
        self._event(
            t,
            "drive_reach",
            f"the drive gives at most {reach_n:.3g} N per finger at this {width_m * 1e3:.1f} mm width (its servo's "
            f"stiffness times the stroke left to its closed command; rated {self.robot.finger_force_limit_n:.3g} N): the grip's cap",
        )

    def _pads_slide_at_cap(self, t: float, load_n: float, opening_m: float | None = None) -> None:
        """Give up: the pads slide at ``load_n`` N of load with the grip at its cap (``blind``
        when the cap is what the fingertip measures, ``never_lifted`` when it is the gripper's).
        Where the drive reaches less than the cap at the fingers' opening now (``opening_m``, m:
        pads pressed into an object close the fingers on, and a position servo's reach falls
        with its stroke, :meth:`RobotLimits.finger_force_limit_at_n`), that reach is what the
        grip came to, and is said: robosuite's Panda gave up on a 1.36 kg, 24 mm cylinder "at
        the gripper's limit, 17.5 N", the reach at the touch's width, its fingers closed to 19 mm
        and pressing 14.6 N, their reach there 15 N."""
        blind = self.measurable_grip_n < self.max_grip_n
        limit = "what the fingertip measures" if blind else "the gripper's limit"
        message = f"the pads slide at {load_n:.3g} N of load with the grip at {limit}, {self.grip_cap_n:.3g} N"
        reach_n = self.robot.finger_force_limit_at_n(opening_m) if opening_m is not None else math.inf
        if not blind and reach_n < self.grip_cap_n:
            message = (
                f"the pads slide at {load_n:.3g} N of load with the grip at what the drive reaches at this "
                f"{opening_m * 1e3:.1f} mm opening, {reach_n:.3g} N"
            )
        self._give_up(t, "blind" if blind else "never_lifted", message, Phase.PLACE)

    def _over_cap(self, t: float, wanted: float, load: float, carried: bool) -> bool:
        """Give up when the load needs more grip than the fingertip measures or the robot has."""
        if wanted <= self.grip_cap_n * (1 + 1e-9):
            return False
        then = Phase.PLACE
        if self.measurable_grip_n < self.max_grip_n:
            self._give_up(
                t,
                "blind",
                f"load {load:.3g} N needs {wanted:.3g} N of grip; the fingertip measures up to {self.measurable_grip_n:.3g} N",
                then,
            )
        else:
            kind = "over_limit" if carried else "never_lifted"
            self._give_up(t, kind, f"load {load:.3g} N needs {wanted:.3g} N of grip; the gripper allows {self.max_grip_n:.3g} N", then)
        return True

    def _carried_checks(self, obs: Observation, t: float, carried: bool) -> bool:
        """Loss and fingertip slip while the object may be off the table (``carried``: raised, held
        or placed; else still moving onto the pads); True if the phase ended."""
        phase = self.phase
        # Proprioception, unless the fingertips contradict it: with the object between them the
        # fingers close at most to its width less the two pads' travel (under a grip near the
        # fingers' limit the mechanism itself yields millimetres more, and then the fingertips
        # read pressure: no fingertip may report a measured load).  For lost_s, as the
        # fingertips' own loss: a fingertip "settling" (just after a mode switch, or a load
        # step) is not one reading empty, and both can settle at once while a high grip has the
        # fingers a millimetre past that width; an object gone stays gone
        # (tests/test_grasp_outcomes.py::test_fingers_past_the_width_while_both_fingertips_settle_is_not_yet_a_loss).
        shut_m = self._width_m - 2.0 * self.robot.pad_travel_m - obs.opening_m
        watched = carried or self.shut_check_in_transfer
        if watched and shut_m > 0 and not any(sel.trusted and sel.status == "ok" for sel in self.selectors.values()):
            self._shut_s += self.dt_s
            if self._lasted_lost_s(self._shut_s):
                shut = 1e3 * shut_m
                message = f"the fingers closed {shut:.1f} mm past the object's width during {phase.label}"
                self._give_up(t, "lost", message, Phase.RELEASE)
                return True
        else:
            self._shut_s = 0.0
        if carried and all(map(_EMPTY, self.selectors.values())):
            self._empty_s += self.dt_s
            if self._lasted_lost_s(self._empty_s):
                self._give_up(t, "lost", f"both fingertips read no load for {self.cfg.lost_s:g} s during {self.phase.label}", Phase.RELEASE)
                return True
        else:
            self._empty_s = 0.0
        if not carried:
            return False
        if t < self._slip_watch_from_s or t - self._last_slip_s < 6.0 * self.cfg.load_filter_s:
            # The grip is still settling on the pads (a subclass lowers it as the raise begins, a
            # slip's answer raises it): the pressures it brings are no slip's reference yet.  A
            # slip is answered at most once per six load-filter time constants, the time the
            # load check gives an answer to show (the fingertips see it sooner, but a raised
            # grip rings in the fingers, and a ring's trough is no slip: tests/test_slip_answers.py::
            # test_slip_answers_are_at_least_the_settling_time_apart).
            self._reference_pa = {}
            return False
        for pad, sel in self.selectors.items():
            if not (sel.trusted and sel.status == "ok"):
                continue
            ref = self._reference_pa.get(pad)
            p, u = sel.estimate_pa, sel.uncertainty_pa
            if ref is None or p > ref:
                self._reference_pa[pad] = p
                continue
            if p < (1.0 - self.cfg.slip_pressure_drop) * ref and ref - p > 3.0 * u:
                self._slip(t, f"{pad} pressure fell to {p:.3g} Pa from {ref:.3g} Pa")
                self._reference_pa = {}
                break
        return self.phase is not phase

    def _lasted_lost_s(self, elapsed_s: float) -> bool:
        """Whether a condition summed over control periods, ``elapsed_s``, has lasted ``lost_s``:
        its lost_s / dt readings (ten 5 ms periods sum to 0.04999 s, short of 0.05 s)."""
        return elapsed_s >= self.cfg.lost_s - 0.5 * self.dt_s

    def _slip(self, t: float, why: str, deficit: float = 1.0) -> None:
        """Answer a slip: grip harder by the safety factor times the grip's ``deficit`` (the
        factor the load fell short by), within the cap."""
        self._last_slip_s = t
        wanted = self.grip_n * self.cfg.grip_safety * max(deficit, 1.0)
        if self._over_cap(t, wanted, self.lift.load_n, carried=True):
            return
        self._event(t, "slip", f"{why}: grip {self.grip_n:.3g} -> {min(wanted, self.grip_cap_n):.3g} N")
        self.grip_n = min(wanted, self.grip_cap_n)


#: Each phase's method, indexed by the phase (an IntEnum: a tuple's index is cheaper than an
#: enum's hash, a Python function).
_HANDLERS = tuple(
    {
        Phase.APPROACH: MultimodeGrasp._approach,
        Phase.CLOSE: MultimodeGrasp._close,
        Phase.SQUEEZE: MultimodeGrasp._squeeze,
        Phase.LIFT: MultimodeGrasp._lift,
        Phase.HOLD: MultimodeGrasp._hold,
        Phase.PLACE: MultimodeGrasp._place,
        Phase.RELEASE: MultimodeGrasp._release,
        Phase.DONE: MultimodeGrasp._done,
    }.get(phase)
    for phase in Phase
)
