"""Creep against sliding: does a held object stay put in the pads?  (issue 29, item 3)

What is measured (:func:`measure_creep`): an object is gripped with a FIXED grip,
``grip_factor`` times the grip its weight needs, m g / (2 mu) per finger (two pads, friction mu
each), lifted and held.  During the hold the object's position relative to the pads is read
from the ground truth: its centre's x and y, and its z less the lift joint's position (the pads
ride on the lift and move only along x, closing).  Its change over the hold, divided by the
hold's duration, is the creep (mm/s).  At 1.2x the needed grip a physics in which a held object
stays put lets it move by at most :data:`CREEP_LIMIT_MM_S`; at 0.8x the friction cannot carry
the weight and the object must slide (out of the pads, or the pads up it on the table).

The run goes through the project's own co-simulation (:class:`piezotip.cosim.loop.CoSimulation`:
the gel pads' law, the servos' interpolation, the sensors, as in every run), with its
controller replaced by :class:`FixedGripHarness`, a measurement rig that knows the object's
width.  Why not the scripted controller (``controller.kind=scripted``): it closes toward
opening 0 with the force limit at the grip and calls a contact when the fingers lag its
20 mm/s ramp by 3 mm.  The saturated finger servo moves the fingers against their drive's
damping (10 N s/m on the opening: each finger joint's 20 N s/m; MuJoCo 4 drops a saturated
servo's kv) at grip / 10 N s/m, so below about 0.2 N they cannot keep that pace: with the
5.9 mN a 1 g object needs at 1.2x they move at 0.6 mm/s, "contact" is called 0.15 s into the
close with the pads still some 60 mm apart, and the lift leaves the object on the table.  The
harness closes by position at a pace its force allows, stops the pads on the object's faces
(no force), and only then sets the fixed grip.

Contact-model variants (:data:`CONTACT_VARIANTS`) are written into the compiled model after the
scene is built: "current" (models/gripper.xml as it is) and "hard" (the pad contacts at MuJoCo's
maximum impedance from first touch, the model before: ``physics.pad_contact=hard``).  The variants
tried on the hard model (noslip, impratio 10, over-damped pad contacts, ...) are in
models/README.md.  Each run's cost is its wall time per simulated second;
:func:`creep_grid` runs the variants side by side in one process and gives each its ratio to
"current" on the same object and grip.

What crept with the hard pad contact (``physics.pad_contact=hard``), and why (measured with this
module; the numbers are the grid's, 1 s holds).  The ramped pad contact of models/gripper.xml
holds all 92 objects within the limit (worst 0.05 mm/s); these notes say why the hard one did not:

* Light point contacts (sphere and egg of 1 g, mu 1 and 1.5, 2.4-2.8 mm/s): not friction creep
  but a contact chatter that ratchets the object down.  The pad contacts are hard (solimp 0.9999),
  so a held contact sits nanometres deep; when the object slips, MuJoCo's convex contact model
  gives the sliding contact a separating normal velocity (about mu times the slip speed), which
  opens it for a whole step.  The object then falls freely for 1 ms, and the gel strip (0.6 g,
  preloaded by the grip) springs about 5 um into it; the re-impact saturates friction, the object
  slips again: a cycle of about 10 ms that moves it 25 um each time.  Heavier objects and smaller
  mu have deeper contacts under a larger grip and do not cycle.  Torsion and rolling play no part
  (the sphere does not turn: condim 4 and 6 change nothing).  Over-damping the normal rows
  (solref "0.002 1.5") stops an established cycle within 0.5 s; a 0.5 ms timestep also stops it.
* The upright cylinder (25 g, mu 1, 2.3 mm/s): a friction-driven sway-and-rock oscillation at
  about 77 Hz (it dies within 0.2 s when gravity is switched off).  The cylinder's side is a line
  on flat strips that cannot tilt; a tilt of under 1 mrad moves each strip's load between its two
  end contacts and lets a strip lose contact for steps at a time (30 % of the hold's steps), and a
  released strip springs 40-130 um into the object.  It is chaotic: whether a cylinder cycles
  changes with any setting (timestep, pad resolution, gel update, mass), so no contact option
  removes it everywhere; dampratio 1.5 passes the grid's cylinders but an off-grid 50 g cylinder
  at mu 1.2 still creeps 2.4 mm/s.
* Heavy objects creep slowly (up to 0.07 mm/s: 8 kg at mu 1.5): the soft friction rows' residual
  slip, the same under every damping ratio (friction rows have no stiffness term).
"""

