"""The readout's ring-up inversion: a steady reading inferred from a transient."""

import cmath
import math

import numpy as np
import pytest
from numpy.testing import assert_allclose

from piezotip.sensor import SensorElement
from piezotip.sensor.readout import ring_up_steady
from piezotip.sensor.resonator import envelope_rate, steady_envelope

EL = SensorElement()
OMEGA = EL.natural_angular_frequency(2)
C = EL.params.damping_n_s_per_m2
RHO_A = EL.params.mass_per_length_kg_m
TAU0 = 2 * RHO_A / C


def ring_up(kappa, gamma, t):
    """Closed form a(t) = a_ss (1 - exp(-lambda t)) from rest (independent of the channel code)."""
    lam = complex(envelope_rate(RHO_A, OMEGA, C, kappa, gamma))
    ass = complex(steady_envelope(OMEGA, C, kappa, gamma))
    return ass * (1 - cmath.exp(-lam * t)), ass


@pytest.mark.parametrize("kappa", [0.0, 300.0, 3e3, 3e4, 3e6])
@pytest.mark.parametrize("gamma", [0.0, 0.01, 0.5])
@pytest.mark.parametrize("t", [0.005, 0.05, 0.4, 4.0])
def test_inversion_recovers_the_steady_envelope(kappa, gamma, t):
    a, ass = ring_up(kappa, gamma, t)
    # Follow the physical root as a channel does: from the rate a short while earlier.
    lam_true = complex(envelope_rate(RHO_A, OMEGA, C, kappa, gamma))
    guess = None if kappa < 1e5 else lam_true
    est, gain = ring_up_steady(a, t, TAU0, guess)
    if guess is None and abs((lam_true * t).imag) > math.pi:
        # Past half a beat, untracked: refusing is the documented answer, a wrong root is not.
        assert (math.isnan(est.real) and math.isinf(gain)) or abs(est - ass) <= 1e-9 * abs(ass)
        return
    # Early in an unloaded ring-up the problem is ill-conditioned (gain ~ 1e4): the error
    # allowed scales with the gain times rounding.
    assert abs(est - ass) <= 1e-12 * max(1.0, gain) * max(1.0, abs(ass)) * 100


def test_identity_a_ss_is_one_over_tau0_lambda():
    for kappa, gamma in [(0.0, 0.0), (1e3, 0.1), (1e5, 2.0)]:
        lam = complex(envelope_rate(RHO_A, OMEGA, C, kappa, gamma))
        assert_allclose(complex(steady_envelope(OMEGA, C, kappa, gamma)), 1 / (TAU0 * lam), rtol=1e-13)


def test_unphysical_root_is_refused():
    """Without a guess a strongly detuned spiral can land on a root with gamma < 0: refused, not returned."""
    a, ass = ring_up(3e6, 0.0, 0.4)
    est, gain = ring_up_steady(a, 0.4, TAU0)
    assert (math.isnan(est.real) and math.isinf(gain)) or abs(est - ass) < 1e-9


def test_noise_gain_matches_a_finite_difference():
    kappa, gamma, t = 2e3, 0.05, 0.08
    a, _ = ring_up(kappa, gamma, t)
    est, gain = ring_up_steady(a, t, TAU0)
    h = 1e-7
    worst = max(abs(ring_up_steady(a + h * d, t, TAU0)[0] - est) / h for d in (1, 1j, -1, -1j))
    assert_allclose(worst, gain, rtol=1e-4)


def test_gain_falls_to_one_when_settled():
    a, _ = ring_up(500.0, 0.01, 20 * TAU0)
    _, gain = ring_up_steady(a, 20 * TAU0, TAU0)
    assert_allclose(gain, 1.0, rtol=1e-6)


@pytest.mark.parametrize(("a", "t"), [(0j, 0.1), (2.0 + 0j, 0.1), (0.5 + 0j, 0.0), (-0.1 + 0j, 0.1)])
def test_uninvertible_readings_say_so(a, t):
    est, gain = ring_up_steady(a, t, TAU0)
    assert math.isnan(est.real) and math.isinf(gain)


def test_noisy_readings_scatter_as_the_gain_predicts():
    rng = np.random.default_rng(0)
    kappa, gamma, t, sigma = 5e3, 0.1, 0.1, 1e-3
    a, ass = ring_up(kappa, gamma, t)
    _, gain = ring_up_steady(a, t, TAU0)
    errs = [abs(ring_up_steady(a + sigma * complex(*rng.standard_normal(2)), t, TAU0)[0] - ass) for _ in range(400)]
    rms = math.sqrt(np.mean(np.square(errs)))
    # Complex noise of sigma per component: |error| rms is at most gain * sigma * sqrt(2).
    assert rms <= gain * sigma * math.sqrt(2) * 1.1
    assert rms >= gain * sigma * 0.5
