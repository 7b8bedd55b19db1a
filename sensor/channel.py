"""One instrumented fingertip as a running instrument: pressure profile in, reading out.

A :class:`SensorChannel` holds what a real readout holds between samples: the mode it is
driving, the resonator's complex envelope (physics.md section 6) and the noise generator.
Each :meth:`SensorChannel.update` takes the pad's pressure along the element (one value per
cell, Pa) and the time since the last sample, and returns a :class:`Reading`.

Only what the scene asks for is computed: the per-mode tables of (k_e, c_e) against
pressure are built once per channel, for its modes only, and a sample evaluates the
active mode alone (the other modes' outputs, for plots, are computed after a run from the
recorded pressures: analysis/run_report.py).

A sample is scalar work (a few table lookups and complex numbers), so it runs on Python
floats and complex numbers: numpy's per-call overhead on 0-d arrays would cost ten times the
arithmetic.  The formulas are those of :mod:`sensor.readout` (``_steady``, ``_rate`` and
``_step`` below restate them for scalars; tests/test_channel_perf_equivalence.py checks them
against the documented functions).  :meth:`SensorChannel.update` checks its input and the
co-simulation, whose profiles are checked by construction, calls
:meth:`SensorChannel.update_trusted`.
"""

from __future__ import annotations

import cmath
import math
from bisect import bisect_right
from collections import deque
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from .carrier import CarrierResonator
from .fingertip import Fingertip
from .readout import relaxation_steady, ring_up_steady

DYNAMICS = ("steady", "envelope", "carrier")
#: A ring-up inversion is trusted while it amplifies the reading's noise at most this much
#: (the estimate's uncertainty is multiplied by the gain, so the controller sees the cost).
RINGUP_MAX_GAIN = 10.0
#: After a switch the readout inverts the ring-up for this many (estimated) time constants,
#: then reads the envelope as settled.
RINGUP_WINDOW_TAUS = 8.0
#: Windows (s) over which the readout fits a relaxation to two readings after a load change.
RELAXATION_WINDOWS_S = (0.02, 0.05, 0.1, 0.2, 0.4)
#: Readings kept for those fits (at least the longest window at the finest control period).
_HISTORY = 512
#: A settled reading stays settled while it moves by at most this many sigmas (per I/Q, x sqrt 2).
_LATCH_SIGMAS = 4.0 * math.sqrt(2.0)
#: Noise is drawn in blocks (one generator call per block, not per reading).
_NOISE_BLOCK = 4096
#: Pressure table for the fast path, Pa: log-spaced, 60 points per decade.
_TABLE_P = np.logspace(-3, 7, 601)
#: A reading is "settled" once the transient has decayed below this fraction.
SETTLE_FRACTION = 1e-3
#: Settling takes this many time constants: ln(1 / SETTLE_FRACTION).
_SETTLE_TAUS = math.log(1.0 / SETTLE_FRACTION)


def _interp(x: float, xp: list[float], fp: list[float]) -> float:
    """``np.interp(x, xp, fp)`` for one float and increasing ``xp`` (lists): the same interval,
    the same arithmetic (slope (fp[j+1] - fp[j]) / (xp[j+1] - xp[j]) times (x - xp[j]) plus
    fp[j]), the same clamping at the ends; NaN for NaN."""
    if x >= xp[-1]:
        return fp[-1]
    if x >= xp[0]:
        j = bisect_right(xp, x) - 1
        return (fp[j + 1] - fp[j]) / (xp[j + 1] - xp[j]) * (x - xp[j]) + fp[j]
    if x < xp[0]:
        return fp[0]
    return math.nan


def _steady(omega: float, c: float, kappa: float, gamma: float) -> complex:
    """:func:`sensor.readout.steady_envelope` for floats."""
    return omega * c / (omega * (gamma + c) - 1j * kappa)


def _rate(mass_per_length_kg_m: float, omega: float, c: float, kappa: float, gamma: float) -> complex:
    """:func:`sensor.readout.envelope_rate` for floats."""
    return (c + gamma) / (2.0 * mass_per_length_kg_m) - 1j * kappa / (2.0 * omega * mass_per_length_kg_m)


