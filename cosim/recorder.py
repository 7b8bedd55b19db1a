"""Recording every control step, with units, at a cost linear in the run's length, crash-safe.

Columns are named with their unit (``time_s``, ``left_pressure_pa``, ...).  Rows are held in
memory in chunks; every ``flush_every`` rows the chunk is written to disk as one more
append-only file, ``<stem>.chunks/chunk_NNNNNN.npy`` (written beside, then renamed, so a file
that exists is whole), and appended to the CSV when asked for.  A flush writes only its own
rows, so a run's recording costs the same per simulated second however long it runs.
:meth:`Recorder.close` gathers the chunks into ``<stem>.npz`` in one pass and removes them.

A run killed outright (SIGKILL, a power cut) leaves its completed chunks: :func:`read_recording`
reads a recording from the NPZ, or from the chunks when the run never closed it.  Use the
recorder as a context manager and :meth:`close` is called on any exit that Python sees,
including an exception or KeyboardInterrupt.
"""

from __future__ import annotations

import csv
import json
import os
import shutil
from pathlib import Path

import numpy as np

from .rows import stack_rows

_META = "meta.json"


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
        self.chunk_dir = self.stem.with_suffix(".chunks")
        self.csv_path = self.stem.with_suffix(".csv") if csv else None
        self.flush_every = int(flush_every)
        self.metadata = dict(metadata or {})
        self._columns: list[str] | None = None
        self._column_set: frozenset[str] = frozenset()
        self._column_source = None  # the sequence append_values was first given, to recognise it
        self._chunk: list[list[float]] = []
        self._flushed: list[np.ndarray] = []
        self._flushed_rows = 0  # rows in self._flushed
        self._closed = False
        # A new recording replaces an old one of the same name (never mixes with it).
        for old in (self.csv_path, self.npz_path):
            if old is not None and old.exists():
                old.unlink()
        if self.chunk_dir.exists():
            shutil.rmtree(self.chunk_dir)

    @property
    def columns(self) -> list[str]:
        return list(self._columns or [])

    def __len__(self) -> int:
        return self._flushed_rows + len(self._chunk)

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
        """Write the pending rows as one more chunk file (and append them to the CSV)."""
        if not self._chunk or self._columns is None:
            return
        chunk = stack_rows(self._chunk, len(self._columns))  # numpy's conversion, compiled where built
        self._chunk = []
        index = len(self._flushed)
        self._flushed.append(chunk)
        self._flushed_rows += len(chunk)
        if index == 0:
            self.chunk_dir.mkdir(parents=True, exist_ok=True)
            _write_atomic(self.chunk_dir / _META, json.dumps({"columns": self._columns, "metadata": self.metadata}).encode())
        tmp = self.chunk_dir / f"chunk_{index:06d}.tmp.npy"
        np.save(tmp, chunk)
        os.replace(tmp, self.chunk_dir / f"chunk_{index:06d}.npy")
        if self.csv_path is not None:
            new = not self.csv_path.exists()
            with self.csv_path.open("a", newline="") as fh:
                writer = csv.writer(fh)
                if new:
                    writer.writerow(self._columns)
                writer.writerows(chunk.tolist())

    def data(self) -> dict[str, np.ndarray]:
        """Everything recorded so far, as columns."""
        return self.rows_from(0)

    def rows_from(self, start: int) -> dict[str, np.ndarray]:
        """The rows recorded from row ``start`` (0-based) on, as columns: what a live consumer (a
        video's strip) reads each time, at a cost of those rows alone (plus at most one pending
        chunk), so that reading a run as it grows costs in proportion to its length."""
        if self._columns is None:
            return {}
        start = max(int(start), 0)
        parts = [np.asarray(self._chunk[max(start - self._flushed_rows, 0) :], dtype=float).reshape(-1, len(self._columns))]
        end = self._flushed_rows
        for chunk in reversed(self._flushed):
            if end <= start:
                break
            parts.append(chunk[max(start - (end - len(chunk)), 0) :])
            end -= len(chunk)
        table = np.concatenate(parts[::-1])
        return {c: table[:, i] for i, c in enumerate(self._columns)}

    def close(self) -> list[Path]:
        """Write everything: the chunks gathered into the NPZ (once), then removed.  Safe to call
        twice; returns the files written."""
        if not self._closed:
            self.flush()
            if self._columns is not None:
                tmp = self.npz_path.with_suffix(".tmp.npz")
                np.savez(tmp, metadata_json=np.array(json.dumps(self.metadata)), **self.data())
                os.replace(tmp, self.npz_path)
                shutil.rmtree(self.chunk_dir, ignore_errors=True)
            self._closed = True
        return [p for p in (self.npz_path, self.csv_path) if p is not None and p.exists()]

    def __enter__(self) -> Recorder:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def _write_atomic(path: Path, payload: bytes) -> None:
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_bytes(payload)
    os.replace(tmp, path)


def read_recording(path: str | Path) -> tuple[dict[str, np.ndarray], dict]:
    """A recording's columns and metadata, from ``<stem>.npz`` or, for a run that was killed
    before it closed its recorder, from the completed chunks in ``<stem>.chunks/``.

    ``path`` is the stem or either file's path.  Raises FileNotFoundError naming the path when
    neither exists.
    """
    stem = Path(path)
    if stem.suffix in (".npz", ".chunks"):
        stem = stem.with_suffix("")
    npz, chunks = stem.with_suffix(".npz"), stem.with_suffix(".chunks")
    if npz.exists():
        with np.load(npz) as f:
            meta = json.loads(str(f["metadata_json"])) if "metadata_json" in f.files else {}
            return {k: f[k] for k in f.files if k != "metadata_json"}, meta
    if (chunks / _META).exists():
        info = json.loads((chunks / _META).read_text())
        parts = [np.load(p) for p in sorted(chunks.glob("chunk_[0-9]*.npy"))]
        columns = info["columns"]
        table = np.concatenate(parts) if parts else np.empty((0, len(columns)))
        return {c: table[:, i] for i, c in enumerate(columns)}, info["metadata"]
    raise FileNotFoundError(f"no recording at {str(stem)!r} (neither {npz.name} nor {chunks.name}/)")