from __future__ import annotations

import dataclasses
import functools
import math
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass

from piezotip.analysis.referee import needed_grip_n  # m g / (2 mu) per finger: the grip the creep is measured against
from piezotip.cosim.control import Command, Event, Observation, Phase, RobotLimits
from piezotip.cosim.pad_model import pad_geom_ids

#: The requirement (issue 29): at 1.2x the needed grip, at most this much motion per second of hold, mm/s.
CREEP_LIMIT_MM_S = 0.1
#: A held object moved by more than this relative to the pads has slid, mm (analysis.referee's "slipped").
SLID_MM = 5.0
#: The grip factors the requirement names: holds with creep only, and must slide.
GRIP_FACTORS = (1.2, 0.8)
#: The grid spanning the gripper's rating (1 g to 10 kg, friction 0.05-2: scenarios/config.py).
MASSES_KG = (0.001, 0.003, 0.025, 0.1, 1.0, 8.0)
FRICTIONS = (0.2, 0.5, 1.0, 1.5)
SHAPES = ("box", "sphere", "egg", "cylinder")
#: The small grid of ``run_sim.py creep --quick`` (and the tests): a light and a medium object.
QUICK = {"masses_kg": (0.003, 0.1), "frictions": (1.0,), "shapes": ("box",), "hold_s": 0.3}

#: The contact-model variants, each a set of changes to the grasp scene as models/ builds it:
#:
#: * a key of ``MjOption`` (``impratio``, ``noslip_iterations``, ``cone``: 0 pyramidal, 1 elliptic)
#:   is written into the compiled model's ``opt``;
#: * ``enable``, ``disable``: names of ``<option><flag>`` switches turned on (``speculative``, ...) or
#:   off (``multiccd``, ``nativeccd``, ...);
#: * ``pad_dampratio``: the pad contacts' solref damping ratio (their time constant stays the one
#:   the build gives them, 2 ms or 2 timesteps);
#: * ``pad_<attribute>`` (``pad_condim``, ``pad_solref``, ``pad_solimp``, ``pad_friction``,
#:   ``pad_margin``) is written into every pad strip's geom (class ``pad`` has priority, so its
#:   values are the pad-object contacts');
#: * ``set``: scenario settings (``--set`` assignments) the scene is built with, such as a timestep.
#:
#: hard: ``physics.pad_contact=hard`` (cosim.pad_model.apply_pad_contact), MuJoCo's maximum
#: impedance from first touch and impratio 1, the model before the ramped pad contact (its sliding
#: pads chatter, :func:`sliding_chatter`, and light point contacts ratchet down: the module's notes).
CONTACT_VARIANTS: dict[str, dict[str, object]] = {
    "current": {},
    "hard": {"set": ("physics.pad_contact=hard",)},
}

#: Object widths across the fingers by mass, m: (mass up to, kg; width, m), everyday objects of
#: the catalogue (scenarios/objects.py: a 3 g paperboard cube 20 mm, the 100 g box 40 mm, a 2 kg
#: block 60 mm, the 10 kg block 80 mm).
_WIDTHS = ((0.005, 0.02), (0.05, 0.03), (0.2, 0.04), (2.0, 0.06), (math.inf, 0.08))


def default_size_m(mass_kg: float) -> float:
    """The object's width across the fingers for its mass, m (:data:`_WIDTHS`)."""
    return next(width for upto, width in _WIDTHS if mass_kg <= upto)


@functools.cache
def finger_force_limit_n() -> float:
    """The fingers' force limit per finger, N, as the compiled model has it (models/gripper.xml)."""
    from piezotip import scenarios
    from piezotip.cosim.assembly import build_scene
    from piezotip.cosim.scene import finger_force_limit_n

    return finger_force_limit_n(build_scene(scenarios.get("grasp")))


# ---------------------------------------------------------------------------------------
# The measurement rig.
# ---------------------------------------------------------------------------------------


def ramp_m(t_s: float, distance_m: float, speed_m_s: float, accel_m_s2: float) -> float:
    """How far a trapezoidal move (accelerate, cruise, brake) of ``distance_m`` has gone at t, m."""
    t_acc = min(speed_m_s / accel_m_s2, math.sqrt(distance_m / accel_m_s2))
    v = accel_m_s2 * t_acc
    d_acc = 0.5 * accel_m_s2 * t_acc**2
    t_cruise = (distance_m - 2 * d_acc) / v
    total = 2 * t_acc + t_cruise
    if t_s <= 0:
        return 0.0
    if t_s < t_acc:
        return 0.5 * accel_m_s2 * t_s**2
    if t_s < t_acc + t_cruise:
        return d_acc + v * (t_s - t_acc)
    if t_s < total:
        return distance_m - 0.5 * accel_m_s2 * (total - t_s) ** 2
    return distance_m


