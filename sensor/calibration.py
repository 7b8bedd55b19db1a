"""Calibration: what the readout measures of its own unit, and the model it reads with.

The readout never sees the physical unit's parameters (:mod:`sensor.variation`): it sees the
nominal design plus what it measured.  Three levels (``sensor.calibration``):

- ``none``: the nominal model, driven at the nominal frequencies.  A unit 1 % off resonance
  reads nearly nothing (Table I's Q ~ 7800: 80 bandwidths away).
- ``self``: the element's own drive and sense layers (the paper's self-sensing function,
  physics.md section 7) sweep each mode unloaded: a coarse sweep over the product's frequency
  tolerance finds the peak; a fine sweep around it, fitted with the single-mode response
  H(w) = G / (rho A (w_r^2 - w^2) + j w c) (:func:`sensor.selftest.frequency_response_v`), gives
  the resonance w_r, the damping c / rho A (so Q) and the complex gain, hence the drive frequency
  (set to w_r) and the reference the readings are normalized by.  What an unloaded sweep cannot
  see (the gel's modulus and thickness, its coverage) stays nominal; its spread enters the
  estimate's uncertainty (:func:`model_uncertainty`).
- ``full``: ``self`` plus a bench: the unit pressed with known pressures (a handful per mode, in
  the mode's range), and the gel's modulus and each mode's modal-load factor (which is all
  that its thickness and coverage change, :class:`sensor.element.ModeTrim`) fitted to them by
  least squares; the fit's covariance is the estimate's calibration uncertainty.

A run then starts with a re-zero (:func:`track_unloaded`): before touch, unloaded, the readout
re-centres each mode's drive on its resonance by the phase of the unloaded reading and
re-normalizes its amplitude, which removes a temperature offset (and reads the temperature
change off the resonance's shift, so the model's gel is taken at that temperature).  What it
cannot separate from load: a resonance that drifts while the fingertip is loaded, which moves
the reading exactly as a gel stiffness does (measured in tests/test_calibration.py).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from .element import ModeTrim, SensorElement
from .fingertip import Fingertip
from .gel import GelModel, GelParams
from .selftest import frequency_response_v
from .variation import (
    REFERENCE_TEMPERATURE_C,
    SPREADS,
    PhysicalUnit,
    check_seed,
    check_temperature,
    check_variation,
    draw_unit,
    gel_params_at,
)

CALIBRATIONS = ("none", "self", "full")

#: The coarse sweep covers the product's frequency tolerance: +-10 % of the nominal frequency
#: (the standard +-5 % of piezoceramic elements, twice over), in steps of a quarter of the
#: nominal bandwidth f / Q, so the peak is never missed (a point lies within an eighth of a
#: bandwidth of it, where the response is above 97 % of the peak).
SWEEP_SPAN = 0.10
SWEEP_STEPS_PER_BANDWIDTH = 4
#: The fine sweep: this many points over +-2 half-bandwidths around the coarse peak, each the
#: average of FINE_AVERAGES readings.
FINE_POINTS = 41
FINE_AVERAGES = 100
#: A sweep point is read after the resonator has settled: 5 time constants (0.7 % left).
SETTLE_TAUS_PER_POINT = 5.0
#: The bench's known pressures: the force's accuracy, relative (a class C3 load cell, OIML R 60,
#: errs by < 0.03 % of its range; 0.1 % allows for the indenter's alignment on the 5 x 7.5 mm
#: face), and the readings averaged at each point.
BENCH_PRESSURE_REL_SIGMA = 1e-3
BENCH_POINTS_PER_MODE = 5
BENCH_AVERAGES = 100
#: Re-zero: readings averaged per tracking step, and steps at most (each halves the error at
#: worst, and converges quadratically near the resonance).
TRACK_AVERAGES = 400
TRACK_STEPS = 12
#: The model's temperature is taken to this resolution, C (its gel tables are shared across
#: runs at the same estimate; the gel's modulus moves ~ 1 %/K, so 0.1 K is 0.1 %).
TEMPERATURE_STEP_C = 0.1


def check_calibration(level: str) -> str:
    if level not in CALIBRATIONS:
        raise ValueError(f"unknown sensor.calibration {level!r}; valid: {', '.join(CALIBRATIONS)}")
    return level


def reading_sigma_v(tip: Fingertip, mode: int) -> float:
    """One reading's noise in volts (in-phase and quadrature each): the readout's two floors
    (:class:`sensor.readout.NoiseParams`) on the unit's own unloaded output."""
    return math.hypot(tip.noise.relative_floor * tip.element.unloaded_voltage(mode), tip.noise.absolute_floor_v)


