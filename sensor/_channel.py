"""A table-driven channel's reading and estimate, once per control period (see :mod:`sensor.channel`).

A kernel (:mod:`sensor.compiled`): this module runs as Python and, where built, compiled
(``_channel.pxd`` types it: the channel's clocks and envelope in C, C calls to the sampler, the
inference and the inverse).  :class:`ChannelCore` owns the per-reading state of one
:class:`sensor.channel.SensorChannel`, which forwards its attributes of the same names here,
and runs the channel's per-step path where it has one: :meth:`SensorChannel.update_trusted`
with "steady" or "envelope" dynamics from the tables (a :class:`sensor.sampler.ModeSampler`
call), and :meth:`SensorChannel.estimate` of a readout that does not re-zero.  The exact gel,
the carrier and a calibrated unit's re-zeroing keep the channel's own Python, on this state.
"""

from __future__ import annotations

import math
from operator import attrgetter

import numpy as np

from piezotip.sensor import _estimator as se
from piezotip.sensor import _inference as si
from piezotip.sensor import _kernel_helpers as kh
from piezotip.sensor import _sampler as sm
from piezotip.sensor import estimator, inference
from piezotip.sensor.estimator import Estimate
from piezotip.sensor.resonator import Reading

#: Noise is drawn in blocks (one generator call per block, not per reading; even: I and Q pair up).
_NOISE_BLOCK = 4096
#: The readout's constants and records (sensor.inference, sensor.estimator: one owner each).
_MAX_GAIN = inference.MAX_GAIN
_SETTLING, _SATURATED, _MODE_INVERSE = estimator._SETTLING, estimator._SATURATED, estimator.ModeInverse
#: What an estimate reads of a reading: its slots (compiled) or its attributes by name.
_READING = ("mode", "v1", "iq")
_READING_AT, _READING_GET = kh.slot_offsets(Reading, 3, _READING), attrgetter(*_READING)
#: What is read of an estimate, likewise.
_ESTIMATE = ("pressure_pa", "uncertainty_pa", "status")
_ESTIMATE_AT, _ESTIMATE_GET = kh.slot_offsets(Estimate, 3, _ESTIMATE), attrgetter(*_ESTIMATE)
#: An estimate's status by its name, as the index the kernels carry (sensor._estimator.STATUSES).
_STATUS_INDEX = {name: i for i, name in enumerate(se.STATUSES)}
_SATURATED_AT, _SETTLING_AT = se.SATURATED, se.SETTLING
_NAN = math.nan  # (compiled, a C double: no lookup of math's)
#: A core's written envelope (``_envelope``) while its envelope is its last reading's (``_r_envelope``).
_LAST_READING = object()
#: What a copy carries over of a core's state (the constructor's arguments rebuild the rest).
_STATE = (
    "mode",
    "evaluations",
    "envelope",
    "time_in_mode_s",
    "_noise",
    "_clock_s",
    "_dt_s",
    "_inference",
    "_inference_mode",
    "_estimated_at",
    "_last_estimate",
    "_seed_a",
    "_low_since_s",
)


