"""One instrumented fingertip as a running instrument: pressure profile in, reading and estimate out.

A :class:`SensorChannel` holds what a real readout holds between samples: the mode it is
driving, the resonator's state (physics.md section 6), the noise generator, the readout's
inference (a physical unit apart from the model, with its calibration and drift, is
:class:`sensor.unit_channel.UnitChannel`'s).  It composes the stages, each with its own home:

- :mod:`sensor.equations`: the paper's equations (eq. 10's steady response per sample);
- :mod:`sensor.resonator`: the resonator's dynamics (steady, envelope, carrier) and the
  :class:`Reading`;
- :mod:`sensor.estimator`: the gel's tables and the one pressure inverse (:class:`ModeInverse`);
- :mod:`sensor.inference`: the steady reading of a resonator that has not settled;
- :mod:`sensor.calibration` and :mod:`sensor.unit_channel`: a physical unit, what the readout
  knows of it (drive, references, re-zeroing by :func:`sensor.calibration.detuning`).

Each :meth:`SensorChannel.update` takes the pad's pressure along the element (one value per
cell, Pa) and the time since the last sample, and returns a :class:`Reading`.  Only what the
scene asks for is computed: the per-mode tables are built once per channel, for its modes
only, and a sample evaluates the active mode alone (the other modes' outputs, for plots, are
computed after a run from the recorded pressures: analysis/run_report.py).  A sample is scalar
work (a few table lookups and complex numbers), so it runs on Python floats and complex
numbers (tests/test_channel_perf_equivalence.py checks it against the documented numpy
functions).  :meth:`SensorChannel.update` checks its input and the co-simulation, whose
profiles are checked by construction, calls :meth:`SensorChannel.update_trusted`.

The readout (:meth:`SensorChannel.estimate`) turns each reading into a pressure estimate.  Its
contract, measured by tests/test_readout_honesty.py: an "ok" estimate's interval, estimate +-
3 uncertainty_pa, holds the true pressure, except in the first readings after an abrupt change
that the readings do not show yet (a physical limit of a slow resonator, measured against an
oracle); the estimate is "settling" while the inference cannot tell; after the load is removed
it reads "below_detection" within the inference's settling time.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from .carrier import CarrierResonator
from .equations import normalized_response
from .estimator import _SATURATED, _SETTLING, Estimate, ModeInverse, mode_tables
from .fingertip import Fingertip
from .inference import MAX_GAIN, SteadyInference
from .resonator import _SETTLE_TAUS, DYNAMICS, Reading, _rate, _reading, _step
from .sampler import ModeSampler

#: Noise is drawn in blocks (one generator call per block, not per reading; even: I and Q pair up).
_NOISE_BLOCK = 4096

#: A mode is known to be saturated, while its inference cannot tell, once every reading for
#: SATURATION_TAUS unloaded time constants has stayed under half the mode's output at P_max (by 3
#: sigma of noise).  Why that proves it: a load's damping only adds to the element's, so the
#: envelope relaxes to its steady value A_ss at least as fast as unloaded, |A(t) - A_ss| <=
#: |A(0) - A_ss| e^(-t / tau0), from any start and along any spiral of a detuned mode.  Were
#: |A_ss| >= V(P_max) with every |A| under V(P_max) / 2, then after t, |A(t)| >= |A_ss| -
#: (V(P_max) / 2 + |A_ss|) e^(-t / tau0), which passes V(P_max) / 2 once e^(-t / tau0) < 1/3:
#: t > ln 3 tau0 (0.73 s with Table I's damping).  So the steady reading lies past P_max: the
#: status is "saturated" (and the selector moves up) instead of "settling" for as long as the
#: load lasts, which a mode driven deep past its range (a 10 kg grip in mode 1: V_1 ~ 1e-3, at
#: the noise) gave before (tests/test_readout_saturation.py).
SATURATION_TAUS = math.log(3.0)


def _modal_load(table_at, pressure_cells_pa, weights) -> tuple[float, float]:
    """(kappa, gamma): the cells' tabulated (k_e, c_e) summed with the mode's weights (the modal
    load of eq. 20's integrals, per cell), in Python floats for the per-step path."""
    if len(weights) == 1:
        k_e, c_e = table_at(pressure_cells_pa[0])
        return k_e * weights[0], c_e * weights[0]
    kappa = gamma = 0.0
    for p, w in zip(pressure_cells_pa, weights, strict=True):
        k_e, c_e = table_at(p)
        kappa += k_e * w
        gamma += c_e * w
    return kappa, gamma


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

    The channel simulates ``fingertip`` itself; a physical unit apart from the model the
    readout knows is :class:`sensor.unit_channel.UnitChannel`'s.
    """

    #: Whether the readout re-zeroes while unloaded (a calibrated physical unit's: UnitChannel).
    _tracking = False

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
        # default: one cell over the gel's contact
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
        tables = {m: mode_tables(fingertip, m, exact) for m in used}
        self._tables = {m: tables[m][0] for m in used} if not exact else {}
        self._inverse = {m: tables[m][1] for m in used}
        # For update_trusted: per mode (omega, sigma, table lookup, weights as floats).
        self._fast = {
            m: (float(self._omega[m]), float(self._sigma[m]), self._tables[m].at if not exact else None, self._weights[m].tolist())
            for m in used
        }
        self._rho_a_f, self._c_f = float(self._rho_a), float(self._c)
        # A table-driven reading with steady or envelope dynamics is one sampler call (the
        # carrier and the exact gel keep their own paths below).
        self._samplers = (
            {
                m: ModeSampler(m, *self._fast[m][:2], self._c_f, self._rho_a_f, self._tables[m], self._fast[m][3], dynamics == "envelope")
                for m in used
            }
            if not exact and dynamics != "carrier"
            else {}
        )
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
        self._noise: list[complex] = []
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
        # Since when (readout clock, s) every reading has stayed under half the driven mode's
        # output at P_max (SATURATION_TAUS); None while the last one did not.
        self._low_since_s: float | None = None
        self._saturation_s = SATURATION_TAUS * self._tau0
        self._low_amplitude = {m: 0.5 * self._inverse[m].v_at_p_max - 3.0 * self._sigma[m] for m in used}

    def _new_carrier(self, mode: int) -> CarrierResonator:
        return CarrierResonator(self._rho_a_f, self._c_f, float(self._omega[mode]), self._carrier_spc)

    def _iq_noise(self) -> complex:
        """The lock-in's noise on one reading: independent standard normal draws on I and Q,
        from a block drawn ahead (the generator's draws taken in pairs, I first)."""
        if not self._noise:
            draws = self.rng.standard_normal(_NOISE_BLOCK).tolist()
            self._noise = [complex(i, q) for i, q in zip(draws[-1::-2], draws[-2::-2], strict=True)][::-1]
        return self._noise.pop()

    @property
    def n_cells(self) -> int:
        return self.edges_m.size - 1

    @property
    def unloaded_samples(self) -> int:
        """Readings that reused the unloaded resonator's response (no modal load: every cell at
        0 Pa), over this channel's modes (:mod:`sensor.sampler`; 0 where it has no samplers)."""
        return sum(s.unloaded_samples for s in self._samplers.values())

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
            self._low_since_s = None
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

    def _resonate(self, steady: complex, rate: complex, kappa: float, gamma: float, dt_s: float) -> tuple[complex, bool, float]:
        """Advance the resonator one sample under the load (kappa, gamma): (envelope, settled,
        tau_s) for the channel's dynamics (steady, envelope or carrier; sensor/resonator.py)."""
        self.time_in_mode_s += dt_s
        self._clock_s += dt_s
        self._dt_s = dt_s
        tau = 1.0 / rate.real
        if self.dynamics == "envelope":
            self.envelope = envelope = _step(self.envelope, steady, dt_s, rate)
            return envelope, self.time_in_mode_s >= tau * _SETTLE_TAUS, tau
        if self.dynamics == "carrier":
            self.envelope = envelope = self._carrier.step(kappa, gamma, dt_s)
            return envelope, self.time_in_mode_s >= tau * _SETTLE_TAUS, tau
        self.envelope = steady
        return steady, True, tau

    def update_trusted(self, pressure_cells_pa: Sequence[float], dt_s: float) -> Reading:
        """:meth:`update` without checking the profile: the co-simulation's per-step path.

        ``pressure_cells_pa`` must be ``n_cells`` finite, non-negative Python floats (Pa); a
        wrong profile gives a wrong reading, not an error.  One table lookup per cell for the
        active mode (counted in :attr:`evaluations`), then the envelope in complex scalars.
        """
        mode = self.mode
        self.evaluations += 1
        sampler = self._samplers.get(mode)
        if sampler is not None:
            self.time_in_mode_s = t = self.time_in_mode_s + dt_s
            self._clock_s += dt_s
            self._dt_s = dt_s
            noise = (self._noise.pop() if self._noise else self._iq_noise()) if self.noise else None  # _iq_noise, inlined
            reading, self.envelope = sampler.sample(pressure_cells_pa, self.envelope, dt_s, t, noise)
            return reading
        omega, sigma, table_at, weights = self._fast[mode]
        c = self._c_f
        if table_at is None:  # exact: the gel model itself, on arrays
            k_e, c_e = self.tip.foundation(np.asarray(pressure_cells_pa, float), mode)
            kappa, gamma = float(k_e @ self._weights[mode]), float(c_e @ self._weights[mode])
        else:
            kappa, gamma = _modal_load(table_at, pressure_cells_pa, weights)
        steady = normalized_response(kappa, gamma, omega, c)
        rate = _rate(self._rho_a_f, omega, c, kappa, gamma)
        envelope, settled, tau = self._resonate(steady, rate, kappa, gamma, dt_s)
        v1_true = abs(envelope)
        # The lock-in's in-phase and quadrature outputs each carry the readout's noise.
        iq = envelope + self._iq_noise() * sigma if self.noise else envelope
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
            if self._tracking:
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
        if abs(reading.iq) < self._low_amplitude[reading.mode]:
            if self._low_since_s is None:
                self._low_since_s = t
        else:
            self._low_since_s = None
        if trusted and gain <= MAX_GAIN:
            est = inverse.inferred(abs(a_ss), gain)
        elif self._low_since_s is not None and t - self._low_since_s >= self._saturation_s:
            est = _SATURATED  # past P_max, as the readings show (SATURATION_TAUS)
        else:
            est = _SETTLING
        if self._tracking and est is not _SETTLING:
            self._track(t, est, a_ss, gain)
        self._estimated_at, self._last_estimate = t, est
        return est

    def inverse(self, mode: int) -> ModeInverse:
        """The fast inverse of ``mode`` (its P_min, P_max, sigma)."""
        return self._inverse[mode]
