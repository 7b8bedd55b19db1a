"""The gel pad: pressure (Pa) and drive frequency (Hz) to the foundation (k_e, c_e).

Physics reference: ``shared/physics.md`` section 4.  The paper gives no relation between
pressure and (k_e, c_e); this module supplies one from four standard parts:

1. **Contact fraction** (Persson's rough-contact theory).  The gel pad rests, unbonded, on
   the element; the element's lapped ceramic/electrode face is rough.  The fraction of the
   face in true contact with the soft gel is (Persson, J. Chem. Phys. 115, 3840 (2001);
   Persson, Surf. Sci. Rep. 61, 201 (2006), eq. for P(sigma))

       phi(P) = erf( sqrt(2) P / (E* h'_rms) ),   E* = E / (1 - nu^2)

   which grows linearly from 0 (phi ~ sqrt(8/pi) P / (E* h'_rms)) and tends to 1 at full
   contact.  So k_e and c_e are zero at zero pressure, as the paper's V_0 assumes.
2. **Large-strain compression** (Gent's hyperelastic law, incompressible, uniaxial):
   the nominal stress in compression at stretch lambda < 1 is

       P = mu J_m (lambda^-2 - lambda) / (J_m - (lambda^2 + 2/lambda - 3)),   mu = E / 3

   (Gent, Rubber Chem. Technol. 69, 59 (1996)); it stiffens without bound as the first
   invariant approaches the locking value J_m + 3, which is how the gel "bottoms out".
3. **Winkler layer**.  Under the contacted fraction the gel column acts as a foundation of
   stiffness per unit area equal to the tangent of the compression law,
   K(P) = (dP/dlambda) / h0 [N/m^3] (= E/h0 at small strain, E_t/h as the layer thins).
4. **Viscoelasticity** (Prony series, quasi-linear: the large-strain law is scaled by the
   relaxation function, Fung's QLV).  The complex modulus ratio is

       R(omega) = E*(omega)/E_inf = 1 + sum_i g_i (j omega tau_i) / (1 + j omega tau_i)

   so each mode sees its own storage and loss modulus.  Then

       k_e = phi K Re R(omega_n),     c_e = phi K Im R(omega_n) / omega_n.

Limits of the model (it reports them, see :meth:`GelModel.state`): the Winkler stiffness
is only the low-frequency limit of the layer's dynamic impedance (the shear wavelength in a
gel with G of a few kPa is well under a millimetre at these frequencies, far shorter than
the 5 mm layer); past ``max_valid_strain`` no simple hyperelastic law describes a soft
layer squeezed to a fraction of its thickness (barrelling, friction at its faces).
"""

from __future__ import annotations

import functools
import math
from bisect import bisect_right
from dataclasses import dataclass, field

import numpy as np

from .element import _require_positive


@dataclass(frozen=True)
class GelParams:
    """A urethane gel pad under a thin silicone film.  Every default says where it comes from.

    Attributes
    ----------
    thickness_m : unloaded gel thickness h0, m.  5 mm: the paper's prototype gel.
    youngs_modulus_pa : relaxed small-strain Young's modulus E_inf, Pa.  30 kPa: soft
        polyurethane gels used for robot skins and shock pads have E of 10-100 kPa
        (Shore 00 10-40); the middle of that range.
    gent_jm : Gent locking parameter J_m, dimensionless.  20: soft, loosely cross-linked
        gels lock at far smaller first-invariant excursions than filled rubbers (J_m 30-100);
        20 puts the lock at about 91 % compression.
    poisson_ratio : nu, dimensionless, used in the contact modulus E* only (Gent's law is
        incompressible).  0.5: an elastomer gel is nearly incompressible.
    density_kg_m3 : gel density, kg/m^3.  1000: polyurethane gels are 1000-1100 kg/m^3.
    prony_g : relative Prony strengths g_i = E_i / E_inf, dimensionless.
    prony_tau_s : Prony relaxation times tau_i, s.  Three terms of strength 0.5 at 1, 10
        and 100 kHz (tau = 1 / (2 pi f)) give a loss tangent of 0.1-0.3 and a storage
        modulus rising 1.5x-2.3x across the element's modes (4 kHz to 130 kHz), the broad
        transition tail polyurethane elastomers show at room temperature in this band.
        Chosen, not fitted: no DMA data for the prototype's gel exist.
    surface_slope_rms : rms slope h'_rms of the element's face as the gel sees it,
        dimensionless.  0.1: lapped ceramic with a screen-printed electrode (Persson's
        surfaces span 0.05-0.5; smoother surfaces raise phi and so the low-pressure output).
    max_valid_strain : nominal compressive strain past which the law is reported as outside
        its range, dimensionless.  0.5: beyond half its thickness a soft pad barrels and its
        faces slip; no single-invariant law is validated there.
    film_thickness_m : protective silicone film, m.  50 um: the paper's cover.  Its bending
        stiffness (E ~ 1 MPa, 50 um) is negligible against the gel's foundation; it sets the
        pad's friction, not its compliance, so it does not enter k_e or c_e.
    """

    thickness_m: float = 5e-3
    youngs_modulus_pa: float = 30e3
    gent_jm: float = 20.0
    poisson_ratio: float = 0.5
    density_kg_m3: float = 1000.0
    prony_g: tuple[float, ...] = (0.5, 0.5, 0.5)
    prony_tau_s: tuple[float, ...] = (1.0 / (2 * math.pi * 1e3), 1.0 / (2 * math.pi * 1e4), 1.0 / (2 * math.pi * 1e5))
    surface_slope_rms: float = 0.1
    max_valid_strain: float = 0.5
    film_thickness_m: float = 50e-6

    def __post_init__(self) -> None:
        _require_positive(self)
        if not 0 < self.poisson_ratio <= 0.5:
            raise ValueError(f"GelParams.poisson_ratio must be in (0, 0.5], got {self.poisson_ratio!r}")
        if not 0 < self.max_valid_strain < 1:
            raise ValueError(f"GelParams.max_valid_strain must be in (0, 1), got {self.max_valid_strain!r}")
        if len(self.prony_g) != len(self.prony_tau_s):
            raise ValueError(f"GelParams.prony_g and prony_tau_s need equal lengths, got {len(self.prony_g)} and {len(self.prony_tau_s)}")
        for name in ("prony_g", "prony_tau_s"):
            for v in getattr(self, name):
                if not (math.isfinite(v) and v > 0):
                    raise ValueError(f"GelParams.{name} values must be positive and finite, got {v!r}")

    @property
    def shear_modulus_pa(self) -> float:
        """mu = E / 3, Pa: Gent's law is for an incompressible solid, so its tangent at lambda = 1 is E.

        (nu enters only the contact modulus E*, where a slightly compressible gel's plane-strain
        stiffness matters.)
        """
        return self.youngs_modulus_pa / 3.0

    @property
    def contact_modulus_pa(self) -> float:
        """E* = E / (1 - nu^2), Pa: the plane-strain modulus of rough-contact theory."""
        return self.youngs_modulus_pa / (1 - self.poisson_ratio**2)

    @property
    def locking_stretch(self) -> float:
        """lambda_lim < 1 at which Gent's compression law locks (lambda^2 + 2/lambda - 3 = J_m)."""
        return _locking_stretch(float(self.gent_jm))

    @property
    def max_valid_pressure_pa(self) -> float:
        """The pressure that compresses the gel to ``max_valid_strain``, Pa: Gent's law at
        lambda = 1 - max_valid_strain (37.3 kPa with the defaults).  Above it the law is outside
        its range (:attr:`GelState.beyond_valid_strain`), so the model ends there
        whatever the element does."""
        return float(gent_pressure_pa(1.0 - self.max_valid_strain, self))