class ChannelCore:
    """The per-reading state of one :class:`sensor.channel.SensorChannel` and its per-step path.

    Parameters
    ----------
    samplers : the channel's :class:`sensor.sampler.ModeSampler` per mode (a dict, shared with
        the channel; empty where its readings take another path: exact gel, carrier).
    inverses : the channel's :class:`sensor.estimator.ModeInverse` per mode (shared: a physical
        unit replaces them in place).
    sigmas : a reading's noise per mode (V_1 units, dimensionless).
    low_amplitudes : per mode, the reading magnitude under which a mode may be saturated
        (V_1 units; :data:`sensor.channel.SATURATION_TAUS`).
    tau0_s : the unloaded envelope's time constant, s.
    saturation_s : how long readings stay low before they say saturated, s.
    dynamics : the channel's dynamics ("steady", "envelope" or "carrier").
    mode : the mode driven at the start.
    noise : whether readings carry the lock-in's noise.
    rng : the noise generator (numpy Generator).
    """

    __slots__ = (
        "_a_record",
        "_args",
        "_clock_s",
        "_core_of",
        "_draws",
        "_dt_s",
        "_envelope",
        "_estimated_at",
        "_inference",
        "_inference_mode",
        "_inverse",
        "_inverse_seen",
        "_last_p",
        "_last_record",
        "_last_sigma",
        "_last_status",
        "_left",
        "_low",
        "_low_amplitude",
        "_low_mode",
        "_low_since_s",
        "_mode_sampler",
        "_mode_seen",
        "_r_envelope",
        "_r_gamma",
        "_r_iq",
        "_r_kappa",
        "_r_mode",
        "_r_record",
        "_r_settled",
        "_r_t",
        "_r_tau",
        "_r_v1",
        "_samplers",
        "_saturation_s",
        "_seed_a",
        "_sigma",
        "_steady",
        "_tau0",
        "evaluations",
        "mode",
        "noise",
        "rng",
        "time_in_mode_s",
    )

    def __init__(self, samplers, inverses, sigmas, low_amplitudes, tau0_s, saturation_s, dynamics, mode, noise, rng) -> None:
        self._args = (samplers, inverses, sigmas, low_amplitudes, tau0_s, saturation_s, dynamics)
        self._samplers, self._inverse, self._sigma, self._low_amplitude = samplers, inverses, sigmas, low_amplitudes
        self._tau0, self._saturation_s = float(tau0_s), float(saturation_s)
        self._steady = dynamics == "steady"
        # The last inverse met and its InverseCore where it is a ModeInverse's (its inferred is
        # that core's, fixed when it is built), else None: found once, not per estimate.
        self._inverse_seen, self._core_of = None, None
        self.noise, self.rng = noise, rng
        self.mode = mode
        self.evaluations = 0  # gel/sensor evaluations, counted for "compute only what is needed" tests
        # The instrument has been running unloaded before the scene starts: steady, settled.
        # (The envelope as written, kept as it is until a reading replaces it by its own,
        # _r_envelope: the property envelope.)
        self._envelope = 1 + 0j
        self.time_in_mode_s = math.inf
        # The lock-in's noise drawn ahead (a block of the generator's draws, I and Q in pairs),
        # and how many readings' worth are left, taken from the end.
        self._draws, self._left = np.zeros(_NOISE_BLOCK), 0
        # The readout's own clock: time since the channel started or last switched, s.
        self._clock_s = 0.0
        self._dt_s = 0.005  # the last sample period, s (for the settled history before the scene)
        # The readout's inference of the steady reading (its mode, and the last estimate, for a
        # reading estimated twice); created at the first estimate from the unloaded history.
        self._inference = None
        self._inference_mode = mode
        self._estimated_at, self._last_estimate = math.nan, _SETTLING
        # The readout's history before the scene: settled, unloaded readings of this value.
        self._seed_a = 1 + 0j
        # Since when (readout clock, s) every reading has stayed under its mode's low amplitude
        # (sensor.channel.SATURATION_TAUS); None while the last one did not.
        self._low_since_s = None
        # The last reading's values (_read) and its record once made (or another sampler's);
        # the last advance's estimate's record where it is not the last estimate (advance).
        self._r_mode, self._r_iq, self._r_envelope, self._r_v1 = mode, 0j, 0j, math.nan
        self._r_t, self._r_tau, self._r_settled, self._r_kappa, self._r_gamma = math.nan, math.nan, False, math.nan, math.nan
        self._r_record, self._a_record = None, None
        # The driven mode's sampler and the last reading's mode's low amplitude, as last looked up.
        self._mode_seen, self._mode_sampler, self._low_mode, self._low = None, None, -1, math.nan

    def _draw(self) -> complex:
        """The lock-in's noise on one reading: independent standard normal draws on I and Q,
        from a block drawn ahead (the generator's draws taken in pairs from the block's end: its
        last two draws, Q then I, make the first reading's)."""
        if self._left == 0:
            self._draws = self.rng.standard_normal(_NOISE_BLOCK)
            self._left = _NOISE_BLOCK // 2
        self._left -= 1
        j = 2 * self._left
        return kh.cx(self._draws[j + 1], self._draws[j])

    def iq_noise(self) -> complex:
        """:meth:`_draw`, as a Python complex."""
        return self._draw()

    @property
    def _noise(self) -> list:
        """The noise drawn ahead and not yet taken (complex), the next one last."""
        return [kh.cx(self._draws[2 * i + 1], self._draws[2 * i]) for i in range(self._left)]

    @_noise.setter
    def _noise(self, values) -> None:
        draws = np.zeros(max(_NOISE_BLOCK, 2 * len(values)))
        for i, z in enumerate(values):
            draws[2 * i + 1], draws[2 * i] = z.real, z.imag
        self._draws, self._left = draws, len(values)

    def _read(self, pressure_cells_pa, pressure_pa: float, dt_s: float) -> None:
        """The reading after ``dt_s`` s under the cells' pressures (Pa, unchecked; None: one cell,
        at ``pressure_pa``), its values kept (:meth:`last_reading` makes its record when asked)."""
        mode = self.mode
        self.evaluations += 1
        if mode is not self._mode_seen:  # the mode's sampler, looked up once a switch, not each reading
            self._mode_seen, self._mode_sampler = mode, self._samplers[mode]
        sampler = self._mode_sampler
        self.time_in_mode_s = t = self.time_in_mode_s + dt_s
        self._clock_s += dt_s
        self._dt_s = dt_s
        noisy = bool(self.noise)
        draw = self._draw() if noisy else 0j
        if type(sampler) is sm.ModeSampler:
            s = sampler  # (a C call, compiled)
            if self._envelope is _LAST_READING:  # (compiled, a C complex: no object made a reading)
                envelope = self._r_envelope
            else:
                envelope = self._envelope
            # (|envelope|, the reading's v1_true, is derived where its record is made: last_reading.)
            if pressure_cells_pa is None:
                iq, envelope, tau, settled, kappa, gamma = s.values_one(pressure_pa, envelope, dt_s, t, noisy, draw)
            else:
                iq, envelope, tau, settled, kappa, gamma = s.values(pressure_cells_pa, envelope, dt_s, t, noisy, draw)
            self._envelope = _LAST_READING
            self._r_mode, self._r_iq, self._r_envelope, self._r_t = mode, iq, envelope, t
            self._r_tau, self._r_settled, self._r_kappa, self._r_gamma = tau, settled, kappa, gamma
            self._r_record = None
        else:  # another sampler class (a test's): through Python, its record kept
            cells = [pressure_pa] if pressure_cells_pa is None else pressure_cells_pa
            reading, self._envelope = sampler.sample(cells, self.envelope, dt_s, t, draw if noisy else None)
            self._r_mode, self._r_v1, self._r_iq = kh.fields(reading, Reading, _READING_AT, 3, _READING_GET)
            self._r_record = reading

    @property
    def envelope(self):
        """The resonator's envelope over the unloaded steady one: as last written (a physical
        unit's may be a NumPy complex, kept as it is), else the last reading's."""
        return self._r_envelope if self._envelope is _LAST_READING else self._envelope

    @envelope.setter
    def envelope(self, value) -> None:
        self._envelope = value

    def last_reading(self) -> Reading:
        """The record of the last reading (:meth:`update`'s, :meth:`advance`'s)."""
        if self._r_record is None:
            self._r_record = sm.reading(
                self._r_mode,
                self._r_iq,
                self._r_envelope,
                kh.cabs(self._r_envelope),
                self._r_t,
                self._r_tau,
                self._r_settled,
                self._r_kappa,
                self._r_gamma,
            )
        return self._r_record

    def update(self, pressure_cells_pa, dt_s: float) -> Reading:
        """:meth:`sensor.channel.SensorChannel.update_trusted` of a channel with samplers: the
        reading after ``dt_s`` s under the cells' pressures (Pa, unchecked)."""
        self._read(pressure_cells_pa, 0.0, dt_s)
        return self.last_reading()

    def _estimate_of(self, mode: int, iq: complex) -> tuple:
        """The estimate's values of a reading of ``mode`` whose lock-in output is ``iq``, with
        "envelope" dynamics (:meth:`estimate`'s rules): (pressure_pa, uncertainty_pa, its status's
        index in :data:`sensor._estimator.STATUSES`, whether it is the kept :attr:`_last_estimate`)."""
        t = self._clock_s
        if t == self._estimated_at:  # this reading's estimate again
            return self._last_p, self._last_sigma, self._last_status, True
        if self._inference is None:
            # The instrument ran unloaded and settled before the scene: a settled history.  Of
            # the class sensor.channel names now, as select_mode's (a test may swap it).
            from piezotip.sensor import channel

            self._inference = channel.SteadyInference(self._tau0, self._sigma[self.mode])
            self._inference.seed(self._seed_a, t - self._dt_s, self._dt_s)
            self._inference_mode = self.mode
        if mode != self._inference_mode:  # a reading of a mode no longer driven
            return _NAN, _NAN, _SETTLING_AT, False
        if type(self._inference) is si.SteadyInference:
            inf = self._inference  # (a C call, compiled)
            a_ss, gain, trusted = inf.step(t, iq)
        else:
            a_ss, gain, trusted = self._inference.step(t, iq)
        if mode != self._low_mode:  # the mode's low amplitude, looked up once a switch
            self._low_mode, self._low = mode, self._low_amplitude[mode]
        if kh.cabs(iq) < self._low:
            if self._low_since_s is None:
                self._low_since_s = t
        else:
            self._low_since_s = None
        record = None
        if trusted and gain <= _MAX_GAIN:
            inverse = self._inverse[mode]
            if inverse is not self._inverse_seen:
                found = inverse._core if type(inverse) is _MODE_INVERSE else None
                self._inverse_seen, self._core_of = inverse, found if type(found) is se.InverseCore else None
            if self._core_of is not None:
                core = self._core_of  # ModeInverse.inferred's own values (a C call, compiled)
                p, sigma, status = core.infer(kh.cabs(a_ss), gain)
            else:
                record = inverse.inferred(kh.cabs(a_ss), gain)
                p, sigma, status = _values_of(record)
        elif self._low_since_s is not None and t - self._low_since_s >= self._saturation_s:
            p, sigma, status, record = _NAN, _NAN, _SATURATED_AT, _SATURATED  # past P_max, as the readings show (SATURATION_TAUS)
        else:
            p, sigma, status, record = _NAN, _NAN, _SETTLING_AT, _SETTLING
        self._estimated_at = t
        self._last_p, self._last_sigma, self._last_status, self._last_record = p, sigma, status, record
        return p, sigma, status, True

    @property
    def _last_estimate(self):
        """The last estimate (a reading estimated twice gets it again), made when asked."""
        if self._last_record is None:
            self._last_record = se.estimate(self._last_p, self._last_sigma, self._last_status)
        return self._last_record

    @_last_estimate.setter
    def _last_estimate(self, record) -> None:
        self._last_p, self._last_sigma, self._last_status = _values_of(record)
        self._last_record = record

    def estimate(self, reading: Reading):
        """:meth:`sensor.channel.SensorChannel.estimate` of a readout that does not re-zero, with
        "steady" or "envelope" dynamics (see there): the pressure estimate of ``reading``."""
        mode, v1, iq = kh.fields(reading, Reading, _READING_AT, 3, _READING_GET)
        if self._steady:
            return self._inverse[mode](v1)
        kept = self._estimate_of(mode, iq)[3]
        return self._last_estimate if kept else _SETTLING

    def sample(self, pressure_cells_pa, dt_s: float) -> tuple:
        """(:meth:`update`, its :meth:`estimate`): one control period's reading and estimate."""
        reading = self.update(pressure_cells_pa, dt_s)
        return reading, self.estimate(reading)

    def advance(self, pressure_cells_pa, dt_s: float) -> tuple:
        """:meth:`sample`'s reading and estimate as values, their records made only when asked
        (:meth:`last_reading`, :meth:`last_estimate`): what a readout pass over many fingertips
        calls.  (mode, pressure_pa, uncertainty_pa, the status's index in
        :data:`sensor._estimator.STATUSES`)."""
        self._read(pressure_cells_pa, 0.0, dt_s)
        return self._estimated()

    def advance_one(self, pressure_pa: float, dt_s: float) -> tuple:
        """:meth:`advance` of a channel of one cell under ``pressure_pa`` (Pa), no list made."""
        self._read(None, pressure_pa, dt_s)
        return self._estimated()

    def _estimated(self) -> tuple:
        """The last reading's estimate as values (:meth:`advance`'s)."""
        mode = self._r_mode
        if self._steady:
            # Another sampler's record: its v1 as it says.
            v1 = self._r_v1 if self._r_record is not None else kh.cabs(self._r_iq)
            record = self._inverse[mode](v1)
            p, sigma, status = _values_of(record)
            self._a_record = record
            return mode, p, sigma, status
        p, sigma, status, kept = self._estimate_of(mode, self._r_iq)
        self._a_record = None if kept else _SETTLING
        return mode, p, sigma, status

    def last_estimate(self):
        """The record of the last :meth:`advance`'s estimate."""
        return self._last_estimate if self._a_record is None else self._a_record

    def __reduce__(self):
        return type(self), (*self._args, self.mode, self.noise, self.rng), tuple([getattr(self, name) for name in _STATE])

    def __setstate__(self, state) -> None:
        if len(state) != len(_STATE):
            raise ValueError(f"a ChannelCore's state has {len(_STATE)} values, got {len(state)}")
        for i in range(len(_STATE)):
            setattr(self, _STATE[i], state[i])


def _values_of(record) -> tuple:
    """An estimate record's values: (pressure_pa, uncertainty_pa, its status's index in
    :data:`sensor._estimator.STATUSES`)."""
    p, sigma, name = kh.fields(record, Estimate, _ESTIMATE_AT, 3, _ESTIMATE_GET)
    return p, sigma, _STATUS_INDEX[name]
