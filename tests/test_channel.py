"""The running sensor channel: envelope dynamics against closed forms, tables, mode switching."""

import math

import numpy as np
import pytest
from numpy.testing import assert_allclose

from piezotip.sensor import Fingertip, SensorElement
from piezotip.sensor.channel import SensorChannel
from piezotip.sensor.resonator import envelope_rate, envelope_step, steady_envelope


@pytest.fixture(scope="module")
def tip():
    return Fingertip(element=SensorElement().with_quality_factor(70))


def test_steady_envelope_magnitude_and_phase_are_eqs_19_and_13(tip):
    el = tip.element
    kappa, gamma = 2.5e3, 0.02
    omega, c = el.natural_angular_frequency(1), el.params.damping_n_s_per_m2
    a = steady_envelope(omega, c, kappa, gamma)
    assert_allclose(abs(a), omega * c / math.hypot(kappa, omega * (gamma + c)), rtol=1e-14)
    # eq. 13's phi is pi/2 unloaded; the envelope's angle is phi - pi/2 measured the other way
    phi = math.atan2(omega * (gamma + c), kappa)
    assert_allclose(-np.angle(a), phi - math.pi / 2, rtol=1e-12)


def test_envelope_ring_up_matches_closed_form_time_constant(tip):
    """Unloaded ring-up from rest: |a(t)| = 1 - exp(-t / tau), tau = 2 rho A / c (= 2 Q / omega)."""
    el = tip.element
    ch = SensorChannel(tip, dynamics="envelope", noise=False, mode=2)
    ch.select_mode(1)  # a switch starts mode 1 from rest
    tau = 2 * el.params.mass_per_length_kg_m / el.params.damping_n_s_per_m2
    assert_allclose(tau, 2 * el.quality_factor(1) / el.natural_angular_frequency(1), rtol=1e-12)
    dt, t = 1e-4, 0.0
    for _ in range(200):
        r = ch.update([0.0], dt)
        t += dt
        assert_allclose(r.v1_true, 1 - math.exp(-t / tau), rtol=1e-9, atol=1e-12)
    assert_allclose(r.tau_s, tau, rtol=1e-12)


def test_envelope_step_is_exact_solution_of_the_linear_ode():
    """The exact update equals a fine RK4 integration of a' = -lambda (a - a_ss)."""
    lam = 200.0 - 900.0j
    a_ss = 0.3 + 0.2j
    a = 0.9 + 0.0j
    exact = envelope_step(a, a_ss, 0.01, lam)
    y, h = a, 0.01 / 20000

    def f(y):
        return -lam * (y - a_ss)

    for _ in range(20000):
        k1 = f(y)
        k2 = f(y + h / 2 * k1)
        k3 = f(y + h / 2 * k2)
        k4 = f(y + h * k3)
        y = y + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    assert_allclose(exact, y, rtol=1e-10)


def test_envelope_rate_real_part_is_inverse_tau_with_gel_damping(tip):
    el = tip.element
    rho_a, c = el.params.mass_per_length_kg_m, el.params.damping_n_s_per_m2
    lam = envelope_rate(rho_a, 1000.0, c, kappa=50.0, gamma=0.1)
    assert_allclose(1 / lam.real, 2 * rho_a / (c + 0.1), rtol=1e-14)
    assert_allclose(lam.imag, -50.0 / (2 * 1000.0 * rho_a), rtol=1e-14)


def test_steady_dynamics_reads_the_fingertip_output(tip):
    ch = SensorChannel(tip, dynamics="steady", noise=False, exact=True)
    for mode in tip.modes:
        ch.select_mode(mode)
        for p in (0.0, 3.0, 300.0, 3e4):
            assert_allclose(ch.update([p], 1e-3).v1_true, tip.output(p, mode), rtol=1e-12)


def test_tables_agree_with_exact_gel_within_stated_error(tip):
    fast = SensorChannel(tip, dynamics="steady", noise=False)
    exact = SensorChannel(tip, dynamics="steady", noise=False, exact=True)
    for mode in tip.modes:
        fast.select_mode(mode)
        exact.select_mode(mode)
        for p in np.logspace(-4, 6.2, 60):
            assert_allclose(fast.update([p], 1e-3).v1_true, exact.update([p], 1e-3).v1_true, rtol=2e-4)


def test_uniform_profile_over_cells_equals_one_cell(tip):
    one = SensorChannel(tip, dynamics="steady", noise=False, exact=True)
    edges = np.linspace(0, tip.element.params.length_m, 8)
    many = SensorChannel(tip, edges_m=edges, dynamics="steady", noise=False, exact=True)
    for mode in tip.modes:
        one.select_mode(mode)
        many.select_mode(mode)
        assert_allclose(many.update(np.full(7, 250.0), 1e-3).v1_true, one.update([250.0], 1e-3).v1_true, rtol=1e-12)


def test_channel_starts_steady_and_settled(tip):
    """The instrument runs before the scene starts: the first reading is the unloaded steady one."""
    r = SensorChannel(tip, dynamics="envelope", noise=False).update([0.0], 1e-3)
    assert r.settled
    assert_allclose(r.v1_true, 1.0, rtol=1e-12)


def test_mode_switch_restarts_ring_up_and_clears_settled(tip):
    ch = SensorChannel(tip, dynamics="envelope", noise=False)
    for _ in range(100):
        r = ch.update([10.0], 1e-3)
    assert r.settled and r.mode == 1
    ch.select_mode(3)
    r = ch.update([10.0], 1e-5)
    assert r.mode == 3 and not r.settled and r.v1_true < 0.1


def test_only_the_active_mode_is_evaluated(tip):
    ch = SensorChannel(tip, dynamics="envelope", noise=False)
    for _ in range(10):
        ch.update([10.0], 1e-3)
    assert ch.evaluations == 10


def test_bad_profiles_raise(tip):
    ch = SensorChannel(tip)
    with pytest.raises(ValueError, match="cells"):
        ch.update([1.0, 2.0], 1e-3)
    with pytest.raises(ValueError, match="pressure_pa"):
        ch.update([math.nan], 1e-3)
    with pytest.raises(ValueError, match="dynamics"):
        SensorChannel(tip, dynamics="bogus")
    with pytest.raises(ValueError, match="mode"):
        ch.select_mode(7)


def test_mode_tables_are_built_once_per_fingertip_mode_and_gel_evaluation():
    from piezotip import scenarios
    from piezotip.cosim.loop import make_fingertip
    from piezotip.sensor.estimator import mode_tables

    tip = make_fingertip(scenarios.get("grasp"))
    table, inverse = mode_tables(tip, 2, exact=False)
    again = mode_tables(make_fingertip(scenarios.get("grasp")), 2, exact=False)
    assert again[0] is table and again[1] is inverse  # an equal fingertip shares them
    other = make_fingertip(scenarios.get("grasp", ["sensor.coverage_mm=(6.0, 7.5)"]))
    assert mode_tables(other, 2, exact=False)[1] is not inverse
    assert mode_tables(other, 2, exact=False)[1].p_max_pa != inverse.p_max_pa
    assert mode_tables(tip, 3, exact=False)[1] is not inverse
    exact_table, exact_inverse = mode_tables(tip, 2, exact=True)
    assert exact_table is None and exact_inverse is not inverse
    # Two channels of one fingertip use the one table, and read the same.
    a, b = SensorChannel(tip, mode=2, noise=False), SensorChannel(tip, mode=2, noise=False)
    assert a.inverse(2) is b.inverse(2)
    assert a.update([500.0], 0.005).v1 == b.update([500.0], 0.005).v1
