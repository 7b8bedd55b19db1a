"""The gel model (sensor/gel.py, physics.md section 4) against closed forms, limits and independent numerics.

Every expected number here comes from the test itself: Gent's law, Persson's erf and the Prony
series are re-written below in plain Python/mpmath, roots are found with the test's own brentq
and derivatives with finite differences or mpmath.diff, never from values printed by the code.
"""

import math

import mpmath
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose
from scipy.optimize import brentq

from piezotip.sensor.gel import (
    GelModel,
    GelParams,
    contact_fraction,
    contact_fraction_slope,
    gent_curvature_pa,
    gent_pressure_pa,
    gent_tangent_pa,
    modulus_ratio,
    stretch_from_pressure,
)

EPS = np.finfo(float).eps
GEL = GelParams()
E = GEL.youngs_modulus_pa


# ---------------------------------------------------------------------------------------
# Independent re-implementations (the test's own formulas).
# ---------------------------------------------------------------------------------------


def gent_ref(lam, mu, jm):
    """Gent's uniaxial compressive nominal stress, written out again (mpmath or float)."""
    return mu * jm * (lam**-2 - lam) / (jm - (lam**2 + 2 / lam - 3))


def mu_incompressible(gel: GelParams) -> float:
    # Gent's law is for an incompressible solid: mu = E / 3 (physics.md section 4, gel.py docstring).
    return gel.youngs_modulus_pa / 3.0


def locking_ref(jm: float) -> float:
    """lambda^2 + 2/lambda - 3 = J_m on (0, 1): the left side decreases from +inf to 0 there."""
    return brentq(lambda lam: lam**2 + 2.0 / lam - 3.0 - jm, 1e-9, 1.0 - 1e-15, xtol=1e-300, rtol=4 * EPS, maxiter=500)


def stretch_ref(p: float, gel: GelParams) -> float:
    """The test's own inversion of Gent's law by bracketing root finding."""
    if p == 0:
        return 1.0
    lo = locking_ref(gel.gent_jm)
    mu = mu_incompressible(gel)
    return brentq(lambda lam: gent_ref(lam, mu, gel.gent_jm) - p, lo * (1 + 1e-15), 1.0, xtol=1e-300, rtol=4 * EPS, maxiter=500)


def sls_ratio(freq_hz: float, gel: GelParams) -> tuple[float, float]:
    """(Re, Im) of 1 + sum g_i j w tau_i / (1 + j w tau_i), in real arithmetic."""
    w = 2 * math.pi * freq_hz
    re, im = 1.0, 0.0
    for g, tau in zip(gel.prony_g, gel.prony_tau_s, strict=True):
        x = w * tau
        re += g * x * x / (1 + x * x)
        im += g * x / (1 + x * x)
    return re, im


# ---------------------------------------------------------------------------------------
# Part 2: Gent's law.
# ---------------------------------------------------------------------------------------


@pytest.mark.parametrize("e", [1e-2, 1e-3, 1e-4])
def test_gent_small_strain_limit_is_youngs_modulus_times_strain(e):
    # Expansion at lambda = 1 - e: P = E e (1 + e + O(e^2)) (coefficient of e^2 is 4/3 + 3/J_m < 2).
    # rtol 2 e^2 covers the O(e^2) term; rounding of lambda^-2 - lambda costs ~eps/e << e^2 here.
    p = float(gent_pressure_pa(1.0 - e, GEL))
    assert_allclose(p / (E * e), 1.0 + e, rtol=2 * e**2)


def test_gent_tangent_at_unit_stretch_is_youngs_modulus():
    # -dP/dlambda at lambda = 1 is Young's modulus by definition of E; exact arithmetic, rtol 1e-13.
    assert_allclose(float(gent_tangent_pa(1.0, GEL)), E, rtol=1e-13)
    # and the Winkler stiffness of part 3 is then E / h0.
    assert_allclose(float(gent_pressure_pa(1.0, GEL)), 0.0, atol=0.0)


@pytest.mark.parametrize("nu", [0.45, 0.49])
def test_gent_tangent_at_unit_stretch_is_youngs_modulus_for_any_poisson_ratio(nu):
    # E is the small-strain slope of the uniaxial stress-stretch law by definition, whatever nu is.
    # gel.py's docstrings promise "= E at lambda = 1" and "E/h0 at small strain"; Gent's law is
    # incompressible (mu = E/3).  Using mu = E / (2 (1 + nu)) in it gives 3 E / (2 (1 + nu)) instead.
    gel = GelParams(poisson_ratio=nu)
    assert_allclose(float(gent_tangent_pa(1.0, gel)), gel.youngs_modulus_pa, rtol=1e-12)


