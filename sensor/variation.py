"""The physical unit: how one manufactured fingertip differs from the nominal model, and its temperature.

The readout's model (:class:`sensor.Fingertip` with Table I and the gel's defaults) is a
design; a unit off the line differs from it.  With Table I's damping the first resonance is
about 0.5 Hz wide at 3.77 kHz: a unit whose resonance is 1 % off sits 80 bandwidths from a
drive at the nominal frequency.  This module draws such units and warms them.

Spreads (:class:`VariationSpread`) are one standard deviation, relative unless stated, and each
says where it comes from.  Manufacturers state tolerances as +- limits; a limit is read as two
standard deviations (a process that holds its stated tolerance on 95 % of its parts).

Temperature (:func:`element_params_at`, :func:`gel_params_at`): calibration happens at 25 C
(:data:`REFERENCE_TEMPERATURE_C`); a unit at another temperature has other moduli:

- the PZT layers' Young's modulus, which carries 99.8 % of the bimorph's bending stiffness
  EI with Table I's thin (50 um) titanium substrate, so it sets the resonances' drift;
- the titanium substrate's Young's modulus (0.2 % of EI: included for completeness);
- the gel's modulus: its relaxed (rubbery) modulus grows with absolute temperature (kinetic
  theory of rubber elasticity) and its relaxation times shorten (time-temperature
  superposition, WLF), which at the element's kilohertz frequencies dominates: a warm gel is
  softer at the drive frequency.

Not modelled (stated, so nobody relies on it): thermal expansion of the element (ppm/K, a
hundred times below the moduli's coefficients), the temperature dependence of d31, of the
permittivity and of the element's damping, and any unit-to-unit spread of the temperature
coefficients themselves.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields, replace

import numpy as np

from .element import ElementParams, ModeTrim, SensorElement
from .fingertip import Fingertip
from .gel import GelModel, GelParams

#: Calibration temperature, C: the bench's room.
REFERENCE_TEMPERATURE_C = 25.0
#: The materials' range, C: soft PZT is specified from -20 C (and far above 80 C, half its
#: Curie point of ~ 350 C); polyurethane gels soften irreversibly and creep above ~ 80 C, and
#: below ~ -20 C approach their glass transition's tail, where the Prony series chosen at
#: room temperature no longer describes them.
TEMPERATURE_RANGE_C = (-20.0, 80.0)

#: Relative temperature coefficient of the PZT's Young's modulus, 1/K.  The resonances of
#: soft-PZT elements rise with temperature between 25 and 150 C ("The temperature effect on the
#: resonant spectra of thin piezoelectric ceramic disk", researcher.life 662c08a0) and
#: manufacturers give the frequency constant's change over -20 to 80 C as about 1 %, i.e.
#: +1e-4/K on frequency, +2e-4/K on the modulus (f ~ sqrt(Y)).  The least certain number
#: here: a real unit's coefficient may differ by a factor of two.
PZT_YOUNGS_TC_PER_K = 2.0e-4
#: Relative temperature coefficient of titanium's Young's modulus, 1/K: -4.5e-4 (commercially
#: pure titanium falls from 105 GPa at 20 C by ~ 0.05 GPa/K: Fisher and Renken, Phys. Rev. 135,
#: A482 (1964), single-crystal moduli of Ti against temperature; ASM Handbook vol. 2).
TITANIUM_YOUNGS_TC_PER_K = -4.5e-4
#: The gel's glass transition, C: -55 (the polyether soft segment of a soft polyurethane gel,
#: -50 to -70 C; Petrovic and Ferguson, Prog. Polym. Sci. 16, 695 (1991)).
GEL_GLASS_TRANSITION_C = -55.0
#: WLF's "universal" constants referred to the glass transition (Williams, Landel and Ferry,
#: J. Am. Chem. Soc. 77, 3701 (1955)): log10 a_T = -C1 (T - Tg) / (C2 + T - Tg).
WLF_C1 = 17.44
WLF_C2_K = 51.6
_KELVIN = 273.15

VARIATIONS = ("none", "typical", "wide")


def check_temperature(temperature_c, name: str = "sensor.temperature_c") -> float:
    """``temperature_c`` as a float in :data:`TEMPERATURE_RANGE_C`, or a ValueError naming it."""
    try:
        t = float(temperature_c)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a number of degrees C, got {temperature_c!r}") from None
    lo, hi = TEMPERATURE_RANGE_C
    if not (math.isfinite(t) and lo <= t <= hi):
        raise ValueError(f"{name} must be within the materials' range {lo:g} to {hi:g} C, got {temperature_c!r}")
    return t


def element_params_at(params: ElementParams, temperature_c: float) -> ElementParams:
    """``params`` (given at 25 C) at ``temperature_c`` (C): both Young's moduli moved by their
    temperature coefficients (linear in T; module docstring for the sources)."""
    dt = check_temperature(temperature_c) - REFERENCE_TEMPERATURE_C
    if dt == 0.0:
        return params
    return replace(
        params,
        pzt_youngs_pa=params.pzt_youngs_pa * (1.0 + PZT_YOUNGS_TC_PER_K * dt),
        substrate_youngs_pa=params.substrate_youngs_pa * (1.0 + TITANIUM_YOUNGS_TC_PER_K * dt),
    )


def stiffness_temperature_coefficient(params: ElementParams) -> float:
    """beta, 1/K: EI(T) = EI(25 C) (1 + beta (T - 25)), exactly (EI is linear in both moduli).

    beta = (alpha_p EI_p + alpha_s EI_s) / EI with EI_p, EI_s the PZT's and the substrate's
    shares of physics.md section 1's EI; every resonance moves as sqrt(1 + beta dT).
    """
    b, ts, tp = params.width_m, params.substrate_half_thickness_m, params.pzt_thickness_m
    ei_s = b * params.substrate_youngs_pa * (2 * ts) ** 3 / 12
    ei_p = b * (2 / 3) * params.pzt_youngs_pa * ((ts + tp) ** 3 - ts**3)
    return (PZT_YOUNGS_TC_PER_K * ei_p + TITANIUM_YOUNGS_TC_PER_K * ei_s) / (ei_p + ei_s)


def wlf_log_shift(temperature_c: float) -> float:
    """log10 of the gel's relaxation-time shift a_T from 25 C to ``temperature_c`` (WLF, negative
    when warmer: relaxation times shorten)."""

    def log_a(t_c: float) -> float:
        d = t_c - GEL_GLASS_TRANSITION_C
        return -WLF_C1 * d / (WLF_C2_K + d)

    return log_a(check_temperature(temperature_c)) - log_a(REFERENCE_TEMPERATURE_C)


def gel_params_at(gel: GelParams, temperature_c: float) -> GelParams:
    """``gel`` (given at 25 C) at ``temperature_c`` (C).

    The relaxed modulus scales with absolute temperature, E(T) = E(25) (T + 273.15) / 298.15
    (an entropic network: Treloar, The Physics of Rubber Elasticity, 3rd ed. 1975, ch. 4), and
    every Prony relaxation time is multiplied by a_T of :func:`wlf_log_shift`.  At 35 C the
    relaxed modulus is 3 % higher and the times 3x shorter: the storage modulus at mode 1's
    3.77 kHz falls by about 11 % (measured in tests/test_variation.py).
    """
    t = check_temperature(temperature_c)
    if t == REFERENCE_TEMPERATURE_C:
        return gel
    shift = 10.0 ** wlf_log_shift(t)
    return replace(
        gel,
        youngs_modulus_pa=gel.youngs_modulus_pa * (t + _KELVIN) / (REFERENCE_TEMPERATURE_C + _KELVIN),
        prony_tau_s=tuple(tau * shift for tau in gel.prony_tau_s),
    )


@dataclass(frozen=True)
class VariationSpread:
    """One standard deviation of each unit-to-unit variation (relative unless stated).

    Attributes
    ----------
    freq_common : spread of every mode's natural frequency together (the PZT layers'
        thickness and modulus move all modes alike).  Piezoceramic elements are sold with
        frequency tolerances of +-5 % (Piezo Technologies, "Standard tolerances": +-5 % below
        10 MHz; +-1 % as the tightest they can hold; a bender's mechanical data +-5 %,
        Rphotronics MTP benders): "typical" 1 % (a process holding +-2 %), "wide" 2.5 % (the
        standard +-5 %).
    freq_mode : each mode's own spread on top (the clamp's compliance and the electrodes'
        edges change the mode ratios).  No manufacturer states it; taken as a fifth of the
        common spread (the clamp is machined, the ceramic fired).  Chosen, not sourced.
    damping : spread of the element's damping c (so of 1 / Q): Q_m tolerances are +-20 % (Sensor
        Technology / Morgan material data, "standard tolerance within +-20 %"): "typical" 10 %,
        "wide" 20 % (a mount's own losses add to the ceramic's).
    d31 : spread of the piezoelectric constant: +-10 % (Piezo Technologies, d33 and other
        piezo coefficients): 5 % typical, 10 % wide.  V_0 ~ d31^2.
    capacitance : spread of the sensing capacitance: +-20 % (Piezo Technologies; +-15 % for
        plates, piezoelements.com): 10 % typical, 15 % wide.  V_0 ~ 1 / C.
    gel_modulus : spread of the gel's modulus: the industry's hardness tolerance of +-5
        durometer points (silicone.pro, "What durometer are you getting"; TTH) spans about
        +-20 % of a soft gel's modulus: 10 % typical, 20 % wide.
    gel_thickness : spread of the cast gel's thickness: ISO 3302-1 class M2 holds +-0.15 mm on
        4-6.3 mm moulded dimensions: 1.5 % of 5 mm typical; class M3 (+-0.25 mm) 2.5 % wide.
    coverage_edge_m : spread of each edge of the gel's contact on the element, m: ISO 3302-1
        M2 holds +-0.10 mm below 4 mm: 0.05 mm typical, 0.10 mm wide (M3).
    """

    freq_common: float
    freq_mode: float
    damping: float
    d31: float
    capacitance: float
    gel_modulus: float
    gel_thickness: float
    coverage_edge_m: float

    def __post_init__(self) -> None:
        for f in fields(self):
            v = getattr(self, f.name)
            if not (math.isfinite(v) and v >= 0):
                raise ValueError(f"VariationSpread.{f.name} must be finite and non-negative, got {v!r}")


SPREADS = {
    "typical": VariationSpread(
        freq_common=0.01,
        freq_mode=0.002,
        damping=0.10,
        d31=0.05,
        capacitance=0.10,
        gel_modulus=0.10,
        gel_thickness=0.015,
        coverage_edge_m=0.05e-3,
    ),
    "wide": VariationSpread(
        freq_common=0.025,
        freq_mode=0.005,
        damping=0.20,
        d31=0.10,
        capacitance=0.15,
        gel_modulus=0.20,
        gel_thickness=0.025,
        coverage_edge_m=0.10e-3,
    ),
}


def check_variation(variation: str) -> str:
    if variation not in VARIATIONS:
        raise ValueError(f"unknown sensor.variation {variation!r}; valid: {', '.join(VARIATIONS)}")
    return variation


def check_seed(seed, name: str = "sensor.unit_seed") -> int:
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ValueError(f"{name} must be a non-negative integer, got {seed!r}")
    return int(seed)


@dataclass(frozen=True)
class UnitDraw:
    """One unit's departures from the nominal design (factors, 1 = nominal).

    Attributes
    ----------
    freq_factors : per mode (mode 1 first), the factor on the natural frequency.
    damping_factor : factor on the element's damping c (Q goes as its inverse).
    d31_factor, capacitance_factor : factors on d31 and on the sensing capacitance C.
    gel_modulus_factor, gel_thickness_factor : factors on the gel's modulus and thickness.
    coverage_offsets_m : (dx1, dx2), m, added to the gel's contact edges (clipped to the beam).
    """

    freq_factors: tuple[float, ...]
    damping_factor: float = 1.0
    d31_factor: float = 1.0
    capacitance_factor: float = 1.0
    gel_modulus_factor: float = 1.0
    gel_thickness_factor: float = 1.0
    coverage_offsets_m: tuple[float, float] = (0.0, 0.0)


def draw_unit(variation: str, seed: int, n_modes: int) -> UnitDraw:
    """A unit drawn from ``variation``'s spreads with ``seed`` (the same seed, the same unit).

    Factors are log-normal (exp of a normal of the spread's sigma): always positive, and a
    10 % spread is 10 % either way to first order.  The draws are taken in a fixed order, so a
    unit's parameters do not depend on how many modes are asked for beyond its own.
    """
    spread = SPREADS[check_variation(variation)] if variation != "none" else None
    seed = check_seed(seed)
    if spread is None:
        return UnitDraw(freq_factors=(1.0,) * n_modes)
    rng = np.random.default_rng([seed, 11])  # 11: this module's stream, apart from the noise's seeds
    z = rng.standard_normal(8)
    per_mode = np.random.default_rng([seed, 12]).standard_normal(max(n_modes, 1))[:n_modes]
    common = spread.freq_common * z[0]
    return UnitDraw(
        freq_factors=tuple(float(math.exp(common + spread.freq_mode * u)) for u in per_mode),
        damping_factor=float(math.exp(spread.damping * z[1])),
        d31_factor=float(math.exp(spread.d31 * z[2])),
        capacitance_factor=float(math.exp(spread.capacitance * z[3])),
        gel_modulus_factor=float(math.exp(spread.gel_modulus * z[4])),
        gel_thickness_factor=float(math.exp(spread.gel_thickness * z[5])),
        coverage_offsets_m=(float(spread.coverage_edge_m * z[6]), float(spread.coverage_edge_m * z[7])),
    )


class PhysicalUnit:
    """One manufactured fingertip at its temperature: what the simulation runs, never the readout.

    Parameters
    ----------
    nominal : the design (the readout's model before calibration).
    draw : the unit's departures (:func:`draw_unit`); None for a unit exactly as designed.
    temperature_c : its temperature at the start of a run, C.
    drift_c_per_s : how fast it warms (or cools) during a run, C/s.
    """

    def __init__(
        self, nominal: Fingertip, draw: UnitDraw | None = None, temperature_c: float = REFERENCE_TEMPERATURE_C, drift_c_per_s: float = 0.0
    ) -> None:
        self.nominal = nominal
        self.draw = draw or UnitDraw(freq_factors=(1.0,) * max(nominal.modes))
        if len(self.draw.freq_factors) < max(nominal.modes):
            raise ValueError(f"the unit's draw has {len(self.draw.freq_factors)} mode frequencies; its modes go to {max(nominal.modes)}")
        self.temperature_c = check_temperature(temperature_c)
        if not math.isfinite(drift_c_per_s):
            raise ValueError(f"sensor.temperature_drift_c_per_s must be finite, got {drift_c_per_s!r}")
        self.drift_c_per_s = float(drift_c_per_s)
        d = self.draw
        el = nominal.element
        p = el.params
        self.params_25 = replace(
            p,
            damping_n_s_per_m2=p.damping_n_s_per_m2 * d.damping_factor,
            d31_m_per_v=p.d31_m_per_v * d.d31_factor,
            capacitance_f=p.capacitance_f * d.capacitance_factor,
        )
        self.trims = {m: ModeTrim(freq_factor=d.freq_factors[m - 1]) for m in nominal.modes}
        g = nominal.gel.params
        self.gel_25 = replace(
            g, youngs_modulus_pa=g.youngs_modulus_pa * d.gel_modulus_factor, thickness_m=g.thickness_m * d.gel_thickness_factor
        )
        length = p.length_m
        x1, x2 = nominal.coverage
        dx1, dx2 = d.coverage_offsets_m
        # A contact edge cannot leave the beam: an edge at the tip stays at the tip if the pad overhangs.
        self.coverage = (min(max(x1 + dx1, 0.0), length), min(max(x2 + dx2, 0.0), length))
        if not self.coverage[1] - self.coverage[0] > 0.05 * (x2 - x1):
            raise ValueError(f"the drawn unit's gel coverage {self.coverage} has lost its contact; widen the nominal coverage")
        self.beta_per_k = stiffness_temperature_coefficient(self.params_25)
        self._tips: dict[float, Fingertip] = {}

    def __repr__(self) -> str:
        return f"PhysicalUnit(draw={self.draw!r}, temperature_c={self.temperature_c}, drift_c_per_s={self.drift_c_per_s})"

    def temperature_at(self, time_s: float) -> float:
        """The unit's temperature ``time_s`` into a run, C (clipped to the materials' range)."""
        lo, hi = TEMPERATURE_RANGE_C
        return min(max(self.temperature_c + self.drift_c_per_s * time_s, lo), hi)

    def fingertip_at(self, temperature_c: float) -> Fingertip:
        """The unit as a Fingertip at ``temperature_c`` (C): its element, gel and coverage."""
        t = check_temperature(temperature_c)
        if t not in self._tips:
            nom = self.nominal
            element = SensorElement(element_params_at(self.params_25, t), nom.element.boundary, self.trims)
            gel = GelModel(gel_params_at(self.gel_25, t), nom.gel.frequency_dependent, nom.gel.reference_freq_hz, nom.gel.layer)
            self._tips[t] = Fingertip(element, gel, self.coverage, nom.noise, nom.modes, nom.rated_pressure_pa, nom.mounting)
        return self._tips[t]

    def resonance_ratio(self, temperature_c: float) -> float:
        """omega_n(T) / omega_n(25 C), every mode: sqrt(1 + beta (T - 25)) (beta of
        :func:`stiffness_temperature_coefficient`; the modal mass does not change)."""
        return math.sqrt(1.0 + self.beta_per_k * (temperature_c - REFERENCE_TEMPERATURE_C))

    def gain_ratio(self, temperature_c: float) -> float:
        """The drive-to-sense gain at T over at 25 C: (Y_p(T) / Y_p(25))^2, eq. 17's Y_p^2."""
        return (1.0 + PZT_YOUNGS_TC_PER_K * (temperature_c - REFERENCE_TEMPERATURE_C)) ** 2


__all__ = [
    "REFERENCE_TEMPERATURE_C",
    "SPREADS",
    "TEMPERATURE_RANGE_C",
    "VARIATIONS",
    "PhysicalUnit",
    "UnitDraw",
    "VariationSpread",
    "check_temperature",
    "check_variation",
    "draw_unit",
    "element_params_at",
    "gel_params_at",
    "stiffness_temperature_coefficient",
    "wlf_log_shift",
]
