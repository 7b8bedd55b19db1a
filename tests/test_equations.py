"""The paper's equations as functions (sensor/equations.py), the lookup helper and the one inverse.

Eqs. 13 and 17 to 21 are checked against the paper's printed forms in tests/test_element.py;
here: eq. 10 against the modal equation integrated in time (scipy's solve_ivp, independent of
the closed form) and written out in 50-digit mpmath, its relations to eqs. 13 and 19, eqs. 17
to 19 against each other; the table lookup against ``np.interp`` bit for bit; the fingertip's
exact inverse against the channel's tabulated one (the same estimator).
"""

from __future__ import annotations

import math

import mpmath as mp
import numpy as np
import pytest
from numpy.testing import assert_allclose
from scipy.integrate import solve_ivp

from piezotip.sensor import ElementParams, Fingertip, SensorElement
from piezotip.sensor.equations import (
    normalized_output,
    normalized_response,
    phase_rad,
    sensed_voltage_v,
    unloaded_voltage_v,
)
from piezotip.sensor.estimator import mode_tables
from piezotip.sensor.lookup import interp, interp_pair

LOADS = [(0.0, 0.0), (0.3, 0.0), (0.0, 0.1), (0.3, 0.1), (2.0, 0.5), (1e4, 1e-3)]


@pytest.mark.parametrize(("kappa", "gamma"), LOADS)
def test_eq10_is_the_steady_state_of_the_modal_equation(kappa, gamma):
    """rho A q'' + (c + gamma) q' + (rho A omega^2 + kappa) q = F cos(omega t), integrated until
    the transient is gone (e^-30) and demodulated over whole cycles, over the same unloaded."""
    rho_a, omega, c, force = 1.0, 1.0, 0.2, 1.0  # a low Q (5): the transient dies in a few cycles

    def amplitude(k: float, g: float) -> complex:
        rate = (c + g) / (2 * rho_a)
        periods = math.ceil(30.0 / rate / (2 * math.pi / omega))
        t_end = periods * 2 * math.pi / omega
        t = np.linspace(t_end - 2 * math.pi / omega, t_end, 2001)

        def rhs(_t, y):
            return [y[1], (force * math.cos(omega * _t) - (c + g) * y[1] - (rho_a * omega**2 + k) * y[0]) / rho_a]

        q = solve_ivp(rhs, (0.0, t_end), [0.0, 0.0], t_eval=t, rtol=1e-11, atol=1e-13, method="DOP853").y[0]
        # One whole cycle of q = Re(a e^(j omega t)): a = (2 / T) int q e^(-j omega t) dt (trapezoid, periodic: exact)
        w = q * np.exp(-1j * omega * t)
        return complex(2.0 * np.sum(0.5 * (w[1:] + w[:-1])) / (t.size - 1))

    measured = amplitude(kappa, gamma) / amplitude(0.0, 0.0)
    assert_allclose(complex(normalized_response(kappa, gamma, omega, c)), measured, rtol=1e-7, atol=1e-9)


def test_eq10_as_printed_in_50_digits():
    """j omega c / (kappa + j omega (gamma + c)) in mpmath against the code's form."""
    rng = np.random.default_rng(3)
    for _ in range(500):
        kappa, gamma = 10 ** rng.uniform(-3, 9) * rng.integers(0, 2), 10 ** rng.uniform(-6, 3) * rng.integers(0, 2)
        omega, c = 10 ** rng.uniform(3, 6), 10 ** rng.uniform(-4, 0)
        with mp.workdps(50):
            want = 1j * mp.mpf(omega) * c / (kappa + 1j * mp.mpf(omega) * (mp.mpf(gamma) + c))
        got = normalized_response(kappa, gamma, omega, c)
        assert abs(complex(want) - got) <= 2e-15 * abs(complex(want))  # a few roundings of a complex division


