"""One reading of a table-driven channel: the per-sample arithmetic of :class:`sensor.channel.SensorChannel`.

For a channel that reads the gel from its tables (not ``exact``) with "steady" or "envelope"
dynamics, a sample of the driven mode n is, in order (physics.md sections 3 and 6):

1. the modal load: each cell's (k_e, c_e) from the mode's :class:`FoundationTable` (log-log
   interpolation, linear in P below its first point), summed with the mode's cell weights
   (b times eq. 20's integrals per cell): kappa in N/m^2, gamma in N s/m^2;
2. eq. 10's steady envelope over the unloaded one, omega c / (omega (gamma + c) - j kappa)
   (:func:`sensor.equations.normalized_response`);
3. the envelope's rate lambda = (c + gamma) / (2 rho A) - j kappa / (2 omega rho A), 1/s, and
   its time constant tau = 1 / Re(lambda), s (:func:`sensor.resonator.envelope_rate`);
4. the envelope advanced exactly over the sample period, a + (a0 - a) exp(-lambda dt)
   (:func:`sensor.resonator.envelope_step`), or the steady envelope itself ("steady");
5. the lock-in's output, the envelope plus the readout's noise (a unit complex normal draw
   times the mode's sigma, dimensionless), its magnitude V_1 and the noise-free phase, rad.

:class:`PyModeSampler` is that, one instance per mode, in Python floats and complex numbers;
it is the reference and the one to read.  ``sensor/_sampler.pyx`` is its compiled twin (the
same arithmetic in the same order, bit for bit: tests/test_compiled_twins.py), used where it
was built (:mod:`sensor.compiled`; :data:`SAMPLER_COMPILED` says).  The channel keeps the
state (mode, envelope, clocks, noise) and calls :meth:`PyModeSampler.sample` once per reading.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from .compiled import twin
from .equations import normalized_response
from .estimator import FoundationTable
from .resonator import _SETTLE_TAUS, Reading, _rate, _reading, _step

__all__ = ["SAMPLER_COMPILED", "ModeSampler", "PyModeSampler"]


class PyModeSampler:
    """The per-sample arithmetic of one mode of a table-driven channel (see the module).

    Parameters
    ----------
    mode : the mode n (recorded in each reading).
    omega : the drive, the mode's unloaded natural angular frequency, rad/s.
    sigma : the readout's noise on I and Q, in units of the unloaded envelope (dimensionless).
    c : the element's damping per unit length, N s/m^2.
    mass_per_length_kg_m : the element's rho A, kg/m.
    table : the mode's (k_e, c_e) table.
    weights : per pressure cell, b times the cell's share of the mode's modal integral, m.
    envelope : True for "envelope" dynamics (the first-order envelope), False for "steady".
    """

    __slots__ = ("_at", "_c", "_envelope", "_omega", "_rho_a", "_sigma", "_weights", "lookups", "mode")

    def __init__(
        self,
        mode: int,
        omega: float,
        sigma: float,
        c: float,
        mass_per_length_kg_m: float,
        table: FoundationTable,
        weights: Sequence[float],
        envelope: bool,
    ) -> None:
        self.mode = int(mode)
        self._omega, self._sigma, self._c = float(omega), float(sigma), float(c)
        self._rho_a = float(mass_per_length_kg_m)
        self._at = table.at
        self._weights = [float(w) for w in weights]
        if not self._weights:
            raise ValueError("a sampler needs at least one pressure cell")
        self._envelope = bool(envelope)
        self.lookups = 0  # table lookups made, one per cell per sample (tests count the work)

    def sample(
        self, pressure_cells_pa: Sequence[float], envelope: complex, dt_s: float, time_in_mode_s: float, noise_iq: complex | None
    ) -> tuple[Reading, complex]:
        """(the reading, the new envelope) after ``dt_s`` s under the cells' pressures (Pa, one
        finite non-negative float per weight, unchecked) from the envelope ``envelope``; the
        drive has been in this mode ``time_in_mode_s`` s at the sample; ``noise_iq`` is the
        lock-in's unit normal draw on I + jQ (None: a noiseless reading)."""
        at, weights = self._at, self._weights
        self.lookups += len(weights)
        if len(weights) == 1:
            k_e, c_e = at(pressure_cells_pa[0])
            kappa, gamma = k_e * weights[0], c_e * weights[0]
        else:
            kappa = gamma = 0.0
            for p, w in zip(pressure_cells_pa, weights, strict=True):
                k_e, c_e = at(p)
                kappa += k_e * w
                gamma += c_e * w
        omega, c = self._omega, self._c
        steady = normalized_response(kappa, gamma, omega, c)
        rate = _rate(self._rho_a, omega, c, kappa, gamma)
        tau = 1.0 / rate.real
        if self._envelope:
            envelope = _step(envelope, steady, dt_s, rate)
            settled = time_in_mode_s >= tau * _SETTLE_TAUS
        else:
            envelope, settled = steady, True
        v1_true = abs(envelope)
        # The lock-in's in-phase and quadrature outputs each carry the readout's noise.
        iq = envelope + noise_iq * self._sigma if noise_iq is not None else envelope
        phase = -math.atan2(envelope.imag, envelope.real) if v1_true > 0 else 0.0
        reading = _reading(self.mode, abs(iq), v1_true, phase, time_in_mode_s, tau, settled, kappa, gamma, iq)
        return reading, envelope


#: The channels' sampler: the compiled twin of :class:`PyModeSampler` where built, else it.
ModeSampler, SAMPLER_COMPILED = twin("piezotip.sensor._sampler", "ModeSampler", PyModeSampler)
