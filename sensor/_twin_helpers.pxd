# cython: language_level=3
"""What the compiled twins (sensor/_*.pyx, cosim/_pads.pyx) share: Python's float semantics in
C, tables copied into C arrays, and the pads' uniform-grid lookup.  Inline functions, compiled
into each twin that cimports them."""

from cpython.mem cimport PyMem_Free, PyMem_Malloc
from cpython.ref cimport PyObject, Py_INCREF
from libc.math cimport NAN, exp, isfinite, isinf


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



cdef inline Py_ssize_t *copy_indices(list values) except NULL:
    """A C array of the ints ``values`` (PyMem_Malloc'd: the caller frees it)."""
    cdef Py_ssize_t *out = <Py_ssize_t *> PyMem_Malloc(max(len(values), 1) * sizeof(Py_ssize_t))
    cdef Py_ssize_t i
    if out == NULL:
        raise MemoryError()
    for i in range(len(values)):
        out[i] = values[i]
    return out

cdef struct UniformPairs:
    # sensor.lookup.PyUniformPairTable's numbers: the grid and a sentinel (inf) past its end,
    # the two columns and their slopes per interval.
    double *grid
    double *fa
    double *fb
    double *fa_slope
    double *fb_slope
    Py_ssize_t n
    double x0, xn, inv_step


cdef inline int uniform_pairs_from(UniformPairs *t, object reference) except -1:
    """Copy a PyUniformPairTable's numbers into ``t`` (free them with uniform_pairs_free)."""
    t.grid = t.fa = t.fb = t.fa_slope = t.fb_slope = NULL
    t.n = len(reference._fa)
    t.grid = copy_doubles(reference._grid)
    t.fa, t.fb = copy_doubles(reference._fa), copy_doubles(reference._fb)
    t.fa_slope, t.fb_slope = copy_doubles(reference._fa_slope), copy_doubles(reference._fb_slope)
    t.x0, t.xn, t.inv_step = reference._x0, reference._xn, reference._inv_step
    return 0


cdef inline void uniform_pairs_free(UniformPairs *t) noexcept:
    PyMem_Free(t.grid)
    PyMem_Free(t.fa)
    PyMem_Free(t.fb)
    PyMem_Free(t.fa_slope)
    PyMem_Free(t.fb_slope)
    t.grid = t.fa = t.fb = t.fa_slope = t.fb_slope = NULL


cdef inline void uniform_pairs_at(const UniformPairs *t, double x, double *a, double *b) noexcept:
    """PyUniformPairTable.at(x): (fa(x), fb(x)), exactly np.interp of each column."""
    cdef Py_ssize_t j
    cdef double dx
    if x > t.x0:
        if x < t.xn:
            j = <Py_ssize_t> ((x - t.x0) * t.inv_step)  # at most one past the last interval
            while x < t.grid[j]:
                j -= 1
            while x >= t.grid[j + 1]:
                j += 1
            dx = x - t.grid[j]
            a[0], b[0] = t.fa_slope[j] * dx + t.fa[j], t.fb_slope[j] * dx + t.fb[j]
        else:
            a[0], b[0] = t.fa[t.n - 1], t.fb[t.n - 1]
    elif x <= t.x0:
        a[0], b[0] = t.fa[0], t.fb[0]
    else:
        a[0] = b[0] = NAN


# -- the per-step records (frozen slots dataclasses: sensor.compiled.record_maker) -----------

cdef extern from "structmember.h":
    ctypedef struct PyMemberDef:
        Py_ssize_t offset
    ctypedef struct PyMemberDescrObject:
        PyMemberDef *d_member


cdef extern from "Python.h":
    object PyType_GenericAlloc(type cls, Py_ssize_t nitems)


cdef inline int slot_offsets(type cls, Py_ssize_t *out, Py_ssize_t n) except -1:
    """Each dataclass field's slot offset in ``cls``, in the fields' order, into ``out`` (``n``
    of them: a record with another number of fields, or a field that is not a slot, raises;
    the descriptors and that check are sensor.compiled.slot_descriptors)."""
    from piezotip.sensor.compiled import slot_descriptors

    slots = slot_descriptors(cls)
    if len(slots) != n:
        raise TypeError(f"{cls.__name__} has {len(slots)} fields, its compiled maker fills {n}")
    for i, slot in enumerate(slots):
        out[i] = (<PyMemberDescrObject *> <PyObject *> slot).d_member.offset
    return 0


cdef inline object new_record(type cls):
    """An instance of ``cls`` with every slot empty: fill each with :func:`put_slot` before any
    Python code runs (an empty slot reads as AttributeError)."""
    return PyType_GenericAlloc(cls, 0)


cdef inline void put_slot(object record, Py_ssize_t offset, object value) noexcept:
    """Set an empty slot of a record made by :func:`new_record` (what a slot's descriptor
    does, less its checks): the record holds a new reference to ``value``."""
    Py_INCREF(value)
    (<PyObject **> ((<char *> <PyObject *> record) + offset))[0] = <PyObject *> value