def _noisy(tip: Fingertip, mode: int, freq_hz: np.ndarray, averages: int, rng: np.random.Generator) -> np.ndarray:
    """The unloaded unit's complex response (V) at ``freq_hz``, each the mean of ``averages`` noisy readings."""
    true = frequency_response_v(tip.element, freq_hz, mode)
    sigma = reading_sigma_v(tip, mode) / math.sqrt(averages)
    return true + rng.normal(0.0, sigma, true.shape) + 1j * rng.normal(0.0, sigma, true.shape)


@dataclass(frozen=True)
class ModeCalibration:
    """What a self-calibration sweep found for one mode.

    Attributes
    ----------
    mode : mode number.
    resonance_hz : the unloaded resonance found, Hz (the drive frequency is set to it).
    quality_factor : the unloaded Q found (dimensionless).
    reference_v : the unloaded complex response at the drive frequency, V: the readings'
        normalization (a reading is the lock-in's output over this).
    sweep_points : readings taken (coarse points plus fine points times their averages).
    sweep_time_s : how long the sweep takes on a real unit, s (every point settled, 5 tau).
    """

    mode: int
    resonance_hz: float
    quality_factor: float
    reference_v: complex
    sweep_points: int
    sweep_time_s: float


def sweep_resonance(unit_tip: Fingertip, nominal: Fingertip, mode: int, rng: np.random.Generator) -> ModeCalibration:
    """Find ``mode``'s unloaded resonance and Q on the unit (``unit_tip``), knowing only ``nominal``.

    The fine sweep's readings H_k are fitted with the single-mode response itself,

        1 / H = (rho A (w_r^2 - w^2) + j w c) / G = k (alpha - x + j beta w / w_c),
        x = (w^2 - w_c^2) / w_c^2,  alpha = (w_r^2 - w_c^2) / w_c^2,  beta = c / (rho A w_c),

    by least squares on H (the noise is on H, not on 1 / H) over the two real unknowns
    (alpha, beta), the complex k = rho A w_c^2 / G solved in closed form for each (variable
    projection), started from the linear fit 1 / H ~ c0 + c1 x (alpha + j beta ~ -c0 / c1).
    Exact for the single-mode response, so its error is the readings' noise alone.  Then
    w_r = w_c sqrt(1 + alpha), Q = w_r / (beta w_c) and the reference H(w_r) = 1 / (j k beta w_r / w_c).
    """
    from scipy.optimize import least_squares

    f_nom = nominal.freq_hz(mode)
    q_nom = nominal.element.quality_factor(mode)
    bandwidth = f_nom / q_nom
    step = bandwidth / SWEEP_STEPS_PER_BANDWIDTH
    n_half = math.ceil(SWEEP_SPAN * f_nom / step)
    coarse_f = f_nom + step * np.arange(-n_half, n_half + 1)
    coarse_f = coarse_f[coarse_f > 0]
    coarse = _noisy(unit_tip, mode, coarse_f, 1, rng)
    f_peak = float(coarse_f[int(np.argmax(np.abs(coarse)))])
    fine_f = f_peak + np.linspace(-1.0, 1.0, FINE_POINTS) * bandwidth  # +-2 half-bandwidths
    h = _noisy(unit_tip, mode, fine_f, FINE_AVERAGES, rng)
    w_c = 2 * math.pi * f_peak
    w = 2 * math.pi * fine_f
    scale = 1.0 / q_nom  # alpha, beta and x are of order 1 / Q: fit them in units of it
    x = (w * w - w_c * w_c) / (w_c * w_c)
    root = np.sqrt(1.0 + x)

    def shape(theta: np.ndarray) -> np.ndarray:  # 1 / (k H) of the model, in units of scale
        return theta[0] - x / scale + 1j * theta[1] * root

    def residual(theta: np.ndarray) -> np.ndarray:
        g = 1.0 / shape(theta)  # H k
        k_inv = np.vdot(g, h) / np.vdot(g, g)  # the least-squares 1 / k for this shape
        r = h - k_inv * g
        return np.concatenate([r.real, r.imag])

    lin = np.polyfit(x / scale, 1.0 / h, 1)
    start = -lin[1] / lin[0]
    fit = least_squares(residual, [start.real, max(start.imag, 1e-3)], x_scale="jac")
    alpha, beta = fit.x[0] * scale, fit.x[1] * scale
    g = 1.0 / shape(fit.x)
    k_inv = complex(np.vdot(g, h) / np.vdot(g, g)) * scale  # 1 / k: H = g / (k scale)
    w_r = w_c * math.sqrt(1.0 + alpha)
    c_over_rho_a = beta * w_c
    if not (math.isfinite(w_r) and c_over_rho_a > 0 and fit.success):
        raise ValueError(f"self-calibration of mode {mode} found no resonance (alpha {alpha!r}, beta {beta!r})")
    reference = k_inv / (1j * beta * w_r / w_c)
    q = w_r / c_over_rho_a
    tau = 2.0 * q / w_r
    points = coarse_f.size + FINE_POINTS * FINE_AVERAGES
    return ModeCalibration(mode, w_r / (2 * math.pi), q, reference, points, (coarse_f.size + FINE_POINTS) * SETTLE_TAUS_PER_POINT * tau)


