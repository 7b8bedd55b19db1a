"""Reading the sensor: noise, detection and resolution, and the steady envelope of a relaxation.

The envelope's own dynamics live in :mod:`sensor.resonator` (``envelope_rate``,
``steady_envelope`` and ``envelope_step``).

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

import cmath
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
# Inferring the steady envelope from a relaxation in progress (physics.md section 6); the
# envelope's own dynamics are in :mod:`sensor.resonator`.
# ---------------------------------------------------------------------------------------


def ring_up_steady(envelope: complex, time_s: float, tau0_s: float, rate_guess: complex | None = None) -> tuple[complex, float]:
    """Steady envelope inferred from a ring-up in progress, and its noise gain.

    After a mode switch the envelope rises from rest under a (constant) load as
    a(t) = a_ss (1 - exp(-lambda t)), and the load ties the two unknowns together:
    a_ss = omega c / (omega (gamma + c) - j kappa) and lambda = ((c + gamma) - j kappa / omega) / (2 rho A)
    give a_ss = 1 / (tau0 lambda), tau0 = 2 rho A / c the unloaded time constant (both from
    eqs. 10 and 19 and :func:`sensor.resonator.envelope_rate`).  One complex reading a at time t
    therefore fixes z = lambda t through

        (1 - exp(-z)) / z = a tau0 / t,

    solved by Newton's method; then a_ss = t / (tau0 z).  The returned gain |d a_ss / d a|
    is how much the reading's noise is amplified: about 2 / |z|^2 early in the ring-up, 1
    once it has settled.  A reading that cannot be inverted yet (noise larger than the rise)
    returns (nan, inf).  This is :func:`relaxation_steady` from rest.

    A stiff load detunes the mode (Im lambda = -kappa / (2 omega rho A)) and the envelope
    spirals in; then the equation has other roots, and only the physical one has
    Re z >= t / tau0 (gamma >= 0) and Im z <= 0 (kappa >= 0).  Pass ``rate_guess`` (the
    previous sample's lambda, 1/s) to follow that root through a ring-up; a root outside the
    physical quadrant, past half a beat (|Im z| > pi) without a guess, or more than one
    radian from the guessed branch, returns (nan, inf).
    """
    return relaxation_steady(0j, envelope, time_s, tau0_s, rate_guess)


def relaxation_steady(
    start: complex, now: complex, window_s: float, tau0_s: float, rate_guess: complex | None = None
) -> tuple[complex, float]:
    """Steady envelope inferred from two readings ``window_s`` apart under a constant load.

    Between them a(t) relaxes as a1 = a_ss + (a0 - a_ss) e^(-z), z = lambda W, and
    a_ss = 1 / (tau0 lambda) (see :func:`ring_up_steady`, the case a0 = 0), so

        F(z) = (W / tau0) (1 - e^(-z)) / z + a0 e^(-z) - a1 = 0

    is one complex equation in z, solved by Newton's method; a_ss = W / (tau0 z).  The gain
    is |d a_ss| per unit of independent noise on both readings:
    W / (tau0 |z|^2) sqrt(1 + |e^(-z)|^2) / |F'(z)|.  Roots are checked as in
    :func:`ring_up_steady` (physical quadrant, the branch).  Returns (nan, inf) when there is
    no usable root.
    """
    nan = complex(math.nan, math.nan), math.inf
    if not (window_s > 0 and tau0_s > 0):
        return nan
    a0, a1 = complex(start), complex(now)
    scale = window_s / tau0_s
    if a0 == 0:
        w = a1 / scale
        if not 1e-12 < abs(w) < 1.0:  # |g(z)| < 1 for every physical z: noise has outrun the rise
            return nan
        default = 2.0 * (1.0 - w) if abs(w) > 0.5 else 1.0 / w  # small- and large-z asymptotes of g
    else:
        if abs(a1) < 1e-12:
            return nan
        default = scale / a1  # the settled reading's own rate, lambda = 1 / (tau0 a1)
    z = complex(rate_guess) * window_s if rate_guess is not None and math.isfinite(abs(rate_guess)) else default
    for _ in range(60):
        if abs(z) < 1e-8 or z.real < -30.0:  # diverging to an unphysical, growing solution
            return nan
        ez = cmath.exp(-z)
        dg = (ez * (1.0 + z) - 1.0) / (z * z)
        f = scale * (1.0 - ez) / z + a0 * ez - a1
        df = scale * dg - a0 * ez
        if df == 0:
            return nan
        step = f / df
        z -= step
        if abs(step) <= 1e-13 * max(1.0, abs(z)):
            break
    else:
        return nan
    unphysical = z.real < (1.0 - 1e-9) * scale or z.imag > 1e-9 * abs(z)
    # Past half a beat the spiral's other turns are roots too: only a tracked root is kept.
    ambiguous = abs(z.imag) > math.pi if rate_guess is None else abs(z - complex(rate_guess) * window_s) > 1.0
    if unphysical or ambiguous:
        return nan
    ez = cmath.exp(-z)
    df = scale * (ez * (1.0 + z) - 1.0) / (z * z) - a0 * ez
    gain = scale / abs(z * z) * math.sqrt(1.0 + abs(ez) ** 2 * (a0 != 0)) / abs(df)
    return scale / z, gain
