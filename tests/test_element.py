"""Tests of ``sensor.element`` against numbers obtained independently of the code.

References: Table I's parameters written out here; EI from the parallel-axis theorem (not the
code's closed form); characteristic roots from mpmath; A_x and A_L from scipy's adaptive
quadrature of Z^2; the paper's eqs. 13, 17, 19, 20, 21 written out literally in A_x, A_L;
derivatives from 5-point finite differences; limits (k_e -> 0, k_e -> infinity).

Physics reference: shared/physics.md sections 1 to 3 (Motoo, Arai, Fukuda 2007).
"""

from __future__ import annotations

import functools
import itertools
import math
from dataclasses import fields

import mpmath as mp
import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose
from scipy import integrate

from piezotip.sensor.element import ElementParams, SensorElement
from piezotip.sensor.modes import Boundary

# Table I, written out here (physics.md section 1).
B_W = 5e-3  # width b, m
L = 7.5e-3  # length, m
T_S = 25e-6  # HALF the substrate thickness, m
T_P = 200e-6  # each PZT layer, m
Y_S, RHO_S = 105e9, 4500.0
Y_P, RHO_P = 62e9, 7650.0
D31 = 210e-12
EPS_P = 2130.0
C_SENSE = 3.54e-9
V_DRIVE = 10.0
C_DAMP = 0.05
EPS0 = 8.8541878128e-12  # CODATA 2018 vacuum permittivity, F/m

CF, SS, CC = Boundary.CLAMPED_FREE, Boundary.SIMPLY_SUPPORTED, Boundary.CLAMPED_CLAMPED
ALL_BOUNDARIES = (CF, SS, CC)
WHOLE = (0.0, L)
TIP = (6.5e-3, 7.5e-3)
COVERAGES = {"whole": WHOLE, "tip": TIP}

# ---------------------------------------------------------------------------------------
# Independent references
# ---------------------------------------------------------------------------------------


def ei_parallel_axis() -> float:
    """EI = sum Y_i (I_own + A d^2): substrate 2 t_s thick at the axis, PZT layers offset t_s + t_p/2."""
    substrate = Y_S * B_W * (2 * T_S) ** 3 / 12
    pzt_layer = Y_P * (B_W * T_P**3 / 12 + B_W * T_P * (T_S + T_P / 2) ** 2)
    return substrate + 2 * pzt_layer


def rho_a_by_layers() -> float:
    """Mass per length: substrate area b 2 t_s, two PZT layers of area b t_p."""
    return RHO_S * B_W * 2 * T_S + 2 * RHO_P * B_W * T_P


@functools.cache
def mp_root(boundary: Boundary, n: int) -> mp.mpf:
    """Root of the textbook frequency equation near its asymptote, 60 digits (see test_modes)."""
    with mp.workdps(60):
        if boundary is SS:
            return mp.pi * n
        sign = 1 if boundary is CF else -1
        guess = (2 * n - 1) * mp.pi / 2 if boundary is CF else (2 * n + 1) * mp.pi / 2
        z = mp.findroot(lambda z: mp.cos(z) * mp.cosh(z) + sign, (guess - 0.4, guess + 0.4), solver="anderson", verify=False)
        assert abs(mp.cos(z) * mp.cosh(z) + sign) / mp.cosh(z) < mp.mpf(10) ** -50
        return z


def omega_closed_form(boundary: Boundary, n: int) -> float:
    """omega_n = (beta_n L)^2 / L^2 sqrt(EI / rho A) with independent root and section properties."""
    return float(mp_root(boundary, n)) ** 2 / L**2 * math.sqrt(ei_parallel_axis() / rho_a_by_layers())


@functools.cache
def a_x_quad(boundary: Boundary, n: int, x1: float, x2: float) -> float:
    """A_x = int_{x1}^{x2} Z_n^2 dx by scipy's adaptive quadrature (not the code's GL rule)."""
    shape = SensorElement(boundary=boundary).mode_shape(n)
    value, err = integrate.quad(lambda x: float(shape(x)) ** 2, x1, x2, limit=200, epsabs=1e-16, epsrel=1e-13)
    assert err < 1e-12 * L
    return value


def ratio_quad(boundary: Boundary, n: int, coverage: tuple[float, float]) -> float:
    """A_x / A_L, both by quadrature."""
    return a_x_quad(boundary, n, *coverage) / a_x_quad(boundary, n, 0.0, L)


def fd5(f, x: np.ndarray, rel_step: float = 1e-3) -> np.ndarray:
    """5-point central difference f'(x), step rel_step * x (x > 0): truncation O(step^4)."""
    h = rel_step * x
    return (f(x - 2 * h) - 8 * f(x - h) + 8 * f(x + h) - f(x + 2 * h)) / (12 * h)


def paper_eq19(k_e, c_e, omega, a_x, a_l, c=C_DAMP, b=B_W):
    """Eq. 19 as printed: V_1 = omega c A_L / sqrt((b k_e A_x)^2 + omega^2 (b c_e A_x + c A_L)^2)."""
    return omega * c * a_l / np.sqrt((b * k_e * a_x) ** 2 + omega**2 * (b * c_e * a_x + c * a_l) ** 2)


