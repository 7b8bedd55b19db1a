"""Scenario configuration: nested frozen dataclasses with dotted-path overrides.

A scenario's whole configuration is one :class:`ScenarioConfig`.  Any value can be changed
by a dotted key (``object.mass_kg=0.4``, ``controller.modes=[1]``); the value is parsed as
a Python literal (numbers, lists, tuples, booleans, ``None``) or else taken as a string,
then checked against the field's type.  An unknown key gets a short error naming it, the keys
it may have meant ("did you mean ...?") and where the valid ones are listed; a value of the
wrong type or range gets an error naming the key and the value.

Every value is bounded before it is parsed (:data:`MAX_VALUE_CHARS` characters, nested at most
:data:`MAX_VALUE_DEPTH` deep; no mappings or sets), and every field's range is the one the
model is built for, checked in its dataclass's ``validate`` (ranges that depend on other fields,
such as the quality factor's on the control period, in :meth:`ScenarioConfig.validate`): a bad
value is a ValueError naming it before anything is built, never a KeyError or a run that cannot
finish deep inside.
"""

from __future__ import annotations

import ast
import dataclasses
import difflib
import itertools
import math
import re
import types
import typing
from contextlib import contextmanager
from contextvars import ContextVar
from dataclasses import dataclass, field

from .shapes import shape_names

#: The object shapes, in registration order: the registry's (scenarios/shapes.py, where a shape is added).
OBJECT_SHAPES = shape_names()
INTEGRATORS = ("discrete", "implicitfast", "implicit", "Euler", "RK4")
#: The pad contacts (cosim.pad_model.apply_pad_contact; models/README.md, "Sliding pads").
PAD_CONTACTS = ("auto", "compliant", "hard")
SENSOR_DYNAMICS = ("steady", "envelope", "carrier")
LOAD_SPREADS = ("layer", "none")
"""sensor.load_spread: the gel layer spreads a face pressure over the element (sensor/spread.py), or not."""
#: The physics timesteps tested stable with the discrete integrator (tests/test_extremes.py): 0.1 ms
#: (smaller only costs time) to 20 ms (the pads' contact time constant, 2 steps, is then 40 ms).
MIN_TIMESTEP_S = 1e-5
#: The gripper's rated payload, kg: 10 kg is what its 100 N fingers hold at friction 1 with a 2x
#: margin and its 300 N lift raises at 1 g (models/gripper.xml); 1 g is the lightest object the
#: pads' contact model is validated for (the squeeze test, models/README.md).
RATED_MASS_KG = (0.001, 10.0)
#: Friction coefficients the contact model is meant for: from ice on steel (0.05) to rubber (2).
FRICTION_RANGE = (0.05, 2.0)
MAX_TIMESTEP_S = 0.02
#: The longest control period, s: the coarsest tested (tests/test_extremes.py, 20 ms at a 20 ms
#: timestep), and the readout's shortest inference window while a load ramps
#: (sensor.inference.MIN_WINDOW_S, 20 ms) must hold a reading.
MAX_CONTROL_PERIOD_S = 0.02
#: The most control steps a run may record: 40 columns, about 0.3 kB a row, 300 MB of run.npz,
#: whose columns the referee and the plot read whole (8 MB each), 83 minutes at the default 5 ms.
MAX_RECORDED_STEPS = 1_000_000
#: The lowest unloaded quality factor of mode 1: soft PZT, the lossiest piezoceramic an element
#: is made of (Navy type VI / PZT-5H, mechanical Q 50-65).  See SensorConfig.quality_factor.
MIN_QUALITY_FACTOR = 50.0
#: The narrowest gel coverage, mm: the gel's contact edges on the element are moulded to ISO
#: 3302-1 class M2, +-0.10 mm each (sensor.variation.SPREADS["wide"].coverage_edge_m): a strip
#: no wider than the two edges' tolerances together can close altogether.
MIN_COVERAGE_MM = 0.2
#: Seeds (sensor.seed, sensor.unit_seed): non-negative and signed 64-bit, so that a sweep's
#: columns (sweep.parquet, int64) and the recordings hold them exactly.
MAX_SEED = 2**63 - 1
#: The longest a mode switch may wait for its ``persist`` readings, s: a second, longer than any
#: ring-up it waits out (10-45 ms at Q 70, 60-350 ms with Table I's damping) and than a touch's
#: squeeze; past it a pressure change is no longer one switch but a grasp's phase.
MAX_PERSIST_S = 1.0
#: A ``--set`` or ``--grid`` value's longest text, characters (checked before it is parsed).
MAX_VALUE_CHARS = 10_000
#: ...and its deepest nesting of brackets (a config value is at most a list of numbers or texts).
MAX_VALUE_DEPTH = 4
#: ...and of its parsed expression (a list of negative numbers is 3 deep: list, minus, number).
_MAX_EXPRESSION_DEPTH = 3 * MAX_VALUE_DEPTH


#: While set, a section's checks wait (with_overrides sets it while it applies a batch of ``--set``
#: assignments one at a time: physics.timestep_s and physics.control_period_s, or gripper.mjcf and
#: gripper.fingertips, are only consistent together), and run once the batch is applied.
_CHECKS_DEFERRED: ContextVar[bool] = ContextVar("piezotip_checks_deferred", default=False)


@contextmanager
def _deferred_checks():
    token = _CHECKS_DEFERRED.set(True)
    try:
        yield
    finally:
        _CHECKS_DEFERRED.reset(token)


class _CheckedOnConstruction:
    """A config section whose values are checked when it is made (its ``validate``), so that a
    bad value cannot exist, except inside a batch of overrides (:func:`with_overrides`)."""

    def __post_init__(self) -> None:
        if not _CHECKS_DEFERRED.get():
            self.validate()


@dataclass(frozen=True)
class ObjectConfig(_CheckedOnConstruction):
    """The object on the table.

    Attributes
    ----------
    shape : a registered shape (:mod:`scenarios.shapes`, which builds its geom): "box" (a cube),
        "cylinder" (upright, 1.2 diameters tall), "sphere" or "egg" (an ellipsoid lying on its
        side, long axis across the fingers' closing direction).
    mass_kg : mass, kg.
    size_m : width across the fingers (box edge, cylinder or sphere diameter, egg's short
        diameter), m.
    friction : sliding friction coefficient against the pads, dimensionless.
    crush_force_n : for a fragile object, the grip force (per finger) at which it breaks, N;
        None for a robust object.
    """

    shape: str = "box"
    mass_kg: float = 0.1
    size_m: float = 0.04
    friction: float = 1.0
    crush_force_n: float | None = None

    def validate(self) -> None:
        _one_of("object.shape", self.shape, shape_names())  # the registry's now, not only at import
        _positive("object.mass_kg", self.mass_kg)
        _positive("object.size_m", self.size_m)
        if not 0.012 <= self.size_m <= 0.085:
            raise ValueError(f"object.size_m must be within 12-85 mm (the open gripper spans 90 mm), got {self.size_m!r}")
        _positive("object.friction", self.friction)
        lo, hi = RATED_MASS_KG
        if not lo <= self.mass_kg <= hi:
            raise ValueError(f"object.mass_kg must be within the gripper's rated {lo:g}-{hi:g} kg, got {self.mass_kg!r}")
        lo, hi = FRICTION_RANGE
        if not lo <= self.friction <= hi:
            raise ValueError(f"object.friction must be within {lo:g}-{hi:g} (dry contacts, from ice to rubber), got {self.friction!r}")
        if self.crush_force_n is not None:
            _positive("object.crush_force_n", self.crush_force_n)


