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
from piezotip.sensor.resonator import Reading

#: Noise is drawn in blocks (one generator call per block, not per reading; even: I and Q pair up).
_NOISE_BLOCK = 4096
#: The readout's constants and records (sensor.inference, sensor.estimator: one owner each).
_MAX_GAIN = inference.MAX_GAIN
_SETTLING, _SATURATED, _MODE_INVERSE = estimator._SETTLING, estimator._SATURATED, estimator.ModeInverse
#: What an estimate reads of a reading: its slots (compiled) or its attributes by name.
_READING = ("mode", "v1", "iq")
_READING_AT, _READING_GET = kh.slot_offsets(Reading, 3, _READING), attrgetter(*_READING)
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
        "_args",
        "_clock_s",
        "_core_of",
        "_dt_s",
        "_estimated_at",
        "_inference",
        "_inference_mode",
        "_inverse",
        "_inverse_seen",
        "_last_estimate",
        "_low_amplitude",
        "_low_since_s",
        "_noise",
        "_samplers",
        "_saturation_s",
        "_seed_a",
        "_sigma",
        "_steady",
        "_tau0",
        "envelope",
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
        self.envelope = 1 + 0j
        self.time_in_mode_s = math.inf
        self._noise = []  # the lock-in's noise drawn ahead, taken from the end
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

    def iq_noise(self) -> complex:
        """The lock-in's noise on one reading: independent standard normal draws on I and Q,
        from a block drawn ahead (the generator's draws taken in pairs, I first)."""
        if not self._noise:
            draws = self.rng.standard_normal(_NOISE_BLOCK)
            # Taken from the end: the block's last two draws (I, then Q) make the first reading's.
            # complex(draws[k + 1], draws[k]) for even k, each made by numpy's copy, not Python's.
            block = np.empty(_NOISE_BLOCK // 2, dtype=complex)
            block.real, block.imag = draws[1::2], draws[0::2]
            self._noise = block.tolist()
        return self._noise.pop()

    def update(self, pressure_cells_pa, dt_s: float) -> Reading:
        """:meth:`sensor.channel.SensorChannel.update_trusted` of a channel with samplers: the
        reading after ``dt_s`` s under the cells' pressures (Pa, unchecked)."""
        mode = self.mode
        self.evaluations += 1
        sampler = self._samplers[mode]
        self.time_in_mode_s = t = self.time_in_mode_s + dt_s
        self._clock_s += dt_s
        self._dt_s = dt_s
        if self.noise:
            noise = self._noise.pop() if self._noise else self.iq_noise()
        else:
            noise = None
        if type(sampler) is sm.ModeSampler:
            s = sampler  # (a C call, compiled)
            out = s.sample(pressure_cells_pa, self.envelope, dt_s, t, noise)
        else:  # another sampler class (a test's): through Python
            out = sampler.sample(pressure_cells_pa, self.envelope, dt_s, t, noise)
        reading, self.envelope = out
        return reading

    def estimate(self, reading: Reading):
        """:meth:`sensor.channel.SensorChannel.estimate` of a readout that does not re-zero, with
        "steady" or "envelope" dynamics (see there): the pressure estimate of ``reading``."""
        mode, v1, iq = kh.fields(reading, Reading, _READING_AT, 3, _READING_GET)
        inverse = self._inverse[mode]
        if self._steady:
            return inverse(v1)
        t = self._clock_s
        if t == self._estimated_at:  # this reading's estimate again
            return self._last_estimate
        if self._inference is None:
            # The instrument ran unloaded and settled before the scene: a settled history.  Of
            # the class sensor.channel names now, as select_mode's (a test may swap it).
            from piezotip.sensor import channel

            self._inference = channel.SteadyInference(self._tau0, self._sigma[self.mode])
            self._inference.seed(self._seed_a, t - self._dt_s, self._dt_s)
            self._inference_mode = self.mode
        if mode != self._inference_mode:  # a reading of a mode no longer driven
            return _SETTLING
        if type(self._inference) is si.SteadyInference:
            inf = self._inference  # (a C call, compiled)
            a_ss, gain, trusted = inf.step(t, iq)
        else:
            a_ss, gain, trusted = self._inference.step(t, iq)
        if kh.cabs(iq) < self._low_amplitude[mode]:
            if self._low_since_s is None:
                self._low_since_s = t
        else:
            self._low_since_s = None
        if trusted and gain <= _MAX_GAIN:
            if inverse is not self._inverse_seen:
                found = inverse._core if type(inverse) is _MODE_INVERSE else None
                self._inverse_seen, self._core_of = inverse, found if type(found) is se.InverseCore else None
            if self._core_of is not None:
                core = self._core_of  # ModeInverse.inferred's own call (a C call, compiled)
                est = core.inferred(kh.cabs(a_ss), gain)
            else:
                est = inverse.inferred(kh.cabs(a_ss), gain)
        elif self._low_since_s is not None and t - self._low_since_s >= self._saturation_s:
            est = _SATURATED  # past P_max, as the readings show (SATURATION_TAUS)
        else:
            est = _SETTLING
        self._estimated_at, self._last_estimate = t, est
        return est

    def sample(self, pressure_cells_pa, dt_s: float) -> tuple:
        """(:meth:`update`, its :meth:`estimate`): one control period's reading and estimate."""
        reading = self.update(pressure_cells_pa, dt_s)
        return reading, self.estimate(reading)

    def __reduce__(self):
        return type(self), (*self._args, self.mode, self.noise, self.rng), tuple([getattr(self, name) for name in _STATE])

    def __setstate__(self, state) -> None:
        if len(state) != len(_STATE):
            raise ValueError(f"a ChannelCore's state has {len(_STATE)} values, got {len(state)}")
        for i in range(len(_STATE)):
            setattr(self, _STATE[i], state[i])