def paper_eq20(k_e, c_e, omega, a_x, a_l, c=C_DAMP, b=B_W):
    """Eq. 20 as printed: S_k = omega c (b A_x)^2 k_e A_L / [...]^(3/2)."""
    return omega * c * (b * a_x) ** 2 * k_e * a_l / ((b * k_e * a_x) ** 2 + omega**2 * (b * c_e * a_x + c * a_l) ** 2) ** 1.5


def paper_eq21(k_e, c_e, omega, a_x, a_l, c=C_DAMP, b=B_W):
    """Eq. 21 as printed: S_c = omega^3 b c (b c_e A_x + c A_L) A_x A_L / [...]^(3/2)."""
    den = ((b * k_e * a_x) ** 2 + omega**2 * (b * c_e * a_x + c * a_l) ** 2) ** 1.5
    return omega**3 * b * c * (b * c_e * a_x + c * a_l) * a_x * a_l / den


def mp_cantilever_tip_slope(n: int) -> float:
    """Z_n'(L) of the normalized cantilever mode (int Z^2 = L), from the 60-digit textbook form.

    phi'(L) = beta (sinh z + sin z - sigma (cosh z - cos z)), sigma = (cosh z + cos z)/(sinh z + sin z);
    with this sigma int phi^2 = L already (checked in test_modes), and Z'(0) = 0 at the clamp.
    """
    with mp.workdps(60):
        z = mp_root(CF, n)
        sigma = (mp.cosh(z) + mp.cos(z)) / (mp.sinh(z) + mp.sin(z))
        return float(z / L * (mp.sinh(z) + mp.sin(z) - sigma * (mp.cosh(z) - mp.cos(z))))


@pytest.fixture(scope="module")
def cantilever() -> SensorElement:
    return SensorElement()


# ---------------------------------------------------------------------------------------
# Section properties and frequencies
# ---------------------------------------------------------------------------------------


def test_section_properties_vs_hand_numbers():
    p = ElementParams()
    # By hand: b [105e9 (50e-6)^3/12 + (2/3) 62e9 ((225e-6)^3 - (25e-6)^3)]
    #        = 5e-3 [1.09375e-3 + (2/3) 62e9 * 1.1375e-11] = 5e-3 * 0.47126041666... N m^2
    assert_allclose(p.bending_stiffness_n_m2, 5e-3 * (1.09375e-3 + 0.70525 * 2 / 3), rtol=1e-14)
    assert_allclose(p.bending_stiffness_n_m2, 2.3563020833333e-3, rtol=1e-12)
    # Parallel-axis theorem, an independent derivation of the same EI.
    assert_allclose(p.bending_stiffness_n_m2, ei_parallel_axis(), rtol=1e-13)
    # rho A = 5e-3 (50e-6 * 4500 + 400e-6 * 7650) = 5e-3 * 3.285 kg/m.
    assert_allclose(p.mass_per_length_kg_m, 0.016425, rtol=1e-14)
    assert_allclose(p.mass_per_length_kg_m, rho_a_by_layers(), rtol=1e-14)


def test_plate_capacitance_matches_table_i():
    p = ElementParams()
    by_hand = EPS0 * EPS_P * B_W * L / T_P  # 3.5361 nF
    assert_allclose(p.plate_capacitance_f, by_hand, rtol=1e-12)
    assert_allclose(p.plate_capacitance_f, C_SENSE, rtol=2e-3)  # Table I's 3.54 nF within 0.2 %


@pytest.mark.parametrize("boundary", ALL_BOUNDARIES)
@pytest.mark.parametrize("mode", [1, 2, 3, 4, 10, 30])
def test_natural_frequency_closed_form(boundary, mode):
    element = SensorElement(boundary=boundary)
    # roots and section properties independent: agreement to rounding (a few eps).
    assert_allclose(element.natural_angular_frequency(mode), omega_closed_form(boundary, mode), rtol=1e-13)
    assert_allclose(element.natural_frequency_hz(mode), omega_closed_form(boundary, mode) / (2 * math.pi), rtol=1e-13)


def test_first_cantilever_frequency_by_hand(cantilever):
    # 1.875104^2 / (7.5e-3)^2 * sqrt(2.3563e-3 / 0.016425) / (2 pi): ~3768 Hz. Root to 6 digits.
    f1 = 1.875104**2 / L**2 * math.sqrt(2.3563020833e-3 / 0.016425) / (2 * math.pi)
    assert_allclose(cantilever.natural_frequency_hz(1), f1, rtol=1e-6)
    assert 3760 < cantilever.natural_frequency_hz(1) < 3775


@pytest.mark.parametrize("boundary", ALL_BOUNDARIES)
def test_frequency_ratios(boundary):
    element = SensorElement(boundary=boundary)
    modes = np.arange(2, 31)
    got = np.array([element.natural_frequency_hz(int(n)) / element.natural_frequency_hz(1) for n in modes])
    want = np.array([(float(mp_root(boundary, int(n))) / float(mp_root(boundary, 1))) ** 2 for n in modes])
    assert_allclose(got, want, rtol=1e-13)