@dataclass(frozen=True)
class PhysicsConfig(_CheckedOnConstruction):
    """The physics engine's fidelity knobs.

    Attributes
    ----------
    timestep_s : MuJoCo timestep, s.
    integrator : MuJoCo integrator: "discrete" (MuJoCo 4's, implicit in position: the only
        one that integrates the gel's stiff law stably at millisecond steps, models/README.md),
        or "implicitfast", "implicit", "Euler", "RK4" (explicit in the gel's stiffness: the
        pad bridge refuses timesteps past their stability limit, before the run starts).
    pad_segments : pad resolution: gel segments along the element's length (1 = uniform).
    gel_update : "substep" (the gel's law evaluated before every physics step) or "control"
        (linearized once per control period, its tangent applied by MuJoCo at every substep:
        no Python between substeps; its error is measured by the benchmark).
    control_period_s : sensor sample and controller period, s; a whole number of timesteps.
        5 ms (200 Hz): a gripper controller's rate and a lock-in amplifier's output bandwidth;
        the envelope update is exact over any period, so it costs no sensor accuracy.
    pad_contact : "compliant" (models/gripper.xml's pad contacts: their impedance ramped over
        the first 30 um of depth, friction rows stiffened by impratio 100; sliding pads do not
        chatter), "hard" (MuJoCo's maximum impedance from first touch, the model before: sliding
        pads chatter), or "auto": compliant on the house gripper, hard on a ``gripper.mjcf``
        gripper (where it is measured to work; models/README.md); cosim.pad_model.
    """

    timestep_s: float = 0.001
    integrator: str = "discrete"
    pad_segments: int = 1
    control_period_s: float = 0.005
    gel_update: str = "control"
    pad_contact: str = "auto"

    def validate(self) -> None:
        _one_of("physics.gel_update", self.gel_update, ("substep", "control"))
        _one_of("physics.pad_contact", self.pad_contact, PAD_CONTACTS)
        _positive("physics.timestep_s", self.timestep_s)
        if not MIN_TIMESTEP_S <= self.timestep_s <= MAX_TIMESTEP_S:
            raise ValueError(
                f"physics.timestep_s must be within {MIN_TIMESTEP_S:g}-{MAX_TIMESTEP_S:g} s (the range tested stable; "
                f"explicit integrators need far less, checked when the scene is built), got {self.timestep_s!r}"
            )
        _one_of("physics.integrator", self.integrator, INTEGRATORS)
        if not isinstance(self.pad_segments, int) or not 1 <= self.pad_segments <= 64:
            raise ValueError(f"physics.pad_segments must be an integer in 1..64, got {self.pad_segments!r}")
        _positive("physics.control_period_s", self.control_period_s)
        if self.control_period_s > MAX_CONTROL_PERIOD_S:
            raise ValueError(
                f"physics.control_period_s must be at most {MAX_CONTROL_PERIOD_S:g} s (the coarsest tested; the readout's "
                f"shortest inference window), got {self.control_period_s!r}"
            )
        ratio = self.control_period_s / self.timestep_s
        if ratio < 1 - 1e-9 or abs(ratio - round(ratio)) > 1e-6:
            raise ValueError(
                f"physics.control_period_s ({self.control_period_s!r}) must be a whole multiple of physics.timestep_s ({self.timestep_s!r})"
            )

    @property
    def substeps(self) -> int:
        """Physics steps per control period."""
        return round(self.control_period_s / self.timestep_s)


@dataclass(frozen=True)
class SensorConfig(_CheckedOnConstruction):
    """What the fingertips observe, and how faithfully.

    Attributes
    ----------
    pads : instrumented pads ("left", "right"); the others carry gel but no sensor model.
    modes : vibration modes the element can be driven in.
    dynamics : "steady" (output follows the load at once), "envelope" (the resonator's
        amplitude relaxes with tau_n = 2 M_n / C_n; a mode switch rings up), or "carrier"
        (the modal equation integrated through every drive cycle, demodulated).
    quality_factor : unloaded Q of mode 1, or None for Table I's damping (Q ~ 7800, ring-up
        time constant 0.66 s: the paper's numbers).  Soft PZT has Q ~ 70 (physics.md
        section 6): 100x faster ring-up and 100x less sensitivity.  Valid from
        MIN_QUALITY_FACTOR = 50, the lowest Q of any piezoceramic (soft PZT, Navy type VI:
        Q_m 50-65); below it the element's own damping drowns the gel's load on the higher
        modes (P_min ~ 1 / Q), which then resolve nothing below the rated 1 MPa or are nowhere
        the most useful mode (Q 20: mode 4 never; Q 1: only mode 1), and the multimode
        controller has no switch pressures between them.  Up to the Q whose unloaded ring-up
        time constant tau0 = 2 Q / omega_1 = Q / (pi f_1) the readout can still read: it infers
        a reading's steady value from a window W = 0.5 s of readings taken every control period
        dt (sensor.inference), and the noise gain of that inference on an unloaded fingertip is
        tau0 sqrt(192 dt / W^3) (the end-point slope of a least-squares quadratic: 2.8 tau0 / s
        at 5 ms), trusted up to MAX_GAIN = 10: tau0 <= 3.6 s, Q <= 4.3e4 at 5 ms readings
        (checked in ScenarioConfig.validate, where the control period is known).  Beyond, an
        unloaded fingertip never reads trusted, a release or a lost object is never seen, and a
        grasp runs out its time (Q 1e6: tau0 = 84 s).
    gel_frequency_dependent : whether each mode sees its own viscoelastic modulus.
    coverage_mm : gel coverage on the element (x1, x2), mm.  The tip (6.5-7.5 mm) by default:
        the paper's widest-range coverage (2 Pa to 450 kPa with Table I's element), which a
        10 kg grip needs; the whole beam (0-7.5) is 1 Pa to 110 kPa.  At least MIN_COVERAGE_MM
        = 0.2 mm wide: the moulded gel's contact edges hold +-0.10 mm each (ISO 3302-1 M2), so a
        narrower strip is not a dimension the casting makes.  With the multimode controllers the
        coverage must also give each allowed mode a range where it is the most useful and a
        switch pressure up to the next (checked in ScenarioConfig.validate): near the clamped
        root, or in a narrow strip mid-beam, the higher modes bend most and are the most
        sensitive ones, which the mode switching (one mode up as the pressure rises) is not
        built for.
    noise : whether readings carry the readout noise.
    seed : seed of the readout noise (an integer in 0..2**63-1).
    exact_gel : evaluate the gel model exactly every sample (True) or through per-mode
        tables of (k_e, c_e) against pressure (False: 1e-4 relative error, several times faster).
    carrier_samples_per_cycle : carrier samples per drive cycle for the "carrier" dynamics.
    gel_layer : "winkler" (the layer's low-frequency stiffness) or "dynamic" (its dynamic
        stiffness, M k cot(k h): 100-4000x more damping, mass-like k_e; evaluated exactly).
        README "The gel's two layer models" compares them.
    load_spread : how a pressure on the pad's face reaches the element under it: "layer" (the
        gel layer spreads it over about its thickness, Flamant's half-space solution at the
        gel's depth, sensor/spread.py: a contact anywhere near the coverage is felt there, at
        every pad resolution) or "none" (each coverage cell feels only the strip above it:
        with fine strips, a contact beside the coverage is not felt at all).
    damage_stiffness, damage_coupling, damage_damping : injected element damage, factors on
        the healthy stiffness, d31 and damping (sensor.selftest.damaged); the multimode
        controller's start-up self-test must catch them.  Damage lowers the stiffness (a crack)
        and d31 (depolarization), so their factors are in (0, 1]; it raises the damping (a rub),
        by at most the factor that damps mode 1 critically (Q = 1/2: no resonance is left), 2 Q.
    variation : the physical unit: "none" (exactly the nominal model, the default), "typical"
        or "wide" (a unit drawn from manufacturing spreads, sensor.variation; the simulation
        runs it, the readout and controller see only the nominal model plus calibration).
    unit_seed : which unit (an integer in 0..2**63-1: the same seed, the same unit).
    calibration : "none", "self" (the element's own resonance sweep per mode) or "full" (plus
        a known-load bench fit), sensor.calibration; None: "self" for a unit that differs from
        the nominal model (varied, not at 25 C, or drifting), else "none".
    temperature_c : the fingertip's temperature at the start, C (-20 to 80; calibrated at 25).
    temperature_drift_c_per_s : how fast it warms during the run, C/s.
    """

    pads: tuple[str, ...] = ("left", "right")
    modes: tuple[int, ...] = (1, 2, 3, 4)
    dynamics: str = "envelope"
    quality_factor: float | None = None
    gel_frequency_dependent: bool = True
    coverage_mm: tuple[float, float] = (6.5, 7.5)
    noise: bool = True
    seed: int = 0
    damage_stiffness: float = 1.0
    damage_coupling: float = 1.0
    damage_damping: float = 1.0
    exact_gel: bool = False
    carrier_samples_per_cycle: int = 16
    gel_layer: str = "winkler"
    load_spread: str = "layer"
    variation: str = "none"
    unit_seed: int = 0
    calibration: str | None = None
    temperature_c: float = 25.0
    temperature_drift_c_per_s: float = 0.0

    def validate(self) -> None:
        _one_of("sensor.gel_layer", self.gel_layer, ("winkler", "dynamic"))
        _one_of("sensor.load_spread", self.load_spread, LOAD_SPREADS)
        self.unit_config()  # variation, seed, calibration and temperature, each named if bad
        if not isinstance(self.carrier_samples_per_cycle, int) or not 4 <= self.carrier_samples_per_cycle <= 256:
            raise ValueError(f"sensor.carrier_samples_per_cycle must be an integer in 4..256, got {self.carrier_samples_per_cycle!r}")
        for name in ("damage_stiffness", "damage_coupling"):
            value = getattr(self, name)
            if not _is_number(value) or not 0 < value <= 1:
                raise ValueError(f"sensor.{name} must be a factor in (0, 1] (damage lowers it), got {_short(value)}")
        if not _is_number(self.damage_damping) or not 1 <= self.damage_damping < math.inf:
            raise ValueError(f"sensor.damage_damping must be a factor >= 1 (damage raises the damping), got {_short(self.damage_damping)}")
        _seed("sensor.seed", self.seed)
        _seed("sensor.unit_seed", self.unit_seed)
        if not self.pads or len(set(self.pads)) != len(self.pads):
            raise ValueError(f"sensor.pads must name one or both pads (left, right) once each, got {list(self.pads)!r}")
        for pad in self.pads:
            _one_of("sensor.pads", pad, ("left", "right"))
        _modes("sensor.modes", self.modes)
        _one_of("sensor.dynamics", self.dynamics, SENSOR_DYNAMICS)
        if self.quality_factor is not None:
            _positive("sensor.quality_factor", self.quality_factor)
            if self.quality_factor < MIN_QUALITY_FACTOR:
                raise ValueError(
                    f"sensor.quality_factor must be at least {MIN_QUALITY_FACTOR:g} (soft PZT, the lossiest piezoceramic; "
                    f"below it the higher modes resolve nothing and have no switch pressures), got {self.quality_factor!r}"
                )
        if len(self.coverage_mm) != 2 or not 0 <= self.coverage_mm[0] < self.coverage_mm[1] <= 7.5:
            raise ValueError(f"sensor.coverage_mm must be (x1, x2) with 0 <= x1 < x2 <= 7.5, got {_short(self.coverage_mm)}")
        width = self.coverage_mm[1] - self.coverage_mm[0]
        if width < MIN_COVERAGE_MM:
            raise ValueError(
                f"sensor.coverage_mm {self.coverage_mm!r} is {width:.3g} mm wide: at least {MIN_COVERAGE_MM:g} mm "
                "(the moulded gel's contact edges hold +-0.1 mm each)"
            )

    def unit_config(self):
        """The physical unit and its calibration (piezotip.sensor.calibration.UnitConfig), validated."""
        from piezotip.sensor.calibration import UnitConfig

        return UnitConfig(self.variation, self.unit_seed, self.calibration, self.temperature_c, self.temperature_drift_c_per_s)


