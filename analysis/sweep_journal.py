"""A sweep's journal, what lets it resume: ``points.jsonl`` in the output folder.

Each finished point's row is appended at once (:func:`append_row`), keyed by the scenario,
preset and the point's overrides (:meth:`analysis.sweep_grid.Point.key`), on a line of its own
(after a newline when a kill tore the last line); a sweep run again with the same folder skips
the points already there (:func:`load_done`; a point that raised is run again).  A line that is
not a row (torn, garbage, not UTF-8) is skipped with a warning naming the file and line, and
its point runs again: a resumed sweep has the rows an uninterrupted one has.  So does a line
shaped like a row whose row lacks columns or holds values of the wrong type (:func:`row_problem`):
it would otherwise stop every resume in the tables.
"""

from __future__ import annotations

import json
import logging
import math
import os
from pathlib import Path

from .sweep_rows import ERROR_OUTCOME, EXTRA_COLUMNS, REFEREE_COLUMNS, RESULT_COLUMNS

#: The journal's name in a sweep's output folder.
JOURNAL_NAME = "points.jsonl"

#: The row's number columns (NaN where there is no value; JSON writes it null).
_NUMBER_COLUMNS = (
    "max_pressure_pa",
    "held_pressure_pa",
    "wall_time_s",
    "touch_latency_s",
    "mode_switches",
    "peak_grip_force_n",
    *REFEREE_COLUMNS,  # every referee column is a number (analysis.sweep_rows)
    "sim_time_s",
)

#: The columns a journaled row must have to be a row: every column a row is made with
#: (:mod:`analysis.sweep_rows`), but the referee's, which :func:`normalized` fills with NaN for a
#: journal written before them.  The sweep's tables, its text table and the experiment's read them.
REQUIRED_COLUMNS = tuple(c for c in (*RESULT_COLUMNS, *EXTRA_COLUMNS) if c not in REFEREE_COLUMNS)

# The sweep's logger, by the name it has always had (a user's logging settings name it): the
# journal's warnings are the sweep's.
log = logging.getLogger("piezotip.analysis.sweep")


def normalized(row: dict) -> dict:
    """The row as it reads back from ``points.jsonl`` (JSON types, NaN for null numbers): a fresh
    row and a resumed one are then the same values."""
    from .runner import json_safe

    row = json.loads(json.dumps(json_safe(row)))
    for key in _NUMBER_COLUMNS:
        if row.get(key, None) is None and (key in row or key in REFEREE_COLUMNS):
            row[key] = math.nan  # null, or a journal written before the referee's columns
    return row


def row_problem(row: dict) -> str | None:
    """Why a journaled ``row`` (a dict) is not a row the sweep can use, or None: a column of
    :data:`REQUIRED_COLUMNS` missing, an ``outcome`` or ``reason`` that is not text, a ``success``
    that is not true or false, a number column (:data:`_NUMBER_COLUMNS`) holding anything but a
    number or null.  A resumed sweep uses its rows as they are, so a row that fails here would
    stop it later (a ``KeyError`` in the tables, every time it is resumed)."""
    missing = [c for c in REQUIRED_COLUMNS if c not in row]
    if missing:
        shown = ", ".join(missing[:4]) + (f" and {len(missing) - 4} more" if len(missing) > 4 else "")
        return f"a row missing {len(missing)} of its {len(REQUIRED_COLUMNS)} columns ({shown})"
    wrong = [c for c in ("outcome", "reason") if not isinstance(row[c], str)]
    wrong += [] if isinstance(row["success"], bool) else ["success"]
    wrong += [c for c in _NUMBER_COLUMNS if not _is_number_or_null(row.get(c))]
    if wrong:
        return f"a row whose {', '.join(wrong)} {'is' if len(wrong) == 1 else 'are'} of the wrong type"
    return None


def _is_number_or_null(value) -> bool:
    return value is None or (isinstance(value, (int, float)) and not isinstance(value, bool))


def load_done(path: Path) -> dict[str, dict]:
    """The rows already in ``points.jsonl`` by key, the last one of a key winning (a point that
    raised is not done).

    A line that is not a row (not UTF-8, not JSON, JSON that is not ``{"key": str, "row": {...}}``,
    a row missing columns or holding a value of the wrong type: :func:`row_problem`, a torn line a
    kill left) is skipped with a warning naming the file and the line number, on the
    ``piezotip.analysis.sweep`` logger; its point, if any, runs again."""
    done: dict[str, dict] = {}
    if not path.exists():
        return done
    text = path.read_bytes()
    lines = text.split(b"\n")
    if lines[-1] == b"":
        lines.pop()  # the newline that ends the last line
    for number, raw in enumerate(lines, 1):
        if not raw.strip():
            continue
        problem, entry = None, None
        try:
            entry = json.loads(raw.decode("utf-8"))
        except UnicodeDecodeError:
            problem = "not UTF-8"
        except ValueError:
            problem = "not JSON (torn: the file ends inside it)" if number == len(lines) and not text.endswith(b"\n") else "not JSON"
        if problem is None and not (isinstance(entry, dict) and isinstance(entry.get("key"), str) and isinstance(entry.get("row"), dict)):
            problem = 'not a row ({"key": ..., "row": {...}})'
        if problem is None and (damage := row_problem(entry["row"])) is not None:
            problem = f"{damage}; its point runs again"
        if problem is not None:
            log.warning("%s:%d: skipped a line that is %s", path, number, problem)
            continue
        if entry["row"].get("outcome") != ERROR_OUTCOME:
            done[entry["key"]] = normalized(entry["row"])
    return done


def append_row(path: Path, key: str, row: dict) -> None:
    """Append the point ``key``'s ``row`` to the journal at ``path``, a line of JSON."""
    from .runner import json_safe

    _append_line(path, json.dumps(json_safe({"key": key, "row": row})))


def _append_line(path: Path, line: str) -> None:
    """Append ``line`` (and a newline) to the journal as one write, on a line of its own: a file
    that does not end with a newline (a line torn by a kill or a full disk) gets one first, so
    the torn fragment stays a line of its own (skipped on reading) and this row is whole."""
    with path.open("a+b") as fh:
        size = fh.seek(0, os.SEEK_END)
        lead = b""
        if size:
            fh.seek(size - 1)
            lead = b"" if fh.read(1) == b"\n" else b"\n"
        fh.write(lead + line.encode("utf-8") + b"\n")  # "a": written at the end, wherever the read left off
