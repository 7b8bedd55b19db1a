# The C types of _rows.py (its one source; piezotip.sensor.compiled explains the kernels).
cimport cython

cimport piezotip.sensor._kernel_helpers as kh

cdef Py_ssize_t _OBSERVATION_AT[5]
cdef Py_ssize_t _SIGNAL_AT[2]
cdef Py_ssize_t _READING_AT[4]
cdef Py_ssize_t _ESTIMATE_AT[3]
cdef Py_ssize_t _NORMAL_SLOT


@cython.final
cdef class RowBuilder:
    cdef object _args  # the constructor's arguments, for copies
    cdef list _pads
    cdef long long[::1] _contact_adr, _normals
    cdef Py_ssize_t _left, _right, _table_normal, _normal_slots
    cdef bint _track_peaks
    cdef double[::1] _fractions
    cdef double _stop_pa, _gel_valid_pa, _backstop_pa, _outside
    cdef dict _status_index
    cdef double[::1] _xpos, _qvel, _sensordata
    cdef bint _bound

    @cython.locals(found=Py_ssize_t, k=Py_ssize_t, at=Py_ssize_t, force=double, sx=double, sy=double, sz=double, horizontal=double)
    cdef double _tilt(self, long long adr) except? -2.0

    @cython.locals(
        vx=double, vy=double, vz=double, wx=double, wy=double, wz=double, row=list, k=Py_ssize_t, i=Py_ssize_t,
        profile=list, covered=list, p=double, top=double, cell=double, code=double,
    )
    cpdef list row(self, time_s, obs, command, list profiles, list cells, finger_peaks)


@cython.locals(i=Py_ssize_t, j=Py_ssize_t, row=object, out="double[:, ::1]")
cpdef stack_rows(list rows, Py_ssize_t n_columns)
