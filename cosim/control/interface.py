"""What a grasp controller sees and commands, and the interface the co-simulation loop calls.

A controller sees only what a real robot has (:class:`Observation`): the fingertip readouts
(mode, reading, the readout's pressure estimate and its status) and the robot's own joints
(positions, the lift's velocity, actuator forces) and its own design (:class:`RobotLimits`).
Never the object's mass, pose or contact forces.  It returns a :class:`Command`: the lift and
finger targets, the fingers' force limit, the mode each fingertip drives, and why.
"""

from __future__ import annotations

import bisect
from dataclasses import dataclass, field
from typing import Protocol, runtime_checkable

from piezotip.sensor.estimator import Estimate
from piezotip.sensor.resonator import Reading

from .phases import Phase


@dataclass(frozen=True, slots=True)
class PadSignal:
    """One fingertip as the controller sees it: the raw reading and the readout's estimate."""

    reading: Reading
    estimate: Estimate


@dataclass(frozen=True, slots=True)
class Observation:
    """Everything the controller may use at one control step.

    Attributes
    ----------
    time_s : time since the start, s.
    pads : per instrumented pad name ("left_pad", ...), its :class:`PadSignal`.
    lift_pos_m : lift joint position, m.
    opening_m : opening between the unloaded pad surfaces, m (finger joints).
    lift_force_n : the lift actuator's reported force, N (positive up).  Under MuJoCo's
        ``discrete`` integrator it is off by about kp h v while the lift moves; the multimode
        controller reads the load from its servo law instead (:meth:`RobotLimits.lift_load_n`).
    grip_force_n : the fingers actuator's squeeze on each finger, N (positive = squeezing).
    lift_vel_m_s : lift joint velocity, m/s (the joint's encoder).
    """

    time_s: float
    pads: dict[str, PadSignal]
    lift_pos_m: float
    opening_m: float
    lift_force_n: float
    grip_force_n: float
    lift_vel_m_s: float = 0.0


@dataclass(frozen=True, slots=True)
class Command:
    """Actuator targets and fingertip drive modes for the next control period.

    Attributes
    ----------
    lift_m : lift joint target at the end of the next control period, m (the servo interpolates
        toward it over the period, as a real servo does between set-points).
    opening_m : finger opening target, m.
    grip_force_limit_n : the fingers' force limit, N per finger (sets the grip on contact).
    modes : per instrumented pad, the mode to drive.
    phase : the controller's phase (a :class:`Phase`; its name with ``str``).
    reason : why this command (and this mode): ``str(reason)`` reads it in words (it may be
        formatted lazily; the controller gives one every step).
    """

    lift_m: float
    opening_m: float
    grip_force_limit_n: float
    modes: dict[str, int] = field(default_factory=dict)
    phase: Phase = Phase.APPROACH
    reason: object = ""


@dataclass(frozen=True)
class Event:
    """Something the controller decided or noticed: time (s), pad, kind, message."""

    time_s: float
    pad: str
    kind: str
    message: str


