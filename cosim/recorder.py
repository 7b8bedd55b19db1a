"""Recording every control step, with units, at a cost linear in the run's length, crash-safe.

Columns are named with their unit (``time_s``, ``left_pressure_pa``, ...).  Rows are held in
memory until ``flush_every`` of them are pending; then the chunk is written to disk as one more
append-only file, ``<stem>.chunks/chunk_NNNNNN.npy`` (written beside as
``chunk_NNNNNN.tmp.npy``, then renamed, so a chunk that exists is whole), appended to the CSV
when asked for, and dropped from memory.  A flush writes only its own rows, so a run's
recording costs the same per simulated second however long it runs, in time and in memory.

:meth:`Recorder.close` gathers the chunks into ``<stem>.npz`` as a stream, column by column
(:func:`_write_npz`: the same file ``np.savez`` writes from the whole table, holding one column
in memory instead of all of them), then removes the chunks.  A chunk is stored column-major so
that a column of it is one contiguous read.  After the close, :meth:`Recorder.data` reads the
columns from the NPZ one at a time as they are asked for (:class:`Columns`).

A run killed outright (SIGKILL, a power cut) or stopped by a full disk leaves its completed
chunks: :func:`read_recording` reads a recording from the NPZ, or from the chunks when the run
never closed it (a torn temporary chunk is not one of them; a chunk a machine's crash tore
under its final name ends what is read, with a warning naming it).  Use the recorder as a
context manager and :meth:`close` is called on any exit that Python sees, including an
exception or KeyboardInterrupt.  A write the file system refuses for want of room raises an
OSError (ENOSPC) saying the disk is full, naming the file and the bytes it took
(:func:`_naming_a_full_disk`).

A new recording replaces an old one of the same stem, removing only the files a recording
writes, by name (``<stem>.npz``, its temporary ``<stem>.tmp.npz``, ``<stem>.csv``, and in
``<stem>.chunks/`` the chunks, their temporaries and ``meta.json``).  A ``<stem>.chunks/`` that
holds anything else (a file a person put there, a folder) is not a recording's: the new
recording refuses to start, with a FileExistsError naming what is there, before it removes
anything (:func:`check_replaceable`).  Refusing, rather than keeping the file and going on,
means a folder never mixes a recording with files nobody can account for.
"""

from __future__ import annotations

import contextlib
import csv
import errno
import io
import json
import logging
import os
import re
import shutil
import zipfile
from collections.abc import Iterator, Mapping
from pathlib import Path

import numpy as np

from .rows import stack_rows

_META = "meta.json"

#: A completed chunk's file name (its index in the group).
_CHUNK_FILE = re.compile(r"chunk_(\d{6})\.npy")

#: Every name a recording writes in its ``.chunks`` folder (completed and temporary chunks, the
#: columns' description and its temporary): what a new recording may remove, and all it may find.
_OWN_CHUNK_FILES = re.compile(r"chunk_\d{6}(\.tmp)?\.npy|meta\.json(\.tmp)?")

log = logging.getLogger(__name__)


def recording_paths(path_stem: str | Path) -> tuple[Path, Path, Path, Path]:
    """The files of the recording at ``path_stem``: (NPZ, its temporary, CSV, chunks folder)."""
    stem = Path(path_stem)
    return stem.with_suffix(".npz"), stem.with_suffix(".tmp.npz"), stem.with_suffix(".csv"), stem.with_suffix(".chunks")


def check_replaceable(path_stem: str | Path) -> None:
    """Raise FileExistsError, naming them, when ``<stem>.chunks`` holds anything a recording does
    not write (a new recording would otherwise have to delete it or mix with it); else nothing."""
    chunks = recording_paths(path_stem)[3]
    if not chunks.exists() and not chunks.is_symlink():
        return
    if chunks.is_symlink() or not chunks.is_dir():
        raise FileExistsError(f"{str(chunks)!r} is not a recording's chunks folder; move it away to record at {str(path_stem)!r}")
    foreign = sorted(p.name for p in chunks.iterdir() if not (_OWN_CHUNK_FILES.fullmatch(p.name) and p.is_file() and not p.is_symlink()))
    if foreign:
        shown = ", ".join(foreign[:5]) + (f" and {len(foreign) - 5} more" if len(foreign) > 5 else "")
        raise FileExistsError(
            f"{str(chunks)!r} holds what no recording wrote ({shown}); a new recording removes only its own files: move them away"
        )