def model_fingertip(
    nominal: Fingertip,
    resonance_hz: dict[int, float],
    quality_factor: dict[int, float],
    reference_v: dict[int, complex],
    gel: GelParams,
    load_factors: dict[int, float] | None = None,
) -> Fingertip:
    """The readout's model of a calibrated unit: the nominal design with the measured
    resonances, the measured damping (one c for the element, the mean over its modes of
    w_r rho A / Q: eq. 4's c is one number), each mode's measured unloaded amplitude (as its
    gain), ``gel`` and, from a bench, each mode's modal-load factor."""
    el = nominal.element
    p = el.params
    c_hat = float(np.mean([2 * math.pi * resonance_hz[m] * p.mass_per_length_kg_m / quality_factor[m] for m in nominal.modes]))
    params = replace(p, damping_n_s_per_m2=c_hat)
    bare = SensorElement(params, el.boundary)
    freq = {m: 2 * math.pi * resonance_hz[m] / bare.natural_angular_frequency(m) for m in nominal.modes}
    shaped = SensorElement(params, el.boundary, {m: ModeTrim(freq_factor=freq[m]) for m in nominal.modes})
    load = load_factors or {}
    trims = {
        m: ModeTrim(freq_factor=freq[m], gain_factor=abs(reference_v[m]) / shaped.unloaded_voltage(m), load_factor=load.get(m, 1.0))
        for m in nominal.modes
    }
    model_gel = GelModel(gel, nominal.gel.frequency_dependent, nominal.gel.reference_freq_hz, nominal.gel.layer)
    return Fingertip(
        SensorElement(params, el.boundary, trims),
        model_gel,
        nominal.coverage,
        nominal.noise,
        nominal.modes,
        nominal.rated_pressure_pa,
        nominal.mounting,
    )


# ---------------------------------------------------------------------------------------
# The readings a readout takes of a physical unit (steady state, in its own normalization).
# ---------------------------------------------------------------------------------------


def steady_reading(unit_tip: Fingertip, mode: int, pressure_pa, drive_hz: float, reference_v: complex) -> np.ndarray:
    """The steady, noise-free reading (complex, the readout's normalization) of a unit driven at
    ``drive_hz`` under a uniform ``pressure_pa`` (Pa): the modal equation with the gel's load
    (eq. 10) off resonance, over the reference:

        V_s = G / (rho A (w_r^2 - w_d^2) + kappa + j w_d (gamma + c)),  reading = V_s / reference,

    G = V_0 w_r c the unit's drive-to-sense gain (:func:`sensor.selftest.frequency_response_v`'s).
    Driven on its own resonance and normalized by its own unloaded response this is exactly
    the envelope of eq. 19 (|reading| = V_1).
    """
    el = unit_tip.element
    p = el.params
    w_r = el.natural_angular_frequency(mode)
    w_d = 2 * math.pi * drive_hz
    gain = el.unloaded_voltage(mode) * w_r * p.damping_n_s_per_m2
    kappa, gamma = unit_tip.modal_load(pressure_pa, mode)
    detune = p.mass_per_length_kg_m * (w_r * w_r - w_d * w_d)
    return gain / (detune + kappa + 1j * w_d * (gamma + p.damping_n_s_per_m2)) / reference_v


