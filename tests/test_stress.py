"""Static bending and the PZT's strength (sensor/stress.py, physics.md section 7) against beam-theory closed forms."""

import math

import numpy as np
import pytest
from numpy.testing import assert_allclose

from piezotip.sensor import Fingertip, Mounting, SensorElement
from piezotip.sensor.modes import Boundary
from piezotip.sensor.stress import _GRID, stress_report, unit_load_response

# Table I, restated (physics.md section 1)
B, L, TS, TP, YS, YP = 5e-3, 7.5e-3, 25e-6, 200e-6, 105e9, 62e9
EI = B * (YS * (2 * TS) ** 3 / 12 + (2 / 3) * YP * ((TS + TP) ** 3 - TS**3))
Y_OUTER = TS + TP  # outer fibre of a PZT layer from the neutral axis
DX = L / (_GRID - 1)

# (max |M|, max |w|) for a unit (1 N/m) load over the whole span, textbook closed forms
CLOSED_FORMS = {
    Boundary.CLAMPED_FREE: (L**2 / 2, L**4 / (8 * EI)),
    Boundary.SIMPLY_SUPPORTED: (L**2 / 8, 5 * L**4 / (384 * EI)),
    Boundary.CLAMPED_CLAMPED: (L**2 / 12, L**4 / (384 * EI)),
}


@pytest.mark.parametrize("boundary", list(CLOSED_FORMS))
def test_full_length_uniform_load_matches_closed_forms(boundary):
    _, moment, deflection = unit_load_response(L, boundary, (0.0, L), EI)
    m_max, w_max = CLOSED_FORMS[boundary]
    # trapezoidal integration of polynomials on 2000 cells: error O(dx^2 / L^2) ~ 1e-7
    assert_allclose(np.max(np.abs(moment)), m_max, rtol=1e-4)
    assert_allclose(np.max(np.abs(deflection)), w_max, rtol=1e-4)