def _stretches(gel: GelParams) -> np.ndarray:
    lim = gel.locking_stretch
    return lim + np.array([1e-3, 1e-2, 0.1, 0.3, 0.6, 0.9, 0.999]) * (1 - lim)


def test_gent_tangent_and_curvature_match_central_finite_differences():
    lam = _stretches(GEL)
    d = lam - GEL.locking_stretch
    h = 1e-4 * d  # step scaled to the distance from the lock, where P ~ 1/d
    p_plus, p0, p_minus = (gent_pressure_pa(lam + s, GEL) for s in (h, 0.0, -h))
    fd1 = -(p_plus - p_minus) / (2 * h)
    fd2 = (p_plus - 2 * p0 + p_minus) / h**2
    # truncation (h/d)^2 ~ 1e-8; rounding eps * P / h relative to P' ~ eps * 1e4 (first), eps * 1e8 (second)
    assert_allclose(gent_tangent_pa(lam, GEL), fd1, rtol=1e-6)
    assert_allclose(gent_curvature_pa(lam, GEL), fd2, rtol=1e-5)
    assert np.all(gent_curvature_pa(lam, GEL) > 0)  # convex: it stiffens under load


def test_gent_derivatives_match_high_precision_differentiation():
    for lam in _stretches(GEL):
        with mpmath.workdps(40):
            mu, jm = mpmath.mpf(E) / 3, mpmath.mpf(GEL.gent_jm)
            x = mpmath.mpf(float(lam))
            d1 = mpmath.diff(lambda s, mu=mu, jm=jm: gent_ref(s, mu, jm), x, 1)
            d2 = mpmath.diff(lambda s, mu=mu, jm=jm: gent_ref(s, mu, jm), x, 2)
        # double-precision formulas with O(1) cancellation at most (near the lock g ~ 1e-3 J_m): 1e-10
        assert_allclose(float(gent_tangent_pa(lam, GEL)), -float(d1), rtol=1e-10)
        assert_allclose(float(gent_curvature_pa(lam, GEL)), float(d2), rtol=1e-10)


@pytest.mark.parametrize("jm", [2.0, 20.0, 200.0])
def test_locking_stretch_solves_the_first_invariant_condition(jm):
    gel = GelParams(gent_jm=jm)
    lim = gel.locking_stretch
    assert 0 < lim < 1
    assert_allclose(lim, locking_ref(jm), rtol=1e-12)
    assert_allclose(lim**2 + 2 / lim - 3, jm, rtol=1e-12)


def test_gent_pressure_diverges_like_one_over_distance_to_the_lock():
    lim = GEL.locking_stretch
    mu, jm = mu_incompressible(GEL), GEL.gent_jm
    f = lim**-2 - lim
    # g(lim + d) = (2/lim^2 - 2 lim) d + O(d^2), so P d -> mu J_m f / (2/lim^2 - 2 lim)
    limit = mu * jm * f / (2 / lim**2 - 2 * lim)
    d = np.array([1e-5, 1e-6, 1e-7])
    p = gent_pressure_pa(lim + d, GEL)
    assert np.all(np.diff(p) > 0) and p[-1] > 1e11
    # relative O(d / lim) ~ 1e-4 at d = 1e-5; rounding of g ~ eps J_m / g ~ 1e-8 at d = 1e-7
    for di, pi in zip(d, p, strict=True):
        assert_allclose(pi * di, limit, rtol=2e-3 * di / 1e-5 + 1e-7)


# ---------------------------------------------------------------------------------------
# Inversion of Gent's law.
# ---------------------------------------------------------------------------------------


def test_stretch_from_pressure_inverts_gent_law_up_to_and_beyond_the_proof_load():
    p = np.concatenate([[0.0], np.geomspace(1e-6, 1.3e6, 120), [2e6, 1e7, 1e8]])
    lam = stretch_from_pressure(p, GEL)
    assert lam[0] == 1.0
    assert np.all((lam > GEL.locking_stretch) & (lam <= 1.0))
    # rtol 1e-9 as asked; atol: lambda near 1 is quantized to eps, a pressure step of eps * E
    assert_allclose(gent_pressure_pa(lam, GEL), p, rtol=1e-9, atol=4 * EPS * E)
    assert np.all(np.diff(lam) <= 0), "stretch must not increase with pressure"
    assert np.all(np.diff(lam[p > 1e-3]) < 0)