def _remove_recording(path_stem: str | Path) -> None:
    """Remove the recording at ``path_stem``, file by known name (after :func:`check_replaceable`)."""
    *files, chunks = recording_paths(path_stem)
    for path in files:
        path.unlink(missing_ok=True)
    if chunks.is_dir():
        _remove_chunks(chunks)


def _remove_chunks(chunks: Path) -> None:
    """A chunks folder's own files, then the folder if that emptied it (anything else stays)."""
    for path in chunks.iterdir():
        if _OWN_CHUNK_FILES.fullmatch(path.name) and path.is_file():
            path.unlink(missing_ok=True)
    try:
        chunks.rmdir()
    except OSError:  # something appeared in it that is not ours: it stays, and so does the folder
        log.warning("%s: left in place, it holds files no recording wrote", chunks)


class Recorder:
    """Append-only table of named float columns, written to ``<stem>.npz`` (and ``.csv``).

    Parameters
    ----------
    path_stem : output path without suffix, e.g. ``out/grasp/run``.
    csv : also write a CSV, appended incrementally.
    flush_every : rows per chunk written to disk.
    metadata : JSON-serializable facts stored in the NPZ as ``metadata_json`` (units, config).

    Raises FileExistsError when ``<stem>.chunks/`` holds files no recording wrote
    (:func:`check_replaceable`); an old recording of the same stem is removed (its own files).
    """

    def __init__(self, path_stem: str | Path, csv: bool = False, flush_every: int = 500, metadata: dict | None = None) -> None:
        self.stem = Path(path_stem)
        self.stem.parent.mkdir(parents=True, exist_ok=True)
        self.npz_path, _, csv_path, self.chunk_dir = recording_paths(self.stem)
        self.csv_path = csv_path if csv else None
        self.flush_every = int(flush_every)
        self.metadata = dict(metadata or {})
        self._columns: list[str] | None = None
        self._column_set: frozenset[str] = frozenset()
        self._column_source = None  # the sequence append_values was first given, to recognise it
        self._chunk: list[list[float]] = []
        self._chunk_rows: list[int] = []  # rows of each chunk on disk
        self._last_chunk: np.ndarray | None = None  # the latest chunk on disk, kept for live readers
        self._flushed_rows = 0  # rows on disk
        self._csv_due: list[np.ndarray] = []  # chunks on disk not yet appended to the CSV
        self._closing = False
        self._closed = False
        # A new recording replaces an old one of the same name (never mixes with it), file by file.
        check_replaceable(self.stem)
        _remove_recording(self.stem)

    @property
    def columns(self) -> list[str]:
        return list(self._columns or [])

    @property
    def closing(self) -> bool:
        """Whether :meth:`close` has begun (the chunks are being gathered, or have been)."""
        return self._closing

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

    def _chunk_path(self, index: int) -> Path:
        return self.chunk_dir / f"chunk_{index:06d}.npy"

    def flush(self) -> None:
        """Write the pending rows as one more chunk file (and append them to the CSV).

        The rows stay pending until their chunk is on disk: a flush that fails (a full disk, an
        interrupt) leaves no chunk and no temporary, and the next flush writes them again.  A
        signal's exception can come between any two of Python's steps here (its handler runs
        at the next call); whichever it lands between, the rows are counted once: pending, or
        in a chunk on disk and no longer pending (before: a Ctrl-C as the chunk's bookkeeping
        ran lost its rows, the chunk on disk but not counted)."""
        if not self._chunk or self._columns is None:
            return
        chunk = stack_rows(self._chunk, len(self._columns))  # numpy's conversion, compiled where built
        index = len(self._chunk_rows)
        if index == 0:
            self.chunk_dir.mkdir(parents=True, exist_ok=True)
            _write_atomic(self.chunk_dir / _META, json.dumps({"columns": self._columns, "metadata": self.metadata}).encode())
        path = self._chunk_path(index)
        tmp = path.with_name(f"chunk_{index:06d}.tmp.npy")
        column_major = np.asfortranarray(chunk)  # a column is one contiguous read (close)
        # the state once the chunk is on disk, made before it is: the commit below only assigns
        # (no call, so no handler runs inside it), the chunk's count last; the handler, seeing
        # the chunk renamed but not counted, makes the same assignments (each is idempotent)
        rows, flushed = [*self._chunk_rows, len(chunk)], self._flushed_rows + len(chunk)
        csv_due = self._csv_due if self.csv_path is None else [*self._csv_due, chunk]
        try:
            with _naming_a_full_disk(tmp, f"chunk {index:06d}", _npy_bytes(column_major), fwrite=True):
                np.save(tmp, column_major)
            os.replace(tmp, path)
            self._chunk, self._flushed_rows, self._last_chunk, self._csv_due, self._chunk_rows = [], flushed, chunk, csv_due, rows
        except BaseException:
            if len(self._chunk_rows) == index and path.exists():  # renamed: on disk, so counted there
                self._chunk, self._flushed_rows, self._last_chunk, self._csv_due, self._chunk_rows = [], flushed, chunk, csv_due, rows
            tmp.unlink(missing_ok=True)
            raise
        self._append_csv()

    def _append_csv(self) -> None:
        """Append the chunks on disk that the CSV does not have yet (all or none of a chunk's
        rows: a write cut short is cut back, and written again at the next flush or close)."""
        if self.csv_path is None or not self._csv_due:
            return
        due = self._csv_due
        start = _size(self.csv_path)
        text = io.StringIO(newline="")
        writer = csv.writer(text)
        if start == 0:
            writer.writerow(self._columns)
        for chunk in due:
            writer.writerows(chunk.tolist())
        payload = text.getvalue().encode()
        try:
            with _naming_a_full_disk(self.csv_path, "the CSV's rows", len(payload), appended=True), self.csv_path.open("ab") as fh:
                fh.write(payload)
            self._csv_due = self._csv_due[len(due) :]
        except BaseException:
            if self._csv_due and self._csv_due[0] is due[0]:  # not all of it known written: none of it
                os.truncate(self.csv_path, start)
            raise

    def data(self) -> Mapping[str, np.ndarray]:
        """Everything recorded so far, as columns: in memory while recording; once closed, the
        NPZ's columns each read when asked for (:class:`Columns`; ``dict(...)`` loads them all)."""
        if self._closed and self._columns is not None:
            return Columns(self.npz_path)
        return self.rows_from(0)

    def rows_from(self, start: int) -> dict[str, np.ndarray]:
        """The rows recorded from row ``start`` (0-based) on, as columns: what a live consumer (a
        video's strip) reads each time, at a cost of those rows alone (the chunks they are in,
        read back from disk but for the latest one, plus the pending rows), so that reading a run
        as it grows costs in proportion to its length."""
        if self._columns is None:
            return {}
        start = max(int(start), 0)
        if self._closed:
            columns = Columns(self.npz_path)
            return {c: columns[c][start:] for c in self._columns}
        parts = [np.asarray(self._chunk[max(start - self._flushed_rows, 0) :], dtype=float).reshape(-1, len(self._columns))]
        end = self._flushed_rows
        for index in range(len(self._chunk_rows) - 1, -1, -1):
            if end <= start:
                break
            rows = self._chunk_rows[index]
            chunk = self._last_chunk if index == len(self._chunk_rows) - 1 else np.load(self._chunk_path(index))
            parts.append(chunk[max(start - (end - rows), 0) :])
            end -= rows
        table = np.concatenate(parts[::-1])
        return {c: table[:, i] for i, c in enumerate(self._columns)}

    def close(self) -> list[Path]:
        """Write everything: the chunks gathered into the NPZ (once, column by column), then
        removed.  Safe to call twice, and again after a close that raised (a full disk, an
        interrupt: the chunks stay until the NPZ is whole); returns the files written."""
        self._closing = True
        if not self._closed:
            self.flush()
            self._append_csv()  # what an interrupted flush left unwritten (a flush with no rows pending writes none)
            if self._columns is not None:
                _write_npz(self.npz_path, self.metadata, self._columns, [self._chunk_path(i) for i in range(len(self._chunk_rows))])
                _remove_chunks(self.chunk_dir)
            self._closed = True
            self._last_chunk = None
        return [p for p in (self.npz_path, self.csv_path) if p is not None and p.exists()]

    def __enter__(self) -> Recorder:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


