"""A scenario's whole configuration, :class:`ScenarioConfig`, and its sections the engine builds:
the object (:class:`ObjectConfig`), the physics (:class:`PhysicsConfig`), the gripper
(:class:`GripperConfig`), a load change (:class:`DisturbConfig`) and the camera's prior
(:class:`PerceptionConfig`).  The fingertip's section is :class:`piezotip.sensor.config.SensorConfig`,
the controllers' are in :mod:`piezotip.cosim.control.config`.

Every value is checked when its section is made (its ``validate``); the ranges that depend on
several sections in :meth:`ScenarioConfig.validate`.  Whether the engine can build a config (its
gripper file, its fingertip) is checked apart, by :mod:`piezotip.cosim.build_checks`.  The dotted-key overrides (``--set``) are
:mod:`piezotip.scenarios.config`'s, which re-exports every name here.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from piezotip.cosim.control.config import ControllerConfig, GentleConfig
from piezotip.cosim.shapes import shape_names
from piezotip.sensor.checks import _CheckedOnConstruction, _is_number, _names_once, _one_of, _positive, _seed, _short
from piezotip.sensor.config import SensorConfig

#: The object shapes, in registration order: the registry's (cosim/shapes.py, where a shape is added).
OBJECT_SHAPES = shape_names()
INTEGRATORS = ("discrete", "implicitfast", "implicit", "Euler", "RK4")
#: The pad contacts (cosim.pad_model.apply_pad_contact; models/README.md, "Sliding pads").
PAD_CONTACTS = ("auto", "compliant", "hard")
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


@dataclass(frozen=True)
class ObjectConfig(_CheckedOnConstruction):
    """The object on the table.

    Attributes
    ----------
    shape : a registered shape (:mod:`cosim.shapes`, which builds its geom): "box" (a cube),
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
        the first 30 um of depth, friction rows stiffened by impratio 1000; sliding pads do not
        chatter), "hard" (MuJoCo's maximum impedance from first touch, the model before: sliding
        pads chatter), or "auto": compliant, on the house gripper and a ``gripper.mjcf`` one
        alike (cosim.pad_model.resolve_pad_contact; models/README.md).
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
        """Check every value, then the ranges that depend on several; return self so it chains.

        Values only: whether the engine can build it (the gripper's file, the fingertip and its
        modes' bands) is :func:`piezotip.cosim.build_checks.check_buildable`'s, which the overrides
        (:func:`piezotip.scenarios.config.with_overrides`) and :class:`piezotip.cosim.loop.CoSimulation` run."""
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
