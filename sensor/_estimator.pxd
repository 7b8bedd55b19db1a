# The C types of _estimator.py (its one source; sensor/compiled.py explains the kernels).
cimport cython

cimport piezotip.sensor._kernel_helpers as kh

cdef double _GAIN_FLOOR
cdef Py_ssize_t _ESTIMATE_AT[3]
cdef int _OK, _BELOW, _SATURATED_AT
cdef double _NAN, _INF


@cython.final
cdef class InverseCore:
    cdef object _args  # the constructor's arguments, for copies
    cdef double[::1] _neg_v, _log_p, _dv_dlogp
    cdef double _v_first, _v_last, _slope0, _sigma, _p_min, _p_max, _three_sigma

    @cython.locals(drop=double, below_scale=double, g=double, log_p=double, p=double, slope=double)
    cpdef (double, double, int) infer(self, double v1, double gain) except *

    @cython.locals(p=double, sigma=double, status=int)
    cpdef object inferred(self, double v1, double gain)


cpdef object estimate(double pressure_pa, double uncertainty_pa, int status)
