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

Each dynamics is an object (:class:`Dynamics`: ``DYNAMICS`` maps its name to it), so a new one
is added here, in one place: what a switch of mode does to the resonator's state, one sample's
advance, whether its reading is the steady one, whether the table-driven sampler runs it.

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
    "Dynamics",
    "Reading",
    "envelope_rate",
    "envelope_step",
    "steady_envelope",
]

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


# ---------------------------------------------------------------------------------------
# The dynamics, one object each: what a channel (sensor.channel.SensorChannel) asks of them.
# ---------------------------------------------------------------------------------------


class Dynamics:
    """One resonator dynamics: what a :class:`sensor.channel.SensorChannel` does by it.

    Stateless (one shared instance per dynamics, in ``DYNAMICS``): the resonator's state is the
    channel's (its ``envelope``, held by its core, and its ``_carrier``), which the methods take.

    Attributes
    ----------
    name : the dynamics' name (``SensorChannel.dynamics``, ``sensor.dynamics`` of a scenario).
    steady_reading : a reading is the steady one (no lag): the readout inverts it directly, and
        a re-zeroing readout averages the readings themselves (:meth:`UnitChannel._track`).
    sampled : a table-driven channel's samples are :class:`sensor.sampler.ModeSampler` calls
        through its :class:`ChannelCore` (the per-step fast path); else the channel's own path.
    """

    __slots__ = ()
    name = ""
    steady_reading = False
    sampled = False

    def __reduce__(self) -> tuple:
        # One instance per dynamics: a pickled or copied channel shares it (found by its name).
        return _dynamics, (self.name,)

    def __repr__(self) -> str:
        return f"<{self.name} dynamics>"

    def start(self, channel, detuning_n_m2: float = 0.0) -> None:
        """Put ``channel``'s resonator where a running, unloaded instrument has it: settled in
        its driven mode, with the drive detuned from the resonance by the stiffness
        ``detuning_n_m2`` (N/m^2, :meth:`sensor.unit_channel.UnitChannel._u_detuning`).  The envelope's own start is
        the channel's (``channel.envelope``); only a carrier has more state."""

    def switch(self, channel, mode: int) -> None:
        """``channel`` now drives ``mode`` (a new mode, from rest): reset the resonator's state."""

    def retune(self, channel) -> None:
        """``channel``'s drive frequency moved (a re-zero): the resonator keeps its motion."""

    def advance(self, channel, steady: complex, rate: complex, kappa: float, gamma: float, dt_s: float) -> tuple[complex, bool, float]:
        """One sample of ``dt_s`` s under the load (kappa N/m^2, gamma N s/m^2), the channel's
        clocks already advanced: sets ``channel.envelope`` and returns (envelope, settled,
        tau_s), tau_s = 1 / Re(lambda) (``rate``, 1/s) and ``steady`` eq. 10's envelope."""
        raise NotImplementedError


class SteadyDynamics(Dynamics):
    """The "steady" dynamics: the envelope is the steady one (eq. 10) at every sample, always settled."""

    __slots__ = ()
    name = "steady"
    steady_reading = True
    sampled = True

    def advance(self, channel, steady: complex, rate: complex, kappa: float, gamma: float, dt_s: float) -> tuple[complex, bool, float]:
        tau = 1.0 / rate.real
        channel.envelope = steady
        return steady, True, tau


class EnvelopeDynamics(Dynamics):
    """The "envelope" dynamics: the first-order complex envelope (:func:`envelope_step`, exact per sample);
    a switch rings the new mode up from rest (envelope 0)."""

    __slots__ = ()
    name = "envelope"
    sampled = True

    def switch(self, channel, mode: int) -> None:
        channel.envelope = 0j

    def advance(self, channel, steady: complex, rate: complex, kappa: float, gamma: float, dt_s: float) -> tuple[complex, bool, float]:
        tau = 1.0 / rate.real
        channel.envelope = envelope = _step(channel.envelope, steady, dt_s, rate)
        return envelope, channel.time_in_mode_s >= tau * _SETTLE_TAUS, tau


class CarrierDynamics(Dynamics):
    """The "carrier" dynamics: the modal equation through every drive cycle and a lock-in
    (:class:`sensor.carrier.CarrierResonator`, the channel's ``_carrier``, made by its
    ``_new_carrier(mode)``); a switch starts the new mode's carrier from rest."""

    __slots__ = ()
    name = "carrier"

    def start(self, channel, detuning_n_m2: float = 0.0) -> None:
        channel._carrier = channel._new_carrier(channel.mode)
        channel._carrier.start_steady(detuning_n_m2)

    def switch(self, channel, mode: int) -> None:
        channel._carrier = channel._new_carrier(mode)  # the new mode starts from rest

    def retune(self, channel) -> None:
        old = channel._carrier
        channel._carrier = new = channel._new_carrier(channel.mode)
        new.q, new.v, new.phase_time_s = old.q, old.v, old.phase_time_s

    def advance(self, channel, steady: complex, rate: complex, kappa: float, gamma: float, dt_s: float) -> tuple[complex, bool, float]:
        tau = 1.0 / rate.real
        channel.envelope = envelope = channel._carrier.step(kappa, gamma, dt_s)
        return envelope, channel.time_in_mode_s >= tau * _SETTLE_TAUS, tau


#: The dynamics by name, one per fidelity (the module's docstring): a new one is added here.
DYNAMICS: dict[str, Dynamics] = {d.name: d for d in (SteadyDynamics(), EnvelopeDynamics(), CarrierDynamics())}


def _dynamics(name: str) -> Dynamics:
    """The dynamics named ``name`` (a ValueError naming the valid ones otherwise)."""
    try:
        return DYNAMICS[name]
    except (KeyError, TypeError):
        raise ValueError(f"unknown sensor dynamics {name!r}; valid: {', '.join(DYNAMICS)}") from None