class Columns(Mapping):
    """A closed recording's columns (``<stem>.npz``), each read from the file when asked for and
    not kept: a consumer holds in memory the columns it holds, never the whole recording unless
    it asks for all of it (``dict(columns)``).

    The file is opened here and stays open while this object lives, so the columns can still be
    read once the file is removed (a run in a temporary folder; POSIX).  Pickled (sent to another
    process) or copied, it becomes a plain dict of its columns.
    """

    def __init__(self, npz_path: str | Path) -> None:
        self.path = Path(npz_path)
        self._npz = np.load(self.path)
        self._names = [name for name in self._npz.files if name != "metadata_json"]
        self._known = frozenset(self._names)

    def __getitem__(self, name: str) -> np.ndarray:
        if name not in self._known:
            raise KeyError(name)
        return self._npz[name]

    def __iter__(self) -> Iterator[str]:
        return iter(self._names)

    def __len__(self) -> int:
        return len(self._names)

    def __contains__(self, name: object) -> bool:
        return name in self._known

    def __repr__(self) -> str:
        return f"Columns({str(self.path)!r}, {len(self._names)} columns)"

    def __reduce__(self):
        return dict, (dict(self),)

    def close(self) -> None:
        self._npz.close()


class _ChunkFile:
    """Where a chunk's columns are in its ``.npy`` file (read from its header once)."""

    def __init__(self, path: Path) -> None:
        self.path = path
        with path.open("rb") as fh:
            version = np.lib.format.read_magic(fh)
            read_header = np.lib.format.read_array_header_1_0 if version == (1, 0) else np.lib.format.read_array_header_2_0
            (self.rows, self.width), self.fortran, self.dtype = read_header(fh)
            self.offset = fh.tell()

    def column(self, index: int) -> bytes:
        """Column ``index``'s values as the bytes an array of them holds (C order)."""
        if not self.fortran:  # row-major (not written by this recorder): the whole chunk, then its column
            return np.ascontiguousarray(np.load(self.path)[:, index]).tobytes()
        size = self.rows * self.dtype.itemsize
        with self.path.open("rb") as fh:
            data = os.pread(fh.fileno(), size, self.offset + index * size)
        if len(data) != size:
            raise OSError(f"{self.path}: chunk shorter than its header says")
        return data


