"""Recording every control step, with units, so that a crash or Ctrl-C keeps what was simulated.

Columns are named with their unit (``time_s``, ``left_pressure_pa``, ...).  Rows are held in
memory in chunks; every ``flush_every`` rows the chunk is appended to the CSV (when asked
for) and a checkpoint NPZ is rewritten atomically (written beside, then renamed), so the
files on disk always hold a complete prefix of the run.  :meth:`Recorder.close` writes the
final NPZ; use the recorder as a context manager and it is called on any exit, including
an exception or KeyboardInterrupt.
"""

from __future__ import annotations

import csv
import json
import os
from pathlib import Path

import numpy as np


class Recorder:
    """Append-only table of named float columns, written to ``<stem>.npz`` (and ``.csv``).

    Parameters
    ----------
    path_stem : output path without suffix, e.g. ``out/grasp/run``.
    csv : also write a CSV, appended incrementally.
    flush_every : rows per chunk written to disk.
    metadata : JSON-serializable facts stored in the NPZ as ``metadata_json`` (units, config).
    """

    def __init__(self, path_stem: str | Path, csv: bool = False, flush_every: int = 500, metadata: dict | None = None) -> None:
        self.stem = Path(path_stem)
        self.stem.parent.mkdir(parents=True, exist_ok=True)
        self.npz_path = self.stem.with_suffix(".npz")
        self.csv_path = self.stem.with_suffix(".csv") if csv else None
        self.flush_every = int(flush_every)
        self.metadata = dict(metadata or {})
        self._columns: list[str] | None = None
        self._column_set: frozenset[str] = frozenset()
        self._column_source = None  # the sequence append_values was first given, to recognise it
        self._chunk: list[list[float]] = []
        self._flushed: list[np.ndarray] = []
        self._closed = False
        if self.csv_path is not None and self.csv_path.exists():
            self.csv_path.unlink()

    @property
    def columns(self) -> list[str]:
        return list(self._columns or [])

    def __len__(self) -> int:
        return sum(len(a) for a in self._flushed) + len(self._chunk)

    def append(self, row: dict[str, float]) -> None:
        """Add one row; the first row fixes the columns (later rows must have the same keys)."""
        if self._columns is None:
            self._set_columns(list(row))
        elif row.keys() != self._column_set:
            differ = self._column_set ^ set(row)
            raise ValueError(f"row columns differ from the first row's: {sorted(differ)}")
        self._chunk.append([float(row[c]) for c in self._columns])
        if len(self._chunk) >= self.flush_every:
            self.flush()

    def append_values(self, values, columns=None, owned: bool = False) -> None:
        """Add one row given as its values in column order (the co-simulation's per-step path).

        ``columns`` names them; it is needed with the first row (which fixes the columns, as
        in :meth:`append`) and checked against them afterwards (cheaply when it is the same
        sequence object every time).  The values are copied, so the caller may reuse its list,
        unless ``owned``: then the list (of Python floats) is handed over and kept as it is.
        """
        if self._columns is None:
            if columns is None:
                raise ValueError("the first row needs its column names")
            self._set_columns(list(columns))
            self._column_source = columns
        elif columns is not None and columns is not self._column_source and list(columns) != self._columns:
            differ = self._column_set ^ set(columns)
            raise ValueError(f"row columns differ from the first row's: {sorted(differ) or 'their order'}")
        row = values if owned else list(map(float, values))
        if len(row) != len(self._columns):
            raise ValueError(f"row has {len(row)} values for {len(self._columns)} columns")
        self._chunk.append(row)
        if len(self._chunk) >= self.flush_every:
            self.flush()

    def _set_columns(self, columns: list[str]) -> None:
        self._columns = columns
        self._column_set = frozenset(columns)

    def flush(self) -> None:
        """Write the pending chunk: append to the CSV, rewrite the checkpoint NPZ."""
        if not self._chunk or self._columns is None:
            return
        chunk = np.asarray(self._chunk, dtype=float)
        self._chunk = []
        self._flushed.append(chunk)
        if self.csv_path is not None:
            new = not self.csv_path.exists()
            with self.csv_path.open("a", newline="") as fh:
                writer = csv.writer(fh)
                if new:
                    writer.writerow(self._columns)
                writer.writerows(chunk.tolist())
        self._write_npz()

    def data(self) -> dict[str, np.ndarray]:
        """Everything recorded so far, as columns."""
        if self._columns is None:
            return {}
        parts = [*self._flushed]
        if self._chunk:
            parts.append(np.asarray(self._chunk, dtype=float))
        table = np.concatenate(parts) if parts else np.empty((0, len(self._columns)))
        return {c: table[:, i] for i, c in enumerate(self._columns)}

    def _write_npz(self) -> None:
        tmp = self.npz_path.with_suffix(".tmp.npz")
        arrays = self.data()
        np.savez(tmp, metadata_json=np.array(json.dumps(self.metadata)), **arrays)
        os.replace(tmp, self.npz_path)

    def close(self) -> list[Path]:
        """Write everything; return the files written.  Safe to call twice."""
        if not self._closed:
            self.flush()
            if self._columns is not None:
                self._write_npz()
            self._closed = True
        return [p for p in (self.npz_path, self.csv_path) if p is not None and p.exists()]

    def __enter__(self) -> Recorder:
        return self

    def __exit__(self, *exc) -> None:
        self.close()