@dataclass(frozen=True)
class ControllerConfig:
    """What every grasp controller is configured with: which one, the modes it may drive, the task.

    Each registered controller (:mod:`piezotip.controllers`) has its own config class, this one
    or a subclass of it; ``controller.kind`` chooses the controller, and with it the class whose
    fields the other ``controller.*`` keys set.  Every value is checked when the config is made.

    Attributes
    ----------
    kind : the registered controller's name (``piezotip.controllers.names()``: "multimode",
        "gentle", "scripted", the ``piezotip.controllers`` entry points' and any registered by the
        user's own script), or ``MODULE:CLASS``, a controller class imported where it runs.
    modes : the modes the controller may drive (a subset of sensor.modes); ``[1]`` alone
        makes a single-mode baseline of a multimode controller.
    lift_height_m : how far to lift the object, m (the referee judges the lift against it).
    hold_s : how long to hold it up, s (the referee judges the hold against it).
    """

    kind: str
    modes: tuple[int, ...] = (1, 2, 3, 4)
    lift_height_m: float = 0.05
    hold_s: float = 1.0

    def __post_init__(self) -> None:
        self.validate()

    def validate(self) -> None:
        """Every field within its range (a ValueError naming the key and the value otherwise)."""
        if not isinstance(self.kind, str) or not self.kind:
            raise ValueError(f"controller.kind must be a registered controller's name, got {_short(self.kind)}")
        _modes("controller.modes", self.modes)
        _positive("controller.lift_height_m", self.lift_height_m)
        if isinstance(self.hold_s, bool) or not isinstance(self.hold_s, (int, float)) or self.hold_s < 0 or not math.isfinite(self.hold_s):
            raise ValueError(f"controller.hold_s must be non-negative, got {self.hold_s!r}")

    def check_scenario(self, scenario: ScenarioConfig) -> None:
        """The ranges that depend on the rest of the scenario: the modes must be the sensor's."""
        unknown = sorted(set(self.modes) - set(scenario.sensor.modes))
        if unknown:
            raise ValueError(
                f"controller.modes {list(self.modes)} include modes the sensor lacks "
                f"(sensor.modes={list(scenario.sensor.modes)}): {unknown}"
            )


@dataclass(frozen=True)
class MotionConfig(ControllerConfig):
    """The gripper's motions the built-in controllers share (scripted and multimode alike).

    Attributes
    ----------
    closing_speed_m_s : how fast the fingers close, m/s: 0.02, the slowest setting of common
        parallel grippers (20-150 mm/s).  The element feels a touch some 10 ms after contact at
        best (Table I's slow resonator), and the pads press on by about the speed times that
        delay meanwhile: at 20 mm/s a 0.1 N-fragile object survives the touch, at 40 mm/s it
        does not (README, "Grasp experiments").
    opening_speed_m_s : how fast they open on release, m/s (a parallel gripper's tens of mm/s).
    lift_speed_m_s : how fast the object is lifted, m/s.
    touchdown_speed_m_s : the last part of the descent when placing, m/s: a fifth of the
        0.1 m/s at which a landing counts as a drop (analysis.referee), and slow enough that the
        lift servo (kp 2e4 N/m) adds at most kp v dt = 2 N per 5 ms control period once the
        table holds the object, so the table's take-over is seen within a period or two.
    baseline_s : how long the gripper waits, open, before it closes, s: 0.1, twenty readings at
        5 ms, over which the multimode controller averages the unloaded touch baseline (to a
        fifth of a sigma, 1 / sqrt 20).
    drive_margin : the fingers' force limit while they move freely, over what their drive's
        damping needs at the commanded speed, -: 1.5 (they keep pace; a touch before it is felt
        meets no more than that).
    """

    closing_speed_m_s: float = 0.02
    opening_speed_m_s: float = 0.05
    lift_speed_m_s: float = 0.1
    touchdown_speed_m_s: float = 0.02
    baseline_s: float = 0.1
    drive_margin: float = 1.5

    def validate(self) -> None:
        super().validate()
        for name in ("closing_speed_m_s", "opening_speed_m_s", "lift_speed_m_s", "touchdown_speed_m_s", "baseline_s"):
            _positive(f"controller.{name}", getattr(self, name))
        if not (_is_number(self.drive_margin) and self.drive_margin >= 1 and math.isfinite(self.drive_margin)):
            raise ValueError(f"controller.drive_margin must be a number >= 1, got {self.drive_margin!r}")


@dataclass(frozen=True)
class ScriptedConfig(MotionConfig):
    """The scripted grasp's settings (cosim/control/scripted.py: fixed targets, no sensing).

    Attributes
    ----------
    grip_force_n : the grip, N per finger: the fingers' force limit it squeezes with, at most
        the fingers' 100 N (models/gripper.xml).
    """

    kind: str = "scripted"
    grip_force_n: float = 20.0

    def validate(self) -> None:
        super().validate()
        _positive("controller.grip_force_n", self.grip_force_n)
        if self.grip_force_n > 100:
            raise ValueError(f"controller.grip_force_n must be at most the fingers' 100 N force limit, got {self.grip_force_n!r}")


