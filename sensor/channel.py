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
profiles are checked by construction, calls :meth:`SensorChannel.update_trusted`.  The state a
reading changes (mode, clocks, envelope, noise, the inference) is held by the channel's
:class:`ChannelCore` (a kernel, sensor/_channel.py), whose per-step path runs a table-driven
channel's :meth:`SensorChannel.update_trusted` and :meth:`SensorChannel.estimate`; the channel's
attributes of those names are that state.

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
from operator import attrgetter

import numpy as np

from ._channel import ChannelCore
from .carrier import CarrierResonator
from .equations import normalized_response
from .estimator import _SATURATED, _SETTLING, Estimate, ModeInverse, mode_tables
from .fingertip import Fingertip
from .inference import MAX_GAIN, SteadyInference
from .resonator import Reading, _dynamics, _rate, _reading
from .sampler import ModeSampler

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


def _state(name: str, doc: str) -> property:
    """The attribute ``name`` of a channel's :class:`ChannelCore`, read and written through the
    channel (the core is its one owner)."""

    def put(channel: SensorChannel, value) -> None:
        setattr(channel._core, name, value)

    return property(attrgetter(f"_core.{name}"), put, doc=doc)


class SensorChannel:
    """The readout of one fingertip: drives one mode at a time, samples, switches.

    Parameters
    ----------
    fingertip : the Fingertip (element, gel, coverage, noise).
    edges_m : cell edges along the element (m) of the pressure profile the pad supplies;
        default one cell over the gel coverage (a uniform pressure).
    dynamics : "steady", "envelope" (first-order complex envelope, exact per step) or
        "carrier" (the reference: the modal equation through every drive cycle, demodulated):
        a name in :data:`sensor.resonator.DYNAMICS`, whose object (:class:`sensor.resonator.Dynamics`,
        the channel's ``_resonator``) does what differs between them.
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

    # The state a reading changes, held by the channel's core (sensor/_channel.py).
    mode = _state("mode", "The mode driven.")
    noise = _state("noise", "Whether readings carry noise.")
    rng = _state("rng", "The noise generator.")
    evaluations = _state("evaluations", 'Gel/sensor evaluations, counted for "compute only what is needed" tests.')
    envelope = _state("envelope", "The resonator's envelope over the unloaded steady one (complex, dimensionless).")
    time_in_mode_s = _state("time_in_mode_s", "Time driving this mode, s (inf: settled before the scene).")
    _noise = _state("_noise", "The lock-in's unit noise drawn ahead (complex), taken from the end.")
    _clock_s = _state("_clock_s", "The readout's own clock: time since the channel started or last switched, s.")
    _dt_s = _state("_dt_s", "The last sample period, s.")
    _inference = _state("_inference", "The readout's SteadyInference (None before the first estimate).")
    _inference_mode = _state("_inference_mode", "The mode the inference reads.")
    _estimated_at = _state("_estimated_at", "The readout clock of the last estimate, s (NaN: none since a switch).")
    _last_estimate = _state("_last_estimate", "The last estimate (a reading estimated twice).")
    _seed_a = _state("_seed_a", "The settled, unloaded reading before the scene (complex).")
    _low_since_s = _state("_low_since_s", "Since when every reading has stayed low (SATURATION_TAUS), s; None.")

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
        self._resonator = resonator = _dynamics(dynamics)
        self.tip = fingertip
        self.dynamics = dynamics
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
        # A table-driven reading of sampled dynamics (steady, envelope) is one sampler call, its
        # envelope lagging unless the reading is the steady one (the carrier and the exact gel
        # keep their own paths below).
        self._samplers = (
            {
                m: ModeSampler(
                    m, *self._fast[m][:2], self._c_f, self._rho_a_f, self._tables[m], self._fast[m][3], not resonator.steady_reading
                )
                for m in used
            }
            if not exact and resonator.sampled
            else {}
        )
        self._tau0 = 2.0 * self._rho_a_f / self._c_f  # unloaded envelope time constant, s
        # A mode is saturated once every reading has stayed under half its output at P_max (by
        # 3 sigma of noise) for _saturation_s (SATURATION_TAUS).
        self._saturation_s = SATURATION_TAUS * self._tau0
        self._low_amplitude = {m: 0.5 * self._inverse[m].v_at_p_max - 3.0 * self._sigma[m] for m in used}
        # The state a reading changes, from the settled, unloaded instrument before the scene
        # (ChannelCore's constructor); its per-step path where the readings are the samplers'.
        start = fingertip.modes[0] if mode is None else fingertip._mode(mode)
        self._core = ChannelCore(
            self._samplers,
            self._inverse,
            self._sigma,
            self._low_amplitude,
            self._tau0,
            self._saturation_s,
            dynamics,
            start,
            noise,
            rng or np.random.default_rng(0),
        )
        self._fast_core = self._core if self._samplers else None
        self._bind_fast_path()
        self._carrier_spc = int(carrier_samples_per_cycle)
        self._carrier: CarrierResonator | None = None
        resonator.start(self)

    def _bind_fast_path(self) -> None:
        """A SensorChannel (not a subclass, which may override or re-zero) whose readings are its
        samplers' reads and estimates through its core's own methods, set on the instance over
        the class's functions: a control step's call costs no Python frame of the channel's."""
        if type(self) is SensorChannel and self._fast_core is not None:
            core = self._fast_core
            self.update_trusted, self.estimate, self.sample = core.update, core.estimate, core.sample

    def __getstate__(self) -> dict:
        # Without the core's bound methods (a copy binds its own core's: _bind_fast_path).
        state = self.__dict__.copy()
        state.pop("update_trusted", None)
        state.pop("estimate", None)
        state.pop("sample", None)
        return state

    def __setstate__(self, state: dict) -> None:
        self.__dict__.update(state)
        self._bind_fast_path()

    def sample(self, pressure_cells_pa: Sequence[float], dt_s: float) -> tuple[Reading, Estimate]:
        """One period's :meth:`update_trusted` and its :meth:`estimate`, in one call (a plain
        channel's is its core's :meth:`ChannelCore.sample`: what a readout pass over many
        fingertips calls)."""
        reading = self.update_trusted(pressure_cells_pa, dt_s)
        return reading, self.estimate(reading)

    def _new_carrier(self, mode: int) -> CarrierResonator:
        return CarrierResonator(self._rho_a_f, self._c_f, float(self._omega[mode]), self._carrier_spc)

    def _iq_noise(self) -> complex:
        """The lock-in's noise on one reading: independent standard normal draws on I and Q,
        from a block drawn ahead (:meth:`ChannelCore.iq_noise`)."""
        return self._core.iq_noise()

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
            self._resonator.switch(self, mode)  # the new mode starts from rest

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
        tau_s) for the channel's dynamics (:meth:`sensor.resonator.Dynamics.advance`)."""
        self.time_in_mode_s += dt_s
        self._clock_s += dt_s
        self._dt_s = dt_s
        return self._resonator.advance(self, steady, rate, kappa, gamma, dt_s)

    def update_trusted(self, pressure_cells_pa: Sequence[float], dt_s: float) -> Reading:
        """:meth:`update` without checking the profile: the co-simulation's per-step path.

        ``pressure_cells_pa`` must be ``n_cells`` finite, non-negative Python floats (Pa); a
        wrong profile gives a wrong reading, not an error.  One table lookup per cell for the
        active mode (counted in :attr:`evaluations`), then the envelope in complex scalars.
        """
        core = self._fast_core
        if core is not None:  # a sampler per mode: the core's path (ChannelCore.update)
            return core.update(pressure_cells_pa, dt_s)
        mode = self.mode
        self.evaluations += 1
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
        core = self._fast_core
        if core is not None and not self._tracking:  # the core's path (ChannelCore.estimate)
            return core.estimate(reading)
        inverse = self._inverse[reading.mode]
        if self._resonator.steady_reading:
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
