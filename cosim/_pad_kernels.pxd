# The C types of _pad_kernels.py (its one source; piezotip.sensor.compiled explains the kernels).
cimport cython



@cython.final
cdef class UniformPairTable:
    cdef object _args  # the constructor's arguments, for copies
    cdef double[::1] _grid, _fa, _fb, _fa_slope, _fb_slope
    cdef double _x0, _xn, _inv_step
    cdef Py_ssize_t _last

    @cython.locals(j=Py_ssize_t, dx=double)
    cpdef (double, double) at(self, double x) noexcept


@cython.final
cdef class GelForces:
    cdef object _args  # the constructor's arguments, for copies
    cdef UniformPairTable _table
    cdef Py_ssize_t _n
    cdef long long[::1] _qadr, _dof, _jnt
    cdef double[::1] _area, _qspring
    cdef double[::1] _qpos, _qfrc, _stiffness
    cdef bint _bound

    @cython.locals(i=Py_ssize_t, q=double, pressure=double, tangent=double, area=double, k=double)
    cpdef apply(self)


@cython.final
cdef class PadPressures:
    cdef object _args
    cdef UniformPairTable _table
    cdef Py_ssize_t _per_pad
    cdef long long[::1] _qadr, _element, _cell_start, _term_at
    cdef double[::1] _term_weight, _values
    cdef double[::1] _qpos
    cdef bint _bound

    @cython.locals(values="double[::1]", i=Py_ssize_t, pad=Py_ssize_t, start=Py_ssize_t, c=Py_ssize_t, j=Py_ssize_t, total=double, profiles=list, covered=list, cells=list)
    cpdef tuple read(self)