#: Beyond this detuning (half-bandwidths) the reading's real part is too small against its
#: noise to give the gain: :func:`detuning` then takes the gain as unchanged.
_DETUNING_EXACT_MAX = 10.0


def detuning(z: complex) -> tuple[float, float]:
    """(delta, g) of an unloaded steady reading z = g / (1 - j delta) (g > 0 the gain's drift,
    delta = rho A (w_r^2 - w_d^2) / (w_d c) the detuning in half-bandwidths; the single-mode
    response over a reference taken on resonance).  1 / z = (1 - j delta) / g.

    Far from resonance (|delta| > 10, or a real part lost in noise: g outside 0.5..2)
    Re(1 / z) is a small
    difference of large numbers: there the gain is taken as 1 and |delta| from the amplitude,
    |z| = 1 / sqrt(1 + delta^2), with the sign of Im z; a tracking loop's next step, nearer
    the resonance, measures both.
    """
    z = complex(z)
    inv = 1.0 / z
    if inv.real > 0:
        g = 1.0 / inv.real
        delta = -inv.imag * g
        # the gain drifts by percent (eq. 17's Y_p^2 over tens of K); a g far from 1 is noise
        if abs(delta) <= _DETUNING_EXACT_MAX and 0.5 < g < 2.0:
            return delta, g
    return math.copysign(math.sqrt(max(1.0 / abs(z) ** 2 - 1.0, 0.0)), z.imag), 1.0


def track_unloaded(
    unit_tip: Fingertip, mode: int, drive_hz: float, reference_v: complex, tau0_s: float, rng: np.random.Generator
) -> tuple[float, complex]:
    """Re-zero one mode while unloaded: re-centre the drive on the resonance and renormalize.

    Each step reads the unloaded response at the drive (TRACK_AVERAGES readings), takes its
    detuning delta and gain drift g (:func:`detuning`), moves the drive by delta / tau0 (rad/s;
    the detuning's definition with rho A (w_r^2 - w_d^2) ~ 2 rho A w_d dw and tau0 = 2 rho A / c)
    and scales the reference by g.  Returns the new (drive_hz, reference_v).
    """
    for _ in range(TRACK_STEPS):
        h = complex(_noisy(unit_tip, mode, np.array([drive_hz]), TRACK_AVERAGES, rng)[0])
        delta, g = detuning(h / reference_v)
        if not (math.isfinite(delta) and g > 0):
            raise ValueError(f"re-zero of mode {mode} lost the resonance (reading {h / reference_v!r})")
        new_hz = drive_hz + delta / tau0_s / (2 * math.pi)
        reference_v = reference_v * g * drive_hz / new_hz
        drive_hz = new_hz
        if abs(delta) < 1e-3:
            break
    # The final reference: the response at the final drive, so an unloaded reading reads 1.
    h = complex(_noisy(unit_tip, mode, np.array([drive_hz]), TRACK_AVERAGES, rng)[0])
    return drive_hz, h


# ---------------------------------------------------------------------------------------
# The model's error: what calibration did not measure, as the estimate's relative sigma.
# ---------------------------------------------------------------------------------------


def _inverse_shift(model: Fingertip, other: Fingertip, mode: int, pressure_pa: np.ndarray) -> np.ndarray:
    """log(P_hat / P) when ``other`` is the truth and ``model`` reads it, per pressure (Pa): the
    model's V_1 curve inverted at other's V_1 (both monotone up to their first rise)."""
    v_model = model.output(pressure_pa, mode)
    v_other = other.output(pressure_pa, mode)
    rising = np.nonzero(np.diff(v_model) > 1e-12)[0]
    end = rising[0] + 1 if rising.size else v_model.size
    log_p = np.log(pressure_pa)
    log_hat = np.interp(-v_other, -v_model[:end], log_p[:end], left=np.nan, right=np.nan)
    return log_hat - log_p


