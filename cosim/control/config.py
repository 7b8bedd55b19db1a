"""The controllers' settings (``controller.*``): :class:`ControllerConfig`, what every grasp
controller is configured with, :class:`MotionConfig`, the built-in controllers' shared motions,
and the built-in controllers' own: :class:`ScriptedConfig` (scripted.py), :class:`MultimodeConfig`
(multimode.py) and :class:`GentleConfig` (gentle.py).

They live here together, not beside their controllers: the scenario's default controller is the
gentle one (:class:`piezotip.cosim.config.ScenarioConfig`), and this module imports nothing of
the controllers, so a config is made (and checked) without importing them.  The ranges that
depend on the rest of the scenario are checked in each ``check_scenario``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

from piezotip.sensor.checks import _is_number, _modes, _positive, _short

if TYPE_CHECKING:
    from piezotip.cosim.config import ScenarioConfig

#: The longest a mode switch may wait for its ``persist`` readings, s: a second, longer than any
#: ring-up it waits out (10-45 ms at Q 70, 60-350 ms with Table I's damping) and than a touch's
#: squeeze; past it a pressure change is no longer one switch but a grasp's phase.
MAX_PERSIST_S = 1.0


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
        best (Table I's slow resonator), and the pads press on by about the contact's stiffness
        times the speed times that delay meanwhile: the slowest speed leaves a 0.1 N-fragile
        object whole at the touch (tests/test_grasp.py::
        test_the_default_closing_speed_touches_the_paper_ball_under_its_crush_limit).
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
        Where the object rested is the lift's home, or for the gentle controller where its pads
        were first seen to carry the weight (they slide up the object first).  A landing speed
        capped under the touchdown speed (the gentle controller's, for a light object) is
        reached by the margin's time at the touchdown speed, not its distance, over the landing
        (``LiftPlan.lower``).
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
        reading.  A sharp touch is then felt one reading sooner than by the CUSUM alone, while the
        fingers press on by the closing speed times a period less (tests/test_grasp.py::
        test_one_reading_past_the_shewhart_limit_is_a_touch_a_reading_before_the_cusum_alone).
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


#: GentleConfig.slowest_climb's default: a quarter of the probe's pace (docs/grippers.md, eleventh
#: session: the trade measured on robosuite's Panda's raspberry, 14 variations at two presets).
SLOWEST_CLIMB_DEFAULT = 0.25


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
    touch_on_flags : whether, where only the fingertips can tell the touch (the fingers' drive has
        dry friction, ``RobotLimits.finger_friction_n``, which hides a few millinewtons from its
        joints) through a readout that lags (``sensor.dynamics`` envelope or carrier), the fingers
        stop on the readouts' change flags and close at the speed that keeps the touch within its
        bound counting the flags' latency (cosim/control/gentle.py, ``flagged_touch_speed_m_s``):
        a trade, measured on robosuite's Panda (docs/grippers.md, twenty-first session).  True:
        its 1 g tissue box touched at 10.4 mN for its 11.9 mN bound at `balanced` (31.6 mN
        without), every grasp about 1.1 s longer, which runs its heavy objects (a 2 kg block, a
        300 g jar) past the scenario's 12 s (``duration_s``: give them more).  False (the
        default): the touch is planned for detection at the grip floor, which the CUSUM on a
        lagging readout reaches 20-40 ms late.
    slowest_climb : the slowest the probe's climb goes, as a share of ``probe_speed_m_s``, on a
        drive with dry friction where the fingertips read the contact fade under pads sliding up
        an object that narrows under them (cosim/control/gentle.py, ``GentleGrasp._pace_climb``:
        the pace halves at each fade, down to this), -: SLOWEST_CLIMB_DEFAULT.  A trade: slower,
        the fingers' creep keeps the contact, but the probe's grip, growing per second, grows
        further before the object leaves the table (docs/grippers.md, eleventh session).
    """

    kind: str = "gentle"
    closing_speed_m_s: float = 0.05
    friction_max: float = 1.5
    probe_speed_m_s: float = 0.001
    touch_force_n: float | None = None
    touch_band_sigmas: float = 3.0
    touch_on_flags: bool = False
    slowest_climb: float = SLOWEST_CLIMB_DEFAULT

    def validate(self) -> None:
        super().validate()
        _positive("controller.friction_max", self.friction_max)
        value = self.slowest_climb
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not 0 < value <= 1:
            raise ValueError(f"controller.slowest_climb must be a share of the probe's pace in (0, 1], got {value!r}")
        _positive("controller.probe_speed_m_s", self.probe_speed_m_s)
        if self.touch_force_n is not None:
            _positive("controller.touch_force_n", self.touch_force_n)
        _positive("controller.touch_band_sigmas", self.touch_band_sigmas)
        if not isinstance(self.touch_on_flags, bool):
            raise ValueError(f"controller.touch_on_flags must be True or False, got {self.touch_on_flags!r}")


__all__ = [
    "MAX_PERSIST_S",
    "SLOWEST_CLIMB_DEFAULT",
    "ControllerConfig",
    "GentleConfig",
    "MotionConfig",
    "MultimodeConfig",
    "ScriptedConfig",
]