def test_full_length_moment_and_deflection_shapes():
    # pointwise, not only the maxima: cantilever M(x) = -(L - x)^2 / 2 (hogging), w = x^2 (6L^2 - 4Lx + x^2) / (24 EI)
    x, moment, deflection = unit_load_response(L, Boundary.CLAMPED_FREE, (0.0, L), EI)
    scale_m, scale_w = L**2 / 2, L**4 / (8 * EI)
    assert_allclose(np.abs(moment), (L - x) ** 2 / 2, atol=1e-6 * scale_m)
    assert_allclose(np.abs(deflection), x**2 * (6 * L**2 - 4 * L * x + x**2) / (24 * EI), atol=1e-6 * scale_w)
    # simply supported: M = x (L - x) / 2, zero deflection at both supports
    x, moment, deflection = unit_load_response(L, Boundary.SIMPLY_SUPPORTED, (0.0, L), EI)
    assert_allclose(np.abs(moment), x * (L - x) / 2, atol=1e-6 * L**2 / 8)
    assert_allclose([deflection[0], deflection[-1]], 0.0, atol=1e-9 * 5 * L**4 / (384 * EI))
    # clamped-clamped: end moments L^2/12, mid-span L^2/24 of the opposite sign
    x, moment, deflection = unit_load_response(L, Boundary.CLAMPED_CLAMPED, (0.0, L), EI)
    assert_allclose(moment[[0, -1]], moment[0], rtol=1e-6)
    assert_allclose(abs(moment[_GRID // 2]), L**2 / 24, rtol=1e-4)
    assert np.sign(moment[0]) == -np.sign(moment[_GRID // 2])
    assert_allclose(deflection[-1], 0.0, atol=1e-9 * L**4 / (384 * EI))


@pytest.mark.parametrize("coverage", [(6.5e-3, 7.5e-3), (1e-3, 3e-3), (3e-3, 7.5e-3)])
def test_partial_load_on_cantilever_root_moment(coverage):
    x1, x2 = coverage
    _, moment, _ = unit_load_response(L, Boundary.CLAMPED_FREE, coverage, EI)
    exact = (x2**2 - x1**2) / 2  # integral_x1^x2 s ds for q = 1 N/m
    # The load is sampled on the grid's nodes and integrated with the trapezoid rule, so each load
    # edge moves by up to one cell: the root moment is off by at most dx * (x1 + x2), first order in dx.
    assert_allclose(abs(moment[0]), exact, rtol=0, atol=DX * (x1 + x2))
    # past the load the cantilever carries no moment
    assert_allclose(moment[-1], 0.0, atol=1e-12 * exact)


def _pzt_stress(m):
    return YP * Y_OUTER * m / EI


def test_free_span_cantilever_is_overstressed_at_one_megapascal():
    el = SensorElement()
    free = Mounting(kind="free-span")
    p = np.array([1e3, 1e6])
    rep = stress_report(el, p, (0.0, L), free)
    expected = _pzt_stress(p * B * L**2 / 2)  # q = P b, M = q L^2 / 2
    assert_allclose(rep.stress_pa, expected, rtol=1e-4)
    assert expected[1] > 5e8  # ~0.8 GPa, as stress.py's docstring says
    assert list(rep.overstressed) == [False, True] and not rep.ok
    assert not np.any(rep.on_backstop)
    assert_allclose(rep.max_deflection_m, p * B * L**4 / (8 * EI), rtol=1e-4)


def test_free_span_simply_supported_also_overstressed():
    el = SensorElement(boundary="simply-supported")
    rep = stress_report(el, np.array([1e6]), (0.0, L), Mounting(kind="free-span"))
    assert_allclose(rep.stress_pa, _pzt_stress(1e6 * B * L**2 / 8), rtol=1e-4)
    assert bool(rep.overstressed[0])


def test_backed_cantilever_is_capped_at_backstop_contact():
    mount = Mounting()  # backed, 20 um gap, 70 MPa
    tip = Fingertip(mounting=mount)
    gap = mount.backstop_gap_m
    # contact when P b L^4 / (8 EI) = gap; the stress there is Y_p y (P b L^2 / 2) / EI = 4 Y_p y gap / L^2
    p_contact = 8 * EI * gap / (B * L**4)
    cap = 4 * YP * Y_OUTER * gap / L**2
    assert_allclose(tip.backstop_pressure_pa(), p_contact, rtol=1e-4)
    p = np.array([0.5 * p_contact, 0.99 * p_contact, 1.01 * p_contact, 1e6, 1.3e6])
    rep = tip.stress(p)
    assert list(rep.on_backstop) == [False, False, True, True, True]
    assert_allclose(rep.stress_pa[:2], _pzt_stress(p[:2] * B * L**2 / 2), rtol=1e-4)
    assert_allclose(rep.stress_pa[2:], cap, rtol=1e-4)
    assert_allclose(rep.max_deflection_m[2:], gap, rtol=1e-12)
    assert np.all(rep.max_deflection_m <= gap * (1 + 1e-12))
    assert cap < mount.pzt_strength_pa
    assert not np.any(rep.overstressed) and rep.ok


def test_free_span_fingertip_has_no_backstop():
    tip = Fingertip(mounting=Mounting(kind="free-span"))
    assert tip.backstop_pressure_pa() is None
    assert not tip.stress(1.3e6).ok


def test_tip_coverage_stress_matches_partial_load_closed_form():
    x1, x2 = 6.5e-3, 7.5e-3
    tip = Fingertip(coverage=(x1, x2), mounting=Mounting(kind="free-span"))
    rep = tip.stress(1e5)
    expected = _pzt_stress(1e5 * B * (x2**2 - x1**2) / 2)
    assert_allclose(float(rep.stress_pa), expected, rtol=DX * (x1 + x2) / ((x2**2 - x1**2) / 2))


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"kind": "glued"}, "unknown mounting 'glued'"),
        ({"kind": "Backed"}, "unknown mounting"),
        ({"backstop_gap_m": -1e-6}, "backstop_gap_m"),
        ({"backstop_gap_m": 0.0}, "backstop_gap_m"),
        ({"backstop_gap_m": math.nan}, "backstop_gap_m"),
        ({"pzt_strength_pa": -70e6}, "pzt_strength_pa"),
        ({"pzt_strength_pa": math.inf}, "pzt_strength_pa"),
    ],
)
def test_mounting_validation(kwargs, match):
    with pytest.raises(ValueError, match=match):
        Mounting(**kwargs)