#: Arrays of up to this many pressures are checked and inverted element by element in Python
#: floats: below it numpy's per-call overhead costs more than the arithmetic (measured: the
#: inversion of 40 pressures takes 44 us in floats, 53 us vectorized; of 5, 7 us against 55 us).
_LOOP_MAX = 48


def check_pressure(pressure_pa) -> np.ndarray:
    """Pressures as a float array; NaN, infinite or negative values raise a ValueError."""
    p = np.asarray(pressure_pa, dtype=float)
    if p.size <= _LOOP_MAX and all(0.0 <= v < math.inf for v in p.ravel().tolist()):
        return p  # (a few values: checked in Python floats, 0.5 us instead of numpy's 3.5 us)
    bad = ~np.isfinite(p) | (p < 0)
    if np.any(bad):
        raise ValueError(f"pressure_pa must be finite and non-negative, got {p[bad].flat[0]!r}")
    return p


def _check_freq(freq_hz, name: str = "freq_hz") -> float:
    """``freq_hz`` as a float, or a ValueError if it is not positive and finite."""
    try:
        f = float(freq_hz)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a positive number of Hz, got {freq_hz!r}") from None
    if not (math.isfinite(f) and f > 0):
        raise ValueError(f"{name} must be positive and finite, got {freq_hz!r}")
    return f


# ---------------------------------------------------------------------------------------
# Parts 1-4, each a small pure function of GelParams.
# ---------------------------------------------------------------------------------------


def contact_fraction(pressure_pa, gel: GelParams) -> np.ndarray:
    """Part 1: Persson's true contact fraction phi(P) = erf(sqrt(2) P / (E* h'_rms)), in [0, 1]."""
    return _erf(math.sqrt(2.0) * np.asarray(pressure_pa, float) / (gel.contact_modulus_pa * gel.surface_slope_rms))


def _erf(x) -> np.ndarray:
    """The error function of an array, element by element with the standard library's
    ``math.erf`` (C99's erf): ``scipy.special`` costs about 0.13 s to import in every run and
    sweep worker, and the arrays here are a pad's cells or a table's few hundred points."""
    x = np.asarray(x, float)
    return np.fromiter(map(math.erf, x.ravel().tolist()), float, x.size).reshape(x.shape)


def gent_pressure_pa(stretch, gel: GelParams) -> np.ndarray:
    """Part 2: compressive nominal stress P(lambda) of Gent's law, Pa (0 at lambda = 1)."""
    lam = np.asarray(stretch, float)
    mu, jm = gel.shear_modulus_pa, gel.gent_jm
    return mu * jm * (lam**-2 - lam) / (jm - (lam**2 + 2.0 / lam - 3.0))


def gent_tangent_pa(stretch, gel: GelParams) -> np.ndarray:
    """-dP/dlambda of Gent's compression law, Pa (= E at lambda = 1; grows without bound at lock)."""
    lam = np.asarray(stretch, float)
    mu, jm = gel.shear_modulus_pa, gel.gent_jm
    f = lam**-2 - lam
    df = -2.0 * lam**-3 - 1.0
    g = jm - (lam**2 + 2.0 / lam - 3.0)
    dg = -(2.0 * lam - 2.0 / lam**2)
    return -mu * jm * (df * g - f * dg) / g**2


