"""The estimator: the one pressure inverse of the readout, and the tables it reads.

From a reading of V_1 (eq. 19) in mode n to the pressure estimate, its uncertainty and its
status (physics.md section 5), for a uniform pressure over the gel's coverage:

- :class:`FoundationTable`: (k_e, c_e) against pressure per mode, tabulated (the gel model is
  the slow part of a sample);
- :class:`ModeInverse`: the inverse of one mode's forward curve V_1(P), tabulated once and read
  by table lookup on the co-simulation's per-step path (:meth:`ModeInverse.__call__` for a
  settled reading, :meth:`ModeInverse.inferred` for a steady reading inferred by
  :mod:`sensor.inference`); :meth:`ModeInverse.polished` is the same inverse (its table, its
  limits, its status rules) refined by Newton's method on the exact forward model, for arrays:
  :meth:`sensor.Fingertip.estimate` is that, with the exact gel (:func:`exact_estimate`);
- :class:`CalibratedInverse`: a :class:`ModeInverse` whose uncertainty also carries what
  calibration left unknown (:mod:`sensor.calibration`);
- :func:`mode_tables`, :func:`foundation_table`: each computed once per process and fingertip
  configuration, and kept on disk (:mod:`sensor.cache`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from .cache import disk_cached
from .cache import enabled as cache_enabled
from .compiled import is_compiled, record_maker, source_module
from .lookup import interp, interp_pair
from .readout import DETECTION_SIGMAS, PressureEstimate

if TYPE_CHECKING:
    from .fingertip import Fingertip

#: Pressure table for the fast path, Pa: log-spaced, 60 points per decade.
_TABLE_P = np.logspace(-3, 7, 601)
_log, _exp = math.log, math.exp


class FoundationTable:
    """(k_e, c_e) against pressure for one mode, tabulated in log-log and interpolated.

    Below the table's first pressure both are linear in P (the contact fraction is), so the
    first point's ratio extrapolates exactly.  The interpolation error (1e-4 relative,
    tests/test_channel.py) is what the presets without ``exact_gel`` pay.
    """

    def __init__(self, fingertip: Fingertip, mode: int) -> None:
        def compute() -> dict[str, np.ndarray]:
            k, c = fingertip.foundation(_TABLE_P, mode)
            return {"k": k, "c": c}

        # Computed once per configuration and kept on disk (piezotip.sensor.cache).
        columns = disk_cached("foundation-table", (fingertip.config_key(), mode), compute)
        k, c = columns["k"], columns["c"]
        if np.any(k <= 0):
            raise ValueError("FoundationTable needs a positive k_e (the Winkler layer); use exact=True for the dynamic layer")
        self._log_p = np.log(_TABLE_P)
        self._log_k = np.log(k)
        self._log_c = np.log(c)
        self._k0, self._c0 = k[0] / _TABLE_P[0], c[0] / _TABLE_P[0]
        self._p0 = _TABLE_P[0]
        # For :meth:`at`: the columns as lists, Python floats.
        self._k0_f, self._c0_f, self._p0_f = float(self._k0), float(self._c0), float(self._p0)
        self._log_p_list = self._log_p.tolist()
        self._log_k_list = self._log_k.tolist()
        self._log_c_list = self._log_c.tolist()

    def __call__(self, pressure_pa: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        p = np.asarray(pressure_pa, float)
        lp = np.log(np.maximum(p, self._p0))
        k = np.exp(np.interp(lp, self._log_p, self._log_k))
        c = np.exp(np.interp(lp, self._log_p, self._log_c))
        low = p < self._p0
        if np.any(low):
            k = np.where(low, p * self._k0, k)
            c = np.where(low, p * self._c0, c)
        return k, c

    def at(self, pressure_pa: float) -> tuple[float, float]:
        """(k_e, c_e) at one pressure (a float, Pa): :meth:`__call__`'s table and formulas, one
        interval search for both, in Python floats (equal to ``__call__`` within rounding)."""
        p = pressure_pa
        if p < self._p0_f:
            return p * self._k0_f, p * self._c0_f
        log_k, log_c = interp_pair(_log(p), self._log_p_list, self._log_k_list, self._log_c_list)
        return _exp(log_k), _exp(log_c)


@dataclass(frozen=True, slots=True)
class Estimate:
    """The readout's pressure estimate from one reading (what a controller may use).

    Attributes
    ----------
    pressure_pa : estimate, Pa (NaN when saturated or settling).
    uncertainty_pa : one standard deviation of the estimate, Pa (NaN when unknown).
    status : "ok", "below_detection" (within 3 sigma of unloaded: P is below the mode's
        P_min, reported as the estimate clipped at >= 0), "saturated" (past the mode's P_max)
        or "settling" (the resonator has not settled since the last switch or load step).
    """

    pressure_pa: float
    uncertainty_pa: float
    status: str


#: ``Estimate(...)`` for the per-step path (positional, every field; see sensor.resonator._reading).
_estimate = record_maker(Estimate)


_SETTLING = _estimate(math.nan, math.nan, "settling")
_SATURATED = _estimate(math.nan, math.nan, "saturated")


class ModeInverse:
    """Fast inverse of one mode's uniform-pressure response: V_1 -> P by table lookup.

    The forward curve is tabulated once on the channel's log-pressure grid; a reading is
    inverted by linear interpolation in log P (the curve is monotone), its uncertainty from
    the tabulated slope.  Status thresholds are the fingertip's P_min and P_max of the mode.
    A call works on Python floats (the tables as lists; the same interpolation as np.interp).
    """

    def __init__(self, fingertip: Fingertip, mode: int, table: FoundationTable | None) -> None:
        def compute() -> dict[str, np.ndarray]:
            if table is None:
                v = fingertip.output(_TABLE_P, mode)
            else:
                k, c = table(_TABLE_P)
                v = fingertip.element.normalized_output(k, c, mode, fingertip.coverage)
            return {
                "v": v,
                "sigma": np.array(fingertip.sigma(mode)),
                "p_min_pa": np.array(fingertip.detection_limit(mode)),
                "p_max_pa": np.array(fingertip.upper_limit(mode)),
                "slope0": np.array(abs(float(fingertip.output_slope(0.0, mode)))),
            }

        # Computed once per configuration, mode and gel evaluation, kept on disk (the table, when
        # there is one, is the same configuration's and mode's).
        numbers = disk_cached("mode-inverse", (fingertip.config_key(), mode, table is None), compute)
        p, v = _TABLE_P, numbers["v"]
        # The inverse exists while the output falls with pressure; past the first rise (the
        # dynamic layer's resonances, deep in saturation) every reading counts as saturated.
        rising = np.nonzero(np.diff(v) > 1e-12)[0]
        if rising.size:
            p, v = p[: rising[0] + 1], v[: rising[0] + 1]
        self._neg_v = -v  # increasing, for np.interp
        self._log_p = np.log(p)
        self._dv_dlogp = np.gradient(v, self._log_p)
        self.sigma = float(numbers["sigma"])
        self.p_min_pa = float(numbers["p_min_pa"])
        self.p_max_pa = float(numbers["p_max_pa"])
        self._v_first, self._v_last = float(v[0]), float(v[-1])
        #: The mode's output V_1 at P_max (dimensionless; from the table, as the inverse reads it).
        self.v_at_p_max = float(np.interp(math.log(self.p_max_pa), self._log_p, v)) if self.p_max_pa > 0 else self._v_last
        self._slope0 = float(numbers["slope0"])
        self._neg_v_list = self._neg_v.tolist()
        self._sigma_f, self._p_min_f, self._p_max_f = float(self.sigma), float(self.p_min_pa), float(self.p_max_pa)
        self._three_sigma = 3.0 * self._sigma_f
        self._log_p_list = self._log_p.tolist()
        self._dv_dlogp_list = self._dv_dlogp.tolist()
        self._core = InverseCore(
            self._neg_v_list,
            self._log_p_list,
            self._dv_dlogp_list,
            self._v_first,
            self._v_last,
            self._slope0,
            self._sigma_f,
            self._p_min_f,
            self._p_max_f,
        )

    def __call__(self, v1: float, settled: bool = True) -> Estimate:
        if not settled:
            return _estimate(math.nan, math.nan, "settling")
        if 1.0 - v1 < self._three_sigma:
            p = max(1.0 - v1, 0.0) / self._slope0
            return _estimate(p, self._p_min_f, "below_detection")
        if v1 <= self._v_last:
            return _estimate(math.nan, math.nan, "saturated")
        if v1 >= self._v_first:
            p = (1.0 - v1) / self._slope0
            return _estimate(p, self._sigma_f / self._slope0, "ok")
        log_p = interp(-v1, self._neg_v_list, self._log_p_list)
        p = math.exp(log_p)
        if not p <= self._p_max_f:
            return _estimate(math.nan, math.nan, "saturated")
        slope = abs(interp(log_p, self._log_p_list, self._dv_dlogp_list)) / p
        return _estimate(p, self._sigma_f / slope if slope > 0 else math.inf, "ok")

    def pressure(self, v1: float) -> float:
        """The inverse alone, Pa: the pressure whose uniform load reads ``v1`` in this mode
        (linear in the first pressure's slope above the table's first point, as the estimates
        are), NaN past the table's last (saturated) point.  No status, no uncertainty: for
        measuring the inverse's accuracy against a known pressure."""
        if v1 <= self._v_last:
            return math.nan
        if v1 >= self._v_first:
            return max(1.0 - v1, 0.0) / self._slope0
        return math.exp(interp(-v1, self._neg_v_list, self._log_p_list))

    def inferred(self, v1: float, gain: float) -> Estimate:
        """The estimate of an inferred steady reading ``v1`` whose noise is ``gain`` times a
        reading's: as :meth:`__call__` with sigma scaled by max(gain, 1) for the below-detection
        test (within 3 scaled sigma of unloaded; its uncertainty is the scaled detection limit)
        and by max(gain, GAIN_FLOOR) for the uncertainty of an "ok" estimate
        (:class:`InverseCore`, compiled where built)."""
        return self._core.inferred(v1, gain)

    def polished(self, fingertip: Fingertip, mode: int, v1) -> PressureEstimate:
        """The same inverse for an array of readings ``v1`` (V_1, dimensionless), polished on the
        exact forward model: the table's pressure refined by three Newton steps on
        ``fingertip.output`` (eq. 19) with its analytic slope, the uncertainty sigma / |dV_1/dP|
        at the polished pressure (Pa).  The status rules are :meth:`__call__`'s: within
        3 sigma of unloaded "below_detection" (uncertainty P_min), at or past the table's last
        point or past P_max "saturated" (NaN), above the table's first point linear in the
        unloaded slope.  Slow (the gel model per reading); ``fingertip`` and ``mode`` must be
        the ones this inverse was built for.
        """
        v = np.asarray(v1, dtype=float)
        p = np.exp(np.interp(-v, self._neg_v, self._log_p))
        inside = (v < self._v_first) & (v > self._v_last)
        for _ in range(3):
            step = (fingertip.output(p, mode) - v) / fingertip.output_slope(p, mode)
            p = np.where(inside, np.clip(p - step, 0.5 * p, 2.0 * p), p)
        # Above the table's first point the response is linear in P (phi ~ P): invert the slope.
        p = np.where(v >= self._v_first, np.maximum(1.0 - v, 0.0) / self._slope0, p)
        uncertainty = self.sigma / np.abs(fingertip.output_slope(p, mode))
        below = (1.0 - v) < DETECTION_SIGMAS * self.sigma
        saturated = ~below & ((v <= self._v_last) | ~(p <= self.p_max_pa))
        status = np.where(below, "below_detection", np.where(saturated, "saturated", "ok"))
        uncertainty = np.where(below, self.p_min_pa, uncertainty)
        return PressureEstimate(
            pressure_pa=np.where(saturated, np.nan, p),
            uncertainty_pa=np.where(saturated, np.nan, uncertainty),
            status=status,
        )


class CalibratedInverse(ModeInverse):
    """A :class:`ModeInverse` whose "ok" estimates also carry calibration's error.

    ``rel_sigma`` (on the channel's pressure table) is the estimate's relative standard
    deviation from what calibration did not measure or measured with noise
    (:func:`sensor.calibration.model_uncertainty`); it is added in quadrature to the noise's
    uncertainty of every "ok" estimate.
    """

    def __init__(self, fingertip: Fingertip, mode: int, table: FoundationTable | None, rel_sigma: np.ndarray) -> None:
        super().__init__(fingertip, mode, table)
        self._rel_log_p = np.log(_TABLE_P).tolist()
        self._rel = np.asarray(rel_sigma, float).tolist()

    def _with_model(self, est: Estimate) -> Estimate:
        if est.status != "ok":
            return est
        p = est.pressure_pa
        rel = interp(math.log(p), self._rel_log_p, self._rel) if p > 0 else 0.0
        return _estimate(p, math.hypot(est.uncertainty_pa, rel * p), "ok")

    def __call__(self, v1: float, settled: bool = True) -> Estimate:
        return self._with_model(super().__call__(v1, settled))

    def inferred(self, v1: float, gain: float) -> Estimate:
        return self._with_model(super().inferred(v1, gain))


_MODE_TABLES: dict[tuple, tuple] = {}


def mode_tables(fingertip: Fingertip, mode: int, exact: bool) -> tuple[FoundationTable | None, ModeInverse]:
    """One mode's (k_e, c_e) table (None for the exact gel) and its inverse, computed once per
    process for each fingertip configuration (:meth:`Fingertip.config_key`), mode and gel
    evaluation: every channel of every run with that fingertip shares them (both are read-only
    after construction)."""
    key = (fingertip.config_key(), mode, bool(exact))
    if key not in _MODE_TABLES or not cache_enabled():
        table = None if exact else foundation_table(fingertip, mode)
        _MODE_TABLES[key] = (table, ModeInverse(fingertip, mode, table))
    return _MODE_TABLES[key]


_FOUNDATION_TABLES: dict[tuple, FoundationTable] = {}


def foundation_table(fingertip: Fingertip, mode: int) -> FoundationTable:
    """One mode's (k_e, c_e) table alone (a physical unit's: the simulation needs no inverse of
    it), once per process for each fingertip configuration and mode."""
    key = (fingertip.config_key(), mode)
    if key not in _FOUNDATION_TABLES or not cache_enabled():
        _FOUNDATION_TABLES[key] = FoundationTable(fingertip, mode)
    return _FOUNDATION_TABLES[key]


def exact_estimate(fingertip: Fingertip, v1, mode: int) -> PressureEstimate:
    """The exact inverse of readings ``v1`` of V_1 in ``mode`` (a checked mode): the exact-gel
    :class:`ModeInverse` of ``fingertip``, polished (:meth:`ModeInverse.polished`)."""
    return mode_tables(fingertip, mode, exact=True)[1].polished(fingertip, mode, v1)


# The inverses' per-reading core (:meth:`ModeInverse.inferred`), a kernel: sensor/_estimator.py,
# compiled where built (sensor.compiled).  Imported last: it reads Estimate from this module.
from . import _estimator  # noqa: E402
from ._estimator import InverseCore  # noqa: E402

#: Whether :class:`InverseCore` runs compiled (sensor/_estimator.py built), not as Python.
INVERSE_COMPILED = is_compiled(_estimator)


def __getattr__(name: str):
    if name == "PyInverseCore":  # the kernel's source run as Python, loaded when asked for
        return source_module(_estimator.__name__).InverseCore
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