def ramp_duration_s(distance_m: float, speed_m_s: float, accel_m_s2: float) -> float:
    """The duration of :func:`ramp_m`'s move, s."""
    t_acc = min(speed_m_s / accel_m_s2, math.sqrt(distance_m / accel_m_s2))
    v = accel_m_s2 * t_acc
    return 2 * t_acc + (distance_m - v * t_acc) / v


class FixedGripHarness:
    """A measurement rig (not a grasp controller): close onto the object, grip it with a fixed
    force, lift it gently and hold it.  It knows the object's width (a rig does); it follows the
    :class:`piezotip.cosim.control.Controller` protocol, so the co-simulation loop runs it.

    * close: the opening's target ramps from home to the object's width at ``closing_speed_m_s``,
      the force limit what the drive's damping needs at that pace (x 1.5, as the multimode
      controller's ``drive_margin``), so the servo follows the ramp and the pads stop on the
      object's faces with no force; then ``close_settle_s`` to come to rest;
    * squeeze: the force limit is the fixed grip, the target far inside the object (opening 0),
      so the servo pushes with exactly the grip; ``settle_s`` for the gel to settle;
    * lift: the lift's target moves by ``lift_height_m`` with a trapezoidal profile
      (``lift_accel_m_s2``: 0.5 m/s^2 adds 5 % of g to the weight, inside the 20 % margin of
      1.2x; a stepped speed would jerk the object at tens of m/s^2);
    * hold: ``settle_s`` for the lift servo to settle, then ``hold_s`` measured; then done.

    ``lift_grip_n`` (default: ``grip_n``) is the grip until the measured hold begins: a grip
    below the weight's need cannot lift the object, so to see a HELD object slide it is lifted
    with more and the grip dropped to ``grip_n`` in the air.
    """

    def __init__(
        self,
        robot: RobotLimits,
        width_m: float,
        grip_n: float,
        lift_height_m: float = 0.01,
        hold_s: float = 1.0,
        settle_s: float = 0.2,
        closing_speed_m_s: float = 0.1,
        lift_speed_m_s: float = 0.05,
        lift_accel_m_s2: float = 0.5,
        close_settle_s: float = 0.05,
        lift_grip_n: float | None = None,
    ) -> None:
        self.robot, self.width_m, self.grip_n = robot, width_m, grip_n
        self.lift_grip_n = grip_n if lift_grip_n is None else lift_grip_n
        self.lift_height_m, self.hold_s, self.settle_s = lift_height_m, hold_s, settle_s
        self.lift_speed_m_s, self.lift_accel_m_s2 = lift_speed_m_s, lift_accel_m_s2
        close_m = robot.home_opening_m - width_m
        self._close_s = close_m / closing_speed_m_s + close_settle_s
        self._closing_speed_m_s = closing_speed_m_s
        self._move_force_n = 1.5 * robot.finger_damping_n_s_m * closing_speed_m_s
        self._lift_s = ramp_duration_s(lift_height_m, lift_speed_m_s, lift_accel_m_s2)
        self.phase = Phase.CLOSE
        self.events: list[Event] = []
        self.t_phase_s = self.now_s = 0.0

    def _enter(self, phase: Phase, t_s: float) -> None:
        self.phase, self.t_phase_s = phase, t_s
        self.events.append(Event(t_s, "", "phase", phase.label))

    def step(self, obs: Observation, dt_s: float) -> Command:
        robot, t = self.robot, obs.time_s
        self.now_s = t
        since = t - self.t_phase_s
        if self.phase is Phase.CLOSE and since >= self._close_s:
            self._enter(Phase.SQUEEZE, t)
        elif self.phase is Phase.SQUEEZE and since >= self.settle_s:
            self._enter(Phase.LIFT, t)
        elif self.phase is Phase.LIFT and since >= self._lift_s:
            self._enter(Phase.HOLD, t)
        elif self.phase is Phase.HOLD and since >= self.settle_s + self.hold_s - 1e-9:
            self._enter(Phase.DONE, t)
        ahead = t + dt_s - self.t_phase_s  # a command is the target at the next period's end
        lift, opening = robot.home_lift_m, 0.0
        grip = self.grip_n if self.measuring else self.lift_grip_n
        if self.phase is Phase.CLOSE:
            opening = max(self.width_m, robot.home_opening_m - self._closing_speed_m_s * ahead)
            grip = self._move_force_n
        elif self.phase is Phase.LIFT:
            lift += ramp_m(ahead, self.lift_height_m, self.lift_speed_m_s, self.lift_accel_m_s2)
        elif self.phase in (Phase.HOLD, Phase.DONE):
            lift += self.lift_height_m
        return Command(lift, opening, grip, {}, self.phase, f"fixed grip {self.phase.label}")

    @property
    def finished(self) -> bool:
        return self.phase is Phase.DONE

    @property
    def measuring(self) -> bool:
        """Whether the hold's measured window has begun (the lift servo has settled)."""
        return self.phase in (Phase.HOLD, Phase.DONE) and self.now_s - self._hold_from_s >= -1e-9

    @property
    def _hold_from_s(self) -> float:
        return self.t_phase_s + self.settle_s if self.phase is Phase.HOLD else -math.inf


