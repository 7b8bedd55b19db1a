"""The fingertip's settings (``sensor.*``): :class:`SensorConfig` and the ranges it checks.

Part of a scenario's configuration (:class:`piezotip.cosim.config.ScenarioConfig`, re-exported by
:mod:`piezotip.scenarios.config` with the override machinery); the ranges that depend on other
sections (the quality factor's on the control period) are checked there.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from piezotip.sensor.checks import MAX_SEED, _CheckedOnConstruction, _is_number, _modes, _one_of, _positive, _seed, _short
from piezotip.sensor.gel import LAYERS
from piezotip.sensor.resonator import DYNAMICS

#: The sensor dynamics (sensor.resonator.DYNAMICS's, in its order: steady, envelope, carrier).
SENSOR_DYNAMICS = tuple(DYNAMICS)
LOAD_SPREADS = ("layer", "none")
"""sensor.load_spread: the gel layer spreads a face pressure over the element (sensor/spread.py), or not."""
#: The gel layer's models (sensor.gel.LAYERS's: winkler, dynamic).
GEL_LAYERS = LAYERS
#: The lowest unloaded quality factor of mode 1: soft PZT, the lossiest piezoceramic an element
#: is made of (Navy type VI / PZT-5H, mechanical Q 50-65).  See SensorConfig.quality_factor.
MIN_QUALITY_FACTOR = 50.0
#: The narrowest gel coverage, mm: the gel's contact edges on the element are moulded to ISO
#: 3302-1 class M2, +-0.10 mm each (sensor.variation.SPREADS["wide"].coverage_edge_m): a strip
#: no wider than the two edges' tolerances together can close altogether.
MIN_COVERAGE_MM = 0.2


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
        _one_of("sensor.gel_layer", self.gel_layer, GEL_LAYERS)
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


__all__ = ["GEL_LAYERS", "LOAD_SPREADS", "MAX_SEED", "MIN_COVERAGE_MM", "MIN_QUALITY_FACTOR", "SENSOR_DYNAMICS", "SensorConfig"]
