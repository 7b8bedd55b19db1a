"""The inverse's per-reading core: the estimate of an inferred steady reading (see :mod:`sensor.estimator`).

A kernel (:mod:`sensor.compiled`): this module runs as Python and, where built, compiled
(``_estimator.pxd`` types it).  The readout inverts an inferred steady reading of every pad
every control step: two table lookups (:func:`sensor.lookup.interp`), an exponential and the
status rules of :meth:`sensor.estimator.ModeInverse.inferred`.
"""

from __future__ import annotations

import math
from array import array

from piezotip.sensor import _kernel_helpers as kh
from piezotip.sensor import inference
from piezotip.sensor.estimator import Estimate

#: An "ok" estimate's uncertainty never reports less than this many single readings' noise.
_GAIN_FLOOR = inference.GAIN_FLOOR
#: Where each field of an Estimate is written (pressure_pa, uncertainty_pa, status).
_ESTIMATE_AT = kh.slot_offsets(Estimate, 3)
#: An estimate's statuses (:class:`sensor.estimator.Estimate`), by the index the kernels carry.
STATUSES = ("ok", "below_detection", "saturated", "settling")
OK, BELOW_DETECTION, SATURATED, SETTLING = range(4)
# (The same, as this kernel's own C ints where compiled: the names above stay Python's.)
_OK, _BELOW, _SATURATED_AT = OK, BELOW_DETECTION, SATURATED
_NAN, _INF = math.nan, math.inf  # (compiled, C doubles: no lookup of math's)


class InverseCore:
    """The per-reading part of :meth:`sensor.estimator.ModeInverse.inferred`.

    The curve is one mode's V_1 (dimensionless) against log P (P in Pa), monotone falling:
    ``neg_v`` (-V_1, increasing), ``log_p`` and ``dv_dlogp`` (dV_1 / d ln P), sequences of floats;
    ``v_first`` and ``v_last`` its ends; ``slope0`` the unloaded |dV_1/dP| (1/Pa); ``sigma`` a
    reading's noise (V_1 units); ``p_min_pa`` and ``p_max_pa`` the mode's limits, Pa.
    """

    __slots__ = ("_args", "_dv_dlogp", "_log_p", "_neg_v", "_p_max", "_p_min", "_sigma", "_slope0", "_three_sigma", "_v_first", "_v_last")

    def __init__(self, neg_v, log_p, dv_dlogp, v_first, v_last, slope0, sigma, p_min_pa, p_max_pa) -> None:
        self._args = (neg_v, log_p, dv_dlogp, v_first, v_last, slope0, sigma, p_min_pa, p_max_pa)
        # The curve as arrays of C doubles (compiled, read as they are).
        self._neg_v, self._log_p, self._dv_dlogp = array("d", neg_v), array("d", log_p), array("d", dv_dlogp)
        if not 2 <= len(self._neg_v) == len(self._log_p) == len(self._dv_dlogp):
            lengths = (len(self._neg_v), len(self._log_p), len(self._dv_dlogp))
            raise ValueError(f"an inverse needs columns of one length, 2 or more, got lengths {lengths}")
        self._v_first, self._v_last, self._slope0 = float(v_first), float(v_last), float(slope0)
        self._sigma, self._p_min, self._p_max = float(sigma), float(p_min_pa), float(p_max_pa)
        self._three_sigma = 3.0 * self._sigma

    def infer(self, v1: float, gain: float) -> tuple[float, float, int]:
        """:meth:`inferred`'s values, no record made: (pressure_pa, uncertainty_pa, the status's
        index in :data:`STATUSES`)."""
        drop = 1.0 - v1
        below_scale = gain if gain > 1.0 else 1.0
        if drop < self._three_sigma * below_scale:
            return max(drop, 0.0) / self._slope0, self._p_min * below_scale, _BELOW
        g = gain if gain > _GAIN_FLOOR else _GAIN_FLOOR
        if v1 <= self._v_last:
            return _NAN, _NAN, _SATURATED_AT
        if v1 >= self._v_first:
            return drop / self._slope0, g * self._sigma / self._slope0, _OK
        log_p = kh.interp(-v1, self._neg_v, self._log_p)
        p = kh.exp(log_p)
        if not p <= self._p_max:
            return _NAN, _NAN, _SATURATED_AT
        slope = abs(kh.interp(log_p, self._log_p, self._dv_dlogp)) / p
        return p, g * self._sigma / slope if slope > 0 else _INF, _OK

    def inferred(self, v1: float, gain: float) -> Estimate:
        """:meth:`sensor.estimator.ModeInverse.inferred` (see there): the estimate of an
        inferred steady reading ``v1`` whose noise is ``gain`` times a reading's."""
        p, sigma, status = self.infer(v1, gain)
        return estimate(p, sigma, status)

    def __reduce__(self):
        return type(self), self._args


def estimate(pressure_pa: float, uncertainty_pa: float, status: int) -> Estimate:
    """The :class:`sensor.estimator.Estimate` of an estimate's values (:meth:`InverseCore.infer`'s;
    ``status`` an index in :data:`STATUSES`)."""
    return kh.record3(Estimate, _ESTIMATE_AT, pressure_pa, uncertainty_pa, STATUSES[status])