@pytest.mark.parametrize("p", [1e-3, 1.0, 3e3, 1e5, 1e6, 1.3e6, 1e8])
def test_stretch_from_pressure_matches_an_independent_root_finder(p):
    # both are roots of the same smooth function; the condition number near lambda = 1 is ~ E/P
    assert_allclose(float(stretch_from_pressure(p, GEL)), stretch_ref(p, GEL), rtol=1e-12, atol=8 * EPS)


# ---------------------------------------------------------------------------------------
# Part 1: contact fraction.
# ---------------------------------------------------------------------------------------


def _e_star_h(gel: GelParams) -> float:
    return gel.youngs_modulus_pa / (1 - gel.poisson_ratio**2) * gel.surface_slope_rms


@pytest.mark.parametrize("p", [1e-3, 1e-1, 1.0, 10.0])
def test_contact_fraction_small_load_is_linear(p):
    x = math.sqrt(2) * p / _e_star_h(GEL)
    linear = math.sqrt(8 / math.pi) * p / _e_star_h(GEL)
    # erf(x) = (2/sqrt(pi)) (x - x^3/3 + ...): relative deviation x^2/3; rtol x^2 + rounding 1e-14
    assert_allclose(float(contact_fraction(p, GEL)), linear, rtol=x**2 + 1e-14)


def test_contact_fraction_saturates_at_full_contact_and_stays_in_unit_interval():
    big = np.array([10, 30, 100]) * _e_star_h(GEL)  # erf(14) = 1 to double precision
    assert_allclose(contact_fraction(big, GEL), 1.0, rtol=0, atol=1e-15)
    p = np.concatenate([[0.0], np.geomspace(1e-6, 1e8, 300)])
    phi = contact_fraction(p, GEL)
    assert phi[0] == 0.0
    assert np.all((phi >= 0) & (phi <= 1)) and np.all(np.diff(phi) >= 0)


def test_contact_fraction_slope_matches_finite_difference():
    p = np.geomspace(1e-2, 1.5 * _e_star_h(GEL), 40)
    h = 1e-5 * p
    fd = (contact_fraction(p + h, GEL) - contact_fraction(p - h, GEL)) / (2 * h)
    # truncation (h/scale)^2 <= 1e-9; rounding eps / (phi' h) <= 1e-9 for P <= 1.5 E* h' (beyond it
    # phi' ~ exp(-x^2) is so small that the difference of two numbers near 1 loses the digits)
    assert_allclose(contact_fraction_slope(p, GEL), fd, rtol=1e-6)
    assert_allclose(float(contact_fraction_slope(0.0, GEL)), math.sqrt(8 / math.pi) / _e_star_h(GEL), rtol=1e-14)


# ---------------------------------------------------------------------------------------
# Part 4: viscoelastic modulus ratio.
# ---------------------------------------------------------------------------------------


def test_modulus_ratio_limits():
    total = 1 + sum(GEL.prony_g)
    # f -> 0: R - 1 ~ j w tau sum g, |w tau| < 1e-11 at 1 uHz
    assert_allclose(complex(modulus_ratio(1e-6, GEL)), 1.0, atol=1e-9)
    # f -> inf: R - (1 + sum g) ~ -j sum g / (w tau), < 1e-6 at 1e13 Hz
    assert_allclose(complex(modulus_ratio(1e13, GEL)), total, atol=1e-6)


@pytest.mark.parametrize("f", [1.0, 1e2, 3768.0, 2.36e4, 6.6e4, 1.3e5, 1e6])
def test_modulus_ratio_matches_hand_written_standard_linear_solid_sum(f):
    re, im = sls_ratio(f, GEL)
    r = complex(modulus_ratio(f, GEL))
    assert_allclose(r.real, re, rtol=1e-13)
    assert_allclose(r.imag, im, rtol=1e-13)
    assert r.imag / r.real > 0  # loss tangent positive
    # and the GelModel method at that frequency is the same number
    assert_allclose(complex(GelModel(GEL).modulus_ratio(f)), complex(re, im), rtol=1e-13)


# ---------------------------------------------------------------------------------------
# The foundation (k_e, c_e).
# ---------------------------------------------------------------------------------------

MODEL = GelModel()
FREQS = [3768.0, 23614.0, 66119.0, 129567.0]