#: What a write that the file system refuses for want of room raises with (a full disk, a quota).
_FULL_ERRNOS = frozenset({errno.ENOSPC, errno.EDQUOT})


def _npy_bytes(array: np.ndarray) -> int:
    """The size of ``array``'s ``.npy`` file as :func:`np.save` writes it, bytes (header and data)."""
    header = io.BytesIO()
    np.lib.format.write_array_header_1_0(header, np.lib.format.header_data_from_array_1_0(array))
    return len(header.getvalue()) + array.nbytes


@contextlib.contextmanager
def _naming_a_full_disk(path: Path, what: str, expected_bytes: int, appended: bool = False, fwrite: bool = False):
    """Turn a write to ``path`` that the file system refused for want of room into an OSError
    (ENOSPC) that says so, naming the file, ``what`` was written and the bytes.

    Why: numpy writes an array to a file with C's ``fwrite``, whose short write on a full disk
    surfaces as ``OSError("19500 requested and 17904 written")`` (values, not bytes; no errno,
    no file), and Python's own writes as ``[Errno 28] No space left on device`` without the
    file.  A write counts as refused for room when it raised ENOSPC or EDQUOT, or, with
    ``fwrite`` (numpy's), no errno at all and fewer bytes on disk than ``expected_bytes`` (its
    short write); any other error passes unchanged.  ``appended``: the file is appended to, its
    bytes before this write are not counted."""
    before = _size(path) if appended else 0
    try:
        yield
    except OSError as err:
        written = max(_size(path) - before, 0)
        if err.errno not in _FULL_ERRNOS and not (fwrite and err.errno is None and written < expected_bytes):
            raise
        try:
            free = f"{shutil.disk_usage(path.parent).free} bytes free there"
        except OSError:
            free = "its free space unknown"
        raise OSError(
            errno.ENOSPC,
            f"{path}: disk full ({os.strerror(errno.ENOSPC)}): the file system took {written} of the {expected_bytes} bytes of "
            f"{what} ({free}; a quota or a file size limit stops writes too): {err}",
        ) from err


def _size(path: Path) -> int:
    """``path``'s size in bytes, 0 when it is not there."""
    try:
        return path.stat().st_size
    except OSError:
        return 0