def _with_gel(tip: Fingertip, gel: GelParams | None = None, coverage=None, load: dict[int, float] | None = None) -> Fingertip:
    el = tip.element
    element = el
    if load:
        trims = {m: replace(el.trim(m), load_factor=el.trim(m).load_factor * load.get(m, 1.0)) for m in tip.modes}
        element = SensorElement(el.params, el.boundary, trims)
    g = tip.gel if gel is None else GelModel(gel, tip.gel.frequency_dependent, tip.gel.reference_freq_hz, tip.gel.layer)
    return Fingertip(element, g, coverage or tip.coverage, tip.noise, tip.modes, tip.rated_pressure_pa, tip.mounting)


def model_uncertainty(
    model: Fingertip, level: str, variation: str, fit_cov: np.ndarray | None, pressure_pa: np.ndarray
) -> dict[int, np.ndarray]:
    """Per mode, the estimate's relative sigma from calibration, on ``pressure_pa`` (Pa).

    ``self``: the unmeasured parameters at one sigma of the product's spread (the gel's
    modulus, its thickness, each coverage edge), each shifting the inverse by
    log(P_hat / P) (:func:`_inverse_shift`), added in quadrature.  ``full``: the fitted
    parameters' covariance ``fit_cov`` (log modulus factor, then each mode's log load factor)
    through the same shifts per unit parameter.  ``none``: zeros (the nominal readout claims
    no calibration error; its estimate is wrong by the unit's departures, unreported).
    """
    zeros = {m: np.zeros(pressure_pa.size) for m in model.modes}
    if level == "none" or (variation == "none" and level == "self"):
        return zeros
    g = model.gel.params
    out = {}
    if level == "self":
        spread = SPREADS[variation]
        x1, x2 = model.coverage
        e = spread.coverage_edge_m
        variants = [
            _with_gel(model, replace(g, youngs_modulus_pa=g.youngs_modulus_pa * math.exp(spread.gel_modulus))),
            _with_gel(model, replace(g, thickness_m=g.thickness_m * math.exp(spread.gel_thickness))),
            # each edge one sigma inwards (an edge at an end of the beam can only move inwards)
            _with_gel(model, coverage=(x1 + e, x2)),
            _with_gel(model, coverage=(x1, x2 - e)),
        ]
        for m in model.modes:
            shifts = np.nan_to_num(np.stack([_inverse_shift(model, v, m, pressure_pa) for v in variants]), nan=0.0)
            out[m] = np.sqrt(np.sum(shifts**2, axis=0))
        return out
    # full: unit steps in each fitted parameter, then the covariance.
    h = 1e-3
    params = [_with_gel(model, replace(g, youngs_modulus_pa=g.youngs_modulus_pa * math.exp(h)))]
    params += [_with_gel(model, load={m: math.exp(h)}) for m in model.modes]
    for m in model.modes:
        jac = np.nan_to_num(np.stack([_inverse_shift(model, v, m, pressure_pa) / h for v in params]), nan=0.0)  # (n_par, n_p)
        var = np.einsum("ip,ij,jp->p", jac, fit_cov, jac)
        out[m] = np.sqrt(np.maximum(var, 0.0))
    return out


# ---------------------------------------------------------------------------------------
# Calibration and the run's set-up.
# ---------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Calibration:
    """A unit's calibration at 25 C: what was measured and the model the readout reads with.

    Attributes
    ----------
    level : "none", "self" or "full".
    modes : per mode, what the self-calibration sweep found (empty for "none").
    model : the readout's model at 25 C (:func:`model_fingertip`; the nominal one for "none").
    gel_modulus_factor : the gel's modulus over nominal fitted on the bench (1 unless "full").
    load_factors : per mode, the modal-load factor fitted on the bench (1 unless "full").
    fit_cov : the bench fit's covariance of (log modulus factor, log load factor per mode), or None.
    bench_points : the known-load points pressed (0 unless "full").
    """

    level: str
    modes: tuple[ModeCalibration, ...]
    model: Fingertip
    gel_modulus_factor: float = 1.0
    load_factors: tuple[float, ...] = ()
    fit_cov: np.ndarray | None = None
    bench_points: int = 0

    def summary(self) -> dict:
        """JSON-ready: the level and, per mode, what was found (Hz, Q, sweep cost)."""
        return {
            "level": self.level,
            "modes": [
                {"mode": c.mode, "resonance_hz": c.resonance_hz, "quality_factor": c.quality_factor, "sweep_time_s": c.sweep_time_s}
                for c in self.modes
            ],
            "gel_modulus_factor": self.gel_modulus_factor,
            "load_factors": list(self.load_factors),
            "bench_points": self.bench_points,
        }


