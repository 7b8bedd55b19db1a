"""A sweep point's row: its columns, made from a finished run's summary and record, or from the
error of a run that raised (:mod:`analysis.sweep` runs the points; this module only says what
a row holds)."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    import numpy as np

#: A sweep row's result columns, after the grid's keys (units in the names; modes_used is a list
#: written "1 2 3").
RESULT_COLUMNS = ("outcome", "reason", "success", "max_pressure_pa", "held_pressure_pa", "modes_used", "wall_time_s")

#: More numbers every row carries, after the result columns (the experiment's table uses them).
EXTRA_COLUMNS = (
    "crushed",
    "slipped",
    "lifted",
    "touch_latency_s",
    "touch_sense",
    "mode_switches",
    "peak_grip_force_n",
    "hold_grip_n",
    "needed_grip_n",
    "grip_margin",
    "contact_tilt_deg",
    "peak_contact_n",
    "touch_peak_n",
    "time_to_touch_s",
    "disturb_slip_mm",
    "disturb_reaction_ms",
    "disturb_hold_grip_n",
    "disturb_needed_grip_n",
    "disturb_grip_margin",
    "outside_model",
    "sim_time_s",
    "error",
)

#: The referee's grip economy (analysis.referee.Verdict): grip held, needed (on the contacts'
#: tilts), their ratio, the contacts' tilt (deg), peak contact.
GRIP_ECONOMY_COLUMNS = ("hold_grip_n", "needed_grip_n", "grip_margin", "contact_tilt_deg", "peak_contact_n")

#: The referee's touch (analysis.referee.touch_metrics): the peak finger force from the first
#: contact to lift-off, N, and the time from the start of closing to the first contact, s.
TOUCH_COLUMNS = ("touch_peak_n", "time_to_touch_s")

#: The referee's answer to a load change while held (analysis.referee.disturbance_metrics; NaN
#: in a run without one): slip, mm; reaction, ms; the new hold's grip and need, N; their ratio.
DISTURB_COLUMNS = ("disturb_slip_mm", "disturb_reaction_ms", "disturb_hold_grip_n", "disturb_needed_grip_n", "disturb_grip_margin")

#: The referee's numbers a row copies from the run's summary (NaN where the summary has none).
REFEREE_COLUMNS = (*GRIP_ECONOMY_COLUMNS, *TOUCH_COLUMNS, *DISTURB_COLUMNS)

#: Each result and extra column's type in the sweep's Parquet file (analysis.sweep_output): "bool",
#: "int" (int64), "float" (float64), "text", or "modes" (list<int64>; a row writes the modes used
#: as text, "1 2", which the CSV keeps).  A missing value is null there: a NaN number, an ``error``
#: of "" (no error), the modes of a point that raised.
COLUMN_TYPES = {
    **dict.fromkeys((*RESULT_COLUMNS, *EXTRA_COLUMNS), "float"),
    **dict.fromkeys(("outcome", "reason", "touch_sense", "outside_model", "error"), "text"),
    **dict.fromkeys(("success", "crushed", "slipped", "lifted"), "bool"),
    "mode_switches": "int",
    "modes_used": "modes",
}

#: The outcome of a point whose run raised.
ERROR_OUTCOME = "error"

#: The phase code of holding in the record (cosim.control.Phase.HOLD).
_HOLD_PHASE = 4.0


def touch_sense(events: Sequence[Mapping]) -> str:
    """Which sense felt the touch the squeeze began on: "fingertip" (every fingertip's touch
    detector: "squeeze: touch on left, right (CUSUM)"), "joints" (the finger drive met a
    resistance first: "squeeze: touch felt by the joints (...)"), or "" with no touch.  The
    last squeeze counts (a false touch is closed on from, and the touch time is the last one's)."""
    sense = ""
    for event in events:
        message = event.get("message", "")
        if event.get("kind") == "phase" and message.startswith("squeeze: touch"):
            sense = "joints" if message.startswith("squeeze: touch felt by the joints") else "fingertip"
    return sense


def point_row(summary: Mapping, data: Mapping[str, np.ndarray]) -> dict:
    """A finished run's row: the result columns and the extras, from its summary and record."""
    import numpy as np

    held = data["phase"] == _HOLD_PHASE if data else np.zeros(0, bool)
    pads = [k.removesuffix("_true_pressure_pa") for k in data if k.endswith("_true_pressure_pa")] if data else []
    true_p = np.max([data[f"{p}_true_pressure_pa"] for p in pads], axis=0) if pads else np.zeros(0)
    # First contact: a finger touches the object (ground truth), not a pressure reading (the
    # pads' own inertia presses a fraction of a pascal as the fingers start).
    if data:
        touching = np.maximum(data["left_finger_force_n"], data["right_finger_force_n"]) > 0
        contact = np.nonzero(touching)[0]
        contact_t = float(data["time_s"][contact[0]]) if contact.size else math.nan
    else:
        contact_t = math.nan
    touch_t = summary.get("touch_time_s", math.nan)
    touch_t = math.nan if touch_t is None else touch_t
    return {
        "outcome": summary["outcome"],
        "reason": summary["reason"],
        "success": bool(summary["success"]),
        "max_pressure_pa": summary["max_pressure_pa"],
        "held_pressure_pa": float(np.mean(true_p[held])) if held.any() else math.nan,
        "modes_used": " ".join(str(m) for m in summary.get("modes_used", [])),
        "wall_time_s": summary["wall_time_s"],
        "crushed": summary["crushed"],
        "slipped": summary["slipped"],
        "lifted": summary["lifted"],
        "touch_latency_s": touch_t - contact_t if math.isfinite(touch_t) and math.isfinite(contact_t) else math.nan,
        "touch_sense": touch_sense(summary.get("events") or []),
        "mode_switches": summary["mode_switches"],
        "peak_grip_force_n": summary["peak_grip_force_n"],
        **{key: _number(summary.get(key)) for key in REFEREE_COLUMNS},
        "outside_model": "; ".join(summary.get("outside_model", [])),
        "sim_time_s": summary["sim_time_s"],
        "error": summary.get("error") or "",
        "object_config": summary.get("object"),
    }


def _number(value) -> float:
    """A summary's number, NaN for a missing one (or JSON's null)."""
    return math.nan if value is None else value


def error_row(message: str) -> dict:
    """The row of a point whose run raised: its error, NaN numbers, ``success`` False."""
    row = {c: math.nan for c in (*RESULT_COLUMNS, *EXTRA_COLUMNS)}
    row.update(outcome=ERROR_OUTCOME, reason=message, success=False, modes_used="", outside_model="", error=message)
    row.update(crushed=False, slipped=False, lifted=False, touch_sense="", object_config=None)
    return row