def _step(envelope: complex, steady: complex, dt_s: float, rate: complex) -> complex:
    """:func:`sensor.readout.envelope_step` for Python complex numbers."""
    return steady + (envelope - steady) * cmath.exp(-rate * dt_s)


@dataclass(frozen=True)
class Reading:
    """One sample of one channel.

    Attributes
    ----------
    mode : the mode being driven.
    v1 : the measured normalized output |V_s| / V_0 (noisy), dimensionless.
    v1_true : the same without noise, dimensionless.
    phase_rad : phase change relative to the unloaded pi/2 (noise-free), rad.
    time_in_mode_s : time since the drive entered this mode, s.
    tau_s : the envelope's current time constant 1 / Re(lambda), s.
    settled : whether a ring-up has decayed below SETTLE_FRACTION by the simulator's own
        knowledge of the load (time_in_mode_s >= tau_s ln(1 / SETTLE_FRACTION)); ground truth
        for diagnostics and tests; the readout decides by itself (:meth:`SensorChannel.estimate`).
        Always True for steady dynamics.
    kappa, gamma : the generalized gel load on the driven mode, N/m^2 and N s/m^2.
    iq : the lock-in's complex output (in-phase + j quadrature, noisy), normalized like the
        envelope; v1 = |iq|.
    """

    mode: int
    v1: float
    v1_true: float
    phase_rad: float
    time_in_mode_s: float
    tau_s: float
    settled: bool
    kappa: float
    gamma: float
    iq: complex = 0j


_new = object.__new__


def _reading(mode, v1, v1_true, phase_rad, time_in_mode_s, tau_s, settled, kappa, gamma, iq) -> Reading:
    """``Reading(...)`` for the per-step path, at half the cost: a frozen dataclass's __init__
    sets each field through object.__setattr__; this fills the instance's dict at once.  The
    result is an ordinary, frozen Reading (tests check it equals the constructor's)."""
    r = _new(Reading)
    r.__dict__.update(
        mode=mode,
        v1=v1,
        v1_true=v1_true,
        phase_rad=phase_rad,
        time_in_mode_s=time_in_mode_s,
        tau_s=tau_s,
        settled=settled,
        kappa=kappa,
        gamma=gamma,
        iq=iq,
    )
    return r


