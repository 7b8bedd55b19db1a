"""One control step's recorded row, and a chunk of rows as one array (see :mod:`cosim.rows`).

A kernel (:mod:`piezotip.sensor.compiled`): this module runs as Python and, where built,
compiled (``_rows.pxd`` types it: MuJoCo's arrays bound once as typed memoryviews).  The row's
columns and their units are documented in :mod:`cosim.rows`.
"""

from __future__ import annotations

import math
from array import array
from operator import attrgetter

import numpy as np

from piezotip.cosim.control.interface import Observation, PadSignal
from piezotip.sensor import _kernel_helpers as kh
from piezotip.sensor.estimator import Estimate
from piezotip.sensor.resonator import Reading

# The fields a row reads of each record, read together (compiled: from the record's slots
# where it is one of its class, a load each; by name otherwise): the names, where each is
# (kh.slot_offsets) and the getter by name.
_OBSERVATION = ("pads", "lift_pos_m", "opening_m", "grip_force_n", "lift_force_n")
#: Values per contact of a finger's object-contact sensor: found (1), force (3), normal (3).
_NORMAL_SLOT = 7
_SIGNAL = ("reading", "estimate")
_READING = ("mode", "v1", "v1_true", "settled")
_ESTIMATE = ("pressure_pa", "uncertainty_pa", "status")
_OBSERVATION_AT, _OBSERVATION_GET = kh.slot_offsets(Observation, 5, _OBSERVATION), attrgetter(*_OBSERVATION)
_SIGNAL_AT, _SIGNAL_GET = kh.slot_offsets(PadSignal, 2, _SIGNAL), attrgetter(*_SIGNAL)
_READING_AT, _READING_GET = kh.slot_offsets(Reading, 4, _READING), attrgetter(*_READING)
_ESTIMATE_AT, _ESTIMATE_GET = kh.slot_offsets(Estimate, 3, _ESTIMATE), attrgetter(*_ESTIMATE)