def gent_curvature_pa(stretch, gel: GelParams) -> np.ndarray:
    """d^2P/dlambda^2 of Gent's compression law, Pa (positive: the law is convex)."""
    lam = np.asarray(stretch, float)
    mu, jm = gel.shear_modulus_pa, gel.gent_jm
    f = lam**-2 - lam
    df = -2.0 * lam**-3 - 1.0
    d2f = 6.0 * lam**-4
    g = jm - (lam**2 + 2.0 / lam - 3.0)
    dg = -(2.0 * lam - 2.0 / lam**2)
    d2g = -(2.0 + 4.0 / lam**3)
    return mu * jm * ((d2f * g - f * d2g) / g**2 - 2.0 * dg * (df * g - f * dg) / g**3)


# ---------------------------------------------------------------------------------------
# Inversion of Gent's law: lambda(P).
# ---------------------------------------------------------------------------------------
#
# P / mu = q(lambda) = J_m f / g with x = 1 - lambda, d = lambda - lambda_lim, w = 1 - lambda_lim and
#
#   f = lambda^-2 - lambda = x (1 + lambda + lambda^2) / lambda^2,
#   g = J_m - (lambda^2 + 2/lambda - 3) = d (a (3 - a) - x w (2 - a)) / (lambda lambda_lim),  a = x + w
#
# (J_m + 3 = lambda_lim^2 + 2/lambda_lim; this form of g has no cancellation at either end, so q is
# known to a few ulps relative everywhere, the lock included), and since dg/dlambda = 2 f the
# tangent is T = -dP/dlambda = mu J_m ((2/lambda^3 + 1) g + 2 f^2) / g^2.  lambda depends on P and
# mu only through q, so the inverse is tabulated once per J_m.
#
# The table is of u = ln(d / x) against t = ln q: lambda's place on (lambda_lim, 1) in a variable
# that keeps x and d to relative precision, with u = -t + const + O(x) as q -> 0 (x ~ q/3) and
# u = -t + const + O(d) as q -> inf (d ~ C/q).  A cubic Hermite interpolant of u(t) (values and
# slopes exact at the nodes) is a starting guess good to 1e-8 in u, i.e. relative in x and in d
# (measured against 50-digit roots for J_m = 1e-6 to 1e6); past the table's ends x ~ q and
# d ~ 1/q are as good.  One Newton step on the law then lands on the root to rounding, and the
# step's size proves it: Newton's error after a step s is K s^2 with K = P'' / (2 T) <= 1/d +
# 1/lambda + 1/w (checked at 50 digits across the interval for J_m = 1e-9 to 1e9), accepted
# below a quarter ulp of lambda, or once the step itself is down to an ulp (a root within a few
# ulps of the lock).  From P = 1e-300 to 1e300 Pa that takes one step (under 1 in 1000 take two).
# Anything not proven within _NEWTON_STEPS goes to the bracketed Newton (:func:`_stretch_bracketed`,
# the solver this replaced), which converges for any P.

#: Spacing of the table's nodes in u = ln(d / x).
_U_STEP = 1.0 / 16
#: The table ends where x (low pressure) or d (high pressure) is this fraction of
#: min(lambda_lim, 1 - lambda_lim); beyond, x is proportional to q and d to 1/q to that relative accuracy.
_TABLE_END = 1e-9
#: Newton's error after a step is accepted below this fraction of lambda (a quarter of an ulp).
_NEWTON_TOL = 2.0**-55
#: ... or when the step itself is down to rounding.
_ULP = 2.0**-52
#: At most this many Newton steps before the bracketed solver takes over.
_NEWTON_STEPS = 6


@functools.lru_cache(maxsize=256)
def _locking_stretch(jm: float) -> float:
    """lambda_lim: the root on (0, 1) of lambda^2 + 2/lambda - 3 = J_m, to rounding.

    Written as a cubic in whichever of lambda and w = 1 - lambda is the smaller, so that the root is
    found to relative precision: for J_m > 5/4 (lambda_lim < 1/2) c(lambda) = lambda^3 - (J_m + 3) lambda + 2,
    convex and decreasing there, from lambda = 2 / (J_m + 3) where c > 0; otherwise
    h(w) = w^3 - 3 w^2 - J_m w + J_m (J_m = w^2 (3 - w) / (1 - w)), concave and decreasing on (0, 1),
    from w = min(sqrt(J_m / 3), 1/2) where h <= 0.  Newton's method converges monotonically from
    either start, quadratically near the root: after a step below 1e-12 of it the error is below
    1e-24 of it.
    """
    if jm > 1.25:
        lam = 2.0 / (jm + 3.0)
        for _ in range(100):
            step = (lam**3 - (jm + 3.0) * lam + 2.0) / (3.0 * lam * lam - (jm + 3.0))
            lam -= step
            if abs(step) <= 1e-12 * lam:
                break
        return lam
    w = min(math.sqrt(jm / 3.0), 0.5)
    for _ in range(100):
        step = (w**3 - 3.0 * w * w - jm * w + jm) / (3.0 * w * w - 6.0 * w - jm)
        w -= step
        if abs(step) <= 1e-12 * w:
            break
    return 1.0 - w


