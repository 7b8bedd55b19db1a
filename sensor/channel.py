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

The readout (:meth:`SensorChannel.estimate`) turns each reading into a pressure estimate.  With
resonator dynamics the reading lags the load by the envelope's time constant (0.66 s with Table
I's damping), so the readout infers the steady reading of the present load from the recent
readings (:class:`SteadyInference`: a least-squares fit of the envelope's own equation over a
window, restarted when a change test says the load changed).  Its contract, measured by
tests/test_readout_honesty.py: an "ok" estimate's interval, estimate +- 3 uncertainty_pa,
holds the true pressure, except in the first readings after an abrupt change that the readings
do not show yet (a physical limit of a slow resonator, measured against an oracle); the
estimate is "settling" while the inference cannot tell; after the load is removed it reads
"below_detection" within the inference's settling time.
"""

from __future__ import annotations

import cmath
import math
from bisect import bisect_right
from collections import deque
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from .cache import disk_cached
from .cache import enabled as cache_enabled
from .calibration import SensorUnit, detuning, reading_sigma_v
from .carrier import CarrierResonator
from .fingertip import Fingertip
from .variation import REFERENCE_TEMPERATURE_C

DYNAMICS = ("steady", "envelope", "carrier")
#: Noise is drawn in blocks (one generator call per block, not per reading).
_NOISE_BLOCK = 4096
#: Pressure table for the fast path, Pa: log-spaced, 60 points per decade.
_TABLE_P = np.logspace(-3, 7, 601)
#: A reading is "settled" once the transient has decayed below this fraction.
SETTLE_FRACTION = 1e-3
#: Settling takes this many time constants: ln(1 / SETTLE_FRACTION).
_SETTLE_TAUS = math.log(1.0 / SETTLE_FRACTION)

# The readout's inference of the steady reading (see :class:`SteadyInference`).
#: An inferred steady reading is trusted ("ok", "below_detection", "saturated") only while it
#: amplifies the lock-in's noise at most this much: its uncertainty carries the gain, so the
#: controller sees the cost of reading a resonator that has not settled.
MAX_GAIN = 10.0
#: ...and never reports less than this many single readings' noise.  A window of many readings
#: averages the noise down, but it cannot see a load change in its last few readings (with
#: Table I's damping a ramp that starts moves the envelope by under one sigma in its first ten
#: readings while the steady value has moved by several): the floor is the allowance for that
#: latency, measured by tests/test_readout_honesty.py (coverage of "ok" intervals).
GAIN_FLOOR = 2.0
#: The inference window: at most this long, s.  Long enough that a held load near unloaded
#: (the slowest envelope, tau0 = 0.66 s with Table I's damping) is inferred to better than
#: GAIN_FLOOR, with the load's ramp as a free parameter.
WINDOW_S = 0.5
#: ...at least this long while the load ramps, s.
MIN_WINDOW_S = 0.02
#: While the load ramps (significantly), the window spans at most this fraction of the time in
#: which the ramp would change the gel's modal load (mu - 1, below) by its own size, so that
#: the linear-in-time model of the load holds over the window (its error is about
#: fraction^2 / 12 of the load, 0.08 % at 0.1).
RAMP_WINDOW_FRACTION = 0.1
#: A ramp is significant at this chi-square (2 degrees of freedom: exceeded by chance 4e-6 of the
#: time, about 5 sigma; a looser test shortens the window of a held load by chance).
_RAMP_CHI2 = 25.0
#: ...and its relative rate is taken against a modal load of at least this (|mu - 1| of a load
#: about ten times the noise: a ramp from unloaded does not shrink the window to nothing).
_MIN_LOAD = 0.01
#: The change test's statistics are Exp(1) under a steady (or steadily ramping) load: a reading
#: whose statistic passes CHANGE_STAT (by chance 6e-6 per look-back) restarts the inference at
#: the change; one past SUSPECT_STAT (0.25 % per look-back: a held load reads "ok" 99 % of the
#: time) is itself reported "settling" but does not restart.
CHANGE_STAT = 12.0
SUSPECT_STAT = 6.0
#: The change test looks back over the last 1, 3, 5, 9 and 27 readings
_SCALES = (1, 3, 5, 9, 27)
#: (the longest look-back's statistic runs about 1.2 to 1.5 times Exp(1) under a held load -- the
#: fit's extrapolation over 27 readings is a little worse than the white-noise formula says -- so
#: it suspects a change at a correspondingly higher threshold).
_SUSPECT_STAT_LONGEST = 7.5
#: ...the latest reading on every reading, the longer look-backs in turn (the per-reading cost:
#: two or three of them a reading; the coverage measured with all five every reading is the same).
_SCALE_TURNS = ((1, 5), (1, 3, 9), (1, 5, 27), (1, 3))
#: Weight of the integrated noise in the fit's residual (see SteadyInference, "noise").
_INTEGRATED_NOISE = 0.05
#: The inferred load mu (and so 1 / mu) is trusted only while known to this fraction (1 sigma):
#: beyond, the first-order uncertainty of 1 / mu no longer describes it.
_MAX_REL = 0.1
#: The window keeps at least this many readings however short it is.
_MIN_SAMPLES = 6
#: An inference older than this re-bases its integrals on its window (precision), s.
_REBASE_S = 30.0
_MAX_REL_SQ = _MAX_REL * _MAX_REL
_TWELFTH = 1.0 / 12.0
_NAN_ENVELOPE = complex(math.nan, math.nan)
#: A calibrated unit's readout re-zeroes after this long unloaded (below detection), s: longer
#: than the inference's settling after a release (0.17 to 0.37 s with Table I's damping, see
#: SteadyInference), so a re-zero takes the unloaded reading, not the tail of a load.
REZERO_S = 0.5
#: ...and corrects a drift only past this many sigmas of its unloaded reading's noise (a false
#: correction at 4 sigma: 6e-5 per look, one in 8 hours of unloaded readout).
REZERO_SIGMAS = 4.0
#: The prefix sums of a sample before any (index 5.. of a sample tuple, see SteadyInference).
_NO_SUMS = (0.0, 0j, 0j, 0j, 0j, 0j, 0j, 0j, 0.0, 0.0, 0j, 0j, 0j)


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
        def compute() -> dict[str, np.ndarray]:
            k, c = fingertip.foundation(_TABLE_P, mode)
            return {"k": k, "c": c}

        # Computed once per configuration and kept on disk (piezotip.sensor.cache).
        columns = disk_cached("foundation-table", (fingertip.config_key(), mode), compute)
        k, c = columns["k"], columns["c"]
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


_SETTLING = _estimate(math.nan, math.nan, "settling")


class ModeInverse:
    """Fast inverse of one mode's uniform-pressure response: V_1 -> P by table lookup.

    The forward curve is tabulated once on the channel's log-pressure grid; a reading is
    inverted by linear interpolation in log P (the curve is monotone), its uncertainty from
    the tabulated slope.  Status thresholds are the fingertip's P_min and P_max of the mode.
    A call works on Python floats (the tables as lists; the same interpolation as np.interp).
    """

    def __init__(self, fingertip: Fingertip, mode: int, table: FoundationTable | None) -> None:
        def compute() -> dict[str, np.ndarray]:
            if table is None:
                v = fingertip.output(_TABLE_P, mode)
            else:
                k, c = table(_TABLE_P)
                v = fingertip.element.normalized_output(k, c, mode, fingertip.coverage)
            return {
                "v": v,
                "sigma": np.array(fingertip.sigma(mode)),
                "p_min_pa": np.array(fingertip.detection_limit(mode)),
                "p_max_pa": np.array(fingertip.upper_limit(mode)),
                "slope0": np.array(abs(float(fingertip.output_slope(0.0, mode)))),
            }

        # Computed once per configuration, mode and gel evaluation, kept on disk (the table, when
        # there is one, is the same configuration's and mode's).
        numbers = disk_cached("mode-inverse", (fingertip.config_key(), mode, table is None), compute)
        p, v = _TABLE_P, numbers["v"]
        # The inverse exists while the output falls with pressure; past the first rise (the
        # dynamic layer's resonances, deep in saturation) every reading counts as saturated.
        rising = np.nonzero(np.diff(v) > 1e-12)[0]
        if rising.size:
            p, v = p[: rising[0] + 1], v[: rising[0] + 1]
        self._neg_v = -v  # increasing, for np.interp
        self._log_p = np.log(p)
        self._dv_dlogp = np.gradient(v, self._log_p)
        self.sigma = float(numbers["sigma"])
        self.p_min_pa = float(numbers["p_min_pa"])
        self.p_max_pa = float(numbers["p_max_pa"])
        self._v_first, self._v_last = float(v[0]), float(v[-1])
        self._slope0 = float(numbers["slope0"])
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

    def pressure(self, v1: float) -> float:
        """The inverse alone, Pa: the pressure whose uniform load reads ``v1`` in this mode
        (linear in the first pressure's slope above the table's first point, as the estimates
        are), NaN past the table's last (saturated) point.  No status, no uncertainty: for
        measuring the inverse's accuracy against a known pressure."""
        if v1 <= self._v_last:
            return math.nan
        if v1 >= self._v_first:
            return max(1.0 - v1, 0.0) / self._slope0
        return math.exp(_interp(-v1, self._neg_v_list, self._log_p_list))

    def inferred(self, v1: float, gain: float) -> Estimate:
        """The estimate of an inferred steady reading ``v1`` whose noise is ``gain`` times a
        reading's: as :meth:`__call__` with sigma scaled by max(gain, 1) for the below-detection
        test (within 3 scaled sigma of unloaded; its uncertainty is the scaled detection limit)
        and by max(gain, GAIN_FLOOR) for the uncertainty of an "ok" estimate."""
        if 1.0 - v1 < self._three_sigma * (gain if gain > 1.0 else 1.0):
            return _estimate(max(1.0 - v1, 0.0) / self._slope0, self._p_min_f * (gain if gain > 1.0 else 1.0), "below_detection")
        g = gain if gain > GAIN_FLOOR else GAIN_FLOOR
        if v1 <= self._v_last:
            return _estimate(math.nan, math.nan, "saturated")
        if v1 >= self._v_first:
            return _estimate((1.0 - v1) / self._slope0, g * self._sigma_f / self._slope0, "ok")
        log_p = _interp(-v1, self._neg_v_list, self._log_p_list)
        p = math.exp(log_p)
        if not p <= self._p_max_f:
            return _estimate(math.nan, math.nan, "saturated")
        slope = abs(_interp(log_p, self._log_p_list, self._dv_dlogp_list)) / p
        return _estimate(p, g * self._sigma_f / slope if slope > 0 else math.inf, "ok")