# ---------------------------------------------------------------------------------------
# One measurement.
# ---------------------------------------------------------------------------------------


@dataclass(frozen=True)
class CreepResult:
    """One held-object measurement (:func:`measure_creep`); lengths in mm, times in s.

    Attributes
    ----------
    shape, mass_kg, friction, size_m : the object.
    grip_factor : the grip over the needed one during the measured hold; grip_n that grip
        per finger, N; needed_grip_n = m g / (2 mu), N.
    lift_grip_factor : the grip factor of the close, squeeze and lift (= grip_factor for one
        fixed grip throughout).
    contact : the contact-model variant (:data:`CONTACT_VARIANTS`).
    outcome : "held" (creep within :data:`CREEP_LIMIT_MM_S`), "creeps" (held, but faster),
        "slid" (lifted, then moved more than :data:`SLID_MM` in the pads or fell out),
        "never_lifted" (the pads slid up it: it did not rise by half the lift), "diverged".
    creep_mm_s : the object's motion relative to the pads over the measured hold (the norm of
        its x, y and z-less-lift changes) per second of hold, mm/s.
    creep_z_mm_s : its z component (negative: down the pads), mm/s.
    lift_slip_mm : its z relative to the pads, change from before the lift to the hold's
        measured window (negative: slid down during the lift), mm.
    rise_mm : how far the object rose off its resting height at the hold's measured window, mm.
    hold_s : the measured hold's duration, s (shorter when it slid out).
    sim_time_s, wall_time_s : the run's simulated and wall-clock time (the loop only), s.
    physics_wall_s : of which the physics stage (mj_step and the gel's law), s.
    """

    shape: str
    mass_kg: float
    friction: float
    size_m: float
    grip_factor: float
    lift_grip_factor: float
    grip_n: float
    needed_grip_n: float
    contact: str
    outcome: str
    creep_mm_s: float
    creep_z_mm_s: float
    lift_slip_mm: float
    rise_mm: float
    hold_s: float
    sim_time_s: float
    wall_time_s: float
    physics_wall_s: float

    @property
    def stays_held(self) -> bool:
        """Held with at most :data:`CREEP_LIMIT_MM_S` of creep."""
        return self.outcome == "held"

    @property
    def wall_s_per_sim_s(self) -> float:
        return self.wall_time_s / self.sim_time_s if self.sim_time_s > 0 else math.nan

    def as_dict(self) -> dict:
        return {**dataclasses.asdict(self), "wall_s_per_sim_s": self.wall_s_per_sim_s}


def _variant(contact: str) -> dict[str, object]:
    if contact not in CONTACT_VARIANTS:
        raise ValueError(f"unknown contact variant {contact!r}; valid: {', '.join(CONTACT_VARIANTS)}")
    return CONTACT_VARIANTS[contact]


def variant_settings(contact: str) -> tuple[str, ...]:
    """The scenario settings the variant builds its scene with (its ``set`` entry)."""
    return tuple(_variant(contact).get("set", ()))