class _GentInverse:
    """The table of u(t) for one J_m (the comment at the head of this section), as lists for the scalar path and as
    arrays for the vectorized one.  Read-only after construction."""

    __slots__ = (
        "c0",
        "c1",
        "c2",
        "c3",
        "coef",
        "d_times_q",
        "inv_width",
        "jm",
        "lock",
        "lock_up",
        "n",
        "q_hi",
        "q_lo",
        "t",
        "t_arr",
        "width",
        "x_per_q",
    )

    def __init__(self, jm: float) -> None:
        lock = _locking_stretch(jm)
        w = 1.0 - lock
        self.jm, self.lock, self.width, self.inv_width = jm, lock, w, 1.0 / w
        self.lock_up = math.nextafter(lock, 1.0)  # the smallest stretch (lambda_lim, 1] holds
        end = _TABLE_END * min(lock, w)
        u_lo, u_hi = math.log(end / (w - end)), math.log((w - end) / end)
        n = math.ceil((u_hi - u_lo) / _U_STEP) + 1
        u = np.linspace(u_hi, u_lo, n)  # descending u: ascending t
        e = np.exp(u)
        x = w / (1.0 + e)  # 1 - lambda, to relative precision
        d = w * e / (1.0 + e)  # lambda - lambda_lim, to relative precision
        lam = np.where(u < 0, lock + d, 1.0 - x)
        f = x * (1.0 + lam + lam * lam) / (lam * lam)
        # g = lambda_lim^2 + 2/lambda_lim - lambda^2 - 2/lambda (J_m + 3 = lambda_lim^2 + 2/lambda_lim), in
        # a form without cancellation at either end: d (a (3 - a) - x w (2 - a)) / (lambda lambda_lim), a = x + w.
        a = x + w
        g = d * (a * (3.0 - a) - x * w * (2.0 - a)) / (lam * lock)
        t = np.log(jm * f / g)
        # du/dt = 1 / (dt/du);  dt/du = -(T / P) d x / w,  T / P = (2/lambda^3 + 1) / f + 2 f / g.
        dudt = -w / ((((2.0 / lam**3 + 1.0) / f) + 2.0 * f / g) * d * x)
        if not np.all(np.diff(t) > 0):
            raise ArithmeticError(f"Gent inverse table for J_m={jm!r} is not monotone")
        h = np.diff(t)
        slope = np.diff(u) / h
        c0, c1 = u[:-1], dudt[:-1]
        c2 = (3.0 * slope - 2.0 * dudt[:-1] - dudt[1:]) / h
        c3 = (dudt[:-1] + dudt[1:] - 2.0 * slope) / (h * h)
        self.t_arr, self.c0, self.c1, self.c2, self.c3 = t, c0, c1, c2, c3
        self.t = t.tolist()
        self.n = len(self.t) - 1  # bisect_right(t, ., 1, n) - 1: an interval index in [0, n - 1)
        self.coef = list(zip(t[:-1].tolist(), c0.tolist(), c1.tolist(), c2.tolist(), c3.tolist(), strict=True))
        # Beyond the ends: x = x_end q / q_end below the table, d = d_end q_end / q above it.
        self.q_lo, self.q_hi = math.exp(t[0]), math.exp(t[-1])
        self.x_per_q = float(x[0]) / self.q_lo
        self.d_times_q = float(d[-1]) * self.q_hi


@functools.lru_cache(maxsize=32)  # ~0.3 MB and ~0.5 ms to build each
def _gent_inverse(jm: float) -> _GentInverse | None:
    """The inverse table for J_m, or None where it cannot be built in double precision (J_m so far
    out, ~1e100, that f^2 overflows): every pressure then goes to the bracketed solver."""
    try:
        with np.errstate(all="raise"):
            return _GentInverse(jm)
    except (ArithmeticError, FloatingPointError, OverflowError, ValueError):
        return None


def _stretch_one(q: float, inv: _GentInverse) -> float:
    """lambda at q = P / mu > 0 (a float): the table's guess and Newton steps; NaN if not proven converged."""
    jm, lock, w = inv.jm, inv.lock, inv.width
    if q < inv.q_lo:
        lam = 1.0 - inv.x_per_q * q
    elif q > inv.q_hi:
        lam = lock + inv.d_times_q / q
        if lam <= lock:
            lam = inv.lock_up
    else:
        t = math.log(q)
        tj, c0, c1, c2, c3 = inv.coef[bisect_right(inv.t, t, 1, inv.n) - 1]
        tau = t - tj
        u = c0 + tau * (c1 + tau * (c2 + tau * c3))
        e = math.exp(u)
        lam = lock + w * e / (1.0 + e) if u < 0 else 1.0 - w / (1.0 + e)
    for _ in range(_NEWTON_STEPS):
        x = 1.0 - lam
        l2 = lam * lam
        f = x * (1.0 + lam + l2) / l2
        a = x + w
        g = (lam - lock) * (a * (3.0 - a) - x * w * (2.0 - a)) / (lam * lock)
        s = (jm * f - q * g) * g / (jm * ((2.0 / (l2 * lam) + 1.0) * g + 2.0 * f * f))
        new = lam + s
        d = new - lock
        if not d > 0.0:  # the root is within an ulp of the lock: the first double above it
            if lam == inv.lock_up:
                return lam
            lam = inv.lock_up
            continue
        if not new <= 1.0:
            return math.nan
        lam = new
        # Newton's error after the step, K s^2 with K <= 1/d + 1/lambda + 1/w, below a quarter ulp,
        # or the step itself down to rounding (then the error is an ulp at most).
        if s * s * (1.0 / d + 1.0 / lam + inv.inv_width) <= _NEWTON_TOL * lam or abs(s) <= _ULP * lam:
            return lam
    return math.nan


