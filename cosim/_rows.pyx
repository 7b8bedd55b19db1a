# cython: language_level=3, cdivision=True, boundscheck=False, wraparound=False
"""One control step's recorded row, compiled: :class:`cosim.rows.PyRowBuilder` in C.

The same row, value for value and bit for bit (tests/test_compiled_twins.py): MuJoCo's arrays
read through typed memoryviews bound once (checked there by the reference's own checks), the
Observation's, Command's, Reading's and Estimate's fields taken as they are, ``float()``
where the reference converts, ``sqrt`` and ``fabs`` as ``math.sqrt`` and ``abs``, Python's
``max`` and ``sum`` of floats in their order, and ``numpy.mean`` itself for a profile of more
than one cell.
"""

from cpython.float cimport PyFloat_AS_DOUBLE, PyFloat_CheckExact
from libc.math cimport fabs, sqrt

import numpy as np


def _reference():
    # Imported when first needed, not with this module: cosim/rows.py imports this module at its
    # end, under either of its names (piezotip.cosim.rows, or cosim.rows from the repository).
    from . import rows

    return rows


cdef class RowBuilder:
    """The compiled :class:`cosim.rows.PyRowBuilder` (see there)."""

    cdef list _pads, _contact_adr, _fractions
    cdef Py_ssize_t _left, _right, _table_normal
    cdef bint _track_peaks
    cdef double _stop_pa
    cdef dict _status_index
    cdef double[::1] _xpos, _qvel, _sensordata
    cdef bint _bound
    cdef object _args, _reference

    def __init__(self, pads, contact_adr, finger_adr, table_adr, track_peaks, cell_fractions, stop_pressure_pa, status_index):
        reference = _reference().PyRowBuilder(pads, contact_adr, finger_adr, table_adr, track_peaks, cell_fractions, stop_pressure_pa, status_index)
        self._args, self._reference = (pads, contact_adr, finger_adr, table_adr, track_peaks, cell_fractions, stop_pressure_pa, status_index), reference
        self._pads, self._contact_adr, self._fractions = reference._pads, reference._contact_adr, reference._fractions
        self._left, self._right = reference._finger_adr
        self._table_normal = reference._table_normal
        self._track_peaks = reference._track_peaks
        self._stop_pa = reference._stop_pa
        self._status_index = reference._status_index
        self._bound = False

    def bind(self, object_xpos, object_qvel, sensordata):
        """Read these live arrays from now on (see the reference)."""
        self._reference.bind(object_xpos, object_qvel, sensordata)  # the same checks, the same errors
        self._xpos, self._qvel, self._sensordata = object_xpos, object_qvel, sensordata
        self._bound = True

    def row(self, time_s, obs, command, list profiles, list cells, finger_peaks):
        """The row's values in column order (see the reference)."""
        cdef double vx, vy, vz, wx, wy, wz, total, top, v
        cdef Py_ssize_t k, i, n_pads = len(self._pads)
        cdef list row, profile, covered, fractions = self._fractions
        if not self._bound:
            raise RuntimeError("bind() the arrays first")
        if len(profiles) != n_pads or len(cells) != n_pads:
            raise ValueError(f"zip() arguments differ in length: {n_pads} pads, {len(profiles)} profiles, {len(cells)} cell lists")
        vx, vy, vz = self._qvel[0], self._qvel[1], self._qvel[2]
        wx, wy, wz = self._qvel[3], self._qvel[4], self._qvel[5]
        row = [
            time_s,
            float(command.phase),
            obs.lift_pos_m,
            obs.opening_m,
            obs.grip_force_n,
            obs.lift_force_n,
            self._xpos[2],
            self._xpos[0],
            self._xpos[1],
            vz,
            sqrt(vx * vx + vy * vy + vz * vz),
            sqrt(wx * wx + wy * wy + wz * wz),
            fabs(self._sensordata[self._table_normal]),
            fabs(self._sensordata[self._left]),
            fabs(self._sensordata[self._right]),
        ]
        if self._track_peaks:
            row += finger_peaks
        signals = obs.pads
        for k in range(n_pads):
            profile, covered = profiles[k], cells[k]
            sig = signals[self._pads[k]]
            r, e = sig.reading, sig.estimate
            if len(profile) == 0:
                raise ValueError("max() arg is an empty sequence")
            if len(covered) == 1:
                cell = covered[0]
            else:
                if len(covered) != len(fractions):
                    raise ValueError("zip() arguments differ in length: coverage cells and their fractions")
                total = 0.0  # sum() of floats: 0 + the first, then each in turn
                for i in range(len(covered)):
                    total += <double> fractions[i] * <double> covered[i]
                cell = total
            top = profile[0]  # max(): the first of the largest
            for i in range(1, len(profile)):
                v = profile[i]
                if v > top:
                    top = v
            row += (
                profile[0] if len(profile) == 1 else float(np.mean(profile)),
                cell,
                fabs(self._sensordata[<Py_ssize_t> self._contact_adr[k]]),
                e.pressure_pa,
                e.uncertainty_pa,
                self._status_index[e.status],
                float(r.mode),
                r.v1,
                r.v1_true,
                float(r.settled),
                1.0 if top >= self._stop_pa else 0.0,
            )
            row += profile
        return row

    def __reduce__(self):
        return RowBuilder, self._args


def stack_rows(list rows, Py_ssize_t n_columns):
    """:func:`cosim.rows.py_stack_rows`: the rows (lists of Python floats) as one float64 array;
    anything else (another length, a value not a float) goes to the reference, with its errors."""
    cdef Py_ssize_t i, j, n = len(rows)
    cdef list row
    cdef double[:, ::1] out
    for i in range(n):
        if type(rows[i]) is not list or len(<list> rows[i]) != n_columns:
            return _reference().py_stack_rows(rows, n_columns)
    table = np.empty((n, n_columns))
    out = table
    for i in range(n):
        row = <list> rows[i]
        for j in range(n_columns):
            value = row[j]
            if not PyFloat_CheckExact(value):
                return _reference().py_stack_rows(rows, n_columns)
            out[i, j] = PyFloat_AS_DOUBLE(value)
    return table
