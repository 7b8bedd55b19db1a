# The C types of _estimator.py (its one source; sensor/compiled.py explains the kernels).
cimport cython

cimport piezotip.sensor._kernel_helpers as kh

cdef double _GAIN_FLOOR
cdef Py_ssize_t _ESTIMATE_AT[3]


@cython.final
cdef class InverseCore:
    cdef object _args  # the constructor's arguments, for copies
    cdef double[::1] _neg_v, _log_p, _dv_dlogp
    cdef double _v_first, _v_last, _slope0, _sigma, _p_min, _p_max, _three_sigma

    @cython.locals(drop=double, below_scale=double, g=double, log_p=double, p=double, slope=double)
    cpdef object inferred(self, double v1, double gain)