def test_quality_factor_and_modal_mass(cantilever):
    for mode in (1, 2, 5):
        omega = omega_closed_form(CF, mode)
        assert_allclose(cantilever.quality_factor(mode), omega * rho_a_by_layers() / C_DAMP, rtol=1e-13)
        assert_allclose(cantilever.modal_mass_kg(mode), rho_a_by_layers() * a_x_quad(CF, mode, 0.0, L), rtol=1e-11)
        tuned = cantilever.with_quality_factor(70.0, mode)
        assert_allclose(tuned.quality_factor(mode), 70.0, rtol=1e-14)
        assert_allclose(tuned.params.damping_n_s_per_m2, omega * rho_a_by_layers() / 70.0, rtol=1e-13)
    for q in (0.0, -5.0, math.nan, math.inf):
        with pytest.raises(ValueError, match="quality factor"):
            cantilever.with_quality_factor(q)


# ---------------------------------------------------------------------------------------
# Construction and validation
# ---------------------------------------------------------------------------------------


@pytest.mark.parametrize("name", ["clamped-free", "simply-supported", "clamped-clamped"])
def test_boundary_names(name):
    element = SensorElement(boundary=name)
    assert element.boundary is Boundary(name)
    assert element.mode_shape(1).boundary is Boundary(name)
    # The first root of each boundary's equation (independent), so the name reached the modes.
    assert_allclose(element.mode_shape(1).beta_l, float(mp_root(Boundary(name), 1)), rtol=1e-14)


def test_default_boundary_is_the_cantilever():
    assert SensorElement().boundary is CF


@pytest.mark.parametrize("name", ["free-free", "cantilever", "", "clamped_free"])
def test_unknown_boundary_raises(name):
    with pytest.raises(ValueError, match=r"unknown boundary .*valid boundaries"):
        SensorElement(boundary=name)


PARAM_NAMES = [f.name for f in fields(ElementParams)]


@pytest.mark.parametrize("name", PARAM_NAMES)
@pytest.mark.parametrize("value", [-1.0, 0.0, -0.0, math.nan, math.inf, -math.inf, -3])
def test_bad_param_raises_naming_field(name, value):
    with pytest.raises(ValueError, match=rf"ElementParams\.{name} must be positive and finite"):
        ElementParams(**{name: value})
    with pytest.raises(ValueError, match=rf"ElementParams\.{name} must be positive and finite"):
        SensorElement(**{name: value})


@pytest.mark.parametrize("value", [np.float32("nan"), np.float32(-1.0), np.int64(0), np.int32(-2)])
def test_bad_numpy_scalar_param_raises(value):
    """Numpy scalars (np.float32, np.int64: not subclasses of float/int) are validated too."""
    with pytest.raises(ValueError, match=r"ElementParams\.width_m must be positive and finite"):
        ElementParams(width_m=value)


def test_overrides():
    element = SensorElement(damping_n_s_per_m2=1e-3, width_m=4e-3)
    assert element.params.damping_n_s_per_m2 == 1e-3
    assert element.params.width_m == 4e-3
    assert element.params.length_m == L
    base = ElementParams(length_m=10e-3)
    assert SensorElement(base, drive_voltage_v=5.0).params == ElementParams(length_m=10e-3, drive_voltage_v=5.0)
    with pytest.raises(ValueError, match=r"unknown element parameter\(s\) \['widht_m'\]; valid: .*'width_m'"):
        SensorElement(widht_m=4e-3)


# ---------------------------------------------------------------------------------------
# Eq. 19: the normalized output
# ---------------------------------------------------------------------------------------


@pytest.mark.parametrize("boundary", ALL_BOUNDARIES)
@pytest.mark.parametrize("coverage", [None, WHOLE, TIP, (1e-3, 3e-3)])
def test_unloaded_output_is_one(boundary, coverage):
    element = SensorElement(boundary=boundary)
    for mode in (1, 2, 7, 30):
        # omega c / hypot(0, omega c) is exactly 1 in floating point.
        assert element.normalized_output(0.0, 0.0, mode, coverage) == 1.0
        assert element.phase(0.0, 0.0, mode, coverage) == math.pi / 2


K_GRID = np.array([0.0, 1.0, 1e3, 1e5, 3e5, 1e6, 1e7, 1e9, 1e12])
C_GRID = np.array([0.0, 1e-3, 0.1, 1.0, 10.0, 1e3])


@pytest.mark.parametrize("boundary", ALL_BOUNDARIES)
@pytest.mark.parametrize("mode", [1, 2, 3, 4, 12])
def test_whole_beam_closed_form(boundary, mode):
    """A_x / A_L = 1: V_1 = omega c / sqrt((b k_e)^2 + omega^2 (b c_e + c)^2)."""
    element = SensorElement(boundary=boundary)
    k, c = np.meshgrid(K_GRID, C_GRID)
    omega = omega_closed_form(boundary, mode)
    want = omega * C_DAMP / np.sqrt((B_W * k) ** 2 + omega**2 * (B_W * c + C_DAMP) ** 2)
    # coverage ratio is 1 to ~1e-15 and omega agrees to ~1e-15: 1e-13 is rounding headroom.
    assert_allclose(element.normalized_output(k, c, mode), want, rtol=1e-13)
    assert_allclose(element.normalized_output(k, c, mode, WHOLE), want, rtol=1e-13)


@pytest.mark.parametrize("boundary", ALL_BOUNDARIES)
def test_whole_beam_damping_response_is_mode_independent(boundary):
    """Paper's finding: with the gel over the whole beam, V_1(c_e) = c / (b c_e + c) in every mode."""
    element = SensorElement(boundary=boundary)
    c_e = np.logspace(-4, 6, 41)
    want = C_DAMP / (B_W * c_e + C_DAMP)
    for mode in range(1, 11):
        assert_allclose(element.normalized_output(0.0, c_e, mode), want, rtol=1e-13)


