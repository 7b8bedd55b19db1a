"""One control step's recorded row, and its columns' names (:func:`row_columns`).

Every control step the co-simulation records what happened: the time, the controller's phase,
what the robot senses of itself, the ground truth of the object (its pose, speed and spin,
what touches it: never in the controller's Observation), and per instrumented pad the true
pressure, the sensor's reading and the readout's estimate.  :class:`PyRowBuilder` makes that
row from the step's objects and MuJoCo's live arrays, all values Python floats (units in the
column names):

- ``time_s``, ``phase`` (the Phase's number), ``lift_m``, ``opening_m``, ``grip_force_n``,
  ``lift_force_n`` (the Observation's);
- the object's height, x and y (m), vertical speed, speed and spin (m/s, rad/s), and the
  normal forces on it of the table and of each finger (N, magnitudes of MuJoCo's contact
  sensors); with ``track_peaks`` the fingers' peak forces over the period's physics steps;
- per pad: the mean true pressure over its element strips, the coverage's mean pressure
  (cells weighted by their share of its length), the finger's contact force on the object,
  the estimate and its uncertainty (Pa), the status's index (``STATUS_CODES``), the mode,
  V_1 measured and noise-free, whether the reading had settled, whether the gel sits on its
  housing stop under the element (its largest strip pressure at the stop's), then the element
  strips' pressures, root to tip (Pa).

It is the reference, the one to read; ``cosim/_rows.pyx`` is its compiled twin (the same
values bit for bit: tests/test_compiled_twins.py), used where built (:data:`ROWS_COMPILED`).
The recorder turns each chunk of rows into an array with :func:`py_stack_rows` (numpy's own
conversion of a list of lists, about 1 us a row) or its twin (the floats copied in C).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

import numpy as np

from piezotip.sensor.compiled import twin

__all__ = [
    "PEAK_COLUMNS",
    "ROWS_COMPILED",
    "STATUS_CODES",
    "TRUTH_COLUMNS",
    "PyRowBuilder",
    "RowBuilder",
    "py_stack_rows",
    "row_columns",
    "stack_rows",
]

#: The recorded ground truth (the referee's; never in an Observation): the object's centre
#: (m), its vertical velocity, speed and spin (m/s, rad/s), the table's vertical push on it and
#: each finger's net contact force (N).
TRUTH_COLUMNS = (
    "object_height_m",
    "object_x_m",
    "object_y_m",
    "object_vz_m_s",
    "object_speed_m_s",
    "object_spin_rad_s",
    "table_force_n",
    "left_finger_force_n",
    "right_finger_force_n",
)

#: Each finger's largest net contact force on the object over the period's physics steps (N),
#: recorded for an object with a crush limit (the referee's crush test): a force can peak
#: between two periods' samples.
PEAK_COLUMNS = ("left_finger_peak_force_n", "right_finger_peak_force_n")

#: Readout statuses, recorded as their index (``{side}_status`` columns).
STATUS_CODES = ("ok", "below_detection", "saturated", "settling")
_STATUS_INDEX = {status: float(i) for i, status in enumerate(STATUS_CODES)}

#: Per instrumented pad, its columns before the element's cells (``{side}_{name}``).
PAD_COLUMNS = (
    "true_pressure_pa",
    "coverage_pressure_pa",
    "contact_force_n",
    "estimate_pa",
    "uncertainty_pa",
    "status",
    "mode",
    "v1",
    "v1_true",
    "settled",
    "bottomed",
)


def row_columns(pads: Sequence[str], segments: int, track_peaks: bool) -> list[str]:
    """The record's column names, in the order of :meth:`PyRowBuilder.row`'s values: ``pads``
    the instrumented pads (``left_pad``, ...), ``segments`` the element's cells per pad."""
    columns = ["time_s", "phase", "lift_m", "opening_m", "grip_force_n", "lift_force_n", *TRUTH_COLUMNS]
    if track_peaks:
        columns += PEAK_COLUMNS
    for pad in pads:
        side = pad.removesuffix("_pad")
        columns += [f"{side}_{name}" for name in PAD_COLUMNS]
        columns += [f"{side}_cell{k}_pressure_pa" for k in range(segments)]
    return columns


def py_stack_rows(rows: Sequence[Sequence[float]], n_columns: int) -> np.ndarray:
    """The recorder's pending rows as one float64 array of shape (len(rows), n_columns): what
    ``numpy.asarray(rows, dtype=float)`` gives (its errors for rows of other lengths too)."""
    table = np.asarray(rows, dtype=float)
    if table.size == 0:
        return table.reshape(0, n_columns)
    if table.ndim != 2 or table.shape[1] != n_columns:
        raise ValueError(f"rows of {n_columns} values expected, got an array of shape {table.shape}")
    return table


