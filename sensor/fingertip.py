"""The fingertip: element + gel + readout, from pressure to reading and back.

``Fingertip`` composes :class:`sensor.SensorElement`, :class:`sensor.gel.GelModel` and
:class:`sensor.readout.NoiseParams` and computes what physics.md section 5 defines:
per-mode outputs against pressure, resolution, detection and upper limits, the inverse
(the estimator's, :mod:`sensor.estimator`),
the dynamic range and the pressures at which the most useful mode changes.

Pressure is force over the element's face (b x L), in Pa, as the paper defines it.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence

import numpy as np

from .element import SensorElement
from .estimator import exact_estimate
from .gel import GelModel, check_pressure
from .modes import check_mode
from .numerics import brentq
from .readout import DETECTION_SIGMAS, RESOLVED_FRACTION, NoiseParams, PressureEstimate, output_sigma
from .stress import Mounting, StressReport, stress_report

#: The pressure grid used to tabulate and search, Pa: from far below any detection limit
#: to beyond the 1.3 MPa proof load.  ~40 points per decade.
_GRID_DECADES = (-4.0, 6.5)
_GRID_POINTS = 421


def range_within_model(p_min_pa: float, p_max_pa: float, model_limit_pa: float) -> dict:
    """The range a fingertip measures within its model, as the range report's keys.

    ``p_max_within_model_pa``: P_max, capped at where the model ends (``model_limit_pa``,
    :meth:`Fingertip.model_limit`); ``dynamic_range``: that over P_min; and
    ``dynamic_range_beyond_model``: P_max / P_min, the resolution criterion's figure alone, whose
    top may lie past the backstop or the gel's valid strain (4.6x past the backstop with the gel
    over the whole beam).  NaN where a limit is missing (no P_max, or no P_min: infinite), and
    ``dynamic_range`` NaN too where P_min itself lies past the model's end (a strip of gel at
    the clamp: nothing it detects is within the model).
    """
    top = math.nan if math.isnan(p_max_pa) else min(p_max_pa, model_limit_pa)

    def over_p_min(p: float) -> float:
        return p / p_min_pa if math.isfinite(p_min_pa) else math.nan

    within = over_p_min(top) if top > p_min_pa else math.nan
    return {"p_max_within_model_pa": top, "dynamic_range": within, "dynamic_range_beyond_model": over_p_min(p_max_pa)}


class Fingertip:
    """A fingertip that turns pressure (Pa) into normalized outputs V_1 per mode, and back.

    Parameters
    ----------
    element : SensorElement (default: Table I cantilever).
    gel : GelModel (default: 5 mm urethane gel, frequency dependent).
    coverage : (x1_m, x2_m) of the gel on the element (default: the whole beam).
    noise : NoiseParams (default: 1e-3 relative, 1 mV absolute).
    modes : the vibration modes the drive can select (default 1 to 4, as in the paper).
    rated_pressure_pa : the pressure the fingertip is rated for, Pa (default 1 MPa); the
        upper limit P_max is at most this.
    mounting : how the element is held (stress checks, physics.md section 7).
    """

    def __init__(
        self,
        element: SensorElement | None = None,
        gel: GelModel | None = None,
        coverage: tuple[float, float] | None = None,
        noise: NoiseParams | None = None,
        modes: Sequence[int] = (1, 2, 3, 4),
        rated_pressure_pa: float = 1e6,
        mounting: Mounting | None = None,
    ) -> None:
        self.element = element or SensorElement()
        self.gel = gel or GelModel()
        self.coverage = self.element._check_coverage(coverage)
        self.noise = noise or NoiseParams()
        self.modes = tuple(check_mode(m) for m in modes)
        if not self.modes:
            raise ValueError("modes must name at least one mode")
        if not (math.isfinite(rated_pressure_pa) and rated_pressure_pa > 0):
            raise ValueError(f"rated_pressure_pa must be positive and finite, got {rated_pressure_pa!r}")
        self.rated_pressure_pa = float(rated_pressure_pa)
        self.mounting = mounting or Mounting()

    def __repr__(self) -> str:
        return f"Fingertip(modes={self.modes}, coverage_m={self.coverage}, rated_pressure_pa={self.rated_pressure_pa})"

    def config_key(self) -> tuple:
        """Every parameter the fingertip's outputs depend on, as one hashable value (all of them
        immutable): equal keys, equal fingertips (a cache of derived tables keys on it)."""
        return (*self.element.config_key(), self.gel, self.coverage, self.noise, self.modes, self.rated_pressure_pa, self.mounting)

    # -- forward model ---------------------------------------------------------------

    def _mode(self, mode: int) -> int:
        mode = check_mode(mode)
        if mode not in self.modes:
            raise ValueError(f"mode {mode} is not one of this fingertip's modes {self.modes}")
        return mode

    def freq_hz(self, mode: int) -> float:
        """Drive frequency of ``mode``: the unloaded natural frequency, Hz."""
        return self.element.natural_frequency_hz(self._mode(mode))

    def foundation(self, pressure_pa, mode: int = 1) -> tuple[np.ndarray, np.ndarray]:
        """(k_e N/m^3, c_e N s/m^3) the gel presents to ``mode`` at ``pressure_pa`` (Pa)."""
        return self.gel.foundation(pressure_pa, self.freq_hz(mode))

    def modal_load(self, pressure_pa, mode: int = 1) -> tuple[np.ndarray, np.ndarray]:
        """(kappa N/m^2, gamma N s/m^2) of a uniform pressure over the coverage.

        kappa = b k_e A_x / A_L, gamma = b c_e A_x / A_L; kappa carries the sign of k_e (the
        dynamic layer's mass-like, negative k_e enters eq. 10 as it is).
        """
        k_e, c_e = self.foundation(pressure_pa, mode)
        b_ratio = self.element.params.width_m * self.element.coverage_ratio(mode, self.coverage)
        return b_ratio * k_e, b_ratio * c_e

    def output(self, pressure_pa, mode: int = 1) -> np.ndarray:
        """Normalized output V_1 (eq. 19, dimensionless) at uniform ``pressure_pa`` (Pa)."""
        kappa, gamma = self.modal_load(pressure_pa, mode)
        return self.element.normalized_output_from_modal(kappa, gamma, mode)

    def output_slope(self, pressure_pa, mode: int = 1) -> np.ndarray:
        """dV_1/dP, 1/Pa (negative): -(S_k dk_e/dP + S_c dc_e/dP), eqs. 20, 21 and the gel's slope.

        For a layer whose k_e takes either sign (the dynamic layer's: :attr:`sensor.gel.GelLayer.signed_stiffness`)
        the chain rule is taken on eq. 19 directly:
        dV/dP = -V (kappa kappa' + omega^2 (gamma + c) gamma') / h^2, h = hypot(kappa, omega (gamma + c)).
        """
        if self.gel.law.signed_stiffness:
            kappa, gamma = self.modal_load(pressure_pa, mode)
            dk, dc = self.gel.foundation_slope(pressure_pa, self.freq_hz(mode))
            b_ratio = self.element.params.width_m * self.element.coverage_ratio(mode, self.coverage)
            omega, c = self.element.natural_angular_frequency(mode), self.element.params.damping_n_s_per_m2
            h2 = kappa**2 + (omega * (gamma + c)) ** 2
            v = omega * c / np.sqrt(h2)
            return -v * (kappa * b_ratio * dk + omega**2 * (gamma + c) * b_ratio * dc) / h2
        k_e, c_e = self.foundation(pressure_pa, mode)
        dk, dc = self.gel.foundation_slope(pressure_pa, self.freq_hz(mode))
        s_k = self.element.sensitivity_k(k_e, c_e, mode, self.coverage)
        s_c = self.element.sensitivity_c(k_e, c_e, mode, self.coverage)
        return -(s_k * dk + s_c * dc)

    def load_factor_slope_per_pa(self, pressure_pa: float = 0.0, mode: int = 1) -> complex:
        """d mu / dP, 1/Pa (complex): the slope of the load's complex factor
        mu = 1 / (the steady envelope over the unloaded) = 1 + gamma / c - j kappa / (omega c)
        (eq. 10 inverted: :func:`sensor.equations.normalized_response`) at uniform ``pressure_pa``
        (Pa), the quantity the readout's inference fits (:class:`sensor.inference.SteadyInference`).
        Its imaginary part, the gel's stiffness detuning the mode, is what moves first near no
        load: V_1 = 1 / |mu| moves only to second order in it."""
        mode = self._mode(mode)
        dk, dc = self.gel.foundation_slope(pressure_pa, self.freq_hz(mode))
        b_ratio = self.element.params.width_m * self.element.coverage_ratio(mode, self.coverage)
        omega, c = self.element.natural_angular_frequency(mode), self.element.params.damping_n_s_per_m2
        return complex(b_ratio * float(dc) / c, -b_ratio * float(dk) / (omega * c))

    def envelope_time_constant_s(self) -> float:
        """The unloaded envelope's time constant tau0 = 2 rho A / c, s (physics.md section 6;
        0.66 s with Table I's damping): how slowly a reading follows the load."""
        p = self.element.params
        return 2.0 * p.mass_per_length_kg_m / p.damping_n_s_per_m2

    def sigma(self, mode: int = 1) -> float:
        """Standard deviation of one reading of V_1 in ``mode`` (dimensionless)."""
        return output_sigma(self.noise, self.element.unloaded_voltage(self._mode(mode)))

    def noisy_output(self, pressure_pa, mode: int = 1, rng: np.random.Generator | None = None) -> np.ndarray:
        """One noisy reading of V_1 per pressure: V_1 + N(0, sigma_n^2)."""
        rng = rng or np.random.default_rng()
        v = self.output(pressure_pa, mode)
        return v + rng.normal(0.0, self.sigma(mode), np.shape(v))

    def resolution(self, pressure_pa, mode: int = 1) -> np.ndarray:
        """Resolution dP_n(P) = 3 sigma_n / |dV_n/dP|, Pa (physics.md section 5)."""
        slope = np.abs(self.output_slope(pressure_pa, mode))
        with np.errstate(divide="ignore"):
            return np.where(slope > 0, DETECTION_SIGMAS * self.sigma(mode) / np.maximum(slope, 1e-300), np.inf)

    # -- limits and range ------------------------------------------------------------

    @functools.cached_property
    def _grid_pa(self) -> np.ndarray:
        return np.logspace(*_GRID_DECADES, _GRID_POINTS)

    @functools.cache  # noqa: B019 - a Fingertip is immutable after construction
    def _table(self, mode: int) -> np.ndarray:
        return self.output(self._grid_pa, mode)

    def detection_limit(self, mode: int = 1) -> float:
        """P_min of ``mode``: the pressure that moves V_1 by 3 sigma from unloaded, Pa (inf if none)."""
        return self._detection_limit(self._mode(mode))

    @functools.cache  # noqa: B019 - cached per (validated) int mode
    def _detection_limit(self, mode: int) -> float:
        target = DETECTION_SIGMAS * self.sigma(mode)
        drop = 1.0 - self._table(mode)
        above = np.nonzero(drop >= target)[0]
        if above.size == 0 or self._grid_pa[above[0]] > self.rated_pressure_pa:
            return math.inf
        i = above[0]
        if i == 0:
            return float(self._grid_pa[0])
        lo, hi = math.log(self._grid_pa[i - 1]), math.log(self._grid_pa[i])
        root = brentq(lambda lp: 1.0 - float(self.output(math.exp(lp), mode)) - target, lo, hi, xtol=1e-12)
        return math.exp(root)

    def _resolved_excess(self, log_p: float, mode: int) -> float:
        p = math.exp(log_p)
        return math.log(float(self.resolution(p, mode)) / (RESOLVED_FRACTION * p))

    def upper_limit(self, mode: int = 1) -> float:
        """P_max of ``mode``: the largest P <= rated where dP_n(P) <= 0.1 P, Pa (NaN if nowhere)."""
        return self._upper_limit(self._mode(mode))

    @functools.cache  # noqa: B019 - cached per (validated) int mode
    def _upper_limit(self, mode: int) -> float:
        grid = self._grid_pa[self._grid_pa <= self.rated_pressure_pa]
        grid = np.append(grid, self.rated_pressure_pa)
        ok = np.nonzero(self.resolution(grid, mode) <= RESOLVED_FRACTION * grid)[0]
        if ok.size == 0:
            return math.nan
        i = ok[-1]
        if i == grid.size - 1:
            return self.rated_pressure_pa
        root = brentq(self._resolved_excess, math.log(grid[i]), math.log(grid[i + 1]), args=(mode,), xtol=1e-12)
        return math.exp(root)

    def best_mode(self, pressure_pa) -> np.ndarray:
        """The mode with the finest resolution at each pressure (the most useful mode)."""
        p = check_pressure(pressure_pa)
        res = np.stack([self.resolution(p, m) for m in self.modes])
        return np.asarray(self.modes)[np.argmin(res, axis=0)]

    @functools.cache  # noqa: B019
    def mode_bands(self) -> tuple[tuple[int, float, float], ...]:
        """((mode, from_pa, to_pa), ...): where each mode is the most useful, P_min to P_max.

        The band edges are the switch pressures: where two modes' resolution curves cross
        (found on the grid, refined with brentq on log dP_a - log dP_b).
        """
        p_lo, p_hi = self.sensor_limits()
        if not (p_lo < p_hi):
            return ()
        grid = np.geomspace(p_lo, p_hi, 400)
        best = self.best_mode(grid)
        bands: list[tuple[int, float, float]] = []
        start = p_lo
        for i in np.nonzero(best[1:] != best[:-1])[0]:
            a, b = int(best[i]), int(best[i + 1])

            def diff(lp: float, a: int = a, b: int = b) -> float:
                p = math.exp(lp)
                return math.log(float(self.resolution(p, a))) - math.log(float(self.resolution(p, b)))

            cross = math.exp(brentq(diff, math.log(grid[i]), math.log(grid[i + 1]), xtol=1e-12))
            bands.append((a, start, cross))
            start = cross
        bands.append((int(best[-1]), start, p_hi))
        return tuple(bands)

    def switch_pressures(self) -> list[float]:
        """Pressures (Pa, ascending) at which the most useful mode changes."""
        return [band[2] for band in self.mode_bands()[:-1]]

    def sensor_limits(self) -> tuple[float, float]:
        """(P_min, P_max) of the whole sensor, Pa: the best over its modes."""
        p_min = min(self.detection_limit(m) for m in self.modes)
        uppers = [self.upper_limit(m) for m in self.modes]
        p_max = max((u for u in uppers if not math.isnan(u)), default=math.nan)
        return p_min, p_max

    def dynamic_range(self) -> dict:
        """The sensor's range as a JSON-ready dict (physics.md section 5 definitions).

        Keys: ``p_min_pa``, ``p_max_pa`` (the resolution limits, P_max up to the rating, which
        may lie past the model's end), the range within the model (:func:`range_within_model`:
        ``p_max_within_model_pa``, ``dynamic_range``, ``dynamic_range_beyond_model``),
        ``modes`` (per mode: ``mode``, ``freq_hz``, ``p_min_pa``, ``p_max_pa``, ``sigma_v1``),
        ``switch_pressures_pa``, and ``mode_bands`` (``mode``, ``from_pa``, ``to_pa``),
        ``coverage_m``, ``rated_pressure_pa``, ``backstop_pressure_pa``, and where the model
        ends (:meth:`model_limit`): ``gel_valid_pressure_pa``, ``model_limit_pa`` and
        ``model_limit`` ("backstop" or "gel_strain").  Pressures in Pa, frequencies in Hz.
        """
        p_min, p_max = self.sensor_limits()
        limit_pa, limit = self.model_limit()
        return {
            "p_min_pa": p_min,
            "p_max_pa": p_max,
            **range_within_model(p_min, p_max, limit_pa),
            "modes": [
                {
                    "mode": m,
                    "freq_hz": self.freq_hz(m),
                    "p_min_pa": self.detection_limit(m),
                    "p_max_pa": self.upper_limit(m),
                    "sigma_v1": self.sigma(m),
                }
                for m in self.modes
            ],
            "switch_pressures_pa": self.switch_pressures(),
            "mode_bands": [{"mode": m, "from_pa": lo, "to_pa": hi} for m, lo, hi in self.mode_bands()],
            "coverage_m": list(self.coverage),
            "rated_pressure_pa": self.rated_pressure_pa,
            "backstop_pressure_pa": self.backstop_pressure_pa(),
            "gel_valid_pressure_pa": self.gel.params.max_valid_pressure_pa,
            "model_limit_pa": limit_pa,
            "model_limit": limit,
        }

    def backstop_pressure_pa(self) -> float | None:
        """Pressure at which a backed element touches its backstop, Pa (None if free-span)."""
        if self.mounting.kind != "backed":
            return None
        per_pa = float(self.stress(1.0).max_deflection_m)
        return self.mounting.backstop_gap_m / per_pa

    def model_limit(self) -> tuple[float, str]:
        """(pressure in Pa, why) where the model ends: the lower of the backstop pressure
        ("backstop": above it a backed element rests on its stop, and its vibration is no longer
        the free beam's) and the gel's valid-strain pressure ("gel_strain": above it no simple
        hyperelastic law describes the layer, :attr:`GelParams.max_valid_pressure_pa`).  The
        outputs above it are still computed, but nothing there is a measurement the model
        vouches for."""
        gel_pa = self.gel.params.max_valid_pressure_pa
        backstop_pa = self.backstop_pressure_pa()
        if backstop_pa is not None and backstop_pa <= gel_pa:
            return backstop_pa, "backstop"
        return gel_pa, "gel_strain"

    # -- the inverse -----------------------------------------------------------------

    def estimate(self, v1, mode: int = 1) -> PressureEstimate:
        """Pressure from a reading ``v1`` of V_1 in ``mode``, with uncertainty and status.

        The readout's one inverse (:class:`sensor.estimator.ModeInverse`, with the exact gel),
        polished by Newton's method on the forward model for arrays of readings
        (:meth:`sensor.estimator.ModeInverse.polished`): readings within 3 sigma of unloaded
        are "below_detection" (estimate from the inverse, never negative, with the detection
        limit as uncertainty); estimates past the mode's P_max are "saturated" and NaN.
        """
        mode = self._mode(mode)
        v = np.asarray(v1, dtype=float)
        if np.any(np.isnan(v)):
            raise ValueError("v1 contains NaN")
        return exact_estimate(self, v, mode)

    def estimate_pressure(self, v1, mode: int = 1) -> np.ndarray:
        """Pressure estimate in Pa from a reading of V_1 in ``mode`` (NaN where saturated)."""
        return self.estimate(v1, mode).pressure_pa

    # -- limits of the hardware ---------------------------------------------------------

    def stress(self, pressure_pa) -> StressReport:
        """Bending stress in the PZT at ``pressure_pa`` against its strength (physics.md section 7)."""
        return stress_report(self.element, check_pressure(pressure_pa), self.coverage, self.mounting)