def foundation_ref(p: float, f: float, gel: GelParams) -> tuple[float, float]:
    """k_e = phi K Re R, c_e = phi K Im R / w with every part computed independently."""
    phi = math.erf(math.sqrt(2) * p / _e_star_h(gel))
    lam = stretch_ref(p, gel)
    with mpmath.workdps(40):
        mu, jm = mpmath.mpf(gel.youngs_modulus_pa) / 3, mpmath.mpf(gel.gent_jm)
        tangent = -float(mpmath.diff(lambda s: gent_ref(s, mu, jm), mpmath.mpf(lam)))
    k = phi * tangent / gel.thickness_m
    re, im = sls_ratio(f, gel)
    return k * re, k * im / (2 * math.pi * f)


@pytest.mark.parametrize("p", [0.5, 50.0, 5e3, 1e5, 1.3e6])
@pytest.mark.parametrize("f", [3768.0, 1.3e5])
def test_foundation_matches_independent_reimplementation(p, f):
    k_ref, c_ref = foundation_ref(p, f, GEL)
    k_e, c_e = MODEL.foundation(p, f)
    # the tangent is evaluated at a root known to ~1e-15 relative; near 1.3 MPa its condition number
    # (lam T'/T) is ~1e2, so 1e-9 leaves ample room
    assert_allclose(float(k_e), k_ref, rtol=1e-9)
    assert_allclose(float(c_e), c_ref, rtol=1e-9)


def test_foundation_is_zero_unloaded_and_non_negative_and_k_increasing():
    p = np.concatenate([[0.0], np.geomspace(1e-4, 1.3e6, 300)])
    for f in FREQS:
        k_e, c_e = MODEL.foundation(p, f)
        assert k_e[0] == 0.0 and c_e[0] == 0.0
        assert np.all(np.isfinite(k_e)) and np.all(np.isfinite(c_e))
        assert np.all(k_e >= 0) and np.all(c_e >= 0)
        assert np.all(np.diff(k_e) > 0), "k_e must increase with pressure"
        assert np.all(np.diff(c_e) > 0)


@pytest.mark.parametrize("f", [3768.0, 129567.0])
def test_foundation_slope_matches_central_finite_differences(f):
    p = np.geomspace(1e-2, 1.3e6, 60)
    h = 1e-4 * p
    k_p, c_p = MODEL.foundation(p + h, f)
    k_m, c_m = MODEL.foundation(p - h, f)
    dk, dc = MODEL.foundation_slope(p, f)
    # truncation (h/P)^2 times O(1) log-curvature ~ 1e-8 (larger near the lock, ~1e-7); rounding ~1e-12
    assert_allclose(dk, (k_p - k_m) / (2 * h), rtol=1e-5)
    assert_allclose(dc, (c_p - c_m) / (2 * h), rtol=1e-5)
    assert np.all(dk > 0) and np.all(dc > 0)


def test_frequency_independent_model_uses_one_modulus_ratio():
    ref = 3768.0
    flat = GelModel(frequency_dependent=False, reference_freq_hz=ref)
    p = np.geomspace(1.0, 1e6, 20)
    k_ref, c_ref = MODEL.foundation(p, ref)  # the frequency-dependent model at the reference frequency
    for f in [10.0, ref, 2.4e4, 1.3e5, 1e6]:
        k_e, c_e = flat.foundation(p, f)
        assert_allclose(k_e, k_ref, rtol=1e-13)
        # c_e omega = phi K Im R(ref): the same loss modulus at every frequency
        assert_allclose(c_e * 2 * math.pi * f, c_ref * 2 * math.pi * ref, rtol=1e-13)
        dk, dc = flat.foundation_slope(p, f)
        dk_ref, dc_ref = MODEL.foundation_slope(p, ref)
        assert_allclose(dk, dk_ref, rtol=1e-13)
        assert_allclose(dc * f, dc_ref * ref, rtol=1e-13)


def test_state_flags_strain_beyond_valid_range():
    # strain 0.5 <=> lambda 0.5: the pressure there from the test's own Gent formula
    p_half = gent_ref(0.5, mu_incompressible(GEL), GEL.gent_jm)
    st_ = MODEL.state(np.array([0.0, 0.99 * p_half, 1.01 * p_half, 1.3e6]))
    assert list(st_.beyond_valid_strain) == [False, False, True, True]
    assert_allclose(st_.strain, 1 - st_.stretch, rtol=0, atol=0)
    assert_allclose(st_.thickness_m, st_.stretch * GEL.thickness_m, rtol=1e-15)
    assert np.all(np.isfinite(st_.stiffness_n_m3))
    strict = GelModel(GelParams(max_valid_strain=0.2)).state(0.99 * p_half)
    assert bool(strict.beyond_valid_strain)


