# The C types of _period.py (its one source; piezotip.sensor.compiled explains the kernels).
cimport cython

cimport piezotip.sensor._kernel_helpers as kh


@cython.final
cdef class PeriodPhysics:
    cdef object _args  # the constructor's arguments, for copies
    cdef bint _bound, _every, _track
    cdef Py_ssize_t _substeps, _lift, _peak_left, _peak_right
    cdef long _no_sensors
    cdef long long[::1] _fingers
    cdef double[::1] _starts, _deltas
    cdef object _model, _data, _opt, _step, _gel
    cdef double[::1] _ctrl, _sensordata, _qpos, _qvel
    cdef int[:] _warnings  # strided: a field of MuJoCo's warning records
    cdef readonly double left_peak, right_peak

    @cython.locals(n=Py_ssize_t, i=Py_ssize_t, start=double, end=double)
    cpdef bint run_drive(self, double lift_from, double lift_to, fingers_from, fingers_to) except -1

    cpdef bint run(self, double lift_from, double lift_to, double finger_from, double finger_to) except -1

    @cython.locals(
        last=Py_ssize_t, delta=double, flags=long, inner=long, left_peak=double, right_peak=double, k=Py_ssize_t, i=Py_ssize_t,
        value=double, ctrl="double[::1]",
    )
    cdef bint _period(self, double lift_from, double lift_to, Py_ssize_t n) except -1

    @cython.locals(i=Py_ssize_t)
    cpdef bint stable(self) except -1