@dataclass(frozen=True)
class MultimodeConfig(MotionConfig):
    """The multimode grasp's settings (cosim/control/multimode.py).  Every number it uses is here,
    with its derivation, or derived there from the fingertip's ranges and the robot's limits.

    Attributes
    ----------
    lift_accel_m_s2 : the lift's acceleration once the object is carried, m/s^2: 0.5 adds 5 %
        of g to the weight, inside the grip's safety margin; it also sets the braking distance
        v^2 / (2 a) above the table at which placing slows to ``touchdown_speed_m_s``.
    touchdown_margin_m : the descent slows to the touchdown speed this far above the lift's
        braking distance over where the object rested, m: an object that crept down in the
        fingers by up to this (a quarter of the 20 mm pad) still lands at the touchdown speed.
    friction_assumed : friction coefficient the grip starts from (the controller never knows
        the object's): 0.8, the low end of a silicone film on dry common objects (0.8-1.2,
        models/gripper.xml).  A lower real friction is measured during the lift (the friction
        check) and used instead; a higher one only means a grip with more margin.
    grip_safety : grip over the friction limit, and the factor a slip raises the grip by:
        1.25, inside the 10-40 % margin people keep (Johansson and Westling 1984, Exp. Brain
        Res. 56).
    grip_floor_n : the first, gentlest grip, N per finger; None derives it from the sensor:
        the lowest pad pressure the lowest allowed mode resolves to 10 % (physics.md section 5's
        criterion), times the pad's area (cosim.control.multimode.grip_floor_n).
    max_grip_n : the most grip the task allows, N per finger (e.g. a fragile object's known
        limit); None: the fingers' force limit, read from the model.
    grip_rate_n_s : how fast the grip may rise, N/s; None: the finger drive's whole force range
        in one second (read from the model).
    load_filter_s : time constant of the low-pass on the lift's load that the grip follows while
        carrying, s: 0.05, ten control periods and several of the lift servo's kv / kp = 30 ms,
        so the force spikes of an accelerating object are not ratcheted into the grip.
    table_load_fraction : placing ends when the lift carries less than this share of the held
        load: 0.5, the table then carries most of the weight and the object rests on it.
    slip_pressure_drop : a fingertip's pressure falling by this share of its value while
        carrying (and by 3 sigma) is a slip: 0.2, far above the estimate's 10 % resolution.
    lost_s : how long both fingertips must read no load, or the fingers stay shut past the
        object's width with no fingertip reading a load, before the object counts as lost, s
        (ten control periods).
    hysteresis : fractional band around each switch pressure, against chattering between modes.
    persist : consecutive readings that call for the same mode switch (saturated, below detection, past
        a switch pressure) before it is made: 3, 15 ms at 5 ms readings.  A lone reading 3 sigma
        out (1 in 740 of Gaussian noise) moves nothing; three in a row come about once in 4e8
        readings (23 days at 200 Hz).  The 10 ms a switch waits is less than the ring-up it costs
        (10-45 ms with Q = 70, 60-350 ms with Table I's damping), and a pressure that swings
        across the band at every reading (pads sticking and slipping) switches nothing.  At most
        MAX_PERSIST_S = 1 s of readings (checked in :meth:`check_scenario`, where the control
        period is known).
    cusum_drift_sigma, cusum_alarm_sigma : the touch CUSUM's allowance k (half the 1-sigma shift
        it is tuned to) and threshold h, in sigmas of a reading (Page 1954): with k = 0.5, h = 8
        an unloaded fingertip false-alarms once in about 19,000 readings (Siegmund's
        approximation: 95 s at 200 Hz; a false touch is caught at the squeeze and closing
        resumes), while a drift of a sigma per reading alarms within 16.
    touch_single_sigma : one reading's drop that signals a touch alone (the Shewhart limit of a
        combined Shewhart-CUSUM, Lucas 1982), sigmas: 6, a one-sided Gaussian tail of 1e-9 per
        reading.  A touch is then felt one reading sooner than by the CUSUM alone (at 20 mm/s,
        0.06 N on a 30 mm sphere instead of 0.11 N).
    out_of_range_sigma : readings outside [-n sigma, 1 + n sigma] are a sensor fault.
    squeeze_settle_s : the squeeze's settling before the lift, s: 0.1, several times the finger
        servo's time constant on the gel (46 g of finger on the pad's 2.4 kN/m: 4 ms) and long
        enough for the readout to say whether the pads feel the grip floor.
    measurable_share : the share of the highest mode's P_max the grip may use, -: 0.9, inside
        the range where the mode still resolves 10 % of the pressure.
    sliding_pace : a lift keeping this share of its goal's pace runs free (the pads slide or the
        object is carried), -: 0.9; between 0.5 and this the pads creep (MuJoCo's soft friction
        at a light grip) and the load-to-grip ratio says nothing of the friction.
    """

    kind: str = "multimode"
    lift_accel_m_s2: float = 0.5
    touchdown_margin_m: float = 0.005
    friction_assumed: float = 0.8
    grip_safety: float = 1.25
    grip_floor_n: float | None = None
    max_grip_n: float | None = None
    grip_rate_n_s: float | None = None
    load_filter_s: float = 0.05
    table_load_fraction: float = 0.5
    slip_pressure_drop: float = 0.2
    lost_s: float = 0.05
    hysteresis: float = 0.25
    persist: int = 3
    cusum_drift_sigma: float = 0.5
    cusum_alarm_sigma: float = 8.0
    touch_single_sigma: float = 6.0
    out_of_range_sigma: float = 6.0
    squeeze_settle_s: float = 0.1
    measurable_share: float = 0.9
    sliding_pace: float = 0.9

    def validate(self) -> None:
        super().validate()
        for name in (
            "lift_accel_m_s2",
            "touchdown_margin_m",
            "friction_assumed",
            "load_filter_s",
            "lost_s",
            "cusum_drift_sigma",
            "cusum_alarm_sigma",
            "touch_single_sigma",
            "out_of_range_sigma",
            "squeeze_settle_s",
        ):
            _positive(f"controller.{name}", getattr(self, name))
        for name in ("grip_floor_n", "max_grip_n", "grip_rate_n_s"):
            if getattr(self, name) is not None:
                _positive(f"controller.{name}", getattr(self, name))
        if not _is_number(self.grip_safety) or not self.grip_safety > 1 or not math.isfinite(self.grip_safety):
            raise ValueError(f"controller.grip_safety must be a number above 1, got {self.grip_safety!r}")
        for name in ("table_load_fraction", "slip_pressure_drop", "hysteresis", "measurable_share"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not 0 < value < 1:
                raise ValueError(f"controller.{name} must be a fraction in (0, 1), got {value!r}")
        if isinstance(self.sliding_pace, bool) or not isinstance(self.sliding_pace, (int, float)) or not 0.5 < self.sliding_pace <= 1:
            raise ValueError(f"controller.sliding_pace must be in (0.5, 1], got {self.sliding_pace!r}")
        if not isinstance(self.persist, int) or isinstance(self.persist, bool) or self.persist < 1:
            raise ValueError(f"controller.persist must be an integer >= 1, got {self.persist!r}")

    def check_scenario(self, scenario: ScenarioConfig) -> None:
        """Also: the mode switch's ``persist`` readings last at most MAX_PERSIST_S."""
        super().check_scenario(scenario)
        persist_s = self.persist * scenario.physics.control_period_s
        if persist_s > MAX_PERSIST_S:
            raise ValueError(
                f"controller.persist {self.persist!r} readings of {scenario.physics.control_period_s:g} s wait "
                f"{persist_s:.3g} s before a mode switch: at most {MAX_PERSIST_S:g} s"
            )


@dataclass(frozen=True)
class GentleConfig(MultimodeConfig):
    """The gentle grasp's settings (cosim/control/gentle.py): the multimode controller's, and its
    friction probe's.

    Attributes
    ----------
    friction_max : the highest pad-object friction the probe expects, -: 1.5, rubber on the
        pads' silicone film (the rating's top, models/gripper.xml).  The gentle probe starts
        from the grip floor and measures the friction while the pads slide; until its first
        measurement this sets how fast the lift's goal rises while the grip grows (the sag
        2 mu G / kp that a sliding grip adds), so the lift keeps rising on any friction below it;
        a friction the probe reads above it is taken as it (a misread grip: a mounted drive reads
        light grips up to 2x off, docs/grippers.md).
    probe_speed_m_s : the lift's pace while the probe finds the grip, m/s: 0.001.  The pads
        slide up the object meanwhile; the probe lasts ln(grip / floor) / growth rate (one to
        three seconds from milli-newtons to tens of newtons), so they slide a millimetre or two,
        well inside the 7.5 mm element under the contact.
    closing_speed_m_s : the fingers' closing speed away from the object, m/s: 0.05, the middle of
        common parallel grippers' 20-150 mm/s (the multimode controller's 0.02 closes at its
        slowest all the way).  Within the camera's band (``touch_band_sigmas``, and everywhere
        without a camera) the fingers close at the touch speed instead, which the touch's bound
        sets (cosim/control/gentle.py, ``touch_speed_m_s``: 1.4 mm/s with the defaults).
    touch_force_n : the touch's bound, N per finger: the most the fingers may press the object
        with before they have stopped on it (cosim/control/gentle.py, ``touch_speed_m_s``:
        the closing speed within the camera's band is set so that the force the loop adds while
        it reacts stays within it).  None: TOUCH_FLOORS = 3 grip floors (18.5 mN with the
        default fingertip): the touch may add twice the gentlest grip the fingertip measures to
        the floor it is detected at, what the probe's grip reaches five growth steps (0.3 s)
        after the squeeze anyway (1.25^5 = 3.05).  At least the grip floor (what the fingertip
        resolves: the touch is detected there), checked where the floor is known.
    touch_band_sigmas : how many of the camera's sigmas (``perception.width_sigma_m``) wider
        than its width the fingers slow to their touch speed, -: 3 (a Gaussian error past 3
        sigma comes once in 740 objects).
    """

    kind: str = "gentle"
    closing_speed_m_s: float = 0.05
    friction_max: float = 1.5
    probe_speed_m_s: float = 0.001
    touch_force_n: float | None = None
    touch_band_sigmas: float = 3.0

    def validate(self) -> None:
        super().validate()
        _positive("controller.friction_max", self.friction_max)
        _positive("controller.probe_speed_m_s", self.probe_speed_m_s)
        if self.touch_force_n is not None:
            _positive("controller.touch_force_n", self.touch_force_n)
        _positive("controller.touch_band_sigmas", self.touch_band_sigmas)


@dataclass(frozen=True)
class GripperConfig(_CheckedOnConstruction):
    """The gripper the scene hangs from the lift: the house gripper (models/gripper.xml), or
    another from its MJCF file (cosim/gripper_mount.py; docs/grippers.md).

    Attributes
    ----------
    mjcf : the gripper's MJCF file (a path, relative to the working directory or absolute), or
        None for the house gripper.  The scene keeps its own options (timestep, integrator,
        contacts), table, object and lift; the file's top body under which both fingertips hang
        is mounted on the lift, with every limit the controller uses read from it.
    fingertips : with ``mjcf``, the two fingertips that carry the gel pads, each the name of a
        box site, a body or a geom in the file (looked up in that order; a body's or a geom's pad
        goes on its face towards the other fingertip, as :func:`piezotip.attach` puts it): the
        first carries the ``left`` pad, the second the ``right``.
    actuators : with ``mjcf``, the actuators in the file that close the fingers, one or several:
        position servos or motors on joints or tendons.
    approach_axis : with ``mjcf``, the direction in which the gripper approaches an object, in
        the file's own frame (a 3-vector, any length; its part along the line between the
        fingertips is dropped); None: from the fingertips' common root body towards the middle
        between their pads.  The mount points it down at the table.
    """

    mjcf: str | None = None
    fingertips: tuple[str, ...] = ()
    actuators: tuple[str, ...] = ()
    approach_axis: tuple[float, float, float] | None = None

    def validate(self) -> None:
        if self.mjcf is None:
            for key, value in (("fingertips", self.fingertips), ("actuators", self.actuators), ("approach_axis", self.approach_axis)):
                if value:
                    raise ValueError(f"gripper.{key} {_short(value)} names a part of a gripper file: give gripper.mjcf too")
            return
        if not isinstance(self.mjcf, str) or not self.mjcf.strip():
            raise ValueError(f"gripper.mjcf must be the path of an MJCF file, got {_short(self.mjcf)}")
        for key, names in (("fingertips", self.fingertips), ("actuators", self.actuators)):
            if not names:  # the file alone: say which file wants them
                raise ValueError(f"gripper.mjcf={_short(self.mjcf)} needs gripper.{key} too: the {key} in that file, by name")
        _names_once("gripper.fingertips", self.fingertips)
        if len(self.fingertips) != 2:
            raise ValueError(f"gripper.fingertips must name two fingertips (the left and the right pad's), got {len(self.fingertips)}")
        _names_once("gripper.actuators", self.actuators)
        if self.approach_axis is not None:
            if not all(_is_number(v) and math.isfinite(v) for v in self.approach_axis) or not any(self.approach_axis):
                raise ValueError(f"gripper.approach_axis must be a nonzero 3-vector of finite numbers, got {_short(self.approach_axis)}")
        from piezotip.cosim.gripper_mount import check_gripper

        check_gripper(self)  # the file loads, and names what these keys name (a ValueError naming the key)


#: The most extra load a disturbance may put on the object, N: the weight of the gripper's rated
#: payload (RATED_MASS_KG's 10 kg at standard gravity, 9.81 m/s^2), what its fingers and lift
#: are built to carry (models/gripper.xml).
MAX_EXTRA_LOAD_N = RATED_MASS_KG[1] * 9.81


@dataclass(frozen=True)
class DisturbConfig(_CheckedOnConstruction):
    """A load change while the object is held: an extra downward force on the object, as a
    pour of water into a held cup or a hand pressing on it would put on.

    The load comes on at the middle of the hold, as the controller's phases define it: the time
    the controller's phase first turns to hold (the recorded ``phase`` column) plus half of
    ``controller.hold_s``.  It rises linearly from zero over ``ramp_s`` and then stays on to the
    end of the run (cosim.disturb.LoadDisturbance applies it, as MuJoCo's ``xfrc_applied`` on
    the object's centre of mass, once per control period at the ramp's mean over that period:
    the impulse the ramp delivers).  A controller that never holds is never disturbed.  The
    referee measures the answer (analysis.referee: ``disturb_slip_mm``, ``disturb_reaction_ms``,
    ``disturb_grip_margin``).

    Attributes
    ----------
    extra_load_n : the extra downward load, N: 0 for none (every scenario but grasp-disturb),
        None for the object's own weight (its simulated mass times the model's gravity:
        grasp-disturb's), else 0 to MAX_EXTRA_LOAD_N = 98.1 N, the rated payload's weight.
    ramp_s : how long the load takes to come on, s: 0.05, about how fast a hand sets a weight
        down (a positive number: a step, 0, has no rise to answer in time).
    """

    extra_load_n: float | None = 0.0
    ramp_s: float = 0.05

    def validate(self) -> None:
        load = self.extra_load_n
        if load is not None and not (_is_number(load) and 0.0 <= load <= MAX_EXTRA_LOAD_N):
            raise ValueError(
                f"disturb.extra_load_n must be None (the object's weight) or within 0-{MAX_EXTRA_LOAD_N:g} N "
                f"(none to the gripper's rated 10 kg payload's weight), got {_short(load)}"
            )
        if not (_is_number(self.ramp_s) and 0.0 < self.ramp_s < math.inf):
            raise ValueError(f"disturb.ramp_s must be a positive number of seconds (the load's rise time), got {_short(self.ramp_s)}")

    @property
    def active(self) -> bool:
        """Whether any load comes on (None, the object's weight, does)."""
        return self.extra_load_n is None or self.extra_load_n > 0.0

    def load_n(self, weight_n: float) -> float:
        """The extra load, N, for an object of weight ``weight_n`` (N; what None stands for)."""
        return float(weight_n) if self.extra_load_n is None else float(self.extra_load_n)


#: The widest camera width uncertainty a scenario may state, m: half the house gripper's 90 mm
#: stroke (a prior that uncertain says nothing the stroke does not).
MAX_WIDTH_SIGMA_M = 0.045


@dataclass(frozen=True)
class PerceptionConfig(_CheckedOnConstruction):
    """What the robot's camera tells the controller before the touch: the object's width across
    the fingers, with its stated uncertainty (a perception prior, as a robot that looked before
    it reached has).  The gentle controller closes fast until the fingers are
    ``controller.touch_band_sigmas`` sigmas wide of the width, and at its touch speed from there
    on (cosim/control/gentle.py); the multimode and scripted controllers do not read it.

    Attributes
    ----------
    width_sigma_m : the camera's stated 1-sigma uncertainty of the width, m: 0.001.  A wrist
        RGB-D camera 0.3-0.5 m from the object resolves an edge to about a pixel (0.5-1 mm) and
        measures depth to 1-2 mm (Intel RealSense D435 datasheet: under 2 % of the range); the
        width across the fingers is an edge-to-edge measurement.  None: no camera, no prior:
        the gentle controller closes at its touch speed from the open fingers (slow: its
        touch bound then costs the whole stroke's time).  0: an exact width.
    width_m : the width the camera reports, m; None: the camera's own reading of the scene's
        object, its true width (``object.size_m``) plus a Gaussian error of ``width_sigma_m``
        drawn from ``seed`` (a camera is off by about its stated sigma, never by nothing).
        A number: the camera reported that (e.g. a wrong prior, to see the touch it costs).
    seed : the seed of the camera's error, an integer in 0..2**63-1.
    """

    width_sigma_m: float | None = 0.001
    width_m: float | None = None
    seed: int = 0

    def validate(self) -> None:
        sigma = self.width_sigma_m
        if sigma is not None and not (_is_number(sigma) and 0.0 <= sigma <= MAX_WIDTH_SIGMA_M):
            raise ValueError(
                f"perception.width_sigma_m must be None (no camera) or a width uncertainty within 0-{MAX_WIDTH_SIGMA_M:g} m, "
                f"got {_short(sigma)}"
            )
        if self.width_m is not None:
            _positive("perception.width_m", self.width_m)
        _seed("perception.seed", self.seed)

    def width_prior_m(self, true_width_m: float) -> tuple[float, float] | None:
        """(the width the camera reports, its sigma), m, for an object ``true_width_m`` wide, or
        None without a camera (the class docstring)."""
        if self.width_sigma_m is None:
            return None
        if self.width_m is not None:
            return float(self.width_m), float(self.width_sigma_m)
        import numpy as np

        error_m = float(np.random.default_rng(self.seed).standard_normal()) * self.width_sigma_m
        return float(true_width_m) + error_m, float(self.width_sigma_m)


def _names_once(key: str, names) -> None:
    """A non-empty list of names, each once; a list written unquoted (``[a, b]``, which reads as
    one name) gets the quoting it needs."""
    if not names:
        raise ValueError(f"{key} must name at least one, got none")
    if len(names) == 1 and names[0].startswith("[") and names[0].endswith("]"):
        quoted = ", ".join(repr(n.strip()) for n in names[0][1:-1].split(","))
        raise ValueError(f"{key}: {_short(names[0])} reads as one name; quote each: {key}=[{quoted}]")
    if any(not n for n in names) or len(set(names)) != len(names):
        raise ValueError(f"{key} must name each once, got {_short(list(names))}")


@dataclass(frozen=True)
class ScenarioConfig:
    """A scenario's whole configuration.

    Attributes
    ----------
    name, description : the registry's name and a line for ``list``.
    duration_s : the longest the controller may take, s (a run ends earlier when it finishes;
        the recording then goes on until the object rests, cosim.loop.REST_MIN_S).
    object, physics, sensor : the parts (their own docstrings).
    controller : the controller's config: the class its ``kind`` is registered with
        (:mod:`piezotip.controllers`), the gentle controller's by default (GentleConfig).
    gripper : the gripper on the lift (:class:`GripperConfig`): the house's by default.
    disturb : a load change while the object is held (:class:`DisturbConfig`): none by default.
    perception : what a camera tells the controller of the object before the touch
        (:class:`PerceptionConfig`): its width, within 1 mm, by default.
    """

    name: str
    description: str
    duration_s: float = 12.0
    object: ObjectConfig = field(default_factory=ObjectConfig)
    physics: PhysicsConfig = field(default_factory=PhysicsConfig)
    sensor: SensorConfig = field(default_factory=SensorConfig)
    controller: ControllerConfig = field(default_factory=GentleConfig)
    gripper: GripperConfig = field(default_factory=GripperConfig)
    disturb: DisturbConfig = field(default_factory=DisturbConfig)
    perception: PerceptionConfig = field(default_factory=PerceptionConfig)

    def validate(self) -> ScenarioConfig:
        """Check every value, then the ranges that depend on several; return self so it chains."""
        _positive("duration_s", self.duration_s)
        registration = controller_registration(self.controller.kind)
        if type(self.controller) is not registration.config:
            raise ValueError(
                f"controller.kind {self.controller.kind!r} takes a {registration.config.__name__}, got a "
                f"{type(self.controller).__name__} (piezotip.controllers.configure builds the one a kind takes)"
            )
        for part in (self.object, self.physics, self.sensor, self.controller, self.gripper, self.disturb, self.perception):
            part.validate()
        steps = self.duration_s / self.physics.control_period_s
        longest = MAX_RECORDED_STEPS * self.physics.control_period_s
        # Compared as durations: duration / period of a duration of exactly `longest` can round
        # past MAX_RECORDED_STEPS (hypothesis found 10739.908... s at 0.01074 s).
        if self.duration_s > longest:
            raise ValueError(
                f"duration_s {self.duration_s!r} s is {steps:.3g} control periods of {self.physics.control_period_s:g} s: at most "
                f"{MAX_RECORDED_STEPS:.0e} are recorded (300 MB of run.npz, read back whole by the referee), {longest:g} s"
            )
        self.controller.check_scenario(self)
        self._check_quality_factor()
        _check_fingertip(self, registration.senses)
        return self

    def _check_quality_factor(self) -> None:
        """The element's Q within what the readout can read at this control period, and its
        damage no more than critical damping (SensorConfig's docstring derives both)."""
        from piezotip.sensor import ElementParams, SensorElement
        from piezotip.sensor.inference import MAX_GAIN, WINDOW_S

        element = SensorElement(ElementParams())
        q = element.quality_factor(1) if self.sensor.quality_factor is None else self.sensor.quality_factor
        f1_hz, dt = element.natural_frequency_hz(1), self.physics.control_period_s
        q_max = math.pi * f1_hz * MAX_GAIN * math.sqrt(WINDOW_S**3 / (192.0 * dt))
        if q > q_max:
            tau0 = q / (math.pi * f1_hz)
            raise ValueError(
                f"sensor.quality_factor {q:g} rings up with tau0 = {tau0:.3g} s: an unloaded fingertip would never read trusted "
                f"(the readout's inference gain tau0 sqrt(192 dt / W^3) passes {MAX_GAIN:g} at {dt:g} s readings): at most {q_max:.3g}"
            )
        if self.sensor.damage_damping > 2.0 * q:
            raise ValueError(
                f"sensor.damage_damping {self.sensor.damage_damping!r} damps the element past critical damping "
                f"(Q {q:g} / {self.sensor.damage_damping!r} < 1/2, no resonance left): at most {2.0 * q:.4g}"
            )


#: Per (sensor config, allowed modes, controller kind, whether it senses): None where the fingertip
#: is one the run can build and its modes' ranges suit the controller, else why not (_check_fingertip).
_FINGERTIPS: dict[tuple, str | None] = {}


def _check_fingertip(config: ScenarioConfig, senses: bool) -> None:
    """The fingertip the run builds (cosim.loop.make_fingertip: a varied unit calibrated), and for
    a controller that reads the fingertips (registered with ``senses``: the multimode ones) each
    allowed mode the most useful somewhere and a switch pressure from each up to the next (the
    edge between their bands): what their mode selector is built for (cosim.control.selector
    switches one allowed mode up as the pressure rises past it).

    Computed once per sensor configuration, with the selector's own ranges (cached on disk, so
    the run then finds them done); a ValueError naming the sensor's keys otherwise."""
    modes = tuple(sorted(config.controller.modes))
    key = (config.sensor, modes, config.controller.kind, senses)
    if key not in _FINGERTIPS:
        _FINGERTIPS[key] = _fingertip_problem(config, modes, senses)
    if _FINGERTIPS[key] is not None:
        raise ValueError(_FINGERTIPS[key])


def _fingertip_problem(config: ScenarioConfig, modes: tuple[int, ...], senses: bool) -> str | None:
    from piezotip.cosim.control.selector import allowed_ranges
    from piezotip.cosim.loop import make_fingertip

    s = config.sensor
    try:
        tip = make_fingertip(config)
    except ValueError as err:
        unit = f"sensor.variation={s.variation}, sensor.unit_seed={s.unit_seed}, sensor.coverage_mm={s.coverage_mm!r}"
        return f"the fingertip ({unit}) cannot be built: {err}"
    if not senses:  # drives no mode selector
        return None
    _, bands, _, _ = allowed_ranges(tip, modes)
    order = [band[0] for band in bands]
    switches = set(itertools.pairwise(order))
    lacking = [m for m in modes if m not in order]
    missing = [pair for pair in itertools.pairwise(modes) if pair not in switches]
    if not lacking and not missing:
        return None
    why = (
        f"mode {lacking[0]} is nowhere the most useful of them"
        if lacking
        else f"there is no switch pressure from mode {missing[0][0]} up to mode {missing[0][1]}"
    )
    unit = "" if s.unit_config().is_nominal else f"sensor.variation={s.variation}, sensor.temperature_c={s.temperature_c!r}, "
    return (
        f"controller.modes {list(modes)}: with sensor.coverage_mm={s.coverage_mm!r}, sensor.quality_factor={s.quality_factor!r}, {unit}"
        f"sensor.gel_layer={s.gel_layer} and sensor.modes={list(s.modes)} {why} (the most useful mode from low to high pressure: "
        f"{_short(', '.join(map(str, order)) or 'none', 60)[1:-1]}), which the {config.controller.kind} controller's mode switching "
        "(one mode up as the pressure rises past their switch pressure) needs: cover the element's tip, or allow fewer modes"
    )


def _is_number(value) -> bool:
    return not isinstance(value, bool) and isinstance(value, (int, float)) and not math.isnan(value)


def _positive(key: str, value) -> None:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) or value <= 0:
        raise ValueError(f"{key} must be a positive number, got {_short(value)}")