@dataclass(frozen=True)
class RobotLimits:
    """The gripper's own design, read from the compiled model (never typed again): the house
    gripper's (cosim.scene.robot_limits) or a mounted one's (cosim.gripper_mount).

    Attributes
    ----------
    lift_kp_n_m, lift_kv_n_s_m : the lift position servo's stiffness (N/m) and damping (N s/m).
    lift_force_limit_n : the lift actuator's force limit, N.
    lift_range_m : (low, high) of the lift joint, m.
    finger_force_limit_n : the fingers actuator's force limit, N per finger.
    finger_damping_n_s_m : damping the fingers' drive must overcome to move, on the opening
        tendon, N s/m (joint damping of both fingers plus the servo's kv).
    lift_moving_mass_kg : the mass the lift moves besides the object (the gripper), kg: its
        inertia m a is in the servo's force while the lift accelerates.
    pad_area_m2 : one pad's face, m^2 (grip force = pressure x area for a full-face contact).
    pad_areal_mass_kg_m2 : the pad's gel mass per area of its face, rho h0, kg/m^2: when the
        finger accelerates at a, the gel presses its element with rho h0 a.
    min_load_n : half the weight of the lightest object the gripper is rated for, N: a load
        below it is no object carried.
    pad_travel_m : how far a pad's gel compresses before its housing stops it, m: with an
        object between them the fingers cannot close by more than twice this.
    home_lift_m, home_opening_m : the home targets, m.
    gravity_m_s2 : the magnitude of gravity, m/s^2.
    finger_friction_n : the dry friction the fingers' drive must overcome to move, on the
        opening, N (its joints' frictionloss, each times its speed per opening speed): none on
        the house gripper; a mounted gripper's from its file (cosim/gripper_mount.py).  Like
        ``finger_damping_n_s_m`` it is a force the fingers need to move, which a moving-force
        guard built on the damping alone leaves out.
    finger_mass_kg : the fingers' inertia on the opening, kg: their kinetic energy is
        (1/2) m o'^2 at an opening speed o' (the least along the stroke; 0 where unknown).
    finger_joint_damping_n_s_m : the part of ``finger_damping_n_s_m`` in the fingers' joints,
        N s/m on the opening: what still brakes them when the drive's force is limited (a
        servo's velocity gain is inside its force, which the force limit caps).
    finger_servo_stiffness_n_m : the finger servo's stiffness on the opening, N/m: the force
        per metre its target leads the fingers by, sum_a kp_a (dl_a/do)^2 (the median along a
        mounted drive's path; the house's servo kp); 0 where unknown.  The robot knows its own
        servo: the lead its fingers keep behind a target they have not yet been seen to follow.
    pad_rise_m : (openings, rises), m: how far the pads' centre lies above its height at home
        at each opening (increasing) of the fingers' free closing; a linkage's fingertips swing
        along an arc as they close, so pads that squeeze an object move it, or the lift, with
        them (tests/test_third_party_grippers.py::
        test_robotiqs_pads_swing_down_their_arc_and_the_lift_braking_opens_them).  Empty where
        they do not (slides; the house gripper).
    lift_coupling_kg : (openings, couplings), kg: the fingers' inertia coupling the lift to the
        opening, c = e_lift^T M v (cosim.gripper_drive.opening_inertia_kg): a lift accelerating
        at a pushes the fingers open with -c a, N on the opening.  Empty where it is 0 (slides).
    finger_reach_n : (openings, grips), N per finger: the most grip the fingers' drive gives at
        each opening, its servo's force kp |l - l*| at its closed command within its rating
        (cosim.gripper_drive.GripperDrive.reach_n; Menagerie's Franka hand: 1.75 N at 60 mm, for a
        rating of 50 N).  Empty where it is ``finger_force_limit_n`` at every opening (the
        house gripper; a servo whose stroke runs past the fingers touching).
    """

    lift_kp_n_m: float
    lift_kv_n_s_m: float
    lift_force_limit_n: float
    lift_range_m: tuple[float, float]
    finger_force_limit_n: float
    finger_damping_n_s_m: float
    lift_moving_mass_kg: float
    pad_area_m2: float
    pad_travel_m: float
    pad_areal_mass_kg_m2: float
    min_load_n: float
    home_lift_m: float
    home_opening_m: float
    gravity_m_s2: float
    finger_friction_n: float = 0.0
    finger_mass_kg: float = 0.0
    finger_joint_damping_n_s_m: float = 0.0
    finger_servo_stiffness_n_m: float = 0.0
    pad_rise_m: tuple[tuple[float, ...], tuple[float, ...]] = ((), ())
    lift_coupling_kg: tuple[tuple[float, ...], tuple[float, ...]] = ((), ())
    finger_reach_n: tuple[tuple[float, ...], tuple[float, ...]] = ((), ())

    def pads_height_m(self, lift_pos_m: float, opening_m: float) -> float:
        """The pads' centre height on the lift's scale, m: the lift's position plus the pads' rise
        along their arc at ``opening_m`` (:attr:`pad_rise_m`).  Proprioception: the lift's and
        the fingers' joints."""
        return lift_pos_m + _along_opening(self.pad_rise_m, opening_m)

    def finger_force_limit_at_n(self, opening_m: float) -> float:
        """The most grip the fingers' drive gives at ``opening_m`` (m), N per finger: its rating,
        or less where its servo's reach is less there (:attr:`finger_reach_n`)."""
        if not self.finger_reach_n[0]:
            return self.finger_force_limit_n
        return min(self.finger_force_limit_n, _along_opening(self.finger_reach_n, opening_m))

    def lift_opens_n(self, opening_m: float, lift_accel_m_s2: float) -> float:
        """The force with which the lift's acceleration pushes the fingers open, N on the opening:
        -c a (:attr:`lift_coupling_kg` at ``opening_m``); negative where it closes them."""
        return -_along_opening(self.lift_coupling_kg, opening_m) * lift_accel_m_s2

    def lift_load_n(self, target_m: float, pos_m: float, vel_m_s: float, accel_m_s2: float = 0.0) -> float:
        """The load the lift carries, N: its servo's force kp (target - q) - kv q' less the
        gripper's own inertia m a (all proprioception: the robot knows its servo and its mass)."""
        return self.lift_kp_n_m * (target_m - pos_m) - self.lift_kv_n_s_m * vel_m_s - self.lift_moving_mass_kg * accel_m_s2


def _along_opening(table: tuple[tuple[float, ...], tuple[float, ...]], opening_m: float) -> float:
    """A (openings, values) table of :class:`RobotLimits` at ``opening_m``: linear between its
    points, held at its ends; 0 for an empty table."""
    openings, values = table
    if not openings:
        return 0.0
    i = bisect.bisect_left(openings, opening_m)
    if i == 0:
        return values[0]
    if i == len(openings):
        return values[-1]
    o0, o1 = openings[i - 1], openings[i]
    return values[i - 1] + (values[i] - values[i - 1]) * (opening_m - o0) / (o1 - o0)


def pad_names(sensor_pads: tuple[str, ...]) -> tuple[str, ...]:
    """The instrumented pads' names as observations key them (``sensor.pads`` "left" -> "left_pad")."""
    return tuple(f"{pad}_pad" for pad in sensor_pads)


@runtime_checkable
class Controller(Protocol):
    """What the co-simulation loop calls, once per control period.

    A registered controller class (:func:`piezotip.controllers.register`) is also built by the
    loop with ``from_scenario(config, robot, fingertip)``: the scenario's whole config (its own in
    ``config.controller``), the robot's :class:`RobotLimits` and the fingertip model the readout
    is calibrated with."""

    phase: Phase
    events: list[Event]

    def step(self, obs: Observation, dt_s: float) -> Command:
        """The command for the next control period."""
        ...

    @property
    def finished(self) -> bool:
        """True once the controller has nothing more to do (done, or gave up / faulted)."""
        ...


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
        return cls(None, *pairs)
