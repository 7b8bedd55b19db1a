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

import math
from dataclasses import dataclass, field

import numpy as np
from scipy.special import erf

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
        jm = self.gent_jm
        # Smallest root of lambda^3 - (J_m + 3) lambda + 2 = 0 on (0, 1).
        roots = np.roots([1.0, 0.0, -(jm + 3.0), 2.0])
        real = sorted(r.real for r in roots if abs(r.imag) < 1e-12 and 0 < r.real < 1)
        return float(real[0])


LAYERS = ("winkler", "dynamic")


def check_pressure(pressure_pa) -> np.ndarray:
    """Pressures as a float array; NaN, infinite or negative values raise a ValueError."""
    p = np.asarray(pressure_pa, dtype=float)
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
    return erf(math.sqrt(2.0) * np.asarray(pressure_pa, float) / (gel.contact_modulus_pa * gel.surface_slope_rms))


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


def stretch_from_pressure(pressure_pa, gel: GelParams) -> np.ndarray:
    """Invert Gent's law: the stretch lambda in (lambda_lim, 1] that carries pressure P (Pa).

    Vectorized Newton's method on lambda, kept inside a shrinking bracket (bisection when a
    Newton step would leave it); converges to rounding in under 40 steps for any P >= 0.
    """
    p = check_pressure(pressure_pa)
    lo = np.full(p.shape, gel.locking_stretch)
    hi = np.ones(p.shape)
    # Start from the small-strain estimate, clipped into the bracket.
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


def contact_fraction_slope(pressure_pa, gel: GelParams) -> np.ndarray:
    """dphi/dP of part 1, 1/Pa: (2/sqrt(pi)) a exp(-(a P)^2), a = sqrt(2) / (E* h'_rms)."""
    a = math.sqrt(2.0) / (gel.contact_modulus_pa * gel.surface_slope_rms)
    return 2.0 / math.sqrt(math.pi) * a * np.exp(-((a * np.asarray(pressure_pa, float)) ** 2))


def winkler_stiffness_n_m3(stretch, gel: GelParams) -> np.ndarray:
    """Part 3: relaxed foundation stiffness K = (-dP/dlambda) / h0, N/m^3 (E/h0 when unloaded)."""
    return gent_tangent_pa(stretch, gel) / gel.thickness_m


def modulus_ratio(freq_hz, gel: GelParams) -> np.ndarray:
    """Part 4: R(omega) = E*(omega) / E_inf of the Prony series, complex, dimensionless."""
    omega = 2 * math.pi * np.asarray(freq_hz, float)
    ratio = np.ones(omega.shape, dtype=complex)
    for g, tau in zip(gel.prony_g, gel.prony_tau_s, strict=True):
        jwt = 1j * omega * tau
        ratio = ratio + g * jwt / (1 + jwt)
    return ratio


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
        stiffness instead of its low-frequency limit; k_e may then be negative, mass-like).
    """

    params: GelParams = field(default_factory=GelParams)
    frequency_dependent: bool = True
    reference_freq_hz: float = 3768.0
    layer: str = "winkler"

    def __post_init__(self) -> None:
        _check_freq(self.reference_freq_hz, "reference_freq_hz")
        if self.layer not in LAYERS:
            raise ValueError(f"unknown gel layer model {self.layer!r}; valid: {', '.join(LAYERS)}")

    def state(self, pressure_pa) -> GelState:
        """The gel's :class:`GelState` at pressures ``pressure_pa`` (Pa, arrays allowed)."""
        p = check_pressure(pressure_pa)
        gel = self.params
        lam = stretch_from_pressure(p, gel)
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

    def foundation(self, pressure_pa, freq_hz) -> tuple[np.ndarray, np.ndarray]:
        """(k_e N/m^3, c_e N s/m^3) at pressure ``pressure_pa`` (Pa) and drive ``freq_hz`` (Hz).

        k_e = phi K Re R(omega), c_e = phi K Im R(omega) / omega  (module docstring, parts 1-4).
        Both are zero at zero pressure and, for the Winkler layer, non-negative everywhere
        (the dynamic layer's k_e turns negative above the layer's resonance; c_e >= 0 always).
        """
        f = _check_freq(freq_hz)
        ratio = complex(self.modulus_ratio(f))
        if self.layer == "dynamic":
            state = self.state(pressure_pa)
            z = state.contact_fraction * layer_dynamic_stiffness(state.stretch, f, self.params, ratio)
            return z.real, z.imag / (2 * math.pi * f)
        stiffness = self.state(pressure_pa).stiffness_n_m3
        return stiffness * ratio.real, stiffness * ratio.imag / (2 * math.pi * f)

    def foundation_slope(self, pressure_pa, freq_hz) -> tuple[np.ndarray, np.ndarray]:
        """(dk_e/dP in 1/m, dc_e/dP in s/m) at ``pressure_pa`` (Pa) and ``freq_hz`` (Hz).

        Chain rule on k_e = phi(P) K(lambda(P)) Re R:  d(phi K)/dP = phi' K + phi K',
        K' = dK/dP = P''(lambda) / (h0 T(lambda)) with T = -dP/dlambda.
        """
        f = _check_freq(freq_hz)
        gel = self.params
        p = check_pressure(pressure_pa)
        if self.layer == "dynamic":  # central difference, relative step 1e-6 (1e-9 Pa near 0)
            h = np.maximum(1e-6 * p, 1e-9)
            (k1, c1), (k0, c0) = self.foundation(p + h, f), self.foundation(np.maximum(p - h, 0.0), f)
            width = p + h - np.maximum(p - h, 0.0)
            return (k1 - k0) / width, (c1 - c0) / width
        lam = stretch_from_pressure(p, gel)
        tangent = gent_tangent_pa(lam, gel)
        stiffness = tangent / gel.thickness_m
        stiffness_slope = gent_curvature_pa(lam, gel) / (gel.thickness_m * tangent)
        slope = contact_fraction_slope(p, gel) * stiffness + contact_fraction(p, gel) * stiffness_slope
        ratio = complex(self.modulus_ratio(f))
        return slope * ratio.real, slope * ratio.imag / (2 * math.pi * f)

    def pressure_from_indentation(self, indentation_m) -> np.ndarray:
        """Quasi-static pressure (Pa) that compresses the gel by ``indentation_m`` (m).

        This is the pad's force law per unit area for the physics engine: P = Gent(1 - d/h0).
        Indentations at or past the locking thickness raise a ValueError (the housing must
        take the load before that).
        """
        d = np.asarray(indentation_m, float)
        lam = 1.0 - np.clip(d, 0.0, None) / self.params.thickness_m
        if np.any(lam <= self.params.locking_stretch):
            raise ValueError(f"indentation {float(np.max(d))!r} m reaches the gel's locking thickness")
        return gent_pressure_pa(lam, self.params)