def _one_of(key: str, value, valid) -> None:
    if value not in valid:
        raise ValueError(f"{key} must be one of {', '.join(map(str, valid))}; got {_short(value)}")


def _modes(key: str, modes) -> None:
    """A set of vibration modes: each an integer in 1..30 (the element's modes the model
    computes: sensor.modes), named once."""
    if not modes or any(isinstance(m, bool) or not isinstance(m, int) or not 1 <= m <= 30 for m in modes):
        raise ValueError(f"{key} must be a non-empty list of modes in 1..30, got {_short(list(modes))}")
    if len(set(modes)) != len(modes):
        repeated = sorted({m for m in modes if modes.count(m) > 1})
        raise ValueError(f"{key} must name each mode once, got {len(modes)} with {repeated} repeated")


def _seed(key: str, value) -> None:
    if isinstance(value, bool) or not isinstance(value, int) or not 0 <= value <= MAX_SEED:
        raise ValueError(f"{key} must be an integer in 0..2**63-1, got {_short(value)}")


def _short(value, limit: int = 80) -> str:
    """``repr(value)``, its middle left out past ``limit`` characters (error messages stay one
    short line whatever was given)."""
    text = repr(value)
    if len(text) <= limit:
        return text
    return f"{text[: limit // 2]}...{text[-(limit // 4) :]} ({len(text)} characters)"