class PyRowBuilder:
    """The recorded row of a control step (see the module).

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
    """

    __slots__ = (
        "_args",
        "_contact_adr",
        "_finger_adr",
        "_fractions",
        "_pads",
        "_qvel",
        "_sensordata",
        "_status_index",
        "_stop_pa",
        "_table_normal",
        "_track_peaks",
        "_xpos",
    )

    def __init__(
        self,
        pads: Sequence[str],
        contact_adr: Sequence[int],
        finger_adr: Sequence[int],
        table_adr: int,
        track_peaks: bool,
        cell_fractions: Sequence[float],
        stop_pressure_pa: float,
        status_index: Mapping[str, float],
    ) -> None:
        self._args = (pads, contact_adr, finger_adr, table_adr, track_peaks, cell_fractions, stop_pressure_pa, status_index)
        self._pads = list(pads)
        self._contact_adr = [int(a) for a in contact_adr]
        self._finger_adr = [int(a) for a in finger_adr]
        if len(self._contact_adr) != len(self._pads) or len(self._finger_adr) != 2:
            raise ValueError("a row needs one contact address per pad and two fingers' addresses")
        self._table_normal = int(table_adr) + 2
        self._track_peaks = bool(track_peaks)
        self._fractions = [float(f) for f in cell_fractions]
        self._stop_pa = float(stop_pressure_pa)
        self._status_index = {str(k): float(v) for k, v in status_index.items()}
        self._xpos = self._qvel = self._sensordata = None

    def bind(self, object_xpos, object_qvel, sensordata) -> None:
        """Read these live arrays from now on: the object's position (3), its velocity (6:
        linear, then angular) and MuJoCo's ``sensordata`` (float64, 1-D, contiguous)."""
        views = [memoryview(a) for a in (object_xpos, object_qvel, sensordata)]
        if not all(v.c_contiguous and v.ndim == 1 and v.format == "d" for v in views):
            raise ValueError("the row's arrays must be contiguous 1-D float64 views of the simulation's own (never copies)")
        if len(views[0]) != 3 or len(views[1]) != 6:
            raise ValueError(f"the object's position needs 3 values and its velocity 6, got {len(views[0])} and {len(views[1])}")
        used = [*self._contact_adr, *self._finger_adr, self._table_normal]
        if not all(0 <= a < len(views[2]) for a in used):
            raise ValueError(f"sensordata addresses {used} are outside its {len(views[2])} values")
        self._xpos, self._qvel, self._sensordata = views

    def row(self, time_s: float, obs, command, profiles, cells, finger_peaks) -> list[float]:
        """The row's values in column order (Python floats).  ``obs`` and ``command`` are the
        step's Observation and Command, ``profiles`` and ``cells`` each pad's element and
        coverage pressures (Pa), ``finger_peaks`` the fingers' peak forces (N; read only with
        ``track_peaks``)."""
        if self._xpos is None:
            raise RuntimeError("bind() the arrays first")
        # One conversion per array to Python floats (a numpy scalar per value costs more).
        x, y, z = self._xpos.tolist()
        vx, vy, vz, wx, wy, wz = self._qvel.tolist()
        sensordata = self._sensordata.tolist()
        left, right = self._finger_adr
        row = [
            time_s,
            float(command.phase),
            obs.lift_pos_m,
            obs.opening_m,
            obs.grip_force_n,
            obs.lift_force_n,
            z,
            x,
            y,
            vz,
            math.sqrt(vx * vx + vy * vy + vz * vz),
            math.sqrt(wx * wx + wy * wy + wz * wz),
            abs(sensordata[self._table_normal]),
            abs(sensordata[left]),
            abs(sensordata[right]),
        ]
        if self._track_peaks:
            row += finger_peaks
        fractions, status_index, stop = self._fractions, self._status_index, self._stop_pa
        for pad, profile, covered, adr in zip(self._pads, profiles, cells, self._contact_adr, strict=True):
            sig = obs.pads[pad]
            r, e = sig.reading, sig.estimate
            mean = profile[0] if len(profile) == 1 else float(np.mean(profile))
            row += (
                mean,
                covered[0] if len(covered) == 1 else sum(f * p for f, p in zip(fractions, covered, strict=True)),
                abs(sensordata[adr]),
                e.pressure_pa,
                e.uncertainty_pa,
                status_index[e.status],
                float(r.mode),
                r.v1,
                r.v1_true,
                float(r.settled),
                # The gel is on its housing stop under the element: the pressure there is the
                # stop's, and the housing carries the rest (the sensor model is told, here).
                float(max(profile) >= stop),
            )
            row += profile
        return row

    def __reduce__(self):  # a copy is unbound: its owner binds it to its own arrays
        return type(self), self._args


#: The compiled twins of :class:`PyRowBuilder` and :func:`py_stack_rows` where built, else they.
RowBuilder, ROWS_COMPILED = twin("piezotip.cosim._rows", "RowBuilder", PyRowBuilder)
stack_rows, _ = twin("piezotip.cosim._rows", "stack_rows", py_stack_rows)