class CalibratedInverse(ModeInverse):
    """A :class:`ModeInverse` whose "ok" estimates also carry calibration's error.

    ``rel_sigma`` (on the channel's pressure table) is the estimate's relative standard
    deviation from what calibration did not measure or measured with noise
    (:func:`sensor.calibration.model_uncertainty`); it is added in quadrature to the noise's
    uncertainty of every "ok" estimate.
    """

    def __init__(self, fingertip: Fingertip, mode: int, table: FoundationTable | None, rel_sigma: np.ndarray) -> None:
        super().__init__(fingertip, mode, table)
        self._rel_log_p = np.log(_TABLE_P).tolist()
        self._rel = np.asarray(rel_sigma, float).tolist()

    def _with_model(self, est: Estimate) -> Estimate:
        if est.status != "ok":
            return est
        p = est.pressure_pa
        rel = _interp(math.log(p), self._rel_log_p, self._rel) if p > 0 else 0.0
        return _estimate(p, math.hypot(est.uncertainty_pa, rel * p), "ok")

    def __call__(self, v1: float, settled: bool = True) -> Estimate:
        return self._with_model(super().__call__(v1, settled))

    def inferred(self, v1: float, gain: float) -> Estimate:
        return self._with_model(super().inferred(v1, gain))


class SteadyInference:
    """The readout's inference of the steady reading from the lock-in's recent readings (one mode).

    The problem (physics.md section 6): driven at a fixed frequency, the envelope a(t) relaxes
    toward the steady envelope a_ss of the present load with the complex rate lambda, and both
    are fixed by one unknown, the gel's load on the mode: a_ss = 1 / mu and
    lambda = mu / tau0, with mu = 1 + gamma / c - j kappa / (omega c) and tau0 = 2 rho A / c
    the unloaded time constant (:func:`sensor.readout.ring_up_steady`).  So the envelope obeys

        tau0 a'(t) = 1 - mu(t) a(t)

    for any load history, and a_ss(t) = 1 / mu(t) is what the readout wants, now.  With Table
    I's damping tau0 = 0.66 s: a reading settles seconds after the load changes, so the readout
    must infer mu from how the envelope moves, not wait.

    The model: over a window of recent readings the load is steady or ramps,
    mu(t) = alpha + mu1 (t - t_r).  Integrated from the segment's start t_s,

        tau0 a_k - (t_k - t_r) = c - alpha X1_k - mu1 X2_k,
        X1_k = int_{t_s}^{t_k} a dt,  X2_k = int_{t_s}^{t_k} (t - t_r) a dt,

    is linear in (c, alpha, mu1) (c = tau0 a(t_s), unknown, or 0 for a ring-up from rest after a
    switch), exact for any decay rate while the integrals are (a three-point rule on the
    readings, exact to (lambda dt)^4).  A complex least-squares fit over the window, from running
    sums (a few complex operations per reading), gives mu(now) = alpha + mu1 (now - t_r) and its
    variance, hence a_ss = 1 / mu and its noise in units of a reading's sigma (the "gain").

    Noise: a reading's noise sigma enters tau0 a_k (white, tau0 sigma) and the integrals
    (a random walk of steps sigma dt, weighted by mu).  The fit's parameters are given the
    variance of a white residual sigma^2 (tau0^2 + 0.05 |mu|^2 W^2) (W the window's span): the
    second term is what the integrated noise adds to a least-squares slope's variance (0.05 =
    0.6 / 12, from the fitted slope of a random walk); it matters only for fast decay
    (|mu| W >> tau0: a realistic Q, or a heavy load).  Checked: the inferred |a_ss| scatters by
    0.9 of its stated sigma with Table I's damping, 0.75 with Q = 70 (tests/test_readout_honesty.py).

    The window: at most WINDOW_S, shortened while the load ramps (RAMP_WINDOW_FRACTION), and
    restarted when the load changes.  The change test: the last m = 1, 3, 5, 9, 27 readings are
    predicted with the fit made just before them (so a change has not pulled it yet) and the
    mean prediction error, normalized by its variance (the readings' own noise through tau0 a
    and the integrals, sigma^2 sum_l |tau0 + mu dt (l - 1/2)|^2, plus the old fit's error at
    them), is Exp(1)-distributed while the load holds or ramps steadily (measured means 1.0 to
    1.07 for m <= 9, 1.2 to 1.5 for m = 27).  Past CHANGE_STAT the window restarts at the
    change (the last m readings); past SUSPECT_STAT this reading is reported "settling".

    :meth:`step` returns (a_ss, gain, trusted): ``trusted`` is False while the window is too
    young for a fit, the last readings suggest a change, or mu is known to worse than
    _MAX_REL; the caller also requires gain <= MAX_GAIN.

    Settling time (the contract's, in code): after a load change, the time from the change
    until this inference is trusted again with gain <= MAX_GAIN, i.e. until it has detected the
    change and its restarted window pins mu down.  It is set by tau0, the readings' noise and
    the size of the change, not by the envelope's own decay (seconds with Table I's damping).
    Measured at 5 ms readings (tests/test_readout_honesty.py): after the load is removed, 0.17 to
    0.37 s with Table I's damping (0.22 s for 1400 Pa in mode 2; longer from heavier loads,
    whose envelope starts far from unloaded), 20 ms (4 readings) with Q = 70; a ring-up after a
    switch, 0.06 to 0.35 s and 10 to 45 ms.
    """

    __slots__ = ("base", "c_known", "fits", "q1", "q2", "samples", "sigma", "tau0", "tau0_sq", "tr", "turn", "w_target")

    def __init__(self, tau0_s: float, sigma: float) -> None:
        self.tau0, self.tau0_sq, self.sigma = tau0_s, tau0_s * tau0_s, sigma
        # Per reading in the window: (t, a, X1, X2, Y, then the running sums since the segment's
        # start of X1, X2, Y, |X1|^2, |X2|^2, conj(X1) X2, conj(X1) Y, conj(X2) Y); the window's
        # sums are the last reading's minus ``base``'s (the reading before the window).
        self.samples: deque[tuple] = deque()
        self.turn = 0  # which of the longer look-backs the change test takes this reading
        # The fit made after each of the last readings: (c, b1, b2, residual variance, 1 / n,
        # the regressors' means and centered sums, and their determinant).
        self.fits: deque[tuple | None] = deque(maxlen=_SCALES[-1] + 1)
        self.restart(0.0, None)

    def restart(self, t_ref: float, a_start: complex | None) -> None:
        """A new segment at ``t_ref``: from a known envelope ``a_start`` (0 after a switch), or
        from the next reading (``None``: the envelope there is a free parameter)."""
        self.samples.clear()
        self.fits.clear()
        self.base = _NO_SUMS
        self.tr = t_ref
        self.c_known = None if a_start is None else self.tau0 * a_start
        self.q1 = None if a_start is None else (t_ref, a_start, 0j, 0j)  # last point: t, a, X1, X2
        self.q2 = None  # the point before: t, a
        self.w_target = WINDOW_S

    def seed(self, a: complex, t_end: float, dt_s: float) -> None:
        """Fill the window with a settled history (the instrument ran unloaded before the scene)."""
        n = int(WINDOW_S / dt_s)
        self.restart(t_end - n * dt_s, None)
        for k in range(n + 1):
            self._append(t_end - (n - k) * dt_s, a)
        self.fits.append(self._fit(t_end)[4])

    def _integrate(self, t: float, a: complex) -> tuple[complex, complex, complex]:
        """(X1, X2, Y) of a reading ``a`` at ``t`` (the integrals continued from the last reading)."""
        tr, q1 = self.tr, self.q1
        if q1 is None:
            x1 = x2 = 0j
        else:
            tp, ap, x1, x2 = q1
            h = t - tp
            q2 = self.q2
            if q2 is not None and abs(tp - q2[0] - h) <= 1e-6 * h:  # three-point rule (uniform steps)
                tq, aq = q2
                x1 = x1 + h * (5.0 * a + 8.0 * ap - aq) * _TWELFTH
                x2 = x2 + h * (5.0 * (t - tr) * a + 8.0 * (tp - tr) * ap - (tq - tr) * aq) * _TWELFTH
            else:
                x1 = x1 + 0.5 * h * (a + ap)
                x2 = x2 + 0.5 * h * ((t - tr) * a + (tp - tr) * ap)
            self.q2 = (tp, ap)
        self.q1 = (t, a, x1, x2)
        return x1, x2, self.tau0 * a - (t - tr)

    def _append(self, t: float, a: complex) -> tuple:
        """Integrate to ``t`` and add the reading to the window's sums; returns its tuple."""
        x1, x2, y = self._integrate(t, a)
        return self._add(t, a, x1, x2, y)

    def _add(self, t: float, a: complex, x1: complex, x2: complex, y: complex) -> tuple:
        """Add an integrated reading to the window."""
        samples = self.samples
        s = samples[-1] if samples else self.base
        c1, c2 = x1.conjugate(), x2.conjugate()
        new = (
            t,
            a,
            x1,
            x2,
            y,
            s[5] + x1,
            s[6] + x2,
            s[7] + y,
            s[8] + (x1.real * x1.real + x1.imag * x1.imag),
            s[9] + (x2.real * x2.real + x2.imag * x2.imag),
            s[10] + c1 * x2,
            s[11] + c1 * y,
            s[12] + c2 * y,
        )
        samples.append(new)
        return new

    def _fit(self, t: float) -> tuple:
        """Least squares over the window: (mu(t), its variance, ramp chi-square, |mu1|, fit record).

        The record keeps what the change test needs to predict the next readings: the
        coefficients (c, b1, b2), 1 / n and the regressors' means (0 with a known start), the
        inverse of their centered sums as (C22, C11, 2 C12) / det, and the noise terms below.
        """
        samples, b = self.samples, self.base
        last = samples[-1]
        n = len(samples)
        s1, s2, sy = last[5] - b[5], last[6] - b[6], last[7] - b[7]
        c = self.c_known
        if c is not None:  # known start: no intercept
            if n < 2:
                return None, math.inf, 0.0, 0.0, None
            c11, c22, c12 = last[8] - b[8], last[9] - b[9], last[10] - b[10]
            c1y = last[11] - b[11] - s1.conjugate() * c
            c2y = last[12] - b[12] - s2.conjugate() * c
            m1 = m2 = 0j
            inv_n = 0.0
        else:
            if n < 4:
                return None, math.inf, 0.0, 0.0, None
            inv_n = 1.0 / n
            m1, m2, my = s1 * inv_n, s2 * inv_n, sy * inv_n
            m1c, m2c = m1.conjugate(), m2.conjugate()
            c11 = last[8] - b[8] - (s1.real * m1.real + s1.imag * m1.imag)
            c22 = last[9] - b[9] - (s2.real * m2.real + s2.imag * m2.imag)
            c12 = last[10] - b[10] - m1c * s2
            c1y = last[11] - b[11] - m1c * sy
            c2y = last[12] - b[12] - m2c * sy
        det = c11 * c22 - (c12.real * c12.real + c12.imag * c12.imag)
        if not det > 0.0:
            return None, math.inf, 0.0, 0.0, None
        inv_det = 1.0 / det
        b1 = (c22 * c1y - c12 * c2y) * inv_det
        b2 = (c11 * c2y - c12.conjugate() * c1y) * inv_det
        if c is None:
            c = my - b1 * m1 - b2 * m2
        tp = samples[-2][0] if n > 1 else t
        h = t - tp
        # The load over the last sample period (held over it, as the co-simulation holds the
        # pad's pressure): mu at its middle.
        d = 0.5 * (t + tp) - self.tr
        mu = -(b1 + b2 * d)
        width = t - samples[0][0]
        mu_sq = mu.real * mu.real + mu.imag * mu.imag
        sig_sq = self.sigma * self.sigma
        s2_res = sig_sq * (self.tau0_sq + _INTEGRATED_NOISE * mu_sq * width * width)
        var_mu = s2_res * (c22 + d * d * c11 - 2.0 * d * c12.real) * inv_det
        b2_sq = b2.real * b2.real + b2.imag * b2.imag
        ramp_chi2 = b2_sq * det / (s2_res * c11) if c11 > 0 else 0.0
        # For the change test: the noise of the residuals of a block of m new readings,
        # sigma^2 sum_l |tau0 + mu h (l - 1/2)|^2 (a reading enters tau0 a and, through the
        # integral, every later X1) ~ m (n0 + m (n1 + m n2)); and the fit's own error at them,
        # n_fit (m^2 / n + q) with q the quadratic form of the block's centered regressors
        # (the residual level n_fit: tau0^2 plus the integrated noise over the window).
        tau0 = self.tau0
        record = (
            c,
            b1,
            b2,
            inv_n,
            m1,
            m2,
            c22 * inv_det,
            c11 * inv_det,
            2.0 * c12 * inv_det,
            sig_sq * self.tau0_sq,
            sig_sq * tau0 * mu.real * h,
            0.5 * sig_sq * mu_sq * h * h,
            sig_sq * (self.tau0_sq + mu_sq * h * width),
        )
        return mu, var_mu, ramp_chi2, math.sqrt(b2_sq), record

    def step(self, t: float, a: complex) -> tuple[complex, float, bool]:
        """Take the lock-in's reading ``a`` at time ``t``; return (a_ss, gain, trusted)."""
        if t - self.tr > _REBASE_S and self.samples:
            self._replay([(s[0], s[1]) for s in self.samples])
        samples, fits = self.samples, self.fits
        x1, x2, y = self._integrate(t, a)
        trusted = True
        n_f = len(fits)
        if n_f and fits[-1] is not None:
            # The change test, before the reading joins the fit: the last m readings predicted
            # with the fit made before them.
            last = samples[-1]
            n_s = len(samples)
            worst, worst_m = 0.0, 0
            self.turn = turn = (self.turn + 1) & 3
            for m in _SCALE_TURNS[turn]:
                if m > n_f or m > n_s:
                    break
                fit = fits[-m]
                if fit is None:
                    break
                c, b1, b2, inv_n, m1, m2, i11, i22, i12, n0, n1, n2, n_fit = fit
                if m == 1:
                    g1, g2, r = x1 - m1, x2 - m2, y - c - b1 * x1 - b2 * x2
                else:
                    ref = samples[-m]
                    g1, g2 = last[5] - ref[5] + x1, last[6] - ref[6] + x2
                    r = (last[7] - ref[7] + y) - m * c - b1 * g1 - b2 * g2
                    g1, g2 = g1 - m * m1, g2 - m * m2
                w = i12 * g2
                q = (
                    i11 * (g1.real * g1.real + g1.imag * g1.imag)
                    + i22 * (g2.real * g2.real + g2.imag * g2.imag)
                    - (g1.real * w.real + g1.imag * w.imag)
                )
                stat = (r.real * r.real + r.imag * r.imag) / (2.0 * (m * (n0 + m * (n1 + m * n2)) + n_fit * (m * m * inv_n + q)))
                if stat > worst:
                    worst, worst_m = stat, m
            if worst > CHANGE_STAT:
                # Restart at the change: the last worst_m readings (this one included) follow it.
                keep = [(s[0], s[1]) for s in list(samples)[n_s - worst_m + 1 :]] if worst_m > 1 else []
                keep.append((t, a))
                self._replay(keep)
                return _NAN_ENVELOPE, math.inf, False
            trusted = worst <= (SUSPECT_STAT if worst_m < _SCALES[-1] else _SUSPECT_STAT_LONGEST)
        self._add(t, a, x1, x2, y)  # the reading into the window's running sums
        w_target = self.w_target
        while t - samples[0][0] > w_target and len(samples) > _MIN_SAMPLES:
            self.base = samples.popleft()
            self.c_known = None  # the window no longer starts at the known start
        mu, var_mu, ramp_chi2, ramp_rate, record = self._fit(t)
        fits.append(record)
        if record is None:
            return _NAN_ENVELOPE, math.inf, False
        # Shorten the window while the load ramps (see RAMP_WINDOW_FRACTION).
        if ramp_chi2 > _RAMP_CHI2:
            load = abs(mu - 1.0)
            w = RAMP_WINDOW_FRACTION * (load if load > _MIN_LOAD else _MIN_LOAD) / ramp_rate
            self.w_target = WINDOW_S if w > WINDOW_S else (MIN_WINDOW_S if w < MIN_WINDOW_S else w)
        elif w_target != WINDOW_S:
            self.w_target = WINDOW_S
        mu_sq = mu.real * mu.real + mu.imag * mu.imag
        if not var_mu < _MAX_REL_SQ * mu_sq:
            return (1.0 / mu if mu_sq > 0 else _NAN_ENVELOPE), math.inf, False
        return 1.0 / mu, math.sqrt(var_mu) / (mu_sq * self.sigma), trusted

    def _replay(self, readings: list[tuple[float, complex]]) -> None:
        """Restart the segment at the first of ``readings`` (envelope unknown there) and refit."""
        self.restart(readings[0][0], None)
        for t, a in readings:
            self._append(t, a)
        self.fits.append(self._fit(readings[-1][0])[4])