class RowBuilder:
    """The recorded row of a control step (:mod:`cosim.rows`).

    Parameters
    ----------
    pads : the instrumented pads, in the record's order.
    contact_adr : per pad, the ``sensordata`` address of its finger's normal force on the object.
    finger_adr : (left, right): the fingers' normal-force addresses in ``sensordata``.
    table_adr : the address of the object-table contact force; its normal is ``table_adr + 2``.
    track_peaks : whether the row carries the fingers' peak forces (an object with a crush limit).
    cell_fractions : each coverage cell's share of the coverage's length.
    stop_pressure_pa : the pressure at which the gel sits on its housing stop, Pa.
    status_index : each estimate status's number in the record.
    normal_adr : (left, right): the addresses of each finger's contact sensor on the object
        with its ``normal_slots`` strongest contacts, each ``found`` (how many were), its force
        (contact frame: the normal force first) and its unit normal (world frame, from the finger
        into the object).  The row records the tilt below the horizontal, rad, of their normal
        forces' resultant, sum_i N_i n_i (NaN where none touches, or None: no such sensors): the
        referee's need on a tilted contact (analysis.referee), to first order in the contacts'
        tilts the need of the one contact the resultant stands for.  Not the strongest contact
        alone: on a pad cut into strips a sphere touches several at tilts of both signs.
    normal_slots : how many contacts each of those sensors reports (its ``num``), >= 1.
    model_limits_pa : (gel_valid_pa, backstop_pa), where the model ends (Pa;
        :meth:`sensor.fingertip.Fingertip.model_limit`): a strip over the element past the gel's
        valid strain, or the coverage's pressure past the element's backstop, and the row's
        status is ``status_index["outside_model"]``, whatever the readout said (the readout
        cannot know; the simulator does).  None: no check.
    """

    __slots__ = (
        "_args",
        "_backstop_pa",
        "_bound",
        "_contact_adr",
        "_fractions",
        "_gel_valid_pa",
        "_left",
        "_normal_slots",
        "_normals",
        "_outside",
        "_pads",
        "_qvel",
        "_right",
        "_sensordata",
        "_status_index",
        "_stop_pa",
        "_table_normal",
        "_track_peaks",
        "_xpos",
    )

    def __init__(
        self,
        pads,
        contact_adr,
        finger_adr,
        table_adr,
        track_peaks,
        cell_fractions,
        stop_pressure_pa,
        status_index,
        model_limits_pa=None,
        normal_adr=None,
        normal_slots=1,
    ) -> None:
        self._args = (
            pads,
            contact_adr,
            finger_adr,
            table_adr,
            track_peaks,
            cell_fractions,
            stop_pressure_pa,
            status_index,
            model_limits_pa,
            normal_adr,
            normal_slots,
        )
        self._pads = list(pads)
        contact_adr, finger_adr = [int(a) for a in contact_adr], [int(a) for a in finger_adr]
        if len(contact_adr) != len(self._pads) or len(finger_adr) != 2:
            raise ValueError("a row needs one contact address per pad and two fingers' addresses")
        self._contact_adr = array("q", contact_adr)
        self._left, self._right = finger_adr
        self._table_normal = int(table_adr) + 2
        normals = [-1, -1] if normal_adr is None else [int(a) for a in normal_adr]
        if len(normals) != 2:
            raise ValueError("a row needs the two fingers' normal sensors' addresses, or None")
        self._normals = array("q", normals)
        self._normal_slots = int(normal_slots)
        if self._normal_slots < 1:
            raise ValueError(f"normal_slots must be >= 1, got {normal_slots!r}")
        self._track_peaks = bool(track_peaks)
        self._fractions = array("d", [float(f) for f in cell_fractions])
        self._stop_pa = float(stop_pressure_pa)
        self._status_index = {str(k): float(v) for k, v in status_index.items()}
        gel_valid_pa, backstop_pa = (math.inf, math.inf) if model_limits_pa is None else model_limits_pa
        self._gel_valid_pa = math.inf if gel_valid_pa is None else float(gel_valid_pa)
        self._backstop_pa = math.inf if backstop_pa is None else float(backstop_pa)
        if model_limits_pa is not None and "outside_model" not in self._status_index:
            raise ValueError("model limits need a status_index with 'outside_model'")
        self._outside = self._status_index.get("outside_model", -1.0)
        self._bound = False

    def bind(self, object_xpos, object_qvel, sensordata) -> None:
        """Read these live arrays from now on: the object's position (3), its velocity (6:
        linear, then angular) and MuJoCo's ``sensordata`` (float64, 1-D, contiguous)."""
        views = [memoryview(a) for a in (object_xpos, object_qvel, sensordata)]
        if not all(v.c_contiguous and v.ndim == 1 and v.format == "d" for v in views):
            raise ValueError("the row's arrays must be contiguous 1-D float64 views of the simulation's own (never copies)")
        if len(views[0]) != 3 or len(views[1]) != 6:
            raise ValueError(f"the object's position needs 3 values and its velocity 6, got {len(views[0])} and {len(views[1])}")
        used = [*list(self._contact_adr), self._left, self._right, self._table_normal]
        used += [a + i for a in self._normals if a >= 0 for i in range(_NORMAL_SLOT * self._normal_slots)]
        if not all(0 <= a < len(views[2]) for a in used):
            raise ValueError(f"sensordata addresses {used} are outside its {len(views[2])} values")
        self._xpos, self._qvel, self._sensordata = views
        self._bound = True

    def _tilt(self, adr: int) -> float:
        """The tilt below the horizontal of the normal forces' resultant of the contacts the
        sensor at ``adr`` reports (rad, atan2 of its downward part over its horizontal one: the
        contacts press the object down where positive), sum_i N_i n_i over its found slots; NaN
        where it found no contact, or none pressed, or there is no sensor (``adr`` < 0)."""
        if adr < 0 or not self._sensordata[adr] > 0.0:
            return math.nan
        found = min(int(self._sensordata[adr]), self._normal_slots)
        sx, sy, sz = 0.0, 0.0, 0.0
        for k in range(found):
            at = adr + _NORMAL_SLOT * k
            force = self._sensordata[at + 1]
            sx += force * self._sensordata[at + 4]
            sy += force * self._sensordata[at + 5]
            sz += force * self._sensordata[at + 6]
        horizontal = kh.sqrt(sx * sx + sy * sy)
        if not (horizontal > 0.0 or sz != 0.0):
            return math.nan
        return kh.atan2(-sz, horizontal)

    def row(self, time_s, obs, command, profiles, cells, finger_peaks) -> list[float]:
        """The row's values in column order (Python floats).  ``obs`` and ``command`` are the
        step's Observation and Command, ``profiles`` and ``cells`` each pad's element and
        coverage pressures (Pa), ``finger_peaks`` the fingers' peak forces (N; read only with
        ``track_peaks``)."""
        if not self._bound:
            raise RuntimeError("bind() the arrays first")
        if len(profiles) != len(self._pads) or len(cells) != len(self._pads):
            raise ValueError(f"{len(self._pads)} pads, {len(profiles)} profiles and {len(cells)} cell lists")
        signals, lift_pos_m, opening_m, grip_force_n, lift_force_n = kh.fields(obs, Observation, _OBSERVATION_AT, 5, _OBSERVATION_GET)
        vx, vy, vz = self._qvel[0], self._qvel[1], self._qvel[2]
        wx, wy, wz = self._qvel[3], self._qvel[4], self._qvel[5]
        row = [
            time_s,
            float(command.phase),
            lift_pos_m,
            opening_m,
            grip_force_n,
            lift_force_n,
            self._xpos[2],
            self._xpos[0],
            self._xpos[1],
            vz,
            kh.sqrt(vx * vx + vy * vy + vz * vz),
            kh.sqrt(wx * wx + wy * wy + wz * wz),
            abs(self._sensordata[self._table_normal]),
            abs(self._sensordata[self._left]),
            abs(self._sensordata[self._right]),
            self._tilt(self._normals[0]),
            self._tilt(self._normals[1]),
        ]
        if self._track_peaks:
            row += finger_peaks
        for k in range(len(self._pads)):
            profile, covered = profiles[k], cells[k]
            reading, estimate = kh.fields(signals[self._pads[k]], PadSignal, _SIGNAL_AT, 2, _SIGNAL_GET)
            mode, v1, v1_true, settled = kh.fields(reading, Reading, _READING_AT, 4, _READING_GET)
            pressure_pa, uncertainty_pa, status = kh.fields(estimate, Estimate, _ESTIMATE_AT, 3, _ESTIMATE_GET)
            top = profile[0]  # max(profile): the first of the largest
            for i in range(1, len(profile)):
                p = profile[i]
                if p > top:
                    top = p
            if len(covered) == 1:
                cell = covered[0]
            else:  # the cells weighted by their shares, summed in order from 0.0 (as sum() does)
                if len(covered) != len(self._fractions):
                    raise ValueError(f"{len(covered)} coverage cells for {len(self._fractions)} fractions")
                cell = 0.0
                for i in range(len(covered)):
                    p = covered[i]
                    cell += self._fractions[i] * p
            code = self._status_index[status]
            if top > self._gel_valid_pa or cell > self._backstop_pa:
                code = self._outside
            row += (
                profile[0] if len(profile) == 1 else float(np.mean(profile)),
                cell,
                abs(self._sensordata[self._contact_adr[k]]),
                pressure_pa,
                uncertainty_pa,
                code,
                float(mode),
                v1,
                v1_true,
                float(settled),
                # The gel is on its housing stop under the element: the pressure there is the
                # stop's, and the housing carries the rest (the sensor model is told, here).
                1.0 if top >= self._stop_pa else 0.0,
            )
            row += profile
        return row

    def __reduce__(self):  # a copy is unbound: its owner binds it to its own arrays
        return type(self), self._args


def stack_rows(rows, n_columns: int) -> np.ndarray:
    """The recorder's pending rows as one float64 array of shape (len(rows), n_columns): what
    ``numpy.asarray(rows, dtype=float)`` gives.  Rows that are lists of ``n_columns`` floats are
    copied value by value (compiled: in C); anything else goes to numpy, with its errors."""
    for row in rows:
        if type(row) is not list or len(row) != n_columns:
            return _numpy_rows(rows, n_columns)
    table = np.empty((len(rows), n_columns))
    out = table
    for i in range(len(rows)):
        row = rows[i]
        for j in range(n_columns):
            value = row[j]
            if type(value) is not float:
                return _numpy_rows(rows, n_columns)
            out[i, j] = value
    return table


def _numpy_rows(rows, n_columns: int) -> np.ndarray:
    table = np.asarray(rows, dtype=float)
    if table.size == 0:
        return table.reshape(0, n_columns)
    if table.ndim != 2 or table.shape[1] != n_columns:
        raise ValueError(f"rows of {n_columns} values expected, got an array of shape {table.shape}")
    return table