def _stretch_many(q: np.ndarray, inv: _GentInverse) -> np.ndarray:
    """:func:`_stretch_one` on an array of q > 0, vectorized; NaN where not proven converged."""
    jm, lock, w, lock_up = inv.jm, inv.lock, inv.width, inv.lock_up
    t = np.log(np.clip(q, inv.q_lo, inv.q_hi))
    j = np.searchsorted(inv.t_arr, t, side="right") - 1
    np.clip(j, 0, inv.c0.size - 1, out=j)
    tau = t - inv.t_arr[j]
    u = inv.c0[j] + tau * (inv.c1[j] + tau * (inv.c2[j] + tau * inv.c3[j]))
    e = np.exp(u)
    lam = np.where(u < 0, lock + w * e / (1.0 + e), 1.0 - w / (1.0 + e))
    lam = np.where(q < inv.q_lo, 1.0 - inv.x_per_q * q, lam)
    lam = np.where(q > inv.q_hi, np.maximum(lock + inv.d_times_q / q, lock_up), lam)
    out = np.full(q.shape, math.nan)
    idx = np.arange(q.size)
    for _ in range(_NEWTON_STEPS):
        x = 1.0 - lam
        l2 = lam * lam
        f = x * (1.0 + lam + l2) / l2
        a = x + w
        g = (lam - lock) * (a * (3.0 - a) - x * w * (2.0 - a)) / (lam * lock)
        s = (jm * f - q * g) * g / (jm * ((2.0 / (l2 * lam) + 1.0) * g + 2.0 * f * f))
        new = lam + s
        past = ~(new > lock)
        new = np.where(past, lock_up, new)
        d = new - lock
        proven = (s * s * (1.0 / d + 1.0 / new + inv.inv_width) <= _NEWTON_TOL * new) | (np.abs(s) <= _ULP * new)
        done = np.where(past, lam == lock_up, proven) & (new <= 1.0)
        out[idx[done]] = new[done]
        keep = ~done & (new <= 1.0)
        if not keep.any():
            break
        idx, q, lam = idx[keep], q[keep], new[keep]
    return out


def _stretch_bracketed(p: np.ndarray, gel: GelParams) -> np.ndarray:
    """The reference inversion (and the fallback): vectorized Newton's method on lambda, kept inside a
    shrinking bracket (bisection when a Newton step would leave it), from the small-strain
    estimate; converges to rounding in under 40 steps for any P >= 0.  About 0.5 ms a call."""
    # (Where the law's denominator rounds to 0 its value is inf or NaN: the bracket takes care of that.)
    with np.errstate(divide="ignore", invalid="ignore"):
        return _bracketed_newton(p, gel)


def _bracketed_newton(p: np.ndarray, gel: GelParams) -> np.ndarray:
    """The body of :func:`_stretch_bracketed` (the original stretch_from_pressure, unchanged)."""
    lo = np.full(p.shape, gel.locking_stretch)
    hi = np.ones(p.shape)
    lam = np.clip(1.0 - p / gel.youngs_modulus_pa, lo + 1e-3 * (1 - lo), 1.0)
    for _ in range(100):
        residual = gent_pressure_pa(lam, gel) - p  # decreasing in lambda
        hi = np.where(residual < 0, lam, hi)
        lo = np.where(residual > 0, lam, lo)
        step = residual / gent_tangent_pa(lam, gel)
        candidate = lam + step
        inside = (candidate > lo) & (candidate < hi)
        new = np.where(inside, candidate, 0.5 * (lo + hi))
        new = np.where(p == 0, 1.0, new)
        if np.all(np.abs(new - lam) <= 4e-16 * np.abs(lam)):
            lam = new
            break
        lam = new
    return lam


def _stretch_float(p: float, gel: GelParams, inv: _GentInverse | None) -> float:
    """lambda at one pressure ``p`` (a float, already known finite and >= 0), ``inv`` = _gent_inverse(J_m)."""
    if p == 0.0:
        return 1.0
    if inv is not None:
        try:
            lam = _stretch_one(p * (3.0 / gel.youngs_modulus_pa), inv)
        except ArithmeticError:  # (never seen: a float division by zero or overflow in a far-out gel)
            lam = math.nan
        if lam == lam:
            return lam
    return float(_stretch_bracketed(np.array(p), gel))


def _stretch_checked(p: np.ndarray, gel: GelParams) -> np.ndarray:
    """:func:`stretch_from_pressure` of a float array already through :func:`check_pressure`."""
    inv = _gent_inverse(float(gel.gent_jm))
    if p.size <= _LOOP_MAX:
        return np.array([_stretch_float(v, gel, inv) for v in p.ravel().tolist()]).reshape(p.shape)
    if inv is None:
        return _stretch_bracketed(p, gel)
    lam = np.ones(p.shape)
    pos = p > 0
    with np.errstate(all="ignore"):  # far out (P ~ 1e300) s^2 overflows to inf: the test is then False, as in _stretch_one
        lam[pos] = _stretch_many(p[pos] * (3.0 / gel.youngs_modulus_pa), inv)
    bad = np.isnan(lam)
    if bad.any():
        lam[bad] = _stretch_bracketed(p[bad], gel)
    return lam