def apply_contact(model, contact: str) -> None:
    """Write the variant's options, flags and pad-geom parameters into the compiled model
    (:data:`CONTACT_VARIANTS`; its ``set`` entry is for the scene's build: :func:`variant_settings`)."""
    import mujoco

    variant = _variant(contact)  # an unknown name fails before the model is touched
    pad_geoms = pad_geom_ids(model)
    for name, value in variant.items():
        if name == "set":
            continue
        if name == "enable":
            for flag in value:
                model.opt.enableflags |= int(getattr(mujoco.mjtEnableBit, f"mjENBL_{flag.upper()}"))
        elif name == "disable":
            for flag in value:
                model.opt.disableflags |= int(getattr(mujoco.mjtDisableBit, f"mjDSBL_{flag.upper()}"))
        elif name == "pad_dampratio":
            model.geom_solref[pad_geoms, 1] = value
        elif name.startswith("pad_"):
            field = getattr(model, f"geom_{name.removeprefix('pad_')}")
            if field.ndim == 1:
                field[pad_geoms] = value
            else:
                field[pad_geoms, : len(value)] = value
        else:
            setattr(model.opt, name, value)


def _simulation(shape: str, mass_kg: float, friction: float, size_m: float, overrides: Iterable[str]):
    """The co-simulation of the grasp scene with this object (its own controller is replaced)."""
    from piezotip import scenarios
    from piezotip.cosim.loop import CoSimulation

    settings = [
        "controller.kind=scripted",  # the cheapest controller to build; the harness replaces it
        f"object.shape={shape}",
        f"object.mass_kg={mass_kg!r}",
        f"object.friction={friction!r}",
        f"object.size_m={size_m!r}",
        *overrides,
    ]
    return CoSimulation(scenarios.get("grasp", settings))


class _Timer:
    """Wraps the physics stage (CoSimulation.wrap_stages) and sums its wall time."""

    def __init__(self) -> None:
        self.total_s = 0.0

    def wrap(self, stage: str, method: Callable) -> Callable:
        if stage != "physics":
            return method

        def timed(*args, **kwargs):
            start = time.perf_counter()
            try:
                return method(*args, **kwargs)
            finally:
                self.total_s += time.perf_counter() - start

        return timed


def _relative_mm(sim) -> tuple[float, float, float]:
    """The object's centre relative to the pads: x, y and z less the lift's position, mm."""
    x, y, z = sim.data.xpos[sim.model.body("object").id]
    return 1e3 * float(x), 1e3 * float(y), 1e3 * (float(z) - float(sim.data.qpos[sim._lift_q]))


def measure_creep(
    shape: str,
    mass_kg: float,
    friction: float,
    grip_factor: float,
    contact: str = "current",
    size_m: float | None = None,
    hold_s: float = 1.0,
    settle_s: float = 0.2,
    lift_height_m: float = 0.01,
    overrides: Iterable[str] = (),
    lift_grip_factor: float | None = None,
) -> CreepResult:
    """Grip an object with a fixed ``grip_factor`` x m g / (2 mu) per finger, lift it
    ``lift_height_m`` and hold it ``hold_s`` (after ``settle_s``); measure its motion relative
    to the pads per second of hold (:class:`CreepResult`).

    ``contact`` names a :data:`CONTACT_VARIANTS` entry, written into the compiled model;
    ``size_m`` is the width across the fingers (default :func:`default_size_m`); ``overrides``
    are further ``--set`` assignments of the scenario (a timestep, a preset's settings).
    ``lift_grip_factor`` (default: ``grip_factor``, one fixed grip throughout) is the grip
    factor of the close, squeeze and lift; the measured hold then runs at ``grip_factor``: with
    1.2 and 0.8, an object lifted with 1.2x has its grip dropped to 0.8x in the air.
    """
    size_m = default_size_m(mass_kg) if size_m is None else size_m
    sim = _simulation(shape, mass_kg, friction, size_m, (*variant_settings(contact), *overrides))
    apply_contact(sim.model, contact)
    gravity = sim.robot.gravity_m_s2
    needed = needed_grip_n(mass_kg, friction, gravity)
    grip = grip_factor * needed
    if grip > sim.robot.finger_force_limit_n:
        raise ValueError(f"a grip of {grip:.3g} N exceeds the fingers' {sim.robot.finger_force_limit_n:g} N force limit")
    lift_grip = grip if lift_grip_factor is None else lift_grip_factor * needed
    if lift_grip > sim.robot.finger_force_limit_n:
        raise ValueError(f"a lift grip of {lift_grip:.3g} N exceeds the fingers' {sim.robot.finger_force_limit_n:g} N force limit")
    harness = FixedGripHarness(sim.robot, size_m, grip, lift_height_m, hold_s, settle_s, lift_grip_n=lift_grip)
    sim.controller = harness  # the loop calls whatever controller it holds
    timer = _Timer()
    sim.wrap_stages(timer.wrap)
    run = _run(sim, harness)
    return CreepResult(
        shape=shape,
        mass_kg=mass_kg,
        friction=friction,
        size_m=size_m,
        grip_factor=grip_factor,
        lift_grip_factor=grip_factor if lift_grip_factor is None else lift_grip_factor,
        grip_n=grip,
        needed_grip_n=needed,
        contact=contact,
        sim_time_s=sim.time_s,
        physics_wall_s=timer.total_s,
        **run,
    )