def _bench_fit(
    unit_tip: Fingertip, model: Fingertip, cal: dict[int, ModeCalibration], rng: np.random.Generator
) -> tuple[float, dict[int, float], np.ndarray, int]:
    """The known-load calibration: press, read, fit (module docstring).  Returns the modulus
    factor, the per-mode load factors, the fit's covariance and the number of points."""
    modes = model.modes
    pressures, readings, sigmas, mode_of = [], [], [], []
    for m in modes:
        lo, hi = model.detection_limit(m), model.upper_limit(m)
        if not (math.isfinite(lo) and math.isfinite(hi) and hi > lo):
            continue
        p_true = np.geomspace(3.0 * lo, hi, BENCH_POINTS_PER_MODE)
        # the bench knows its pressure to BENCH_PRESSURE_REL_SIGMA; the unit feels the true one
        p_known = p_true * (1.0 + BENCH_PRESSURE_REL_SIGMA * rng.standard_normal(p_true.size))
        v_true = np.abs(steady_reading(unit_tip, m, p_true, cal[m].resonance_hz, cal[m].reference_v))
        noise = model.sigma(m) / math.sqrt(BENCH_AVERAGES)
        v = v_true + noise * rng.standard_normal(p_true.size)
        slope = np.abs(model.output_slope(p_known, m))
        pressures.append(p_known)
        readings.append(v)
        sigmas.append(np.hypot(noise, slope * p_known * BENCH_PRESSURE_REL_SIGMA))
        mode_of.append(np.full(p_true.size, m))
    p_k, v_k, s_k, m_k = (np.concatenate(a) for a in (pressures, readings, sigmas, mode_of))
    g = model.gel.params

    def predict(theta: np.ndarray) -> np.ndarray:
        tip = _with_gel(
            model,
            replace(g, youngs_modulus_pa=g.youngs_modulus_pa * math.exp(theta[0])),
            load={m: math.exp(theta[1 + i]) for i, m in enumerate(modes)},
        )
        out = np.empty_like(p_k)
        for m in modes:
            sel = m_k == m
            if np.any(sel):
                out[sel] = tip.output(p_k[sel], m)
        return out

    from scipy.optimize import least_squares

    def residual(theta: np.ndarray) -> np.ndarray:
        return (v_k - predict(theta)) / s_k

    # log factors within +-1 (a factor e either way: far beyond any spread)
    fit = least_squares(residual, np.zeros(1 + len(modes)), bounds=(-1.0, 1.0), x_scale=0.1, diff_step=1e-6)
    theta, r, jac = fit.x, fit.fun, fit.jac
    cov = np.linalg.pinv(jac.T @ jac)
    # a fit worse than its noise (chi2 / dof > 1) means something unmodelled: widen by it
    dof = max(p_k.size - theta.size, 1)
    cov *= max(1.0, float(r @ r) / dof)
    return math.exp(theta[0]), {m: math.exp(theta[1 + i]) for i, m in enumerate(modes)}, cov, int(p_k.size)


