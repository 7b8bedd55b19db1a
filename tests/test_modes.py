"""Tests of ``sensor.modes`` against references computed independently of the code.

References used (none of them copied from running the code under test):

* textbook roots of the frequency equations (Blevins, *Formulas for Natural Frequency and
  Mode Shape*, table 8-1), printed to 6 decimals;
* the same equations solved with ``mpmath.findroot`` at 60 digits, in their textbook form
  ``cos z cosh z = -1 / +1`` and ``sin z = 0``, bracketed around the asymptotic roots
  ``(2n - 1) pi / 2`` and ``(2n + 1) pi / 2`` (not the code's brackets);
* the textbook mode shape ``cosh - cos - sigma (sinh - sin)`` evaluated with mpmath at 60
  digits (where the cancellation that ruins it in double precision is harmless), normalized
  by a Gauss-Legendre rule written here;
* ``sqrt(2) sin(n pi x / L)`` for the simply supported beam and its closed-form square integral;
* ``scipy.integrate.quad`` (adaptive Gauss-Kronrod) for square integrals and Gram entries.

Physics reference: shared/physics.md section 2.
"""

from __future__ import annotations

import functools
import math

import mpmath as mp
import numpy as np
import pytest
from numpy.testing import assert_allclose
from scipy import integrate

from piezotip.sensor.modes import MAX_MODE, Boundary, characteristic_root, check_mode, mode_shape

L = 7.5e-3  # beam length of Table I, m
CF, SS, CC = Boundary.CLAMPED_FREE, Boundary.SIMPLY_SUPPORTED, Boundary.CLAMPED_CLAMPED
ALL_BOUNDARIES = (CF, SS, CC)
MODES_1_30 = tuple(range(1, 31))

# ---------------------------------------------------------------------------------------
# Independent references
# ---------------------------------------------------------------------------------------


@functools.cache
def mp_root(boundary: Boundary, n: int) -> mp.mpf:
    """Root n of the textbook frequency equation, to 60 digits, found independently.

    Clamped-free ``cos z cosh z + 1 = 0`` near ``(2n-1) pi/2``, clamped-clamped
    ``cos z cosh z - 1 = 0`` near ``(2n+1) pi/2`` (each bracket of half-width 0.4 holds exactly
    one root: the asymptotic estimate is off by at most 0.31, for clamped-free mode 1, and
    roots are about pi apart), simply supported ``n pi``.
    """
    with mp.workdps(60):
        if boundary is SS:
            return mp.pi * n
        sign = 1 if boundary is CF else -1
        guess = (2 * n - 1) * mp.pi / 2 if boundary is CF else (2 * n + 1) * mp.pi / 2

        def f(z):
            return mp.cos(z) * mp.cosh(z) + sign

        z = mp.findroot(f, (guess - mp.mpf("0.4"), guess + mp.mpf("0.4")), solver="anderson", verify=False)
        # Verify ourselves, relative to the size cosh z of the two terms that cancel.
        assert abs(f(z)) / mp.cosh(z) < mp.mpf(10) ** -50
        assert abs(z - guess) < mp.mpf("0.4")
        return z


def _mp_textbook_scaled(boundary: Boundary, n: int, xi: np.ndarray, order: int) -> np.ndarray:
    """``phi^(order)(x) / beta^order`` of the textbook (unnormalized) mode, at xi = x/L, via mpmath.

    phi = cosh u - cos u - sigma (sinh u - sin u), u = beta x, with clamped-free
    sigma = (cosh bL + cos bL)/(sinh bL + sin bL) and clamped-clamped
    sigma = (cosh bL - cos bL)/(sinh bL - sin bL); successive derivatives cycle through
    (C - c - s(S - s)), (S + s - s(C - c)), (C + c - s(S + s)), (S - s - s(C + c)).
    """
    out = np.empty(np.shape(xi))
    with mp.workdps(60):
        z = mp_root(boundary, n)
        if boundary is CF:
            sigma = (mp.cosh(z) + mp.cos(z)) / (mp.sinh(z) + mp.sin(z))
        else:
            sigma = (mp.cosh(z) - mp.cos(z)) / (mp.sinh(z) - mp.sin(z))
        for i, x in enumerate(np.ravel(xi)):
            u = z * mp.mpf(float(x))
            e = mp.exp(u)
            ch, sh = (e + 1 / e) / 2, (e - 1 / e) / 2
            c, s = mp.cos(u), mp.sin(u)
            value = [ch - c - sigma * (sh - s), sh + s - sigma * (ch - c), ch + c - sigma * (sh + s), sh - s - sigma * (ch + c)][order]
            out.flat[i] = float(value)
    return out