def stretch_from_pressure(pressure_pa, gel: GelParams) -> np.ndarray:
    """Invert Gent's law: the stretch lambda in (lambda_lim, 1] that carries pressure P (Pa).

    A per-J_m table of the inverse gives a starting guess good to ~1e-8; one Newton step on the
    law (rarely two) lands on the root to rounding, and the step's size proves it (the comment at
    the head of this section); anything unproven goes to the bracketed Newton of
    :func:`_stretch_bracketed`.  About 1.5 us for a float; arrays of up to ``_LOOP_MAX``
    pressures are done element by element in Python floats, longer ones vectorized.
    A scalar pressure gives a 0-d array.
    """
    if isinstance(pressure_pa, (float, int)):
        p = float(pressure_pa)
        if not 0.0 <= p < math.inf:
            check_pressure(p)  # raises, with the usual message
        return np.array(_stretch_float(p, gel, _gent_inverse(float(gel.gent_jm))))
    return _stretch_checked(check_pressure(pressure_pa), gel)


def contact_fraction_slope(pressure_pa, gel: GelParams) -> np.ndarray:
    """dphi/dP of part 1, 1/Pa: (2/sqrt(pi)) a exp(-(a P)^2), a = sqrt(2) / (E* h'_rms)."""
    a = math.sqrt(2.0) / (gel.contact_modulus_pa * gel.surface_slope_rms)
    return 2.0 / math.sqrt(math.pi) * a * np.exp(-((a * np.asarray(pressure_pa, float)) ** 2))


def winkler_stiffness_n_m3(stretch, gel: GelParams) -> np.ndarray:
    """Part 3: relaxed foundation stiffness K = (-dP/dlambda) / h0, N/m^3 (E/h0 when unloaded)."""
    return gent_tangent_pa(stretch, gel) / gel.thickness_m


def modulus_ratio(freq_hz, gel: GelParams) -> np.ndarray:
    """Part 4: R(omega) = E*(omega) / E_inf of the Prony series, complex, dimensionless."""
    return _prony_ratio(freq_hz, gel.prony_g, gel.prony_tau_s)


def _prony_ratio(freq_hz, prony_g: tuple[float, ...], prony_tau_s: tuple[float, ...]) -> np.ndarray:
    omega = 2 * math.pi * np.asarray(freq_hz, float)
    ratio = np.ones(omega.shape, dtype=complex)
    for g, tau in zip(prony_g, prony_tau_s, strict=True):
        jwt = 1j * omega * tau
        ratio = ratio + g * jwt / (1 + jwt)
    return ratio


@functools.lru_cache(maxsize=1024)
def _modulus_ratio_at(prony_g: tuple[float, ...], prony_tau_s: tuple[float, ...], freq_hz: float) -> complex:
    """complex(modulus_ratio(freq_hz, gel)) for a gel with these Prony terms, at one frequency (a float):
    computed once (GelModel.foundation asks for the same few mode frequencies every step)."""
    return complex(_prony_ratio(freq_hz, prony_g, prony_tau_s))


def layer_dynamic_stiffness(stretch, freq_hz: float, gel: GelParams, ratio: complex) -> np.ndarray:
    """Part 5 (option): the gel column's dynamic stiffness per unit area, N/m^3, complex.

    The contacted column (current height h = lambda h0, held at its top by the object, its
    density rho) is driven at its base by the element: a one-dimensional wave in a layer of
    complex modulus M = T(lambda) lambda R(omega), so that M / h is exactly the Winkler
    stiffness K R of part 3 (T = -dP/dlambda).  The force per unit area and displacement is

        Z = M k cot(k h),   k = omega sqrt(rho / M)

    (a clamped-top layer).  Z -> M / h as omega -> 0 (Winkler); above the layer's first
    resonance Re Z turns negative (the gel's mass moves with the element), and with loss,
    once the wave dies out within the layer, Z -> j omega sqrt(rho M), the radiation
    impedance.  cot is evaluated as j (1 + e^(-2jz)) / (1 - e^(-2jz)), which stays finite
    however lossy the layer (Im z < 0).
    """
    lam = np.asarray(stretch, float)
    omega = 2 * math.pi * float(freq_hz)
    modulus = gent_tangent_pa(lam, gel) * lam * ratio
    k = omega * np.sqrt(gel.density_kg_m3 / modulus)
    z = k * lam * gel.thickness_m
    inv = np.exp(-2j * z)
    return modulus * k * (1j * (1 + inv) / (1 - inv))


# ---------------------------------------------------------------------------------------
# The layer laws, one object each (GelModel.layer names one): a new one is added here.
# ---------------------------------------------------------------------------------------


