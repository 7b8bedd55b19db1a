"""The multimode grasp controller: feel a touch of a few pascals, hold a grip of hundreds of kPa.

It reads only the fingertip readouts and the robot's proprioception (:class:`Observation`).
Two parts:

:class:`ModeSelector` (one per fingertip) drives the element in the mode best suited to the
current pressure estimate.  The switch pressures are the fingertip's own (the pressures at
which the per-mode resolution curves cross, ``Fingertip.switch_pressures`` for the allowed
modes), never typed-in constants.  It switches up at ``s (1 + h)`` and down at ``s (1 - h)``
(hysteresis ``h``), also up when the current mode reports saturation and down when it
reports below-detection (each for ``persist`` consecutive readings), and never while a
ring-up is settling: a reading taken before the new mode has settled is not trusted, the last
trusted estimate is held meanwhile.

:class:`MultimodeGrasp` runs the phases

    approach -> close -> squeeze -> lift -> hold -> place -> release -> done   (or fault)

- approach: learn each fingertip's unloaded baseline (and refuse to grasp if the element's
  self-test failed);
- close: close at ``closing_speed_m_s`` until touch is detected on both fingertips: a
  one-sided CUSUM on the drop of the most sensitive mode's reading below its baseline
  (a sudden drop of 8 sigma alarms at once; a slow drift of a sigma per reading within a few
  readings).  Closing has no force guard: the touch is what stops it, so a late touch costs
  a force spike (servo stiffness x closing speed x latency);
- squeeze: ramp the grip to ``MIN_GRIP_N``;
- lift: raise the object while the grip follows the load the lift actuator feels,
  ``grip = SAFETY x load / (2 MU_DESIGN)`` (grip-load coupling, as in human grasping), at
  least ``MIN_GRIP_N``; the grip is never set above what the fingertip can still measure
  (0.9 x P_max of the highest allowed mode x pad area): a grasp that would need more is
  flagged "blind" and held at that cap;
- hold, place (lower back), release (open), done.

Faults (self-test failed, a reading out of range, saturation in the highest mode, a grip
beyond what the fingertip can measure) are logged with their time in :attr:`events` and
surfaced in the command's reason; none is ignored.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from scenarios.config import ControllerConfig
from sensor import Fingertip

from .controller import Command, Observation, make_command

#: Friction coefficient the controller designs for (it never knows the object's), -.
MU_DESIGN = 0.8
#: Grip safety factor over the load's friction requirement, -.
SAFETY = 1.25
#: Smallest grip the controller squeezes to, N per finger.
MIN_GRIP_N = 1.0
#: Grip ramp rate during squeeze and lift, N/s.
GRIP_RATE_N_S = 100.0
#: Hysteresis on the switch pressures, fraction.
HYSTERESIS = 0.25
#: CUSUM touch detector: drift allowance and alarm threshold, in sigmas of the reading.
CUSUM_DRIFT_SIGMA = 0.5
CUSUM_ALARM_SIGMA = 8.0
#: Time constant of the low-pass on the lift load the grip follows, s.
LOAD_FILTER_S = 0.05
#: Acceleration of the lift once the object is carried, m/s^2 (0.5 m/s^2: 5 % of g on top of
#: the weight).
LIFT_ACCEL_M_S2 = 0.5
#: The lift servo's stiffness, N/m (the robot's own design: gripper.xml lift_actuator kp).
LIFT_SERVO_KP_N_M = 2.0e4
#: How long both fingertips must read no load (below detection in the lowest mode) before the
#: object counts as gone, s.
LOST_S = 0.05
#: Readings outside [-OUT_OF_RANGE_SIGMA sigma, 1 + OUT_OF_RANGE_SIGMA sigma] are faults.
OUT_OF_RANGE_SIGMA = 6.0


@dataclass(frozen=True)
class Event:
    """Something the controller decided or noticed: time (s), pad, kind, message."""

    time_s: float
    pad: str
    kind: str
    message: str


class Why:
    """A reason, formatted only when read (``str(why)``): a controller gives one every step,
    and formatting numbers each step would cost more than deciding."""

    __slots__ = ("args", "template")

    def __init__(self, template: str, *args) -> None:
        self.template, self.args = template, args

    def __str__(self) -> str:
        if self.template is None:  # a join of (pad, why) pairs
            return "; ".join(f"{pad}: {why}" for pad, why in self.args)
        return self.template.format(*self.args)

    @classmethod
    def join(cls, pairs: list) -> Why:
        """'pad: why; pad: why', lazily."""
        why = cls("")
        why.template, why.args = None, tuple(pairs)
        return why


class ModeSelector:
    """Chooses one fingertip's drive mode from its readout, with hysteresis and settling.

    Parameters
    ----------
    fingertip : the fingertip model whose switch pressures and limits the selector uses.
    modes : the allowed modes (a subset of the fingertip's), ascending.
    hysteresis : fractional band around each switch pressure.
    persist : consecutive saturated / below-detection readings before acting on them.
    """

    def __init__(self, fingertip: Fingertip, modes: tuple[int, ...], hysteresis: float = HYSTERESIS, persist: int = 3) -> None:
        self.modes = tuple(sorted(modes))
        allowed = Fingertip(
            element=fingertip.element,
            gel=fingertip.gel,
            coverage=fingertip.coverage,
            noise=fingertip.noise,
            modes=self.modes,
            rated_pressure_pa=fingertip.rated_pressure_pa,
            mounting=fingertip.mounting,
        )
        self.bands = allowed.mode_bands()
        # Switch pressure between consecutive allowed modes (the band edge), Pa.
        self.switch_pa = {(a[0], b[0]): a[2] for a, b in zip(self.bands, self.bands[1:], strict=False)}
        self.p_max_pa = {m: allowed.upper_limit(m) for m in self.modes}
        self.p_min_pa = {m: allowed.detection_limit(m) for m in self.modes}
        self.hysteresis = hysteresis
        self.persist = persist
        self.mode = self.modes[0]
        self._saturated = 0
        self._below = 0
        self.blind = False  # saturated in the highest allowed mode
        self.estimate_pa = 0.0  # last trusted estimate
        self.uncertainty_pa = math.nan
        self.trusted = True

    def _up(self) -> int | None:
        i = self.modes.index(self.mode)
        return self.modes[i + 1] if i + 1 < len(self.modes) else None

    def _down(self) -> int | None:
        i = self.modes.index(self.mode)
        return self.modes[i - 1] if i > 0 else None

    def update(self, estimate) -> tuple[int, str]:
        """Take one readout estimate; return (mode to drive next, why).

        A "settling" estimate (the readout cannot yet tell the new mode's steady reading) is
        not used: the last trusted estimate is held and no switch is made.
        """
        if estimate.status == "settling":
            self.trusted = False
            return self.mode, Why("mode {}: settling after switch, holding {:.3g} Pa", self.mode, self.estimate_pa)
        self.trusted = True
        self.blind = False
        status = estimate.status
        self._saturated = self._saturated + 1 if status == "saturated" else 0
        self._below = self._below + 1 if status == "below_detection" else 0
        if status in ("ok", "below_detection") and math.isfinite(estimate.pressure_pa):
            self.estimate_pa, self.uncertainty_pa = estimate.pressure_pa, estimate.uncertainty_pa
        up, down = self._up(), self._down()
        if self._saturated >= self.persist:
            if up is None:
                self.blind = True
                return self.mode, Why(
                    "mode {}: saturated and no higher mode allowed (blind above {:.3g} Pa)", self.mode, self.p_max_pa[self.mode]
                )
            return self._switch(up, f"mode {self.mode} saturated (P > {self.p_max_pa[self.mode]:.3g} Pa)")
        if self._below >= self.persist and down is not None:
            return self._switch(down, f"mode {self.mode} below detection (P < {self.p_min_pa[self.mode]:.3g} Pa)")
        if status == "ok":
            p = self.estimate_pa
            if up is not None and p > self.switch_pa[(self.mode, up)] * (1 + self.hysteresis):
                return self._switch(up, f"P {p:.3g} Pa above switch {self.switch_pa[(self.mode, up)]:.3g} Pa x {1 + self.hysteresis:g}")
            if down is not None and p < self.switch_pa[(down, self.mode)] * (1 - self.hysteresis):
                return self._switch(down, f"P {p:.3g} Pa below switch {self.switch_pa[(down, self.mode)]:.3g} Pa x {1 - self.hysteresis:g}")
        return self.mode, Why("mode {}: {}, P {:.3g} Pa", self.mode, status, self.estimate_pa)

    def _switch(self, mode: int, why: str) -> tuple[int, str]:
        old, self.mode = self.mode, mode
        self._saturated = self._below = 0
        self.trusted = False
        return mode, f"switch {old} -> {mode}: {why}"


class TouchDetector:
    """One-sided CUSUM on the drop of a reading below its unloaded baseline (in sigmas)."""

    def __init__(self, sigma: float) -> None:
        self.sigma = sigma
        self.baseline = math.nan
        self._samples: list[float] = []
        self.score = 0.0
        self.touched = False

    def learn(self, v1: float) -> None:
        """Add an unloaded reading to the baseline."""
        self._samples.append(v1)
        self.baseline = sum(self._samples) / len(self._samples)

    def update(self, v1: float) -> bool:
        """Take a reading; True once the drop is significant (latched)."""
        if not self.touched:
            drop = (self.baseline - v1) / self.sigma
            self.score = max(0.0, self.score + drop - CUSUM_DRIFT_SIGMA)
            self.touched = self.score > CUSUM_ALARM_SIGMA
        return self.touched


class MultimodeGrasp:
    """Approach, close to first touch, squeeze, lift with grip following load, hold, place, release.

    Parameters
    ----------
    config : ControllerConfig (``modes`` restricts the modes: ``[1]`` is a single-mode baseline).
    home_lift_m, home_opening_m : the home targets, m.
    pads : instrumented pad names.
    fingertip : the fingertip model the readout is calibrated with.
    pad_area_m2 : the pad's face area, m^2 (design knowledge: grip force = pressure x area).
    self_test_message : None if the element's self-test passed, else its message (the
        controller then refuses to grasp).
    """

    APPROACH_S = 0.1
    SETTLE_S = 0.1

    def __init__(
        self,
        config: ControllerConfig,
        home_lift_m: float,
        home_opening_m: float,
        pads: tuple[str, ...],
        fingertip: Fingertip,
        pad_area_m2: float = 4e-4,
        self_test_message: str | None = None,
    ) -> None:
        self.cfg = config
        self.home_lift_m, self.home_opening_m = home_lift_m, home_opening_m
        self.pads = pads
        self.pad_area_m2 = pad_area_m2
        self.selectors = {pad: ModeSelector(fingertip, config.modes) for pad in pads}
        lowest = min(config.modes)
        self.touch = {pad: TouchDetector(fingertip.sigma(lowest)) for pad in pads}
        highest = max(config.modes)
        self.grip_cap_n = min(100.0, 0.9 * self.selectors[pads[0]].p_max_pa[highest] * pad_area_m2)
        self.phase = "approach"
        self._t_phase = 0.0
        self.opening_target = home_opening_m
        self.lift_target = home_lift_m
        self.grip_n = 100.0  # closing: no force guard (see module docstring)
        self.events: list[Event] = []
        self.touch_time_s = math.nan
        self._lift_baseline_n = 0.0
        self._blind = False
        self._held_load_n = 0.0
        self._load_n = 0.0
        self._lift_goal = home_lift_m
        self._last_step = 0.0
        self._last_load = 0.0
        self._steady_load_steps = 0
        self._carried = False
        self._lift_speed = 0.0
        self._last_lift_pos = home_lift_m
        self._empty_count = 0
        self._dt_s = 0.005
        self._saturated_logged: set[str] = set()
        if self_test_message is not None:
            self._fault(0.0, "", "self_test", self_test_message)

    def _object_lost(self, obs: Observation) -> bool:
        """Both fingertips have read no load for ``LOST_S`` seconds."""
        empty = all(sig.estimate.status == "below_detection" and sig.reading.mode == min(self.cfg.modes) for sig in obs.pads.values())
        self._empty_count = self._empty_count + 1 if empty else 0
        return self._empty_count * self._dt_s >= LOST_S

    @property
    def finished(self) -> bool:
        return self.phase in ("done", "fault")

    def _enter(self, phase: str, t: float, why: str = "") -> None:
        self.phase, self._t_phase = phase, t
        self.events.append(Event(t, "", "phase", f"{phase}: {why}" if why else phase))

    def _fault(self, t: float, pad: str, kind: str, message: str) -> None:
        self.events.append(Event(t, pad, kind, message))
        self.phase = "fault"

    def pressure_estimate(self) -> dict[str, float]:
        """Each fingertip's last trusted pressure estimate, Pa."""
        return {pad: sel.estimate_pa for pad, sel in self.selectors.items()}

    def step(self, obs: Observation, dt_s: float) -> Command:
        t, cfg = obs.time_s, self.cfg
        self._dt_s = dt_s
        reasons = []
        modes = {}
        # Readout: check range, choose each fingertip's mode.
        for pad, sig in obs.pads.items():
            sel = self.selectors[pad]
            sigma = self.touch[pad].sigma
            v1 = sig.reading.v1
            if not (-OUT_OF_RANGE_SIGMA * sigma <= v1 <= 1 + OUT_OF_RANGE_SIGMA * sigma) or math.isnan(v1):
                self._fault(t, pad, "out_of_range", f"{pad}: reading {v1!r} outside [0, 1] by more than {OUT_OF_RANGE_SIGMA:g} sigma")
            mode, why = sel.update(sig.estimate)
            if mode != sig.reading.mode:
                self.events.append(Event(t, pad, "mode_switch", str(why)))
            if sel.blind and pad not in self._saturated_logged:
                self._saturated_logged.add(pad)
                self.events.append(Event(t, pad, "saturated", str(why)))
            modes[pad] = mode
            reasons.append((pad, why))
        if self.phase == "fault":
            return Command(self.lift_target, self.home_opening_m, 0.0, modes, "fault", "; ".join(e.message for e in self.events[-1:]))

        if self.phase == "approach":
            for pad, sig in obs.pads.items():
                self.touch[pad].learn(sig.reading.v1)
            if t >= self.APPROACH_S:
                self._enter("close", t)
        elif self.phase == "close":
            self.opening_target = max(0.0, self.opening_target - cfg.closing_speed_m_s * dt_s)
            touched = [self.touch[pad].update(obs.pads[pad].reading.v1) for pad in self.pads]
            if all(touched):
                self.touch_time_s = t
                self.opening_target = obs.opening_m  # stop where the fingers are
                self.grip_n = MIN_GRIP_N
                self._enter("squeeze", t, f"touch on {', '.join(self.pads)} (CUSUM)")
            elif self.opening_target <= 0.0 and obs.opening_m < 0.002:
                self._fault(t, "", "no_object", "closed without feeling a touch")
        elif self.phase == "squeeze":
            self.opening_target = 0.0
            if t - self._t_phase >= self.SETTLE_S:
                self._lift_baseline_n = obs.lift_force_n
                self._enter("lift", t, f"grip {self.grip_n:.2f} N")
        elif self.phase in ("lift", "hold"):
            raw_load = max(obs.lift_force_n - self._lift_baseline_n, 0.0)
            # The load the grip answers to is low-passed: the servo's force spikes while the
            # object accelerates, and the grip ratchets, so a spike would set it for good.
            self._load_n += (raw_load - self._load_n) * min(1.0, dt_s / LOAD_FILTER_S)
            load = self._load_n
            wanted = max(MIN_GRIP_N, SAFETY * load / (2 * MU_DESIGN))
            if wanted > self.grip_cap_n and not self._blind:
                self._blind = True
                self.events.append(
                    Event(
                        t,
                        "",
                        "blind",
                        f"load {load:.1f} N needs {wanted:.1f} N of grip; the fingertip measures up to {self.grip_cap_n:.1f} N",
                    )
                )
            target = min(wanted, self.grip_cap_n)
            # Grip follows the load up, never down while the object is carried: a load that
            # dips as the object accelerates must not loosen the grip (a ratchet).
            self.grip_n = max(self.grip_n, min(target, self.grip_n + GRIP_RATE_N_S * dt_s))
            self._held_load_n = max(self._held_load_n, load)
            if self._object_lost(obs):
                self._fault(t, "", "lost", f"both fingertips lost touch during {self.phase} (slip?)")
                return Command(self.lift_target, self.opening_target, self.grip_n, modes, "fault", "object lost")
            if self.phase == "lift":
                top = self.home_lift_m + cfg.lift_height_m
                # Raise only while the grip keeps up with the load: the load grows as the
                # object's weight moves from the table onto the pads, the grip follows it,
                # and the object leaves the table once the grip carries its weight.
                # Never ask the lift for more load than the grip can carry with the design
                # friction: the servo turns a goal step into load at kp N/m.
                # Once the load stops growing with the goal, the object has left the table and
                # raising it further adds no load: full speed.
                # (These use the raw load: the filter's lag would read as "no longer growing".)
                carry = 2 * MU_DESIGN * self.grip_n - raw_load
                if self._last_step > 0 and raw_load - self._last_load < 0.3 * LIFT_SERVO_KP_N_M * self._last_step:
                    self._steady_load_steps += 1
                else:
                    self._steady_load_steps = 0
                # ...and the grip is not at its friction limit (a slipping pad also stops the
                # load from growing, at load = 2 mu grip, where carry is spent).
                airborne = self._carried or (self._steady_load_steps >= 3 and carry > 0.2 * raw_load)
                # Speed up gently (LIFT_ACCEL_M_S2): an abrupt start loads the pads with m a on
                # top of m g, and the grip, which ratchets, would keep that peak for good.
                if airborne:
                    self._lift_speed = min(cfg.lift_speed_m_s, self._lift_speed + LIFT_ACCEL_M_S2 * dt_s)
                full = (self._lift_speed if airborne else cfg.lift_speed_m_s) * dt_s
                step = full if airborne else min(full, max(carry, 0.0) / LIFT_SERVO_KP_N_M)
                self._lift_goal = min(top, self._lift_goal + step)
                self._last_step, self._last_load = step, raw_load
                # The lift servo sags by load / kp under a carried object (the robot knows its
                # gain); while the object still rests on the table that offset would only pull
                # harder on the pads, so it waits until the object is carried.
                self._carried = self._carried or airborne
                self.lift_target = self._lift_goal + (load / LIFT_SERVO_KP_N_M if self._carried else 0.0)
                moving = abs(obs.lift_pos_m - self._last_lift_pos) > 1e-4
                if self._lift_goal >= top and abs(obs.lift_pos_m - top) < 0.002 and not moving:
                    self._enter("hold", t)
            elif t - self._t_phase >= cfg.hold_s:
                self._enter("place", t)
        elif self.phase == "place":
            self._lift_goal = max(self.home_lift_m, self._lift_goal - cfg.lift_speed_m_s * dt_s)
            self.lift_target = self._lift_goal
            load = obs.lift_force_n - self._lift_baseline_n
            # The table takes the object's weight: the load falls, or the lift is home.
            on_table = load < 0.5 * self._held_load_n
            if on_table or (self.lift_target <= self.home_lift_m and abs(obs.lift_pos_m - self.home_lift_m) < 0.002):
                self._enter("release", t, f"load {load:.2f} N (held {self._held_load_n:.2f} N)")
        elif self.phase == "release":
            self.opening_target = self.home_opening_m
            self.grip_n = 100.0
            if obs.opening_m > self.home_opening_m - 0.005:
                self._enter("done", t)
        self._last_lift_pos = obs.lift_pos_m
        return make_command(self.lift_target, self.opening_target, self.grip_n, modes, self.phase, Why.join(reasons))