class FoundationTable:
    """(k_e, c_e) against pressure for one mode, tabulated in log-log and interpolated.

    Below the table's first pressure both are linear in P (the contact fraction is), so the
    first point's ratio extrapolates exactly.  The interpolation error (1e-4 relative,
    tests/test_channel.py) is what the presets without ``exact_gel`` pay.
    """

    def __init__(self, fingertip: Fingertip, mode: int) -> None:
        k, c = fingertip.foundation(_TABLE_P, mode)
        if np.any(k <= 0):
            raise ValueError("FoundationTable needs a positive k_e (the Winkler layer); use exact=True for the dynamic layer")
        self._log_p = np.log(_TABLE_P)
        self._log_k = np.log(k)
        self._log_c = np.log(c)
        self._k0, self._c0 = k[0] / _TABLE_P[0], c[0] / _TABLE_P[0]
        self._p0 = _TABLE_P[0]
        # For :meth:`at`: the columns as lists, Python floats.
        self._k0_f, self._c0_f, self._p0_f = float(self._k0), float(self._c0), float(self._p0)
        self._log_p_list = self._log_p.tolist()
        self._log_k_list = self._log_k.tolist()
        self._log_c_list = self._log_c.tolist()

    def __call__(self, pressure_pa: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        p = np.asarray(pressure_pa, float)
        lp = np.log(np.maximum(p, self._p0))
        k = np.exp(np.interp(lp, self._log_p, self._log_k))
        c = np.exp(np.interp(lp, self._log_p, self._log_c))
        low = p < self._p0
        if np.any(low):
            k = np.where(low, p * self._k0, k)
            c = np.where(low, p * self._c0, c)
        return k, c

    def at(self, pressure_pa: float) -> tuple[float, float]:
        """(k_e, c_e) at one pressure (a float, Pa): :meth:`__call__`'s table and formulas, one
        interval search for both, in Python floats (equal to ``__call__`` within rounding)."""
        p = pressure_pa
        if p < self._p0_f:
            return p * self._k0_f, p * self._c0_f
        lp, xp = math.log(p), self._log_p_list
        log_k, log_c = self._log_k_list, self._log_c_list
        if lp >= xp[-1]:
            return math.exp(log_k[-1]), math.exp(log_c[-1])
        if lp > xp[0]:
            j = bisect_right(xp, lp) - 1
            dx, h = lp - xp[j], xp[j + 1] - xp[j]
            return math.exp((log_k[j + 1] - log_k[j]) / h * dx + log_k[j]), math.exp((log_c[j + 1] - log_c[j]) / h * dx + log_c[j])
        if lp <= xp[0]:  # p0 itself, where math.log may round below the table's first point
            return math.exp(log_k[0]), math.exp(log_c[0])
        return math.nan, math.nan


@dataclass(frozen=True)
class Estimate:
    """The readout's pressure estimate from one reading (what a controller may use).

    Attributes
    ----------
    pressure_pa : estimate, Pa (NaN when saturated or settling).
    uncertainty_pa : one standard deviation of the estimate, Pa (NaN when unknown).
    status : "ok", "below_detection" (within 3 sigma of unloaded: P is below the mode's
        P_min, reported as the estimate clipped at >= 0), "saturated" (past the mode's P_max)
        or "settling" (the resonator has not settled since the last switch or load step).
    """

    pressure_pa: float
    uncertainty_pa: float
    status: str


def _estimate(pressure_pa: float, uncertainty_pa: float, status: str) -> Estimate:
    """``Estimate(...)`` for the per-step path (see :func:`_reading`)."""
    e = _new(Estimate)
    e.__dict__.update(pressure_pa=pressure_pa, uncertainty_pa=uncertainty_pa, status=status)
    return e


class ModeInverse:
    """Fast inverse of one mode's uniform-pressure response: V_1 -> P by table lookup.

    The forward curve is tabulated once on the channel's log-pressure grid; a reading is
    inverted by linear interpolation in log P (the curve is monotone), its uncertainty from
    the tabulated slope.  Status thresholds are the fingertip's P_min and P_max of the mode.
    A call works on Python floats (the tables as lists; the same interpolation as np.interp).
    """

    def __init__(self, fingertip: Fingertip, mode: int, table: FoundationTable | None) -> None:
        p = _TABLE_P
        if table is None:
            v = fingertip.output(p, mode)
        else:
            k, c = table(p)
            v = fingertip.element.normalized_output(k, c, mode, fingertip.coverage)
        # The inverse exists while the output falls with pressure; past the first rise (the
        # dynamic layer's resonances, deep in saturation) every reading counts as saturated.
        rising = np.nonzero(np.diff(v) > 1e-12)[0]
        if rising.size:
            p, v = p[: rising[0] + 1], v[: rising[0] + 1]
        self._neg_v = -v  # increasing, for np.interp
        self._log_p = np.log(p)
        self._dv_dlogp = np.gradient(v, self._log_p)
        self.sigma = fingertip.sigma(mode)
        self.p_min_pa = fingertip.detection_limit(mode)
        self.p_max_pa = fingertip.upper_limit(mode)
        self._v_first, self._v_last = float(v[0]), float(v[-1])
        self._slope0 = abs(float(fingertip.output_slope(0.0, mode)))
        self._neg_v_list = self._neg_v.tolist()
        self._sigma_f, self._p_min_f, self._p_max_f = float(self.sigma), float(self.p_min_pa), float(self.p_max_pa)
        self._three_sigma = 3.0 * self._sigma_f
        self._log_p_list = self._log_p.tolist()
        self._dv_dlogp_list = self._dv_dlogp.tolist()

    def __call__(self, v1: float, settled: bool = True) -> Estimate:
        if not settled:
            return _estimate(math.nan, math.nan, "settling")
        if 1.0 - v1 < self._three_sigma:
            p = max(1.0 - v1, 0.0) / self._slope0
            return _estimate(p, self._p_min_f, "below_detection")
        if v1 <= self._v_last:
            return _estimate(math.nan, math.nan, "saturated")
        if v1 >= self._v_first:
            p = (1.0 - v1) / self._slope0
            return _estimate(p, self._sigma_f / self._slope0, "ok")
        log_p = _interp(-v1, self._neg_v_list, self._log_p_list)
        p = math.exp(log_p)
        if not p <= self._p_max_f:
            return _estimate(math.nan, math.nan, "saturated")
        slope = abs(_interp(log_p, self._log_p_list, self._dv_dlogp_list)) / p
        return _estimate(p, self._sigma_f / slope if slope > 0 else math.inf, "ok")


class SensorChannel:
    """The readout of one fingertip: drives one mode at a time, samples, switches.

    Parameters
    ----------
    fingertip : the Fingertip (element, gel, coverage, noise).
    edges_m : cell edges along the element (m) of the pressure profile the pad supplies;
        default one cell over the gel coverage (a uniform pressure).
    dynamics : "steady", "envelope" (first-order complex envelope, exact per step) or
        "carrier" (the reference: the modal equation through every drive cycle, demodulated).
    mode : the initial drive mode.
    noise : whether readings carry noise.
    rng : noise generator.
    exact : evaluate the gel model exactly each sample instead of the tables.
    carrier_samples_per_cycle : carrier samples per drive cycle ("carrier" dynamics).
    """

    def __init__(
        self,
        fingertip: Fingertip,
        edges_m: Sequence[float] | None = None,
        dynamics: str = "envelope",
        mode: int | None = None,
        noise: bool = True,
        rng: np.random.Generator | None = None,
        exact: bool = False,
        carrier_samples_per_cycle: int = 16,
    ) -> None:
        if dynamics not in DYNAMICS:
            raise ValueError(f"unknown sensor dynamics {dynamics!r}; valid: {', '.join(DYNAMICS)}")
        self.tip = fingertip
        self.dynamics = dynamics
        self.noise = noise
        self.rng = rng or np.random.default_rng(0)
        self.exact = exact
        self.edges_m = np.asarray(edges_m if edges_m is not None else fingertip.coverage, float)
        el = fingertip.element
        self._rho_a = el.params.mass_per_length_kg_m
        self._c = el.params.damping_n_s_per_m2
        b = el.params.width_m
        used = sorted({*fingertip.modes})
        # Per mode: b * cell ratios (so kappa = k_e @ weights), omega, sigma, table.
        self._weights = {m: b * el.cell_ratios(m, self.edges_m) for m in used}
        self._omega = {m: el.natural_angular_frequency(m) for m in used}
        self._sigma = {m: fingertip.sigma(m) for m in used}
        self._tables = {m: FoundationTable(fingertip, m) for m in used} if not exact else {}
        self._inverse = {m: ModeInverse(fingertip, m, self._tables.get(m)) for m in used}
        # For update_trusted: per mode (omega, sigma, table lookup, weights as floats).
        self._fast = {
            m: (float(self._omega[m]), float(self._sigma[m]), self._tables[m].at if not exact else None, self._weights[m].tolist())
            for m in used
        }
        self._rho_a_f, self._c_f = float(self._rho_a), float(self._c)
        self._tau0 = 2.0 * self._rho_a_f / self._c_f  # unloaded envelope time constant, s
        self.evaluations = 0  # gel/sensor evaluations, counted for "compute only what is needed" tests
        self.mode = fingertip.modes[0] if mode is None else fingertip._mode(mode)
        # The instrument has been running unloaded before the scene starts: steady, settled.
        self.envelope = 1 + 0j
        self.time_in_mode_s = math.inf
        self._carrier_spc = int(carrier_samples_per_cycle)
        self._carrier: CarrierResonator | None = None
        if dynamics == "carrier":
            self._carrier = self._new_carrier(self.mode)
            self._carrier.start_steady()
        self._noise: list[float] = []
        self._rate_estimate: complex | None = None  # the readout's tracked ring-up rate, 1/s
        self._hist_t: deque[float] = deque(maxlen=_HISTORY)  # recent readings: time in mode, s
        self._hist_a: deque[complex] = deque(maxlen=_HISTORY)  # and the lock-in output
        self._last_window: float | None = None
        # The readout's own clock: time since the channel started or last switched, s.  It starts
        # settled on the unloaded reading; only a switch starts a ring-up from rest.
        self._clock_s = 0.0
        self._ring_up_valid = False  # the ring-up since the switch still fits one steady load
        self._ring_up_seen = False
        self._settled_at: complex | None = complex(self.envelope)
        self._fit: tuple | None = None  # (time, reading, a_ss, lambda, gain) of the last fit

    def _new_carrier(self, mode: int) -> CarrierResonator:
        return CarrierResonator(self._rho_a_f, self._c_f, float(self._omega[mode]), self._carrier_spc)

    def _normal(self) -> float:
        """One standard normal draw (from a block drawn ahead)."""
        if not self._noise:
            self._noise = self.rng.standard_normal(_NOISE_BLOCK).tolist()
        return self._noise.pop()

    @property
    def n_cells(self) -> int:
        return self.edges_m.size - 1

    def select_mode(self, mode: int) -> None:
        """Drive ``mode`` from now on; the envelope starts from rest (a ring-up)."""
        if mode.__class__ is int and mode == self.mode:  # already driven (so a valid mode): nothing to do
            return
        mode = self.tip._mode(mode)
        if mode != self.mode:
            self.mode = mode
            self.time_in_mode_s = 0.0
            self._clock_s = 0.0
            self._rate_estimate = None
            self._hist_t.clear()
            self._hist_a.clear()
            self._last_window = None
            self._ring_up_valid, self._ring_up_seen = True, False
            self._settled_at = None
            self._fit = None
            if self.dynamics == "envelope":
                self.envelope = 0j
            elif self.dynamics == "carrier":
                self._carrier = self._new_carrier(mode)  # the new mode starts from rest

    def _foundation(self, pressure_cells_pa: np.ndarray, mode: int) -> tuple[np.ndarray, np.ndarray]:
        self.evaluations += 1
        if self.exact:
            return self.tip.foundation(pressure_cells_pa, mode)
        return self._tables[mode](pressure_cells_pa)

    def _checked(self, pressure_cells_pa) -> np.ndarray:
        p = np.asarray(pressure_cells_pa, float)
        if p.shape != (self.n_cells,):
            raise ValueError(f"pressure profile needs {self.n_cells} cells, got shape {p.shape}")
        if not np.all(np.isfinite(p)) or np.any(p < 0):
            raise ValueError(f"pressure_pa must be finite and non-negative, got {p!r}")
        return p

    def modal_load(self, pressure_cells_pa, mode: int) -> tuple[float, float]:
        """(kappa, gamma) of a pressure profile on ``mode``: the modal integrals over cells."""
        k_e, c_e = self._foundation(self._checked(pressure_cells_pa), mode)
        w = self._weights[mode]
        return float(k_e @ w), float(c_e @ w)

    def update(self, pressure_cells_pa, dt_s: float) -> Reading:
        """Advance by ``dt_s`` under the pad's pressure profile (held over the step) and sample."""
        return self.update_trusted(self._checked(pressure_cells_pa).tolist(), dt_s)

    def update_trusted(self, pressure_cells_pa: Sequence[float], dt_s: float) -> Reading:
        """:meth:`update` without checking the profile: the co-simulation's per-step path.

        ``pressure_cells_pa`` must be ``n_cells`` finite, non-negative Python floats (Pa); a
        wrong profile gives a wrong reading, not an error.  One table lookup per cell for the
        active mode (counted in :attr:`evaluations`), then the envelope in complex scalars.
        """
        mode = self.mode
        omega, sigma, table_at, weights = self._fast[mode]
        c = self._c_f
        self.evaluations += 1
        if table_at is None:  # exact: the gel model itself, on arrays
            k_e, c_e = self.tip.foundation(np.asarray(pressure_cells_pa, float), mode)
            kappa, gamma = float(k_e @ self._weights[mode]), float(c_e @ self._weights[mode])
        elif len(weights) == 1:
            k_e, c_e = table_at(pressure_cells_pa[0])
            kappa, gamma = k_e * weights[0], c_e * weights[0]
        else:
            kappa = gamma = 0.0
            for p, w in zip(pressure_cells_pa, weights, strict=True):
                k_e, c_e = table_at(p)
                kappa += k_e * w
                gamma += c_e * w
        steady = _steady(omega, c, kappa, gamma)
        rate = _rate(self._rho_a_f, omega, c, kappa, gamma)
        self.time_in_mode_s += dt_s
        self._clock_s += dt_s
        tau = 1.0 / rate.real
        if self.dynamics == "envelope":
            self.envelope = envelope = _step(self.envelope, steady, dt_s, rate)
            settled = self.time_in_mode_s >= tau * _SETTLE_TAUS
        elif self.dynamics == "carrier":
            self.envelope = envelope = self._carrier.step(kappa, gamma, dt_s)
            settled = self.time_in_mode_s >= tau * _SETTLE_TAUS
        else:
            self.envelope = envelope = steady
            settled = True
        v1_true = abs(envelope)
        # The lock-in's in-phase and quadrature outputs each carry the readout's noise.
        iq = envelope + complex(self._normal() * sigma, self._normal() * sigma) if self.noise else envelope
        v1 = abs(iq)
        phase = -math.atan2(envelope.imag, envelope.real) if v1_true > 0 else 0.0
        return _reading(mode, v1, v1_true, phase, self.time_in_mode_s, tau, settled, kappa, gamma, iq)

    def estimate(self, reading: Reading) -> Estimate:
        """The readout's pressure estimate from ``reading`` (uniform-pressure calibration).

        Steady dynamics: the inverse of the reading.  Resonator dynamics: for a while after a
        mode switch the envelope is still ringing up, and the readout infers the steady
        reading from the ring-up itself (:func:`sensor.readout.ring_up_steady`, tracking the
        physical root from reading to reading, assuming the load held since the switch).
        The estimate is "settling" until that inference amplifies the noise at most
        ``RINGUP_MAX_GAIN`` times; its uncertainty carries that gain.  Once the switch is
        ``RINGUP_WINDOW_TAUS`` of the reading's own time constants ago, the reading is read
        as it is (settled).
        The readout uses only what a lock-in gives (I, Q, the time since its own switch) and
        the unloaded time constant from calibration, never the simulator's load.
        """
        inverse = self._inverse[reading.mode]
        if self.dynamics == "steady":
            return inverse(reading.v1)
        t, iq = self._clock_s, reading.iq
        # The reading's own time constant, were it steady (tau = 1 / Re(1 / (tau0 a))): once the
        # switch is that many of them ago, the ring-up is over (conservative: a ring-up still
        # in progress reads a longer time constant than it has elapsed).
        if iq.real > 0 and t * iq.real >= RINGUP_WINDOW_TAUS * self._tau0 * (iq.real * iq.real + iq.imag * iq.imag):
            return inverse(reading.v1)
        if not self._hist_t or self._hist_t[-1] != t:
            self._hist_t.append(t)
            self._hist_a.append(iq)
        # Latched settled: the envelope reached its steady value and has not moved by more than
        # the noise since; a step that moves it (a load change) releases the latch.
        bound = _LATCH_SIGMAS * self._sigma[reading.mode]
        if self._settled_at is not None:
            if abs(iq - self._settled_at) <= bound:
                self._settled_at = iq
                return inverse(reading.v1)
            self._settled_at = None
        # A fit made earlier predicts where the envelope should be now; while the reading
        # follows it (within the noise), its steady value still holds and no fit is needed.
        fit = self._fit
        if fit is not None:
            t_fit, a_fit, a_ss, lam, gain = fit
            if abs(iq - (a_ss + (a_fit - a_ss) * cmath.exp(-lam * (t - t_fit)))) <= bound:
                return self._estimate_from(inverse, a_ss, gain, iq, bound)
            self._fit = None
        best, best_gain = self._ring_up(t, iq) if self._ring_up_valid else (complex(math.nan, math.nan), math.inf)
        if self._ring_up_valid and not best_gain <= RINGUP_MAX_GAIN and self._ring_up_seen:
            self._ring_up_valid = False  # it fitted, then stopped fitting: the load has changed since
        self._ring_up_seen = self._ring_up_seen or best_gain <= RINGUP_MAX_GAIN
        if not best_gain <= RINGUP_MAX_GAIN:
            best, best_gain = self._relaxation(t, iq, reading.mode)
        if not best_gain <= RINGUP_MAX_GAIN:
            return _estimate(math.nan, math.nan, "settling")
        self._fit = (t, iq, best, 1.0 / (self._tau0 * best), best_gain)
        return self._estimate_from(inverse, best, best_gain, iq, bound)

    def _estimate_from(self, inverse: ModeInverse, a_ss: complex, gain: float, iq: complex, bound: float) -> Estimate:
        """The estimate of an inferred steady envelope, its uncertainty scaled by the fit's gain."""
        if abs(a_ss - iq) <= 0.5 * bound:  # the inferred steady value is where the reading is
            self._settled_at = iq
            self._fit = None
        est = inverse(abs(a_ss))
        if est.status == "ok" and gain > 1.0:
            return _estimate(est.pressure_pa, est.uncertainty_pa * gain, "ok")
        return est

    def _ring_up(self, t: float, iq: complex) -> tuple[complex, float]:
        """The steady reading from the ring-up since the switch (load held since), tracked."""
        a_ss, gain = ring_up_steady(iq, t, self._tau0, self._rate_estimate)
        self._rate_estimate = None if math.isnan(a_ss.real) else 1.0 / (self._tau0 * a_ss)
        return a_ss, gain

    def _relaxation(self, t: float, iq: complex, mode: int) -> tuple[complex, float]:
        """The steady reading from a relaxation over a recent window (load held over it).

        Tries the windows of RELAXATION_WINDOWS_S that the history covers; a fit counts only if
        it also predicts the reading halfway through the window to within 4 sigma (the load
        did not change inside it, the root is the physical one); the smallest gain wins.
        """
        times, values, sigma = self._hist_t, self._hist_a, self._sigma[mode]
        best, best_gain = complex(math.nan, math.nan), math.inf
        # The window that fitted last time first: under a steady load it fits again, and a
        # good enough fit ends the search (the per-step cost of a settled hold).
        windows = (self._last_window, *RELAXATION_WINDOWS_S) if self._last_window else RELAXATION_WINDOWS_S
        for window in windows:
            i0 = bisect_right(times, t - window) - 1
            if i0 < 0:
                continue
            t0, a0 = times[i0], values[i0]
            im = bisect_right(times, t0 + 0.5 * (t - t0)) - 1
            if im <= i0 or im >= len(times) - 1:
                continue
            a_ss, gain = relaxation_steady(a0, iq, t - t0, self._tau0)
            if not gain < best_gain:
                continue
            lam = 1.0 / (self._tau0 * a_ss)
            predicted = a_ss + (a0 - a_ss) * cmath.exp(-lam * (times[im] - t0))
            if abs(predicted - values[im]) <= 4.0 * math.sqrt(2.0) * sigma:
                best, best_gain = a_ss, gain
                if window == self._last_window and gain <= 1.5:
                    break
                self._last_window = window
        return best, best_gain

    def inverse(self, mode: int) -> ModeInverse:
        """The fast inverse of ``mode`` (its P_min, P_max, sigma)."""
        return self._inverse[mode]