class GelLayer:
    """How the contacted gel column loads the element: its foundation law (k_e, c_e) and slope.

    Stateless (one shared instance per law, in ``GEL_LAYERS``, named by :attr:`GelModel.layer`).

    Attributes
    ----------
    name : the law's name (``GelModel.layer``, ``sensor.gel_layer`` of a scenario).
    signed_stiffness : k_e may be negative (mass-like, above the layer's resonance): eq. 19
        is differentiated directly, not through the sensitivities of eqs. 20 and 21
        (:meth:`sensor.fingertip.Fingertip.output_slope`), and no table of k_e > 0 holds it
        (:class:`sensor.estimator.FoundationTable`).
    """

    __slots__ = ()
    name = ""
    signed_stiffness = False

    def __reduce__(self) -> tuple:
        # One instance per law: a pickled or copied model shares it (found by its name).
        return gel_layer, (self.name,)

    def __repr__(self) -> str:
        return f"<{self.name} gel layer>"

    def foundation(self, pressure_pa: np.ndarray, stretch: np.ndarray, freq_hz: float, gel: GelParams, ratio: complex):
        """(k_e N/m^3, c_e N s/m^3) at checked pressures (Pa), their stretch lambda, the drive
        ``freq_hz`` (Hz) and the modulus ratio R there (:meth:`GelModel.foundation`)."""
        raise NotImplementedError

    def foundation_slope(self, model: GelModel, pressure_pa: np.ndarray, freq_hz: float):
        """(dk_e/dP in 1/m, dc_e/dP in s/m) of ``model`` at checked pressures (Pa) and
        ``freq_hz`` (Hz) (:meth:`GelModel.foundation_slope`)."""
        raise NotImplementedError


class WinklerLayer(GelLayer):
    """Parts 1-4: k_e = phi K Re R(omega), c_e = phi K Im R(omega) / omega, with K the Winkler
    stiffness (the column's low-frequency limit, part 3); k_e >= 0 everywhere."""

    __slots__ = ()
    name = "winkler"

    def foundation(self, pressure_pa: np.ndarray, stretch: np.ndarray, freq_hz: float, gel: GelParams, ratio: complex):
        # GelState.stiffness_n_m3, without the rest of the state
        stiffness = contact_fraction(pressure_pa, gel) * winkler_stiffness_n_m3(stretch, gel)
        return stiffness * ratio.real, stiffness * ratio.imag / (2 * math.pi * freq_hz)

    def foundation_slope(self, model: GelModel, pressure_pa: np.ndarray, freq_hz: float):
        """Chain rule on k_e = phi(P) K(lambda(P)) Re R:  d(phi K)/dP = phi' K + phi K',
        K' = dK/dP = P''(lambda) / (h0 T(lambda)) with T = -dP/dlambda."""
        gel = model.params
        lam = _stretch_checked(pressure_pa, gel)
        tangent = gent_tangent_pa(lam, gel)
        stiffness = tangent / gel.thickness_m
        stiffness_slope = gent_curvature_pa(lam, gel) / (gel.thickness_m * tangent)
        slope = contact_fraction_slope(pressure_pa, gel) * stiffness + contact_fraction(pressure_pa, gel) * stiffness_slope
        ratio = model._ratio(freq_hz)
        return slope * ratio.real, slope * ratio.imag / (2 * math.pi * freq_hz)


class DynamicLayer(GelLayer):
    """Part 5: k_e + j omega c_e = phi Z, Z the column's dynamic stiffness
    (:func:`layer_dynamic_stiffness`); k_e turns negative, mass-like, above the layer's
    resonance (c_e >= 0 always)."""

    __slots__ = ()
    name = "dynamic"
    signed_stiffness = True

    def foundation(self, pressure_pa: np.ndarray, stretch: np.ndarray, freq_hz: float, gel: GelParams, ratio: complex):
        z = contact_fraction(pressure_pa, gel) * layer_dynamic_stiffness(stretch, freq_hz, gel, ratio)
        return z.real, z.imag / (2 * math.pi * freq_hz)

    def foundation_slope(self, model: GelModel, pressure_pa: np.ndarray, freq_hz: float):
        """Central difference of :meth:`GelModel.foundation`, relative step 1e-6 (1e-9 Pa near 0)."""
        p, f = pressure_pa, freq_hz
        h = np.maximum(1e-6 * p, 1e-9)
        (k1, c1), (k0, c0) = model.foundation(p + h, f), model.foundation(np.maximum(p - h, 0.0), f)
        width = p + h - np.maximum(p - h, 0.0)
        return (k1 - k0) / width, (c1 - c0) / width


#: The gel layer laws by name (:attr:`GelModel.layer`): a new one is added here.
GEL_LAYERS: dict[str, GelLayer] = {law.name: law for law in (WinklerLayer(), DynamicLayer())}
#: Their names, in order.
LAYERS = tuple(GEL_LAYERS)


def gel_layer(name: str) -> GelLayer:
    """The gel layer law named ``name`` (a ValueError naming the valid ones otherwise)."""
    try:
        return GEL_LAYERS[name]
    except (KeyError, TypeError):
        raise ValueError(f"unknown gel layer model {name!r}; valid: {', '.join(LAYERS)}") from None


@dataclass(frozen=True)
class GelState:
    """What the gel is doing at one pressure: the foundation and the model's own limits.

    Attributes
    ----------
    pressure_pa : applied pressure P, Pa.
    contact_fraction : phi, dimensionless.
    stretch : lambda = current / unloaded thickness, dimensionless.
    strain : nominal compressive strain 1 - lambda, dimensionless.
    thickness_m : current thickness lambda h0, m.
    stiffness_n_m3 : relaxed foundation stiffness phi K, N/m^3 (before the modulus ratio).
    beyond_valid_strain : True where the strain exceeds ``GelParams.max_valid_strain``.
    """

    pressure_pa: np.ndarray
    contact_fraction: np.ndarray
    stretch: np.ndarray
    strain: np.ndarray
    thickness_m: np.ndarray
    stiffness_n_m3: np.ndarray
    beyond_valid_strain: np.ndarray