def calibrate(level: str, unit: PhysicalUnit, rng: np.random.Generator) -> Calibration:
    """Calibrate ``unit`` at 25 C to ``level`` (module docstring); the readout knows only
    ``unit.nominal`` beforehand."""
    check_calibration(level)
    nominal = unit.nominal
    if level == "none":
        return Calibration("none", (), nominal)
    tip25 = unit.fingertip_at(REFERENCE_TEMPERATURE_C)
    found = {m: sweep_resonance(tip25, nominal, m, rng) for m in nominal.modes}
    model = model_fingertip(
        nominal,
        {m: c.resonance_hz for m, c in found.items()},
        {m: c.quality_factor for m, c in found.items()},
        {m: c.reference_v for m, c in found.items()},
        nominal.gel.params,
    )
    if level == "self":
        return Calibration("self", tuple(found.values()), model)
    modulus, load, cov, n = _bench_fit(tip25, model, found, rng)
    g = nominal.gel.params
    fitted = model_fingertip(
        nominal,
        {m: c.resonance_hz for m, c in found.items()},
        {m: c.quality_factor for m, c in found.items()},
        {m: c.reference_v for m, c in found.items()},
        replace(g, youngs_modulus_pa=g.youngs_modulus_pa * modulus),
        load,
    )
    return Calibration("full", tuple(found.values()), fitted, modulus, tuple(load[m] for m in nominal.modes), cov, n)


@dataclass(frozen=True)
class UnitConfig:
    """Which unit a run uses and how it is calibrated (the ``sensor.*`` keys).

    Attributes
    ----------
    variation : "none", "typical" or "wide" (:mod:`sensor.variation`).
    unit_seed : the unit's seed (the same seed, the same unit).
    calibration : "none", "self", "full"; None: "self" for a unit that differs from the
        nominal one (varied, or not at 25 C, or drifting), else "none".
    temperature_c : the unit's temperature at the start of a run, C.
    drift_c_per_s : how fast it warms during a run, C/s.
    """

    variation: str = "none"
    unit_seed: int = 0
    calibration: str | None = None
    temperature_c: float = REFERENCE_TEMPERATURE_C
    drift_c_per_s: float = 0.0

    def __post_init__(self) -> None:
        check_variation(self.variation)
        check_seed(self.unit_seed)
        if self.calibration is not None:
            check_calibration(self.calibration)
        check_temperature(self.temperature_c)
        if not math.isfinite(self.drift_c_per_s):
            raise ValueError(f"sensor.temperature_drift_c_per_s must be finite, got {self.drift_c_per_s!r}")

    @property
    def is_nominal(self) -> bool:
        """The physical unit is the nominal model itself (today's behaviour)."""
        return self.variation == "none" and self.temperature_c == REFERENCE_TEMPERATURE_C and self.drift_c_per_s == 0.0

    @property
    def level(self) -> str:
        if self.calibration is not None:
            return self.calibration
        return "none" if self.is_nominal else "self"


