"""The bimorph sensor element: parameters, section properties and the loaded response.

Physics reference: ``shared/physics.md`` sections 1 to 3, which restate Motoo, Arai and
Fukuda, "Piezoelectric vibration-type tactile sensor with wide measurement range using
elasticity and viscosity change", IEEE Sensors Journal 7(7), 2007.  Equation numbers
(eq. N) are the paper's.

The element's outputs are the paper's eqs. 13 and 17 to 21, written once as functions of the
gel's modal loads in :mod:`sensor.equations` (in the paper's order, each naming its equation
and units); the methods here supply those loads (kappa = b k_e A_x / A_L, gamma likewise, from
the mode shapes of :mod:`sensor.modes`) and the element's omega_n, c and coupling.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, fields

import numpy as np

from .equations import normalized_output, phase_rad, sensed_voltage_v, sensitivity_c, sensitivity_k, unloaded_voltage_v
from .modes import Boundary, ModeShape, check_mode, mode_shape

VACUUM_PERMITTIVITY_F_PER_M = 8.8541878128e-12


def _require_positive(obj: object) -> None:
    """Raise a ValueError naming the first field of ``obj`` that is not positive and finite."""
    for f in fields(obj):  # type: ignore[arg-type]
        value = getattr(obj, f.name)
        if isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(value, bool):
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f"{type(obj).__name__}.{f.name} must be positive and finite, got {value!r}")


@dataclass(frozen=True)
class ElementParams:
    """Geometry and materials of the bimorph element; defaults are the paper's Table I.

    Attributes
    ----------
    width_m : beam width b, m (5 mm).
    length_m : beam length L, m (7.5 mm).
    substrate_half_thickness_m : t_s, HALF the titanium substrate thickness, m (25 um).
    pzt_thickness_m : t_p, thickness of each PZT layer, m (200 um).
    substrate_youngs_pa, substrate_density_kg_m3 : titanium Y_s (105 GPa), rho_s (4500 kg/m^3).
    pzt_youngs_pa, pzt_density_kg_m3 : PZT C-6 Y_p (62 GPa), rho_p (7650 kg/m^3).
    d31_m_per_v : magnitude of the piezoelectric constant d31, m/V (210 pm/V).
    pzt_relative_permittivity : eps_p, dimensionless (2130).
    capacitance_f : sensing capacitance C, F (3.54 nF; equals eps0 eps_p b L / t_p).
    drive_voltage_v : drive voltage V, volts peak-to-peak (10 V); the output of
        :meth:`SensorElement.output_voltage` is in the same measure (the model is linear).
    damping_n_s_per_m2 : the element's viscous damping c per unit length, N s/m^2 (0.05).
        Table I's value read per unit length implies Q of several thousand (physics.md
        section 6); :meth:`with_quality_factor` sets a realistic Q instead.
    """

    width_m: float = 5e-3
    length_m: float = 7.5e-3
    substrate_half_thickness_m: float = 25e-6
    pzt_thickness_m: float = 200e-6
    substrate_youngs_pa: float = 105e9
    substrate_density_kg_m3: float = 4500.0
    pzt_youngs_pa: float = 62e9
    pzt_density_kg_m3: float = 7650.0
    d31_m_per_v: float = 210e-12
    pzt_relative_permittivity: float = 2130.0
    capacitance_f: float = 3.54e-9
    drive_voltage_v: float = 10.0
    damping_n_s_per_m2: float = 0.05

    def __post_init__(self) -> None:
        _require_positive(self)

    @property
    def bending_stiffness_n_m2(self) -> float:
        """EI of the symmetric three-layer section, N m^2 (physics.md section 1).

        EI = b [ Y_s (2 t_s)^3 / 12 + (2/3) Y_p ((t_s + t_p)^3 - t_s^3) ].
        """
        b, ts, tp = self.width_m, self.substrate_half_thickness_m, self.pzt_thickness_m
        return b * (self.substrate_youngs_pa * (2 * ts) ** 3 / 12 + (2 / 3) * self.pzt_youngs_pa * ((ts + tp) ** 3 - ts**3))

    @property
    def mass_per_length_kg_m(self) -> float:
        """rho A = b (2 t_s rho_s + 2 t_p rho_p), kg/m (physics.md section 1)."""
        b = self.width_m
        return b * (2 * self.substrate_half_thickness_m * self.substrate_density_kg_m3 + 2 * self.pzt_thickness_m * self.pzt_density_kg_m3)

    @property
    def plate_capacitance_f(self) -> float:
        """Parallel-plate capacitance of one PZT layer, eps0 eps_p b L / t_p, in F."""
        return VACUUM_PERMITTIVITY_F_PER_M * self.pzt_relative_permittivity * self.width_m * self.length_m / self.pzt_thickness_m


def _as_load(name: str, value: np.ndarray | float) -> np.ndarray:
    """A float array of a gel load; NaN, infinite or negative values raise a ValueError."""
    arr = np.asarray(value, dtype=float)
    bad = ~np.isfinite(arr) | (arr < 0)
    if np.any(bad):
        first = arr[bad].flat[0]
        raise ValueError(f"{name} must be finite and non-negative, got {first!r}")
    return arr


@dataclass(frozen=True)
class ModeTrim:
    """How one mode of a particular element departs from beam theory with its ElementParams.

    A physical unit's modes do not sit exactly where eq. 12's beam puts them (thickness and
    clamp variations move each mode a little differently), and a calibrated model of a unit
    carries what calibration measured per mode.  Each factor is dimensionless, 1 = none.

    Attributes
    ----------
    freq_factor : factor on the natural angular frequency omega_n.
    gain_factor : factor on eq. 17's amplitude (so on V_0): the electrode's coupling to this mode.
    load_factor : factor on the gel's modal load on this mode (A_x / A_L, so kappa and gamma):
        what a known-load calibration fits for the gel's thickness and coverage, which act on
        a Winkler layer only through this product (k_e ~ 1 / h0, kappa ~ A_x).
    """

    freq_factor: float = 1.0
    gain_factor: float = 1.0
    load_factor: float = 1.0

    def __post_init__(self) -> None:
        _require_positive(self)


_NO_TRIM = ModeTrim()


class SensorElement:
    """The piezoelectric bimorph element driven at one bending resonance.

    Parameters
    ----------
    params : ElementParams, default Table I.
    boundary : "clamped-free" (default, the paper's cantilever), "simply-supported" or
        "clamped-clamped".
    trims : per-mode departures from beam theory, {mode: ModeTrim} (default none: every mode
        exactly where eqs. 12-21 put it).
    **overrides : any ElementParams field, e.g. ``damping_n_s_per_m2=1e-3``.

    Every output method takes k_e (N/m^3) and c_e (N s/m^3) as scalars or arrays that
    broadcast together, a ``mode`` (1, 2, 3, ...) and a ``coverage`` ``(x1_m, x2_m)``, the
    part of the beam under the gel (default: the whole beam).
    """

    def __init__(
        self,
        params: ElementParams | None = None,
        boundary: Boundary | str = Boundary.CLAMPED_FREE,
        trims: Mapping[int, ModeTrim] | None = None,
        **overrides: float,
    ) -> None:
        base = params or ElementParams()
        if overrides:
            valid = {f.name for f in fields(ElementParams)}
            unknown = sorted(set(overrides) - valid)
            if unknown:
                raise ValueError(f"unknown element parameter(s) {unknown}; valid: {sorted(valid)}")
            base = ElementParams(**{**{f.name: getattr(base, f.name) for f in fields(base)}, **overrides})
        self.params = base
        self.boundary = Boundary.parse(boundary)
        trims = dict(trims or {})
        for mode, trim in trims.items():
            check_mode(mode)
            if not isinstance(trim, ModeTrim):
                raise ValueError(f"trims must map modes to ModeTrim, got {trim!r} for mode {mode}")
        # Sorted (mode, trim) pairs without the identity trims: equal elements, equal tuples.
        self.trims: tuple[tuple[int, ModeTrim], ...] = tuple(sorted((m, t) for m, t in trims.items() if t != ModeTrim()))
        self._trims = dict(self.trims)
        self._ratio_cache: dict[tuple[int, float, float], float] = {}

    def __repr__(self) -> str:
        trims = f", trims={dict(self.trims)!r}" if self.trims else ""
        return f"SensorElement(boundary={self.boundary.value!r}, params={self.params!r}{trims})"

    def config_key(self) -> tuple:
        """Every parameter the element's outputs depend on, hashable (params, boundary, trims)."""
        return (self.params, self.boundary, self.trims)

    def trim(self, mode: int) -> ModeTrim:
        """Mode ``mode``'s ModeTrim (the identity when it has none)."""
        return self._trims.get(mode, _NO_TRIM)

    # -- modes -------------------------------------------------------------------------

    def mode_shape(self, mode: int) -> ModeShape:
        """Mode ``mode``'s shape Z_n(x), normalized so that A_L = L (physics.md section 2)."""
        return mode_shape(self.boundary, check_mode(mode), self.params.length_m)

    def natural_angular_frequency(self, mode: int) -> float:
        """omega_n = (beta_n L)^2 / L^2 sqrt(EI / rho A), rad/s (physics.md section 2)."""
        p = self.params
        beta_l = self.mode_shape(mode).beta_l
        omega = beta_l**2 / p.length_m**2 * math.sqrt(p.bending_stiffness_n_m2 / p.mass_per_length_kg_m)
        return omega * self._trims[mode].freq_factor if mode in self._trims else omega

    def natural_frequency_hz(self, mode: int) -> float:
        """Natural frequency f_n = omega_n / 2 pi of mode ``mode``, Hz."""
        return self.natural_angular_frequency(mode) / (2 * math.pi)

    def quality_factor(self, mode: int) -> float:
        """Unloaded Q_n = omega_n rho A / c (dimensionless) of the modal equation (eq. 4)."""
        p = self.params
        return self.natural_angular_frequency(mode) * p.mass_per_length_kg_m / p.damping_n_s_per_m2

    def modal_mass_kg(self, mode: int) -> float:
        """Modal mass M_n = rho A A_L, kg, for the A_L = L normalization."""
        return self.params.mass_per_length_kg_m * self.params.length_m

    def with_quality_factor(self, q: float, mode: int = 1) -> SensorElement:
        """A copy whose damping c gives unloaded quality factor ``q`` in ``mode``."""
        if not (math.isfinite(q) and q > 0):
            raise ValueError(f"quality factor must be positive and finite, got {q!r}")
        p = self.params
        c = self.natural_angular_frequency(mode) * p.mass_per_length_kg_m / q
        return SensorElement(p, self.boundary, dict(self.trims), damping_n_s_per_m2=c)

    def coverage_ratio(self, mode: int, coverage: tuple[float, float] | None = None) -> float:
        """A_x / A_L for gel over ``coverage`` = (x1_m, x2_m), dimensionless in [0, 1] (times the
        mode's ``ModeTrim.load_factor``, when it has one)."""
        x1, x2 = self._check_coverage(coverage)
        key = (check_mode(mode), x1, x2)
        if key not in self._ratio_cache:
            shape = self.mode_shape(mode)
            self._ratio_cache[key] = float(shape.square_integral(x1, x2)) / self.params.length_m
        ratio = self._ratio_cache[key]
        return ratio * self._trims[mode].load_factor if mode in self._trims else ratio

    def cell_ratios(self, mode: int, edges_m: np.ndarray) -> np.ndarray:
        """Per-cell ``integral_cell Z_n^2 dx / A_L`` for cells between ``edges_m`` (m).

        With these, a load sampled per cell (k_e constant on each cell) has
        kappa = b sum(k_e_i r_i); a uniform load over cells spanning [x1, x2] sums to exactly
        ``b k_e A_x / A_L`` because the cell integrals telescope.
        """
        edges = np.asarray(edges_m, dtype=float)
        if edges.ndim != 1 or edges.size < 2 or np.any(np.diff(edges) <= 0):
            raise ValueError(f"edges_m must be a strictly increasing 1-D array of at least 2 positions, got {edges_m!r}")
        self._check_coverage((edges[0], edges[-1]))
        ratios = self.mode_shape(mode).square_integral(edges[:-1], edges[1:]) / self.params.length_m
        return ratios * self._trims[mode].load_factor if mode in self._trims else ratios

    def _check_coverage(self, coverage: tuple[float, float] | None) -> tuple[float, float]:
        length = self.params.length_m
        if coverage is None:
            return (0.0, length)
        try:
            x1, x2 = (float(v) for v in coverage)
        except (TypeError, ValueError):
            raise ValueError(f"coverage must be a pair (x1_m, x2_m), got {coverage!r}") from None
        # Allow rounding at the ends (coverage given in mm and converted, for instance).
        tol = 1e-12 * length
        if not (math.isfinite(x1) and math.isfinite(x2) and -tol <= x1 < x2 <= length + tol):
            raise ValueError(f"coverage must satisfy 0 <= x1 < x2 <= L = {length} m, got ({x1!r}, {x2!r})")
        return (max(x1, 0.0), min(x2, length))

    # -- the loaded element --------------------------------------------------------------

    def modal_load(self, k_e, c_e, mode: int, coverage: tuple[float, float] | None = None) -> tuple[np.ndarray, np.ndarray]:
        """(kappa N/m^2, gamma N s/m^2) of a uniform gel (k_e N/m^3, c_e N s/m^3) over ``coverage``."""
        k_e = _as_load("k_e", k_e)
        c_e = _as_load("c_e", c_e)
        b_ratio = self.params.width_m * self.coverage_ratio(mode, coverage)
        return b_ratio * k_e, b_ratio * c_e

    def modal_load_profile(self, k_e_cells, c_e_cells, mode: int, edges_m) -> tuple[np.ndarray, np.ndarray]:
        """(kappa, gamma) of a gel whose k_e, c_e vary along the beam, one value per cell.

        ``k_e_cells`` and ``c_e_cells`` have shape ``(..., n_cells)`` with cells between
        ``edges_m`` (n_cells + 1 positions, m); the modal integrals of physics.md section 3
        (beyond the paper) become ``b sum_i k_e_i integral_cell_i Z_n^2 dx / A_L``.
        """
        ratios = self.cell_ratios(mode, edges_m)
        k_e = _as_load("k_e", k_e_cells)
        c_e = _as_load("c_e", c_e_cells)
        if k_e.shape[-1:] != ratios.shape or c_e.shape[-1:] != ratios.shape:
            raise ValueError(
                f"k_e_cells and c_e_cells need {ratios.size} values on their last axis, got shapes {k_e.shape} and {c_e.shape}"
            )
        b = self.params.width_m
        return b * (k_e @ ratios), b * (c_e @ ratios)

    def _omega_c(self, mode: int) -> tuple[float, float]:
        return self.natural_angular_frequency(mode), self.params.damping_n_s_per_m2

    def normalized_output(self, k_e, c_e, mode: int = 1, coverage: tuple[float, float] | None = None) -> np.ndarray:
        """Eq. 19: V_1 = V_s / V_0, dimensionless in (0, 1]; 1 means unloaded."""
        kappa, gamma = self.modal_load(k_e, c_e, mode, coverage)
        return normalized_output(kappa, gamma, *self._omega_c(mode))

    def normalized_output_from_modal(self, kappa, gamma, mode: int = 1) -> np.ndarray:
        """Eq. 19 from generalized loads (kappa N/m^2, gamma N s/m^2), e.g. of a profile."""
        return normalized_output(np.asarray(kappa, float), np.asarray(gamma, float), *self._omega_c(mode))

    def phase(self, k_e, c_e, mode: int = 1, coverage: tuple[float, float] | None = None) -> np.ndarray:
        """Eq. 13: the output's phase lag phi, radians in (0, pi/2]; pi/2 when unloaded."""
        kappa, gamma = self.modal_load(k_e, c_e, mode, coverage)
        return phase_rad(kappa, gamma, *self._omega_c(mode))

    def sensitivity_k(self, k_e, c_e, mode: int = 1, coverage: tuple[float, float] | None = None) -> np.ndarray:
        """Eq. 20: S_k = -dV_1/dk_e, m^3/N."""
        kappa, gamma = self.modal_load(k_e, c_e, mode, coverage)
        b_ratio = self.params.width_m * self.coverage_ratio(mode, coverage)
        return sensitivity_k(kappa, gamma, *self._omega_c(mode), b_ratio)

    def sensitivity_c(self, k_e, c_e, mode: int = 1, coverage: tuple[float, float] | None = None) -> np.ndarray:
        """Eq. 21: S_c = -dV_1/dc_e, m^3/(N s)."""
        kappa, gamma = self.modal_load(k_e, c_e, mode, coverage)
        b_ratio = self.params.width_m * self.coverage_ratio(mode, coverage)
        return sensitivity_c(kappa, gamma, *self._omega_c(mode), b_ratio)

    def coupling_factor_per_m2(self, mode: int) -> float:
        """[integral_0^L Z_n'' dx] [Z_n'(L) - Z_n'(0)] for the A_L = L normalization, 1/m^2.

        Eq. 17 as printed multiplies by [Z_n(0) - Z_n(L)], which leaves its right-hand side a
        length short of a voltage (V m).  A drive electrode over the whole beam applies a
        uniform bending moment, whose generalized force on mode n is proportional to the
        slope difference Z_n'(L) - Z_n'(0) (the same factor as the sensing layer's
        integral of curvature); with that factor eq. 17 is in volts.  Both factors vanish for
        a fully electroded clamped-clamped beam and for even simply supported modes: those
        modes are not excited by a full-length electrode, and their absolute voltage is 0.
        """
        shape = self.mode_shape(mode)
        slope_diff = float(shape.derivative(self.params.length_m, 1) - shape.derivative(0.0, 1))
        # The slopes are O(beta); a difference at rounding level is an exact zero (a clamped
        # end, or an even simply supported mode), not a tiny coupling.
        if abs(slope_diff) < 1e-9 * shape.beta_per_m:
            return 0.0
        return slope_diff * slope_diff

    def _gain_factor(self, mode: int) -> float:
        return self._trims[mode].gain_factor if mode in self._trims else 1.0

    def unloaded_voltage(self, mode: int = 1) -> float:
        """Eq. 18: V_0, eq. 17's amplitude with k_e = c_e = 0, volts (drive V in the same measure)."""
        check_mode(mode)
        return unloaded_voltage_v(self.params, self.coupling_factor_per_m2(mode), *self._omega_c(mode), self._gain_factor(mode))

    def output_voltage(self, k_e, c_e, mode: int = 1, coverage: tuple[float, float] | None = None) -> np.ndarray:
        """Eq. 17: amplitude |V_s| of the sensed voltage, volts (same measure as the drive).

        |V_s| = b^2 Y_p^2 d31^2 V (2 t_s + t_p)^2 F_n / (4 C A_L sqrt(kappa^2 + omega^2 (gamma + c)^2))
        with F_n the coupling factor of :meth:`coupling_factor_per_m2` (see there for the one
        deviation from the printed equation) and A_L = L.
        """
        kappa, gamma = self.modal_load(k_e, c_e, mode, coverage)
        return sensed_voltage_v(self.params, self.coupling_factor_per_m2(mode), kappa, gamma, *self._omega_c(mode), self._gain_factor(mode))