@pytest.mark.parametrize("boundary", ALL_BOUNDARIES)
@pytest.mark.parametrize("mode", [1, 2, 3, 4])
@pytest.mark.parametrize("coverage_name", ["whole", "tip"])
@pytest.mark.parametrize("c_e", [0.0, 1.0, 100.0])
def test_stiff_gel_limit(boundary, mode, coverage_name, c_e):
    """k_e -> infinity: V_1 -> omega c / (b k_e A_x / A_L).

    k_e is set to m times omega (b c_e A_x/A_L + c) / (b A_x/A_L), so that the exact
    relative gap to the limit is (1 + 1/m^2)^(-1/2) - 1 ~ -1/(2 m^2).
    """
    coverage = COVERAGES[coverage_name]
    element = SensorElement(boundary=boundary)
    omega = omega_closed_form(boundary, mode)
    b_ratio = B_W * ratio_quad(boundary, mode, coverage)
    m = np.array([1e2, 1e3, 1e4, 1e5, 1e6])
    k_e = m * omega * (b_ratio * c_e + C_DAMP) / b_ratio
    limit = omega * C_DAMP / (b_ratio * k_e)
    got = element.normalized_output(k_e, c_e, mode, coverage)
    # quad gives A_x/A_L to ~1e-13; the gap is a ratio of O(1) numbers: atol 1e-11.
    assert_allclose(got / limit - 1.0, (1.0 + m**-2) ** -0.5 - 1.0, rtol=0, atol=1e-11)
    assert_allclose(got[m >= 1e5], limit[m >= 1e5], rtol=1e-9)


@pytest.mark.parametrize("boundary", ALL_BOUNDARIES)
@pytest.mark.parametrize("coverage_name", ["whole", "tip"])
def test_monotone_decreasing(boundary, coverage_name):
    element = SensorElement(boundary=boundary)
    coverage = COVERAGES[coverage_name]
    k_e = np.concatenate([[0.0], np.logspace(-3, 15, 500)])
    c_e = np.concatenate([[0.0], np.logspace(-6, 9, 500)])
    for mode in (1, 2, 3, 4, 15):
        # Non-increasing everywhere; strictly decreasing once V_1 has left 1 (the relative
        # change per grid step is then at least ~1e-10, far above rounding).
        for v in (element.normalized_output(k_e, 0.0, mode, coverage), element.normalized_output(0.0, c_e, mode, coverage)):
            step = np.diff(v)
            assert np.all(step <= 0)
            assert np.all(step[v[:-1] < 1 - 1e-9] < 0)
        # With the other load present, still non-increasing.
        assert np.all(np.diff(element.normalized_output(k_e, 0.5, mode, coverage)) <= 0)
        assert np.all(np.diff(element.normalized_output(3e6, c_e, mode, coverage)) <= 0)


@pytest.mark.parametrize("mode", [1, 2, 3, 4])
def test_tip_coverage_widens_range_and_lowers_sensitivity(cantilever, mode):
    omega = omega_closed_form(CF, mode)
    r_tip = ratio_quad(CF, mode, TIP)
    assert 0 < r_tip < 1
    k_e = np.logspace(2, 15, 300)
    tip, whole = cantilever.normalized_output(k_e, 0.0, mode, TIP), cantilever.normalized_output(k_e, 0.0, mode, WHOLE)
    assert np.all(tip >= whole)
    assert np.all(tip[whole < 1 - 1e-12] > whole[whole < 1 - 1e-12])
    # Half-output stiffness: V_1 = 1/2 at b k_e A_x/A_L = sqrt(3) omega c (c_e = 0).
    k_half_tip = math.sqrt(3) * omega * C_DAMP / (B_W * r_tip)
    k_half_whole = math.sqrt(3) * omega * C_DAMP / B_W
    assert_allclose(cantilever.normalized_output(k_half_tip, 0.0, mode, TIP), 0.5, rtol=1e-11)
    assert_allclose(cantilever.normalized_output(k_half_whole, 0.0, mode, WHOLE), 0.5, rtol=1e-13)
    assert k_half_tip > k_half_whole
    # Small-load sensitivities: S_k -> (b A_x/A_L)^2 k_e / (omega c)^2, S_c -> b (A_x/A_L) / c.
    k_small = 1e-5 * k_half_whole  # next-order terms ~ (kappa / omega c)^2 < 1e-10
    s_tip, s_whole = cantilever.sensitivity_k(k_small, 0.0, mode, TIP), cantilever.sensitivity_k(k_small, 0.0, mode, WHOLE)
    assert_allclose(s_tip / s_whole, r_tip**2, rtol=1e-9)
    assert_allclose(s_whole, B_W**2 * k_small / (omega * C_DAMP) ** 2, rtol=1e-9)
    assert_allclose(cantilever.sensitivity_c(0.0, 0.0, mode, TIP), B_W * r_tip / C_DAMP, rtol=1e-11)
    assert_allclose(cantilever.sensitivity_c(0.0, 0.0, mode, WHOLE), B_W / C_DAMP, rtol=1e-13)