def gauss_legendre_rule(a: float, b: float, panels: int, nodes: int = 20) -> tuple[np.ndarray, np.ndarray]:
    """Composite Gauss-Legendre nodes and weights on [a, b] (written here, not the code's rule)."""
    t, w = np.polynomial.legendre.leggauss(nodes)
    edges = np.linspace(a, b, panels + 1)
    half = 0.5 * np.diff(edges)
    mid = 0.5 * (edges[1:] + edges[:-1])
    x = (mid[:, None] + half[:, None] * t).ravel()
    weights = (half[:, None] * w).ravel()
    return x, weights


@functools.cache
def mp_reference_norm(boundary: Boundary, n: int) -> float:
    """norm of the textbook mode: Z = phi / norm has int Z^2 = L.

    The textbook forms (cosh - cos - sigma (sinh - sin), and sin) already have the documented
    sign: phi''(0) = 2 beta^2 > 0 at a clamped end, phi'(0) > 0 at a pinned one.
    """
    xi, w = gauss_legendre_rule(0.0, 1.0, panels=2 * n + 8)
    phi = _mp_textbook_scaled(boundary, n, xi, 0)
    return math.sqrt(float(np.sum(w * phi**2)))  # integral over xi in [0, 1] = (1/L) int phi^2 dx


def expected_derivative_scaled(boundary: Boundary, n: int, x: np.ndarray, order: int) -> np.ndarray:
    """Reference ``Z^(order)(x) / beta^order`` for the normalized mode."""
    if boundary is SS:
        u = n * np.pi * x / L
        return math.sqrt(2.0) * [np.sin(u), np.cos(u), -np.sin(u), -np.cos(u)][order]
    return _mp_textbook_scaled(boundary, n, x / L, order) / mp_reference_norm(boundary, n)


# ---------------------------------------------------------------------------------------
# Characteristic roots
# ---------------------------------------------------------------------------------------

TEXTBOOK_ROOTS = [
    (CF, 1, 1.875104),
    (CF, 2, 4.694091),
    (CF, 3, 7.854757),
    (CF, 4, 10.995541),
    (CF, 5, 14.137168),
    (CC, 1, 4.730041),
    (CC, 2, 7.853205),
    (CC, 3, 10.995608),
    *[(SS, n, n * math.pi) for n in range(1, 6)],
]


@pytest.mark.parametrize(("boundary", "mode", "root"), TEXTBOOK_ROOTS)
def test_characteristic_root_textbook(boundary, mode, root):
    # Printed to 6 decimals: half a unit in the last place is 5e-7.
    assert_allclose(characteristic_root(boundary, mode), root, rtol=0, atol=5e-7)


@pytest.mark.parametrize("boundary", ALL_BOUNDARIES)
def test_characteristic_root_vs_mpmath(boundary):
    got = np.array([characteristic_root(boundary, n) for n in MODES_1_30])
    want = np.array([float(mp_root(boundary, n)) for n in MODES_1_30])
    # brentq is asked for rtol = 4 eps; 1e-14 leaves room for the float conversion.
    assert_allclose(got, want, rtol=1e-14, atol=0)


def test_characteristic_root_accepts_names_and_numpy_ints():
    assert characteristic_root("clamped-free", np.int64(2)) == characteristic_root(CF, 2)
    assert characteristic_root(" Clamped-Clamped ", 1) == characteristic_root(CC, 1)


@pytest.mark.parametrize("boundary", [CF, CC])
def test_roots_approach_asymptote(boundary):
    # For large n, cos z = -+1/cosh z ~ 0: z_n -> (2n -+ 1) pi / 2 with error ~ 2 e^-z.
    n = np.arange(10, 31)
    asymptote = (2 * n - 1) * np.pi / 2 if boundary is CF else (2 * n + 1) * np.pi / 2
    got = np.array([characteristic_root(boundary, int(k)) for k in n])
    assert_allclose(got, asymptote, rtol=1e-12, atol=0)