_MODE_TABLES: dict[tuple, tuple] = {}


def mode_tables(fingertip: Fingertip, mode: int, exact: bool) -> tuple[FoundationTable | None, ModeInverse]:
    """One mode's (k_e, c_e) table (None for the exact gel) and its inverse, computed once per
    process for each fingertip configuration (:meth:`Fingertip.config_key`), mode and gel
    evaluation: every channel of every run with that fingertip shares them (both are read-only
    after construction)."""
    key = (fingertip.config_key(), mode, bool(exact))
    if key not in _MODE_TABLES or not cache_enabled():
        table = None if exact else foundation_table(fingertip, mode)
        _MODE_TABLES[key] = (table, ModeInverse(fingertip, mode, table))
    return _MODE_TABLES[key]


_FOUNDATION_TABLES: dict[tuple, FoundationTable] = {}


def foundation_table(fingertip: Fingertip, mode: int) -> FoundationTable:
    """One mode's (k_e, c_e) table alone (a physical unit's: the simulation needs no inverse of
    it), once per process for each fingertip configuration and mode."""
    key = (fingertip.config_key(), mode)
    if key not in _FOUNDATION_TABLES or not cache_enabled():
        _FOUNDATION_TABLES[key] = FoundationTable(fingertip, mode)
    return _FOUNDATION_TABLES[key]


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
    unit : the physical unit and its calibration (:class:`sensor.calibration.SensorUnit`), or
        None: the unit is ``fingertip`` itself.  With a unit, the simulation runs the unit
        (its element, gel, coverage, temperature, driven at the readout's drive frequencies
        and read against its references) and ``fingertip`` must be the unit's ``model``: the
        readout and the controller see nothing else (see :meth:`_setup_unit`).
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
        unit: SensorUnit | None = None,
    ) -> None:
        if dynamics not in DYNAMICS:
            raise ValueError(f"unknown sensor dynamics {dynamics!r}; valid: {', '.join(DYNAMICS)}")
        self.tip = fingertip
        self.dynamics = dynamics
        self._unit: SensorUnit | None = None  # a physical unit other than the model (_setup_unit)
        self.noise = noise
        self.rng = rng or np.random.default_rng(0)
        self.exact = exact
        # default: one cell over the gel's contact (the unit's own, if there is a unit)
        self.edges_m = np.asarray(edges_m if edges_m is not None else (unit.coverage if unit is not None else fingertip.coverage), float)
        el = fingertip.element
        self._rho_a = el.params.mass_per_length_kg_m
        self._c = el.params.damping_n_s_per_m2
        b = el.params.width_m
        used = sorted({*fingertip.modes})
        # Per mode: b * cell ratios (so kappa = k_e @ weights), omega, sigma, table.
        self._weights = {m: b * el.cell_ratios(m, self.edges_m) for m in used}
        self._omega = {m: el.natural_angular_frequency(m) for m in used}
        self._sigma = {m: fingertip.sigma(m) for m in used}
        tables = {m: mode_tables(fingertip, m, exact) for m in used}
        self._tables = {m: tables[m][0] for m in used} if not exact else {}
        self._inverse = {m: tables[m][1] for m in used}
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
        # The readout's own clock: time since the channel started or last switched, s.
        self._clock_s = 0.0
        self._dt_s = 0.005  # the last sample period, s (for the settled history before the scene)
        # The readout's inference of the steady reading (its mode, and the last estimate, for a
        # reading estimated twice); created at the first estimate from the unloaded history.
        self._inference: SteadyInference | None = None
        self._inference_mode = self.mode
        self._estimated_at, self._last_estimate = math.nan, _SETTLING
        # The readout's history before the scene: settled, unloaded readings of this value.
        self._seed_a = 1 + 0j
        self.rezeros = 0  # re-zeroes while unloaded (a varied or warming unit's tracking)
        if unit is not None and not (unit.config.is_nominal and unit.config.level == "none"):
            self._setup_unit(unit)

    # -- a physical unit other than the model ------------------------------------------

    def _setup_unit(self, unit: SensorUnit) -> None:
        """Simulate ``unit`` (not the readout's model) from now on.

        The unit's mode n, driven at w_d (the readout's drive) with the gel's load, obeys eq. 4
        off resonance: its envelope a (normalized by G / (j w_d c), G the unit's gain) relaxes
        to a_ss = w_d c / (w_d (gamma + c) - j (kappa + K_d)) at the rate
        lambda = (c + gamma) / (2 rho A) - j (kappa + K_d) / (2 w_d rho A), where
        K_d = rho A (w_r^2 - w_d^2) is the detuning, a stiffness like the gel's: the same
        equations as the nominal path (_steady, _rate) with kappa + K_d.  The lock-in's output
        is V_s over the readout's reference R: reading = a G / (j w_d c R).  Temperature moves
        w_r (sqrt(1 + beta dT)), G ((Y_p(T) / Y_p(25))^2) and the gel (its tables at T, to
        0.1 K).  See :mod:`sensor.calibration` for the drive and references.
        """
        if unit.model is not self.tip:
            raise ValueError("a channel with a physical unit must be given the unit's model as its fingertip")
        phys = unit.physical
        self._unit = unit
        tip = phys.fingertip_at(phys.temperature_c)
        el = tip.element
        used = list(self._fast)
        p25 = phys.fingertip_at(REFERENCE_TEMPERATURE_C).element
        self._u_rho_a = float(el.params.mass_per_length_kg_m)
        self._u_c = float(el.params.damping_n_s_per_m2)
        self._u_omega25 = {m: float(p25.natural_angular_frequency(m)) for m in used}
        self._u_gain25 = {m: float(p25.unloaded_voltage(m)) * self._u_omega25[m] * self._u_c for m in used}
        self._u_sigma_v = {m: reading_sigma_v(tip, m) for m in used}
        b = el.params.width_m
        self._u_weights = {m: (b * el.cell_ratios(m, self.edges_m)).tolist() for m in used}
        self._u_drive = {m: 2 * math.pi * unit.drive_hz[m] for m in used}
        self._u_ref = {m: complex(unit.reference_v[m]) for m in used}
        self._u_drifts = phys.drift_c_per_s != 0.0
        self._u_time_s = 0.0
        self._u_tables: dict[tuple[int, float], object] = {}
        self._u_temperature_c = phys.temperature_c
        # The readout: the model's inverses with calibration's error in their uncertainty.
        cache = unit.readout_cache
        for m in used:
            key = ("inverse", m, self.exact)
            if key not in cache:
                rel = unit.uncertainty_tables(_TABLE_P)[m]
                cache[key] = CalibratedInverse(self.tip, m, None if self.exact else self._tables[m], rel)
            self._inverse[m] = cache[key]
        # Unloaded and settled before the scene, at the start's drive.
        steady0 = self._u_steady(self.mode, 0.0, 0.0, phys.temperature_c)
        self.envelope = steady0
        self._seed_a = steady0 * self._u_scale(self.mode, phys.temperature_c)
        if self.dynamics == "carrier":
            self._carrier = self._new_carrier(self.mode)
            k_d = self._u_detuning(self.mode, phys.temperature_c)
            a_p = self._carrier.force / (k_d + 1j * self._carrier.omega * self._u_c)
            self._carrier.q, self._carrier.v = self._carrier._particular(a_p, self._carrier.phase_time_s)
        self._unloaded_from = math.nan
        self._unloaded_sum, self._unloaded_n = 0j, 0

    def _u_detuning(self, mode: int, temperature_c: float) -> float:
        """K_d = rho A (w_r(T)^2 - w_d^2), N/m^2: the unit's detuning from the drive, a stiffness."""
        w_r = self._u_omega25[mode] * self._unit.physical.resonance_ratio(temperature_c)
        w_d = self._u_drive[mode]
        return self._u_rho_a * (w_r * w_r - w_d * w_d)

    def _u_steady(self, mode: int, kappa: float, gamma: float, temperature_c: float) -> complex:
        return _steady(self._u_drive[mode], self._u_c, kappa + self._u_detuning(mode, temperature_c), gamma)

    def _u_scale(self, mode: int, temperature_c: float) -> complex:
        """Envelope to reading: G(T) / (j w_d c R)."""
        gain = self._u_gain25[mode] * self._unit.physical.gain_ratio(temperature_c)
        return gain / (1j * self._u_drive[mode] * self._u_c) / self._u_ref[mode]

    def _u_table(self, mode: int, temperature_c: float):
        """The unit's (k_e, c_e) lookup for ``mode`` at ``temperature_c`` (tables to 0.1 K), or
        None for the exact gel."""
        t_q = round(temperature_c * 10.0) / 10.0
        key = (mode, t_q)
        if key not in self._u_tables:
            tip = self._unit.physical.fingertip_at(t_q)
            self._u_tables[key] = None if self.exact else foundation_table(tip, mode).at
        return self._u_tables[key]

    def _update_unit(self, pressure_cells_pa: Sequence[float], dt_s: float) -> Reading:
        """:meth:`update_trusted` for a physical unit (see :meth:`_setup_unit`)."""
        mode = self.mode
        self._u_time_s += dt_s
        temp = self._unit.physical.temperature_at(self._u_time_s) if self._u_drifts else self._u_temperature_c
        self._u_temperature_c = temp
        table_at = self._u_table(mode, temp)
        weights = self._u_weights[mode]
        self.evaluations += 1
        if table_at is None:
            tip = self._unit.physical.fingertip_at(round(temp * 10.0) / 10.0)
            k_e, c_e = tip.foundation(np.asarray(pressure_cells_pa, float), mode)
            kappa, gamma = float(k_e @ np.asarray(weights)), float(c_e @ np.asarray(weights))
        else:
            kappa = gamma = 0.0
            for p, w in zip(pressure_cells_pa, weights, strict=True):
                k_e, c_e = table_at(p)
                kappa += k_e * w
                gamma += c_e * w
        c, rho_a, w_d = self._u_c, self._u_rho_a, self._u_drive[mode]
        k_eff = kappa + self._u_detuning(mode, temp)
        steady = _steady(w_d, c, k_eff, gamma)
        rate = _rate(rho_a, w_d, c, k_eff, gamma)
        self.time_in_mode_s += dt_s
        self._clock_s += dt_s
        self._dt_s = dt_s
        tau = 1.0 / rate.real
        if self.dynamics == "envelope":
            self.envelope = envelope = _step(self.envelope, steady, dt_s, rate)
            settled = self.time_in_mode_s >= tau * _SETTLE_TAUS
        elif self.dynamics == "carrier":
            self.envelope = envelope = self._carrier.step(k_eff, gamma, dt_s)
            settled = self.time_in_mode_s >= tau * _SETTLE_TAUS
        else:
            self.envelope = envelope = steady
            settled = True
        out = envelope * self._u_scale(mode, temp)
        ref = self._u_ref[mode]
        sigma = self._u_sigma_v[mode] / math.hypot(ref.real, ref.imag)
        iq = out + complex(self._normal() * sigma, self._normal() * sigma) if self.noise else out
        v1_true = abs(out)
        phase = -math.atan2(out.imag, out.real) if v1_true > 0 else 0.0
        return _reading(mode, abs(iq), v1_true, phase, self.time_in_mode_s, tau, settled, kappa, gamma, iq)

    def _track(self, t: float, est: Estimate, a_ss: complex, gain: float = 1.0) -> None:
        """Re-zero while unloaded (calibrated units): re-centre the drive, renormalize.

        While the estimate has been "below_detection" for REZERO_S, the steady reading a_ss
        (the inference's, or the mean reading with steady dynamics) is the unloaded response,
        g / (1 - j delta) (:func:`sensor.calibration.detuning`): the drive moves by
        delta / tau0 in this mode and by the same fraction in every mode (temperature moves
        them alike), every reference by g.  Only a drift of more than REZERO_SIGMAS times the
        steady reading's own noise (``gain`` times a reading's sigma; a reading's sigma over
        the square root of the readings averaged with steady dynamics) is corrected: below that
        a correction would add noise, not remove drift.  A load below the detection limit is zeroed with it.
        """
        if est.status != "below_detection":
            self._unloaded_from = math.nan
            return
        if not t >= self._unloaded_from:  # a new unloaded stretch
            self._unloaded_from, self._unloaded_sum, self._unloaded_n = t, 0j, 0
        self._unloaded_sum += a_ss
        self._unloaded_n += 1
        if t - self._unloaded_from < REZERO_S:
            return
        if self.dynamics == "steady":
            z, sigma_z = self._unloaded_sum / self._unloaded_n, self._sigma[self.mode] / math.sqrt(self._unloaded_n)
        else:
            z, sigma_z = a_ss, gain * self._sigma[self.mode]
        self._unloaded_from, self._unloaded_sum, self._unloaded_n = t, 0j, 0
        delta, g = detuning(z)
        if not (math.isfinite(delta) and g > 0):
            return
        # Each part only where it is significant (delta ~ Im z and g - 1 ~ Re z - 1 near resonance,
        # each known to sigma_z): a correction of noise would add it to every later reading.
        if not abs(delta) > REZERO_SIGMAS * sigma_z:
            delta = 0.0
        # The gain drifts slowly (eq. 17's Y_p^2: 0.04 %/K) and its estimate is the noisier part
        # of a short window's a_ss: renormalized only from a settled window (gain <= GAIN_FLOOR).
        if not (abs(g - 1.0) > REZERO_SIGMAS * sigma_z and gain <= GAIN_FLOOR):
            g = 1.0
        if delta == 0.0 and g == 1.0:
            return
        w_d = self._u_drive[self.mode]
        frac = delta / (self._tau0 * w_d)
        for m in self._u_drive:
            old = self._u_drive[m]
            self._u_drive[m] = new = old * (1.0 + frac)
            self._u_ref[m] *= g * old / new
        # The envelope's normalization G / (j w_d c) moved with w_d: the same V_s, rescaled.
        self.envelope *= 1.0 + frac
        if self._carrier is not None:
            old = self._carrier
            self._carrier = self._new_carrier(self.mode)
            self._carrier.q, self._carrier.v, self._carrier.phase_time_s = old.q, old.v, old.phase_time_s
        if self._inference is not None:
            # in the new normalization the envelope is where it was: z / g now, relaxing to 1
            self._inference.restart(t, z / g)
        self.rezeros += 1

    def _new_carrier(self, mode: int) -> CarrierResonator:
        if self._unit is not None:  # the unit's resonator, driven at the readout's frequency
            return CarrierResonator(self._u_rho_a, self._u_c, self._u_drive[mode], self._carrier_spc)
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
            # A ring-up from rest: the inference starts from the known envelope 0 at the switch.
            self._inference = SteadyInference(self._tau0, self._sigma[mode])
            self._inference.restart(0.0, 0j)
            self._inference_mode = mode
            self._estimated_at = math.nan
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
        if self._unit is not None:
            return self._update_unit(pressure_cells_pa, dt_s)
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
        self._dt_s = dt_s
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

        Steady dynamics: the inverse of the reading.  Resonator dynamics: the envelope lags the
        load (tau0 = 0.66 s with Table I's damping), so the readout infers the steady reading of
        the present load from its recent readings (:class:`SteadyInference`) and inverts that.
        The estimate is "settling" while the inference is not trusted: too few readings since a
        switch or a detected load change, the last readings suggesting a change, or a gain above
        MAX_GAIN.  Otherwise its uncertainty is sigma / |dV/dP| times max(gain, GAIN_FLOOR), and
        its status is decided on that scaled sigma (below detection within 3 of unloaded).

        The contract (tests/test_readout_honesty.py measures it): where the status is "ok", the
        true pressure lies within estimate +- 3 uncertainty_pa, except in the first readings
        after an abrupt change that the readings cannot yet show (the resonator's latency);
        after the load is removed the status is "below_detection" within the inference's
        settling time (:class:`SteadyInference`).

        The readout uses only what a lock-in gives (I, Q, the time since its own switch) and
        the unloaded time constant from calibration, never the simulator's load.
        """
        inverse = self._inverse[reading.mode]
        if self.dynamics == "steady":
            if self._unit is not None and self._unit.tracking:
                est = inverse(reading.v1)
                self._track(self._clock_s, est, reading.iq)
                return est
            return inverse(reading.v1)
        t = self._clock_s
        if t == self._estimated_at:  # this reading's estimate again
            return self._last_estimate
        inference = self._inference
        if inference is None:
            # The instrument ran unloaded and settled before the scene: a settled history.
            inference = self._inference = SteadyInference(self._tau0, self._sigma[self.mode])
            inference.seed(self._seed_a, t - self._dt_s, self._dt_s)
            self._inference_mode = self.mode
        if reading.mode != self._inference_mode:  # a reading of a mode no longer driven
            return _SETTLING
        a_ss, gain, trusted = inference.step(t, reading.iq)
        est = inverse.inferred(abs(a_ss), gain) if trusted and gain <= MAX_GAIN else _SETTLING
        if self._unit is not None and self._unit.tracking and est is not _SETTLING:
            self._track(t, est, a_ss, gain)
        self._estimated_at, self._last_estimate = t, est
        return est

    def inverse(self, mode: int) -> ModeInverse:
        """The fast inverse of ``mode`` (its P_min, P_max, sigma)."""
        return self._inverse[mode]