def test_higher_modes_have_wider_range(cantilever):
    """Whole coverage: k_half scales with omega_n, i.e. with (beta_n L)^2 (paper: high modes have a wide range)."""
    k_half = [math.sqrt(3) * cantilever.natural_angular_frequency(n) * C_DAMP / B_W for n in (1, 2, 3, 4)]
    for n, k in zip((1, 2, 3, 4), k_half, strict=True):
        assert_allclose(cantilever.normalized_output(k, 0.0, n), 0.5, rtol=1e-13)
    assert_allclose(np.array(k_half) / k_half[0], [(float(mp_root(CF, n)) / float(mp_root(CF, 1))) ** 2 for n in (1, 2, 3, 4)], rtol=1e-13)


# ---------------------------------------------------------------------------------------
# Eqs. 20, 21: sensitivities
# ---------------------------------------------------------------------------------------

R_K = np.array([0.03, 0.1, 0.3, 1.0, 3.0, 10.0, 100.0])  # kappa / (omega (gamma + c))
Q_C = np.array([0.0, 0.1, 1.0, 10.0, 100.0])  # gamma / c


@pytest.mark.parametrize("boundary", [CF, SS])
@pytest.mark.parametrize("mode", [1, 2, 3, 4])
@pytest.mark.parametrize("coverage_name", ["whole", "tip"])
def test_sensitivities_vs_finite_differences(boundary, mode, coverage_name):
    """S_k = -dV_1/dk_e and S_c = -dV_1/dc_e against 5-point differences of normalized_output.

    The grid is placed on each mode's own scale (k_e relative to omega (b c_e A_x/A_L + c) /
    (b A_x/A_L)), so every point has a derivative that differences resolve: with a relative
    step 1e-3 the truncation error is ~1e-12 and the rounding error below ~1e-8 relative.
    """
    element = SensorElement(boundary=boundary)
    coverage = COVERAGES[coverage_name]
    omega = omega_closed_form(boundary, mode)
    b_ratio = B_W * ratio_quad(boundary, mode, coverage)
    r, q = np.meshgrid(R_K, Q_C)
    c_e = q * C_DAMP / b_ratio
    k_e = r * omega * (b_ratio * c_e + C_DAMP) / b_ratio

    fd_k = -fd5(lambda k: element.normalized_output(k, c_e, mode, coverage), k_e)
    assert_allclose(element.sensitivity_k(k_e, c_e, mode, coverage), fd_k, rtol=1e-6)

    q_pos = np.where(q > 0, q, 0.01)  # c_e > 0 for a central difference
    c_pos = q_pos * C_DAMP / b_ratio
    k_c = np.where(r > 10, 0.0, r * omega * C_DAMP / b_ratio)  # include the elastic-free case
    fd_c = -fd5(lambda c: element.normalized_output(k_c, c, mode, coverage), c_pos)
    assert_allclose(element.sensitivity_c(k_c, c_pos, mode, coverage), fd_c, rtol=1e-6)


@pytest.mark.parametrize("boundary", ALL_BOUNDARIES)
@pytest.mark.parametrize("mode", [1, 2, 3, 4])
@pytest.mark.parametrize("coverage", [WHOLE, TIP, (1e-3, 3e-3), (2e-3, 2.5e-3)])
def test_equations_as_printed(boundary, mode, coverage):
    """Eqs. 13, 19, 20, 21 written out literally in A_x and A_L (both by scipy quad)."""
    element = SensorElement(boundary=boundary)
    omega = omega_closed_form(boundary, mode)
    a_x, a_l = a_x_quad(boundary, mode, *coverage), a_x_quad(boundary, mode, 0.0, L)
    k, c = np.meshgrid(np.array([0.0, 1e2, 1e4, 1e6, 1e8, 1e10, 1e13]), np.array([0.0, 1e-2, 1.0, 1e2, 1e4]))
    # quad gives A_x to ~1e-13 relative (observed agreement ~2e-14); each formula's sensitivity to A_x is at most ~3: 1e-12.
    assert_allclose(element.normalized_output(k, c, mode, coverage), paper_eq19(k, c, omega, a_x, a_l), rtol=1e-12)
    assert_allclose(element.sensitivity_k(k, c, mode, coverage), paper_eq20(k, c, omega, a_x, a_l), rtol=1e-12)
    assert_allclose(element.sensitivity_c(k, c, mode, coverage), paper_eq21(k, c, omega, a_x, a_l), rtol=1e-12)
    # Eq. 13: tan(phi) = omega (b c_e A_x + c A_L) / (b k_e A_x).
    phi = element.phase(k, c, mode, coverage)
    with np.errstate(divide="ignore"):
        tan_phi = omega * (B_W * c * a_x + C_DAMP * a_l) / (B_W * k * a_x)
    assert_allclose(phi, np.arctan(tan_phi), rtol=1e-12)
    assert np.all(phi[k == 0] == math.pi / 2)
    assert np.all((phi > 0) & (phi <= math.pi / 2))


def test_phase_tends_to_zero_for_stiff_gel(cantilever):
    phi = cantilever.phase(np.logspace(6, 15, 10), 0.0, 1)
    assert np.all(np.diff(phi) < 0)
    # atan(x) -> x: phi ~ omega c / (b k_e) at k_e = 1e15.
    assert_allclose(phi[-1], omega_closed_form(CF, 1) * C_DAMP / (B_W * 1e15), rtol=1e-12)