# ---------------------------------------------------------------------------------------
# Mode shapes
# ---------------------------------------------------------------------------------------


def _sample_points(n_points: int = 121, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return np.sort(np.concatenate([np.linspace(0.0, L, n_points), rng.uniform(0.0, L, 40)]))


@pytest.mark.parametrize("boundary", ALL_BOUNDARIES)
@pytest.mark.parametrize("mode", [1, 5, 10, 20, 30])
@pytest.mark.parametrize("order", [0, 1, 2, 3])
def test_mode_shape_vs_textbook(boundary, mode, order):
    """Z and its derivatives vs the 60-digit textbook form (sqrt(2) sin for simply supported).

    The reference is good to about 1e-19 (60 digits less the 41 lost to cancellation at mode
    30); the code's bounded basis is good to ~1e-14. atol 1e-11 on the O(1) scaled values
    (|Z^(k)| / beta^k <= ~2) is therefore 3 orders tighter than the 1e-10 asked for and
    ~1000x above the expected error.
    """
    shape = mode_shape(boundary, mode, L)
    x = _sample_points()
    got = shape.derivative(x, order) / shape.beta_per_m**order
    want = expected_derivative_scaled(boundary, mode, x, order)
    assert_allclose(got, want, rtol=0, atol=1e-11)


@pytest.mark.parametrize("boundary", [CF, CC])
@pytest.mark.parametrize("mode", [1, 5, 10, 20, 30])
def test_textbook_normalization_identity(boundary, mode):
    # Blevins: with sigma as above, int_0^L phi^2 dx = L exactly for clamped-free and
    # clamped-clamped beams. Checks the reference itself (norm computed by our GL rule).
    norm = mp_reference_norm(boundary, mode)
    assert_allclose(norm, 1.0, rtol=1e-13)


@pytest.mark.parametrize("boundary", ALL_BOUNDARIES)
@pytest.mark.parametrize("mode", MODES_1_30)
def test_sign_convention(boundary, mode):
    """The lowest derivative the x = 0 support leaves free is positive (Z' pinned, Z'' clamped)."""
    shape = mode_shape(boundary, mode, L)
    order = 1 if boundary is SS else 2
    assert shape.derivative(0.0, order) > 0
    if boundary is CF:
        # Textbook: phi_n(L) = 2 (-1)^(n+1) for the int phi^2 = L normalization.
        assert_allclose(shape(L), 2.0 * (-1) ** (mode + 1), rtol=1e-12)


@pytest.mark.parametrize("boundary", ALL_BOUNDARIES)
@pytest.mark.parametrize("mode", MODES_1_30)
def test_boundary_conditions(boundary, mode):
    """The end conditions hold, written here from the physics (not from the code's table).

    Derivatives are scaled by beta^k, so every scaled value is O(1) (up to 2 at an antinode
    of the clamped-end curvature); 1e-12 is ~1e4 eps.
    """
    shape = mode_shape(boundary, mode, L)
    beta = shape.beta_per_m

    def scaled(x, k):
        return float(shape.derivative(x, k)) / beta**k

    vanishing = {
        CF: [(0.0, 0), (0.0, 1), (L, 2), (L, 3)],  # clamped: Z = Z' = 0; free: moment Z'' = shear Z''' = 0
        SS: [(0.0, 0), (0.0, 2), (L, 0), (L, 2)],  # pinned: Z = Z'' = 0
        CC: [(0.0, 0), (0.0, 1), (L, 0), (L, 1)],
    }[boundary]
    for x, k in vanishing:
        assert abs(scaled(x, k)) < 1e-12, (x, k, scaled(x, k))
    # ... and the mode is not trivially zero there: the textbook values of the others.
    if boundary is SS:
        assert_allclose(abs(scaled(0.0, 1)), math.sqrt(2.0), rtol=1e-12)
        assert_allclose(abs(scaled(L, 1)), math.sqrt(2.0), rtol=1e-12)
    else:
        # phi''(0)/beta^2 = cosh 0 + cos 0 = 2 at a clamped end with norm 1.
        assert_allclose(abs(scaled(0.0, 2)), 2.0, rtol=1e-12)


# ---------------------------------------------------------------------------------------
# Orthogonality and square integrals
# ---------------------------------------------------------------------------------------


@pytest.mark.parametrize("boundary", ALL_BOUNDARIES)
def test_orthonormality_gram_matrix(boundary):
    """Gram matrix of modes 1..30 equals L * identity.

    Our own composite GL rule: 400 panels x 20 nodes. The fastest product (modes 30 x 30 at
    2 beta ~ 2 * 95 / L) turns ~0.5 rad per panel, far inside a 20-node rule's exactness;
    quadrature error is at rounding level. 1e-12 relative to L (asked: 1e-9) is still ~100x
    the expected rounding of summing 8000 terms.
    """
    x, w = gauss_legendre_rule(0.0, L, panels=400)
    z = np.array([mode_shape(boundary, n, L)(x) for n in MODES_1_30])
    gram = (z * w) @ z.T
    assert_allclose(gram / L, np.eye(30), rtol=0, atol=1e-12)


@pytest.mark.parametrize(("boundary", "m", "n"), [(CF, 1, 2), (CF, 29, 30), (CF, 30, 30), (SS, 3, 7), (CC, 5, 9), (CC, 30, 28)])
def test_orthonormality_vs_quad(boundary, m, n):
    zm, zn = mode_shape(boundary, m, L), mode_shape(boundary, n, L)
    value, err = integrate.quad(lambda x: float(zm(x) * zn(x)), 0.0, L, limit=400, epsabs=1e-13 * L, epsrel=1e-12)
    assert err < 1e-11 * L
    assert_allclose(value / L, float(m == n), rtol=0, atol=1e-11)


@pytest.mark.parametrize("boundary", ALL_BOUNDARIES)
@pytest.mark.parametrize("mode", [1, 2, 7, 15, 30])
def test_square_integral_vs_quad(boundary, mode):
    """Random sub-intervals against scipy's adaptive Gauss-Kronrod (asked for 1e-13 relative)."""
    shape = mode_shape(boundary, mode, L)
    rng = np.random.default_rng(1000 * mode + len(boundary.value))
    ends = np.sort(rng.uniform(0.0, L, size=(12, 2)), axis=1)
    got = shape.square_integral(ends[:, 0], ends[:, 1])
    want = np.array([integrate.quad(lambda x: float(shape(x)) ** 2, a, b, limit=400, epsabs=1e-16 * L, epsrel=1e-13)[0] for a, b in ends])
    assert got.shape == (12,)
    # Integrals are O(1e-3 m); absolute 1e-15 m is ~1e-12 relative to L.
    assert_allclose(got, want, rtol=1e-11, atol=1e-15)


@pytest.mark.parametrize("mode", [1, 2, 3, 10, 29, 30])
def test_square_integral_simply_supported_closed_form(mode):
    # int 2 sin^2(k x) dx = (x2 - x1) - (sin 2 k x2 - sin 2 k x1) / (2 k), k = n pi / L.
    shape = mode_shape(SS, mode, L)
    rng = np.random.default_rng(mode)
    x1, x2 = np.sort(rng.uniform(0.0, L, size=(2, 50)), axis=0)
    k = mode * np.pi / L
    want = (x2 - x1) - (np.sin(2 * k * x2) - np.sin(2 * k * x1)) / (2 * k)
    assert_allclose(shape.square_integral(x1, x2), want, rtol=0, atol=1e-16)


@pytest.mark.parametrize("boundary", ALL_BOUNDARIES)
@pytest.mark.parametrize("mode", [1, 4, 17, 30])
def test_square_integral_whole_beam_and_additivity(boundary, mode):
    shape = mode_shape(boundary, mode, L)
    assert_allclose(shape.square_integral(0.0, L), L, rtol=1e-14)
    assert shape.square_integral(0.3 * L, 0.3 * L) == 0.0
    rng = np.random.default_rng(mode)
    a, b, c = np.sort(rng.uniform(0.0, L, size=(3, 30)), axis=0)
    # Additivity over adjacent intervals, to rounding of O(L) partial sums.
    assert_allclose(shape.square_integral(a, b) + shape.square_integral(b, c), shape.square_integral(a, c), rtol=0, atol=1e-17)
    # Broadcasting of scalar and array ends.
    assert shape.square_integral(0.0, c).shape == c.shape


@pytest.mark.parametrize("boundary", ALL_BOUNDARIES)
def test_square_integral_nonnegative_on_narrow_intervals(boundary):
    """int_{x1}^{x2} Z^2 dx >= 0 whenever x1 <= x2, however narrow the interval.

    A negative value is unphysical and propagates: SensorElement.coverage_ratio < 0 gives
    V_1 > 1 and S_c < 0 (see test_element.test_narrow_coverage_keeps_outputs_physical).
    """
    rng = np.random.default_rng(7)
    x1 = rng.uniform(0.0, L, 3000)
    x2 = np.nextafter(np.nextafter(x1, np.inf), np.inf)  # two ulps wide
    worst = min(float(np.min(mode_shape(boundary, n, L).square_integral(x1, x2))) for n in (1, 2, 3, 10, 30))
    assert worst >= 0.0, f"square_integral returned {worst!r} m on an interval with x2 > x1"


@pytest.mark.parametrize("boundary", ALL_BOUNDARIES)
@pytest.mark.parametrize("mode", [1, 5, 30])
def test_square_integral_reversed_interval(boundary, mode):
    """x1 > x2 must not give a silently wrong number.

    ``integral_{x1}^{x2}`` with x1 > x2 is minus the forward integral; raising a ValueError
    is an acceptable alternative. Anything else (e.g. a positive value unrelated to either)
    would corrupt any caller that passes unsorted ends.
    """
    shape = mode_shape(boundary, mode, L)
    a = np.array([0.1, 0.13, 0.5, 0.0]) * L
    b = np.array([0.8, 0.14, 0.51, 1.0]) * L
    forward = shape.square_integral(a, b)
    try:
        backward = shape.square_integral(b, a)
    except ValueError:
        return
    assert_allclose(backward, -forward, rtol=1e-13, atol=1e-17)


# ---------------------------------------------------------------------------------------
# Bad inputs
# ---------------------------------------------------------------------------------------

BAD_MODES = [(0, r"mode must be in 1\.\.200"), (-1, r"mode must be in 1\.\.200"), (MAX_MODE + 1, r"mode must be in"),
             (1.5, r"mode must be a positive integer"), (True, r"mode must be a positive integer"),
             (1.0, r"mode must be a positive integer"), ("1", r"mode must be a positive integer"),
             (None, r"mode must be a positive integer")]  # fmt: skip


@pytest.mark.parametrize(("mode", "message"), BAD_MODES)
def test_bad_mode_raises(mode, message):
    """Bad modes raise, also after the valid mode 1 is cached.

    ``True == 1.0 == 1`` with equal hashes, so a ``functools.cache`` placed before the
    validation returns the cached mode 1 instead of raising; warm the caches first so the
    outcome does not depend on test order.
    """
    mode_shape(CF, 1, L)
    characteristic_root(SS, 1)
    with pytest.raises(ValueError, match=message):
        check_mode(mode)
    with pytest.raises(ValueError, match=message):
        mode_shape(CF, mode, L)
    with pytest.raises(ValueError, match=message):
        characteristic_root(SS, mode)


@pytest.mark.parametrize("name", ["free-free", "clamped", "", "clamped_free", "pinned-pinned"])
def test_unknown_boundary_raises(name):
    expected = r"unknown boundary .*valid boundaries: 'clamped-free', 'simply-supported', 'clamped-clamped'"
    with pytest.raises(ValueError, match=expected):
        mode_shape(name, 1, L)
    with pytest.raises(ValueError, match=expected):
        characteristic_root(name, 1)


@pytest.mark.parametrize("length", [0.0, -1e-3, math.nan, math.inf])
def test_bad_length_raises(length):
    with pytest.raises(ValueError, match="length_m must be positive and finite"):
        mode_shape(CF, 1, length)


def test_highest_mode_is_still_normalized():
    # MAX_MODE is accepted and still exact: its root is n pi -/+ pi/2 to within e^-600, and
    # its square integral over [0, L] matches an independent dense GL rule.
    for boundary in ALL_BOUNDARIES:
        shape = mode_shape(boundary, MAX_MODE, L)
        x, w = gauss_legendre_rule(0.0, L, panels=2000)
        assert_allclose(np.sum(w * shape(x) ** 2), L, rtol=1e-12)
    assert_allclose(characteristic_root(CF, MAX_MODE), (2 * MAX_MODE - 1) * math.pi / 2, rtol=1e-15)
