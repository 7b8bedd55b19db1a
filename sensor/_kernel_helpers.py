"""The few operations of the kernels whose compiled form is written out in C, here in Python.

A kernel (:mod:`sensor.compiled`) is Python that Cython compiles; compiled, most of it computes
what Python computes, the same floats.  A few operations it would compile otherwise: complex
division (Cython's own formula rounds differently from CPython's), a complex magnitude (here
``sqrt(x^2 + y^2)``, not CPython's ``hypot``), ``math``'s and ``cmath``'s functions (C's return
inf or NaN where Python raises, or are not called at all), a bisection (Python's ``bisect``
module, called), a record's construction (a Python call), a number made a Python complex
(``as_complex``: compiled, the argument's conversion to a C complex did it; run as Python, a
NumPy scalar would carry NumPy's arithmetic on).  And the table lookups
:func:`interp` and :func:`interp_pair` (:mod:`sensor.lookup`'s, for Python's callers on lists),
which the kernels read on arrays of C doubles.  The kernels call these as ``kh.name(...)``:
run as Python, this module's function; compiled, the inline C function of the same name in
``_kernel_helpers.pxd``, written to round and raise as the Python here does (CPython's own
functions where it has them).  Each C function there says what it mirrors; the kernels'
equivalence tests (tests/test_compiled_twins.py) run both.  This module is not compiled.
"""

from __future__ import annotations

import cmath
import math
from bisect import bisect_right

from .compiled import slot_descriptors

__all__ = [
    "as_complex",
    "atan2",
    "bisect_right",
    "cabs",
    "cexp",
    "cquot",
    "cx",
    "exp",
    "fields",
    "interp",
    "interp_pair",
    "isfinite",
    "log",
    "record",
    "record2",
    "record3",
    "record6",
    "record7",
    "record10",
    "slot_offsets",
    "sqrt",
]


def cquot(a: complex, b: complex) -> complex:
    """``a / b`` for complex (or real) a and b: CPython's ``_Py_c_quot``, ZeroDivisionError for b = 0."""
    return a / b


def cabs(z: complex) -> float:
    """``abs(z)`` of a complex z: CPython's ``_Py_c_abs`` (OverflowError past the largest float)."""
    return abs(z)


def cx(re: float, im: float) -> complex:
    """``complex(re, im)`` of two floats (NumPy's too): a Python complex."""
    return complex(re, im)


# complex(z): a Python complex of the number z (a NumPy complex128 too), what a kernel's C
# ``double complex`` argument is; its arithmetic is then CPython's, as the compiled kernel's is.
as_complex = complex
cexp = cmath.exp  # cmath.exp(z)
exp = math.exp  # math.exp(x): OverflowError past the largest float
log = math.log  # math.log(x): ValueError for x <= 0
sqrt = math.sqrt  # math.sqrt(x): ValueError for x < 0
atan2 = math.atan2  # math.atan2(y, x)
isfinite = math.isfinite  # math.isfinite(x)
# bisect.bisect_right(a, x) on a sorted sequence of floats ``a``: imported above.


def interp(x: float, xp, fp) -> float:
    """``np.interp(x, xp, fp)`` for one float: the same interval, the same arithmetic (slope
    (fp[j+1] - fp[j]) / (xp[j+1] - xp[j]) times (x - xp[j]) plus fp[j]), the same clamping at
    the ends; NaN for NaN.  ``xp`` (strictly increasing) and ``fp`` are lists or arrays of floats
    (:mod:`array`; the compiled kernels' are); units are those of ``fp``."""
    if x >= xp[-1]:
        return fp[-1]
    if x >= xp[0]:
        j = bisect_right(xp, x) - 1
        return (fp[j + 1] - fp[j]) / (xp[j + 1] - xp[j]) * (x - xp[j]) + fp[j]
    if x < xp[0]:
        return fp[0]
    return math.nan


def interp_pair(x: float, xp, fa, fb) -> tuple[float, float]:
    """``(interp(x, xp, fa), interp(x, xp, fb))`` with one interval search for both columns
    (bit for bit the same numbers: two columns of one table, looked up together)."""
    if x >= xp[-1]:
        return fa[-1], fb[-1]
    if x >= xp[0]:
        j = bisect_right(xp, x) - 1
        dx, h = x - xp[j], xp[j + 1] - xp[j]
        return (fa[j + 1] - fa[j]) / h * dx + fa[j], (fb[j + 1] - fb[j]) / h * dx + fb[j]
    if x < xp[0]:
        return fa[0], fb[0]
    return math.nan, math.nan


def slot_offsets(cls: type, n: int, names: tuple[str, ...] = ()) -> list:
    """Where each of the ``n`` fields of the frozen slots dataclass ``cls`` is written, in the
    fields' order, for :func:`record` (or each of the attributes ``names`` of a class with
    ``__slots__``): each slot's setter (compiled: its offset in an instance).

    Raises TypeError for a record of another number of fields, or one whose fields are not slots."""
    setters = [slot.__set__ for slot in slot_descriptors(cls, names)]
    if len(setters) != n:
        raise TypeError(f"{cls.__name__} has {len(setters)} fields, its kernel fills {n}")
    return setters


def record(cls: type, at: list, *values) -> object:
    """An instance of the frozen slots dataclass ``cls`` with ``values`` in its fields, all of
    them, in order (``at`` from :func:`slot_offsets`): each set through its slot, not through
    the constructor (:func:`sensor.compiled.record_maker`; an equal instance).  Or of a class
    with ``__slots__``, the attributes ``at`` names set, its ``__init__`` not called."""
    made = object.__new__(cls)
    for put, value in zip(at, values, strict=True):
        put(made, value)
    return made


# One name per number of fields (compiled, one C function each).
record2 = record3 = record6 = record7 = record10 = record


def fields(record, cls: type, at: list, n: int, get) -> tuple:
    """``get(record)``: the ``n`` attributes of ``record`` that ``get`` (an
    :func:`operator.attrgetter`) names, as a tuple.  Compiled, those of an instance of the slots
    class ``cls`` are read from the slots ``at`` (:func:`slot_offsets` of the same names, in
    their order), a load each where ``getattr`` looks each name up; anything else by name."""
    return get(record)