# ---------------------------------------------------------------------------------------
# Dotted-path overrides.
# ---------------------------------------------------------------------------------------


def valid_keys(config) -> list[str]:
    """Every dotted key of ``config`` that ``--set`` accepts."""
    keys = []
    for f in dataclasses.fields(config):
        value = getattr(config, f.name)
        if dataclasses.is_dataclass(value):
            keys.extend(f"{f.name}.{k}" for k in valid_keys(value))
        else:
            keys.append(f.name)
    return keys


def parse_value(text: str, key: str | None = None):
    """A ``--set`` value: a Python literal if it parses as one, else the string itself.

    Bounded before it is parsed: at most MAX_VALUE_CHARS characters and MAX_VALUE_DEPTH
    nested brackets; a mapping or a set (no field takes one) is refused.  Each is a ValueError
    naming ``key`` (or the value).  Text that is no literal (``envelope``, ``10**400``,
    ``1+1``) is the string itself, which the field's type then refuses or takes.
    """
    what = f"{key}: " if key else ""
    if len(text) > MAX_VALUE_CHARS:
        raise ValueError(f"{what}a value of {len(text)} characters ({_short(text, 30)}), more than the {MAX_VALUE_CHARS} a value may have")
    depth = _bracket_depth(text)
    if depth > MAX_VALUE_DEPTH:
        raise ValueError(f"{what}{_short(text, 40)} nests {depth} brackets deep, more than the {MAX_VALUE_DEPTH} a value may")
    try:
        tree = ast.parse(text.strip(), mode="eval")
    except (SyntaxError, ValueError, MemoryError, RecursionError):  # not Python (or null bytes, or too deep for the parser)
        return text
    if _expression_depth(tree.body) > _MAX_EXPRESSION_DEPTH:
        raise ValueError(f"{what}{_short(text, 40)} is an expression nested too deep for a value")
    if any(isinstance(node, (ast.Dict, ast.Set, ast.DictComp, ast.SetComp)) for node in ast.walk(tree)):
        raise ValueError(f"{what}{_short(text, 40)} is a mapping or a set; a value is a number, text, True/False, None or a list of them")
    try:
        return ast.literal_eval(tree)
    except (ValueError, SyntaxError, TypeError, MemoryError, RecursionError):
        return text


