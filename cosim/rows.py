"""One control step's recorded row, and its columns' names (:func:`row_columns`).

Every control step the co-simulation records what happened: the time, the controller's phase,
what the robot senses of itself, the ground truth of the object (its pose, speed and spin,
what touches it: never in the controller's Observation), and per instrumented pad the true
pressure, the sensor's reading and the readout's estimate.  :class:`RowBuilder` makes that
row from the step's objects and MuJoCo's live arrays, all values Python floats (units in the
column names):

- ``time_s``, ``phase`` (the Phase's number), ``lift_m``, ``opening_m``, ``grip_force_n``,
  ``lift_force_n`` (the Observation's);
- the object's height, x and y (m), vertical speed, speed and spin (m/s, rad/s), and the
  normal forces on it of the table and of each finger (N, magnitudes of MuJoCo's contact
  sensors), each finger's contact tilt (rad); with ``track_peaks`` the fingers' peak forces over the period's physics steps;
- per pad: the mean true pressure over its element strips, the coverage's mean pressure
  (cells weighted by their share of its length), the finger's contact force on the object,
  the estimate and its uncertainty (Pa), the status's index (``STATUS_CODES``), the mode,
  V_1 measured and noise-free, whether the reading had settled, whether the gel sits on its
  housing stop under the element (its largest strip pressure at the stop's), then the element
  strips' pressures, root to tip (Pa).

:class:`RowBuilder` and :func:`stack_rows` (the recorder's chunk of rows as one array, what
``numpy.asarray`` gives) are a kernel: one source, ``cosim/_rows.py``, compiled where built
(:mod:`piezotip.sensor.compiled`; :data:`ROWS_COMPILED` says); :class:`PyRowBuilder` and
:func:`py_stack_rows` are the same source run as Python.
"""

from __future__ import annotations

from collections.abc import Sequence

from piezotip.sensor.compiled import is_compiled, source_module

from . import _rows
from ._rows import RowBuilder, stack_rows

__all__ = [
    "PEAK_COLUMNS",
    "READOUT_STATUSES",
    "ROWS_COMPILED",
    "STATUS_CODES",
    "TRUTH_COLUMNS",
    "RowBuilder",
    "row_columns",
    "stack_rows",
]

#: The recorded ground truth (the referee's; never in an Observation): the object's centre
#: (m), its vertical velocity, speed and spin (m/s, rad/s), the table's vertical push on it and
#: each finger's net contact force (N), and the tilt below the horizontal of each finger's
#: normal forces' resultant over its contacts with the object (rad; NaN where it touches
#: nothing: the referee's need on contacts above or below a round object's centre).
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
    "left_contact_tilt_rad",
    "right_contact_tilt_rad",
)

#: Each finger's largest net contact force on the object over the period's physics steps (N),
#: recorded for an object with a crush limit (the referee's crush test): a force can peak
#: between two periods' samples.
PEAK_COLUMNS = ("left_finger_peak_force_n", "right_finger_peak_force_n")

#: Readout statuses, recorded as their index (``{side}_status`` columns).  The first four are the
#: readout's own; "outside_model" is the simulator's: the reading was taken past where the model
#: holds (the gel past its valid strain, or the element on its backstop; :class:`RowBuilder`).
STATUS_CODES = ("ok", "below_detection", "saturated", "settling", "outside_model")
#: The readout's own statuses (STATUS_CODES' first four): what a controller, and a Gym agent, sees.
READOUT_STATUSES = STATUS_CODES[:4]
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
    """The record's column names, in the order of :meth:`RowBuilder.row`'s values: ``pads``
    the instrumented pads (``left_pad``, ...), ``segments`` the element's cells per pad."""
    columns = ["time_s", "phase", "lift_m", "opening_m", "grip_force_n", "lift_force_n", *TRUTH_COLUMNS]
    if track_peaks:
        columns += PEAK_COLUMNS
    for pad in pads:
        side = pad.removesuffix("_pad")
        columns += [f"{side}_{name}" for name in PAD_COLUMNS]
        columns += [f"{side}_cell{k}_pressure_pa" for k in range(segments)]
    return columns


#: Whether :class:`RowBuilder` and :func:`stack_rows` run compiled (cosim/_rows.py built).
ROWS_COMPILED = is_compiled(_rows)


def __getattr__(name: str):
    # The kernel's source run as Python, loaded when asked for.
    if name == "PyRowBuilder":
        return source_module(_rows.__name__).RowBuilder
    if name == "py_stack_rows":
        return source_module(_rows.__name__).stack_rows
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
