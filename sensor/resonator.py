"""The driven resonator's dynamics: from the gel's modal load to the lock-in's reading.

Physics reference: ``shared/physics.md`` section 6.  Driven at a fixed frequency, the mode's
complex envelope does not jump when the load changes: it relaxes toward the steady envelope
of eq. 10 (:func:`sensor.equations.normalized_response`) at a complex rate lambda.  Three
dynamics, one per fidelity (``DYNAMICS``):

- "steady": the envelope is the steady one at every sample (no lag);
- "envelope": the first-order complex envelope, advanced exactly per sample
  (:func:`envelope_rate`, :func:`envelope_step`);
- "carrier": the reference, the modal equation through every drive cycle and a lock-in
  (:class:`sensor.carrier.CarrierResonator`).

Each formula is written twice where it must be: for numpy arrays (the documented functions,
used by the analyses and the tests) and for Python floats and complex numbers (``_steady``,
``_rate``, ``_step``: a sample is scalar work, and numpy's per-call overhead on 0-d arrays
would cost ten times the arithmetic).  tests/test_channel_perf_equivalence.py checks the pairs
agree.  A sample's result is a :class:`Reading`.
"""

from __future__ import annotations

import cmath
import math
from dataclasses import dataclass

import numpy as np

from .compiled import record_maker
from .equations import normalized_response

__all__ = [
    "DYNAMICS",
    "SETTLE_FRACTION",
    "Reading",
    "envelope_rate",
    "envelope_step",
    "steady_envelope",
]

DYNAMICS = ("steady", "envelope", "carrier")
#: A reading is "settled" once the transient has decayed below this fraction.
SETTLE_FRACTION = 1e-3
#: Settling takes this many time constants: ln(1 / SETTLE_FRACTION).
_SETTLE_TAUS = math.log(1.0 / SETTLE_FRACTION)


# ---------------------------------------------------------------------------------------
# The envelope, for numpy arrays.
# ---------------------------------------------------------------------------------------


def envelope_rate(mass_per_length_kg_m: float, omega: float, c: float, kappa, gamma) -> np.ndarray:
    """Complex relaxation rate lambda of the driven mode's envelope, 1/s.

    Writing the modal displacement as Re(a(t) e^(j omega t)) with a slowly varying and
    dropping a'' (first-order averaging of eq. 4 at the drive omega = omega_n), the modal
    equation per unit A_L becomes  2 j omega rho A a' + (kappa + j omega (gamma + c)) a = F,
    so a relaxes to its steady state (eq. 10) as exp(-lambda t) with

        lambda = (c + gamma) / (2 rho A) - j kappa / (2 omega rho A).

    Its real part is 1 / tau_n with tau_n = 2 M_n / C_n (physics.md section 6); the
    imaginary part is the detuning by the gel's stiffness, which makes a loaded ring-up beat.
    """
    return _rate(mass_per_length_kg_m, omega, c, np.asarray(kappa, float), np.asarray(gamma, float))


def steady_envelope(omega: float, c: float, kappa, gamma) -> np.ndarray:
    """Steady complex envelope normalized to the unloaded one: omega c / (omega (gamma + c) - j kappa).

    Its magnitude is V_1 (eq. 19) and its angle is the phase change of eq. 13 relative to
    the unloaded pi/2.
    """
    return normalized_response(np.asarray(kappa, float), np.asarray(gamma, float), omega, c)


def envelope_step(envelope, steady, dt_s: float, rate) -> np.ndarray:
    """Advance the complex envelope toward ``steady`` over ``dt_s`` (exact for a constant load).

    a(t + dt) = a_ss + (a - a_ss) exp(-lambda dt): the exact solution of
    a' = -lambda (a - a_ss) with a_ss and lambda held over the step, so it is stable for any
    dt and needs no substeps.
    """
    return steady + (np.asarray(envelope, complex) - steady) * np.exp(-np.asarray(rate) * dt_s)


# ---------------------------------------------------------------------------------------
# The same, for one sample: Python floats and complex numbers.
# ---------------------------------------------------------------------------------------


def _steady(omega: float, c: float, kappa: float, gamma: float) -> complex:
    """:func:`steady_envelope` for floats (eq. 10 normalized: the per-step path calls
    :func:`sensor.equations.normalized_response` itself)."""
    return normalized_response(kappa, gamma, omega, c)


def _rate(mass_per_length_kg_m: float, omega: float, c: float, kappa: float, gamma: float) -> complex:
    """:func:`envelope_rate` for floats, 1/s (rho A kg/m, omega rad/s, c and gamma N s/m^2, kappa N/m^2)."""
    return (c + gamma) / (2.0 * mass_per_length_kg_m) - 1j * kappa / (2.0 * omega * mass_per_length_kg_m)


def _step(envelope: complex, steady: complex, dt_s: float, rate: complex) -> complex:
    """:func:`envelope_step` for Python complex numbers (``dt_s`` s, ``rate`` 1/s)."""
    return steady + (envelope - steady) * cmath.exp(-rate * dt_s)


@dataclass(frozen=True, slots=True)
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


#: ``Reading(...)`` for the per-step path (positional, every field): its slots set through
#: their descriptors, without the constructor's object.__setattr__ per field (sensor.compiled).
_reading = record_maker(Reading)