_QUOTED = re.compile(r"'(?:[^'\\]|\\.)*'|\"(?:[^\"\\]|\\.)*\"")


def _bracket_depth(text: str) -> int:
    """The deepest nesting of (), [] and {} in ``text`` outside quoted strings."""
    depth = deepest = 0
    for char in _QUOTED.sub("", text):
        if char in "([{":
            depth += 1
            deepest = max(deepest, depth)
        elif char in ")]}":
            depth = max(depth - 1, 0)
    return deepest


def _expression_depth(node: ast.AST) -> int:
    """The depth of ``node``'s tree, counted without recursion and no further than past the limit."""
    deepest, stack = 0, [(node, 1)]
    while stack:
        node, depth = stack.pop()
        deepest = max(deepest, depth)
        if deepest > _MAX_EXPRESSION_DEPTH:
            break
        stack.extend((child, depth + 1) for child in ast.iter_child_nodes(node))
    return deepest


def _coerce(key: str, hint, value):
    """``value`` converted to the field type ``hint``, or a ValueError naming ``key``."""
    origin = typing.get_origin(hint)
    args = typing.get_args(hint)
    if origin in (typing.Union, types.UnionType):
        if value is None and type(None) in args:
            return None
        for arg in args:
            if arg is type(None):
                continue
            try:
                return _coerce(key, arg, value)
            except ValueError:
                continue
        raise ValueError(f"{key}: cannot use {_short(value)} (expected {hint})")
    if origin is tuple:
        given = value
        if isinstance(value, (int, float, str)) and not isinstance(value, bool):
            value = [value]
        if not isinstance(value, (list, tuple)):
            raise ValueError(f"{key}: expected a list, got {_short(value)}")
        item_types = args[:1] if (len(args) == 2 and args[1] is Ellipsis) else args
        if len(item_types) == 1:
            try:
                return tuple(_coerce(key, item_types[0], v) for v in value)
            except ValueError:
                # A list of the wrong items, or a list written as text where a mapping's value
                # is taken as given ({"controller.modes": "[2, 3]"}): say what a list needs.
                name = item_types[0].__name__
                raise ValueError(f"{key}: expected a list of {name} values (e.g. {key}=[1, 2]), got {_short(given)}") from None
        if len(value) != len(item_types):
            raise ValueError(f"{key}: expected {len(item_types)} values, got {_short(value)}")
        return tuple(_coerce(key, t, v) for t, v in zip(item_types, value, strict=True))
    if hint is bool:
        if isinstance(value, bool):
            return value
        if isinstance(value, str) and value.lower() in ("true", "false"):
            return value.lower() == "true"
        raise ValueError(f"{key}: expected true or false, got {_short(value)}")
    if hint is int:
        if isinstance(value, bool) or not isinstance(value, int):
            raise ValueError(f"{key}: expected an integer, got {_short(value)}")
        return value
    if hint is float:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise ValueError(f"{key}: expected a number, got {_short(value)}")
        try:
            return float(value)
        except OverflowError:  # an integer past 1.8e308
            raise ValueError(f"{key}: {_short(value)} is too large a number (at most 1.8e308)") from None
    if hint is str:
        if not isinstance(value, str):
            raise ValueError(f"{key}: expected text, got {_short(value)}")
        return value
    return value


