# cython: language_level=3, cdivision=True, boundscheck=False, wraparound=False
"""The pads' per-step arithmetic, compiled: :mod:`cosim.pad_kernels`' references in C.

:class:`GelForces` and :class:`PadPressures` mirror :class:`cosim.pad_kernels.PyGelForces` and
:class:`cosim.pad_kernels.PyPadPressures` statement for statement (the lookup is
:class:`sensor.lookup.PyUniformPairTable`'s, shared with ``sensor/_lookup.pyx``; Python's
``max(p, 0.0)`` and ``sum`` of floats in their order; no fused multiply-adds), so their
results are the references' bit for bit (tests/test_compiled_twins.py).  The arrays are bound
once as typed memoryviews (indices checked there, by the reference's own check) and read and
written directly.
"""

from cpython.mem cimport PyMem_Free

from _twin_helpers cimport UniformPairs, copy_doubles, copy_indices, uniform_pairs_at, uniform_pairs_free, uniform_pairs_from

from piezotip.sensor import lookup as _lookup


def _reference():
    # Imported when first needed, not with this module (see cosim/_rows.pyx).
    from . import pad_kernels

    return pad_kernels


cdef class GelForces:
    """The compiled :class:`cosim.pad_kernels.PyGelForces` (see there)."""

    cdef UniformPairs _t
    cdef Py_ssize_t _n
    cdef Py_ssize_t *_qadr
    cdef Py_ssize_t *_dof
    cdef Py_ssize_t *_jnt
    cdef double *_area
    cdef double *_qspring
    cdef double[::1] _qpos, _qfrc, _stiffness
    cdef bint _bound
    cdef object _args, _reference

    def __dealloc__(self):
        uniform_pairs_free(&self._t)
        PyMem_Free(self._qadr)
        PyMem_Free(self._dof)
        PyMem_Free(self._jnt)
        PyMem_Free(self._area)
        PyMem_Free(self._qspring)

    def __init__(self, table, qadr, dof, jnt, area_m2, qspring_m):
        reference = _reference().PyGelForces(table, qadr, dof, jnt, area_m2, qspring_m)  # checks
        self._args, self._reference = (table, qadr, dof, jnt, area_m2, qspring_m), reference
        strips = reference._strips
        self._n = len(strips)
        uniform_pairs_from(&self._t, _lookup.PyUniformPairTable(*table))
        self._qadr = copy_indices([s[0] for s in strips])
        self._dof = copy_indices([s[1] for s in strips])
        self._jnt = copy_indices([s[2] for s in strips])
        self._area = copy_doubles([s[3] for s in strips])
        self._qspring = copy_doubles([s[4] for s in strips])
        self._bound = False

    def bind(self, qpos, qfrc_applied, jnt_stiffness):
        """Work on these arrays from now on (see the reference)."""
        self._reference.bind(qpos, qfrc_applied, jnt_stiffness)  # the same checks, the same errors
        self._qpos, self._qfrc, self._stiffness = qpos, qfrc_applied, jnt_stiffness
        self._bound = True

    def apply(self):
        """Write each strip joint's stiffness and applied force for the state in ``qpos``."""
        cdef Py_ssize_t i
        cdef double q, pressure, tangent, k, area
        if not self._bound:
            raise RuntimeError("bind() the arrays first")
        for i in range(self._n):
            q = self._qpos[self._qadr[i]]
            uniform_pairs_at(&self._t, q, &pressure, &tangent)
            area = self._area[i]
            k = area * tangent
            self._stiffness[self._jnt[i]] = k
            self._qfrc[self._dof[i]] = k * (q - self._qspring[i]) - area * pressure

    def __reduce__(self):
        return GelForces, self._args


cdef class PadPressures:
    """The compiled :class:`cosim.pad_kernels.PyPadPressures` (see there)."""

    cdef UniformPairs _t
    cdef Py_ssize_t _n, _per_pad, _n_element, _n_cells, _n_terms
    cdef Py_ssize_t *_qadr
    cdef Py_ssize_t *_element
    cdef Py_ssize_t *_cell_start  # each cell's first term, and the end of the last
    cdef Py_ssize_t *_term_at
    cdef double *_term_weight
    cdef double *_values
    cdef double[::1] _qpos
    cdef bint _bound
    cdef object _args, _reference

    def __dealloc__(self):
        uniform_pairs_free(&self._t)
        PyMem_Free(self._qadr)
        PyMem_Free(self._element)
        PyMem_Free(self._cell_start)
        PyMem_Free(self._term_at)
        PyMem_Free(self._term_weight)
        PyMem_Free(self._values)

    def __init__(self, table, qadr, per_pad, element, weights):
        reference = _reference().PyPadPressures(table, qadr, per_pad, element, weights)  # checks
        self._args, self._reference = (table, qadr, per_pad, element, weights), reference
        uniform_pairs_from(&self._t, _lookup.PyUniformPairTable(*table))
        self._n, self._per_pad = len(reference._qadr), reference._per_pad
        self._qadr = copy_indices(reference._qadr)
        self._n_element = len(reference._element)
        self._element = copy_indices(reference._element)
        rows = reference._weights
        self._n_cells = len(rows)
        starts, at, weight = [0], [], []
        for row in rows:
            at += [i for i, _ in row]
            weight += [w for _, w in row]
            starts.append(len(at))
        self._n_terms = len(at)
        self._cell_start = copy_indices(starts)
        self._term_at = copy_indices(at)
        self._term_weight = copy_doubles(weight)
        self._values = copy_doubles([0.0] * self._n)
        self._bound = False

    def bind(self, qpos):
        """Read this array from now on (see the reference)."""
        self._reference.bind(qpos)
        self._qpos = qpos
        self._bound = True

    def read(self):
        """Per pad: the element strips' and the coverage cells' pressures, Pa (see the reference)."""
        cdef Py_ssize_t i, j, c, start
        cdef double p, tangent, total
        cdef double *values = self._values
        if not self._bound:
            raise RuntimeError("bind() the array first")
        for i in range(self._n):
            uniform_pairs_at(&self._t, self._qpos[self._qadr[i]], &p, &tangent)
            if 0.0 > p:  # max(p, 0.0)
                p = 0.0
            values[i] = p
        profiles, covered = [], []
        for start in range(0, self._n, self._per_pad):
            profile = [values[start + self._element[j]] for j in range(self._n_element)]
            cells = []
            for c in range(self._n_cells):
                total = 0.0  # sum() of floats: 0 + the first, then each in turn
                for j in range(self._cell_start[c], self._cell_start[c + 1]):
                    total += self._term_weight[j] * values[start + self._term_at[j]]
                cells.append(total)
            profiles.append(profile)
            covered.append(cells)
        return profiles, covered

    def __reduce__(self):
        return PadPressures, self._args
