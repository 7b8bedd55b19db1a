"""The paper's equations of the loaded, driven element, in the paper's order, one function each.

Physics reference: ``shared/physics.md`` section 3, which restates Motoo, Arai and Fukuda,
"Piezoelectric vibration-type tactile sensor with wide measurement range using elasticity and
viscosity change", IEEE Sensors Journal 7(7), 2007.  Equation numbers (eq. N) are the paper's.

The gel acts on the driven mode n only through two generalized (modal) loads, normalized by
``A_L = integral_0^L Z_n^2 dx`` so that the mode's normalization drops out:

    kappa = b integral k_e(x) Z_n^2 dx / A_L      [N/m^2]   (= b k_e A_x / A_L if uniform)
    gamma = b integral c_e(x) Z_n^2 dx / A_L      [N s/m^2] (= b c_e A_x / A_L if uniform)

and with the element's own damping ``c`` (N s/m^2, per unit length) eq. 10's denominator
divided by A_L is ``kappa + j omega (gamma + c)`` (N/m^2), omega the drive (the unloaded
natural angular frequency omega_n, rad/s).  Every function below is written in these terms and
takes Python floats or numpy arrays alike (the co-simulation's per-step path calls them on
floats).  They use ``hypot`` and ratios of bounded quantities, so k_e up to 1e15 N/m^3, c_e up
to 1e9 N s/m^3 and damping down to 1e-12 give finite results without overflow or warnings.

physics.md restates eqs. 10, 13 and 17 to 21; the paper's eqs. 11, 12 and 14 to 16 are the
steps between them (the amplitude and phase of eq. 10, the sensing layer's strain and
charge) and have no function of their own here: nothing computes them apart from the
equations they lead to.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from .element import ElementParams


def normalized_response(kappa, gamma, omega: float, c: float):
    """Eq. 10 over its unloaded value: the steady complex amplitude of the driven mode relative
    to the unloaded one, dimensionless.

    Eq. 10's amplitude is proportional to 1 / (kappa + j omega (gamma + c)) (per unit A_L);
    unloaded it is 1 / (j omega c), so the ratio is j omega c / (kappa + j omega (gamma + c)),
    computed as omega c / (omega (gamma + c) - j kappa) (kappa N/m^2, gamma and c N s/m^2,
    omega rad/s).  Its magnitude is V_1 (eq. 19), its angle the change of eq. 13's phase from
    the unloaded pi/2.  This is the resonator's steady envelope (:mod:`sensor.resonator`).
    """
    return omega * c / (omega * (gamma + c) - 1j * kappa)


def phase_rad(kappa, gamma, omega: float, c: float):
    """Eq. 13: phi = atan(omega (gamma + c) / kappa), radians in (0, pi/2] (pi/2 unloaded);
    kappa N/m^2, gamma and c N s/m^2, omega rad/s."""
    return np.arctan2(omega * (gamma + c), kappa)


def sensed_voltage_v(params: ElementParams, coupling_per_m2: float, kappa, gamma, omega: float, c: float, gain_factor: float = 1.0):
    """Eq. 17: amplitude |V_s| of the sensed voltage, volts (the drive V's measure, peak-to-peak).

    |V_s| = b^2 Y_p^2 d31^2 V (2 t_s + t_p)^2 F_n / (4 C A_L sqrt(kappa^2 + omega^2 (gamma + c)^2))

    with A_L = L (the modes' normalization, m), ``params`` the element's Table I quantities
    (b, Y_p, d31, V, t_s, t_p, C in SI units), F_n = ``coupling_per_m2`` (1/m^2, the one
    deviation from the printed equation: :meth:`sensor.element.SensorElement.coupling_factor_per_m2`),
    kappa N/m^2, gamma and c N s/m^2, omega rad/s, and ``gain_factor`` (dimensionless) a unit's
    measured departure from it (:class:`sensor.element.ModeTrim`).
    """
    p = params
    numerator = (
        (p.width_m * p.pzt_youngs_pa * p.d31_m_per_v) ** 2 * p.drive_voltage_v * (2 * p.substrate_half_thickness_m + p.pzt_thickness_m) ** 2
    )
    numerator *= coupling_per_m2
    numerator *= gain_factor
    return numerator / (4 * p.capacitance_f * p.length_m * np.hypot(kappa, omega * (gamma + c)))


def unloaded_voltage_v(params: ElementParams, coupling_per_m2: float, omega: float, c: float, gain_factor: float = 1.0) -> float:
    """Eq. 18: V_0, eq. 17's amplitude with k_e = c_e = 0, volts:
    b^2 Y_p^2 d31^2 V (2 t_s + t_p)^2 F_n / (4 C A_L omega c) (arguments as :func:`sensed_voltage_v`)."""
    return float(sensed_voltage_v(params, coupling_per_m2, 0.0, 0.0, omega, c, gain_factor))


def normalized_output(kappa, gamma, omega: float, c: float):
    """Eq. 19: V_1 = V_s / V_0 = omega c / sqrt(kappa^2 + omega^2 (gamma + c)^2), dimensionless in
    (0, 1]; kappa N/m^2, gamma and c N s/m^2, omega rad/s."""
    return (omega * c) / np.hypot(kappa, omega * (gamma + c))


def sensitivity_k(kappa, gamma, omega: float, c: float, b_ratio: float):
    """Eq. 20: S_k = -dV_1/dk_e, in m^3/N, for a uniform gel (``b_ratio`` = b A_x / A_L, m).

    Written as the product of three ratios each at most 1 in size, so it cannot overflow:
    S_k = (omega c / h) (kappa / h) (b_ratio / h), h = hypot(kappa, omega (gamma + c)).
    """
    h = np.hypot(kappa, omega * (gamma + c))
    return (omega * c / h) * (kappa / h) * (b_ratio / h)


def sensitivity_c(kappa, gamma, omega: float, c: float, b_ratio: float):
    """Eq. 21: S_c = -dV_1/dc_e, in m^3/(N s), for a uniform gel (``b_ratio`` = b A_x / A_L, m).

    S_c = (omega c / h) (omega (gamma + c) / h) (omega b_ratio / h), h as in eq. 20.
    """
    h = np.hypot(kappa, omega * (gamma + c))
    return (omega * c / h) * (omega * (gamma + c) / h) * (omega * b_ratio / h)
