"""The multimode grasp controller: feel a touch of a few pascals, carry what the grip allows.

It reads only the fingertip readouts and the robot's own joints (:class:`Observation`) and
knows only the robot's design (:class:`RobotLimits`); every number it uses is a field of
:class:`~scenarios.config.ControllerConfig` with its derivation, or derived here from the
fingertip's ranges and the robot's limits.

Phases (:class:`Phase`), one method each::

    approach -> close -> squeeze -> lift -> hold -> place -> release -> done
                                  (any of them may give up with a reason, then put down / open)

- approach: learn each fingertip's unloaded baseline; refuse to grasp if the self-test failed.
- close: close at ``closing_speed_m_s`` with the force the fingers need to move (a guard, not
  a grip) until a CUSUM on the most sensitive mode detects touch on both fingertips.
- squeeze: settle at the grip floor: the gentlest grip whose pad pressure the lowest mode
  resolves to 10 % (:func:`grip_floor_n`).  A fingertip reading nothing there was alarmed by
  something else (a false touch): close on; but fingers that cannot close, twice felt by no
  fingertip, touch the object off the pads (``unfelt_contact``: give up).
- lift, in three stages.  *Transfer*: the lift goal rises only as far as the grip can carry
  at the assumed friction, and the grip follows the load the lift feels (grip = safety x
  load / (2 mu)), so the weight moves from the table onto the pads.  When the load stops
  growing with the goal, the object has left the table *or* the pads are sliding on it (the
  load then sits at the friction limit 2 mu grip): a *friction check* raises the grip by the
  safety factor and watches whether the load follows it.  If it does, the pads were
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
"""

from __future__ import annotations

import math
from enum import Enum
from operator import attrgetter

import numpy as np

from piezotip.scenarios.config import ControllerConfig
from piezotip.sensor import Fingertip
from piezotip.sensor.cache import disk_cached

from .interface import Command, Event, Observation, RobotLimits, Why, make_command
from .phases import FINISHED, Phase
from .selector import ModeSelector, TouchDetector


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


class Stage(Enum):
    """The lift's stages (see the module docstring)."""

    TRANSFER = "transfer"
    CHECK = "friction check"
    RAISE = "raise"


#: The members the per-step path compares with, as module globals: on Python 3.11 reading a
#: member through its class passes EnumType's __getattr__ hook (0.1 us, as long as the rest of
#: a comparison ten times over).
_FAULT, _LIFT, _RAISE = Phase.FAULT, Phase.LIFT, Stage.RAISE

_EMPTY = attrgetter("empty")  # all(map(_EMPTY, ...)): no generator made and closed each step