def _run(sim, harness: FixedGripHarness) -> dict:
    """Step the simulation through the harness's phases; the measured numbers and the outcome."""
    from piezotip.cosim.loop import SimulationDiverged

    body = sim.model.body("object").id
    rest_z_mm = 1e3 * float(sim.data.xpos[body][2])
    home_lift_mm = 1e3 * float(sim.data.qpos[sim._lift_q])
    rise_mm = math.nan
    before_lift = start = end = None
    start_t = end_t = math.nan
    outcome = None
    wall_start = time.perf_counter()
    try:
        while not harness.finished:
            sim.advance()
            if harness.phase is Phase.SQUEEZE:
                before_lift = _relative_mm(sim)
            if start is None and harness.measuring:
                start, start_t = _relative_mm(sim), sim.time_s
                rise_mm = 1e3 * float(sim.data.xpos[body][2]) - rest_z_mm
                lift_rise_mm = 1e3 * float(sim.data.qpos[sim._lift_q]) - home_lift_mm  # less the servo's sag
                if rise_mm < 0.5 * lift_rise_mm:
                    outcome = "never_lifted"  # the pads slid up it: nothing to hold
                    break
            if start is not None:
                end, end_t = _relative_mm(sim), sim.time_s
                if math.dist(start, end) > SLID_MM:
                    outcome = "slid"
                    break
    except SimulationDiverged:
        outcome = "diverged"
    wall = time.perf_counter() - wall_start
    hold = end_t - start_t if end is not None else 0.0
    if start is None or hold <= 0:
        return _numbers(outcome or "never_lifted", math.nan, math.nan, math.nan, rise_mm, 0.0, wall)
    moved = [b - a for a, b in zip(start, end, strict=True)]
    creep = math.hypot(*moved) / hold
    lift_slip = start[2] - before_lift[2] if before_lift is not None else math.nan
    if outcome is None:
        outcome = "held" if creep <= CREEP_LIMIT_MM_S else "creeps"
    return _numbers(outcome, creep, moved[2] / hold, lift_slip, rise_mm, hold, wall)


def _numbers(outcome: str, creep: float, creep_z: float, lift_slip: float, rise: float, hold: float, wall: float) -> dict:
    return {
        "outcome": outcome,
        "creep_mm_s": creep,
        "creep_z_mm_s": creep_z,
        "lift_slip_mm": lift_slip,
        "rise_mm": rise,
        "hold_s": hold,
        "wall_time_s": wall,
    }


def sliding_chatter(
    shape: str,
    mass_kg: float,
    friction: float,
    contact: str = "current",
    grip_factor: float = 0.6,
    slide_speed_m_s: float = 0.001,
    size_m: float = 0.04,
    measure_s: float = 0.5,
    overrides: Iterable[str] = (),
) -> float:
    """How much a sliding pad's pressure chatters: the pads grip an object resting on the table
    with ``grip_factor`` x m g / (2 mu) (below 1 they cannot lift it) and the lift pulls them up
    it at ``slide_speed_m_s``; over ``measure_s`` of that slide (after 0.5 s of it), the left
    fingertip's coverage pressure each control period against its running median (21 periods),
    as a relative standard deviation, -.  A smooth slide at a fixed grip gives 0; MuJoCo's hard
    pad contacts give 0.25-0.3 (models/README.md, "Sliding pads")."""
    import numpy as np
    from scipy.ndimage import median_filter

    sim = _simulation(shape, mass_kg, friction, size_m, (*variant_settings(contact), *overrides))
    apply_contact(sim.model, contact)
    grip = grip_factor * needed_grip_n(mass_kg, friction, sim.robot.gravity_m_s2)
    distance_m = slide_speed_m_s * (1.0 + measure_s) + 0.001
    harness = FixedGripHarness(sim.robot, size_m, grip, lift_height_m=distance_m, hold_s=0.1, lift_speed_m_s=slide_speed_m_s)
    sim.controller = harness
    pressures = []
    while not harness.finished and len(pressures) < round(measure_s / sim.dt):
        sim.advance()
        if harness.phase is Phase.LIFT and sim.time_s - harness.t_phase_s > 0.5:
            pressures.append(float(sim.coverage_pressures()[0].mean()))
    p = np.asarray(pressures)
    if p.size < 21 or not np.all(p > 0.0):
        raise RuntimeError(f"the pads did not press the {shape} while sliding ({p.size} periods measured)")
    base = median_filter(p, 21, mode="nearest")
    return float(np.std((p - base) / base))


