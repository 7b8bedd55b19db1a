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

from _twin_helpers cimport UniformPairs, uniform_pairs_at, uniform_pairs_free, uniform_pairs_from

from . import lookup as _py


cdef class UniformPairTable:
    """The compiled :class:`sensor.lookup.PyUniformPairTable` (see there): two columns over an
    evenly spaced grid, looked up at one float, exactly ``np.interp`` of each."""

    cdef UniformPairs _t
    cdef object _args  # the constructor's arguments, for copies

    def __dealloc__(self):
        uniform_pairs_free(&self._t)

    def __init__(self, grid, fa, fb):
        reference = _py.PyUniformPairTable(grid, fa, fb)  # checks the input and tabulates the slopes
        self._args = (grid, fa, fb)
        uniform_pairs_free(&self._t)
        uniform_pairs_from(&self._t, reference)

    cpdef tuple at(self, double x):
        """(fa(x), fb(x)), exactly ``np.interp`` of the two columns."""
        cdef double a, b
        uniform_pairs_at(&self._t, x, &a, &b)
        return a, b

    def __reduce__(self):
        return UniformPairTable, self._args