# ---------------------------------------------------------------------------------------
# Eq. 17: the absolute output voltage
# ---------------------------------------------------------------------------------------


def v0_closed_form(omega: float, slope_difference: float) -> float:
    """Eq. 17 with k_e = c_e = 0 and A_L = L, coupling [int Z'' dx][Z'(L) - Z'(0)] = slope_diff^2."""
    a_l = L
    numerator = B_W**2 * Y_P**2 * D31**2 * V_DRIVE * (2 * T_S + T_P) ** 2 * slope_difference * slope_difference
    return numerator / (4 * C_SENSE * math.sqrt(omega**2 * (C_DAMP * a_l) ** 2))


@pytest.mark.parametrize("mode", [1, 2, 3, 4])
def test_unloaded_voltage_cantilever(cantilever, mode):
    slope = mp_cantilever_tip_slope(mode)  # Z'(0) = 0 at the clamp
    assert_allclose(cantilever.coupling_factor_per_m2(mode), slope**2, rtol=1e-12)
    assert_allclose(cantilever.unloaded_voltage(mode), v0_closed_form(omega_closed_form(CF, mode), slope), rtol=1e-12)
    # The coupling uses int_0^L Z'' dx = Z'(L) - Z'(0): check with a quadrature of the curvature.
    shape = cantilever.mode_shape(mode)
    curvature_integral = integrate.quad(lambda x: float(shape.derivative(x, 2)), 0.0, L, limit=200, epsrel=1e-12)[0]
    assert_allclose(cantilever.coupling_factor_per_m2(mode), curvature_integral**2, rtol=1e-9)


@pytest.mark.parametrize("mode", [1, 2, 3, 4, 5])
def test_unloaded_voltage_simply_supported(mode):
    element = SensorElement(boundary="simply-supported")
    # Z = sqrt(2) sin(n pi x / L): Z'(L) - Z'(0) = sqrt(2) n pi / L (cos(n pi) - 1), up to sign.
    slope_difference = math.sqrt(2) * mode * math.pi / L * (math.cos(mode * math.pi) - 1)
    want = v0_closed_form(omega_closed_form(SS, mode), slope_difference)
    if mode % 2:
        assert_allclose(element.coupling_factor_per_m2(mode), 8 * mode**2 * math.pi**2 / L**2, rtol=1e-12)
        assert_allclose(element.unloaded_voltage(mode), want, rtol=1e-12)
    else:  # even modes are not excited by a full-length electrode; compare with mode 1's ~1e4 V
        assert want == 0.0
        assert_allclose(element.unloaded_voltage(mode), 0.0, atol=1e-18)


def test_clamped_clamped_gives_zero_volts():
    element = SensorElement(boundary="clamped-clamped")
    for mode in range(1, 8):
        # Z'(0) = Z'(L) = 0: exactly zero; 1e-18 V allows rounding (cantilever V_0 is ~3e3 V).
        assert_allclose(element.output_voltage(np.array([0.0, 1e6]), 1.0, mode), 0.0, atol=1e-18)
        assert_allclose(element.coupling_factor_per_m2(mode), 0.0, atol=1e-18)


@pytest.mark.parametrize("boundary", [CF, SS])
@pytest.mark.parametrize("mode", [1, 3])
@pytest.mark.parametrize("coverage", [None, TIP])
def test_output_voltage_is_v0_times_v1(boundary, mode, coverage):
    element = SensorElement(boundary=boundary)
    k, c = np.meshgrid(K_GRID, C_GRID)
    v0 = element.unloaded_voltage(mode)
    assert v0 > 0
    assert_allclose(element.output_voltage(k, c, mode, coverage), v0 * element.normalized_output(k, c, mode, coverage), rtol=1e-14)
    assert_allclose(element.output_voltage(0.0, 0.0, mode, coverage), v0, rtol=1e-15)


def test_output_voltage_scales_with_parameters():
    """Eq. 17's dependence on the drive, C, d31 and the damping (all else fixed)."""
    base = SensorElement()
    v0 = base.unloaded_voltage(1)
    assert_allclose(SensorElement(drive_voltage_v=20.0).unloaded_voltage(1), 2 * v0, rtol=1e-14)
    assert_allclose(SensorElement(capacitance_f=2 * C_SENSE).unloaded_voltage(1), v0 / 2, rtol=1e-14)
    assert_allclose(SensorElement(d31_m_per_v=2 * D31).unloaded_voltage(1), 4 * v0, rtol=1e-14)
    assert_allclose(SensorElement(damping_n_s_per_m2=2 * C_DAMP).unloaded_voltage(1), v0 / 2, rtol=1e-14)


# ---------------------------------------------------------------------------------------
# Distributed loads
# ---------------------------------------------------------------------------------------


