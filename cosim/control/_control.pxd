# The C types of _control.py (its one source; piezotip.sensor.compiled explains the kernels).
cimport cython

cimport piezotip.sensor._kernel_helpers as kh

cdef Py_ssize_t _PAD_SIGNAL_AT[2]
cdef Py_ssize_t _OBSERVATION_AT[7]
cdef Py_ssize_t _COMMAND_AT[6]
cdef Py_ssize_t _WHY_AT[2]

cdef object _why(str template, tuple args)


@cython.final
cdef class ModeSelector:
    cdef public tuple modes, bands
    cdef public object fingertip
    cdef public dict p_min_pa, p_max_pa, switch_pa
    cdef public double hysteresis, estimate_pa, uncertainty_pa
    cdef public int persist, mode
    cdef public bint blind, trusted
    cdef public str status
    cdef readonly dict _neighbours
    cdef readonly int _saturated, _above_switch, _under_switch

    @cython.locals(status=str, pressure=double, up=object, down=object, up_pa=double, down_pa=double, p=double, h=double, above=bint, under=bint)
    cpdef tuple update(self, estimate)

    @cython.locals(old=int)
    cdef tuple _switch(self, int mode, str why)


@cython.final
cdef class TouchDetector:
    cdef public double sigma, drift_sigma, alarm_sigma, single_sigma, baseline, score
    cdef public bint touched
    cdef readonly double _sum, _armed_sum
    cdef readonly Py_ssize_t _count, _armed_count

    cpdef learn(self, double v1)

    @cython.locals(drop=double)
    cpdef bint update(self, double v1) except -1