class MultimodeGrasp:
    """The multimode grasp controller (module docstring).

    Parameters
    ----------
    config : ControllerConfig (``modes`` restricts the modes: ``[1]`` is a single-mode baseline).
    robot : the gripper's limits and home targets, read from the model.
    pads : instrumented pad names.
    fingertip : the fingertip model the readout is calibrated with.
    self_test_message : None if the element's self-test passed, else its message (the
        controller then refuses to grasp).
    dt_s : the control period, s.
    """

    #: Whether the fingers shut past the object's width count as a loss during the transfer too
    #: (not only once carried): the gentle probe grows the grip while the lift rises, which
    #: closes fingers that hold nothing.
    shut_check_in_transfer = False

    def __init__(
        self,
        config: ControllerConfig,
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
        #: The fingers' force limit while they move freely: what their drive's damping needs at
        #: the commanded speed, x 1.5 (a guard: a touch before it is detected meets no more).
        moving = c.drive_margin * robot.finger_damping_n_s_m * c.closing_speed_m_s
        self.moving_force_n = min(robot.finger_force_limit_n, max(self.grip_floor_n, moving))
        self.opening_force_n = min(robot.finger_force_limit_n, c.drive_margin * robot.finger_damping_n_s_m * c.opening_speed_m_s)
        #: The fingers' acceleration, m/s^2: the element feels its own pad's inertia (rho h0 a
        #: on its face), so they speed up slowly enough that it stays under half the lowest
        #: mode's detection limit, unseen (a faster start reads as a touch).
        self.finger_accel_m_s2 = 0.5 * sel.p_min_pa[lowest] / robot.pad_areal_mass_kg_m2
        self._finger_speed = 0.0
        self._opening_speed = 0.0  # of the opening target on release, m/s
        # The drive's force while the fingers close freely at pace (learned, as the fingertips'
        # baselines are), and the force in the last period: see _joint_touch.
        self._free_drive_n: float | None = None
        self._joints_felt_touch = False  # the last touch was the joints', not the fingertips'
        self._last_drive_n = math.nan
        #: Share of a load change the lift's own acceleration explains (load = m (g + a)).
        self.load_noise_fraction = c.lift_accel_m_s2 / robot.gravity_m_s2
        #: The load transfer gives up after twice the time the grip needs to ramp to its cap
        #: and the goal to rise by the lift height at lift speed.
        self.transfer_timeout_s = 2.0 * (self.grip_cap_n / self.grip_rate_n_s + c.lift_height_m / c.lift_speed_m_s)
        self.top_m = robot.home_lift_m + c.lift_height_m
        self.phase = Phase.APPROACH
        self.stage = Stage.TRANSFER
        self.events: list[Event] = []
        self.gave_up: str | None = None
        self.touch_time_s = math.nan
        self.friction = c.friction_assumed  # assumed, never estimated (see _transfer)
        self._sliding_ratio = c.friction_assumed
        self._t_phase = 0.0
        self.opening_target = robot.home_opening_m
        self.lift_target = robot.home_lift_m
        self.grip_n = self.moving_force_n
        self._goal = robot.home_lift_m
        self._speed = 0.0
        self._last_vel = 0.0
        self._load_n = 0.0  # low-passed load, N
        self._raw_load_n = 0.0
        self._baseline_n = 0.0
        self._held_load_n = 0.0
        # (goal, lift position, raw load) over the last plateau window, to tell a lift that
        # follows its goal (the object airborne, or the pads sliding) from one held back by the
        # object, and to average the load over the same window.
        self._track: list[tuple[float, float, float]] = []
        #: The plateau window: two of the lift servo's time constants kv / kp, so a lift that
        #: lags its goal is not taken for one that cannot follow it.
        self.plateau_steps = max(3, math.ceil(2.0 * robot.lift_kv_n_s_m / robot.lift_kp_n_m / dt_s))
        self._check: tuple[float, float, float] | None = None  # (t0, G0, L0)
        self._check_pace = 0.0
        self._reference_pa: dict[str, float] = {}
        self._empty_s = 0.0
        self._shut_s = 0.0  # how long the fingers have been shut past the object, no fingertip reading it
        self._table_steps = 0
        self._last_slip_s = -math.inf
        self._low_steps = 0
        self._low_sum_n = 0.0  # the low readings' sum, N (_hold)
        self._width_m = math.nan
        self._steady_steps = 0
        self._saturated_logged: set[str] = set()
        self._unfelt_opening_m: float | None = None  # the opening at the last false touch felt by no fingertip
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
        self.phase = Phase.FAULT
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
        if self.phase is _FAULT:
            # Refused or faulted: hold still with the fingers open (nothing was grasped) or
            # as they are, never squeezing.
            return make_command(self.lift_target, self.opening_target, self.opening_force_n, modes, self.phase, self.events[-1].message)
        accel = (obs.lift_vel_m_s - self._last_vel) / dt_s
        self._last_vel = obs.lift_vel_m_s
        self._raw_load_n = self.robot.lift_load_n(self.lift_target, obs.lift_pos_m, obs.lift_vel_m_s, accel) - self._baseline_n
        self._load_n += (self._raw_load_n - self._load_n) * min(1.0, dt_s / self.cfg.load_filter_s)
        _HANDLERS[self.phase](self, obs, t, dt_s)
        return make_command(self.lift_target, self.opening_target, self.grip_n, modes, self.phase, Why.join(reasons))

    def _read_fingertips(self, obs: Observation, t: float) -> tuple[dict[str, int], list]:
        """Check each reading's range and choose each fingertip's next mode."""
        modes, reasons = {}, []
        for pad, sig in obs.pads.items():
            sel, low, high = self._reading_bounds[pad]
            reading = sig.reading
            v1 = reading.v1
            if not (low <= v1 <= high) and self.phase is not _FAULT:
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

    def _close(self, obs: Observation, t: float, dt_s: float) -> None:
        self._finger_speed = min(self.cfg.closing_speed_m_s, self._finger_speed + self.finger_accel_m_s2 * dt_s)
        self.opening_target = max(0.0, self.opening_target - self._finger_speed * dt_s)
        touched = [self.touch[pad].update(obs.pads[pad].reading.v1) for pad in self.pads]
        felt_by_joints = self._joint_touch(obs.grip_force_n)
        if all(touched) or felt_by_joints:
            self.touch_time_s = t
            self._width_m = obs.opening_m  # the object's width: the pads barely pressed yet
            self.opening_target = 0.0  # squeeze at the force limit
            self.grip_n = self.grip_floor_n
            self._free_drive_n = None
            self._joints_felt_touch = not all(touched)
            how = f"on {', '.join(self.pads)} (CUSUM)" if all(touched) else f"felt by the joints ({felt_by_joints})"
            self._enter(Phase.SQUEEZE, t, f"touch {how}; grip floor {self.grip_floor_n:.3g} N")
        elif self.opening_target <= 0.0:
            if obs.opening_m < 0.002:
                self._give_up(t, "no_object", "closed without feeling a touch", Phase.RELEASE)
            elif self._last_opening_m - obs.opening_m < 0.5 * self.cfg.closing_speed_m_s * dt_s:
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
        if self._finger_speed < self.cfg.closing_speed_m_s:  # still speeding up
            self._free_drive_n = None
            return ""
        free, floor = self._free_drive_n, self.grip_floor_n
        if free is None:
            if abs(drive_n - last) < floor:
                self._free_drive_n = drive_n
            return ""
        if drive_n - free > floor:
            return f"the drive needs {drive_n:.3g} N against its free {free:.3g} N"
        self._free_drive_n = min(free, drive_n)
        return ""

    def _squeeze(self, obs: Observation, t: float, dt_s: float) -> None:
        if t - self._t_phase < self.cfg.squeeze_settle_s:
            return
        # A touch leaves the floor's pressure on the pads; a fingertip that reads nothing was
        # alarmed by something else (its own pad's inertia as the fingers jerk): close on.
        empty = [pad for pad, sel in self.selectors.items() if sel.trusted and sel.status == "below_detection"]
        if empty:
            # Closing on is for fingers that are free.  If every fingertip read nothing here and
            # at the last false touch, and the fingers have not closed since by what one control
            # period of free closing covers, something they do not feel blocks them (an object
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
            if unfelt and previous is not None and previous - obs.opening_m < self.cfg.closing_speed_m_s * dt_s:
                self._give_up(
                    t,
                    "unfelt_contact",
                    f"the fingers stopped at {obs.opening_m * 1e3:.1f} mm twice with no pressure on any fingertip: "
                    "they touch the object off the sensing pads",
                    Phase.RELEASE,
                )
                return
            for pad in self.pads:
                self.touch[pad].rearm()
            self.opening_target, self._finger_speed = obs.opening_m, 0.0
            self.grip_n = self.moving_force_n
            self._event(t, "false_touch", f"{', '.join(empty)} read no pressure at the grip floor: closing on")
            self._enter(Phase.CLOSE, t)
            return
        self._baseline_n = self._raw_load_n + self._baseline_n  # what the lift carries before lifting
        self._load_n = self._raw_load_n = 0.0
        self._goal = self.lift_target
        self._enter(Phase.LIFT, t, self._lift_message())

    def _lift_message(self) -> str:
        """What the lift phase's event says it starts from."""
        return f"grip {self.grip_n:.3g} N, assumed friction {self.friction:g}"

    def _lift(self, obs: Observation, t: float, dt_s: float) -> None:
        if self._carried_checks(obs, t):
            return
        if self.stage is _RAISE:
            self._raise(obs, t, dt_s)
        else:
            self._transfer(obs, t, dt_s)

    def _transfer(self, obs: Observation, t: float, dt_s: float) -> None:
        """Move the weight onto the pads: the goal rises only as far as the grip carries."""
        c, load = self.cfg, max(self._raw_load_n, 0.0)
        if t - self._t_phase > self.transfer_timeout_s:
            self._give_up(t, "never_lifted", f"the load transfer did not finish in {self.transfer_timeout_s:.2g} s", Phase.PLACE)
            return
        if self._over_cap(t, c.grip_safety * load / (2.0 * self.friction), load, carried=False):
            return
        # The grip follows the load at the friction assumed or, once a check has seen the load
        # follow the grip, at the load-to-grip ratio seen then: while the pads slide that ratio
        # is the friction, and the grip grows until the pads hold.  (Where MuJoCo's soft
        # friction crept at a tiny grip the ratio is low, and the grip carries more margin.)
        wanted = max(self.grip_floor_n, c.grip_safety * load / (2.0 * self._sliding_ratio))
        if self._check is not None:
            wanted = max(wanted, c.grip_safety * self._check[1])
        self._ratchet_grip(min(wanted, self.grip_cap_n), dt_s)
        # The goal rises at the speed at which the load it adds on a held object (kp per metre)
        # needs grip no faster than the grip can rise, and only while the grip the fingers
        # apply (their drive lags the command) can carry the load at the friction assumed.
        applied = max(obs.grip_force_n, 0.0)
        carry = 2.0 * self.friction * applied - load
        speed = min(c.lift_speed_m_s, self.grip_rate_n_s * 2.0 * self.friction / (c.grip_safety * self.robot.lift_kp_n_m))
        self._goal = min(self.top_m, self._goal + (speed * dt_s if carry > 0 else 0.0))
        self.lift_target = self._goal
        # While the pads hold the object on the table the lift cannot follow its goal (the
        # load grows by kp per metre of goal instead); a lift that follows it carries the
        # object in the air, or its pads slide up the object at the friction limit.
        self._track.append((self._goal, obs.lift_pos_m, self._raw_load_n))
        if len(self._track) > self.plateau_steps:
            self._track.pop(0)
        follows = len(self._track) == self.plateau_steps and self._follows()
        if self._check is None:
            if follows and applied > 0.0:
                self._check = (t, applied, self._window_load_n())
                self._check_pace = self._pace()
            return
        t0, g0, l0 = self._check
        grip_gain = applied / g0 - 1.0
        risen = grip_gain >= 0.5 * (c.grip_safety - 1.0) or self.grip_n >= self.grip_cap_n
        window_load = self._window_load_n()
        if risen and window_load > l0 * (1.0 + 0.5 * grip_gain):
            # The load grew with the grip: the object still rests on the table, held or
            # sliding.  The grip keeps the raise (a ratchet), so every check that finds the
            # object on the table leaves the grip higher by the safety factor: a friction below
            # the one assumed is met in a few checks, without estimating it (MuJoCo's soft
            # friction creeps below the limit, so a slide cannot be told from a hold here).
            self._event(t, "on_table", f"load {load:.3g} N followed the grip ({g0:.3g} -> {applied:.3g} N): still on the table")
            if self._check_pace >= self.cfg.sliding_pace:
                self._sliding_ratio = min(self._sliding_ratio, max(l0, 1e-12) / (2.0 * g0))
            self._check = None
            self._track.clear()
            if self.grip_n >= self.grip_cap_n:
                self._pads_slide_at_cap(t, l0)
        elif risen and t - t0 >= self._check_window_s(g0) and follows and window_load >= self.robot.min_load_n:
            self._check = None
            self.stage = Stage.RAISE
            self._start_carry(obs)
            self._event(t, "carried", f"load {load:.3g} N does not follow the grip ({g0:.3g} -> {applied:.3g} N): the object is carried")

    def _window_load_n(self) -> float:
        """The raw load averaged over the plateau window, N.

        The friction check compares loads over the window in which the lift followed its goal,
        so a load taken on before that window (at lift-off) is wholly in the first average; a
        low-pass would still be rising toward it and read its own rise as the load following
        the grip (the 50 ms filter has caught only 70 % of a step after the 60 ms window).
        Averaged over the window, because sliding pads stick and slip and one reading of a
        small load is mostly that noise."""
        return sum(entry[2] for entry in self._track) / len(self._track)

    def _pace(self) -> float:
        """How far the lift moved over the plateau window, as a share of how far its goal did."""
        (g0, q0, _), (g1, q1, _) = self._track[0], self._track[-1]
        return (q1 - q0) / (g1 - g0) if g1 - g0 > 1e-7 else 0.0

    def _follows(self) -> bool:
        """The lift has moved by at least half as much as its goal over the plateau window."""
        return self._pace() > 0.5

    def _check_window_s(self, g0: float) -> float:
        """How long the friction check waits: the grip's ramp by the safety factor, then three of
        the lift servo's time constants (kv / kp) for the load to answer."""
        ramp = (self.cfg.grip_safety - 1.0) * g0 / self.grip_rate_n_s
        return ramp + 3.0 * self.robot.lift_kv_n_s_m / self.robot.lift_kp_n_m

    def _start_carry(self, obs: Observation) -> None:
        self._speed = 0.0
        self._reference_pa = {pad: sel.estimate_pa for pad, sel in self.selectors.items() if sel.status == "ok"}

    def _raise(self, obs: Observation, t: float, dt_s: float) -> None:
        c = self.cfg
        self._speed = self._profile(self.top_m - self._goal, c.lift_speed_m_s, 0.0, dt_s)
        self._goal = min(self.top_m, self._goal + self._speed * dt_s)
        self._follow_load(t, dt_s)
        self.lift_target = self._servo_target(self._load_n, self._speed)
        moving = abs(obs.lift_vel_m_s) > 1e-3
        if self._goal >= self.top_m and abs(obs.lift_pos_m - self.top_m) < 0.002 and not moving:
            self._held_load_n = self._load_n
            self._enter(Phase.HOLD, t, f"carrying {self._load_n:.3g} N with {self.grip_n:.3g} N of grip")

    def _hold(self, obs: Observation, t: float, dt_s: float) -> None:
        self._speed = 0.0
        if self._carried_checks(obs, t):
            return
        self._follow_load(t, dt_s)
        # The lift has stopped and its filtered load forgotten the braking after six filter time
        # constants (e^-6 = 0.25 %); the load then is the reference.  Half of it gone is the
        # object gone; less than the lift's own acceleration explains is weight the pads no
        # longer carry: a slip, answered at most once per six time constants (the time the
        # load takes to show the answer).
        settle = 6.0 * self.cfg.load_filter_s
        if t - self._t_phase < settle:
            self._held_load_n = self._load_n
        elif self._load_n < self.cfg.table_load_fraction * self._held_load_n:
            held = self._held_load_n
            self._give_up(t, "lost", f"the lift's load fell to {self._load_n:.3g} N of the {held:.3g} N held", Phase.RELEASE)
            return
        else:
            # Stationary, the raw load is clean (the filter would cost 50 ms of sliding); two
            # readings in a row below the held load by more than the lift's acceleration explains.
            low = self._raw_load_n < (1.0 - 2.0 * self.load_noise_fraction) * self._held_load_n
            self._low_steps = self._low_steps + 1 if low else 0
            self._low_sum_n = self._low_sum_n + self._raw_load_n if low else 0.0
            if self._low_steps >= 2 and t - self._last_slip_s >= settle:
                # Sliding, the pads carry their friction limit 2 mu G: the held weight over it is
                # the grip the weight needs, over the grip there is.  The limit is the mean of the
                # low readings: single readings of a slide just begun scatter widely (stick-slip,
                # the lift recoiling: 0.23 then 0.80 N where the limit was 0.67 N), and the last
                # one alone left a box whose friction fell to 0.3 sliding at 4 % over its weight.
                sliding_n = self._low_sum_n / self._low_steps
                deficit = self._held_load_n / max(sliding_n, 1e-9 * self._held_load_n)
                self._slip(t, f"the lift's load fell to {sliding_n:.3g} N from {self._held_load_n:.3g} N", deficit)
        self.lift_target = self._servo_target(self._held_load_n, 0.0)
        if t - self._t_phase >= self.cfg.hold_s:
            self._enter(Phase.PLACE, t)

    def _place(self, obs: Observation, t: float, dt_s: float) -> None:
        c = self.cfg
        if self.gave_up is None and self._carried_checks(obs, t):
            return
        touchdown = self.robot.home_lift_m
        # Full speed, braking at the lift's acceleration to the touchdown speed by
        # ``touchdown_margin_m`` above where the object rested, then the touchdown speed.
        distance = self._goal - touchdown - c.touchdown_margin_m
        self._speed = self._profile(distance, c.lift_speed_m_s, c.touchdown_speed_m_s, dt_s)
        self._goal -= self._speed * dt_s
        self.lift_target = self._servo_target(self._held_load_n, -self._speed)
        # The load is judged only at the steady touchdown speed: while the lift brakes, the
        # gripper's own inertia (it is far heavier than a light object) blurs it.
        self._steady_steps = self._steady_steps + 1 if self._speed == c.touchdown_speed_m_s else 0
        on_table = self._steady_steps >= self.plateau_steps and self._raw_load_n < c.table_load_fraction * self._held_load_n
        self._table_steps = self._table_steps + 1 if on_table else 0
        below = obs.lift_pos_m < touchdown - c.touchdown_margin_m
        # Nothing carried (a give-up during the transfer): back down to where the lift was.
        home = self._held_load_n < self.robot.min_load_n and obs.lift_pos_m <= touchdown + 1e-4
        if self._table_steps >= 2 or below or home:
            # Stop where the lift is: its servo carries nothing more, the table the rest.
            self._goal = self.lift_target = obs.lift_pos_m
            why = (
                f"load {self._raw_load_n:.3g} N of {self._held_load_n:.3g} N: the table has the weight"
                if self._table_steps >= 2
                else "the lift is back where the object rested"
                if home
                else "the lift is below where the object rested"
            )
            self._enter(Phase.RELEASE, t, why)

    def _release(self, obs: Observation, t: float, dt_s: float) -> None:
        if self.opening_target < obs.opening_m:
            # The fingers are ahead of their target: squeezing (the target inside the object) on
            # the first period, then the pads' gel unloading pushes them out.  The target jumps
            # to them with the grip at the floor (the servo never squeezes the object back) and
            # its profile keeps its speed: it overtakes the gel's creep within a few periods.
            # (Restarting the profile from rest whenever the fingers crept ahead held the
            # object on the table until the creep stopped: up to 2.7 s on a soft object.)
            self.opening_target = obs.opening_m
            self.grip_n = self.grip_floor_n
        else:
            self.grip_n = self.opening_force_n
        self._open_toward_home(dt_s)
        if obs.opening_m >= self.robot.home_opening_m - 0.002:
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

    def _profile(self, distance_m: float, top_speed: float, end_speed: float, dt_s: float) -> float:
        """The next speed of a trapezoidal move, m/s: up at the lift's acceleration to
        ``top_speed``, braking so as to reach ``end_speed`` after ``distance_m`` (then holding
        it; 0 stops there).  Speed steps would load the pads with m a."""
        a = self.cfg.lift_accel_m_s2
        allowed = math.sqrt(end_speed * end_speed + 2.0 * a * max(distance_m, 0.0))
        wanted = min(top_speed, allowed)
        if end_speed == 0.0 and distance_m <= 0.0:
            return 0.0
        return min(wanted, self._speed + a * dt_s) if self._speed < wanted else max(wanted, self._speed - a * dt_s)

    def _servo_target(self, load_n: float, speed_m_s: float) -> float:
        """The lift target that puts the lift on its goal: the servo sags by load / kp under the
        object and lags by kv v / kp in motion (the robot knows its gains), both fed forward."""
        return self._goal + (load_n + self.robot.lift_kv_n_s_m * speed_m_s) / self.robot.lift_kp_n_m

    def _ratchet_grip(self, wanted: float, dt_s: float) -> None:
        """Grip toward ``wanted`` at the grip rate, never down while carrying, never over the cap."""
        target = min(wanted, self.grip_cap_n)
        self.grip_n = max(self.grip_n, min(target, self.grip_n + self.grip_rate_n_s * dt_s))

    def _follow_load(self, t: float, dt_s: float) -> None:
        wanted = max(self.grip_floor_n, self.cfg.grip_safety * max(self._load_n, 0.0) / (2.0 * self.friction))
        if not self._over_cap(t, wanted, self._load_n, carried=True):
            self._ratchet_grip(wanted, dt_s)

    def _pads_slide_at_cap(self, t: float, load_n: float) -> None:
        """Give up: the pads slide at ``load_n`` N of load with the grip at its cap (``blind``
        when the cap is what the fingertip measures, ``never_lifted`` when it is the gripper's)."""
        blind = self.measurable_grip_n < self.max_grip_n
        limit = "what the fingertip measures" if blind else "the gripper's limit"
        message = f"the pads slide at {load_n:.3g} N of load with the grip at {limit}, {self.grip_cap_n:.3g} N"
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

    def _carried_checks(self, obs: Observation, t: float) -> bool:
        """Loss and fingertip slip while the object may be off the table; True if the phase ended."""
        phase = self.phase
        # Proprioception, unless the fingertips contradict it: with the object between them the
        # fingers close at most to its width less the two pads' travel (under a grip near the
        # fingers' limit the mechanism itself yields millimetres more, and then the fingertips
        # read pressure: no fingertip may report a measured load).  For lost_s, as the
        # fingertips' own loss: a fingertip "settling" (just after a mode switch, or a load
        # step) is not one reading empty, and both can settle at once while a high grip has the
        # fingers a millimetre past that width (seen at 25 N and 62 N); an object gone stays gone.
        carried = self.phase is not _LIFT or self.stage is _RAISE
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
        if self.phase is _LIFT and self.stage is not _RAISE:
            return False
        if t < self._slip_watch_from_s:
            # The grip is still settling on the pads (a subclass lowers it as the raise begins):
            # the pressures it brings are no slip's reference yet.
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
        if self._over_cap(t, wanted, self._load_n, carried=True):
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