# ---------------------------------------------------------------------------------------
# The grid, its summary and its table.
# ---------------------------------------------------------------------------------------

#: The grips of each object: (label, hold's grip factor, lift's grip factor or None for the same).
#: "1.2>0.8" lifts with 1.2x and drops the grip to 0.8x in the air: a HELD object must slide.
GRIP_CASES = (("1.2", 1.2, None), ("0.8", 0.8, None), ("1.2>0.8", 0.8, 1.2))


def grid_objects(
    masses_kg: Iterable[float] = MASSES_KG, frictions: Iterable[float] = FRICTIONS, shapes: Iterable[str] = SHAPES
) -> list[tuple[str, float, float]]:
    """(shape, mass, friction) of the grid whose 1.2x grip the fingers can give."""
    limit = finger_force_limit_n()
    return [
        (shape, mass, mu)
        for shape in shapes
        for mass in masses_kg
        for mu in frictions
        if max(GRIP_FACTORS) * needed_grip_n(mass, mu) <= limit
    ]


def creep_grid(
    objects: Iterable[tuple[str, float, float]],
    contacts: Iterable[str] = tuple(CONTACT_VARIANTS),
    hold_s: float = 1.0,
    progress: Callable[[str], None] | None = None,
) -> list[dict]:
    """Every object at every grip of :data:`GRIP_CASES`, under every contact variant, the
    variants side by side (one after another on the same object and grip, in this process).

    Each row is :meth:`CreepResult.as_dict` plus ``grip_case`` (its label), ``cost_ratio``
    (its wall time per simulated second over "current"'s on the same object and grip) and
    ``physics_cost_ratio`` (the same for the physics stage alone).
    """
    contacts = tuple(contacts)
    rows = []
    for shape, mass, mu in objects:
        for label, factor, lift_factor in GRIP_CASES:
            if progress is not None:
                progress(f"{shape} {1e3 * mass:g} g, mu {mu:g}, grip {label}")
            results = {c: measure_creep(shape, mass, mu, factor, c, hold_s=hold_s, lift_grip_factor=lift_factor) for c in contacts}
            base = results.get("current")
            for result in results.values():
                row = {"grip_case": label, **result.as_dict()}
                row["cost_ratio"] = _ratio(result.wall_time_s, result.sim_time_s, base.wall_time_s, base.sim_time_s) if base else math.nan
                row["physics_cost_ratio"] = (
                    _ratio(result.physics_wall_s, result.sim_time_s, base.physics_wall_s, base.sim_time_s) if base else math.nan
                )
                rows.append(row)
    return rows


def _ratio(wall_s: float, sim_s: float, base_wall_s: float, base_sim_s: float) -> float:
    if sim_s <= 0 or base_sim_s <= 0 or base_wall_s <= 0:
        return math.nan
    return (wall_s / sim_s) / (base_wall_s / base_sim_s)


