"""One reading of a table-driven channel: the per-sample arithmetic of one mode (see :mod:`sensor.sampler`).

A kernel (:mod:`sensor.compiled`): this module runs as Python and, where built, compiled
(``_sampler.pxd`` types it: the sample's floats and complex numbers in C).  The steps, their
equations and the reuse of the unloaded response are documented in :mod:`sensor.sampler`.
"""

from __future__ import annotations

import math
from array import array

from piezotip.sensor import _kernel_helpers as kh
from piezotip.sensor import resonator
from piezotip.sensor.resonator import Reading

#: A reading has settled this many time constants after its load changed (sensor.resonator).
_SETTLE_TAUS = resonator._SETTLE_TAUS
#: Where each field of a Reading is written (mode, v1, v1_true, phase_rad, time_in_mode_s,
#: tau_s, settled, kappa, gamma, iq).
_READING_AT = kh.slot_offsets(Reading, 10)


class ModeSampler:
    """The per-sample arithmetic of one mode of a table-driven channel (:mod:`sensor.sampler`).

    Parameters
    ----------
    mode : the mode n (recorded in each reading).
    omega : the drive, the mode's unloaded natural angular frequency, rad/s.
    sigma : the readout's noise on I and Q, in units of the unloaded envelope (dimensionless).
    c : the element's damping per unit length, N s/m^2.
    mass_per_length_kg_m : the element's rho A, kg/m.
    table : the mode's (k_e, c_e) table (:class:`sensor.estimator.FoundationTable`).
    weights : per pressure cell, b times the cell's share of the mode's modal integral, m.
    envelope : True for "envelope" dynamics (the first-order envelope), False for "steady".
    skip_unloaded : reuse the unloaded response for a sample without modal load (the readings
        are the same either way); None: :data:`sensor.sampler.SKIP_UNLOADED` now.
    """

    __slots__ = (
        "_args",
        "_c",
        "_c0",
        "_envelope",
        "_k0",
        "_log_c",
        "_log_k",
        "_log_p",
        "_n",
        "_omega",
        "_p0",
        "_rho_a",
        "_sigma",
        "_skip_unloaded",
        "_u_decay",
        "_u_dt",
        "_u_rate",
        "_u_steady",
        "_u_tau",
        "_weights",
        "lookups",
        "mode",
        "unloaded_samples",
    )

    def __init__(self, mode, omega, sigma, c, mass_per_length_kg_m, table, weights, envelope, skip_unloaded=None) -> None:
        weights = [float(w) for w in weights]
        if not weights:
            raise ValueError("a sampler needs at least one pressure cell")
        if skip_unloaded is None:
            from piezotip.sensor import sampler  # the public module's switch, as it is now

            skip_unloaded = sampler.SKIP_UNLOADED
        self._args = (mode, omega, sigma, c, mass_per_length_kg_m, table, weights, envelope, bool(skip_unloaded))
        self.mode = int(mode)
        self._omega, self._sigma, self._c = float(omega), float(sigma), float(c)
        self._rho_a = float(mass_per_length_kg_m)
        self._weights, self._n = array("d", weights), len(weights)  # C doubles, compiled
        self._envelope = bool(envelope)
        # The table, as FoundationTable.at reads it: log P, log k_e and log c_e (arrays of C
        # doubles), and below its first pressure P0 the linear part k0 P, c0 P.
        self._log_p, self._log_k, self._log_c = (array("d", column) for column in (table._log_p_list, table._log_k_list, table._log_c_list))
        if len(self._log_p) < 2 or len(self._log_k) != len(self._log_p) or len(self._log_c) != len(self._log_p):
            raise ValueError("a table needs two or more points and columns of its length")
        self._p0, self._k0, self._c0 = table._p0_f, table._k0_f, table._c0_f
        self.lookups = 0  # table lookups made, one per cell per sample (tests count the work)
        self._skip_unloaded = bool(skip_unloaded)
        # The unloaded resonator's steady envelope, rate and tau, and its decay exp(-rate dt)
        # over the last unloaded sample period _u_dt s (NaN before the first).
        self._u_steady, self._u_rate, self._u_tau = self._response(0.0, 0.0)
        self._u_dt, self._u_decay = math.nan, 0j
        self.unloaded_samples = 0  # samples that reused the unloaded response (tests count them)

    def _at(self, p: float) -> tuple[float, float]:
        """(k_e, c_e) at the pressure p, Pa: :meth:`sensor.estimator.FoundationTable.at` (log-log
        interpolation, linear below the table's first pressure)."""
        if p < self._p0:
            return p * self._k0, p * self._c0
        log_k, log_c = kh.interp_pair(kh.log(p), self._log_p, self._log_k, self._log_c)
        return kh.exp(log_k), kh.exp(log_c)

    def _response(self, kappa: float, gamma: float) -> tuple[complex, complex, float]:
        """(steady envelope, rate lambda 1/s, time constant tau s) under the modal load
        (kappa N/m^2, gamma N s/m^2): steps 2 and 3 of :mod:`sensor.sampler`."""
        omega, c = self._omega, self._c
        jk = 1j * kappa
        # Eq. 10 over its unloaded value, omega c / (omega (gamma + c) - j kappa)
        # (sensor.equations.normalized_response), and the rate (sensor.resonator._rate).
        steady = kh.cquot(omega * c, omega * (gamma + c) - jk)
        rate = (c + gamma) / (2.0 * self._rho_a) - kh.cquot(jk, 2.0 * omega * self._rho_a)
        return steady, rate, 1.0 / rate.real

    def _load(self, pressure_cells_pa) -> tuple[float, float]:
        """The modal load (kappa N/m^2, gamma N s/m^2) of the cells' pressures (Pa, one finite
        non-negative float per weight, unchecked): step 1 of :mod:`sensor.sampler`."""
        self.lookups += self._n
        if self._n == 1:
            k_e, c_e = self._at(pressure_cells_pa[0])
            return k_e * self._weights[0], c_e * self._weights[0]
        if len(pressure_cells_pa) != self._n:
            raise ValueError(f"{len(pressure_cells_pa)} pressure cells for {self._n} weights")
        kappa = gamma = 0.0
        for i in range(self._n):
            k_e, c_e = self._at(pressure_cells_pa[i])
            kappa += k_e * self._weights[i]
            gamma += c_e * self._weights[i]
        return kappa, gamma

    def _step(self, kappa: float, gamma: float, envelope: complex, dt_s: float, t_s: float, noisy: bool, noise: complex) -> tuple:
        """:meth:`advance` under the modal load (kappa, gamma): steps 2 to 5 of :mod:`sensor.sampler`
        (``t_s``: the time in this mode, s), less |envelope|: (iq, the new envelope, tau_s, settled)."""
        if kappa == 0.0 and gamma == 0.0 and self._skip_unloaded:  # no load: the unloaded resonator's
            self.unloaded_samples += 1
            steady, rate, tau = self._u_steady, self._u_rate, self._u_tau
            if self._envelope:
                if dt_s != self._u_dt:
                    self._u_decay = kh.cexp(-rate * dt_s)
                    self._u_dt = dt_s
                decay = self._u_decay
        else:
            steady, rate, tau = self._response(kappa, gamma)
            if self._envelope:
                decay = kh.cexp(-rate * dt_s)
        if self._envelope:
            envelope = steady + (envelope - steady) * decay  # resonator._step, its decay factor given
            settled = t_s >= tau * _SETTLE_TAUS
        else:
            envelope, settled = steady, True
        # The lock-in's in-phase and quadrature outputs each carry the readout's noise.
        iq = envelope + noise * self._sigma if noisy else envelope
        return iq, envelope, tau, settled

    def values(self, pressure_cells_pa, envelope: complex, dt_s: float, time_in_mode_s: float, noisy: bool, noise: complex) -> tuple:
        """:meth:`advance`'s values less v1_true = |envelope|, which a channel's per-step path
        (:class:`sensor._channel.ChannelCore`) derives only where a reading's record is asked for:
        (iq, the new envelope, tau_s, settled, kappa, gamma)."""
        kappa, gamma = self._load(pressure_cells_pa)
        iq, envelope, tau, settled = self._step(kappa, gamma, envelope, dt_s, time_in_mode_s, noisy, noise)
        return iq, envelope, tau, settled, kappa, gamma

    def values_one(self, pressure_pa: float, envelope: complex, dt_s: float, time_in_mode_s: float, noisy: bool, noise: complex) -> tuple:
        """:meth:`values` of a sampler of one cell under the pressure ``pressure_pa`` (Pa), no list
        made (:meth:`advance_one`'s)."""
        if self._n != 1:
            raise ValueError(f"one pressure for {self._n} weights")
        self.lookups += 1
        k_e, c_e = self._at(pressure_pa)
        kappa, gamma = k_e * self._weights[0], c_e * self._weights[0]
        iq, envelope, tau, settled = self._step(kappa, gamma, envelope, dt_s, time_in_mode_s, noisy, noise)
        return iq, envelope, tau, settled, kappa, gamma

    def advance(self, pressure_cells_pa, envelope: complex, dt_s: float, time_in_mode_s: float, noisy: bool, noise: complex) -> tuple:
        """One reading's values, no record made (:meth:`sample`'s arithmetic; a readout pass over
        many fingertips, :class:`sensor._channel.ChannelCore`, calls :meth:`values`, these less v1_true):
        (iq, the new envelope, v1_true, tau_s, settled, kappa, gamma) after ``dt_s`` s under the
        cells' pressures (Pa, one finite non-negative float per weight, unchecked) from the
        envelope ``envelope``; the drive has been in this mode ``time_in_mode_s`` s at the sample;
        ``noise`` is the lock-in's unit normal draw on I + jQ, added where ``noisy``."""
        iq, envelope, tau, settled, kappa, gamma = self.values(pressure_cells_pa, envelope, dt_s, time_in_mode_s, noisy, noise)
        return iq, envelope, kh.cabs(envelope), tau, settled, kappa, gamma

    def advance_one(self, pressure_pa: float, envelope: complex, dt_s: float, time_in_mode_s: float, noisy: bool, noise: complex) -> tuple:
        """:meth:`advance` of a sampler of one cell under the pressure ``pressure_pa`` (Pa), no list
        made (a touch pad's: its zone's force over its area)."""
        iq, envelope, tau, settled, kappa, gamma = self.values_one(pressure_pa, envelope, dt_s, time_in_mode_s, noisy, noise)
        return iq, envelope, kh.cabs(envelope), tau, settled, kappa, gamma

    def sample(self, pressure_cells_pa, envelope: complex, dt_s: float, time_in_mode_s: float, noise_iq):
        """(the reading, the new envelope) after ``dt_s`` s under the cells' pressures (Pa, one
        finite non-negative float per weight, unchecked) from the envelope ``envelope``; the
        drive has been in this mode ``time_in_mode_s`` s at the sample; ``noise_iq`` is the
        lock-in's unit normal draw on I + jQ (None: a noiseless reading)."""
        noisy = noise_iq is not None
        draw = noise_iq if noisy else 0j
        iq, envelope, v1_true, tau, settled, kappa, gamma = self.advance(pressure_cells_pa, envelope, dt_s, time_in_mode_s, noisy, draw)
        return reading(self.mode, iq, envelope, v1_true, time_in_mode_s, tau, settled, kappa, gamma), envelope

    def __reduce__(self):  # the unloaded decay is recomputed by the copy, the same
        return type(self), self._args, (self.lookups, self.unloaded_samples)

    def __setstate__(self, state) -> None:
        self.lookups, self.unloaded_samples = state


def reading(
    mode: int,
    iq: complex,
    envelope: complex,
    v1_true: float,
    time_in_mode_s: float,
    tau_s: float,
    settled: bool,
    kappa: float,
    gamma: float,
) -> Reading:
    """The :class:`sensor.resonator.Reading` of one sample's values (:meth:`ModeSampler.advance`'s):
    its magnitude |iq| and the envelope's phase (0 for a zero envelope) derived here."""
    phase = -kh.atan2(envelope.imag, envelope.real) if v1_true > 0 else 0.0
    return kh.record10(Reading, _READING_AT, mode, kh.cabs(iq), v1_true, phase, time_in_mode_s, tau_s, settled, kappa, gamma, iq)
