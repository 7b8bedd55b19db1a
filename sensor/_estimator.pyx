# cython: language_level=3, cdivision=True, boundscheck=False, wraparound=False
"""The inverse's per-reading core, compiled: :class:`sensor.estimator.PyInverseCore` in C.

The readout inverts an inferred steady reading of every pad every control step (two table
lookups by interval search, an exponential, the status rules); in Python that cost about
1.4 us a pad.  This class is the reference's twin, statement for statement, so its estimates
are the reference's bit for bit (tests/test_compiled_twins.py): the lookups are
:func:`sensor.lookup.interp` (``bisect_right``, slope times offset plus value), ``math.exp``
and float division are written out with Python's errors, and ``-ffp-contract=off``
(setup.py) rules out fused multiply-adds.  ``GAIN_FLOOR`` and the :class:`Estimate` record are
read from :mod:`sensor.estimator` when this module is imported.
"""

from cpython.mem cimport PyMem_Free
from libc.math cimport INFINITY, NAN, fabs

from _twin_helpers cimport bisect_right, copy_doubles, exp_py, fdiv, new_record, put_slot, slot_offsets

from . import estimator as _py


cdef double GAIN_FLOOR = _py.GAIN_FLOOR
cdef type Estimate = _py.Estimate
cdef Py_ssize_t[3] _ESTIMATE_AT  # pressure_pa, uncertainty_pa, status: the fields' order
slot_offsets(Estimate, _ESTIMATE_AT, 3)


cdef inline double interp(double x, const double *xp, const double *fp, Py_ssize_t n) noexcept:
    """sensor.lookup.interp(x, xp, fp) on C arrays of n points."""
    cdef Py_ssize_t j
    if x >= xp[n - 1]:
        return fp[n - 1]
    if x >= xp[0]:
        j = bisect_right(xp, n, x) - 1
        return (fp[j + 1] - fp[j]) / (xp[j + 1] - xp[j]) * (x - xp[j]) + fp[j]
    if x < xp[0]:
        return fp[0]
    return NAN


cdef inline object estimate(double pressure_pa, double uncertainty_pa, str status):
    """sensor.estimator._estimate: the Estimate's slots written at once."""
    e = new_record(Estimate)
    put_slot(e, _ESTIMATE_AT[0], pressure_pa)
    put_slot(e, _ESTIMATE_AT[1], uncertainty_pa)
    put_slot(e, _ESTIMATE_AT[2], status)
    return e


cdef class InverseCore:
    """The compiled :class:`sensor.estimator.PyInverseCore` (see there)."""

    cdef double *_neg_v
    cdef double *_log_p
    cdef double *_dv_dlogp
    cdef Py_ssize_t _n
    cdef double _v_first, _v_last, _slope0, _sigma, _p_min, _p_max, _three_sigma
    cdef object _args

    def __dealloc__(self):
        PyMem_Free(self._neg_v)
        PyMem_Free(self._log_p)
        PyMem_Free(self._dv_dlogp)

    def __init__(self, neg_v, log_p, dv_dlogp, v_first, v_last, slope0, sigma, p_min_pa, p_max_pa):
        reference = _py.PyInverseCore(neg_v, log_p, dv_dlogp, v_first, v_last, slope0, sigma, p_min_pa, p_max_pa)  # checks
        self._args = (neg_v, log_p, dv_dlogp, v_first, v_last, slope0, sigma, p_min_pa, p_max_pa)
        self._n = len(reference._neg_v)
        self._neg_v, self._log_p, self._dv_dlogp = copy_doubles(reference._neg_v), copy_doubles(reference._log_p), copy_doubles(reference._dv_dlogp)
        self._v_first, self._v_last, self._slope0 = reference._v_first, reference._v_last, reference._slope0
        self._sigma, self._p_min, self._p_max = reference._sigma, reference._p_min, reference._p_max
        self._three_sigma = reference._three_sigma

    cpdef object inferred(self, double v1, double gain):
        """:meth:`sensor.estimator.ModeInverse.inferred`."""
        cdef double drop = 1.0 - v1
        cdef double below_scale = gain if gain > 1.0 else 1.0
        cdef double g, log_p, p, slope, floor
        if drop < self._three_sigma * below_scale:
            floor = drop
            if 0.0 > floor:  # max(drop, 0.0)
                floor = 0.0
            return estimate(fdiv(floor, self._slope0), self._p_min * below_scale, "below_detection")
        g = gain if gain > GAIN_FLOOR else GAIN_FLOOR
        if v1 <= self._v_last:
            return estimate(NAN, NAN, "saturated")
        if v1 >= self._v_first:
            return estimate(fdiv(drop, self._slope0), fdiv(g * self._sigma, self._slope0), "ok")
        log_p = interp(-v1, self._neg_v, self._log_p, self._n)
        p = exp_py(log_p)
        if not p <= self._p_max:
            return estimate(NAN, NAN, "saturated")
        slope = fdiv(fabs(interp(log_p, self._log_p, self._dv_dlogp, self._n)), p)
        return estimate(p, fdiv(g * self._sigma, slope) if slope > 0 else INFINITY, "ok")

    def __reduce__(self):
        return InverseCore, self._args