def summarize(rows: list[dict]) -> dict:
    """Per contact variant: the requirement judged over the grid, and the cost.

    ``max_creep_1p2_mm_s``: the largest creep at 1.2x (and which object); ``held_1p2``: how many
    of the objects were held within the limit at 1.2x, of ``objects``; ``slid_0p8`` and
    ``slid_in_air_0p8``: how many did not stay held at 0.8x (fixed grip; lifted at 1.2x then
    dropped); ``meets_requirement``: all of them; ``wall_s_per_sim_s`` and
    ``physics_wall_s_per_sim_s``: totals over the variant's runs; ``cost_ratio`` and
    ``physics_cost_ratio``: those over "current"'s, and the median of the per-run ratios.
    """
    summary = {}
    variants = list(dict.fromkeys(r["contact"] for r in rows))
    for contact in variants:
        mine = [r for r in rows if r["contact"] == contact]
        held = [r for r in mine if r["grip_case"] == "1.2"]
        worst = max(held, key=lambda r: r["creep_mm_s"] if math.isfinite(r["creep_mm_s"]) else math.inf, default=None)
        entry = {
            "objects": len(held),
            "held_1p2": sum(r["outcome"] == "held" for r in held),
            "slid_0p8": sum(r["outcome"] != "held" for r in mine if r["grip_case"] == "0.8"),
            "slid_in_air_0p8": sum(r["outcome"] == "slid" for r in mine if r["grip_case"] == "1.2>0.8"),
            "max_creep_1p2_mm_s": worst["creep_mm_s"] if worst else math.nan,
            "max_creep_object": _object_label(worst) if worst else None,
            "wall_s_per_sim_s": sum(r["wall_time_s"] for r in mine) / sum(r["sim_time_s"] for r in mine),
            "physics_wall_s_per_sim_s": sum(r["physics_wall_s"] for r in mine) / sum(r["sim_time_s"] for r in mine),
            "median_cost_ratio": _median(r["cost_ratio"] for r in mine),
            "median_physics_cost_ratio": _median(r["physics_cost_ratio"] for r in mine),
        }
        entry["meets_requirement"] = entry["held_1p2"] == entry["objects"] == entry["slid_0p8"] == entry["slid_in_air_0p8"]
        summary[contact] = entry
    base = summary.get("current")
    for entry in summary.values():
        entry["cost_ratio"] = entry["wall_s_per_sim_s"] / base["wall_s_per_sim_s"] if base else math.nan
        entry["physics_cost_ratio"] = entry["physics_wall_s_per_sim_s"] / base["physics_wall_s_per_sim_s"] if base else math.nan
    return summary


def _median(values: Iterable[float]) -> float:
    finite = sorted(v for v in values if math.isfinite(v))
    if not finite:
        return math.nan
    mid = len(finite) // 2
    return finite[mid] if len(finite) % 2 else 0.5 * (finite[mid - 1] + finite[mid])


def _object_label(row: dict) -> str:
    return f"{row['shape']} {1e3 * row['mass_kg']:g} g mu {row['friction']:g}"


def creep_report(quick: bool = False, progress: Callable[[str], None] | None = None) -> dict:
    """The measurement over the whole grid (or :data:`QUICK`'s), its summary and its settings."""
    if quick:
        objects = grid_objects(QUICK["masses_kg"], QUICK["frictions"], QUICK["shapes"])
        hold_s = QUICK["hold_s"]
    else:
        objects, hold_s = grid_objects(), 1.0
    rows = creep_grid(objects, hold_s=hold_s, progress=progress)
    return {
        "creep_limit_mm_s": CREEP_LIMIT_MM_S,
        "slid_mm": SLID_MM,
        "hold_s": hold_s,
        "contact_variants": CONTACT_VARIANTS,
        "rows": rows,
        "summary": summarize(rows),
    }


def format_table(report: dict) -> str:
    """The report as text: one line per run, then the summary per contact variant."""
    lines = [
        f"{'object':<26} {'grip':>7} {'grip_n':>9} {'contact':<10} {'creep_mm_s':>11} {'outcome':<12} {'cost_ratio':>10} {'physics':>8}"
    ]
    for r in report["rows"]:
        lines.append(
            f"{_object_label(r):<26} {r['grip_case']:>7} {r['grip_n']:>9.4g} {r['contact']:<10} {r['creep_mm_s']:>11.3g} "
            f"{r['outcome']:<12} {r['cost_ratio']:>10.2f} {r['physics_cost_ratio']:>8.2f}"
        )
    lines.append("")
    limit = report["creep_limit_mm_s"]
    lines.append(f"per contact variant (held: creep <= {limit:g} mm/s at 1.2x; slid: not held at 0.8x):")
    for contact, s in report["summary"].items():
        lines.append(
            f"  {contact:<10} held {s['held_1p2']}/{s['objects']} at 1.2x (max creep {s['max_creep_1p2_mm_s']:.3g} mm/s, "
            f"{s['max_creep_object']}); slid {s['slid_0p8']}/{s['objects']} at 0.8x, {s['slid_in_air_0p8']}/{s['objects']} "
            f"dropped to 0.8x in the air; cost {s['cost_ratio']:.2f}x (physics {s['physics_cost_ratio']:.2f}x); "
            f"{'meets' if s['meets_requirement'] else 'FAILS'} the requirement"
        )
    return "\n".join(lines)
