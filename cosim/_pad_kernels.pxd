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
cdef class PassiveGelForces:
    cdef object _args  # the constructor's arguments, for copies
    cdef UniformPairTable _table
    cdef Py_ssize_t _n
    cdef long long[::1] _qadr, _dof, _jnt
    cdef double[::1] _area, _gel_mass, _gel_damping, _q0, _p0, _k0, _last_q
    cdef double _h, _h2
    cdef double[::1] _qpos, _passive, _spring, _stiffness, _armature, _damping
    cdef bint _bound

    cdef void _check_bound(self) except *
    @cython.locals(i=Py_ssize_t)
    cpdef scale_masses(self, stiffness_n_m)
    @cython.locals(dof=Py_ssize_t)
    cdef void _scale(self, Py_ssize_t i, double k) noexcept
    @cython.locals(i=Py_ssize_t, q=double, moved=bint)
    cpdef bint changed(self) except -1
    @cython.locals(i=Py_ssize_t, q=double, pressure=double, tangent=double)
    cpdef linearize(self)
    @cython.locals(i=Py_ssize_t)
    cpdef stiffness(self, bint held)
    @cython.locals(i=Py_ssize_t, q=double, pressure=double, tangent=double, k=double, force=double, dof=Py_ssize_t)
    cpdef apply(self, bint implicit, bint held)


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
