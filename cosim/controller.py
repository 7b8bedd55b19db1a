"""What a grasp controller sees and commands, and the scripted grasp that exercises the loop.

A controller sees only what a real robot has (:class:`Observation`): the fingertip
readouts (mode, reading, the readout's pressure estimate and its status) and the robot's own
joint positions and actuator forces.  Never the object's mass, pose or contact forces.
It returns a :class:`Command`: the lift and finger targets, the fingers' force limit, the
mode each fingertip drives, and why.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from scenarios.config import ControllerConfig
from sensor.channel import Estimate, Reading


@dataclass(frozen=True)
class PadSignal:
    """One fingertip as the controller sees it: the raw reading and the readout's estimate."""

    reading: Reading
    estimate: Estimate


@dataclass(frozen=True)
class Observation:
    """Everything the controller may use at one control step.

    Attributes
    ----------
    time_s : time since the start, s.
    pads : per instrumented pad name ("left_pad", ...), its :class:`PadSignal`.
    lift_pos_m : lift joint position, m.
    opening_m : opening between the unloaded pad surfaces, m (finger joints).
    lift_force_n : the lift actuator's force, N (positive up).
    grip_force_n : the fingers actuator's squeeze on each finger, N (positive = squeezing).
    """

    time_s: float
    pads: dict[str, PadSignal]
    lift_pos_m: float
    opening_m: float
    lift_force_n: float
    grip_force_n: float


@dataclass(frozen=True)
class Command:
    """Actuator targets and fingertip drive modes for the next control period.

    Attributes
    ----------
    lift_m : lift joint target, m.
    opening_m : finger opening target, m.
    grip_force_limit_n : the fingers' force limit, N per finger (sets the grip on contact).
    modes : per instrumented pad, the mode to drive.
    phase : the controller's phase ("approach", "close", ...).
    reason : why this command (and this mode): ``str(reason)`` reads it in words (it may be
        formatted lazily; the controller gives one every step).
    """

    lift_m: float
    opening_m: float
    grip_force_limit_n: float
    modes: dict[str, int] = field(default_factory=dict)
    phase: str = ""
    reason: object = ""


_new = object.__new__


def make_pad_signal(reading: Reading, estimate: Estimate) -> PadSignal:
    """``PadSignal(reading, estimate)`` for the per-step path: a frozen dataclass's __init__
    sets each field through object.__setattr__; this fills the instance's dict at once (the
    result is an ordinary, equal, frozen instance; tests check it)."""
    s = _new(PadSignal)
    s.__dict__.update(reading=reading, estimate=estimate)
    return s


def make_observation(time_s, pads, lift_pos_m, opening_m, lift_force_n, grip_force_n) -> Observation:
    """``Observation(...)`` for the per-step path (see :func:`make_pad_signal`)."""
    o = _new(Observation)
    o.__dict__.update(
        time_s=time_s, pads=pads, lift_pos_m=lift_pos_m, opening_m=opening_m, lift_force_n=lift_force_n, grip_force_n=grip_force_n
    )
    return o


def make_command(lift_m, opening_m, grip_force_limit_n, modes, phase, reason) -> Command:
    """``Command(...)`` for the per-step path (see :func:`make_pad_signal`)."""
    c = _new(Command)
    c.__dict__.update(lift_m=lift_m, opening_m=opening_m, grip_force_limit_n=grip_force_limit_n, modes=modes, phase=phase, reason=reason)
    return c


#: Phase names, in order; recorded as their index.
PHASES = ("approach", "close", "squeeze", "lift", "hold", "place", "release", "done", "fault")


class ScriptedGrasp:
    """Approach, close, lift, hold with fixed targets: a grasp that needs no sensing.

    The fingers close at ``closing_speed_m_s`` toward a closed target with the force limit
    ``grip_force_n``; contact is taken from proprioception (the fingers stop following the
    ramp); after a short settle the object is lifted at ``lift_speed_m_s`` by
    ``lift_height_m`` and held for ``hold_s``.  The fingertips stay in their first mode.
    """

    APPROACH_S = 0.1
    SETTLE_S = 0.3

    def __init__(self, config: ControllerConfig, home_lift_m: float, home_opening_m: float, pads: tuple[str, ...]) -> None:
        self.cfg = config
        self.home_lift_m = home_lift_m
        self.home_opening_m = home_opening_m
        self.pads = pads
        self.phase = "approach"
        self._t_phase = 0.0
        self._target_opening = home_opening_m
        self._lift_target = home_lift_m

    def _enter(self, phase: str, t: float) -> None:
        self.phase, self._t_phase = phase, t

    def step(self, obs: Observation, dt_s: float) -> Command:
        cfg, t = self.cfg, obs.time_s
        reason = ""
        if self.phase == "approach" and t >= self.APPROACH_S:
            self._enter("close", t)
        if self.phase == "close":
            self._target_opening = max(0.0, self._target_opening - cfg.closing_speed_m_s * dt_s)
            # The fingers lag the ramp by more than 3 mm: they are held by the object.
            if obs.opening_m - self._target_opening > 0.003:
                self._enter("squeeze", t)
                reason = f"contact: opening {1e3 * obs.opening_m:.1f} mm stopped following the ramp"
        if self.phase in ("squeeze", "lift", "hold"):
            self._target_opening = 0.0  # squeeze at the force limit
        if self.phase == "squeeze" and t - self._t_phase >= self.SETTLE_S:
            self._enter("lift", t)
        if self.phase == "lift":
            self._lift_target = min(self.home_lift_m + cfg.lift_height_m, self._lift_target + cfg.lift_speed_m_s * dt_s)
            if self._lift_target >= self.home_lift_m + cfg.lift_height_m and abs(obs.lift_pos_m - self._lift_target) < 0.002:
                self._enter("hold", t)
        if self.phase == "hold" and t - self._t_phase >= cfg.hold_s:
            self._enter("done", t)
        modes = {pad: cfg.modes[0] for pad in self.pads}
        return Command(self._lift_target, self._target_opening, cfg.grip_force_n, modes, self.phase, reason or f"scripted {self.phase}")

    @property
    def finished(self) -> bool:
        return self.phase == "done"


def phase_index(phase: str) -> int:
    """The recorded code of ``phase`` (its index in PHASES)."""
    return PHASES.index(phase)


__all__ = ["PHASES", "Command", "Observation", "PadSignal", "ScriptedGrasp", "phase_index"]