def apply_override(config, key: str, value, full_key: str | None = None):
    """A copy of ``config`` with the dotted ``key`` set to ``value`` (already parsed).

    ``controller.kind`` chooses the controller and with it the config's class: the new kind's
    (:func:`piezotip.controllers.configure`), keeping what the old config was given."""
    full_key = full_key or key
    head, _, rest = key.partition(".")
    names = {f.name: f for f in dataclasses.fields(config)}
    if head not in names or (rest and not dataclasses.is_dataclass(getattr(config, head))):
        raise KeyError(key)
    if rest:
        return dataclasses.replace(config, **{head: apply_override(getattr(config, head), rest, value, full_key)})
    if dataclasses.is_dataclass(getattr(config, head)):
        raise KeyError(key)
    hints = typing.get_type_hints(type(config))
    if head == "kind" and isinstance(config, ControllerConfig):
        from piezotip import controllers

        kind = _coerce(full_key, hints[head], value)
        controller_registration(kind)  # an unknown kind's error names the key
        return controllers.configure(kind, like=config)
    return dataclasses.replace(config, **{head: _coerce(full_key, hints[head], value)})


def controller_registration(kind: str):
    """The registration (:class:`piezotip.controllers.Registration`) of controller ``kind`` (a
    registered name, or ``MODULE:CLASS``: a controller class to import), or a ValueError naming
    ``controller.kind`` and the registered controllers."""
    from piezotip.cosim.control import registry

    if isinstance(kind, str) and ":" in kind:
        return registry.get(kind)  # imported and resolved (its errors name controller.kind)
    if kind not in registry.names():
        raise ValueError(
            f"controller.kind must be one of {', '.join(registry.names())}, or MODULE:CLASS (a controller class to import); "
            f"got {_short(kind)}"
        )
    return registry.get(kind)


#: The key that chooses the controller, and so which ``controller.*`` keys there are.
CONTROLLER_KIND_KEY = "controller.kind"


def with_overrides(config: ScenarioConfig, assignments: list[str]) -> ScenarioConfig:
    """Apply ``key=value`` strings, then validate the result.

    In order, except that ``controller.kind`` comes first: it chooses the controller, whose
    config class has the keys the other ``controller.*`` assignments set (so the order they are
    given in does not matter)."""
    pairs = []
    for assignment in assignments:
        key, sep, text = assignment.partition("=")
        key = key.strip()
        if not sep or not key:
            raise ValueError(f"--set takes key=value, got {_short(assignment)}")
        pairs.append((key, text))
    pairs.sort(key=lambda pair: pair[0] != CONTROLLER_KIND_KEY)  # stable: the kinds in their order, then the rest
    with _deferred_checks():
        for key, text in pairs:
            try:
                config = apply_override(config, key, parse_value(text.strip(), key))
            except KeyError:
                raise ValueError(unknown_key_message(config, key)) from None
    return config.validate()


#: An unknown key's error lists the keys of its part (``object.*``, ...) when there are at most
#: this many: a list a reader scans at a glance.  A longer one (a controller's 30-odd) is left
#: to its dataclass's docstring, which the error names: one line of every key (1,629 characters
#: for a mistyped controller key) is read by no one.
MAX_LISTED_KEYS = 12
#: How close a valid key's last part must come to the unknown one's to be suggested (difflib's
#: ratio: 0.6 takes "mas" for "mass_kg"), and how far behind the best a second may be.
CLOSE_KEY_RATIO, CLOSE_KEY_SPREAD = 0.6, 0.1


def close_keys(key: str, keys: list[str], n: int = 3) -> list[str]:
    """Up to ``n`` of ``keys`` that ``key`` may have meant, best first: those whose last part is
    closest to its last part (a typo in the name, or the right name under the wrong part:
    ``sensor.mass_kg`` is ``object.mass_kg``), those in the key's own part first."""
    leaf = key.rpartition(".")[2]
    by_leaf: dict[str, list[str]] = {}
    for k in keys:
        by_leaf.setdefault(k.rpartition(".")[2], []).append(k)
    scored = [(difflib.SequenceMatcher(None, leaf, name).ratio(), name) for name in by_leaf]
    best = max((score for score, _ in scored), default=0.0)
    names = [name for score, name in sorted(scored, key=lambda sn: -sn[0]) if score >= max(CLOSE_KEY_RATIO, best - CLOSE_KEY_SPREAD)]
    head = key.partition(".")[0] + "."
    found = sorted((k for name in names for k in by_leaf[name]), key=lambda k: not k.startswith(head))  # stable: by score within
    return found[:n]


def unknown_key_message(config: ScenarioConfig, key: str) -> str:
    """Why ``key`` is not one of ``config``'s, in one short line: the keys it may have meant
    (:func:`close_keys`), the keys of its part when they are few (:data:`MAX_LISTED_KEYS`), and
    the dataclass whose docstring lists them all with their units and ranges.  For a
    ``controller.*`` key: the chosen controller's keys, and which registered controllers have it."""
    head, _, name = key.partition(".")
    suggestions = close_keys(key, valid_keys(config))
    meant = f" (did you mean {' or '.join(suggestions)}?)" if suggestions else ""

    def listed(what: str, keys: list[str], doc: str) -> str:
        # the keys themselves when few, else how many and where they are documented
        if len(keys) <= MAX_LISTED_KEYS:
            return f"; {what}: {', '.join(keys)} (their units and ranges: {doc}'s docstring in scenarios/config.py)"
        return f"; {what} ({len(keys)}), their units and ranges: {doc}'s docstring in scenarios/config.py"

    if head == "controller" and name and "." not in name:
        from piezotip import controllers

        c = config.controller
        owners = [kind for kind in controllers.names() if name in {f.name for f in dataclasses.fields(controllers.get(kind).config)}]
        elsewhere = f" (the {', '.join(owners)} controller{'s have' if len(owners) > 1 else ' has'} it)" if owners else ""
        own = [f"controller.{k}" for k in valid_keys(c)]
        kind = type(c).__name__
        return f"unknown key {_short(key)} for the {c.kind} controller ({kind}){elsewhere}{meant}{listed('its valid keys', own, kind)}"
    part = getattr(config, head, None) if head in {f.name for f in dataclasses.fields(config)} else None
    if dataclasses.is_dataclass(part):
        own = [f"{head}.{k}" for k in valid_keys(part)]
        return f"unknown key {_short(key)}{meant}{listed(f'the {head} keys', own, type(part).__name__)}"
    fields = dataclasses.fields(config)
    plain = [f.name for f in fields if not dataclasses.is_dataclass(getattr(config, f.name))]
    parts = [f"{f.name}.*" for f in fields if dataclasses.is_dataclass(getattr(config, f.name))]
    return (
        f"unknown key {_short(key)}{meant}; a key is one of {', '.join(plain)} or in {', '.join(parts)} "
        f"(every key with its unit and range: the docstrings of {type(config).__name__} and its parts in scenarios/config.py)"
    )
