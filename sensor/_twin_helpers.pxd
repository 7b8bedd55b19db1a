# cython: language_level=3
"""What the compiled twins (sensor/_*.pyx) share: Python's float semantics in C, and tables
copied into C arrays.  Inline functions, compiled into each twin that cimports them."""

from cpython.mem cimport PyMem_Malloc
from libc.math cimport exp, isfinite, isinf


cdef inline double fdiv(double a, double b) except? -1.0:
    """a / b as Python's float division (ZeroDivisionError for b == 0)."""
    if b == 0.0:
        raise ZeroDivisionError("float division by zero")
    return a / b


cdef inline double exp_py(double x) except? -1.0:
    """math.exp(x) (OverflowError where a finite x overflows)."""
    cdef double r = exp(x)
    if isinf(r) and isfinite(x):
        raise OverflowError("math range error")
    return r


cdef inline double *copy_doubles(list values) except NULL:
    """A C array of the floats ``values`` (PyMem_Malloc'd: the caller frees it)."""
    cdef double *out = <double *> PyMem_Malloc(max(len(values), 1) * sizeof(double))
    cdef Py_ssize_t i
    if out == NULL:
        raise MemoryError()
    for i in range(len(values)):
        out[i] = values[i]
    return out


cdef inline Py_ssize_t bisect_right(const double *a, Py_ssize_t n, double x) noexcept:
    """bisect.bisect_right on a C array of n sorted floats."""
    cdef Py_ssize_t lo = 0, hi = n, mid
    while lo < hi:
        mid = (lo + hi) // 2
        if x < a[mid]:
            hi = mid
        else:
            lo = mid + 1
    return lo