class SensorUnit:
    """A run's fingertip: the physical unit, its calibration, and the readout's state at the start.

    Built by :func:`sensor_unit`.  The simulation (:class:`sensor.channel.SensorChannel`) runs
    ``physical``; the readout and the controller get ``model`` (the nominal design plus what
    calibration and the start's re-zero measured), the per-mode drive frequencies and
    references, and the estimate's calibration uncertainty.

    Attributes
    ----------
    config : the UnitConfig.
    physical : the PhysicalUnit.
    calibration : the Calibration (at 25 C).
    model : the readout's model for this run (at the temperature it inferred at the start).
    drive_hz : per mode, the drive frequency at the start, Hz.
    reference_v : per mode, the complex reference at the start, V.
    temperature_estimate_c : the temperature the readout inferred from its resonances' shift, C.
    tracking : whether the readout re-zeroes while unloaded during the run (any calibration).
    """

    def __init__(self, config: UnitConfig, nominal: Fingertip, rng_seed: int = 0) -> None:
        self.config = config
        self.readout_cache: dict = {}  # the channels' calibrated inverses, shared by a run's pads
        draw = draw_unit(config.variation, config.unit_seed, max(nominal.modes))
        self.physical = PhysicalUnit(nominal, draw, config.temperature_c, config.drift_c_per_s)
        # calibration noise: its own stream, from the unit's seed (the same unit, the same calibration)
        rng = np.random.default_rng([config.unit_seed, 21, rng_seed])
        level = config.level
        self.calibration = calibrate(level, self.physical, rng)
        self.tracking = level != "none"
        if level == "none":
            self.drive_hz = {m: nominal.freq_hz(m) for m in nominal.modes}
            el = nominal.element
            # the nominal reference: the design's unloaded response on its resonance, -j V_0
            self.reference_v = {m: complex(frequency_response_v(el, self.drive_hz[m], m)) for m in nominal.modes}
            self.temperature_estimate_c = REFERENCE_TEMPERATURE_C
            self.model = nominal
        else:
            found = {c.mode: c for c in self.calibration.modes}
            tip_start = self.physical.fingertip_at(config.temperature_c)
            drive, ref = {}, {}
            for m in nominal.modes:
                tau0 = 2.0 * found[m].quality_factor / (2 * math.pi * found[m].resonance_hz)
                drive[m], ref[m] = track_unloaded(tip_start, m, found[m].resonance_hz, found[m].reference_v, tau0, rng)
            self.drive_hz, self.reference_v = drive, ref
            # The element is its own thermometer: every resonance moves as sqrt(1 + beta dT)
            # (beta the design's, sensor.variation); the mean over modes of the measured shift.
            beta = self.physical.beta_per_k  # the design's coefficient (the unit's stiffness spread does not change beta)
            shift = np.mean([(drive[m] / found[m].resonance_hz) ** 2 - 1.0 for m in nominal.modes])
            t_est = REFERENCE_TEMPERATURE_C + shift / beta
            t_est = round(t_est / TEMPERATURE_STEP_C) * TEMPERATURE_STEP_C
            self.temperature_estimate_c = float(min(max(t_est, -20.0), 80.0))
            g = nominal.gel.params
            gel = replace(g, youngs_modulus_pa=g.youngs_modulus_pa * self.calibration.gel_modulus_factor)
            load = dict(zip(nominal.modes, self.calibration.load_factors, strict=True)) if self.calibration.load_factors else None
            self.model = model_fingertip(
                nominal,
                drive,
                # c / rho A = w_r / Q is what the sweep measured; the drive moved with temperature
                {m: found[m].quality_factor * drive[m] / found[m].resonance_hz for m in nominal.modes},
                ref,
                gel_params_at(gel, self.temperature_estimate_c),
                load,
            )

    @property
    def coverage(self) -> tuple[float, float]:
        """The physical unit's gel coverage, m (where the pad's pressure reaches the element)."""
        return self.physical.coverage

    def reading(self, mode: int, pressure_pa, temperature_c: float | None = None) -> np.ndarray:
        """The steady, noise-free reading (complex, the readout's normalization) at the start's
        drive and reference under uniform ``pressure_pa`` (Pa), at ``temperature_c`` (default: the start's)."""
        t = self.config.temperature_c if temperature_c is None else temperature_c
        return steady_reading(self.physical.fingertip_at(t), mode, pressure_pa, self.drive_hz[mode], self.reference_v[mode])

    def reading_sigma(self, mode: int) -> float:
        """One reading's noise (each of I and Q) in the readout's normalization (dimensionless)."""
        return reading_sigma_v(self.physical.fingertip_at(self.config.temperature_c), mode) / abs(self.reference_v[mode])

    def uncertainty_tables(self, pressure_pa: np.ndarray) -> dict[int, np.ndarray]:
        """Per mode, the estimate's relative sigma from calibration on ``pressure_pa`` (Pa)."""
        key = ("uncertainty", pressure_pa.size, float(pressure_pa[0]), float(pressure_pa[-1]))
        if key not in self.readout_cache:
            self.readout_cache[key] = model_uncertainty(
                self.model, self.config.level, self.config.variation, self.calibration.fit_cov, pressure_pa
            )
        return self.readout_cache[key]


_UNITS: dict[tuple, SensorUnit] = {}


def sensor_unit(config: UnitConfig, nominal: Fingertip) -> SensorUnit:
    """The run's :class:`SensorUnit`, built once per process for each (unit, nominal design)."""
    key = (config, nominal.config_key())
    if key not in _UNITS:
        _UNITS[key] = SensorUnit(config, nominal)
    return _UNITS[key]


__all__ = [
    "CALIBRATIONS",
    "Calibration",
    "ModeCalibration",
    "SensorUnit",
    "UnitConfig",
    "calibrate",
    "check_calibration",
    "detuning",
    "model_fingertip",
    "model_uncertainty",
    "sensor_unit",
    "steady_reading",
    "sweep_resonance",
    "track_unloaded",
]