@pytest.mark.parametrize("boundary", ALL_BOUNDARIES)
@pytest.mark.parametrize("mode", [1, 2, 4, 20])
@pytest.mark.parametrize("span", [WHOLE, TIP, (1e-3, 3e-3), (0.3e-3, 5.9e-3)])
def test_uniform_profile_equals_uniform_coverage(boundary, mode, span):
    element = SensorElement(boundary=boundary)
    rng = np.random.default_rng(mode)
    inner = np.sort(rng.uniform(*span, size=9))
    for edges in (np.linspace(*span, 13), np.concatenate([[span[0]], inner, [span[1]]])):
        n_cells = edges.size - 1
        k_e, c_e = np.array([[0.0], [3e5], [1e9]]), np.array([[0.0], [2.0], [50.0]])
        kappa, gamma = element.modal_load_profile(np.broadcast_to(k_e, (3, n_cells)), np.broadcast_to(c_e, (3, n_cells)), mode, edges)
        want_k, want_g = element.modal_load(k_e[:, 0], c_e[:, 0], mode, span)
        assert_allclose(kappa, want_k, rtol=1e-12)
        assert_allclose(gamma, want_g, rtol=1e-12)
        v1_uniform = element.normalized_output(k_e[:, 0], c_e[:, 0], mode, span)
        assert_allclose(element.normalized_output_from_modal(kappa, gamma, mode), v1_uniform, rtol=1e-12)
        assert_allclose(np.sum(element.cell_ratios(mode, edges)), element.coverage_ratio(mode, span), rtol=1e-12)


@pytest.mark.parametrize("boundary", [CF, CC])
@pytest.mark.parametrize("mode", [1, 3, 12])
def test_cell_loads_vs_quadrature(boundary, mode):
    element = SensorElement(boundary=boundary)
    edges = np.linspace(0.0, L, 16)
    n_cells = edges.size - 1
    cells = np.array([a_x_quad(boundary, mode, a, b) for a, b in itertools.pairwise(edges)])
    want_ratios = cells / a_x_quad(boundary, mode, 0.0, L)
    assert_allclose(element.cell_ratios(mode, edges), want_ratios, rtol=1e-10, atol=1e-15)
    # A load on a single cell.
    for j in (0, 7, n_cells - 1):
        k_cells = np.zeros(n_cells)
        k_cells[j] = 4e6
        c_cells = np.zeros(n_cells)
        c_cells[j] = 3.0
        kappa, gamma = element.modal_load_profile(k_cells, c_cells, mode, edges)
        assert_allclose(kappa, B_W * 4e6 * want_ratios[j], rtol=1e-10, atol=1e-12)
        assert_allclose(gamma, B_W * 3.0 * want_ratios[j], rtol=1e-10, atol=1e-18)
    # A varying profile: b sum_i k_i A_i / A_L.
    k_cells = np.random.default_rng(3).uniform(0.0, 1e7, n_cells)
    assert_allclose(element.modal_load_profile(k_cells, 0 * k_cells, mode, edges)[0], B_W * np.sum(k_cells * want_ratios), rtol=1e-10)


def test_profile_bad_inputs(cantilever):
    edges = np.linspace(0.0, L, 5)
    with pytest.raises(ValueError, match="need 4 values"):
        cantilever.modal_load_profile(np.ones(3), np.ones(4), 1, edges)
    with pytest.raises(ValueError, match="strictly increasing"):
        cantilever.cell_ratios(1, edges[::-1])
    with pytest.raises(ValueError, match="strictly increasing"):
        cantilever.cell_ratios(1, np.array([0.0]))
    with pytest.raises(ValueError, match="coverage must satisfy"):
        cantilever.cell_ratios(1, np.linspace(0.0, 2 * L, 5))
    with pytest.raises(ValueError, match="k_e must be finite and non-negative"):
        cantilever.modal_load_profile(np.array([1.0, -1.0, 0.0, 0.0]), np.ones(4), 1, edges)


# ---------------------------------------------------------------------------------------
# Extremes and bad inputs
# ---------------------------------------------------------------------------------------

EXTREME_K = np.array([0.0, 1e-12, 1.0, 1e3, 1e6, 1e9, 1e12, 1e15])
EXTREME_C = np.array([0.0, 1e-12, 1e-3, 1.0, 1e3, 1e6, 1e9])


@pytest.mark.filterwarnings("error")
@pytest.mark.parametrize("boundary", ALL_BOUNDARIES)
@pytest.mark.parametrize("damping", [C_DAMP, 1e-12])
def test_extremes_are_finite_and_bounded(boundary, damping):
    element = SensorElement(ElementParams(damping_n_s_per_m2=damping), boundary=boundary)
    k, c = np.meshgrid(EXTREME_K, EXTREME_C)
    with np.errstate(all="raise"):
        for mode in range(1, 31):
            for coverage in (None, TIP, (1e-3, 3e-3)):
                v1 = element.normalized_output(k, c, mode, coverage)
                s_k = element.sensitivity_k(k, c, mode, coverage)
                s_c = element.sensitivity_c(k, c, mode, coverage)
                phi = element.phase(k, c, mode, coverage)
                volts = element.output_voltage(k, c, mode, coverage)
                for a in (v1, s_k, s_c, phi, volts):
                    assert np.all(np.isfinite(a))
                assert np.all((v1 >= 0) & (v1 <= 1))
                assert np.all(s_k >= 0) and np.all(s_c >= 0) and np.all(volts >= 0)
                assert np.all((phi >= 0) & (phi <= math.pi / 2))
                # Unloaded corner exactly 1; the heaviest corner strictly below it.
                assert v1[0, 0] == 1.0
                assert v1[-1, -1] < 1.0


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf, -1.0, -1e-300, np.array([1.0, math.nan])])
@pytest.mark.parametrize("method", ["normalized_output", "phase", "sensitivity_k", "sensitivity_c", "output_voltage", "modal_load"])
def test_bad_load_raises(cantilever, bad, method):
    fn = getattr(cantilever, method)
    with pytest.raises(ValueError, match="k_e must be finite and non-negative"):
        fn(bad, 1.0, 1)
    with pytest.raises(ValueError, match="c_e must be finite and non-negative"):
        fn(1.0, bad, 1)