def _write_npz(path: Path, metadata: dict, columns: list[str], chunk_paths: list[Path]) -> None:
    """``<stem>.npz`` from the chunks, one column in memory at a time: the file ``np.savez(path,
    metadata_json=np.array(json.dumps(metadata)), **columns)`` writes (the same members in the
    same order, each the same bytes: uncompressed, ZIP64 headers, NPY format 1.0), each column
    concatenated from the chunks as it goes into its member.  Written beside as
    ``<stem>.tmp.npz`` (removed if this fails), then renamed."""
    chunks = [_ChunkFile(p) for p in chunk_paths]
    if any(c.width != len(columns) for c in chunks):
        raise ValueError(f"{path}: a chunk's width differs from the {len(columns)} columns")
    dtype = chunks[0].dtype if chunks else np.dtype(float)
    rows = sum(c.rows for c in chunks)
    header = {"descr": np.lib.format.dtype_to_descr(dtype), "fortran_order": False, "shape": (rows,)}
    tmp = path.with_suffix(".tmp.npz")
    data_bytes = len(columns) * rows * dtype.itemsize  # the columns' values, headers and the ZIP's own records aside
    try:
        with _naming_a_full_disk(tmp, f"the recording's {len(columns)} columns", data_bytes):
            with zipfile.ZipFile(tmp, mode="w", compression=zipfile.ZIP_STORED, allowZip64=True) as zf:
                with zf.open("metadata_json.npy", "w", force_zip64=True) as fid:
                    np.lib.format.write_array(fid, np.array(json.dumps(metadata)))
                for index, name in enumerate(columns):
                    with zf.open(f"{name}.npy", "w", force_zip64=True) as fid:
                        np.lib.format.write_array_header_1_0(fid, header)
                        for chunk in chunks:
                            fid.write(chunk.column(index))
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise


def _write_atomic(path: Path, payload: bytes) -> None:
    tmp = path.with_name(path.name + ".tmp")
    with _naming_a_full_disk(tmp, path.name, len(payload)):
        tmp.write_bytes(payload)
    os.replace(tmp, path)


def _read_chunk(path: Path, width: int) -> np.ndarray:
    """A completed chunk's rows, or ValueError saying how it is torn: unreadable, shorter than
    its header says, or not a table of ``width`` float columns.

    A chunk is renamed to its final name once written, but a machine that crashes before the
    file system has stored its bytes can leave the name with the bytes short or zero (the rename
    was kept, the data not): such a chunk is torn under its final name."""
    try:
        chunk = np.load(path, allow_pickle=False)
    except FileNotFoundError:
        raise
    except Exception as err:  # numpy raises ValueError, EOFError, OSError ... for a short or garbled file
        raise ValueError(f"{type(err).__name__}: {' '.join(str(err).split())[:200]}") from None
    if chunk.ndim != 2 or chunk.shape[1] != width or chunk.dtype.kind != "f":
        raise ValueError(f"a {chunk.dtype} array of shape {chunk.shape}, not rows of {width} float columns")
    return chunk


def read_recording(path: str | Path) -> tuple[dict[str, np.ndarray], dict]:
    """A recording's columns and metadata, from ``<stem>.npz`` or, for a run that was killed
    before it closed its recorder, from the completed chunks in ``<stem>.chunks/``
    (``chunk_000000.npy``, ``chunk_000001.npy``, ... in order, up to the first one missing or
    torn under its final name by a machine's crash, with a warning naming it on this module's
    logger; a torn temporary, ``chunk_NNNNNN.tmp.npy``, or any other file there is not read).

    ``path`` is the stem or either file's path.  Raises FileNotFoundError naming the path when
    neither exists.
    """
    stem = Path(path)
    if stem.suffix in (".npz", ".chunks"):
        stem = stem.with_suffix("")
    npz, _, _, chunks = recording_paths(stem)
    if npz.exists():
        with np.load(npz) as f:
            meta = json.loads(str(f["metadata_json"])) if "metadata_json" in f.files else {}
            return {k: f[k] for k in f.files if k != "metadata_json"}, meta
    if (chunks / _META).exists():
        info = json.loads((chunks / _META).read_text())
        columns = info["columns"]
        found = sorted(int(m.group(1)) for p in chunks.iterdir() if (m := _CHUNK_FILE.fullmatch(p.name)))
        parts = []
        for expected, index in enumerate(found):
            if index != expected:
                log.warning("%s: chunk %06d is missing; read the %d chunks before it", chunks, expected, expected)
                break
            try:
                parts.append(_read_chunk(chunks / f"chunk_{index:06d}.npy", len(columns)))
            except FileNotFoundError:  # removed since the folder was listed
                log.warning("%s: chunk %06d is missing; read the %d chunks before it", chunks, index, index)
                break
            except ValueError as torn:
                log.warning("%s: chunk %06d is torn (%s); read the %d chunks before it", chunks, index, torn, index)
                break
        table = np.concatenate(parts) if parts else np.empty((0, len(columns)))
        return {c: table[:, i] for i, c in enumerate(columns)}, info["metadata"]
    raise FileNotFoundError(f"no recording at {str(stem)!r} (neither {npz.name} nor {chunks.name}/)")