def test_proof_load_is_handled():
    for f in FREQS:
        k_e, c_e = MODEL.foundation(1.3e6, f)
        dk, dc = MODEL.foundation_slope(1.3e6, f)
        assert all(math.isfinite(float(v)) and float(v) > 0 for v in (k_e, c_e, dk, dc))


# ---------------------------------------------------------------------------------------
# Validation.
# ---------------------------------------------------------------------------------------

_NUMERIC_FIELDS = [
    "thickness_m",
    "youngs_modulus_pa",
    "gent_jm",
    "poisson_ratio",
    "density_kg_m3",
    "surface_slope_rms",
    "max_valid_strain",
    "film_thickness_m",
]


@pytest.mark.parametrize("name", _NUMERIC_FIELDS)
@pytest.mark.parametrize("bad", [0.0, -1.0, math.nan, math.inf])
def test_gel_params_reject_non_positive_or_nan_fields_naming_them(name, bad):
    with pytest.raises(ValueError, match=name):
        GelParams(**{name: bad})


@pytest.mark.parametrize(
    ("kwargs", "name"),
    [
        ({"poisson_ratio": 0.6}, "poisson_ratio"),
        ({"max_valid_strain": 1.0}, "max_valid_strain"),
        ({"prony_g": (0.5, -0.1, 0.5)}, "prony_g"),
        ({"prony_g": (0.5, math.nan, 0.5)}, "prony_g"),
        ({"prony_tau_s": (1e-4, 0.0, 1e-6)}, "prony_tau_s"),
        ({"prony_g": (0.5, 0.5)}, "prony_g"),
    ],
)
def test_gel_params_reject_out_of_range_values(kwargs, name):
    with pytest.raises(ValueError, match=name):
        GelParams(**kwargs)


@pytest.mark.parametrize("bad", [-1.0, math.nan, math.inf, [1.0, -2.0]])
def test_bad_pressure_raises(bad):
    with pytest.raises(ValueError, match="pressure"):
        MODEL.foundation(bad, 3768.0)
    with pytest.raises(ValueError, match="pressure"):
        MODEL.foundation_slope(bad, 3768.0)
    with pytest.raises(ValueError, match="pressure"):
        MODEL.state(bad)
    with pytest.raises(ValueError, match="pressure"):
        stretch_from_pressure(bad, GEL)


@pytest.mark.parametrize("bad", [0.0, -10.0, math.nan, math.inf])
def test_bad_frequency_raises_in_foundation(bad):
    with pytest.raises(ValueError, match="freq"):
        MODEL.foundation(100.0, bad)


@pytest.mark.parametrize("bad", [0.0, -10.0, math.nan])
def test_bad_frequency_raises_in_foundation_slope(bad):
    # foundation() validates freq_hz; foundation_slope() must too (a negative frequency gives a
    # negative dc_e/dP, NaN gives NaN, zero divides by zero).
    with pytest.raises(ValueError, match="freq"):
        MODEL.foundation_slope(100.0, bad)


@pytest.mark.parametrize("bad", [-100.0, math.nan])
def test_bad_reference_frequency_is_rejected(bad):
    # With frequency_dependent=False the reference frequency sets Im R: a negative one makes c_e < 0
    # ("non-negative everywhere" broken), NaN makes every k_e, c_e NaN.  It must be rejected.
    with pytest.raises(ValueError, match="reference_freq_hz"):
        model = GelModel(frequency_dependent=False, reference_freq_hz=bad)
        model.foundation(1e3, 1e4)


# ---------------------------------------------------------------------------------------
# Property tests.
# ---------------------------------------------------------------------------------------


@settings(max_examples=50, deadline=None)
@given(
    p=st.floats(0.0, 2e6),
    f=st.floats(1.0, 1e6),
    e=st.floats(1e3, 1e6),
    jm=st.floats(2.0, 200.0),
    h0=st.floats(1e-4, 2e-2),
    slope=st.floats(0.01, 1.0),
)
def test_foundation_is_finite_and_non_negative_for_any_plausible_gel(p, f, e, jm, h0, slope):
    gel = GelParams(youngs_modulus_pa=e, gent_jm=jm, thickness_m=h0, surface_slope_rms=slope)
    model = GelModel(gel)
    k_e, c_e = model.foundation(p, f)
    dk, dc = model.foundation_slope(p, f)
    for v in (k_e, c_e, dk, dc):
        assert math.isfinite(float(v))
        assert float(v) >= 0
    lam = float(stretch_from_pressure(p, gel))
    assert gel.locking_stretch < lam <= 1.0
    assert_allclose(float(gent_pressure_pa(lam, gel)), p, rtol=1e-9, atol=4 * EPS * e)