@pytest.mark.parametrize(
    "coverage",
    [(3e-3, 2e-3), (2e-3, 2e-3), (-1e-4, 2e-3), (0.0, L + 1e-6), (-1e-3, -0.5e-3), (math.nan, 2e-3), (1e-3, math.nan),
     (0.0, math.inf), (1.0, 2.0)],
)  # fmt: skip
def test_bad_coverage_raises(cantilever, coverage):
    with pytest.raises(ValueError, match="coverage must satisfy"):
        cantilever.normalized_output(1e5, 1.0, 1, coverage)
    with pytest.raises(ValueError, match="coverage must satisfy"):
        cantilever.coverage_ratio(1, coverage)


@pytest.mark.parametrize("coverage", [(1e-3,), (1e-3, 2e-3, 3e-3), "ab", 5.0, ("a", "b")])
def test_malformed_coverage_raises(cantilever, coverage):
    with pytest.raises(ValueError, match="coverage must be a pair"):
        cantilever.normalized_output(1e5, 1.0, 1, coverage)


def test_bad_mode_raises(cantilever):
    for mode in (0, -1, 1.5, True, 201):
        with pytest.raises(ValueError, match="mode must be"):
            cantilever.normalized_output(1.0, 1.0, mode)
        with pytest.raises(ValueError, match="mode must be"):
            cantilever.natural_frequency_hz(mode)


@pytest.mark.parametrize("boundary", ALL_BOUNDARIES)
@pytest.mark.parametrize("damping", [C_DAMP, 1e-12])
def test_narrow_coverage_keeps_outputs_physical(boundary, damping):
    """A_x / A_L >= 0 for any x1 < x2, so V_1 <= 1 and S_c >= 0 even for a sliver of gel.

    A sliver a few ulps wide must give A_x ~ 0, not a negative number (see
    test_modes.test_square_integral_nonnegative_on_narrow_intervals): with A_x < 0 the gel
    "removes" damping, V_1 exceeds 1 and S_c turns negative.
    """
    element = SensorElement(ElementParams(damping_n_s_per_m2=damping), boundary=boundary)
    rng = np.random.default_rng(11)
    worst_ratio, worst_v1, worst_sc = math.inf, -math.inf, math.inf
    for x1 in rng.uniform(0.0, L - 1e-9, 400):
        x2 = float(np.nextafter(np.nextafter(x1, 1.0), 1.0))
        for mode in (1, 2, 3):
            worst_ratio = min(worst_ratio, element.coverage_ratio(mode, (x1, x2)))
            worst_v1 = max(worst_v1, float(element.normalized_output(0.0, 1e9, mode, (x1, x2))))
            worst_sc = min(worst_sc, float(element.sensitivity_c(0.0, 1e9, mode, (x1, x2))))
    assert worst_ratio >= 0.0, f"coverage_ratio = {worst_ratio!r}"
    assert worst_v1 <= 1.0, f"V_1 = {worst_v1!r}"
    assert worst_sc >= 0.0, f"S_c = {worst_sc!r}"


# ---------------------------------------------------------------------------------------
# Property test
# ---------------------------------------------------------------------------------------


@st.composite
def coverages(draw):
    kind = draw(st.sampled_from(["default", "whole", "tip", "any", "narrow"]))
    if kind == "default":
        return None
    if kind == "whole":
        return WHOLE
    if kind == "tip":
        return TIP
    x1 = draw(st.floats(0.0, L, exclude_max=True))
    if kind == "any":
        x2 = draw(st.floats(x1, L))
    else:  # a sliver a few ulps wide
        x2 = x1
        for _ in range(draw(st.integers(1, 4))):
            x2 = float(np.nextafter(x2, 1.0))
    assume(x1 < x2 <= L)
    return (x1, x2)


_ELEMENTS = {(b, d): SensorElement(ElementParams(damping_n_s_per_m2=d), boundary=b) for b in ALL_BOUNDARIES for d in (C_DAMP, 1e-12)}


@settings(max_examples=400, deadline=None, derandomize=True)
@given(
    k_e=st.floats(0.0, 1e15),
    c_e=st.floats(0.0, 1e9),
    mode=st.integers(1, 30),
    boundary=st.sampled_from(ALL_BOUNDARIES),
    damping=st.sampled_from([C_DAMP, 1e-12]),
    coverage=coverages(),
)
def test_property_outputs_bounded(k_e, c_e, mode, boundary, damping, coverage):
    element = _ELEMENTS[(boundary, damping)]
    v1 = float(element.normalized_output(k_e, c_e, mode, coverage))
    s_k = float(element.sensitivity_k(k_e, c_e, mode, coverage))
    s_c = float(element.sensitivity_c(k_e, c_e, mode, coverage))
    phi = float(element.phase(k_e, c_e, mode, coverage))
    assert math.isfinite(v1) and 0.0 <= v1 <= 1.0
    assert math.isfinite(s_k) and s_k >= 0.0
    assert math.isfinite(s_c) and s_c >= 0.0
    assert 0.0 <= phi <= math.pi / 2