@dataclass(frozen=True)
class GelModel:
    """Pressure to (k_e, c_e) for one gel.

    Parameters
    ----------
    params : GelParams.
    frequency_dependent : if False, every mode sees the modulus ratio at
        ``reference_freq_hz`` (one complex number, computed once): a scene that needs no
        frequency dependence does not pay for the Prony series per mode.
    reference_freq_hz : the frequency used when ``frequency_dependent`` is False, Hz.
    layer : "winkler" (parts 1-4, the default) or "dynamic" (part 5: the column's dynamic
        stiffness instead of its low-frequency limit; k_e may then be negative, mass-like):
        a name in :data:`GEL_LAYERS`, whose law (:attr:`law`) does what differs between them.
    """

    params: GelParams = field(default_factory=GelParams)
    frequency_dependent: bool = True
    reference_freq_hz: float = 3768.0
    layer: str = "winkler"

    def __post_init__(self) -> None:
        _check_freq(self.reference_freq_hz, "reference_freq_hz")
        gel_layer(self.layer)  # a ValueError if it names no law

    @property
    def law(self) -> GelLayer:
        """The layer's law (:class:`GelLayer`), named by :attr:`layer`."""
        return GEL_LAYERS[self.layer]

    def state(self, pressure_pa) -> GelState:
        """The gel's :class:`GelState` at pressures ``pressure_pa`` (Pa, arrays allowed)."""
        p = check_pressure(pressure_pa)
        gel = self.params
        lam = _stretch_checked(p, gel)
        phi = contact_fraction(p, gel)
        strain = 1.0 - lam
        return GelState(
            pressure_pa=p,
            contact_fraction=phi,
            stretch=lam,
            strain=strain,
            thickness_m=lam * gel.thickness_m,
            stiffness_n_m3=phi * winkler_stiffness_n_m3(lam, gel),
            beyond_valid_strain=strain > gel.max_valid_strain,
        )

    def modulus_ratio(self, freq_hz) -> np.ndarray:
        """R at ``freq_hz`` (or at the reference frequency when not frequency dependent)."""
        f = freq_hz if self.frequency_dependent else self.reference_freq_hz
        return modulus_ratio(f, self.params)

    def _ratio(self, freq_hz: float) -> complex:
        """:meth:`modulus_ratio` as a complex number, computed once per gel and frequency."""
        f = freq_hz if self.frequency_dependent else self.reference_freq_hz
        return _modulus_ratio_at(tuple(self.params.prony_g), tuple(self.params.prony_tau_s), float(f))

    def foundation(self, pressure_pa, freq_hz) -> tuple[np.ndarray, np.ndarray]:
        """(k_e N/m^3, c_e N s/m^3) at pressure ``pressure_pa`` (Pa) and drive ``freq_hz`` (Hz).

        k_e = phi K Re R(omega), c_e = phi K Im R(omega) / omega  (module docstring, parts 1-4).
        Both are zero at zero pressure and, for the Winkler layer, non-negative everywhere
        (the dynamic layer's k_e turns negative above the layer's resonance; c_e >= 0 always):
        the layer's law (:meth:`GelLayer.foundation`).
        """
        f = _check_freq(freq_hz)
        ratio = self._ratio(f)
        gel = self.params
        p = check_pressure(pressure_pa)
        return GEL_LAYERS[self.layer].foundation(p, _stretch_checked(p, gel), f, gel, ratio)

    def foundation_slope(self, pressure_pa, freq_hz) -> tuple[np.ndarray, np.ndarray]:
        """(dk_e/dP in 1/m, dc_e/dP in s/m) at ``pressure_pa`` (Pa) and ``freq_hz`` (Hz).

        Winkler layer: the chain rule on k_e = phi(P) K(lambda(P)) Re R:  d(phi K)/dP =
        phi' K + phi K', K' = dK/dP = P''(lambda) / (h0 T(lambda)) with T = -dP/dlambda.
        Dynamic layer: a central difference, relative step 1e-6 (1e-9 Pa near 0).  The layer's
        law (:meth:`GelLayer.foundation_slope`).
        """
        f = _check_freq(freq_hz)
        return GEL_LAYERS[self.layer].foundation_slope(self, check_pressure(pressure_pa), f)

    def pressure_from_indentation(self, indentation_m) -> np.ndarray:
        """Quasi-static pressure (Pa) that compresses the gel by ``indentation_m`` (m).

        This is the pad's force law per unit area for the physics engine: P = Gent(1 - d/h0).
        Indentations at or past the locking thickness raise a ValueError (the housing must
        take the load before that).
        """
        d = np.asarray(indentation_m, float)
        lam = 1.0 - np.clip(d, 0.0, None) / self.params.thickness_m
        # The lock is where Gent's denominator J_m - (I_1 - 3) vanishes; locking_stretch is its
        # root rounded, so a stretch an ulp above it can still leave the denominator at 0.
        locked = (lam <= self.params.locking_stretch) | (self.params.gent_jm - (lam**2 + 2.0 / lam - 3.0) <= 0.0)
        if np.any(locked):
            raise ValueError(f"indentation {float(np.max(d))!r} m reaches the gel's locking thickness")
        return gent_pressure_pa(lam, self.params)
