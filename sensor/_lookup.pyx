# cython: language_level=3, cdivision=True
"""The pads' gel-law table lookup, compiled: :class:`sensor.lookup.PyUniformPairTable` in C.

The co-simulation looks the gel's law up once per pad strip per control step (twice with the
gel law applied every step): in Python each lookup cost about 0.6 us, most of a control step's
pressure stage.  This class is the Python reference's twin, the same arithmetic in the same
order (the interval from one multiplication, corrected by the grid's own values; slope times
offset plus value, no fused multiply-add), so its results are the reference's bit for bit
(tests/test_channel_perf_equivalence.py checks both against ``np.interp``).  The tables are
built by the reference's own code (numpy), then copied into C arrays.
"""

from cpython.mem cimport PyMem_Free
from libc.math cimport NAN

from _twin_helpers cimport copy_doubles

from . import lookup as _py


cdef class UniformPairTable:
    """The compiled :class:`sensor.lookup.PyUniformPairTable` (see there): two columns over an
    evenly spaced grid, looked up at one float, exactly ``np.interp`` of each."""

    cdef double *_grid  # the grid and a sentinel (inf) past its end
    cdef double *_fa
    cdef double *_fb
    cdef double *_fa_slope
    cdef double *_fb_slope
    cdef Py_ssize_t _n
    cdef double _x0, _xn, _inv_step
    cdef object _args  # the constructor's arguments, for copies

    def __dealloc__(self):
        PyMem_Free(self._grid)
        PyMem_Free(self._fa)
        PyMem_Free(self._fb)
        PyMem_Free(self._fa_slope)
        PyMem_Free(self._fb_slope)

    def __init__(self, grid, fa, fb):
        reference = _py.PyUniformPairTable(grid, fa, fb)  # checks the input and tabulates the slopes
        self._args = (grid, fa, fb)
        self._n = len(reference._fa)
        self._grid = copy_doubles(reference._grid)
        self._fa, self._fb = copy_doubles(reference._fa), copy_doubles(reference._fb)
        self._fa_slope, self._fb_slope = copy_doubles(reference._fa_slope), copy_doubles(reference._fb_slope)
        self._x0, self._xn, self._inv_step = reference._x0, reference._xn, reference._inv_step

    cpdef tuple at(self, double x):
        """(fa(x), fb(x)), exactly ``np.interp`` of the two columns."""
        cdef Py_ssize_t j
        cdef double dx
        if x > self._x0:
            if x < self._xn:
                j = <Py_ssize_t> ((x - self._x0) * self._inv_step)  # at most one past the last interval
                while x < self._grid[j]:
                    j -= 1
                while x >= self._grid[j + 1]:
                    j += 1
                dx = x - self._grid[j]
                return self._fa_slope[j] * dx + self._fa[j], self._fb_slope[j] * dx + self._fb[j]
            return self._fa[self._n - 1], self._fb[self._n - 1]
        if x <= self._x0:
            return self._fa[0], self._fb[0]
        return NAN, NAN

    def __reduce__(self):
        return UniformPairTable, self._args

