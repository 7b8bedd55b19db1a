"""Reading the sensor: noise, detection and resolution, and the resonator's envelope.

Physics reference: ``shared/physics.md`` sections 5 and 6.  Definitions used throughout
(stated here once, computed by :class:`sensor.Fingertip`):

- sigma_n: the standard deviation of a reading of V_1 in mode n (dimensionless, V_1 units),
  from two floors added in quadrature (:func:`output_sigma`);
- detection limit P_min: the smallest pressure that moves some mode's output by 3 sigma;
- resolution dP_n(P) = 3 sigma_n / |dV_n/dP|;
- upper limit P_max: the largest pressure (at most the rated pressure) at which some mode
  still resolves 10 % of P, i.e. dP_n(P) <= 0.1 P;
- dynamic range: P_max / P_min.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .element import _require_positive

#: A reading moves "detectably" when it moves by this many standard deviations.
DETECTION_SIGMAS = 3.0
#: A mode "resolves" P while its resolution is at most this fraction of P.
RESOLVED_FRACTION = 0.1


@dataclass(frozen=True)
class NoiseParams:
    """Noise of one reading of the sensed voltage.

    Attributes
    ----------
    relative_floor : standard deviation as a fraction of the mode's unloaded output V_0,
        dimensionless.  1e-3: the drive's amplitude stability (a laboratory function
        generator holds its amplitude to about 0.1 %) and the lock-in amplifier's gain
        stability, which scale with the signal and so set a floor of 60 dB below V_0.
    absolute_floor_v : standard deviation in volts, independent of the signal.  1e-3 V: the
        charge amplifier's input noise and a 14-bit converter over +-10 V (one count is
        1.2 mV, its quantization noise 0.35 mV rms), rounded up.
    """

    relative_floor: float = 1e-3
    absolute_floor_v: float = 1e-3

    def __post_init__(self) -> None:
        _require_positive(self)


def output_sigma(noise: NoiseParams, unloaded_voltage_v: float) -> float:
    """sigma of V_1 (dimensionless): sqrt(rel^2 + (abs / V_0)^2), V_0 in volts.

    A mode whose V_0 is zero (not excited by the electrode) has infinite sigma: it reads
    nothing.
    """
    if unloaded_voltage_v <= 0:
        return math.inf
    return math.hypot(noise.relative_floor, noise.absolute_floor_v / unloaded_voltage_v)


@dataclass(frozen=True)
class PressureEstimate:
    """The inverse of one mode's reading.

    Attributes
    ----------
    pressure_pa : estimate, Pa; NaN where the mode is saturated (it cannot tell).
    uncertainty_pa : one standard deviation of the estimate, sigma_n / |dV_n/dP|, Pa; at and
        below detection it is the mode's detection limit.
    status : per reading, "ok", "below_detection" (the reading is within 3 sigma of the
        unloaded output: P is somewhere below P_min of that mode) or "saturated" (the
        estimate lies past the mode's P_max, where it resolves less than 10 % of P).
    """

    pressure_pa: np.ndarray
    uncertainty_pa: np.ndarray
    status: np.ndarray


# ---------------------------------------------------------------------------------------
# Envelope dynamics of the driven resonator (physics.md section 6).
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
    kappa = np.asarray(kappa, float)
    gamma = np.asarray(gamma, float)
    return (c + gamma) / (2.0 * mass_per_length_kg_m) - 1j * kappa / (2.0 * omega * mass_per_length_kg_m)


def steady_envelope(omega: float, c: float, kappa, gamma) -> np.ndarray:
    """Steady complex envelope normalized to the unloaded one: omega c / (omega (gamma + c) - j kappa).

    Its magnitude is V_1 (eq. 19) and its angle is the phase change of eq. 13 relative to
    the unloaded pi/2.
    """
    return omega * c / (omega * (np.asarray(gamma, float) + c) - 1j * np.asarray(kappa, float))


def envelope_step(envelope, steady, dt_s: float, rate) -> np.ndarray:
    """Advance the complex envelope toward ``steady`` over ``dt_s`` (exact for a constant load).

    a(t + dt) = a_ss + (a - a_ss) exp(-lambda dt): the exact solution of
    a' = -lambda (a - a_ss) with a_ss and lambda held over the step, so it is stable for any
    dt and needs no substeps.
    """
    return steady + (np.asarray(envelope, complex) - steady) * np.exp(-np.asarray(rate) * dt_s)