def test_eq10_gives_eq19_and_eq13():
    kappa = np.array([0.0, 1.0, 1e3, 1e6, 1e9])
    gamma = np.array([0.0, 1e-3, 0.1, 1.0, 10.0])
    omega, c = 2.4e5, 0.05
    h = normalized_response(kappa, gamma, omega, c)
    assert_allclose(np.abs(h), normalized_output(kappa, gamma, omega, c), rtol=1e-15)
    # The angle is the change of eq. 13's phase from the unloaded pi/2.
    assert_allclose(np.angle(h), math.pi / 2 - phase_rad(kappa, gamma, omega, c), rtol=0, atol=1e-15)
    assert h[0] == 1.0  # unloaded: exactly 1


def test_eq17_over_eq18_is_eq19():
    params, coupling, omega, c = ElementParams(), 1.4e8, 2.4e5, 0.05
    kappa, gamma = np.geomspace(1e-2, 1e9, 12), np.geomspace(1e-5, 10, 12)
    v0 = unloaded_voltage_v(params, coupling, omega, c)
    assert v0 == float(sensed_voltage_v(params, coupling, 0.0, 0.0, omega, c))
    assert_allclose(sensed_voltage_v(params, coupling, kappa, gamma, omega, c) / v0, normalized_output(kappa, gamma, omega, c), rtol=1e-14)
    # eq. 18 by hand: b^2 Y_p^2 d31^2 V (2 t_s + t_p)^2 F / (4 C L omega c)
    by_hand = (5e-3 * 62e9 * 210e-12) ** 2 * 10.0 * (2 * 25e-6 + 200e-6) ** 2 * coupling / (4 * 3.54e-9 * 7.5e-3 * omega * c)
    assert_allclose(v0, by_hand, rtol=1e-14)
    assert unloaded_voltage_v(params, coupling, omega, c, gain_factor=1.5) == pytest.approx(1.5 * v0, rel=1e-15)


def test_the_element_uses_the_equations():
    element = SensorElement()
    omega, c = element.natural_angular_frequency(2), element.params.damping_n_s_per_m2
    assert element.unloaded_voltage(2) == unloaded_voltage_v(element.params, element.coupling_factor_per_m2(2), omega, c)


def test_interp_pair_is_np_interp_of_both_columns_bit_for_bit():
    rng = np.random.default_rng(5)
    xp = np.sort(rng.uniform(-3, 5, 301))
    fa, fb = rng.normal(size=xp.size), rng.normal(size=xp.size)
    xs = np.concatenate([rng.uniform(-4, 6, 5000), xp, np.nextafter(xp, np.inf), np.nextafter(xp, -np.inf), [-np.inf, np.inf]])
    lists = xp.tolist(), fa.tolist(), fb.tolist()
    pairs = np.array([interp_pair(x, *lists) for x in xs.tolist()])
    assert np.array_equal(pairs[:, 0], np.interp(xs, xp, fa))
    assert np.array_equal(pairs[:, 1], np.interp(xs, xp, fb))
    assert np.array_equal(pairs[:, 0], [interp(x, lists[0], lists[1]) for x in xs.tolist()])
    assert all(math.isnan(v) for v in interp_pair(math.nan, *lists))


@pytest.mark.parametrize("mode", [1, 2, 3, 4])
def test_fingertip_estimate_is_the_channel_inverse_polished(mode):
    """One estimator: Fingertip.estimate (exact) and the tabulated inverse agree to the table's accuracy."""
    tip = Fingertip()
    inverse = mode_tables(tip, mode, exact=True)[1]
    p = np.geomspace(1e-2 * inverse.p_min_pa, 3 * inverse.p_max_pa, 200)
    v = tip.output(p, mode)
    exact = tip.estimate(v, mode)
    fast = [inverse(x) for x in v.tolist()]
    statuses = exact.status.tolist()
    near_edge = (np.abs(p / inverse.p_min_pa - 1) < 1e-3) | (np.abs(p / inverse.p_max_pa - 1) < 1e-3)
    assert [s for s, n in zip(statuses, near_edge, strict=True) if not n] == [
        f.status for f, n in zip(fast, near_edge, strict=True) if not n
    ]
    ok = exact.status == "ok"
    assert ok.sum() > 50
    assert_allclose(exact.pressure_pa[ok], p[ok], rtol=1e-6)
    assert_allclose([f.pressure_pa for f, o in zip(fast, ok, strict=True) if o], p[ok], rtol=1e-3)
