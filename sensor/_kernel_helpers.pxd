# cython: language_level=3
"""The C of ``_kernel_helpers.py``: what a compiled kernel's ``kh.name(...)`` calls (inline).

Each function computes what its namesake in ``_kernel_helpers.py`` computes, bit for bit, and
raises what it raises: CPython's own C where CPython exports it, else CPython's formula for
the arguments the kernels meet, handing anything else to the Python function itself; the
table lookups (``interp``, ``interp_pair``, ``bisect_right``) on arrays of C doubles.
(setup.py compiles the kernels with ``CYTHON_CCOMPLEX=0``: Cython's ``double complex`` is then
a struct whose sum, difference, product and negation are CPython's formulas, not C99's; and
``-ffp-contract=off``: no fused multiply-adds.)
"""

cimport cython
from cpython.complex cimport Py_complex
from cpython.ref cimport PyObject, Py_INCREF
from cpython.tuple cimport PyTuple_New, PyTuple_SET_ITEM
from libc.math cimport M_PI, NAN, copysign, cos, isinf, isnan, sin
from libc.math cimport atan2 as c_atan2, exp as c_exp, isfinite as c_isfinite, log as c_log, sqrt as c_sqrt


cdef extern from "Python.h":
    Py_complex _Py_c_quot(Py_complex, Py_complex)
    double _Py_c_abs(Py_complex)
    object PyType_GenericAlloc(type cls, Py_ssize_t nitems)


cdef extern from "structmember.h":
    ctypedef struct PyMemberDef:
        Py_ssize_t offset
    ctypedef struct PyMemberDescrObject:
        PyMemberDef *d_member


cdef inline Py_complex _py(double complex z) noexcept:
    cdef Py_complex c
    c.real, c.imag = z.real, z.imag
    return c


cdef inline double complex _cx(double re, double im) noexcept:
    cdef double complex z
    z.real, z.imag = re, im
    return z


cdef inline double complex cx(double re, double im) noexcept:
    """complex(re, im) of two floats."""
    return _cx(re, im)


cdef inline double complex as_complex(double complex z) noexcept:
    """complex(z): the argument's conversion to a C complex (of a Python complex, a NumPy
    complex128, any number) made it; nothing is left to do."""
    return z


cdef inline double complex cquot(double complex a, double complex b) except *:
    """a / b: CPython's complex division (``complex_div``)."""
    cdef Py_complex q
    if b.real == 0.0 and b.imag == 0.0:
        raise ZeroDivisionError("complex division by zero")
    q = _Py_c_quot(_py(a), _py(b))
    return _cx(q.real, q.imag)


cdef inline double cabs(double complex z) except? -1.0:
    """abs(z): CPython's ``complex_abs``."""
    cdef double r = _Py_c_abs(_py(z))
    if isinf(r) and c_isfinite(z.real) and c_isfinite(z.imag):
        raise OverflowError("absolute value too large")
    return r


cdef inline double complex cexp(double complex z) except *:
    """cmath.exp(z): CPython's ``cmath_exp_impl`` for a finite z of real part up to 700 (below
    log(DBL_MAX / 4), where it computes exp(x) (cos y, sin y)); cmath.exp itself otherwise."""
    cdef double m
    if c_isfinite(z.real) and c_isfinite(z.imag) and z.real <= 700.0:
        m = c_exp(z.real)
        return _cx(m * cos(z.imag), m * sin(z.imag))
    import cmath

    w = cmath.exp(complex(z.real, z.imag))
    return _cx(w.real, w.imag)


cdef inline double exp(double x) except? -1.0:
    """math.exp(x): OverflowError where a finite x overflows (``math_1``)."""
    cdef double r = c_exp(x)
    if isinf(r) and c_isfinite(x):
        raise OverflowError("math range error")
    return r


cdef inline double log(double x) except? -1.0:
    """math.log(x) of a float: CPython's ``m_log``, ValueError for x <= 0 and for -inf."""
    if c_isfinite(x):
        if x > 0.0:
            return c_log(x)
        raise ValueError("math domain error")
    if isnan(x) or x > 0.0:
        return x
    raise ValueError("math domain error")


cdef inline bint isfinite(double x) noexcept:
    """math.isfinite(x) of a float."""
    return c_isfinite(x)


cdef inline double sqrt(double x) except? -1.0:
    """math.sqrt(x): ValueError for x < 0 (``math_1``)."""
    if x < 0.0:
        raise ValueError("math domain error")
    return c_sqrt(x)


cdef inline double atan2(double y, double x) noexcept:
    """math.atan2(y, x): CPython's ``m_atan2`` (its own zeros and infinities, then C's)."""
    if isnan(x) or isnan(y):
        return NAN  # Py_NAN: the quiet NaN of positive sign
    if isinf(y):
        if isinf(x):
            return copysign(0.25 * M_PI if copysign(1.0, x) == 1.0 else 0.75 * M_PI, y)
        return copysign(0.5 * M_PI, y)
    if isinf(x) or y == 0.0:
        return copysign(0.0 if copysign(1.0, x) == 1.0 else M_PI, y)
    return c_atan2(y, x)


@cython.boundscheck(False)
@cython.wraparound(False)
cdef inline Py_ssize_t bisect_right(const double[::1] a, double x) noexcept:
    """bisect.bisect_right(a, x) on an array of floats."""
    cdef Py_ssize_t lo = 0, hi = a.shape[0], mid
    while lo < hi:
        mid = (lo + hi) >> 1  # (lo + hi) // 2, both non-negative
        if x < a[mid]:
            hi = mid
        else:
            lo = mid + 1
    return lo


@cython.boundscheck(False)
@cython.wraparound(False)
cdef inline double interp(double x, const double[::1] xp, const double[::1] fp) noexcept:
    """interp(x, xp, fp) on arrays of two or more floats (np.interp: its interval, arithmetic, ends)."""
    cdef Py_ssize_t j, last = xp.shape[0] - 1
    if x >= xp[last]:
        return fp[last]
    if x >= xp[0]:
        j = bisect_right(xp, x) - 1
        return (fp[j + 1] - fp[j]) / (xp[j + 1] - xp[j]) * (x - xp[j]) + fp[j]
    if x < xp[0]:
        return fp[0]
    return NAN


@cython.boundscheck(False)
@cython.wraparound(False)
cdef inline (double, double) interp_pair(double x, const double[::1] xp, const double[::1] fa, const double[::1] fb) noexcept:
    """interp_pair(x, xp, fa, fb) on arrays of two or more floats: one interval for both columns."""
    cdef Py_ssize_t j, last = xp.shape[0] - 1
    cdef double dx, h
    if x >= xp[last]:
        return fa[last], fb[last]
    if x >= xp[0]:
        j = bisect_right(xp, x) - 1
        dx, h = x - xp[j], xp[j + 1] - xp[j]
        return (fa[j + 1] - fa[j]) / h * dx + fa[j], (fb[j + 1] - fb[j]) / h * dx + fb[j]
    if x < xp[0]:
        return fa[0], fb[0]
    return NAN, NAN


# -- the per-step records (frozen slots dataclasses: sensor.compiled.record_maker) -----------


cdef inline list slot_offsets(type cls, Py_ssize_t n, tuple names=()):
    """Each field's slot offset in ``cls``, in the fields' order, or each of the attributes
    ``names``' (``n`` of them: a record with another number of fields, or a field that is not a
    slot, raises; the descriptors and that check are sensor.compiled.slot_descriptors)."""
    from piezotip.sensor.compiled import slot_descriptors

    slots = slot_descriptors(cls, names)
    if len(slots) != n:
        raise TypeError(f"{cls.__name__} has {len(slots)} fields, its kernel fills {n}")
    return [(<PyMemberDescrObject *> <PyObject *> slot).d_member.offset for slot in slots]


cdef inline void _put(object record, Py_ssize_t offset, object value) noexcept:
    # An empty slot of a new record set, as its descriptor would (less its checks): the record
    # holds a new reference to ``value``.
    Py_INCREF(value)
    (<PyObject **> ((<char *> <PyObject *> record) + offset))[0] = <PyObject *> value


cdef inline object record2(type cls, const Py_ssize_t *at, object v0, object v1):
    """record(cls, at, v0, v1): every slot written before any Python code sees the record."""
    r = PyType_GenericAlloc(cls, 0)
    _put(r, at[0], v0)
    _put(r, at[1], v1)
    return r


cdef inline object record3(type cls, const Py_ssize_t *at, object v0, object v1, object v2):
    r = PyType_GenericAlloc(cls, 0)
    _put(r, at[0], v0)
    _put(r, at[1], v1)
    _put(r, at[2], v2)
    return r


cdef inline object record6(type cls, const Py_ssize_t *at, object v0, object v1, object v2, object v3, object v4, object v5):
    r = PyType_GenericAlloc(cls, 0)
    _put(r, at[0], v0)
    _put(r, at[1], v1)
    _put(r, at[2], v2)
    _put(r, at[3], v3)
    _put(r, at[4], v4)
    _put(r, at[5], v5)
    return r


cdef inline object record7(type cls, const Py_ssize_t *at, object v0, object v1, object v2, object v3, object v4, object v5, object v6):
    r = PyType_GenericAlloc(cls, 0)
    _put(r, at[0], v0)
    _put(r, at[1], v1)
    _put(r, at[2], v2)
    _put(r, at[3], v3)
    _put(r, at[4], v4)
    _put(r, at[5], v5)
    _put(r, at[6], v6)
    return r


cdef inline object record10(
    type cls, const Py_ssize_t *at, object v0, object v1, object v2, object v3, object v4, object v5, object v6, object v7, object v8, object v9
):
    r = PyType_GenericAlloc(cls, 0)
    _put(r, at[0], v0)
    _put(r, at[1], v1)
    _put(r, at[2], v2)
    _put(r, at[3], v3)
    _put(r, at[4], v4)
    _put(r, at[5], v5)
    _put(r, at[6], v6)
    _put(r, at[7], v7)
    _put(r, at[8], v8)
    _put(r, at[9], v9)
    return r


cdef inline tuple fields(object record, type cls, const Py_ssize_t *at, Py_ssize_t n, object get):
    """fields(record, cls, at, n, get): an instance of ``cls`` (its type exactly) read from its
    slots, anything else (or a slot left empty: the attribute's own error) through ``get``."""
    cdef PyObject *value
    cdef Py_ssize_t i
    if type(record) is not cls:
        return get(record)
    out = PyTuple_New(n)
    for i in range(n):
        value = (<PyObject **> ((<char *> <PyObject *> record) + at[i]))[0]
        if value is NULL:
            return get(record)
        Py_INCREF(<object> value)  # the tuple takes this reference
        PyTuple_SET_ITEM(out, i, <object> value)
    return out
